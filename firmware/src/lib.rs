//! # vistaf-firmware
//!
//! The device side of a vistaf skin around the pipeline (`vistaf-pipeline`): the
//! service that films the skin, measures each frame and streams summaries over the link,
//! and the edges it runs between (camera, LED ring, serial link, configuration file).
#![deny(missing_docs)]

pub mod config;
pub mod figure;
pub mod report;
pub mod service;
pub mod source_spec;
