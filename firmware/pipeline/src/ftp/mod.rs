//! Fourier-transform profilometry: from a frame and the reference to the wrapped phase
//! difference and the fringe amplitudes, on two paths that compute the same operator.
//!
//! * [`carrier`]: the grating's frequency and orientation, found once per reference.
//! * [`band`]: the band-pass both paths share (the device path's box cascade).
//! * [`float`]: the float reference with rustfft, the oracle in tests.
//! * [`fixed`]: the device path, integer demodulation per frame.
//! * [`lateral`]: each colour's grating offset, which both paths turn out before the
//!   colours are added.

pub mod band;
pub mod carrier;
pub mod fixed;
pub mod float;
pub mod lateral;
