//! Several skins at once: one reader thread per link, merged into one event stream in
//! arrival order, with per-device sequence-gap and dropped-frame accounting.

use std::thread::JoinHandle;
use std::time::Duration;

use crossbeam_channel::{Receiver, RecvTimeoutError};
use vistaf_protocol::{DeviceMsg, DropCounts};

use crate::client::{Client, Next, Received};
use crate::error::HostError;
use crate::seq::SeqTracker;

/// What one of the links produced.
// Summaries are the common case and small; a rare Map makes the enum large. Boxing
// would cost an allocation per summary to save stack on the rare case.
#[allow(clippy::large_enum_variant)]
#[derive(Debug)]
pub enum Event {
    /// A message from device `device` (index into the links given to [`MultiReader::spawn`]).
    Message {
        /// Which device.
        device: usize,
        /// The message.
        received: Received,
    },
    /// Device `device`'s stream ended.
    Ended {
        /// Which device.
        device: usize,
    },
    /// Device `device`'s link failed; its reader has stopped.
    Failed {
        /// Which device.
        device: usize,
        /// Why.
        error: HostError,
    },
}

/// Per-device counters kept by the [`MultiReader`].
#[derive(Debug, Clone, Default)]
pub struct DeviceStats {
    /// Link name.
    pub name: String,
    /// Summary sequence accounting.
    pub seq: SeqTracker,
    /// Frames the decoder dropped on this link.
    pub drops: DropCounts,
    /// Whether the stream has ended or failed.
    pub finished: bool,
}

/// Merges several links.
#[derive(Debug)]
pub struct MultiReader {
    rx: Receiver<(Event, DropCounts)>,
    stats: Vec<DeviceStats>,
    threads: Vec<JoinHandle<()>>,
}

impl MultiReader {
    /// Starts one reader thread per client.
    pub fn spawn(clients: Vec<Client>) -> MultiReader {
        let (tx, rx) = crossbeam_channel::bounded(1024);
        let mut stats = Vec::new();
        let mut threads = Vec::new();
        for (device, mut client) in clients.into_iter().enumerate() {
            stats.push(DeviceStats {
                name: client.name().to_string(),
                ..Default::default()
            });
            let tx = tx.clone();
            threads.push(std::thread::spawn(move || loop {
                let event = match client.next(None) {
                    Ok(Next::Message(received)) => Event::Message { device, received },
                    Ok(Next::End | Next::Timeout) => Event::Ended { device },
                    Err(error) => Event::Failed { device, error },
                };
                let last = !matches!(event, Event::Message { .. });
                if tx.send((event, client.drops())).is_err() || last {
                    return;
                }
            }));
        }
        MultiReader { rx, stats, threads }
    }

    /// The next event from any link, or `None` after `timeout` or once every link ended.
    pub fn recv(&mut self, timeout: Duration) -> Option<Event> {
        if self.stats.iter().all(|s| s.finished) {
            return None;
        }
        match self.rx.recv_timeout(timeout) {
            Ok((event, drops)) => {
                let device = match &event {
                    Event::Message { device, .. }
                    | Event::Ended { device }
                    | Event::Failed { device, .. } => *device,
                };
                if let Some(s) = self.stats.get_mut(device) {
                    s.drops = drops;
                    match &event {
                        Event::Message { received, .. } => {
                            if let DeviceMsg::Summary(sum) = &received.msg {
                                s.seq.observe(sum.seq);
                            }
                        }
                        _ => s.finished = true,
                    }
                }
                Some(event)
            }
            Err(RecvTimeoutError::Timeout) => None,
            Err(RecvTimeoutError::Disconnected) => {
                self.stats.iter_mut().for_each(|s| s.finished = true);
                None
            }
        }
    }

    /// Counters of every device, in the order the links were given.
    pub fn stats(&self) -> &[DeviceStats] {
        &self.stats
    }

    /// Whether every link has ended.
    pub fn all_finished(&self) -> bool {
        self.stats.iter().all(|s| s.finished)
    }

    /// Waits for the reader threads of finished links.
    pub fn join(self) {
        for t in self.threads {
            let _ = t.join();
        }
    }
}
