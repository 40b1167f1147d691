//! `vistaf-skin run`: the service.

use std::io::Write;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use anyhow::{bail, Context, Result};
use vistaf_firmware::service::{run as serve, Settings};
use vistaf_firmware::source_spec::{open, OpenOptions, SourceSpec};
use vistaf_hardware::led::{LedConfig, MemoryLedRing};

/// Service options.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// camera:/dev/videoN, camera-serial:SERIAL, camera-name:NAME, set:DIR or sim:SCENE.
    #[arg(long, default_value = "camera:/dev/video0")]
    pub source: SourceSpec,
    /// serial:PATH[@BAUD], file:PATH or stdout.
    #[arg(long, default_value = "serial:/dev/ttyGS0@921600")]
    pub link: String,
    /// Stop after this many processed frames.
    #[arg(long)]
    pub frames: Option<u64>,
    #[command(flatten)]
    pub pipe: super::common::PipelineArgs,
    /// Pace sets and simulated scenes at this rate (frames per second).
    #[arg(long)]
    pub fps: Option<f32>,
    /// Simulated unit (sim: sources).
    #[arg(long, default_value_t = 0)]
    pub unit_seed: u64,
    /// Frames a simulated scene lasts.
    #[arg(long, default_value_t = 120)]
    pub sim_frames: usize,
    /// Serial of this skin, sent in Hello.
    #[arg(long, default_value = "VSK-SIM")]
    pub serial: String,
}

/// The device's side of a link: where frames go, and where commands come from (if anywhere).
type LinkEnds = (Box<dyn Write + Send>, Option<Box<dyn std::io::Read + Send>>);

/// Opens a link spec.
pub fn open_link(spec: &str) -> Result<LinkEnds> {
    if spec == "stdout" {
        return Ok((Box::new(std::io::stdout()), None));
    }
    if let Some(path) = spec.strip_prefix("file:") {
        let f = std::fs::File::create(path).with_context(|| format!("link file {path}"))?;
        return Ok((Box::new(f), None));
    }
    let Some(rest) = spec.strip_prefix("serial:") else {
        bail!("link {spec:?}: expected serial:PATH[@BAUD], file:PATH or stdout");
    };
    let (path, baud) = match rest.rsplit_once('@') {
        Some((p, b)) => (
            p,
            b.parse::<u32>()
                .with_context(|| format!("link {spec:?}: baud rate"))?,
        ),
        None => (rest, 921_600),
    };
    let port = serialport::new(path, baud)
        .timeout(std::time::Duration::from_millis(100))
        .open_native()
        .with_context(|| format!("opening serial link {path}"))?;
    let reader = port
        .try_clone_native()
        .with_context(|| format!("serial link {path}"))?;
    Ok((Box::new(port), Some(Box::new(reader))))
}

/// Runs the command until the source ends, `--frames`, or SIGTERM/SIGINT.
pub fn run(a: &Args) -> Result<()> {
    let calibration = a.pipe.calibration()?;
    let opts = OpenOptions {
        sim_frames: a.sim_frames,
        unit_seed: a.unit_seed,
        fps: a.fps,
        ..OpenOptions::default()
    };
    let source = open(&a.source, &opts)?;
    let (writer, reader) = open_link(&a.link)?;
    let stop = Arc::new(AtomicBool::new(false));
    for sig in [signal_hook::consts::SIGTERM, signal_hook::consts::SIGINT] {
        signal_hook::flag::register(sig, stop.clone()).context("installing signal handlers")?;
    }
    let settings = Settings {
        serial: a.serial.clone(),
        calibration,
        force_calibration: a.pipe.force_calibration,
        pipeline: a.pipe.pipeline,
        frames: a.frames,
        max_rate_hz: 0,
        led: LedConfig::default(),
    };
    let mut led = MemoryLedRing::default();
    let c = serve(source, writer, reader, &mut led, &settings, stop)?;
    eprintln!(
        "vistaf-skin: {} frames captured, {} processed, {} dropped (newest wins), {} bad, {} summaries sent, {} link errors",
        c.captured, c.processed, c.dropped, c.bad, c.sent, c.link_errors
    );
    Ok(())
}
