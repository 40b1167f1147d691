//! A frame's maps for the link: each built once at the working resolution ([`Plane`]),
//! then sent whole as [`MapChunk`]s or reduced to one coarse [`Map`] tile.
//!
//! The coarse tile fits one message (block maxima of depth, block means of temperature);
//! a picture a person reads (the depth field's shape, the camera's stripes) needs every
//! working pixel, so a full map goes out as a run of pieces of [`MAP_MAX_CELLS`] cells that
//! the host puts together.

use vistaf_pipeline::input::Pixels;
use vistaf_pipeline::Measurement;
use vistaf_protocol::msg::{MAP_MAX_CELLS, MAP_NO_DATA};
use vistaf_protocol::units::{centi_c, to_u32};
use vistaf_protocol::{Map, MapChunk, MapKind};

/// How much of a map was asked for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Size {
    /// One tile of at most [`MAP_MAX_CELLS`] cells ([`Plane::tile`]).
    Coarse,
    /// Every cell, in pieces ([`chunks`]).
    Full,
}

/// The `kind` map of a measured frame (`img` for the camera); `None` for temperature
/// without a temperature model.
pub fn plane(kind: MapKind, d: &Measurement, img: Pixels<'_>, mm_per_px: f32) -> Option<Plane> {
    match kind {
        MapKind::Depth => Some(depth_plane(d, mm_per_px)),
        MapKind::Temperature => temperature_plane(d),
        MapKind::Camera => Some(camera_plane(img, d, mm_per_px)),
    }
}

/// A whole map before it is cut: row-major cells in the wire's units.
#[derive(Debug, Clone, PartialEq)]
pub struct Plane {
    /// What the cells hold.
    pub kind: MapKind,
    /// Cells per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Side of one cell on the skin, mm.
    pub pitch_mm: f32,
    /// The cells (units of [`MapKind`]).
    pub cells: Vec<i16>,
}

/// The depth map, one cell per working pixel, µm; untrusted pixels [`MAP_NO_DATA`].
pub fn depth_plane(d: &Measurement, mm_per_px: f32) -> Plane {
    let cells = d
        .depth_um
        .iter()
        .zip(&d.reliable)
        .map(|(&um, &ok)| {
            if ok {
                um.clamp(0, i32::from(i16::MAX)) as i16
            } else {
                MAP_NO_DATA
            }
        })
        .collect();
    Plane {
        kind: MapKind::Depth,
        width: d.width_px,
        height: d.height_px,
        pitch_mm: mm_per_px * d.factor as f32,
        cells,
    }
}

/// The temperature map, one cell per measured block (the resolution the colour is read
/// at), 0.01 °C; `None` without a temperature model.
pub fn temperature_plane(d: &Measurement) -> Option<Plane> {
    let t = d.temperature.as_ref()?;
    let cells = t
        .map_c
        .iter()
        .map(|&c| {
            if c.is_finite() {
                centi_c(c)
            } else {
                MAP_NO_DATA
            }
        })
        .collect();
    Some(Plane {
        kind: MapKind::Temperature,
        width: t.bw,
        height: t.bh,
        pitch_mm: t.block_mm,
        cells,
    })
}

/// The camera image as the pipeline saw it: each working pixel the mean colour of the
/// `factor × factor` input pixels it stands for, RGB 5-6-5.
pub fn camera_plane(img: Pixels<'_>, d: &Measurement, mm_per_px: f32) -> Plane {
    let rgb = img.box_rgb(d.factor, d.width_px, d.height_px);
    let cells = rgb
        .as_chunks::<3>()
        .0
        .iter()
        .map(|&[r, g, b]| {
            let (r, g, b) = (u16::from(r), u16::from(g), u16::from(b));
            (((r >> 3) << 11) | ((g >> 2) << 5) | (b >> 3)) as i16
        })
        .collect();
    Plane {
        kind: MapKind::Camera,
        width: d.width_px,
        height: d.height_px,
        pitch_mm: mm_per_px * d.factor as f32,
        cells,
    }
}

impl Plane {
    /// The plane in one tile of at most [`MAP_MAX_CELLS`] cells: square blocks of trusted
    /// cells reduced to their maximum (depth: the deepest place survives) or their mean
    /// (temperature, camera), [`MAP_NO_DATA`] where a block has none.
    pub fn tile(&self, seq: u32) -> Map {
        let (w, h) = (self.width, self.height);
        // The smallest block whose tile fits one message (and 255 cells a side).
        let fits = |s: usize| {
            let (tw, th) = (w.div_ceil(s), h.div_ceil(s));
            tw <= 255 && th <= 255 && tw * th <= MAP_MAX_CELLS
        };
        let first = ((w * h) as f32 / MAP_MAX_CELLS as f32)
            .sqrt()
            .ceil()
            .max(1.0) as usize;
        let step = (first..).find(|&s| fits(s)).unwrap_or(first);
        let (tw, th) = (w.div_ceil(step), h.div_ceil(step));
        let mut cells = heapless::Vec::new();
        for ty in 0..th {
            for tx in 0..tw {
                let block = (ty * step..((ty + 1) * step).min(h))
                    .flat_map(|y| (tx * step..((tx + 1) * step).min(w)).map(move |x| y * w + x))
                    .map(|i| self.cells[i])
                    .filter(|&c| c != MAP_NO_DATA);
                let v = if self.kind == MapKind::Depth {
                    block.max()
                } else {
                    let (sum, n) = block.fold((0i64, 0i64), |(s, n), c| (s + i64::from(c), n + 1));
                    (n > 0).then(|| ((sum as f64) / n as f64).round() as i16)
                };
                // `step` makes the tile fit: the push cannot fail.
                let _ = cells.push(v.unwrap_or(MAP_NO_DATA));
            }
        }
        Map {
            seq,
            kind: self.kind,
            width: tw as u8,
            height: th as u8,
            cell_pitch_centi_mm: to_u32(self.pitch_mm * step as f32, 100.0).min(u32::from(u16::MAX))
                as u16,
            cells,
        }
    }
}

/// The plane as pieces for the link, in order, all carrying the frame's `seq`.
pub fn chunks(plane: &Plane, seq: u32) -> impl Iterator<Item = MapChunk> + '_ {
    let pitch_nm = (f64::from(plane.pitch_mm) * 1e6)
        .round()
        .clamp(0.0, f64::from(u32::MAX));
    plane
        .cells
        .chunks(MAP_MAX_CELLS)
        .enumerate()
        .map(move |(i, part)| MapChunk {
            seq,
            kind: plane.kind,
            width: u16::try_from(plane.width).unwrap_or(u16::MAX),
            height: u16::try_from(plane.height).unwrap_or(u16::MAX),
            cell_pitch_nm: pitch_nm as u32,
            first_cell: u32::try_from(i * MAP_MAX_CELLS).unwrap_or(u32::MAX),
            cells: part.iter().copied().collect(),
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tile_fits_one_message_at_any_size_and_keeps_the_deepest_place() {
        for (w, h) in [
            (320, 240),
            (400, 300),
            (41, 30),
            (97, 89),
            (1000, 3),
            (28, 28),
        ] {
            let mut cells = vec![MAP_NO_DATA; w * h];
            cells[(h / 2) * w + w / 3] = 1234;
            cells[(h / 2) * w + w / 3 + 1] = 5;
            let plane = Plane {
                kind: MapKind::Depth,
                width: w,
                height: h,
                pitch_mm: 0.1,
                cells,
            };
            let t = plane.tile(3);
            assert!(
                t.is_consistent() && t.cells.len() <= MAP_MAX_CELLS,
                "{w}×{h}"
            );
            assert_eq!(t.cells.iter().copied().max(), Some(1234), "{w}×{h}");
            assert_eq!(t.cells.iter().filter(|&&c| c != MAP_NO_DATA).count(), {
                let step = w.div_ceil(usize::from(t.width));
                1 + usize::from((w / 3) / step != (w / 3 + 1) / step)
            });
        }
        // Temperature: block means of the trusted cells.
        let mut cells = vec![2500; 40 * 40];
        cells[0] = 2600;
        cells[1] = MAP_NO_DATA;
        let temp = Plane {
            kind: MapKind::Temperature,
            width: 40,
            height: 40,
            pitch_mm: 2.0,
            cells,
        };
        let t = temp.tile(0);
        assert_eq!((t.width, t.height, t.cell_pitch_centi_mm), (20, 20, 400));
        assert_eq!((t.cells[0], t.cells[1]), (2533, 2500));
    }

    #[test]
    fn the_pieces_cover_the_map_once_in_order() {
        let plane = Plane {
            kind: MapKind::Depth,
            width: 41,
            height: 30,
            pitch_mm: 0.0625,
            cells: (0..41 * 30).map(|i| i as i16).collect(),
        };
        let parts: Vec<MapChunk> = chunks(&plane, 7).collect();
        assert_eq!(parts.len(), (41 * 30usize).div_ceil(MAP_MAX_CELLS));
        let mut joined = Vec::new();
        for p in &parts {
            assert!(p.is_consistent());
            assert_eq!(
                (p.seq, p.width, p.height, p.cell_pitch_nm),
                (7, 41, 30, 62_500)
            );
            assert_eq!(p.first_cell as usize, joined.len());
            joined.extend(p.cells.iter().copied());
        }
        assert_eq!(joined, plane.cells);
    }
}
