//! # vistaf-calibrate
//!
//! Fits a calibration from labelled frame sets (the procedure behind `vistaf-skin
//! calibrate`) and says how much to trust it: every candidate model is scored by grouped
//! cross-validation (leave one setpoint out), and the smallest model within one standard
//! error of the best is chosen.
//!
//! ```text
//!  frame sets (vistaf-hardware) ─▶ procedure ─▶ Analyzer (vistaf-pipeline) per set
//!        labels ──────────────────────┘            │ peak phase, features, colour sums
//!                                                  ▼
//!                     fit (phase → depth, deformation → force)
//!                     temperature (colour → temperature)  ─▶ Calibration
//! ```
//!
//! * [`procedure`]: which frames feed which fit, in which order, and what is left out.
//! * [`fit`]: the depth and force candidates, cross-validation and the parsimony rule.
//! * [`linear`]: the small linear systems the least-squares fits solve.
//! * [`temperature`]: the colour → temperature polynomials per stripe population.
//! * [`paper`]: the paper's Table II refitted from its own per-image data.
//! * [`verdict`]: each fitted model's held-out error against the product's target.
#![deny(missing_docs)]

pub mod fit;
pub mod linear;
pub mod paper;
pub mod procedure;
pub mod temperature;
pub mod verdict;

pub use procedure::{calibrate, CalibrateError, Notes, Observer, Quiet};
