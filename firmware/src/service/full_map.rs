//! A frame's maps at the working resolution, cut into [`MapChunk`]s for the link.
//!
//! The coarse [`vistaf_protocol::Map`] fits one message; a picture a person reads (the
//! depth field's shape, the camera's stripes) needs every working pixel, so a full map goes
//! out as a run of pieces of [`MAP_MAX_CELLS`] cells that the host puts together.

use vistaf_pipeline::input::Pixels;
use vistaf_pipeline::Measurement;
use vistaf_protocol::msg::{MAP_MAX_CELLS, MAP_NO_DATA};
use vistaf_protocol::units::centi_c;
use vistaf_protocol::{MapChunk, MapKind};

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
