//! # vistaf-figure
//!
//! One frame of a vistaf skin as a person reads it, the layout of the paper's Figure 2:
//! the camera image, the depth map in mm with mm axes and a numbered colour bar, a shaded
//! 3-D view of the indented surface, and the temperature map with its coldest and hottest
//! places marked; force, depth, contact temperature and flags in the title. Each figure is
//! written as PNG and as an SVG twin whose text (axis and colour-bar labels) a program can
//! read back.
//!
//! The crate knows nothing of the wire or the pipeline: callers hand it plain grids in SI
//! units ([`Grid`], [`Picture`]), so the device's `analyze`, the host's `snapshot` and the
//! demo draw the same figure. Colour ranges are fixed by the caller ([`Ranges`]): frames of
//! one session share them, so colours compare across frames.
//!
//! * [`colour`]: the colour maps.
//! * [`range`]: colour ranges with round ends.
//! * [`panel`]: the 2-D panels (a heat map with its colour bar, the camera image).
//! * [`surface`]: the 3-D view.
//! * [`layout`]: the four panels and the title as one figure.
//! * [`ply`]: the surface as a PLY mesh for other tools.
//! * [`font`]: the bundled font every label is drawn with.

#![deny(missing_docs)]

pub mod colour;
pub mod font;
pub mod layout;
pub mod panel;
pub mod ply;
pub mod range;
pub mod surface;

pub use layout::{write, Written};
pub use range::Ranges;

/// A scalar field on the skin: row-major values in SI units (mm or °C), NaN where nothing
/// trusted was measured.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// Cells per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Side of one cell on the skin, mm.
    pub pitch_mm: f64,
    /// The values, `width × height`.
    pub values: Vec<f32>,
}

impl Grid {
    /// Whether `values` fills the grid and the pitch is a length.
    pub fn is_consistent(&self) -> bool {
        self.width > 0
            && self.height > 0
            && self.values.len() == self.width * self.height
            && self.pitch_mm.is_finite()
            && self.pitch_mm > 0.0
    }

    /// The finite values' smallest and largest, with their cells; `None` when no value
    /// is finite.
    pub fn extremes(&self) -> Option<(Extreme, Extreme)> {
        let w = self.width.max(1);
        let mut it = self
            .values
            .iter()
            .enumerate()
            .filter(|(_, v)| v.is_finite())
            .map(|(i, &value)| Extreme {
                value,
                cell: (i % w, i / w),
            });
        let first = it.next()?;
        Some(it.fold((first, first), |(lo, hi), c| {
            (
                if c.value < lo.value { c } else { lo },
                if c.value > hi.value { c } else { hi },
            )
        }))
    }
}

/// A value of a grid and where it is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Extreme {
    /// The value.
    pub value: f32,
    /// Its cell, `(x, y)`.
    pub cell: (usize, usize),
}

/// A colour image on the skin: row-major 8-bit RGB.
#[derive(Debug, Clone, PartialEq)]
pub struct Picture {
    /// Pixels per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Side of one pixel on the skin, mm.
    pub pitch_mm: f64,
    /// Three bytes per pixel.
    pub rgb: Vec<u8>,
}

impl Picture {
    /// Whether `rgb` fills the image and the pitch is a length.
    pub fn is_consistent(&self) -> bool {
        self.width > 0
            && self.height > 0
            && self.rgb.len() == self.width * self.height * 3
            && self.pitch_mm.is_finite()
            && self.pitch_mm > 0.0
    }
}

/// The numbers of the frame, for the title.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Readout {
    /// Which frame (its sequence number or name).
    pub label: String,
    /// Normal force, N.
    pub force_n: Option<f64>,
    /// Peak indentation depth, mm.
    pub depth_mm: Option<f64>,
    /// Mean temperature over the contact, °C.
    pub contact_temp_c: Option<f64>,
    /// The quality flags raised (empty: none).
    pub flags: Vec<String>,
}

/// Everything one figure shows; a panel without its data is drawn empty and says so.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Frame {
    /// The camera image.
    pub camera: Option<Picture>,
    /// Indentation depth, mm (positive into the skin).
    pub depth_mm: Option<Grid>,
    /// Skin temperature, °C.
    pub temperature_c: Option<Grid>,
    /// The title's numbers.
    pub readout: Readout,
}

/// Why a figure could not be written.
#[derive(Debug, thiserror::Error)]
pub enum FigureError {
    /// Plotting failed (the backend's message).
    #[error("drawing {path}: {detail}")]
    Draw {
        /// The file being drawn.
        path: String,
        /// What the backend said.
        detail: String,
    },
    /// A file could not be written.
    #[error("writing {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
    /// The data cannot be drawn (sizes that do not agree).
    #[error("{0}")]
    Data(String),
}
