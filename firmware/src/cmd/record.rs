//! `vistaf-skin record`: write frames from any source into a frame set.

use std::path::PathBuf;

use anyhow::Result;
use vistaf_hardware::source::record;

use vistaf_firmware::source_spec::{open, OpenOptions, SourceSpec};

/// What to record.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Source: camera:/dev/videoN, camera-serial:SERIAL, camera-name:NAME, set:DIR, sim:SCENE.
    #[arg(long)]
    pub source: SourceSpec,
    /// Output directory.
    #[arg(long)]
    pub out: PathBuf,
    /// Frames after the reference.
    #[arg(long, default_value_t = 10)]
    pub frames: usize,
    /// Simulated unit (sim: sources).
    #[arg(long, default_value_t = 0)]
    pub unit_seed: u64,
}

/// Runs the command. The first frame is the reference: start with nothing on the skin.
pub fn run(a: &Args) -> Result<()> {
    let opts = OpenOptions {
        sim_frames: a.frames + 1,
        unit_seed: a.unit_seed,
        ..OpenOptions::default()
    };
    let mut src = open(&a.source, &opts)?;
    let set = record(src.as_mut(), &a.out, a.frames, 2.0)?;
    println!(
        "{}: reference + {} frames from {}",
        set.dir().display(),
        set.len(),
        src.name()
    );
    Ok(())
}
