//! Encode and decode cost of a typical contact summary (setup excluded from the timing).
#![allow(clippy::unwrap_used)] // a bench that cannot encode is a broken bench

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use vistaf_protocol::frame::DEVICE_FRAME_MAX;
use vistaf_protocol::*;

fn summary() -> DeviceMsg {
    DeviceMsg::Summary(Summary {
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
    })
}

fn codec(c: &mut Criterion) {
    let msg = summary();
    let mut buf = [0u8; DEVICE_FRAME_MAX];
    c.bench_function("encode_summary", |b| {
        b.iter(|| encode(black_box(&msg), black_box(&mut buf)).unwrap())
    });
    let n = encode(&msg, &mut buf).unwrap();
    let frame = buf[..n].to_vec();
    let mut dec = DeviceDecoder::new();
    c.bench_function("decode_summary", |b| {
        b.iter(|| {
            let mut out = None;
            dec.push(black_box(&frame), |r| out = r.ok());
            out
        })
    });
}

criterion_group!(benches, codec);
criterion_main!(benches);
