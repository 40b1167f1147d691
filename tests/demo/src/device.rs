//! The device side of the demo: the service on a simulated skin, on its own thread,
//! writing to one end of a pseudo-terminal pair.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use anyhow::{Context, Result};
use vistaf_firmware::service::{run as serve, Counters, Settings};
use vistaf_firmware::source_spec::{open, OpenOptions, SourceSpec};
use vistaf_hardware::led::MemoryLedRing;
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
        let (master, slave) =
            serialport::TTYPort::pair().context("creating a pseudo-terminal pair")?;
        let port = serialport::SerialPort::name(&slave).context("pseudo-terminal has no name")?;
        let calibration = Calibration::default_sim();
        let settings = Settings {
            serial: "VSK-SIM-DEMO".into(),
            frames: Some(frames as u64),
            ..Settings::new(calibration.clone())
        };
        let source = open(
            &SourceSpec::Sim("demo".into()),
            &OpenOptions {
                sim_frames: frames + 2,
                fps: Some(FPS),
                ..OpenOptions::default()
            },
        )?;
        let reader = master.try_clone_native().context("pseudo-terminal")?;
        let stop = Arc::new(AtomicBool::new(false));
        let device_stop = stop.clone();
        let thread = std::thread::spawn(move || {
            let mut led = MemoryLedRing::default();
            serve(
                source,
                master,
                Some(Box::new(reader)),
                &mut led,
                &settings,
                device_stop,
            )
        });
        Ok(SimulatedSkin {
            port,
            calibration,
            stop,
            thread,
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
