//! The service on one end of a new pseudo-terminal, on a thread of its own, with an
//! in-memory LED ring: a skin without hardware, for the demo and the end-to-end tests,
//! whose host opens the other end as it would a USB serial port.

use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::thread::JoinHandle;

use anyhow::{Context, Result};
use serialport::{SerialPort, TTYPort};
use vistaf_hardware::led::MemoryLedRing;
use vistaf_hardware::source::FrameSource;

use super::{run, Counters, Settings};

/// A service running on a pseudo-terminal.
#[derive(Debug)]
pub struct OnPty {
    /// The terminal's path, for the host to open.
    pub port: String,
    /// Set to stop the service.
    pub stop: Arc<AtomicBool>,
    /// The service: its counters, or why it failed.
    pub thread: JoinHandle<Result<Counters>>,
    /// The device's end of the terminal, held open as long as this is kept. When the last
    /// handle on that end closes, Linux hangs up the host's end and throws away what the
    /// host has not read yet; a USB gadget's port stays when the service stops, and so
    /// does this one, until it is dropped.
    pub device_end: TTYPort,
}

/// Starts the service on `source` with `settings` on a new pseudo-terminal.
pub fn spawn(source: Box<dyn FrameSource>, settings: Settings) -> Result<OnPty> {
    let (master, slave) = TTYPort::pair().context("creating a pseudo-terminal pair")?;
    let port = slave.name().context("the pseudo-terminal has no name")?;
    let reader = master.try_clone_native().context("pseudo-terminal")?;
    let device_end = master.try_clone_native().context("pseudo-terminal")?;
    drop(slave);
    let stop = Arc::new(AtomicBool::new(false));
    let device_stop = stop.clone();
    let thread = std::thread::spawn(move || {
        let mut led = MemoryLedRing::default();
        run(
            source,
            master,
            Some(Box::new(reader)),
            &mut led,
            &settings,
            device_stop,
        )
    });
    Ok(OnPty {
        port,
        stop,
        thread,
        device_end,
    })
}
