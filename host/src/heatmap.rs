//! A map as a few lines of a terminal: the live heat map under a skin's line in
//! `vistaf-host monitor --map`.
//!
//! Each character is two cells tall: an upper half block whose foreground is the upper
//! cell's colour and whose background the lower one's (24-bit colour, which every current
//! terminal emulator draws), so a 32 × 24 coarse map fits 32 columns and 12 lines. The
//! colours are the figures' (`vistaf_figure::colour`) on a bar fixed for the session, so a
//! colour means the same depth or temperature in every redraw; a legend line gives the bar's
//! ends and unit. Plain escape sequences suffice for a grid of coloured blocks; a TUI
//! framework would take the terminal over (raw mode, its own screen) for no gain here.

use vistaf_figure::colour::{INFERNO, VIRIDIS};
use vistaf_protocol::MapKind;

use crate::maps::{kind_si, WholeMap};

/// The upper half block.
const UPPER_HALF: char = '▀';

/// `map` as lines at most `max_cols` characters wide (cells are averaged into a column
/// when the map is wider), coloured on the bar `range` (its SI unit: mm or °C), with a
/// legend line last. Nothing for the camera image.
pub fn render(map: &WholeMap, range: (f64, f64), max_cols: usize) -> Vec<String> {
    let Some(values) = map.si() else {
        return Vec::new();
    };
    if map.width == 0 || map.height == 0 || max_cols == 0 {
        return Vec::new();
    }
    let colours = match map.kind {
        MapKind::Temperature => INFERNO,
        _ => VIRIDIS,
    };
    let cols = map.width.min(max_cols);
    // The map's trusted cells that fall in a column, averaged (NaN if there are none).
    let cell = |row: usize, col: usize| -> f32 {
        let a = col * map.width / cols;
        let b = ((col + 1) * map.width / cols).clamp(a + 1, map.width);
        let (sum, n) = values[row * map.width + a..row * map.width + b]
            .iter()
            .filter(|v| !v.is_nan())
            .fold((0.0, 0u32), |(s, n), v| (s + v, n + 1));
        if n == 0 {
            f32::NAN
        } else {
            sum / n as f32
        }
    };
    let mut lines = Vec::with_capacity(map.height.div_ceil(2) + 1);
    for row in (0..map.height).step_by(2) {
        let mut line = String::new();
        for col in 0..cols {
            let [r, g, b] = colours.of(cell(row, col), range);
            let [r2, g2, b2] = if row + 1 < map.height {
                colours.of(cell(row + 1, col), range)
            } else {
                [0, 0, 0]
            };
            line.push_str(&format!(
                "\x1b[38;2;{r};{g};{b}m\x1b[48;2;{r2};{g2};{b2}m{UPPER_HALF}"
            ));
        }
        line.push_str("\x1b[0m");
        lines.push(line);
    }
    let (name, unit, _) = kind_si(map.kind);
    lines.push(format!(
        "{name} {} to {} {unit}, frame {}, {:.1} mm per column",
        range.0,
        range.1,
        map.seq,
        map.pitch_mm * map.width as f64 / cols as f64
    ));
    lines
}

#[cfg(test)]
mod tests {
    use super::*;

    fn depth_map(width: usize, height: usize, um: impl Fn(usize, usize) -> i16) -> WholeMap {
        WholeMap {
            seq: 7,
            kind: MapKind::Depth,
            width,
            height,
            pitch_mm: 0.5,
            cells: (0..width * height)
                .map(|i| um(i % width, i / width))
                .collect(),
        }
    }

    /// The colour escapes of a line, one (foreground, background) pair per character.
    fn pairs(line: &str) -> Vec<(String, String)> {
        line.split(UPPER_HALF)
            .filter(|p| p.contains("38;2"))
            .map(|p| {
                let fg = p
                    .split("\x1b[38;2;")
                    .nth(1)
                    .unwrap()
                    .split('m')
                    .next()
                    .unwrap();
                let bg = p
                    .split("\x1b[48;2;")
                    .nth(1)
                    .unwrap()
                    .split('m')
                    .next()
                    .unwrap();
                (fg.to_string(), bg.to_string())
            })
            .collect()
    }

    #[test]
    fn two_rows_make_one_line_and_a_deep_cell_is_yellow() {
        // 4 × 3 cells: the lower right one 1 mm deep, the rest untouched.
        let map = depth_map(4, 3, |x, y| if (x, y) == (3, 1) { 1000 } else { 0 });
        let lines = render(&map, (0.0, 1.0), 80);
        assert_eq!(lines.len(), 2 + 1, "3 rows in 2 lines, and the legend");
        let first = pairs(&lines[0]);
        assert_eq!(first.len(), 4);
        assert_eq!(
            first[0],
            ("68;1;84".into(), "68;1;84".into()),
            "none deep: dark"
        );
        assert_eq!(
            first[3].1, "253;231;37",
            "row 1 is the lower half of line 0"
        );
        assert!(lines[2].contains("depth 0 to 1 mm") && lines[2].contains("frame 7"));
    }

    #[test]
    fn a_wide_map_is_averaged_into_the_columns_there_are() {
        let map = depth_map(32, 2, |x, _| if x < 16 { 0 } else { 1000 });
        let lines = render(&map, (0.0, 1.0), 8);
        let cols = pairs(&lines[0]);
        assert_eq!(cols.len(), 8);
        assert_eq!(cols[0].0, "68;1;84");
        assert_eq!(cols[7].0, "253;231;37");
        assert!(lines[1].contains("2.0 mm per column"), "{}", lines[1]);
    }

    #[test]
    fn untrusted_cells_are_grey_and_the_camera_has_no_heat_map() {
        let map = depth_map(2, 2, |_, _| vistaf_protocol::msg::MAP_NO_DATA);
        assert_eq!(pairs(&render(&map, (0.0, 1.0), 80)[0])[0].0, "170;170;170");
        let camera = WholeMap {
            kind: MapKind::Camera,
            ..map
        };
        assert!(render(&camera, (0.0, 1.0), 80).is_empty());
    }
}
