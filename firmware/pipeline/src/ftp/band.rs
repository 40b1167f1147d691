//! The band-pass both paths share: the device path's box cascade along each axis, whose
//! response the float path reproduces (or replaces by a Hann window), and the band the
//! measurement's phase-slope test is set against.

use super::carrier::Carrier;

/// Band-pass half-width of the Hann window, as a fraction of the carrier frequency; also the
/// band the phase-slope flag measures against.
pub const BAND_HALF_WIDTH: f32 = 0.64;

/// The band-pass window of the float path.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BandWindow {
    /// The device path's box-cascade response (the oracle's default).
    #[default]
    Matched,
    /// Separable Hann of half-width [`BAND_HALF_WIDTH`] × f.
    Hann,
}

/// Box lengths (x, y) of the device demodulator for a working-resolution carrier: one
/// period along x, so the nulls fall on the other orders; one period along y.
pub fn box_lengths(c: &Carrier) -> (usize, usize) {
    let lx = (1.0 / c.fx.abs().max(1e-3)).round().clamp(2.0, 64.0) as usize;
    let ly = c.period_px().round().clamp(2.0, 64.0) as usize;
    (lx, ly)
}

/// `|D_L(ν)|²`: the magnitude response of two passes of a length-`L` box at `ν` cycles/px.
pub fn box2_response(nu: f32, l: usize) -> f32 {
    let s = (std::f32::consts::PI * nu).sin();
    if s.abs() < 1e-7 {
        return 1.0;
    }
    let d = (std::f32::consts::PI * nu * l as f32).sin() / (l as f32 * s);
    d * d
}
