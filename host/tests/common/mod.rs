//! A deterministic noisy stream of summaries with its ground truth.
#![allow(dead_code, clippy::unwrap_used)]

use vistaf_protocol::frame::DEVICE_FRAME_MAX;
use vistaf_protocol::*;

/// xorshift64: deterministic noise without a dependency.
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
}

pub fn summary(seq: u32) -> Summary {
    Summary {
        seq,
        capture_us: u64::from(seq) * 33_333,
        latency_us: 2_000 + seq % 500,
        force_mn: (seq * 37) % 30_000,
        peak_depth_um: (seq * 11) % 2_500,
        contact_area_centi_mm2: seq % 9_000,
        volume_milli_mm3: seq % 70_000,
        centroid: (!seq.is_multiple_of(3)).then_some(CentroidDeciMm {
            x: (seq % 400) as i16,
            y: 120,
        }),
        temp_min_centi_c: 2_400,
        temp_mean_centi_c: 2_500 + (seq % 100) as i16,
        temp_max_centi_c: 2_700,
        contact_temp_centi_c: (!seq.is_multiple_of(3)).then_some(3_900),
        // Every fifth summary raises one flag, each bit in turn, those no build names too.
        flags: QualityFlags(if seq.is_multiple_of(5) {
            1 << ((seq / 5) % 16)
        } else {
            0
        }),
    }
}

pub fn frame(msg: &DeviceMsg) -> Vec<u8> {
    let mut buf = vec![0u8; DEVICE_FRAME_MAX];
    let n = encode(msg, &mut buf).unwrap();
    buf.truncate(n);
    buf
}

/// A stream of `count` summaries where every 10th frame is corrupted (a body bit flipped)
/// and every 13th is preceded by garbage. Returns the bytes, the sequence numbers that
/// reached the line intact, and the number of fragments the decoder must drop.
pub struct NoisyStream {
    pub bytes: Vec<u8>,
    pub intact: Vec<u32>,
    pub damaged: u64,
    pub expected_drops: u64,
}

pub fn noisy_stream(count: u32, seed: u64) -> NoisyStream {
    let mut rng = Rng(seed);
    let mut bytes = Vec::new();
    let mut intact = Vec::new();
    let mut damaged = 0;
    for seq in 0..count {
        if seq % 13 == 5 {
            let n = 1 + rng.next() % 50;
            bytes.extend((0..n).map(|_| rng.next() as u8));
        }
        let mut f = frame(&DeviceMsg::Summary(summary(seq)));
        if seq % 10 == 7 {
            let at = 1 + (rng.next() as usize) % (f.len() - 2);
            f[at] ^= 1 << (rng.next() % 8);
            damaged += 1;
        } else {
            intact.push(seq);
        }
        bytes.extend_from_slice(&f);
    }
    let fragments = bytes.split(|&b| b == 0).filter(|s| !s.is_empty()).count() as u64;
    let expected_drops = fragments - intact.len() as u64;
    NoisyStream {
        bytes,
        intact,
        damaged,
        expected_drops,
    }
}

/// The `Hello` of a skin of this protocol with `serial`.
pub fn hello(serial: &str, calibration_id: u32) -> DeviceMsg {
    DeviceMsg::Hello(Hello {
        protocol_version: PROTOCOL_VERSION,
        schema_hash: schema_hash(),
        firmware: FirmwareVersion {
            major: 0,
            minor: 1,
            patch: 0,
        },
        serial: heapless::String::from(serial),
        frame_width_px: 640,
        frame_height_px: 480,
        calibration_id,
    })
}

/// Runs `vistaf-host` with `args`; its standard output, after checking it succeeded (its
/// standard error is the failure's message).
pub fn host_ok(args: &[&str]) -> String {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_vistaf-host"))
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "vistaf-host {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}
