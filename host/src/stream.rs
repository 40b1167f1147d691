//! Reading skins until told to stop: the loop behind `monitor`, `record`, `bridge` and the demo.
//!
//! [`stream`] merges every link's messages ([`MultiReader`]) and hands each to a
//! [`Consumer`] (a monitor, a recorder, a hook), until the summary count or the duration
//! in [`Limits`] is reached or every link has ended. The consumer sees every message in
//! arrival order and is ticked while nothing arrives, so a live view can redraw.

use std::time::{Duration, Instant};

use vistaf_protocol::DeviceMsg;

use crate::client::{Client, Received};
use crate::error::HostError;
use crate::monitor::Monitor;
use crate::multi::{DeviceStats, Event, MultiReader, Reopen};
use crate::record::Recorder;

/// How often a consumer is ticked while no message arrives.
pub const TICK: Duration = Duration::from_millis(100);

/// When a stream stops (besides every link ending).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Limits {
    /// After this many summaries, from all links together.
    pub summaries: Option<u64>,
    /// After this long.
    pub duration: Option<Duration>,
}

/// What a stream hands out.
pub trait Consumer {
    /// A message from link `device`; an error stops the stream (a recorder that cannot
    /// write, say).
    fn message(
        &mut self,
        device: usize,
        stats: &[DeviceStats],
        received: &Received,
    ) -> Result<(), HostError>;
    /// Link `device`'s stream ended (said on standard error unless overridden, as are the
    /// other link events).
    fn ended(&mut self, device: usize, stats: &[DeviceStats]) {
        eprintln!("{}: stream ended", name_of(stats, device));
    }
    /// Link `device` failed; its reader has stopped, the others go on.
    fn failed(&mut self, device: usize, stats: &[DeviceStats], error: &HostError) {
        eprintln!("{}: {error}", name_of(stats, device));
    }
    /// Link `device` went away and is being opened again ([`crate::multi::Reopen`]).
    fn lost(&mut self, device: usize, stats: &[DeviceStats], why: &str) {
        eprintln!("{}: lost ({why}); reconnecting", name_of(stats, device));
    }
    /// Link `device` is back.
    fn reconnected(&mut self, device: usize, stats: &[DeviceStats]) {
        eprintln!("{}: back", name_of(stats, device));
    }
    /// Called after every event and at least every [`TICK`] while nothing arrives.
    fn tick(&mut self, stats: &[DeviceStats]) {
        let _ = stats;
    }
}

/// How a stream went.
#[derive(Debug)]
pub struct Outcome {
    /// Every link's counters, in the order the clients were given.
    pub stats: Vec<DeviceStats>,
    /// Summaries received from all links.
    pub summaries: u64,
    /// The first link failure, if any (the others are in the consumer's `failed` calls).
    pub failure: Option<HostError>,
}

/// Reads `clients` until `limits` or the end of every link, handing everything to `consumer`.
pub fn stream(
    clients: Vec<Client>,
    limits: &Limits,
    consumer: &mut dyn Consumer,
) -> Result<Outcome, HostError> {
    stream_with(
        clients.into_iter().map(|c| (c, None)).collect(),
        limits,
        consumer,
    )
}

/// [`stream`] over links of which those given a [`Reopen`] are opened again when they go
/// away.
pub fn stream_with(
    links: Vec<(Client, Option<Reopen>)>,
    limits: &Limits,
    consumer: &mut dyn Consumer,
) -> Result<Outcome, HostError> {
    let mut reader = MultiReader::spawn_with(links);
    let deadline = limits.duration.map(|d| Instant::now() + d);
    let mut summaries = 0u64;
    let mut failure = None;
    loop {
        if limits.summaries.is_some_and(|n| summaries >= n)
            || deadline.is_some_and(|d| Instant::now() >= d)
        {
            break;
        }
        let Some(event) = reader.recv(TICK) else {
            if reader.all_finished() {
                break;
            }
            consumer.tick(reader.stats());
            continue;
        };
        match event {
            Event::Message { device, received } => {
                consumer.message(device, reader.stats(), &received)?;
                if matches!(received.msg, DeviceMsg::Summary(_)) {
                    summaries += 1;
                }
            }
            Event::Ended { device } => consumer.ended(device, reader.stats()),
            Event::Failed { device, error } => {
                consumer.failed(device, reader.stats(), &error);
                failure.get_or_insert(error);
            }
            Event::Lost { device, why } => consumer.lost(device, reader.stats(), &why),
            Event::Reconnected { device } => consumer.reconnected(device, reader.stats()),
        }
        consumer.tick(reader.stats());
    }
    Ok(Outcome {
        stats: reader.stats().to_vec(),
        summaries,
        failure,
    })
}

/// The name of link `device`, for messages.
pub fn name_of(stats: &[DeviceStats], device: usize) -> &str {
    stats.get(device).map_or("?", |s| s.name.as_str())
}

/// The consumer of `monitor` and `record`: records every message, keeps the live
/// readout, and reports device errors, ended and failed links on standard error.
#[derive(Debug)]
pub struct Readout {
    /// Where messages are recorded, if anywhere.
    pub recorder: Option<Recorder>,
    /// The live readout.
    pub monitor: Monitor,
}

impl Consumer for Readout {
    fn message(
        &mut self,
        device: usize,
        stats: &[DeviceStats],
        received: &Received,
    ) -> Result<(), HostError> {
        if let Some(rec) = self.recorder.as_mut() {
            rec.record(name_of(stats, device), received)?;
        }
        self.monitor.heard(device);
        match &received.msg {
            DeviceMsg::Summary(s) => self.monitor.summary(device, s),
            DeviceMsg::Hello(h) => self.monitor.name(device, &h.serial),
            DeviceMsg::Map(m) => self.monitor.map(device, m),
            DeviceMsg::Error(e) => eprintln!(
                "{}: device error {:?}: {}",
                name_of(stats, device),
                e.code,
                e.detail
            ),
            _ => {}
        }
        Ok(())
    }

    fn tick(&mut self, stats: &[DeviceStats]) {
        self.monitor.draw(stats, false);
    }
}

impl Readout {
    /// The last redraw, then on standard error the lines recorded and, per link, the
    /// summaries received, missing, out of order and the frames dropped.
    pub fn finish(&mut self, outcome: &Outcome) {
        self.monitor.draw(&outcome.stats, true);
        if let Some(rec) = &self.recorder {
            eprintln!("recorded {} lines", rec.lines());
        }
        for s in &outcome.stats {
            eprintln!(
                "{}: {} summaries, {} missing (sequence gaps), {} out of order, {} frames dropped",
                s.name,
                s.seq.received,
                s.seq.missing,
                s.seq.out_of_order,
                s.drops.total()
            );
        }
    }
}
