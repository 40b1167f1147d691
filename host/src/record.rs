//! Recording decoded messages to CSV or JSON lines, flushed after every line so a killed
//! run loses at most the line being written.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

use serde_json::{json, Value};
use vistaf_protocol::{DeviceMsg, Summary};

use crate::client::Received;

/// Output format, chosen from the file extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Comma-separated summaries, one header line.
    Csv,
    /// One JSON object per message.
    JsonLines,
}

impl Format {
    /// `.csv` → CSV, `.jsonl`/`.json`/`.ndjson` → JSON lines.
    pub fn from_path(path: &Path) -> Option<Format> {
        match path.extension()?.to_str()? {
            "csv" => Some(Format::Csv),
            "jsonl" | "ndjson" | "json" => Some(Format::JsonLines),
            _ => None,
        }
    }
}

/// Seconds since the Unix epoch, with µs resolution.
pub fn unix_s(t: SystemTime) -> f64 {
    t.duration_since(UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or(0.0)
}

/// CSV columns of a summary line.
pub const CSV_HEADER: &str = "device,received_unix_s,seq,capture_us,latency_us,force_n,\
peak_depth_mm,contact_area_mm2,volume_mm3,centroid_x_mm,centroid_y_mm,temp_min_c,\
temp_mean_c,temp_max_c,contact_temp_c,flags";

/// Flag names of a summary, `|`-separated (empty when trusted).
pub fn flag_names(s: &Summary) -> Vec<&'static str> {
    s.flags.iter().map(|f| f.name()).collect()
}

/// One CSV line (no newline) for a summary.
pub fn csv_line(device: &str, at: SystemTime, s: &Summary) -> String {
    let si = s.si();
    let opt = |v: Option<f32>| v.map(|x| format!("{x}")).unwrap_or_default();
    format!(
        "{device},{:.6},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
        unix_s(at),
        s.seq,
        s.capture_us,
        s.latency_us,
        si.force_n,
        si.peak_depth_mm,
        si.contact_area_mm2,
        si.volume_mm3,
        opt(si.centroid_mm.map(|c| c.0)),
        opt(si.centroid_mm.map(|c| c.1)),
        si.temp_min_c,
        si.temp_mean_c,
        si.temp_max_c,
        opt(si.contact_temp_c),
        flag_names(s).join("|"),
    )
}

/// A message as a JSON object: summaries in SI units with flag names, everything else in
/// its wire form.
pub fn message_json(device: &str, received: &Received) -> Value {
    let at = unix_s(received.at);
    match &received.msg {
        DeviceMsg::Summary(s) => {
            let si = s.si();
            json!({
                "type": "summary",
                "device": device,
                "received_unix_s": at,
                "seq": s.seq,
                "capture_us": s.capture_us,
                "latency_us": s.latency_us,
                "force_n": si.force_n,
                "peak_depth_mm": si.peak_depth_mm,
                "contact_area_mm2": si.contact_area_mm2,
                "volume_mm3": si.volume_mm3,
                "centroid_mm": si.centroid_mm.map(|(x, y)| [x, y]),
                "temp_min_c": si.temp_min_c,
                "temp_mean_c": si.temp_mean_c,
                "temp_max_c": si.temp_max_c,
                "contact_temp_c": si.contact_temp_c,
                "flags": flag_names(s),
                "unknown_flag_bits": s.flags.unknown_bits(),
            })
        }
        other => {
            let (kind, body) = match other {
                DeviceMsg::Hello(h) => ("hello", json!(h)),
                DeviceMsg::Map(m) => ("map", json!(m)),
                DeviceMsg::Status(st) => ("status", json!(st)),
                DeviceMsg::Error(e) => ("error", json!(e)),
                DeviceMsg::Pong { nonce } => ("pong", json!({ "nonce": nonce })),
                DeviceMsg::Ack(c) => ("ack", json!(c)),
                DeviceMsg::Summary(_) => ("summary", Value::Null),
            };
            json!({ "type": kind, "device": device, "received_unix_s": at, "body": body })
        }
    }
}

/// Writes messages to a file, one flushed line each.
#[derive(Debug)]
pub struct Recorder {
    path: PathBuf,
    format: Format,
    out: BufWriter<File>,
    lines: u64,
}

impl Recorder {
    /// Creates (or truncates) `path`; the format follows its extension.
    pub fn create(path: &Path) -> anyhow::Result<Recorder> {
        let format = Format::from_path(path).ok_or_else(|| {
            anyhow::anyhow!("{}: unknown extension (use .csv or .jsonl)", path.display())
        })?;
        let file = File::create(path)
            .map_err(|e| anyhow::anyhow!("cannot create {}: {e}", path.display()))?;
        let mut rec = Recorder {
            path: path.to_path_buf(),
            format,
            out: BufWriter::new(file),
            lines: 0,
        };
        if format == Format::Csv {
            rec.line(CSV_HEADER)?;
        }
        Ok(rec)
    }

    fn line(&mut self, text: &str) -> anyhow::Result<()> {
        writeln!(self.out, "{text}")
            .and_then(|()| self.out.flush())
            .map_err(|e| anyhow::anyhow!("writing {}: {e}", self.path.display()))
    }

    /// Records one message. CSV keeps summaries only; JSON lines keep everything.
    pub fn record(&mut self, device: &str, received: &Received) -> anyhow::Result<()> {
        let text = match (self.format, &received.msg) {
            (Format::Csv, DeviceMsg::Summary(s)) => csv_line(device, received.at, s),
            (Format::Csv, _) => return Ok(()),
            (Format::JsonLines, _) => message_json(device, received).to_string(),
        };
        self.line(&text)?;
        self.lines += 1;
        Ok(())
    }

    /// Lines recorded (not counting a CSV header).
    pub fn lines(&self) -> u64 {
        self.lines
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use vistaf_protocol::{Flag, QualityFlags};

    #[test]
    fn each_line_is_on_disk_as_soon_as_it_is_recorded() {
        let dir = std::env::temp_dir().join(format!("vistaf-rec-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("r.csv");
        let mut rec = Recorder::create(&path).unwrap();
        let s = Summary {
            seq: 5,
            force_mn: 1500,
            flags: QualityFlags::NONE.with(Flag::PhaseSlope),
            ..Default::default()
        };
        rec.record(
            "a",
            &Received {
                msg: DeviceMsg::Summary(s),
                at: SystemTime::now(),
            },
        )
        .unwrap();
        // Read back without closing the recorder: the line is already flushed.
        let text = std::fs::read_to_string(&path).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 2);
        assert_eq!(lines[0], CSV_HEADER);
        let cols: Vec<&str> = lines[1].split(',').collect();
        assert_eq!(cols.len(), CSV_HEADER.split(',').count());
        assert_eq!(cols[2], "5");
        assert_eq!(cols[5], "1.5");
        assert_eq!(cols[15], "phase_slope");
        assert!(Recorder::create(&dir.join("r.txt")).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
