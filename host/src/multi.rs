//! Several skins at once: one reader thread per link, merged into one event stream in
//! arrival order, with per-device sequence-gap and dropped-frame accounting.
//!
//! A link given a [`Reopen`] survives going away (a USB gadget re-enumerating, a cable
//! pulled and put back): its reader says it is lost, tries to open it again with back-off,
//! and says when it is back; only when it does not come back in time does it fail.

use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, RecvTimeoutError, Sender};
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
    /// Device `device`'s link went away; its reader is trying to open it again.
    Lost {
        /// Which device.
        device: usize,
        /// Why it went away.
        why: String,
    },
    /// Device `device`'s link is open again.
    Reconnected {
        /// Which device.
        device: usize,
    },
}

impl Event {
    /// The device the event is about.
    pub fn device(&self) -> usize {
        match self {
            Event::Message { device, .. }
            | Event::Ended { device }
            | Event::Failed { device, .. }
            | Event::Lost { device, .. }
            | Event::Reconnected { device } => *device,
        }
    }
}

/// How a lost link is opened again.
pub struct Reopen {
    /// Opens the link (and shakes hands, if the caller wants that) once more.
    pub open: Box<dyn FnMut() -> Result<Client, HostError> + Send>,
    /// How long to keep trying before giving up.
    pub give_up_after: Duration,
    /// Wait before the first attempt, doubled after each failed one up to `max_backoff`.
    pub min_backoff: Duration,
    /// See `min_backoff`.
    pub max_backoff: Duration,
}

impl std::fmt::Debug for Reopen {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Reopen")
            .field("give_up_after", &self.give_up_after)
            .finish_non_exhaustive()
    }
}

/// Per-device counters kept by the [`MultiReader`].
#[derive(Debug, Clone, Default)]
pub struct DeviceStats {
    /// Link name.
    pub name: String,
    /// Summary sequence accounting.
    pub seq: SeqTracker,
    /// Frames the decoder dropped on this link (over every connection).
    pub drops: DropCounts,
    /// Times the link was lost and came back.
    pub reconnects: u64,
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

/// One link's reader: its client, how to reopen it, and the drops of the connections
/// before this one.
struct LinkReader {
    device: usize,
    client: Client,
    reopen: Option<Reopen>,
    earlier_drops: DropCounts,
}

impl LinkReader {
    fn drops(&self) -> DropCounts {
        self.earlier_drops.plus(self.client.drops())
    }

    /// Reads until the link ends for good, sending every event.
    fn run(mut self, tx: &Sender<(Event, DropCounts)>) {
        let device = self.device;
        loop {
            let lost = match self.client.next(None) {
                Ok(Next::Message(received)) => {
                    if tx
                        .send((Event::Message { device, received }, self.drops()))
                        .is_err()
                    {
                        return;
                    }
                    continue;
                }
                Ok(Next::End | Next::Timeout) => Event::Ended { device },
                Err(error) => Event::Failed { device, error },
            };
            if self.reopen.is_none() {
                let _ = tx.send((lost, self.drops()));
                return;
            }
            let why = match &lost {
                Event::Failed { error, .. } => error.to_string(),
                _ => "the stream ended".to_string(),
            };
            if tx
                .send((
                    Event::Lost {
                        device,
                        why: why.clone(),
                    },
                    self.drops(),
                ))
                .is_err()
            {
                return;
            }
            match self.reconnect(why) {
                Ok(client) => {
                    self.earlier_drops = self.drops();
                    self.client = client;
                    if tx
                        .send((Event::Reconnected { device }, self.drops()))
                        .is_err()
                    {
                        return;
                    }
                }
                Err(error) => {
                    let _ = tx.send((Event::Failed { device, error }, self.drops()));
                    return;
                }
            }
        }
    }

    /// Opens the link again with back-off, until [`Reopen::give_up_after`].
    fn reconnect(&mut self, mut last: String) -> Result<Client, HostError> {
        let link = self.client.name().to_string();
        let Some(r) = self.reopen.as_mut() else {
            return Err(HostError::GaveUp {
                link,
                after: Duration::ZERO,
                last,
            });
        };
        let started = Instant::now();
        let mut wait = r.min_backoff;
        loop {
            std::thread::sleep(wait);
            match (r.open)() {
                Ok(c) => return Ok(c),
                Err(e) => last = e.to_string(),
            }
            if started.elapsed() >= r.give_up_after {
                return Err(HostError::GaveUp {
                    link,
                    after: r.give_up_after,
                    last,
                });
            }
            wait = (wait * 2).clamp(r.min_backoff, r.max_backoff);
        }
    }
}

impl MultiReader {
    /// Starts one reader thread per client.
    pub fn spawn(clients: Vec<Client>) -> MultiReader {
        MultiReader::spawn_with(clients.into_iter().map(|c| (c, None)).collect())
    }

    /// Starts one reader thread per client; a client given a [`Reopen`] is opened again
    /// when its link goes away.
    pub fn spawn_with(links: Vec<(Client, Option<Reopen>)>) -> MultiReader {
        let (tx, rx) = crossbeam_channel::bounded(1024);
        let mut stats = Vec::new();
        let mut threads = Vec::new();
        for (device, (client, reopen)) in links.into_iter().enumerate() {
            stats.push(DeviceStats {
                name: client.name().to_string(),
                ..Default::default()
            });
            let tx = tx.clone();
            let reader = LinkReader {
                device,
                client,
                reopen,
                earlier_drops: DropCounts::default(),
            };
            threads.push(std::thread::spawn(move || reader.run(&tx)));
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
                if let Some(s) = self.stats.get_mut(event.device()) {
                    s.drops = drops;
                    match &event {
                        Event::Message { received, .. } => {
                            if let DeviceMsg::Summary(sum) = &received.msg {
                                s.seq.observe(sum.seq);
                            }
                        }
                        Event::Lost { .. } => {}
                        Event::Reconnected { .. } => s.reconnects += 1,
                        Event::Ended { .. } | Event::Failed { .. } => s.finished = true,
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::Link;
    use vistaf_protocol::frame::DEVICE_FRAME_MAX;
    use vistaf_protocol::{encode, Summary};

    /// A captured stream of summaries `seqs`, as a link that ends after it.
    fn stream_of(seqs: std::ops::Range<u32>) -> Client {
        let mut bytes = Vec::new();
        let mut buf = [0u8; DEVICE_FRAME_MAX];
        for seq in seqs {
            let n = encode(
                &DeviceMsg::Summary(Summary {
                    seq,
                    ..Default::default()
                }),
                &mut buf,
            )
            .unwrap();
            bytes.extend_from_slice(&buf[..n]);
        }
        Client::new(Link::read_only(
            "serial:/dev/ttyFAKE@921600".into(),
            std::io::Cursor::new(bytes),
        ))
    }

    fn drain(r: &mut MultiReader) -> Vec<Event> {
        let mut out = Vec::new();
        while let Some(e) = r.recv(Duration::from_secs(5)) {
            out.push(e);
        }
        out
    }

    fn kinds(events: &[Event]) -> Vec<&'static str> {
        events
            .iter()
            .map(|e| match e {
                Event::Message { .. } => "message",
                Event::Ended { .. } => "ended",
                Event::Failed { .. } => "failed",
                Event::Lost { .. } => "lost",
                Event::Reconnected { .. } => "reconnected",
            })
            .collect()
    }

    #[test]
    fn a_link_that_comes_back_is_read_on() {
        let mut second = Some(stream_of(3..5));
        let reopen = Reopen {
            // Refused once (the port not there yet), then back.
            open: Box::new({
                let mut tries = 0;
                move || {
                    tries += 1;
                    match (tries, second.take()) {
                        (1, s) => {
                            second = s;
                            Err(HostError::ReadOnly { link: "x".into() })
                        }
                        (_, Some(c)) => Ok(c),
                        (_, None) => Err(HostError::ReadOnly { link: "x".into() }),
                    }
                }
            }),
            give_up_after: Duration::from_millis(50),
            min_backoff: Duration::ZERO,
            max_backoff: Duration::from_millis(1),
        };
        let mut r = MultiReader::spawn_with(vec![(stream_of(0..3), Some(reopen))]);
        let events = drain(&mut r);
        assert_eq!(
            kinds(&events),
            [
                "message",
                "message",
                "message",
                "lost",
                "reconnected",
                "message",
                "message",
                "lost",
                "failed"
            ]
        );
        assert!(matches!(
            events.last(),
            Some(Event::Failed {
                error: HostError::GaveUp { .. },
                ..
            })
        ));
        let s = &r.stats()[0];
        assert_eq!((s.seq.received, s.seq.missing, s.reconnects), (5, 0, 1));
    }

    #[test]
    fn without_reopen_a_link_ends_once() {
        let mut r = MultiReader::spawn(vec![stream_of(0..2)]);
        assert_eq!(kinds(&drain(&mut r)), ["message", "message", "ended"]);
    }
}
