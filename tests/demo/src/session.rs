//! The session file: what ran, what the device counted, the calibration, the strongest
//! press and its maps, and every summary.

use std::path::Path;

use anyhow::{Context, Result};
use vistaf_firmware::service::Counters;
use vistaf_pipeline::Calibration;

use crate::peak::Watched;

/// What `session.json` is made of.
pub struct Session<'a> {
    /// The pseudo-terminal the skin wrote to.
    pub port: &'a str,
    /// The device's counters at the end.
    pub counters: &'a Counters,
    /// The calibration it ran with.
    pub calibration: &'a Calibration,
    /// What the host saw.
    pub watched: &'a Watched,
}

/// Writes `out/session.json`.
pub fn write(out: &Path, s: &Session<'_>) -> Result<()> {
    let (c, w) = (s.counters, s.watched);
    let session = serde_json::json!({
        "scene": "demo",
        "link": s.port,
        "device": {
            "frames_captured": c.captured, "frames_processed": c.processed,
            "frames_dropped": c.dropped, "summaries_sent": c.sent,
        },
        "calibration": vistaf_firmware::report::calibration_json(s.calibration),
        "peak_contact": w.peak.as_ref().map(|p| serde_json::json!({
            "seq": p.maps.first().map(|m| m.seq),
            "force_n": p.summary.as_ref().map(|s| f64::from(s.force_mn) / 1000.0),
            "figure": crate::peak::PEAK_FIGURE,
        })),
        "summaries": "summaries.jsonl",
        "frames": w.summaries,
    });
    let path = out.join("session.json");
    std::fs::write(&path, serde_json::to_string_pretty(&session)? + "\n")
        .with_context(|| format!("writing {}", path.display()))
}
