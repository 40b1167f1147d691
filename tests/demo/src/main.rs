//! `vistaf-demo`: the whole chain on a simulated skin, with no hardware and no system
//! packages. The device service films a scripted scene (idle, a heated sphere pressed,
//! slid and released, the letter E, a heated bar) and writes its summaries to a real
//! pseudo-terminal; the host library reads them there with a live readout, records the
//! session and asks for the maps at the strongest press.
//!
//! ```sh
//! cargo run --release -p vistaf-demo                      # 300 frames into vistaf-demo/
//! cargo run --release -p vistaf-demo -- --frames 120 --out /tmp/run
//! cargo run --release -p vistaf-demo -- --calibrate         # a guided calibration
//! ```
//!
//! `--calibrate` runs a guided calibration instead: a simulated unit unlike the default
//! (`--unit-seed`) on a bench the device drives, the host's session with the default kit
//! plan, the kit kept in `OUT/kit/`, the fit judged and activated into
//! `OUT/calibration.json` (the default kept as `calibration.json.previous`).

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
    /// Run a guided calibration of a simulated unit instead of the scene.
    #[arg(long)]
    calibrate: bool,
    /// The simulated unit `--calibrate` calibrates (0 is the default calibration's).
    #[arg(long, default_value_t = 3)]
    unit_seed: u64,
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
    if a.calibrate {
        return calibrate(a);
    }
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

/// A guided calibration of simulated unit `a.unit_seed`, end to end.
fn calibrate(a: &Args) -> Result<()> {
    use vistaf_host::calibrate::{run, Plan, Scripted};
    let path = a.out.join("calibration.json");
    let device = device::SimulatedSkin::start_on_bench(a.unit_seed, &path, &a.out.join("kit"))?;
    eprintln!(
        "device: simulated unit {} on a calibration bench on {}",
        a.unit_seed,
        device.port()
    );
    let (mut client, _) = device.host_ends()?;
    let hello = client.handshake(vistaf_host::client::DEFAULT_TIMEOUT)?;
    eprintln!(
        "{}; calibration {} in use (the default, made for another unit)",
        vistaf_host::client::describe(&hello),
        vistaf_protocol::CalibrationId(hello.calibration_id)
    );
    let outcome = run(
        &mut client,
        &Plan::default(),
        &mut Scripted::new(std::io::stdout()),
    );
    drop(client);
    device.finish()?;
    let outcome = outcome?;
    eprintln!(
        "kit: {}; calibration file: {}",
        a.out.join("kit").display(),
        path.display()
    );
    match outcome.activated {
        Some(_) => Ok(()),
        None => Err(anyhow::anyhow!(
            "the fit was not activated: a model missed its target"
        )),
    }
}
