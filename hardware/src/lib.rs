//! # vistaf-hardware
//!
//! Everything that touches hardware, behind small traits, each with a real implementation
//! and a stand-in that tests and demos use:
//!
//! | seam | real | stand-in |
//! |---|---|---|
//! | [`source::FrameSource`] | [`camera`] (V4L2, feature `v4l`) | [`source::SetReplay`]; the simulated skin (`vistaf-sim`) |
//! | [`led::LedRing`] | [`led::SpiLedRing`] over rppal SPI (feature `rpi`) | [`led::MemoryLedRing`] |
//! | [`bench::Bench`] | a person, told by the host what to set | the simulated skin's scripted indenter and heater |
//!
//! [`decode`] turns a frame's bytes into the pipeline's input at the size it needs, and
//! [`encode`] an image into the bytes a camera sends;
//! [`frameset`] reads and writes the `vistaf-frames/1` format; [`clock`] is the device's
//! one time line, which frame timestamps from a camera or the simulated skin are read on.
#![deny(missing_docs)]

pub mod bench;
#[cfg(feature = "v4l")]
pub mod camera;
pub mod clock;
pub mod decode;
pub mod encode;
pub mod frame;
pub mod frameset;
mod jpeg;
pub mod led;
pub mod light_hold;
pub mod source;
mod yuyv;

pub use frame::{Frame, PixelFormat};
pub use source::{FrameSource, SourceError, SourceFormat};
