//! `vistaf-demo`: the whole chain on a simulated skin, with no hardware and no system
//! packages. The device service films a scripted scene (idle, a heated sphere pressed,
//! slid and released, the letter E, a heated bar) and writes its summaries to a real
//! pseudo-terminal; the host library reads them there with a live readout, records the
//! session and asks for the maps at the strongest press.
//!
//! ```sh
//! cargo run --release -p vistaf-demo                      # 300 frames into vistaf-demo/
//! cargo run --release -p vistaf-demo -- --frames 120 --out /tmp/run
//! ```

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Parser;

mod device;
mod peak;
mod session;

/// The demo's options.
#[derive(Parser, Debug)]
#[command(
    name = "vistaf-demo",
    version,
    about = "A simulated vistaf skin and its host over a pseudo-terminal"
)]
struct Args {
    /// Frames of the scripted scene (30 per second).
    #[arg(long, default_value_t = 300)]
    frames: usize,
    /// Session folder (summaries.jsonl, session.json, the maps at the strongest press).
    #[arg(long, default_value = "vistaf-demo")]
    out: PathBuf,
}

fn main() {
    let args = Args::parse();
    if let Err(e) = run(&args) {
        eprintln!("vistaf-demo: {e:#}");
        std::process::exit(1);
    }
}

fn run(a: &Args) -> Result<()> {
    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    let device = device::SimulatedSkin::start(a.frames)?;
    eprintln!(
        "device: simulated skin on {}; host: reading it",
        device.port()
    );
    let watched = peak::watch(&device, a.frames, &a.out)?;
    let calibration = device.calibration().clone();
    let port = device.port().to_string();
    let counters = device.finish()?;
    session::write(
        &a.out,
        &session::Session {
            port: &port,
            counters: &counters,
            calibration: &calibration,
            watched: &watched,
        },
    )?;
    eprintln!("session: {}", a.out.display());
    match &watched.failure {
        Some(e) => Err(anyhow::anyhow!("{e}")),
        None => Ok(()),
    }
}
