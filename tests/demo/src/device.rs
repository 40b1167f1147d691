//! The device side of the demo: the service on a simulated skin, on its own thread,
//! writing to one end of a pseudo-terminal pair.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use anyhow::{Context, Result};
use vistaf_firmware::service::{pty, Counters, Settings};
use vistaf_firmware::source_spec::{open, open_with_bench, OpenOptions, SourceSpec, BENCH_SCENE};
use vistaf_hardware::source::FrameSource;
use vistaf_host::client::Client;
use vistaf_host::link::{Link, DEFAULT_BAUD};
use vistaf_pipeline::Calibration;

/// Frames per second the simulated camera delivers.
pub const FPS: f32 = 30.0;

/// The simulated skin, running.
pub struct SimulatedSkin {
    port: String,
    calibration: Calibration,
    stop: Arc<AtomicBool>,
    thread: JoinHandle<Result<Counters>>,
}

impl SimulatedSkin {
    /// Starts the service on the `demo` scene, `frames` long, on a new pseudo-terminal.
    pub fn start(frames: usize) -> Result<SimulatedSkin> {
        let settings = Settings {
            serial: "VSK-SIM-DEMO".into(),
            frames: Some(frames as u64),
            ..Settings::new(Calibration::default_sim())
        };
        let source = open(
            &SourceSpec::Sim("demo".into()),
            &OpenOptions {
                sim_frames: frames + 2,
                fps: Some(FPS),
                ..OpenOptions::default()
            },
        )?;
        SimulatedSkin::spawn(source, settings)
    }

    /// Starts the service on simulated unit `unit_seed` on a calibration bench that the
    /// device drives, running the default calibration from `calibration_path` (written
    /// there first) and keeping kits under `kit_dir`.
    pub fn start_on_bench(
        unit_seed: u64,
        calibration_path: &Path,
        kit_dir: &Path,
    ) -> Result<SimulatedSkin> {
        let calibration = Calibration::default_sim();
        calibration.save(calibration_path)?;
        let (source, bench) = open_with_bench(
            &SourceSpec::Sim(BENCH_SCENE.into()),
            &OpenOptions {
                unit_seed,
                fps: Some(FPS),
                ..OpenOptions::default()
            },
        )?;
        let settings = Settings {
            serial: format!("VSK-SIM-{unit_seed}"),
            calibration_path: Some(calibration_path.to_path_buf()),
            kit_dir: kit_dir.to_path_buf(),
            bench,
            ..Settings::new(calibration)
        };
        SimulatedSkin::spawn(source, settings)
    }

    /// Runs the service with `settings` on `source`, on a new pseudo-terminal.
    fn spawn(source: Box<dyn FrameSource>, settings: Settings) -> Result<SimulatedSkin> {
        let calibration = settings.calibration.clone();
        let on = pty::spawn(source, settings)?;
        Ok(SimulatedSkin {
            port: on.port,
            calibration,
            stop: on.stop,
            thread: on.thread,
        })
    }

    /// The pseudo-terminal the host opens.
    pub fn port(&self) -> &str {
        &self.port
    }

    /// The calibration the skin runs with.
    pub fn calibration(&self) -> &Calibration {
        &self.calibration
    }

    /// The host's ends of the link: a client that reads the stream, and one that only
    /// sends commands (so a command never waits behind the reader).
    pub fn host_ends(&self) -> Result<(Client, Client)> {
        let host_end = serialport::new(&self.port, DEFAULT_BAUD)
            .timeout(Duration::from_millis(100))
            .open_native()
            .context("opening the pseudo-terminal")?;
        let commands = host_end
            .try_clone_native()
            .context("opening the pseudo-terminal for commands")?;
        let name = format!("serial:{}", self.port);
        let reader = Client::new(Link::from_serial(name.clone(), host_end)?);
        let commander = Client::new(Link::new(name, std::io::empty(), commands));
        Ok((reader, commander))
    }

    /// Stops the service and returns its counters.
    pub fn finish(self) -> Result<Counters> {
        self.stop.store(true, Ordering::Relaxed);
        self.thread
            .join()
            .map_err(|_| anyhow::anyhow!("device thread panicked"))?
    }
}
