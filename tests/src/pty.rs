//! The device service on one end of a real pseudo-terminal and the host's client on the
//! other, in one process: the link as a robot sees it, without hardware.

use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::thread::JoinHandle;

use serialport::TTYPort;
use vistaf_firmware::service::{pty, Counters, Settings};
use vistaf_hardware::source::FrameSource;
use vistaf_host::client::Client;
use vistaf_host::link::{Link, LinkSpec};

/// A service running on a pseudo-terminal: the host's client, the flag that stops the
/// service, and the service's thread (its counters, or why it failed).
#[derive(Debug)]
pub struct Served {
    /// The host's end.
    pub client: Client,
    /// Set to stop the service.
    pub stop: Arc<AtomicBool>,
    /// The service.
    pub device: JoinHandle<anyhow::Result<Counters>>,
    /// The device's end of the terminal: while it is kept, what the service wrote before
    /// it ended can still be read (see [`pty::OnPty::device_end`]).
    pub device_end: TTYPort,
}

/// Runs the service on `source` with `settings` on a new pseudo-terminal, and opens the
/// host's end. Panics when that cannot be done (a test without it cannot run).
pub fn serve(source: Box<dyn FrameSource>, settings: Settings) -> Served {
    let on = pty::spawn(source, settings).unwrap_or_else(|e| panic!("{e:#}"));
    let spec: LinkSpec = format!("serial:{}", on.port)
        .parse()
        .unwrap_or_else(|e| panic!("{}: {e}", on.port));
    let link = Link::open(&spec).unwrap_or_else(|e| panic!("{}: {e}", on.port));
    Served {
        client: Client::new(link),
        stop: on.stop,
        device: on.thread,
        device_end: on.device_end,
    }
}
