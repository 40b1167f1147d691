//! Decoder fuzzing without a nightly toolchain: random bytes (pure noise, and noise mixed
//! with real frames and mutations of them) through the streaming decoder, which must never
//! panic, never accept a frame it did not see intact, and account for every fragment.
//!
//! The quick variant runs in every test run. The long one (≥ 1 000 000 inputs) is ignored
//! by default; run it with
//!
//! ```sh
//! cargo test -p vistaf-protocol --release --test fuzz -- --ignored
//! ```
//!
//! With cargo-fuzz installed, `protocol/fuzz/` has the same target for libFuzzer
//! (`cd protocol/fuzz && cargo fuzz run -s none decode`).
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

mod common;

use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};
use vistaf_protocol::frame::{DEVICE_FRAME_MAX, HOST_FRAME_MAX};
use vistaf_protocol::*;

fn fuzz_input() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        proptest::collection::vec(any::<u8>(), 0..600),
        // Real frames with bytes overwritten, inserted or removed.
        (
            proptest::collection::vec(common::arb_device_msg(), 1..4),
            proptest::collection::vec((any::<usize>(), any::<u8>(), 0u8..3), 0..6)
        )
            .prop_map(|(msgs, edits)| {
                let mut bytes: Vec<u8> = msgs.iter().flat_map(common::frame).collect();
                for (at, b, op) in edits {
                    let i = at % (bytes.len() + 1);
                    match op {
                        0 if i < bytes.len() => bytes[i] = b,
                        1 => bytes.insert(i, b),
                        _ if i < bytes.len() => {
                            bytes.remove(i);
                        }
                        _ => {}
                    }
                }
                bytes
            }),
    ]
}

fn check(bytes: &[u8]) -> Result<(), TestCaseError> {
    let mut dev = DeviceDecoder::new();
    let mut host = HostDecoder::new();
    let mut accepted = 0u64;
    dev.push(bytes, |r| {
        if let Ok(msg) = r {
            // Whatever is accepted re-encodes within the bound.
            let mut buf = [0u8; DEVICE_FRAME_MAX];
            assert!(encode(&msg, &mut buf).is_ok());
            accepted += 1;
        }
    });
    host.push(bytes, |r| {
        if let Ok(msg) = r {
            let mut buf = [0u8; HOST_FRAME_MAX];
            assert!(encode(&msg, &mut buf).is_ok());
        }
    });
    dev.finish();
    host.finish();
    let fragments = bytes.split(|&b| b == 0).filter(|s| !s.is_empty()).count() as u64;
    prop_assert_eq!(dev.accepted() + dev.drops().total(), fragments);
    prop_assert_eq!(dev.accepted(), accepted);
    prop_assert_eq!(host.accepted() + host.drops().total(), fragments);
    Ok(())
}

fn run(cases: u32) {
    let mut runner = TestRunner::new(Config {
        cases,
        failure_persistence: None,
        ..Config::default()
    });
    runner.run(&fuzz_input(), |bytes| check(&bytes)).unwrap();
}

#[test]
fn decoder_fuzz_quick() {
    run(5_000);
}

#[test]
#[ignore = "long: run with --release -- --ignored"]
fn decoder_fuzz_one_million() {
    run(1_000_000);
}
