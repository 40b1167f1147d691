//! Recording decoded messages to CSV or JSON lines, flushed after every line so a killed
//! run loses at most the line being written.

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::SystemTime;

use serde::Serialize;
use serde_json::{json, Value};
use vistaf_protocol::{CalibrationId, DeviceMsg, KitCaptured, KitVerdict, Reading, Summary};

use crate::client::Received;
use crate::clock::{unix_s, MappedTime};
use crate::error::HostError;
use crate::maps::{chunk_json, WholeMap};

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

/// A summary in SI units with flag names: the one form every output of the host (CSV,
/// JSON lines, session files) is written from. Temperatures that were not measured are
/// `None` (JSON `null`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SummaryRecord {
    /// Sequence number.
    pub seq: u32,
    /// Device capture time, µs since the device's service started.
    pub capture_us: u64,
    /// Processing latency on the device, µs.
    pub latency_us: u32,
    /// Normal force, N.
    pub force_n: f32,
    /// Peak depth, mm.
    pub peak_depth_mm: f32,
    /// Contact area, mm².
    pub contact_area_mm2: f32,
    /// Deformation volume, mm³.
    pub volume_mm3: f32,
    /// Contact centre (x, y), mm.
    pub centroid_mm: Option<[f32; 2]>,
    /// Coldest measured block, °C.
    pub temp_min_c: Option<f32>,
    /// Mean over the measured blocks, °C.
    pub temp_mean_c: Option<f32>,
    /// Hottest measured block, °C.
    pub temp_max_c: Option<f32>,
    /// Temperature of the contact, °C.
    pub contact_temp_c: Option<f32>,
    /// Quality flags by name (empty when trusted).
    pub flags: Vec<&'static str>,
    /// Flag bits this host does not know (a newer device).
    pub unknown_flag_bits: u16,
    /// The readings a raised flag concerns (`Flag::concerns`), by name: not held to their
    /// tolerance in this frame. Every reading under a bit this host does not know.
    pub doubted: Vec<&'static str>,
}

impl From<&Summary> for SummaryRecord {
    fn from(s: &Summary) -> SummaryRecord {
        let si = s.si();
        let measured = |v: f32| (!v.is_nan()).then_some(v);
        SummaryRecord {
            seq: s.seq,
            capture_us: s.capture_us,
            latency_us: s.latency_us,
            force_n: si.force_n,
            peak_depth_mm: si.peak_depth_mm,
            contact_area_mm2: si.contact_area_mm2,
            volume_mm3: si.volume_mm3,
            centroid_mm: si.centroid_mm.map(|(x, y)| [x, y]),
            temp_min_c: measured(si.temp_min_c),
            temp_mean_c: measured(si.temp_mean_c),
            temp_max_c: measured(si.temp_max_c),
            contact_temp_c: si.contact_temp_c,
            flags: s.flags.iter().map(|f| f.name()).collect(),
            unknown_flag_bits: s.flags.unknown_bits(),
            doubted: s.flags.doubted().map(Reading::name).collect(),
        }
    }
}

/// CSV columns of a summary line.
pub const CSV_HEADER: &str = "device,received_unix_s,seq,capture_us,latency_us,force_n,\
peak_depth_mm,contact_area_mm2,volume_mm3,centroid_x_mm,centroid_y_mm,temp_min_c,\
temp_mean_c,temp_max_c,contact_temp_c,flags,captured_unix_s,captured_uncertainty_s";

impl SummaryRecord {
    /// One CSV line (no newline), in [`CSV_HEADER`]'s columns; an unmeasured temperature
    /// reads `NaN` in the block columns and is empty for the contact, and a capture time
    /// not mapped onto the host's clock is empty.
    pub fn csv_line(&self, device: &str, at: SystemTime, captured: Option<MappedTime>) -> String {
        let opt = |v: Option<f32>| v.map(|x| format!("{x}")).unwrap_or_default();
        let nan = |v: Option<f32>| v.unwrap_or(f32::NAN);
        let (host_s, uncertainty_s) = captured.map_or((String::new(), String::new()), |c| {
            (
                format!("{:.6}", c.host_s),
                format!("{:.6}", c.uncertainty_s),
            )
        });
        format!(
            "{device},{:.6},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{host_s},{uncertainty_s}",
            unix_s(at),
            self.seq,
            self.capture_us,
            self.latency_us,
            self.force_n,
            self.peak_depth_mm,
            self.contact_area_mm2,
            self.volume_mm3,
            opt(self.centroid_mm.map(|c| c[0])),
            opt(self.centroid_mm.map(|c| c[1])),
            nan(self.temp_min_c),
            nan(self.temp_mean_c),
            nan(self.temp_max_c),
            opt(self.contact_temp_c),
            self.flags.join("|"),
        )
    }
}

/// A summary line of the JSON-lines record: the device, the receive time, the capture
/// time on the host's clock (when mapped), the summary.
#[derive(Serialize)]
struct SummaryLine<'a> {
    r#type: &'static str,
    device: &'a str,
    received_unix_s: f64,
    captured_unix_s: Option<f64>,
    captured_uncertainty_s: Option<f64>,
    #[serde(flatten)]
    summary: SummaryRecord,
}

/// A map in SI units: depth cells in mm, temperature cells in °C, `null` where the device
/// trusts no value; the cell pitch in mm (`null` for a map whose cells do not fill it).
pub fn map_json(m: &vistaf_protocol::Map) -> Value {
    WholeMap::from_coarse(m).map_or(Value::Null, |w| w.to_json())
}

fn kit_captured_json(c: &KitCaptured) -> Value {
    let (name, unit, k) = c.step.quantity.si();
    json!({
        "quantity": name,
        "value": f64::from(c.step.value_milli) * k,
        "unit": unit,
        "frames": c.frames,
        "settle_s": f64::from(c.settle_ms) / 1000.0,
        "change_dn": f64::from(c.change_centi_dn) / 100.0,
    })
}

fn kit_verdict_json(v: &KitVerdict) -> Value {
    let (name, unit, k) = v.quantity.si();
    json!({
        "quantity": name,
        "samples": v.samples,
        "error": f64::from(v.error_milli) * k,
        "target": f64::from(v.target_milli) * k,
        "unit": unit,
        "pass": v.pass,
    })
}

/// A message as a JSON object: summaries as [`SummaryRecord`]s, maps in SI units
/// ([`map_json`]), everything else in its wire form.
pub fn message_json(device: &str, received: &Received) -> Value {
    let at = unix_s(received.at);
    match &received.msg {
        DeviceMsg::Summary(s) => serde_json::to_value(SummaryLine {
            r#type: "summary",
            device,
            received_unix_s: at,
            captured_unix_s: received.captured.map(|c| c.host_s),
            captured_uncertainty_s: received.captured.map(|c| c.uncertainty_s),
            summary: SummaryRecord::from(s),
        })
        .unwrap_or(Value::Null),
        other => {
            let (kind, body) = match other {
                DeviceMsg::Hello(h) => {
                    let mut v = json!(h);
                    v["calibration_id"] = json!(CalibrationId(h.calibration_id).to_string());
                    ("hello", v)
                }
                DeviceMsg::Map(m) => ("map", map_json(m)),
                DeviceMsg::MapChunk(c) => ("map_chunk", chunk_json(c)),
                DeviceMsg::Status(st) => ("status", json!(st)),
                DeviceMsg::Error(e) => ("error", json!(e)),
                DeviceMsg::Pong { nonce } => ("pong", json!({ "nonce": nonce })),
                DeviceMsg::Ack(c) => ("ack", json!(c)),
                DeviceMsg::Clock(c) => ("clock", json!(c)),
                DeviceMsg::Summary(_) => ("summary", Value::Null),
                DeviceMsg::KitCaptured(c) => ("kit_captured", kit_captured_json(c)),
                DeviceMsg::KitVerdict(v) => ("kit_verdict", kit_verdict_json(v)),
                DeviceMsg::CalibrationFitted(f) => (
                    "calibration_fitted",
                    json!({
                        "calibration_id": CalibrationId(f.calibration_id).to_string(),
                        "pass": f.pass,
                    }),
                ),
            };
            json!({ "type": kind, "device": device, "received_unix_s": at, "body": body })
        }
    }
}

/// Where a recorder's lines go: a file it can cut back to a length.
pub trait RecordFile: Write + Send + std::fmt::Debug {
    /// Cuts the file to `len` bytes and continues writing there.
    fn cut_to(&mut self, len: u64) -> std::io::Result<()>;
}

impl RecordFile for File {
    fn cut_to(&mut self, len: u64) -> std::io::Result<()> {
        use std::io::{Seek, SeekFrom};
        self.set_len(len)?;
        self.seek(SeekFrom::Start(len)).map(|_| ())
    }
}

/// Writes messages to a file, one whole line at a time: each line goes out in one write
/// and is flushed, and a write that fails (a full disk) is cut back off the file, so the
/// file always ends with a complete line and a killed run loses at most the line being
/// written.
#[derive(Debug)]
pub struct Recorder {
    path: PathBuf,
    format: Format,
    out: Box<dyn RecordFile>,
    /// Bytes of complete lines in the file.
    whole: u64,
    lines: u64,
}

/// Standard output as a record file: JSON lines for another program to read. A line that
/// fails to write cannot be taken back from a pipe; the recorder stops there.
#[derive(Debug)]
struct StdoutFile(std::io::Stdout);

impl Write for StdoutFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.0.flush()
    }
}

impl RecordFile for StdoutFile {
    fn cut_to(&mut self, _len: u64) -> std::io::Result<()> {
        Ok(())
    }
}

impl Recorder {
    /// Creates (or truncates) `path`; the format follows its extension, and `-` is JSON
    /// lines on standard output.
    pub fn create(path: &Path) -> Result<Recorder, HostError> {
        if path == Path::new("-") {
            return Recorder::to(
                path,
                Format::JsonLines,
                Box::new(StdoutFile(std::io::stdout())),
            );
        }
        let format = Format::from_path(path).ok_or_else(|| HostError::RecordFormat {
            path: path.display().to_string(),
        })?;
        let file = File::create(path).map_err(|cause| HostError::Record {
            path: path.display().to_string(),
            cause,
        })?;
        Recorder::to(path, format, Box::new(file))
    }

    /// A recorder writing `format` into `out` (named `path` in messages).
    pub fn to(
        path: &Path,
        format: Format,
        out: Box<dyn RecordFile>,
    ) -> Result<Recorder, HostError> {
        let mut rec = Recorder {
            path: path.to_path_buf(),
            format,
            out,
            whole: 0,
            lines: 0,
        };
        if format == Format::Csv {
            rec.line(CSV_HEADER)?;
        }
        Ok(rec)
    }

    fn line(&mut self, text: &str) -> Result<(), HostError> {
        let mut bytes = Vec::with_capacity(text.len() + 1);
        bytes.extend_from_slice(text.as_bytes());
        bytes.push(b'\n');
        match self.out.write_all(&bytes).and_then(|()| self.out.flush()) {
            Ok(()) => {
                self.whole += bytes.len() as u64;
                Ok(())
            }
            Err(cause) => {
                // What part of the line reached the file is cut off again.
                let _ = self.out.cut_to(self.whole);
                Err(HostError::Record {
                    path: self.path.display().to_string(),
                    cause,
                })
            }
        }
    }

    /// Records one message. CSV keeps summaries only; JSON lines keep everything.
    pub fn record(&mut self, device: &str, received: &Received) -> Result<(), HostError> {
        let text = match (self.format, &received.msg) {
            (Format::Csv, DeviceMsg::Summary(s)) => {
                SummaryRecord::from(s).csv_line(device, received.at, received.captured)
            }
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
            &Received::new(DeviceMsg::Summary(s), SystemTime::now()),
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

    /// A disk that fills up after `room` bytes: a write takes what fits, then fails.
    #[derive(Debug, Clone, Default)]
    struct Filling {
        bytes: std::sync::Arc<std::sync::Mutex<Vec<u8>>>,
        room: usize,
    }

    impl Write for Filling {
        fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
            let mut bytes = self.bytes.lock().unwrap();
            let n = b.len().min(self.room - bytes.len());
            if n == 0 {
                return Err(std::io::Error::from(std::io::ErrorKind::StorageFull));
            }
            bytes.extend_from_slice(&b[..n]);
            Ok(n)
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    impl RecordFile for Filling {
        fn cut_to(&mut self, len: u64) -> std::io::Result<()> {
            self.bytes.lock().unwrap().truncate(len as usize);
            Ok(())
        }
    }

    #[test]
    fn a_full_disk_leaves_only_whole_lines() {
        for format in [Format::Csv, Format::JsonLines] {
            let disk = Filling {
                room: 700,
                ..Default::default()
            };
            let mut rec = Recorder::to(Path::new("r"), format, Box::new(disk.clone())).unwrap();
            let mut failed = None;
            for seq in 0..100 {
                let r = Received::new(
                    DeviceMsg::Summary(Summary {
                        seq,
                        ..Default::default()
                    }),
                    SystemTime::now(),
                );
                if let Err(e) = rec.record("a", &r) {
                    failed = Some((seq, e));
                    break;
                }
            }
            let (seq, e) = failed.expect("the disk fills up");
            assert!(e.to_string().starts_with("writing r: "), "{e}");
            let text = String::from_utf8(disk.bytes.lock().unwrap().clone()).unwrap();
            assert!(
                text.ends_with('\n'),
                "{format:?}: torn last line in {text:?}"
            );
            let header = usize::from(format == Format::Csv);
            assert_eq!(text.lines().count(), header + seq as usize, "{format:?}");
            assert_eq!(rec.lines(), u64::from(seq));
        }
    }
}
