//! The stream and the recordings read by code we did not write in Rust: the pure-Python
//! serial reader (`host/python/vistaf_serial.py`) against the Rust decoder on golden and
//! damaged streams, and the bridge's MCAP file decoded by the official Python readers
//! (`mcap`, `mcap-ros2-support`, installed into `target/interop-venv` by
//! `scripts/install-deps.sh`), back to the values the device sent.
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;
use vistaf_host::record::SummaryRecord;
use vistaf_protocol::*;

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("vistaf-interop-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// Runs `python` on `args`; its standard output as JSON lines.
fn json_lines(python: &Path, args: &[&str]) -> Vec<Value> {
    let out = Command::new(python)
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("{}: {e}", python.display()));
    assert!(
        out.status.success(),
        "{} {args:?}: {}",
        python.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

fn close(a: &Value, b: f64) -> bool {
    a.as_f64()
        .is_some_and(|a| (a - b).abs() <= 1e-6 * b.abs().max(1.0))
}

fn hello() -> DeviceMsg {
    common::hello("VSK-0042", 0xb545_9c92)
}

/// The device's status report `i`, one per second of uptime.
fn status(i: u64) -> DeviceMsg {
    DeviceMsg::Status(Status {
        uptime_ms: 5_000 + 1_000 * i,
        state: RunState::Streaming,
        max_rate_hz: 0,
        frames_captured: 150,
        frames_processed: 149,
        frames_dropped: 1,
        bad_frames: 0,
        link_frames_dropped: 0,
        reference_age_ms: 4_000,
        camera_restarts: 0,
        latency_p50_us: 10_200 + 10 * i as u32,
        latency_p99_us: 15_000,
    })
}

/// A depth and a temperature map of the frame of summary `seq`, each with a cell of no data.
fn maps(seq: u32) -> [Map; 2] {
    let map = |kind, cells: &[i16]| Map {
        seq,
        kind,
        width: 3,
        height: 2,
        cell_pitch_centi_mm: 125,
        cells: heapless::Vec::from_slice(cells).unwrap(),
    };
    [
        map(MapKind::Depth, &[0, 150, msg::MAP_NO_DATA, 900, 2000, 1]),
        map(
            MapKind::Temperature,
            &[2500, 2510, 3990, msg::MAP_NO_DATA, 2480, 2501],
        ),
    ]
}

/// Every field of a Python summary equals the Rust reading of the same summary.
fn assert_same_summary(py: &Value, s: &Summary) {
    let r = SummaryRecord::from(s);
    let rust = serde_json::to_value(&r).unwrap();
    for key in [
        "seq",
        "capture_us",
        "latency_us",
        "flags",
        "unknown_flag_bits",
        "doubted",
        "centroid_mm",
    ] {
        let (a, b) = (&py[key], &rust[key]);
        let same = match (a.as_array(), b.as_array()) {
            (Some(x), Some(y)) if key == "centroid_mm" => {
                x.len() == y.len() && x.iter().zip(y).all(|(p, q)| close(p, q.as_f64().unwrap()))
            }
            _ => a == b,
        };
        assert!(same, "seq {}: {key} {a} vs {b}", s.seq);
    }
    for key in [
        "force_n",
        "peak_depth_mm",
        "contact_area_mm2",
        "volume_mm3",
        "temp_min_c",
        "temp_mean_c",
        "temp_max_c",
        "contact_temp_c",
    ] {
        let (a, b) = (&py[key], &rust[key]);
        let same = match b.as_f64() {
            Some(v) => close(a, v),
            None => a.is_null(),
        };
        assert!(same, "seq {}: {key} {a} vs {b}", s.seq);
    }
}

#[test]
fn the_python_reader_decodes_what_the_rust_decoder_does() {
    // The golden summary, then a noisy stream: corrupted frames and garbage between frames.
    let golden = std::fs::read(workspace().join("protocol/tests/golden/summary.bin")).unwrap();
    let noisy = common::noisy_stream(600, 0x5eed);
    let mut bytes = common::frame(&hello());
    bytes.extend(&golden);
    bytes.extend(&noisy.bytes);
    bytes.extend(common::frame(&status(0)));
    let path = temp("python-reader.bin");
    std::fs::write(&path, &bytes).unwrap();

    let mut rust = Vec::new();
    let mut dec = DeviceDecoder::new();
    dec.push(&bytes, |r| {
        if let Ok(m) = r {
            rust.push(m);
        }
    });
    let script = workspace().join("host/python/vistaf_serial.py");
    let py = json_lines(
        Path::new("python3"),
        &[script.to_str().unwrap(), "--decode", path.to_str().unwrap()],
    );
    assert_eq!(py.len(), rust.len(), "one Python message per Rust message");
    for (p, r) in py.iter().zip(&rust) {
        match r {
            DeviceMsg::Summary(s) => assert_same_summary(p, s),
            DeviceMsg::Hello(h) => {
                assert_eq!(p["type"], "hello");
                assert_eq!(p["compatible"], true);
                assert_eq!(p["serial"], h.serial.as_str());
                assert_eq!(p["calibration_id"], format!("{:08x}", h.calibration_id));
            }
            DeviceMsg::Status(st) => {
                assert_eq!(p["type"], "status");
                assert_eq!(p["frames_processed"], st.frames_processed);
                assert_eq!(p["state"], "Streaming");
            }
            other => panic!("unexpected {other:?}"),
        }
    }
    assert_eq!(
        rust.iter()
            .filter(|m| matches!(m, DeviceMsg::Summary(_)))
            .count(),
        1 + noisy.intact.len()
    );
}

#[test]
fn the_bridge_s_mcap_decodes_with_the_official_readers_to_what_the_device_sent() {
    let python = workspace().join("target/interop-venv/bin/python");
    assert!(
        python.exists(),
        "{} is missing: run scripts/install-deps.sh (the README's test command does)",
        python.display()
    );
    let summaries: Vec<Summary> = (0..120).map(common::summary).collect();
    let mut bytes = common::frame(&hello());
    for (i, s) in summaries.iter().enumerate() {
        // A status a second, each after a summary that raises a flag.
        if i % 30 == 1 {
            bytes.extend(common::frame(&status(i as u64 / 30)));
        }
        bytes.extend(common::frame(&DeviceMsg::Summary(*s)));
        if i == 10 {
            for m in maps(s.seq) {
                bytes.extend(common::frame(&DeviceMsg::Map(m)));
            }
        }
    }
    let capture = temp("bridge.bin");
    std::fs::write(&capture, &bytes).unwrap();
    let mcap = temp("bridge.mcap");
    common::host_ok(&[
        "bridge",
        &format!("file:{}", capture.display()),
        "--mcap",
        mcap.to_str().unwrap(),
        "--frame-id",
        "palm",
    ]);

    let script = workspace().join("tests/interop/mcap_dump.py");
    let msgs = json_lines(&python, &[script.to_str().unwrap(), mcap.to_str().unwrap()]);
    let on = |topic: &str| -> Vec<&Value> { msgs.iter().filter(|m| m["topic"] == topic).collect() };
    let stamp_ns = |m: &Value| {
        let st = &m["body"]["header"]["stamp"];
        st["sec"].as_i64().unwrap() * 1_000_000_000 + st["nanosec"].as_i64().unwrap()
    };

    // One wrench per summary: the force on the skin along −z, stamped at capture.
    let wrench = on("/vistaf/VSK_0042/wrench");
    assert_eq!(wrench.len(), summaries.len());
    for (m, s) in wrench.iter().zip(&summaries) {
        assert_eq!(m["schema"], "geometry_msgs/msg/WrenchStamped");
        assert_eq!(m["body"]["header"]["frame_id"], "palm");
        assert!(close(
            &m["body"]["wrench"]["force"]["z"],
            -f64::from(s.force_mn) / 1e3
        ));
        assert_eq!(stamp_ns(m), s.capture_us as i64 * 1000);
        assert_eq!(m["log_time"].as_i64(), Some(s.capture_us as i64 * 1000));
    }
    // A contact point for each summary with contact, in metres.
    let with_contact: Vec<&Summary> = summaries.iter().filter(|s| s.centroid.is_some()).collect();
    let contact = on("/vistaf/VSK_0042/contact");
    assert_eq!(contact.len(), with_contact.len());
    for (m, s) in contact.iter().zip(&with_contact) {
        let c = s.centroid.unwrap();
        assert!(close(&m["body"]["point"]["x"], f64::from(c.x) * 1e-4));
        assert!(close(&m["body"]["point"]["y"], f64::from(c.y) * 1e-4));
    }
    // Temperatures: the contact's where there is one, the skin's mean always.
    let contact_t = on("/vistaf/VSK_0042/contact_temperature");
    assert_eq!(contact_t.len(), with_contact.len());
    for (m, s) in contact_t.iter().zip(&with_contact) {
        let c = f64::from(s.contact_temp_centi_c.unwrap()) / 100.0;
        assert!(close(&m["body"]["temperature"], c));
    }
    let skin_t = on("/vistaf/VSK_0042/skin_temperature");
    assert_eq!(skin_t.len(), summaries.len());
    for (m, s) in skin_t.iter().zip(&summaries) {
        assert!(close(
            &m["body"]["temperature"],
            f64::from(s.temp_mean_centi_c) / 100.0
        ));
    }
    // The whole summary as JSON, for plotting any field.
    let json = on("/vistaf/VSK_0042/summary");
    assert_eq!(json.len(), summaries.len());
    for (m, s) in json.iter().zip(&summaries) {
        assert_eq!(m["schema_encoding"], "jsonschema");
        assert_same_summary(&m["body"], s);
    }
    // The maps as 32FC1 images, stamped as the summary of their frame: depth in m,
    // temperature in °C, NaN where there is no value.
    for (topic, m, scale) in [
        ("/vistaf/VSK_0042/depth", &maps(10)[0], 1e-6),
        ("/vistaf/VSK_0042/temperature_map", &maps(10)[1], 1e-2),
    ] {
        let img = on(topic);
        assert_eq!(img.len(), 1, "{topic}");
        let b = &img[0]["body"];
        assert_eq!(b["encoding"], "32FC1");
        assert_eq!(
            (b["width"].as_u64(), b["height"].as_u64()),
            (Some(3), Some(2))
        );
        assert_eq!(b["step"], 12);
        assert_eq!(stamp_ns(img[0]), summaries[10].capture_us as i64 * 1000);
        let data: Vec<u8> = b["data"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_u64().unwrap() as u8)
            .collect();
        let px: Vec<f32> = data
            .chunks(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        for (p, &c) in px.iter().zip(&m.cells) {
            if c == msg::MAP_NO_DATA {
                assert!(p.is_nan(), "{topic}: {p} for no data");
            } else {
                let want = f64::from(c) * scale;
                assert!(
                    (f64::from(*p) - want).abs() <= 1e-6 * want.abs().max(1.0),
                    "{topic}: {p} for {c}"
                );
            }
        }
    }
    // Health on /diagnostics, per Status.
    let diag = on("/diagnostics");
    assert_eq!(diag.len(), 4);
    let status = &diag[0]["body"]["status"][0];
    assert_eq!(status["hardware_id"], "VSK-0042");
    let values = status["values"].as_array().unwrap();
    let value = |k: &str| values.iter().find(|v| v["key"] == k).unwrap()["value"].clone();
    assert_eq!(value("calibration_id"), "b5459c92");
    // Each report's readings doubted are those its latest summary's flags concern.
    for d in &diag {
        let values = d["body"]["status"][0]["values"].as_array().unwrap();
        let value = |k: &str| values.iter().find(|v| v["key"] == k).unwrap()["value"].clone();
        let flags: QualityFlags = value("flags")
            .as_str()
            .unwrap()
            .split('|')
            .filter_map(Flag::from_name)
            .collect();
        assert!(!flags.is_empty(), "{d}");
        let doubted: Vec<&str> = flags.doubted().map(Reading::name).collect();
        assert_eq!(value("doubted"), doubted.join("|"));
    }
    assert_eq!(value("frames_dropped"), "1");
    // 30 summaries between reports a second apart.
    let later = diag[1]["body"]["status"][0]["values"].as_array().unwrap();
    let rate = later
        .iter()
        .find(|v| v["key"] == "summary_rate_hz")
        .unwrap();
    assert_eq!(rate["value"], "30.0");
}
