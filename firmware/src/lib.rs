//! # vistaf-firmware
//!
//! The on-device side: the FTP and temperature pipeline (fixed-point device path and a
//! float reference) and the `vistaf-skin` service that streams summaries over serial.
