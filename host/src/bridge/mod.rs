//! `vistaf-host bridge`: one reader of every skin, each message fanned out to every
//! consumer at once (a ROS 2 publisher, an MCAP file, JSON lines, the stream served again
//! on TCP for monitors), so one program owns the ports and the others read what it
//! publishes.
//!
//! Every summary is stamped with its capture time on the host's clock when the skin's clock
//! has been read ([`crate::clock`]); before the first exchange, with its receive time less
//! the device's processing latency. A replayed capture (a `file:` link) has no host time to
//! map onto: its messages keep the device's clock (s since the device's epoch), so a
//! recording converted from a capture plots on the time line it was captured on.

#[cfg(feature = "ros2")]
pub mod dds;
pub mod mcap;
pub mod serve;

use serde_json::Value;
use vistaf_protocol::{DeviceMsg, Hello, Map, Reading, Status, Summary};

use crate::client::Received;
use crate::clock::{unix_s, MappedTime};
use crate::error::HostError;
use crate::multi::DeviceStats;
use crate::record::{message_json, Recorder};
use crate::ros2::{HostCounts, Outgoing, SkinTopics};
use crate::stream::{name_of, Consumer};
use serve::Serve;

/// A consumer of what the bridge publishes.
pub trait Sink {
    /// A ROS 2 message.
    fn ros(&mut self, msg: &Outgoing) -> Result<(), HostError>;
    /// A whole summary as JSON (SI units), on the skin's `summary` topic.
    fn summary_json(&mut self, topic: &str, stamp_ns: i64, json: &Value) -> Result<(), HostError> {
        let _ = (topic, stamp_ns, json);
        Ok(())
    }
    /// The end: write what is pending and close.
    fn finish(&mut self) -> Result<(), HostError> {
        Ok(())
    }
}

/// Which clock the messages are stamped on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stamps {
    /// The host's: live skins.
    Host,
    /// The device's: replayed captures, which have no host time.
    Device,
}

#[derive(Debug, Default)]
struct Skin {
    topics: Option<SkinTopics>,
    counts: HostCounts,
    last_stamp_ns: Option<i64>,
    last_seq: Option<u32>,
    /// Summaries since the last `Status`, and that status's uptime, ms.
    since_status: (u64, Option<u64>),
}

/// The bridge's consumer: names each skin by the serial of its `Hello` (by its link until
/// one arrives) and hands its messages to every sink.
pub struct Bridge {
    skins: Vec<Skin>,
    frame_id: Option<String>,
    stamps: Stamps,
    sinks: Vec<Box<dyn Sink>>,
    jsonl: Option<Recorder>,
    serve: Option<Serve>,
    published: u64,
}

impl std::fmt::Debug for Bridge {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Bridge")
            .field("skins", &self.skins)
            .field("published", &self.published)
            .finish_non_exhaustive()
    }
}

impl Bridge {
    /// A bridge of `devices` skins, stamping on `stamps`, every skin's frame `frame_id`
    /// (default `vistaf_<serial>`).
    pub fn new(devices: usize, stamps: Stamps, frame_id: Option<String>) -> Bridge {
        Bridge {
            skins: (0..devices).map(|_| Skin::default()).collect(),
            frame_id,
            stamps,
            sinks: Vec::new(),
            jsonl: None,
            serve: None,
            published: 0,
        }
    }

    /// Adds a sink.
    pub fn sink(mut self, sink: Box<dyn Sink>) -> Bridge {
        self.sinks.push(sink);
        self
    }

    /// Also writes every message as a JSON line.
    pub fn jsonl(mut self, rec: Recorder) -> Bridge {
        self.jsonl = Some(rec);
        self
    }

    /// Also serves each skin's stream again on TCP, for monitors to attach to.
    pub fn serve(mut self, serve: Serve) -> Bridge {
        self.serve = Some(serve);
        self
    }

    /// ROS messages handed to the sinks so far.
    pub fn published(&self) -> u64 {
        self.published
    }

    /// Finishes every sink; the first failure is returned after all were tried.
    pub fn finish(&mut self) -> Result<(), HostError> {
        let mut first = Ok(());
        for s in &mut self.sinks {
            if let Err(e) = s.finish() {
                if first.is_ok() {
                    first = Err(e);
                }
            }
        }
        first
    }

    fn publish(&mut self, msgs: &[Outgoing]) -> Result<(), HostError> {
        for m in msgs {
            for s in &mut self.sinks {
                s.ros(m)?;
            }
            self.published += 1;
        }
        Ok(())
    }

    /// When `received` is stamped, ns; `None` for a message of a replay that carries no
    /// device time of its own.
    fn stamp_of(&self, received: &Received) -> Option<i64> {
        let ns = |s: f64| (s * 1e9).round() as i64;
        let us = |us: u64| i64::try_from(us).unwrap_or(i64::MAX / 1000) * 1000;
        match (&received.msg, self.stamps, received.captured) {
            (DeviceMsg::Summary(_), Stamps::Host, Some(c)) => Some(ns(c.host_s)),
            (DeviceMsg::Summary(s), Stamps::Host, None) => {
                Some(ns(unix_s(received.at) - f64::from(s.latency_us) * 1e-6))
            }
            (DeviceMsg::Summary(s), Stamps::Device, _) => Some(us(s.capture_us)),
            (_, Stamps::Host, _) => Some(ns(unix_s(received.at))),
            (_, Stamps::Device, _) => None,
        }
    }
}

impl Bridge {
    /// Writes `received` as a JSON line, if asked; a reader that hung up (`--jsonl - |
    /// head`) is let go and the other consumers go on.
    fn record_jsonl(&mut self, link: &str, received: &Received) -> Result<(), HostError> {
        let Some(rec) = self.jsonl.as_mut() else {
            return Ok(());
        };
        match rec.record(link, received) {
            Err(HostError::Record { cause, .. })
                if cause.kind() == std::io::ErrorKind::BrokenPipe =>
            {
                eprintln!("JSON lines: the reader hung up; bridging on without it");
                self.jsonl = None;
                Ok(())
            }
            other => other,
        }
    }
}

impl Skin {
    /// Named by its `Hello`'s serial, with the calibration it runs.
    fn hello(&mut self, h: &Hello, frame_id: Option<&str>) {
        self.topics = Some(SkinTopics::new(&h.serial, frame_id));
        self.counts.calibration_id = h.calibration_id;
    }

    /// A summary stamped `stamp`: its messages, and what the diagnostics keep of it.
    fn summary(&mut self, s: &Summary, stamp: i64, captured: Option<MappedTime>) -> Vec<Outgoing> {
        self.last_stamp_ns = Some(stamp);
        self.last_seq = Some(s.seq);
        self.since_status.0 += 1;
        let flags: Vec<&str> = s.flags.iter().map(|f| f.name()).collect();
        self.counts.last_flags = flags.join("|");
        let doubted: Vec<&str> = s.flags.doubted().map(Reading::name).collect();
        self.counts.last_doubted = doubted.join("|");
        self.counts.clock_uncertainty_ms = captured
            .map(|c| format!("{:.3}", c.uncertainty_s * 1e3))
            .unwrap_or_default();
        self.topics
            .as_ref()
            .map_or_else(Vec::new, |t| t.summary(s, stamp))
    }

    /// A map, stamped as the summary of its frame when that was the last one.
    fn map(&self, m: &Map, stamp: Option<i64>) -> Option<Outgoing> {
        let at = match (self.last_seq, self.last_stamp_ns) {
            (Some(seq), Some(t)) if seq == m.seq => Some(t),
            _ => stamp.or(self.last_stamp_ns),
        };
        self.topics.as_ref()?.map(m, at.unwrap_or_default())
    }

    /// A health report: the summary rate on the device's clock (the summaries between two
    /// reports) and the diagnostics. A replay's report goes on the time line of the
    /// summaries around it.
    fn status(&mut self, st: &Status, stamp: Option<i64>) -> Option<Outgoing> {
        let (n, last_ms) = std::mem::replace(&mut self.since_status, (0, Some(st.uptime_ms)));
        if let Some(dt_ms) = last_ms.and_then(|t| st.uptime_ms.checked_sub(t)) {
            if dt_ms > 0 {
                self.counts.summary_rate_hz = n as f64 * 1e3 / dt_ms as f64;
            }
        }
        let at = stamp
            .or(self.last_stamp_ns)
            .unwrap_or_else(|| i64::try_from(st.uptime_ms).unwrap_or(0) * 1_000_000);
        Some(self.topics.as_ref()?.diagnostics(st, &self.counts, at))
    }
}

impl Consumer for Bridge {
    fn message(
        &mut self,
        device: usize,
        stats: &[DeviceStats],
        received: &Received,
    ) -> Result<(), HostError> {
        let link = name_of(stats, device);
        self.record_jsonl(link, received)?;
        if let Some(serve) = self.serve.as_mut() {
            serve.send(device, &received.msg);
        }
        let stamp = self.stamp_of(received);
        let frame_id = self.frame_id.as_deref();
        let Some(skin) = self.skins.get_mut(device) else {
            return Ok(());
        };
        if let Some(st) = stats.get(device) {
            skin.counts.summaries_missing = st.seq.missing;
            skin.counts.link_frames_dropped = st.drops.total();
        }
        if skin.topics.is_none() {
            skin.topics = Some(SkinTopics::new(link, frame_id));
        }
        let out: Vec<Outgoing> = match &received.msg {
            DeviceMsg::Hello(h) => {
                skin.hello(h, frame_id);
                Vec::new()
            }
            DeviceMsg::Summary(s) => {
                let stamp = stamp.unwrap_or_default();
                if let Some(t) = &skin.topics {
                    let (topic, json) = (t.topic("summary"), message_json(link, received));
                    for sink in &mut self.sinks {
                        sink.summary_json(&topic, stamp, &json)?;
                    }
                }
                skin.summary(s, stamp, received.captured)
            }
            DeviceMsg::Map(m) => skin.map(m, stamp).into_iter().collect(),
            DeviceMsg::Status(st) => skin.status(st, stamp).into_iter().collect(),
            DeviceMsg::Error(e) => {
                eprintln!("{link}: device error {:?}: {}", e.code, e.detail);
                Vec::new()
            }
            _ => Vec::new(),
        };
        self.publish(&out)
    }

    fn tick(&mut self, _stats: &[DeviceStats]) {
        if let Some(serve) = self.serve.as_mut() {
            serve.accept();
        }
    }
}
