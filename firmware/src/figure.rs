//! A measured frame as the figure a person reads (`vistaf-figure`): the camera image at the
//! working resolution, the depth map, the temperature map, and the frame's numbers. Used by
//! `analyze --out`, which draws every frame with the colour ranges of the whole run.

use vistaf_figure::{Frame, Grid, Picture, Readout};
use vistaf_pipeline::input::Pixels;
use vistaf_pipeline::Measurement;

/// The figure's frame of a measurement of `img`, named `label`.
pub fn frame(d: &Measurement, img: Pixels<'_>, mm_per_px: f32, label: &str) -> Frame {
    let pitch_mm = f64::from(mm_per_px) * d.factor as f64;
    let depth = d
        .depth_um
        .iter()
        .zip(&d.reliable)
        .map(|(&um, &ok)| if ok { um as f32 / 1000.0 } else { f32::NAN })
        .collect();
    let t = d.temperature.as_ref();
    Frame {
        camera: Some(Picture {
            width: d.width_px,
            height: d.height_px,
            pitch_mm,
            rgb: img.box_rgb(d.factor, d.width_px, d.height_px),
        }),
        depth_mm: Some(Grid {
            width: d.width_px,
            height: d.height_px,
            pitch_mm,
            values: depth,
        }),
        temperature_c: t.map(|t| Grid {
            width: t.bw,
            height: t.bh,
            pitch_mm: f64::from(t.block_mm),
            values: t.map_c.clone(),
        }),
        readout: Readout {
            label: label.to_string(),
            force_n: Some(f64::from(d.force_n)),
            depth_mm: Some(f64::from(d.peak_depth_mm)),
            contact_temp_c: t.and_then(|t| t.contact_c).map(f64::from),
            flags: d.flags.iter().map(|f| f.name().to_string()).collect(),
        },
    }
}
