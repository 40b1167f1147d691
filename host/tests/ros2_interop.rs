//! ROS 2 against a DDS we did not write: the bridge reads a skin over a pseudo-terminal
//! and publishes on DDS (RustDDS); a subscriber on Eclipse Cyclone DDS's Python binding
//! (`cyclonedds`, in `target/interop-venv`), with the standard ROS 2 types and topic names,
//! receives the wrench and temperature with the values and stamps the skin sent.
//!
//! The one test that waits on the wall clock: DDS discovery takes real time, and the skin
//! here sends at a device's pace. Nothing is timed; the waits only leave room.
#![cfg(feature = "ros2")]
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

mod common;

use std::io::{BufRead, BufReader, Write};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, SystemTime};

use serialport::{SerialPort, TTYPort};
use vistaf_host::clock::unix_s;
use vistaf_protocol::*;

const SUMMARIES: u32 = 120;

/// Summary `seq`: a force that names it (1 N + 10 mN per step), the skin at 25 °C + 0.01·seq.
fn summary(seq: u32) -> Summary {
    Summary {
        seq,
        capture_us: 1_000_000 + u64::from(seq) * 50_000,
        latency_us: 1_500,
        force_mn: 1_000 + 10 * seq,
        temp_mean_centi_c: 2_500 + seq as i16,
        ..Default::default()
    }
}

#[test]
fn a_cyclone_dds_subscriber_receives_the_bridge_s_wrench_and_temperature() {
    let ws = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let python = ws.join("target/interop-venv/bin/python");
    assert!(
        python.exists(),
        "{} is missing: run scripts/install-deps.sh (the README's test command does)",
        python.display()
    );
    let mut listener = Command::new(&python)
        .arg(ws.join("tests/interop/dds_listen.py"))
        .args(["VSK_ROS2", "30", &SUMMARIES.to_string()])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(listener.stdout.take().unwrap()).lines();
    assert_eq!(lines.next().unwrap().unwrap(), "ready");

    // The skin: a Hello, then a summary every 50 ms, as a 20 Hz device sends them.
    let (mut master, slave) = TTYPort::pair().unwrap();
    let path = slave.name().unwrap();
    let mut bridge = Command::new(env!("CARGO_BIN_EXE_vistaf-host"))
        .args([
            "bridge",
            &format!("serial:{path}"),
            "--ros2",
            "--no-handshake",
        ])
        .args(["--summaries", &SUMMARIES.to_string(), "--duration-s", "60"])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Let the bridge open the port (what is written before is discarded) and DDS discover.
    std::thread::sleep(Duration::from_millis(1500));
    let started = unix_s(SystemTime::now());
    master
        .write_all(&common::frame(&common::hello("VSK-ROS2", 7)))
        .unwrap();
    for seq in 0..SUMMARIES {
        master
            .write_all(&common::frame(&DeviceMsg::Summary(summary(seq))))
            .unwrap();
        std::thread::sleep(Duration::from_millis(50));
    }
    let status = bridge.wait().unwrap();
    let mut stderr = String::new();
    std::io::Read::read_to_string(&mut bridge.stderr.take().unwrap(), &mut stderr).unwrap();
    assert!(status.success(), "{stderr}");
    drop(slave);
    // The last samples in flight, then the listener is done.
    std::thread::sleep(Duration::from_millis(1000));
    let _ = listener.kill();
    let _ = listener.wait();

    let mut seqs = Vec::new();
    let mut temperatures = 0;
    let finished = unix_s(SystemTime::now());
    for line in lines.map_while(Result::ok) {
        let v: serde_json::Value = serde_json::from_str(&line).unwrap();
        let stamp = v["sec"].as_f64().unwrap() + v["nanosec"].as_f64().unwrap() * 1e-9;
        assert!(
            (started - 1.0..=finished).contains(&stamp),
            "stamp {stamp} outside the run {started}..{finished}"
        );
        assert_eq!(v["frame_id"], "vistaf_VSK_ROS2");
        if v["topic"] == "wrench" {
            let f = &v["force"];
            assert_eq!((f[0].as_f64(), f[1].as_f64()), (Some(0.0), Some(0.0)));
            // The force on the skin is along −z: 1 N + 10 mN per summary.
            let seq = ((-f[2].as_f64().unwrap() - 1.0) / 0.01).round();
            // (The summary's SI view is f32: 1e-6 N of rounding.)
            assert!((-f[2].as_f64().unwrap() - (1.0 + 0.01 * seq)).abs() < 1e-5);
            seqs.push(seq as u32);
        } else {
            temperatures += 1;
        }
    }
    // Best effort over a real DDS stack: nearly all arrive, in order.
    assert!(
        seqs.len() as u32 >= SUMMARIES * 8 / 10,
        "{} of {SUMMARIES} wrenches received; bridge said: {stderr}",
        seqs.len()
    );
    assert!(
        seqs.windows(2).all(|w| w[0] < w[1]),
        "out of order: {seqs:?}"
    );
    assert!(seqs.iter().all(|&s| s < SUMMARIES));
    assert!(
        temperatures as u32 >= SUMMARIES * 8 / 10,
        "{temperatures} temperatures"
    );
    println!(
        "Cyclone DDS received {} of {SUMMARIES} wrenches and {temperatures} temperatures",
        seqs.len()
    );
}
