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
