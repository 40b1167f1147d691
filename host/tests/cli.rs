//! The `vistaf-host` binary on captured streams.
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

mod common;

use std::process::Command;

use vistaf_protocol::*;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_vistaf-host"))
}

fn temp(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("vistaf-host-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

#[test]
fn decode_turns_a_corrupted_capture_into_exactly_the_intact_frames() {
    let s = common::noisy_stream(3_000, 0x5eed);
    let path = temp("capture.bin");
    std::fs::write(&path, &s.bytes).unwrap();
    let out = bin()
        .args(["decode", path.to_str().unwrap(), "--json"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8(out.stdout).unwrap();
    let seqs: Vec<u32> = stdout
        .lines()
        .map(|l| {
            let v: serde_json::Value = serde_json::from_str(l).unwrap();
            assert_eq!(v["type"], "summary");
            let seq = v["seq"].as_u64().unwrap() as u32;
            let want = common::summary(seq).si();
            assert!((v["force_n"].as_f64().unwrap() - f64::from(want.force_n)).abs() < 1e-6);
            seq
        })
        .collect();
    assert_eq!(seqs, s.intact);
    let stderr = String::from_utf8(out.stderr).unwrap();
    let expected = format!(
        "{} frames decoded, {} dropped",
        s.intact.len(),
        s.expected_drops
    );
    assert!(
        stderr.contains(&expected),
        "stderr {stderr:?} lacks {expected:?}"
    );
}

#[test]
fn decode_reports_a_device_of_another_protocol() {
    // A Hello from a protocol v9 device with a different schema.
    let hello = DeviceMsg::Hello(Hello {
        protocol_version: 9,
        schema_hash: 42,
        firmware: FirmwareVersion {
            major: 9,
            minor: 0,
            patch: 0,
        },
        serial: heapless::String::new(),
        frame_width_px: 1,
        frame_height_px: 1,
        calibration_id: 0,
    });
    let path = temp("other.bin");
    std::fs::write(&path, common::frame(&hello)).unwrap();
    let out = bin()
        .args(["decode", path.to_str().unwrap()])
        .output()
        .unwrap();
    // The Hello itself decodes (its layout is frozen); the host names the versions.
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert!(stdout.contains("\"protocol_version\":9"), "{stdout}");
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(
        stderr.contains("device speaks protocol v9")
            && stderr.contains(&format!(
                "host speaks v{}",
                vistaf_protocol::PROTOCOL_VERSION
            )),
        "{stderr}"
    );
}

#[test]
fn missing_inputs_are_named() {
    let out = bin()
        .args(["decode", "/nonexistent/capture.bin"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(err.contains("/nonexistent/capture.bin"), "{err}");

    let out = bin()
        .args(["monitor", "serial:/dev/nonexistent-tty"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8(out.stderr)
        .unwrap()
        .contains("/dev/nonexistent-tty"));

    let out = bin()
        .args(["record", "-", "--out", "/tmp/x.txt"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8(out.stderr)
        .unwrap()
        .contains("unknown extension"));
}

#[test]
fn record_from_a_capture_writes_every_summary() {
    let s = common::noisy_stream(500, 7);
    let cap = temp("rec.bin");
    std::fs::write(&cap, &s.bytes).unwrap();
    let csv = temp("rec.csv");
    common::host_ok(&[
        "record",
        &format!("file:{}", cap.display()),
        "--out",
        csv.to_str().unwrap(),
    ]);
    let text = std::fs::read_to_string(&csv).unwrap();
    let seqs: Vec<u32> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(2).unwrap().parse().unwrap())
        .collect();
    assert_eq!(seqs, s.intact);
}
