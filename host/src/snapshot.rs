//! A frame's figure from what the device sent: its full maps and its summary, drawn by
//! `vistaf-figure` (the paper's Figure 2 layout), and its surface as a PLY mesh.

use std::path::Path;

use vistaf_figure::{Frame, Grid, Picture, Readout};
use vistaf_protocol::MapKind;

use crate::maps::{Snapshot, WholeMap};
use crate::record::SummaryRecord;

/// The maps a figure shows, in the order they are asked for.
pub const FIGURE_MAPS: [MapKind; 3] = [MapKind::Camera, MapKind::Depth, MapKind::Temperature];

/// A depth or temperature map as a figure's grid (SI units).
pub fn grid(m: &WholeMap) -> Option<Grid> {
    Some(Grid {
        width: m.width,
        height: m.height,
        pitch_mm: m.pitch_mm,
        values: m.si()?,
    })
}

/// The camera image as a figure's picture.
pub fn picture(m: &WholeMap) -> Option<Picture> {
    Some(Picture {
        width: m.width,
        height: m.height,
        pitch_mm: m.pitch_mm,
        rgb: m.rgb()?,
    })
}

/// The title's numbers from a summary.
pub fn readout(s: &SummaryRecord) -> Readout {
    Readout {
        label: format!("frame {}", s.seq),
        force_n: Some(f64::from(s.force_n)),
        depth_mm: Some(f64::from(s.peak_depth_mm)),
        contact_temp_c: s.contact_temp_c.map(f64::from),
        flags: s.flags.iter().map(|f| (*f).to_string()).collect(),
    }
}

/// The figure's frame: whichever maps came, and the summary's numbers when it came.
pub fn frame(s: &Snapshot) -> Frame {
    let find = |k: MapKind| s.maps.iter().find(|m| m.kind == k);
    let seq = s.maps.first().map(|m| m.seq);
    Frame {
        camera: find(MapKind::Camera).and_then(picture),
        depth_mm: find(MapKind::Depth).and_then(grid),
        temperature_c: find(MapKind::Temperature).and_then(grid),
        readout: s.summary.as_ref().map_or_else(
            || Readout {
                label: seq.map_or_else(String::new, |q| format!("frame {q} (no summary: stopped)")),
                ..Readout::default()
            },
            |sum| readout(&SummaryRecord::from(sum)),
        ),
    }
}

/// Writes the surface of `frame`'s depth map as a PLY mesh; an error when it has none.
pub fn write_ply(frame: &Frame, path: &Path) -> anyhow::Result<()> {
    let depth = frame
        .depth_mm
        .as_ref()
        .ok_or_else(|| anyhow::anyhow!("no depth map to write to {}", path.display()))?;
    Ok(vistaf_figure::ply::write(depth, path)?)
}
