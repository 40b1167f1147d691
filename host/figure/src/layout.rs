//! One frame as one figure: the title, then camera | depth over 3-D | temperature.

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::colour::{INFERNO, VIRIDIS};
use crate::font::{self, FAMILY};
use crate::panel::{self, err, Drawn, Mark};
use crate::surface;
use crate::{FigureError, Frame, Ranges};

/// Size of a figure, pixels.
pub const SIZE_PX: (u32, u32) = (1500, 1060);

/// The files a figure was written to.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Written {
    /// The picture.
    pub png: PathBuf,
    /// Its SVG twin (same drawing; its text can be read back).
    pub svg: PathBuf,
}

/// The title: which frame, force, depth, contact temperature, and the flags (or "no
/// flags"), so a figure is never read without what the device said of it.
pub fn title(frame: &Frame) -> String {
    let r = &frame.readout;
    let mut parts = vec![r.label.clone()];
    parts.push(
        r.force_n
            .map_or("force –".into(), |f| format!("force {f:.2} N")),
    );
    parts.push(
        r.depth_mm
            .map_or("depth –".into(), |d| format!("depth {d:.3} mm")),
    );
    parts.push(
        r.contact_temp_c
            .map_or("no contact temperature".into(), |t| {
                format!("contact {t:.1} °C")
            }),
    );
    parts.push(if r.flags.is_empty() {
        "no flags".into()
    } else {
        format!("flags: {}", r.flags.join(", "))
    });
    parts.retain(|p| !p.is_empty());
    parts.join("  ·  ")
}

/// Draws the figure on any backend.
pub fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, frame: &Frame, r: &Ranges) -> Drawn {
    root.fill(&WHITE).map_err(err)?;
    let body = root.titled(&title(frame), (FAMILY, 22)).map_err(err)?;
    let panels = body.split_evenly((2, 2));
    panel::camera(&panels[0], "camera", frame.camera.as_ref())?;
    panel::heat(
        &panels[1],
        "depth",
        frame.depth_mm.as_ref(),
        VIRIDIS,
        r.depth_mm,
        ("depth", "mm"),
        &[],
    )?;
    surface::relief(
        &panels[2],
        "surface",
        frame.depth_mm.as_ref(),
        VIRIDIS,
        r.depth_mm,
    )?;
    let marks: Vec<Mark> = frame
        .temperature_c
        .as_ref()
        .and_then(|g| g.extremes())
        .map(|(lo, hi)| {
            vec![
                Mark {
                    cell: lo.cell,
                    text: format!("min {:.1} °C", lo.value),
                },
                Mark {
                    cell: hi.cell,
                    text: format!("max {:.1} °C", hi.value),
                },
            ]
        })
        .unwrap_or_default();
    panel::heat(
        &panels[3],
        "temperature",
        frame.temperature_c.as_ref(),
        INFERNO,
        r.temperature_c,
        ("temperature", "°C"),
        &marks,
    )
}

/// Writes the figure as `png` and as its SVG twin beside it (same name, `.svg`).
pub fn write(frame: &Frame, ranges: &Ranges, png: &Path) -> Result<Written, FigureError> {
    font::register();
    let svg = png.with_extension("svg");
    let failed = |path: &Path| {
        let path = path.display().to_string();
        move |detail: String| FigureError::Draw { path, detail }
    };
    {
        let root = BitMapBackend::new(png, SIZE_PX).into_drawing_area();
        draw(&root, frame, ranges).map_err(failed(png))?;
        root.present().map_err(|e| failed(png)(e.to_string()))?;
    }
    {
        let root = SVGBackend::new(&svg, SIZE_PX).into_drawing_area();
        draw(&root, frame, ranges).map_err(failed(&svg))?;
        root.present().map_err(|e| failed(&svg)(e.to_string()))?;
    }
    Ok(Written {
        png: png.to_path_buf(),
        svg,
    })
}
