//! # vistaf-firmware
//!
//! The device side of a vistaf skin: the pipeline that turns a reference frame and each new
//! frame into force, shape and temperature, and the `vistaf-skin` service that streams
//! them over serial.
#![deny(missing_docs)]

pub mod calibrate;
pub mod calibration;
pub mod config;
pub mod fit;
pub mod maps;
pub mod pipeline;
pub mod service;
pub mod source_spec;
#[cfg(test)]
mod test_rng;
pub mod thermal;
