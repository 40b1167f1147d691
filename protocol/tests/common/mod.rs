//! Strategies and sample messages shared by the protocol tests.
#![allow(dead_code, clippy::unwrap_used)]

use proptest::prelude::*;
use vistaf_protocol::msg::{ERROR_DETAIL_MAX_LEN, MAP_MAX_CELLS, SERIAL_MAX_LEN};
use vistaf_protocol::*;

pub fn arb_flags() -> impl Strategy<Value = QualityFlags> {
    any::<u16>().prop_map(QualityFlags)
}

prop_compose! {
    pub fn arb_summary()(
        seq in any::<u32>(), capture_us in any::<u64>(), latency_us in any::<u32>(),
        force_mn in any::<u32>(), peak_depth_um in any::<u32>(),
        area in any::<u32>(), vol in any::<u32>(),
        centroid in proptest::option::of((any::<i16>(), any::<i16>())),
        temps in any::<(i16, i16, i16)>(), contact in proptest::option::of(any::<i16>()),
        flags in arb_flags(),
    ) -> Summary {
        Summary {
            seq, capture_us, latency_us, force_mn, peak_depth_um,
            contact_area_centi_mm2: area, volume_milli_mm3: vol,
            centroid: centroid.map(|(x, y)| CentroidDeciMm { x, y }),
            temp_min_centi_c: temps.0, temp_mean_centi_c: temps.1, temp_max_centi_c: temps.2,
            contact_temp_centi_c: contact, flags,
        }
    }
}

fn arb_string<const N: usize>() -> impl Strategy<Value = heapless::String<N>> {
    proptest::collection::vec(any::<char>(), 0..N).prop_map(|chars| {
        let mut s = heapless::String::<N>::new();
        for c in chars {
            if s.push(c).is_err() {
                break;
            }
        }
        s
    })
}

fn arb_map() -> impl Strategy<Value = Map> {
    (
        1u8..=32,
        1u8..=24,
        any::<u32>(),
        any::<bool>(),
        any::<u16>(),
    )
        .prop_flat_map(|(w, h, seq, depth, pitch)| {
            let n = usize::from(w) * usize::from(h);
            proptest::collection::vec(any::<i16>(), n).prop_map(move |cells| Map {
                seq,
                kind: if depth {
                    MapKind::Depth
                } else {
                    MapKind::Temperature
                },
                width: w,
                height: h,
                cell_pitch_centi_mm: pitch,
                cells: heapless::Vec::from_slice(&cells).unwrap(),
            })
        })
}

fn arb_run_state() -> impl Strategy<Value = RunState> {
    prop_oneof![
        Just(RunState::Stopped),
        Just(RunState::Streaming),
        Just(RunState::Referencing),
        Just(RunState::CameraLost)
    ]
}

fn arb_error_code() -> impl Strategy<Value = ErrorCode> {
    prop_oneof![
        Just(ErrorCode::CameraLost),
        Just(ErrorCode::BadFrame),
        Just(ErrorCode::UnsupportedCommand),
        Just(ErrorCode::InvalidArgument),
        Just(ErrorCode::Calibration),
        Just(ErrorCode::LedFault),
        Just(ErrorCode::Internal)
    ]
}

fn arb_command() -> impl Strategy<Value = Command> {
    prop_oneof![
        Just(Command::CaptureReference),
        Just(Command::SetRate),
        Just(Command::SetLed),
        Just(Command::RequestMap),
        Just(Command::Start),
        Just(Command::Stop),
        Just(Command::RequestFullMap)
    ]
}

/// A piece of a full map that lies inside its map (the worst case: a whole piece of
/// cells at their widest encoding is in the mix).
fn arb_map_chunk() -> impl Strategy<Value = MapChunk> {
    (
        any::<u32>(),
        prop_oneof![
            Just(MapKind::Depth),
            Just(MapKind::Temperature),
            Just(MapKind::Camera)
        ],
        (1u16..=800, 1u16..=600),
        any::<u32>(),
        1usize..=MAP_MAX_CELLS,
    )
        .prop_flat_map(|(seq, kind, (w, h), pitch, len)| {
            let total = usize::from(w) * usize::from(h);
            let len = len.min(total);
            (
                0..=total - len,
                proptest::collection::vec(any::<i16>(), len),
            )
                .prop_map(move |(first, cells)| MapChunk {
                    seq,
                    kind,
                    width: w,
                    height: h,
                    cell_pitch_nm: pitch,
                    first_cell: first as u32,
                    cells: heapless::Vec::from_slice(&cells).unwrap(),
                })
        })
}

pub fn arb_device_msg() -> impl Strategy<Value = DeviceMsg> {
    prop_oneof![
        1 => (any::<u16>(), any::<u64>(), any::<(u8, u8, u8)>(), arb_string::<SERIAL_MAX_LEN>(),
         any::<(u16, u16, u32)>())
            .prop_map(|(v, h, fw, serial, (w, hh, cal))| DeviceMsg::Hello(Hello {
                protocol_version: v,
                schema_hash: h,
                firmware: FirmwareVersion { major: fw.0, minor: fw.1, patch: fw.2 },
                serial,
                frame_width_px: w,
                frame_height_px: hh,
                calibration_id: cal,
            })),
        4 => arb_summary().prop_map(DeviceMsg::Summary),
        1 => arb_map().prop_map(DeviceMsg::Map),
        1 => arb_map_chunk().prop_map(DeviceMsg::MapChunk),
        1 => (any::<u64>(), arb_run_state(), any::<u16>(), any::<[u32; 8]>(), any::<u16>()).prop_map(
            |(uptime_ms, state, max_rate_hz, c, camera_restarts)| DeviceMsg::Status(Status {
                uptime_ms,
                state,
                max_rate_hz,
                frames_captured: c[0],
                frames_processed: c[1],
                frames_dropped: c[2],
                bad_frames: c[3],
                link_frames_dropped: c[4],
                reference_age_ms: c[5],
                camera_restarts,
                latency_p50_us: c[6],
                latency_p99_us: c[7],
            })
        ),
        1 => (arb_error_code(), arb_string::<ERROR_DETAIL_MAX_LEN>())
            .prop_map(|(code, detail)| DeviceMsg::Error(DeviceError { code, detail })),
        1 => any::<u32>().prop_map(|nonce| DeviceMsg::Pong { nonce }),
        1 => arb_command().prop_map(DeviceMsg::Ack),
    ]
}

pub fn arb_host_msg() -> impl Strategy<Value = HostMsg> {
    prop_oneof![
        any::<u32>().prop_map(|nonce| HostMsg::Ping { nonce }),
        Just(HostMsg::GetInfo),
        Just(HostMsg::CaptureReference),
        any::<u16>().prop_map(|max_rate_hz| HostMsg::SetRate { max_rate_hz }),
        (any::<[u8; 4]>(), any::<u32>()).prop_map(|(c, lit_mask)| HostMsg::SetLed(SetLed {
            rgb: Rgb {
                r: c[0],
                g: c[1],
                b: c[2]
            },
            brightness: c[3],
            lit_mask,
        })),
        prop_oneof![Just(MapKind::Depth), Just(MapKind::Temperature)].prop_map(HostMsg::RequestMap),
        prop_oneof![
            Just(MapKind::Depth),
            Just(MapKind::Temperature),
            Just(MapKind::Camera)
        ]
        .prop_map(HostMsg::RequestFullMap),
        Just(HostMsg::Start),
        Just(HostMsg::Stop),
    ]
}

/// A summary as the device sends it during a 12 N press with a heated contact,
/// one hour after start.
pub fn contact_summary() -> Summary {
    Summary {
        seq: 108_000,
        capture_us: 3_600_000_000,
        latency_us: 4_200,
        force_mn: 12_000,
        peak_depth_um: 2_000,
        contact_area_centi_mm2: 6_280,
        volume_milli_mm3: 62_000,
        centroid: Some(CentroidDeciMm { x: 212, y: 160 }),
        temp_min_centi_c: 2_480,
        temp_mean_centi_c: 2_630,
        temp_max_centi_c: 4_120,
        contact_temp_centi_c: Some(3_980),
        flags: QualityFlags::NONE,
    }
}

/// A no-contact summary one hour after start.
pub fn idle_summary() -> Summary {
    Summary {
        seq: 108_000,
        capture_us: 3_600_000_000,
        latency_us: 1_900,
        centroid: None,
        contact_temp_centi_c: None,
        temp_min_centi_c: 2_480,
        temp_mean_centi_c: 2_500,
        temp_max_centi_c: 2_530,
        ..Default::default()
    }
}

pub fn frame(msg: &DeviceMsg) -> Vec<u8> {
    let mut buf = vec![0u8; vistaf_protocol::frame::DEVICE_FRAME_MAX];
    let n = encode(msg, &mut buf).unwrap();
    buf.truncate(n);
    buf
}
