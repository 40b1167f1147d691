//! # vistaf-tests
//!
//! End-to-end tests across crates, recorded-frame fixtures, benchmarks and charts.
