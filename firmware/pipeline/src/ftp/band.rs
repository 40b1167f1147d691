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

/// Variance of two passes of a length-`l` box (the triangle of length `2l − 1`), px²:
/// twice a pass's `(l² − 1)/12`.
pub fn box2_variance_px2(l: usize) -> f64 {
    let l = l.max(1) as f64;
    (l * l - 1.0) / 6.0
}

/// The σ of the two-box kernel of lengths `(lx, ly)`, px: the root of the two axes' mean
/// variance, at least half a pixel (what the blur corrections model it by).
pub fn box2_sigma_px((lx, ly): (usize, usize)) -> f64 {
    (0.5 * (box2_variance_px2(lx) + box2_variance_px2(ly)))
        .sqrt()
        .max(0.5)
}

/// The box length whose two passes (the triangle of length `2l − 1`) have variance `v`
/// px²: each pass is uniform over `l` pixels, of variance `(l² − 1)/12`.
pub fn box2_length_of_variance(v: f32) -> usize {
    (6.0 * v + 1.0).sqrt().round().max(1.0) as usize
}

/// Variance of the point-spread of a Hann band-pass of half-width `rho` cycles/px, px²:
/// `−H''(0)/(4π²·H(0))` for `H(ν) = ½ + ½·cos(πν/ρ)`, that is `1/(8ρ²)`.
pub fn hann_variance_px2(rho: f32) -> f32 {
    1.0 / (8.0 * rho * rho)
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
