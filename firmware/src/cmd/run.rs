//! `vistaf-skin run`: the service.

use std::io::Write;
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use anyhow::{bail, Context, Result};
use vistaf_firmware::config::Config;
use vistaf_firmware::service::persist;
use vistaf_firmware::service::{run as serve, Settings, DEFAULT_KIT_DIR};
use vistaf_firmware::source_spec::{open_with_bench, OpenOptions, SourceSpec};
use vistaf_hardware::led::{LedRing, MemoryLedRing};
use vistaf_pipeline::calibration::Calibration;
use vistaf_pipeline::Implementation;
use vistaf_protocol::link::LinkSpec;

/// What a service on this board films, with which calibration, and where kits go: shared
/// by `run` and `calibrate --guided`. Each overrides the same key of `--config`; without
/// either, the built-in default (the reference build) applies.
#[derive(clap::Args, Debug)]
pub struct ServiceArgs {
    /// TOML configuration file (see firmware/deploy/skin.toml).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// camera:/dev/videoN, camera-serial:SERIAL, camera-name:NAME, set:DIR, sim:SCENE or
    /// sim:bench (a simulated unit a guided calibration drives) [default: camera:/dev/video0].
    #[arg(long)]
    pub source: Option<SourceSpec>,
    /// Calibration file [default: the simulated reference unit's].
    #[arg(long)]
    pub calibration: Option<PathBuf>,
    /// Where guided calibrations keep their frames, a folder per session [default: `kit`
    /// beside the calibration file, else ./vistaf-kit].
    #[arg(long)]
    pub kit: Option<PathBuf>,
    /// Use a calibration made for another grating period or image size.
    #[arg(long)]
    pub force_calibration: bool,
    /// Pace sets and simulated scenes at this rate (frames per second).
    #[arg(long, value_parser = super::common::positive_rate)]
    pub fps: Option<f32>,
    /// Simulated unit (sim: sources).
    #[arg(long, default_value_t = 0)]
    pub unit_seed: u64,
    /// Frames a simulated scene lasts.
    #[arg(long, default_value_t = 120)]
    pub sim_frames: usize,
    /// Serial of this skin, sent in Hello [default: VSK-SIM].
    #[arg(long)]
    pub serial: Option<String>,
}

/// Service options.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The camera, the calibration, the kits.
    #[command(flatten)]
    pub service: ServiceArgs,
    /// /dev/ttyX, serial:PATH or serial:PATH@BAUD, file:PATH, or - for stdout
    /// (default: serial:/dev/ttyGS0@921600).
    #[arg(long)]
    pub link: Option<LinkSpec>,
    /// Stop after this many processed frames.
    #[arg(long)]
    pub frames: Option<u64>,
    /// float (rustfft reference) or fixed (device path) [default: fixed].
    #[arg(long)]
    pub pipeline: Option<Implementation>,
    /// Summary rate limit, Hz (0: every frame) [default: 0].
    #[arg(long)]
    pub max_rate_hz: Option<u16>,
    /// Seconds without contact before a drifted reference is renewed (0: never; summaries
    /// then carry stale_reference) [default: 30].
    #[arg(long)]
    pub auto_reference_s: Option<f32>,
}

/// The device's side of a link: where frames go, and where commands come from (if anywhere).
type LinkEnds = (Box<dyn Write + Send>, Option<Box<dyn std::io::Read + Send>>);

/// Opens a link for the device: a serial port both ways, a file or stdout write-only.
pub fn open_link(spec: &LinkSpec) -> Result<LinkEnds> {
    match spec {
        LinkSpec::Stdio => Ok((Box::new(std::io::stdout()), None)),
        LinkSpec::File(path) => {
            let f = std::fs::File::create(path)
                .with_context(|| format!("link file {}", path.display()))?;
            Ok((Box::new(f), None))
        }
        LinkSpec::Tcp(addr) => bail!(
            "tcp:{addr}: a TCP link is the host's (a bridge's --serve); the skin speaks on a \
             serial port, a file or stdout"
        ),
        LinkSpec::Serial { path, baud } => {
            let port = serialport::new(path, *baud)
                .timeout(std::time::Duration::from_millis(100))
                .open_native()
                .with_context(|| format!("opening serial link {path}"))?;
            let reader = port
                .try_clone_native()
                .with_context(|| format!("serial link {path}"))?;
            Ok((Box::new(port), Some(Box::new(reader))))
        }
    }
}

/// A service as its options and configuration say: the source opened (with its bench,
/// when software drives it), the settings, and the configuration they came from.
#[allow(missing_debug_implementations)] // a frame source has no Debug
pub struct Opened {
    /// The frames.
    pub source: Box<dyn vistaf_hardware::source::FrameSource>,
    /// The service's settings (summaries per frame, no frame limit: the caller's to set).
    pub settings: Settings,
    /// The configuration file's contents (or the defaults).
    pub config: Config,
}

/// Opens what `a` names, with `pipeline` (else the configuration's, else the device path).
/// With `fresh_ok`, a calibration file that is not there yet is one the first activation
/// writes, and the reference build's calibration is used until then.
pub fn open(a: &ServiceArgs, pipeline: Option<Implementation>, fresh_ok: bool) -> Result<Opened> {
    let cfg = match &a.config {
        Some(p) => Config::load(p)?,
        None => Config::default(),
    };
    let source: SourceSpec = match (&a.source, &cfg.source) {
        (Some(s), _) => s.clone(),
        (None, Some(s)) => s.parse().context("config key `source`")?,
        (None, None) => "camera:/dev/video0".parse()?,
    };
    let pipeline = match (pipeline, &cfg.pipeline) {
        (Some(p), _) => p,
        (None, Some(p)) => p.parse().map_err(|e: String| anyhow::anyhow!(e))?,
        (None, None) => Implementation::Fixed,
    };
    let calibration_path = a.calibration.as_ref().or(cfg.calibration.as_ref()).cloned();
    let calibration = match &calibration_path {
        Some(p) if !fresh_ok || p.exists() => Calibration::load(p)?,
        _ => Calibration::default_sim(),
    };
    let kit_dir = match (&a.kit, &cfg.kit, &calibration_path) {
        (Some(k), _, _) | (None, Some(k), _) => k.clone(),
        (None, None, Some(c)) => c.with_file_name("kit"),
        (None, None, None) => PathBuf::from(DEFAULT_KIT_DIR),
    };
    let previous = calibration_path.as_deref().and_then(persist::previous);
    let opts = OpenOptions {
        sim_frames: a.sim_frames,
        unit_seed: a.unit_seed,
        fps: a.fps.or(cfg.fps),
        camera_hold: cfg.camera_hold(),
        ..OpenOptions::default()
    };
    let (source, bench) = open_with_bench(&source, &opts)?;
    let settings = Settings {
        serial: a
            .serial
            .clone()
            .or(cfg.serial.clone())
            .unwrap_or_else(|| "VSK-SIM".into()),
        force_calibration: a.force_calibration || cfg.force_calibration.unwrap_or(false),
        pipeline,
        led: cfg.led.led_config(),
        reference: cfg.reference,
        calibration_path,
        previous,
        kit_dir,
        bench,
        ..Settings::new(calibration)
    };
    Ok(Opened {
        source,
        settings,
        config: cfg,
    })
}

/// Runs the command until the source ends, `--frames`, or SIGTERM/SIGINT.
pub fn run(a: &Args) -> Result<()> {
    if let Some(s) = a.auto_reference_s {
        if !(s.is_finite() && s >= 0.0) {
            bail!("--auto-reference-s {s}: seconds ≥ 0 (0: never)");
        }
    }
    let Opened {
        source,
        mut settings,
        config: cfg,
    } = open(&a.service, a.pipeline, false)?;
    let link: LinkSpec = match (&a.link, &cfg.link) {
        (Some(l), _) => l.clone(),
        (None, Some(l)) => l.parse().context("config key `link`")?,
        (None, None) => "serial:/dev/ttyGS0@921600".parse()?,
    };
    if let Some(s) = a.auto_reference_s {
        settings.reference.auto_after_s = s;
    }
    settings.frames = a.frames.or(cfg.frames);
    settings.max_rate_hz = a.max_rate_hz.or(cfg.max_rate_hz).unwrap_or(0);
    let (writer, reader) = open_link(&link)?;
    let stop = Arc::new(AtomicBool::new(false));
    for sig in [signal_hook::consts::SIGTERM, signal_hook::consts::SIGINT] {
        signal_hook::flag::register(sig, stop.clone()).context("installing signal handlers")?;
    }
    let mut led = led_ring(&cfg.led)?;
    let c = serve(source, writer, reader, led.as_mut(), &settings, stop)?;
    eprintln!(
        "vistaf-skin: {} frames captured, {} processed, {} dropped (newest wins), {} bad, \
         {} summaries sent ({} stale), {} link errors, {} references, {} camera restarts",
        c.captured,
        c.processed,
        c.dropped,
        c.bad,
        c.sent,
        c.stale,
        c.link_errors,
        c.references,
        c.camera_restarts
    );
    Ok(())
}

/// The LED ring the configuration names: the WS2812 ring on SPI0 in a `rpi` build, an
/// in-memory stand-in otherwise or when SPI0 cannot be opened (with the reason on stderr,
/// which the journal keeps).
pub fn led_ring(l: &vistaf_firmware::config::LedSection) -> Result<Box<dyn LedRing>> {
    match l.ring.as_str() {
        // A missing ring must not keep the skin from reporting: say why, run dark.
        #[cfg(feature = "rpi")]
        "spi0" => match vistaf_hardware::led::open_pi_ring(l.count) {
            Ok(ring) => Ok(Box::new(ring)),
            Err(e) => {
                eprintln!("vistaf-skin: LED ring: {e}; running without it");
                Ok(Box::new(MemoryLedRing::default()))
            }
        },
        #[cfg(not(feature = "rpi"))]
        "spi0" => {
            eprintln!(
                "vistaf-skin: this build has no SPI LED driver (built without the rpi feature); \
                 the ring stays dark"
            );
            Ok(Box::new(MemoryLedRing::default()))
        }
        _ => Ok(Box::new(MemoryLedRing::default())),
    }
}
