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
use vistaf_protocol::DeviceMsg;

use crate::client::Received;
use crate::error::HostError;
use crate::multi::DeviceStats;
use crate::record::{message_json, unix_s, Recorder};
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

impl Consumer for Bridge {
    fn message(
        &mut self,
        device: usize,
        stats: &[DeviceStats],
        received: &Received,
    ) -> Result<(), HostError> {
        let link = name_of(stats, device);
        if let Some(rec) = self.jsonl.as_mut() {
            match rec.record(link, received) {
                // `--jsonl - | head`: the reader left; the other consumers go on.
                Err(HostError::Record { cause, .. })
                    if cause.kind() == std::io::ErrorKind::BrokenPipe =>
                {
                    eprintln!("JSON lines: the reader hung up; bridging on without it");
                    self.jsonl = None;
                }
                other => other?,
            }
        }
        if let Some(serve) = self.serve.as_mut() {
            serve.send(device, &received.msg);
        }
        let stamp = self.stamp_of(received);
        let frame_id = self.frame_id.clone();
        let Some(skin) = self.skins.get_mut(device) else {
            return Ok(());
        };
        if let Some(st) = stats.get(device) {
            skin.counts.summaries_missing = st.seq.missing;
            skin.counts.link_frames_dropped = st.drops.total();
        }
        let topics = skin
            .topics
            .get_or_insert_with(|| SkinTopics::new(link, frame_id.as_deref()))
            .clone();
        let out = match &received.msg {
            DeviceMsg::Hello(h) => {
                skin.topics = Some(SkinTopics::new(&h.serial, frame_id.as_deref()));
                skin.counts.calibration_id = h.calibration_id;
                Vec::new()
            }
            DeviceMsg::Summary(s) => {
                let stamp = stamp.unwrap_or_default();
                skin.last_stamp_ns = Some(stamp);
                skin.last_seq = Some(s.seq);
                skin.since_status.0 += 1;
                skin.counts.last_flags = s
                    .flags
                    .iter()
                    .map(|f| f.name())
                    .collect::<Vec<_>>()
                    .join("|");
                skin.counts.clock_uncertainty_ms = received
                    .captured
                    .map(|c| format!("{:.3}", c.uncertainty_s * 1e3))
                    .unwrap_or_default();
                let json = message_json(link, received);
                let topic = topics.topic("summary");
                for sink in &mut self.sinks {
                    sink.summary_json(&topic, stamp, &json)?;
                }
                topics.summary(s, stamp)
            }
            DeviceMsg::Map(m) => {
                // A map comes from the frame of the summary it names: stamped as that one.
                let at = match (skin.last_seq, skin.last_stamp_ns) {
                    (Some(seq), Some(t)) if seq == m.seq => Some(t),
                    _ => stamp.or(skin.last_stamp_ns),
                };
                topics.map(m, at.unwrap_or_default()).into_iter().collect()
            }
            DeviceMsg::Error(e) => {
                eprintln!("{link}: device error {:?}: {}", e.code, e.detail);
                Vec::new()
            }
            DeviceMsg::Status(st) => {
                // The rate on the device's clock: the summaries between two reports.
                let (n, last_ms) =
                    std::mem::replace(&mut skin.since_status, (0, Some(st.uptime_ms)));
                if let Some(dt_ms) = last_ms.and_then(|t| st.uptime_ms.checked_sub(t)) {
                    if dt_ms > 0 {
                        skin.counts.summary_rate_hz = n as f64 * 1e3 / dt_ms as f64;
                    }
                }
                // A replay's status goes on the time line of the summaries around it.
                let at = stamp
                    .or(skin.last_stamp_ns)
                    .unwrap_or_else(|| i64::try_from(st.uptime_ms).unwrap_or(0) * 1_000_000);
                vec![topics.diagnostics(st, &skin.counts, at)]
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
