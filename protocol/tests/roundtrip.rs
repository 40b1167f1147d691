//! Property-based round trips: every message of either direction survives encode → decode,
//! fits its compile-time frame bound, and decodes the same whatever the read chunking.
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

mod common;

use proptest::prelude::*;
use vistaf_protocol::frame::{DEVICE_FRAME_MAX, HOST_FRAME_MAX, SUMMARY_FRAME_MAX};
use vistaf_protocol::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(
        std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(512)
    ))]

    #[test]
    fn device_messages_round_trip(msg in common::arb_device_msg()) {
        let mut buf = [0u8; DEVICE_FRAME_MAX];
        let n = encode(&msg, &mut buf).unwrap();
        prop_assert!(n <= DEVICE_FRAME_MAX);
        if matches!(msg, DeviceMsg::Summary(_)) {
            prop_assert!(n <= SUMMARY_FRAME_MAX, "summary frame {n} > bound {SUMMARY_FRAME_MAX}");
        }
        let mut dec = DeviceDecoder::new();
        let mut got = Vec::new();
        dec.push(&buf[..n], |r| got.push(r));
        prop_assert_eq!(got, vec![Ok(msg)]);
    }

    #[test]
    fn host_messages_round_trip(msg in common::arb_host_msg()) {
        let mut buf = [0u8; HOST_FRAME_MAX];
        let n = encode(&msg, &mut buf).unwrap();
        let mut dec = HostDecoder::new();
        let mut got = Vec::new();
        dec.push(&buf[..n], |r| got.push(r));
        prop_assert_eq!(got, vec![Ok(msg)]);
    }

    #[test]
    fn chunking_does_not_matter(
        msgs in proptest::collection::vec(common::arb_device_msg(), 1..20),
        cuts in proptest::collection::vec(1usize..64, 1..200),
    ) {
        let stream: Vec<u8> = msgs.iter().flat_map(common::frame).collect();
        let mut dec = DeviceDecoder::new();
        let mut got = Vec::new();
        let mut rest = stream.as_slice();
        for cut in cuts.iter().cycle() {
            if rest.is_empty() { break; }
            let (now, later) = rest.split_at((*cut).min(rest.len()));
            dec.push(now, |r| got.push(r.unwrap()));
            rest = later;
        }
        prop_assert_eq!(got, msgs);
        prop_assert_eq!(dec.drops().total(), 0);
        prop_assert_eq!(dec.pending(), 0);
    }
}

#[test]
fn largest_messages_fit_their_bounds() {
    // A full map of the widest cells and a status with every counter at its maximum.
    let map = DeviceMsg::Map(Map {
        seq: u32::MAX,
        kind: MapKind::Temperature,
        width: 32,
        height: 24,
        cell_pitch_centi_mm: u16::MAX,
        cells: heapless::Vec::from_slice(&[i16::MIN; msg::MAP_MAX_CELLS]).unwrap(),
    });
    let mut buf = [0u8; DEVICE_FRAME_MAX];
    let n = encode(&map, &mut buf).unwrap();
    assert!(n <= DEVICE_FRAME_MAX);
    let widest = Summary {
        seq: u32::MAX,
        capture_us: u64::MAX,
        latency_us: u32::MAX,
        force_mn: u32::MAX,
        peak_depth_um: u32::MAX,
        contact_area_centi_mm2: u32::MAX,
        volume_milli_mm3: u32::MAX,
        centroid: Some(CentroidDeciMm {
            x: i16::MIN,
            y: i16::MIN,
        }),
        temp_min_centi_c: i16::MIN,
        temp_mean_centi_c: i16::MIN,
        temp_max_centi_c: i16::MIN,
        contact_temp_centi_c: Some(i16::MIN),
        flags: QualityFlags(u16::MAX),
    };
    let n = encode(&DeviceMsg::Summary(widest), &mut buf).unwrap();
    assert_eq!(
        n, SUMMARY_FRAME_MAX,
        "the widest summary is exactly the bound"
    );
}
