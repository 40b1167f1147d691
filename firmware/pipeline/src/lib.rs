//! # vistaf-pipeline
//!
//! The per-frame pipeline of a vistaf skin, and nothing else: a reference frame and a
//! calibration in, an [`Analyzer`] (the plan for that reference) out; then each frame in, a
//! [`Measurement`] out (depth map, contact, area, volume, centre, force, temperatures,
//! flags), working in a [`Scratch`] the caller keeps from frame to frame. No I/O beyond
//! reading a calibration file, no clock, no threads.
//!
//! ```text
//!  fixed_point, image_ops          integer phase arithmetic, luminance and downsampling
//!        │
//!  ftp::{carrier, band}           the grating's carrier and the shared band-pass
//!        │
//!  ftp::{float, fixed} ──▶ phase::PhaseMap ──▶ measure ──▶ Measurement ◀── thermal
//!        ▲                                       ▲                           ▲
//!        └──────────────── plan::Analyzer ───────┴───────────────────────────┘
//!                               (calibration: the models each stage evaluates)
//! ```
//!
//! * [`plan`]: the [`Analyzer`], one per reference, and the [`plan::FtpPath`] seam between
//!   the float reference ([`ftp::float`], the oracle) and the device path ([`ftp::fixed`]).
//! * [`measure`]: registration, noise floor, contact, unwrapping, depth, features, flags,
//!   shared by both paths over a [`phase::PhaseMap`].
//! * [`thermal`]: temperature from the stripes' colour.
//! * [`calibration`]: the calibration file and the models it holds (fitting them is
//!   `vistaf-calibrate`'s job); [`evidence`]: the scores a fitted model carries.
//!
//! How fast and how accurate each path is, measured, is in `docs/pipeline.md` and
//! `docs/performance.md`.
#![deny(missing_docs)]

pub mod calibration;
pub mod evidence;
pub mod fixed_point;
pub mod ftp;
pub mod image_ops;
pub mod input;
pub mod mask;
pub mod measure;
pub mod measurement;
pub mod phase;
pub mod plan;
#[cfg(test)]
mod test_rng;
pub mod thermal;
pub mod unwrap;

pub use calibration::Calibration;
pub use measurement::Measurement;
pub use plan::{Analyzer, AnalyzerOptions, Implementation, PipelineError, Scratch};
