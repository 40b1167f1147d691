//! libFuzzer target: arbitrary bytes through both streaming decoders, in two chunkings.
//! Run: `cd protocol/fuzz && cargo fuzz run -s none decode` (stable) or
//! `cargo +nightly fuzz run decode` (with AddressSanitizer).
#![no_main]

use libfuzzer_sys::fuzz_target;
use vistaf_protocol::frame::DEVICE_FRAME_MAX;
use vistaf_protocol::{encode, DeviceDecoder, HostDecoder};

fuzz_target!(|data: &[u8]| {
    let mut whole = DeviceDecoder::new();
    let mut split = DeviceDecoder::new();
    let mut a = Vec::new();
    let mut b = Vec::new();
    whole.push(data, |r| a.push(r));
    for chunk in data.chunks(3) {
        split.push(chunk, |r| b.push(r));
    }
    assert_eq!(a, b, "chunking changed the result");
    for msg in a.into_iter().flatten() {
        let mut buf = [0u8; DEVICE_FRAME_MAX];
        assert!(encode(&msg, &mut buf).is_ok());
    }
    HostDecoder::new().push(data, |_| {});
});
