//! # vistaf-protocol
//!
//! The wire between a vistaf skin and the robot computer: every message type in both
//! directions and the framing that carries them over a serial line. `no_std`, no allocation;
//! the device and the host share this crate so they cannot disagree on a byte.
//!
//! ```text
//!  camera ─▶ pipeline ─▶ Summary ─▶ encode ─▶ serial ─▶ Decoder ─▶ host
//!  (device)                          0x00 COBS(postcard · CRC-32) 0x00
//! ```
//!
//! * [`msg`]: the messages. Device → host: [`Hello`], [`Summary`], [`Map`] (coarse) and
//!   [`MapChunk`] (a piece of a full map), [`Status`], [`DeviceError`], `Pong`, `Ack`,
//!   [`ClockReading`], and a guided calibration's [`KitCaptured`], [`KitVerdict`],
//!   [`CalibrationFitted`]. Host → device: [`HostMsg`].
//! * [`frame`]: framing, with compile-time maximum frame sizes and a streaming decoder
//!   that resynchronises after garbage and counts every drop.
//! * [`flags`]: the quality-flag bitfield of a summary.
//! * [`schema`]: protocol version and schema hash, checked in the `Hello` handshake.
//! * `link` (feature `std`): the link spec grammar both CLIs share (`/dev/ttyX`,
//!   `serial:PATH@BAUD`, `file:PATH`, `-`).
//!
//! ## Sizes and rates
//!
//! Measured by `tests/sizes.rs` (the tests fail if these figures stop holding):
//!
//! | message | framed bytes |
//! |---|---|
//! | `Summary`, no contact, 1 h uptime | 31 |
//! | `Summary`, 12 N press, 2 mm deep, heated contact, 1 h uptime | 42 |
//! | `Summary`, worst case (every varint at its widest) | [`frame::SUMMARY_FRAME_MAX`] = 71 |
//! | largest `DeviceMsg` (a full 768-cell `Map`) | [`frame::DEVICE_FRAME_MAX`] |
//!
//! A serial byte is 10 bits on the line (8N1). At 921 600 baud the line carries
//! 92 160 bytes/s: **2 194 typical contact summaries per second** (42 bytes), 1 298 per
//! second even in the worst case, far above any camera rate. At 115 200 baud:
//! 274 typical summaries per second.
//!
//! ## Compatibility
//!
//! The wire is append-only (see [`msg`]). A device announces [`PROTOCOL_VERSION`] and
//! [`schema_hash`] in its `Hello`; a host of another version sees
//! [`frame::FrameError::ProtocolMismatch`] and refuses with a message naming both versions.
#![no_std]
#![deny(missing_docs)]

#[cfg(feature = "std")]
extern crate std;

pub mod flags;
pub mod frame;
#[cfg(feature = "std")]
pub mod link;
pub mod msg;
pub mod schema;
pub mod units;

pub use flags::{Flag, QualityFlags, Reading};
pub use frame::{encode, Decoder, DeviceDecoder, DropCounts, FrameError, HostDecoder};
pub use msg::{
    CalibrationFitted, CentroidDeciMm, ClockReading, Command, DeviceError, DeviceMsg, ErrorCode,
    FirmwareVersion, Hello, HostMsg, KitCaptured, KitQuantity, KitStep, KitVerdict, Map, MapChunk,
    MapKind, Rgb, RunState, SetLed, Status, Summary,
};
pub use schema::{schema_hash, PROTOCOL_VERSION};
pub use units::CalibrationId;
