//! The sizes and line rates quoted in the crate docs, measured.
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

mod common;

use vistaf_protocol::frame::SUMMARY_FRAME_MAX;
use vistaf_protocol::DeviceMsg;

/// Bytes per second an 8N1 serial line carries at `baud` (10 bits per byte).
fn bytes_per_s(baud: u32) -> u32 {
    baud / 10
}

#[test]
fn summary_sizes_match_the_docs() {
    let idle = common::frame(&DeviceMsg::Summary(common::idle_summary())).len();
    let contact = common::frame(&DeviceMsg::Summary(common::contact_summary())).len();
    println!("framed summary: idle {idle} B, contact {contact} B, worst {SUMMARY_FRAME_MAX} B");
    assert_eq!(idle, 31);
    assert_eq!(contact, 42);
    assert!(contact <= 48, "summary budget is 48 bytes framed");
    assert_eq!(SUMMARY_FRAME_MAX, 71);
}

#[test]
fn line_rates_match_the_docs() {
    let contact = common::frame(&DeviceMsg::Summary(common::contact_summary())).len() as u32;
    let rates: Vec<(u32, u32, u32)> = [115_200u32, 460_800, 921_600]
        .iter()
        .map(|&b| {
            (
                b,
                bytes_per_s(b) / contact,
                bytes_per_s(b) / SUMMARY_FRAME_MAX as u32,
            )
        })
        .collect();
    for (baud, typical, worst) in &rates {
        println!("{baud} baud: {typical} summaries/s typical, {worst} worst case");
    }
    assert_eq!(rates[0].1, 274);
    assert_eq!(rates[2].1, 2194);
    assert_eq!(rates[2].2, 1298);
}
