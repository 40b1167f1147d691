//! Wire stability: the framed bytes of one sample of every message are pinned in
//! `tests/golden/<message>.bin`. A change to a wire type changes these bytes and fails here;
//! if the change is intended, bump `PROTOCOL_VERSION`, then regenerate with
//! `VISTAF_BLESS=1 cargo test -p vistaf-protocol --test golden` and commit the files.
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

mod common;

use std::path::PathBuf;
use vistaf_protocol::frame::{DEVICE_FRAME_MAX, HOST_FRAME_MAX};
use vistaf_protocol::*;

fn golden_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/golden")
}

fn device_samples() -> Vec<(&'static str, DeviceMsg)> {
    vec![
        (
            "hello",
            DeviceMsg::Hello(Hello {
                protocol_version: 1,
                schema_hash: 0x0123_4567_89ab_cdef,
                firmware: FirmwareVersion {
                    major: 0,
                    minor: 1,
                    patch: 0,
                },
                serial: heapless::String::from("VSK-000042"),
                frame_width_px: 640,
                frame_height_px: 480,
                calibration_id: 0xdead_beef,
            }),
        ),
        ("summary", DeviceMsg::Summary(common::contact_summary())),
        (
            "map",
            DeviceMsg::Map(Map {
                seq: 7,
                kind: MapKind::Depth,
                width: 3,
                height: 2,
                cell_pitch_centi_mm: 125,
                cells: heapless::Vec::from_slice(&[0, 150, msg::MAP_NO_DATA, -2, 2000, 1]).unwrap(),
            }),
        ),
        (
            "status",
            DeviceMsg::Status(Status {
                uptime_ms: 86_400_000,
                state: RunState::Streaming,
                max_rate_hz: 0,
                frames_captured: 2_592_000,
                frames_processed: 2_591_990,
                frames_dropped: 10,
                bad_frames: 1,
                link_frames_dropped: 2,
                reference_age_ms: 60_000,
                camera_restarts: 0,
                latency_p50_us: 9_800,
                latency_p99_us: 14_250,
            }),
        ),
        (
            "error",
            DeviceMsg::Error(DeviceError {
                code: ErrorCode::CameraLost,
                detail: heapless::String::from("/dev/video0: no such device"),
            }),
        ),
        ("pong", DeviceMsg::Pong { nonce: 0xfeed }),
        ("ack", DeviceMsg::Ack(Command::CaptureReference)),
        (
            "clock",
            DeviceMsg::Clock(ClockReading {
                nonce: 0xfeed,
                received_us: 3_600_000_123,
                sent_us: 3_600_000_456,
            }),
        ),
        (
            "kit_captured",
            DeviceMsg::KitCaptured(KitCaptured {
                step: KitStep {
                    quantity: KitQuantity::Force,
                    value_milli: 15_000,
                },
                frames: 7,
                settle_ms: 1_250,
                change_centi_dn: 42,
            }),
        ),
        (
            "kit_verdict",
            DeviceMsg::KitVerdict(KitVerdict {
                quantity: KitQuantity::Temperature,
                samples: 10_868,
                error_milli: 338,
                target_milli: 300,
                pass: false,
            }),
        ),
        (
            "calibration_fitted",
            DeviceMsg::CalibrationFitted(CalibrationFitted {
                calibration_id: 0xb545_9c92,
                pass: true,
            }),
        ),
        (
            "map_chunk",
            DeviceMsg::MapChunk(MapChunk {
                seq: 7,
                kind: MapKind::Camera,
                width: 320,
                height: 240,
                cell_pitch_nm: 125_000,
                first_cell: 76_032,
                cells: heapless::Vec::from_slice(&[0x7bef, -1, 0, 0x1f]).unwrap(),
            }),
        ),
    ]
}

fn host_samples() -> Vec<(&'static str, HostMsg)> {
    vec![
        ("ping", HostMsg::Ping { nonce: 0xfeed }),
        ("get_info", HostMsg::GetInfo),
        ("capture_reference", HostMsg::CaptureReference),
        ("set_rate", HostMsg::SetRate { max_rate_hz: 60 }),
        (
            "set_led",
            HostMsg::SetLed(SetLed {
                rgb: Rgb {
                    r: 210,
                    g: 245,
                    b: 125,
                },
                brightness: 30,
                lit_mask: 0x00AA_AAAA,
            }),
        ),
        ("request_map", HostMsg::RequestMap(MapKind::Temperature)),
        ("request_full_map", HostMsg::RequestFullMap(MapKind::Depth)),
        ("start", HostMsg::Start),
        ("stop", HostMsg::Stop),
        ("clock_request", HostMsg::Clock { nonce: 0xfeed }),
        (
            "kit_capture",
            HostMsg::KitCapture(KitStep {
                quantity: KitQuantity::Depth,
                value_milli: 500,
            }),
        ),
        ("kit_fit", HostMsg::KitFit),
        (
            "calibration_activate",
            HostMsg::CalibrationActivate {
                calibration_id: 0xb545_9c92,
            },
        ),
        ("calibration_rollback", HostMsg::CalibrationRollback),
    ]
}

fn check(name: &str, framed: &[u8]) {
    let path = golden_dir().join(format!("{name}.bin"));
    if std::env::var_os("VISTAF_BLESS").is_some() {
        std::fs::create_dir_all(golden_dir()).unwrap();
        std::fs::write(&path, framed).unwrap();
        return;
    }
    let want = std::fs::read(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (run with VISTAF_BLESS=1 to create)",
            path.display()
        )
    });
    assert_eq!(
        framed,
        want.as_slice(),
        "{name}: encoding changed from {}",
        path.display()
    );
}

#[test]
fn every_device_message_matches_its_golden_frame() {
    for (name, msg) in device_samples() {
        let mut buf = [0u8; DEVICE_FRAME_MAX];
        let n = encode(&msg, &mut buf).unwrap();
        check(name, &buf[..n]);
        let mut dec = DeviceDecoder::new();
        let mut got = Vec::new();
        dec.push(
            &std::fs::read(golden_dir().join(format!("{name}.bin"))).unwrap(),
            |r| got.push(r.unwrap()),
        );
        assert_eq!(
            got,
            vec![msg],
            "{name}: golden file does not decode to the sample"
        );
    }
}

#[test]
fn every_host_message_matches_its_golden_frame() {
    for (name, msg) in host_samples() {
        let mut buf = [0u8; HOST_FRAME_MAX];
        let n = encode(&msg, &mut buf).unwrap();
        check(name, &buf[..n]);
        let mut dec = HostDecoder::new();
        let mut got = Vec::new();
        dec.push(
            &std::fs::read(golden_dir().join(format!("{name}.bin"))).unwrap(),
            |r| got.push(r.unwrap()),
        );
        assert_eq!(
            got,
            vec![msg],
            "{name}: golden file does not decode to the sample"
        );
    }
}

#[test]
fn every_golden_file_has_a_sample() {
    let names: Vec<String> = device_samples()
        .iter()
        .map(|(n, _)| n.to_string())
        .chain(host_samples().iter().map(|(n, _)| n.to_string()))
        .collect();
    for entry in std::fs::read_dir(golden_dir()).unwrap() {
        let file = entry.unwrap().file_name().into_string().unwrap();
        let stem = file.trim_end_matches(".bin");
        assert!(names.iter().any(|n| n == stem), "stale golden file {file}");
    }
}

/// The schema hash is pinned: a change to any wire type changes it. When this fails,
/// bump `PROTOCOL_VERSION` and update the constant below together with the golden files.
#[test]
fn schema_hash_is_pinned() {
    assert_eq!(PROTOCOL_VERSION, 11);
    assert_eq!(
        schema_hash(),
        PINNED_SCHEMA_HASH,
        "schema changed: {:#018x}",
        schema_hash()
    );
}

const PINNED_SCHEMA_HASH: u64 = 0xc9d8_ea77_8716_206a;

#[test]
fn a_hello_of_another_version_is_named_not_misread() {
    // A future Hello: the next version, a different hash, and a field this build does not know.
    let mut payload = Vec::new();
    payload.extend(
        postcard::to_stdvec(&(0u32, PROTOCOL_VERSION + 1, 0x1111_2222_3333_4444u64)).unwrap(),
    );
    payload.extend([0xff, 0xff, 0xff, 0xff, 0xff, 0xff]);
    let got = decoded(&payload);
    assert_eq!(
        got,
        vec![Err(FrameError::ProtocolMismatch {
            protocol_version: PROTOCOL_VERSION + 1,
            schema_hash: 0x1111_2222_3333_4444
        })]
    );
    let text = got[0].clone().unwrap_err().to_string();
    let (next, this) = (
        format!("v{}", PROTOCOL_VERSION + 1),
        format!("v{PROTOCOL_VERSION}"),
    );
    assert!(text.contains(&next) && text.contains(&this), "{text}");
}

/// A Hello of this very version and schema that does not decode (a serial that is not
/// UTF-8) is a malformed frame, not a version mismatch.
#[test]
fn a_malformed_hello_of_this_version_is_a_bad_frame() {
    let mut payload = Vec::new();
    payload.extend(postcard::to_stdvec(&(0u32, PROTOCOL_VERSION, schema_hash())).unwrap());
    payload.extend([0x00, 0x00, 0x00, 0x02, 0xff, 0xfe]);
    assert_eq!(decoded(&payload), vec![Err(FrameError::Decode)]);
}

/// A map whose cells do not fill its size decodes, but is dropped as not a map.
#[test]
fn a_map_whose_cells_do_not_fill_it_is_dropped() {
    let mut m = Map {
        seq: 1,
        kind: MapKind::Depth,
        width: 3,
        height: 2,
        cell_pitch_centi_mm: 100,
        cells: heapless::Vec::new(),
    };
    for v in 0..5 {
        m.cells.push(v).unwrap();
    }
    let payload = postcard::to_stdvec(&DeviceMsg::Map(m.clone())).unwrap();
    assert_eq!(decoded(&payload), vec![Err(FrameError::Decode)]);
    m.cells.push(5).unwrap();
    let payload = postcard::to_stdvec(&DeviceMsg::Map(m.clone())).unwrap();
    assert_eq!(decoded(&payload), vec![Ok(DeviceMsg::Map(m))]);
}

/// What a device decoder makes of one frame carrying `payload`.
fn decoded(payload: &[u8]) -> Vec<Result<DeviceMsg, FrameError>> {
    let mut body = payload.to_vec();
    body.extend(frame::CRC32.checksum(payload).to_le_bytes());
    let mut wire = vec![0u8];
    wire.extend(cobs_encode(&body));
    wire.push(0);
    let mut dec = DeviceDecoder::new();
    let mut got = Vec::new();
    dec.push(&wire, |r| got.push(r));
    got
}

fn cobs_encode(data: &[u8]) -> Vec<u8> {
    // Reference COBS encoder, independent of the crate under test.
    let mut out = vec![0u8];
    let mut code_at = 0;
    let mut code = 1u8;
    for &b in data {
        if b == 0 {
            out[code_at] = code;
            code_at = out.len();
            out.push(0);
            code = 1;
        } else {
            out.push(b);
            code += 1;
            if code == 0xff {
                out[code_at] = code;
                code_at = out.len();
                out.push(0);
                code = 1;
            }
        }
    }
    out[code_at] = code;
    out
}
