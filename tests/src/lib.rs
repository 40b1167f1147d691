//! # vistaf-tests
//!
//! End-to-end tests across the crates (`tests/*.rs`), the recorded-frame fixtures they
//! replay (`fixtures/`, regenerated with `vistaf-skin simulate --fixtures tests/fixtures`),
//! and benchmarks (`benches/`).
//!
//! The helpers here read a fixture's ground truth so tests can score the pipeline.

pub mod accuracy;
pub mod charts;
pub mod pty;

use std::path::{Path, PathBuf};

use vistaf_hardware::frameset::FrameSet;

/// The fixture directory.
pub fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures")
}

/// Opens a fixture set by name.
pub fn fixture(name: &str) -> FrameSet {
    FrameSet::open(&fixtures().join(name)).unwrap_or_else(|e| panic!("fixture {name}: {e}"))
}

/// The 16-bit truth depth map of frame `i` of a simulated set, mm.
pub fn truth_depth_mm(set: &FrameSet, i: usize) -> Option<Vec<f32>> {
    let name = set.manifest.frames[i]
        .extra
        .get("truth_depth_png")?
        .as_str()?;
    let img = image::open(set.path_of(name)).ok()?.into_luma16();
    Some(img.pixels().map(|p| f32::from(p.0[0]) / 1000.0).collect())
}
