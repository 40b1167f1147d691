//! Options shared by the commands that run the pipeline.

use std::path::PathBuf;

use anyhow::Result;
use vistaf_pipeline::calibration::Calibration;
use vistaf_pipeline::Implementation;

/// Which calibration and which pipeline.
#[derive(clap::Args, Debug)]
pub struct PipelineArgs {
    /// Calibration file (default: the simulated reference unit's).
    #[arg(long)]
    pub calibration: Option<PathBuf>,
    /// Use a calibration made for another grating period or image size.
    #[arg(long)]
    pub force_calibration: bool,
    /// float (rustfft reference) or fixed (device path).
    #[arg(long, default_value = "fixed")]
    pub pipeline: Implementation,
}

impl PipelineArgs {
    /// Loads the calibration (or the default).
    pub fn calibration(&self) -> Result<Calibration> {
        Ok(match &self.calibration {
            Some(p) => Calibration::load(p)?,
            None => Calibration::default_sim(),
        })
    }
}

/// A rate for `--fps`: finite and above zero (as the configuration file requires).
pub fn positive_rate(s: &str) -> Result<f32, String> {
    let v: f32 = s.parse().map_err(|_| format!("{s:?} is not a number"))?;
    if v.is_finite() && v > 0.0 && v <= 10_000.0 {
        Ok(v)
    } else {
        Err(format!(
            "{v}: a rate above 0 and at most 10 000 frames per second"
        ))
    }
}
