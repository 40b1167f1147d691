//! MCAP recordings that Foxglove opens and that are also ROS 2 bags: one channel per skin
//! and topic, `ros2msg` schemas and CDR messages, plus a JSON channel per skin carrying the
//! whole summary in SI units (so every field plots against time without a ROS type).
//!
//! Chunks are small and flushed every second: a bridge that is killed loses at most the
//! last second; the file's index is written when the bridge finishes.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use mcap::records::MessageHeader;
use mcap::{WriteOptions, Writer};
use serde_json::json;

use super::Sink;
use crate::error::HostError;
use crate::ros2::Outgoing;

/// Chunk size: small, so a flush every second does not leave most of a chunk unwritten.
const CHUNK_BYTES: u64 = 64 * 1024;
/// How often what is written reaches the file.
const FLUSH_EVERY: Duration = Duration::from_secs(1);

/// The JSON schema of the summary channel: the fields Foxglove offers to plot.
fn summary_schema() -> String {
    let num = json!({ "type": ["number", "null"] });
    json!({
        "title": "vistaf summary",
        "type": "object",
        "properties": {
            "seq": { "type": "integer" },
            "capture_us": { "type": "integer", "description": "device clock, µs" },
            "captured_unix_s": num,
            "captured_uncertainty_s": num,
            "latency_us": { "type": "integer" },
            "force_n": num,
            "peak_depth_mm": num,
            "contact_area_mm2": num,
            "volume_mm3": num,
            "centroid_mm": { "type": ["array", "null"], "items": { "type": "number" } },
            "temp_min_c": num,
            "temp_mean_c": num,
            "temp_max_c": num,
            "contact_temp_c": num,
            "flags": { "type": "array", "items": { "type": "string" } },
            "doubted": {
                "type": "array",
                "items": { "type": "string" },
                "description": "readings a raised flag concerns"
            }
        }
    })
    .to_string()
}

/// Writes an MCAP file.
pub struct McapSink {
    path: PathBuf,
    writer: Option<Writer<BufWriter<File>>>,
    schemas: BTreeMap<String, u16>,
    channels: BTreeMap<String, (u16, u32)>,
    flushed: Instant,
    messages: u64,
}

impl std::fmt::Debug for McapSink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("McapSink")
            .field("path", &self.path)
            .field("messages", &self.messages)
            .finish_non_exhaustive()
    }
}

impl McapSink {
    /// Creates (or truncates) `path`.
    pub fn create(path: &Path) -> Result<McapSink, HostError> {
        let file = File::create(path).map_err(|cause| record_error(path, cause))?;
        let writer = WriteOptions::new()
            .compression(None)
            .profile("ros2")
            .chunk_size(Some(CHUNK_BYTES))
            .create(BufWriter::new(file))
            .map_err(|e| mcap_error(path, e))?;
        Ok(McapSink {
            path: path.to_path_buf(),
            writer: Some(writer),
            schemas: BTreeMap::new(),
            channels: BTreeMap::new(),
            flushed: Instant::now(),
            messages: 0,
        })
    }

    /// Messages written.
    pub fn messages(&self) -> u64 {
        self.messages
    }

    /// The open writer, and the file's path for its errors.
    fn open(&mut self) -> Result<(&mut Writer<BufWriter<File>>, &Path), HostError> {
        match self.writer.as_mut() {
            Some(w) => Ok((w, &self.path)),
            None => Err(record_error(
                &self.path,
                std::io::Error::other("the recording is finished"),
            )),
        }
    }

    /// The channel of `topic` (created with its schema on first use) and its next
    /// sequence number.
    fn channel(
        &mut self,
        topic: &str,
        schema: (&str, &str, &dyn Fn() -> String),
        message_encoding: &str,
    ) -> Result<(u16, u32), HostError> {
        if let Some((id, seq)) = self.channels.get_mut(topic) {
            *seq = seq.wrapping_add(1);
            return Ok((*id, *seq));
        }
        let (name, encoding, text) = schema;
        let schema_id = match self.schemas.get(name) {
            Some(id) => *id,
            None => {
                let (w, path) = self.open()?;
                let id = w
                    .add_schema(name, encoding, text().as_bytes())
                    .map_err(|e| mcap_error(path, e))?;
                self.schemas.insert(name.to_string(), id);
                id
            }
        };
        let (w, path) = self.open()?;
        let id = w
            .add_channel(schema_id, topic, message_encoding, &BTreeMap::new())
            .map_err(|e| mcap_error(path, e))?;
        self.channels.insert(topic.to_string(), (id, 0));
        Ok((id, 0))
    }

    fn write(&mut self, channel: (u16, u32), stamp_ns: i64, data: &[u8]) -> Result<(), HostError> {
        let time_ns = u64::try_from(stamp_ns).unwrap_or(0);
        let header = MessageHeader {
            channel_id: channel.0,
            sequence: channel.1,
            log_time: time_ns,
            publish_time: time_ns,
        };
        let (w, path) = self.open()?;
        w.write_to_known_channel(&header, data)
            .map_err(|e| mcap_error(path, e))?;
        self.messages += 1;
        if self.flushed.elapsed() >= FLUSH_EVERY {
            self.flushed = Instant::now();
            let (w, path) = self.open()?;
            w.flush().map_err(|e| mcap_error(path, e))?;
        }
        Ok(())
    }
}

impl Sink for McapSink {
    fn ros(&mut self, msg: &Outgoing) -> Result<(), HostError> {
        let channel = self.channel(
            &msg.topic,
            (msg.type_name, "ros2msg", &msg.definition),
            "cdr",
        )?;
        self.write(channel, msg.stamp_ns, &msg.cdr())
    }

    fn summary_json(
        &mut self,
        topic: &str,
        stamp_ns: i64,
        json: &serde_json::Value,
    ) -> Result<(), HostError> {
        let channel = self.channel(
            topic,
            ("vistaf.Summary", "jsonschema", &summary_schema),
            "json",
        )?;
        self.write(channel, stamp_ns, json.to_string().as_bytes())
    }

    fn finish(&mut self) -> Result<(), HostError> {
        if let Some(mut w) = self.writer.take() {
            w.finish().map_err(|e| mcap_error(&self.path, e))?;
        }
        Ok(())
    }
}

fn record_error(path: &Path, cause: std::io::Error) -> HostError {
    HostError::Record {
        path: path.display().to_string(),
        cause,
    }
}

fn mcap_error(path: &Path, e: mcap::McapError) -> HostError {
    record_error(path, std::io::Error::other(e))
}
