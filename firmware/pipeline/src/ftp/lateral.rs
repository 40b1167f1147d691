//! Each colour's grating where the lens put it: lateral chromatic aberration.
//!
//! A lens images red and blue at slightly other scales than green, so each colour's stripes
//! lie a fraction of a pixel off the others', in proportion to the distance from the
//! image's centre. The luminance adds the three colours' fringes, and its phase is their
//! mean weighted by each colour's fringe amplitude. Those amplitudes move with the
//! pigment's colour (the skin's temperature) and with the camera's white balance, so the
//! luminance's phase moves over the view where nothing pressed, by a field the reference
//! does not show.
//!
//! **Each colour's fringe is turned onto one phase before the colours are added.** Colour
//! `k` is mixed by `e^{−i(θ + εₖ)}` instead of `e^{−iθ}`, `εₖ` being its grating phase
//! against the luminance's in the reference. The sum's phase is then the indentation's,
//! whatever the colours' weights. `εₖ` is a fraction of a radian, so to first order
//! `Σ wₖ·Cₖ·e^{−i(θ + εₖ)} = (L − i·Q)·e^{−iθ}` with `Q = Σ wₖ·εₖ·Cₖ`: the luminance `L`
//! and one quadrature term `Q` per working pixel, through the one low-pass both paths
//! already run.
//!
//! `εₖ` is a plane over the view: a magnification moves a stripe in proportion to its
//! distance from the centre, which across the stripes is a phase linear in x and y, and a
//! constant shift of a colour plane (a sensor's demosaicking) is its constant term. Each
//! plane is fitted to the reference's coarse samples, weighted by the colour's fringe
//! amplitude, away from the filters' padded borders, after the colour's mean offset is
//! taken out so that no sample wraps. A colour whose fringe is faint or opposite to the
//! luminance's in the reference keeps `εₖ = 0` (its share is left as the luminance had
//! it). A unit whose colours all lie within [`Offsets::NEGLIGIBLE_RAD`] of the luminance
//! gets no correction, and its frames cost nothing more: the fit's noise alone does not
//! buy a quadrature term.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// One coarse sample of the reference: where it lies and the analytic signals there.
#[derive(Debug, Clone, Copy)]
pub struct Sample {
    /// Working pixel, x and y.
    pub at: (f64, f64),
    /// Each colour's analytic signal (re, im), demodulated by the carrier alone.
    pub colours: [(f64, f64); 3],
    /// The luminance's analytic signal (re, im), the same way.
    pub luma: (f64, f64),
}

/// Each colour's grating phase against the luminance's, a plane over the view per colour:
/// `εₖ(x, y) = a + b·x + c·y`, radians, x and y in working pixels.
#[derive(Debug, Clone, PartialEq)]
pub struct Offsets {
    planes: [[f64; 3]; 3],
    /// Working size the planes span.
    size: (usize, usize),
}

impl Offsets {
    /// Colours within this of the luminance everywhere in the view (rad) get no correction:
    /// a field of at most half of it, far under any frame's noise.
    pub const NEGLIGIBLE_RAD: f64 = 0.02;
    /// The largest offset the first-order rotation is used for (rad): its error, under
    /// `ε²/2` of the fringe, stays a few per cent of the amplitude and none of the phase.
    pub const MAX_RAD: f64 = 0.45;
    /// A sample takes part when its colour's fringe is at least this share of the colour's
    /// median fringe.
    const FAINT: f64 = 0.25;
    /// Samples further than this many median absolute residuals from the first plane are
    /// left out of the second fit (a reflection's or a flaw's own phase).
    const OUTLIER_MADS: f64 = 4.0;

    /// The planes fitted to `samples` of a `w × h` working image, `None` when every colour
    /// lies within [`Offsets::NEGLIGIBLE_RAD`] of the luminance over the whole view.
    pub fn fit(samples: &[Sample], (w, h): (usize, usize)) -> Option<Offsets> {
        let planes: [[f64; 3]; 3] = std::array::from_fn(|k| colour_plane(samples, k));
        let offsets = Offsets {
            planes,
            size: (w, h),
        };
        (offsets.largest_rad() >= Self::NEGLIGIBLE_RAD).then_some(offsets)
    }

    /// The largest |εₖ| over the view (at a corner: the planes are linear), rad.
    pub fn largest_rad(&self) -> f64 {
        let (w, h) = (self.size.0 as f64, self.size.1 as f64);
        let corners = [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h)];
        (0..3)
            .flat_map(|k| corners.map(|(x, y)| self.rad(k, x, y).abs()))
            .fold(0.0, f64::max)
    }

    /// Colour `k`'s offset at working pixel (x, y), rad, within ±[`Offsets::MAX_RAD`].
    pub fn rad(&self, k: usize, x: f64, y: f64) -> f64 {
        let [a, b, c] = self.planes[k];
        (a + b * x + c * y).clamp(-Self::MAX_RAD, Self::MAX_RAD)
    }

    /// Per colour and working pixel (row-major), `weightₖ/256 · εₖ` through `f`: the
    /// factors of the colours' means in the quadrature term `Q`.
    pub fn weighted<T>(&self, weights: [u32; 3], f: impl Fn(f64) -> T) -> [Vec<T>; 3] {
        let (w, h) = self.size;
        std::array::from_fn(|k| {
            let share = f64::from(weights[k]) / 256.0;
            (0..w * h)
                .map(|i| f(share * self.rad(k, (i % w) as f64, (i / w) as f64)))
                .collect()
        })
    }
}

/// Whether working pixel `(x, y)` of a `w × h` image lies clear of the padding the low-pass
/// of lengths `(lx, ly)` sees at the borders (where the colours' fringes are cut off alike,
/// so their phases say nothing of the lens).
pub fn clear_of_padding(
    (x, y): (usize, usize),
    (w, h): (usize, usize),
    (lx, ly): (usize, usize),
) -> bool {
    x >= lx && x + lx < w && y >= ly && y + ly < h
}

/// Colour `k`'s plane against the luminance, `[0; 3]` where its fringe is faint or
/// opposite to the luminance's.
fn colour_plane(samples: &[Sample], k: usize) -> [f64; 3] {
    // Each sample: position, the colour's phase against the luminance's, the colour's
    // fringe amplitude.
    let (mut sr, mut si) = (0.0, 0.0);
    let pts: Vec<(f64, f64, f64, f64)> = samples
        .iter()
        .map(|s| {
            let ((a, b), (c, d)) = (s.colours[k], s.luma);
            let (re, im) = (a * c + b * d, b * c - a * d);
            sr += re;
            si += im;
            (s.at.0, s.at.1, im.atan2(re), a.hypot(b))
        })
        .collect();
    let mean = si.atan2(sr);
    if pts.is_empty() || mean.abs() > FRAC_PI_2 {
        return [0.0; 3];
    }
    let mut amps: Vec<f64> = pts.iter().map(|p| p.3).collect();
    let mid = amps.len() / 2;
    let floor = Offsets::FAINT * *amps.select_nth_unstable_by(mid, f64::total_cmp).1;
    let wrap = |d: f64| (d - mean + PI).rem_euclid(TAU) - PI + mean;
    let mut kept: Vec<(f64, f64, f64, f64)> = pts
        .into_iter()
        .filter(|p| p.3 >= floor && p.3 > 0.0)
        .map(|(x, y, d, a)| (x, y, wrap(d), a))
        .collect();
    let Some(first) = fit_plane(&kept) else {
        return [0.0; 3];
    };
    let residual =
        |p: &(f64, f64, f64, f64)| (p.2 - first[0] - first[1] * p.0 - first[2] * p.1).abs();
    let mut r: Vec<f64> = kept.iter().map(residual).collect();
    let mid = r.len() / 2;
    let mad = *r.select_nth_unstable_by(mid, f64::total_cmp).1;
    kept.retain(|p| residual(p) <= Offsets::OUTLIER_MADS * mad.max(1e-6));
    fit_plane(&kept).unwrap_or(first)
}

/// The weighted least-squares plane `d = a + b·x + c·y` through `(x, y, d, weight)`;
/// `None` when the points do not span a plane.
fn fit_plane(pts: &[(f64, f64, f64, f64)]) -> Option<[f64; 3]> {
    // The normal equations, centred on the weighted mean position for conditioning.
    let total: f64 = pts.iter().map(|p| p.3).sum();
    if total <= 0.0 {
        return None;
    }
    let mx = pts.iter().map(|p| p.3 * p.0).sum::<f64>() / total;
    let my = pts.iter().map(|p| p.3 * p.1).sum::<f64>() / total;
    let (mut sxx, mut sxy, mut syy, mut sd, mut sxd, mut syd) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for &(x, y, d, wt) in pts {
        let (x, y) = (x - mx, y - my);
        sxx += wt * x * x;
        sxy += wt * x * y;
        syy += wt * y * y;
        sd += wt * d;
        sxd += wt * x * d;
        syd += wt * y * d;
    }
    let det = sxx * syy - sxy * sxy;
    if det <= 1e-9 * sxx.max(syy).powi(2) || !det.is_finite() {
        return None;
    }
    let b = (sxd * syy - syd * sxy) / det;
    let c = (syd * sxx - sxd * sxy) / det;
    let a = sd / total - b * mx - c * my;
    Some([a, b, c])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Samples of a view whose colours lie on the given planes against the luminance, each
    /// colour's fringe of the given amplitude, the luminance's phase wandering.
    fn view(planes: [[f64; 3]; 3], amps: [f64; 3]) -> Vec<Sample> {
        let mut out = Vec::new();
        for y in (0..120).step_by(4) {
            for x in (0..160).step_by(4) {
                let (x, y) = (f64::from(x), f64::from(y));
                let base = 0.3 * (x / 17.0).sin() + 0.01 * y;
                let colours = std::array::from_fn(|k| {
                    let [a, b, c] = planes[k];
                    let p = base + a + b * x + c * y;
                    (amps[k] * p.cos(), amps[k] * p.sin())
                });
                out.push(Sample {
                    at: (x, y),
                    colours,
                    luma: (base.cos() * 40.0, base.sin() * 40.0),
                });
            }
        }
        out
    }

    #[test]
    fn each_colour_s_plane_is_found() {
        let planes = [
            [0.05, 0.002, -0.001],
            [0.0, -0.0005, 0.0003],
            [-0.1, -0.001, 0.002],
        ];
        let fit = Offsets::fit(&view(planes, [30.0, 50.0, 10.0]), (160, 120)).expect("offsets");
        for (k, p) in planes.iter().enumerate() {
            for (x, y) in [(0.0, 0.0), (159.0, 0.0), (0.0, 119.0), (80.0, 60.0)] {
                let want = p[0] + p[1] * x + p[2] * y;
                assert!(
                    (fit.rad(k, x, y) - want).abs() < 1e-9,
                    "colour {k} at {x},{y}"
                );
            }
        }
    }

    #[test]
    fn a_colour_opposite_to_the_luminance_or_faint_everywhere_keeps_no_offset() {
        let planes = [[PI, 0.001, 0.0], [0.0, 0.001, 0.0], [0.0, 0.001, 0.0]];
        let fit = Offsets::fit(&view(planes, [30.0, 50.0, 0.0]), (160, 120)).expect("offsets");
        assert_eq!(fit.rad(0, 100.0, 100.0), 0.0);
        assert_eq!(fit.rad(2, 100.0, 100.0), 0.0);
        assert!((fit.rad(1, 100.0, 0.0) - 0.1).abs() < 1e-9);
    }

    #[test]
    fn colours_on_the_luminance_s_grating_need_no_correction() {
        let tiny = [0.004, 0.00005, -0.00005];
        assert_eq!(Offsets::fit(&view([tiny; 3], [30.0; 3]), (160, 120)), None);
    }

    #[test]
    fn a_sample_with_its_own_phase_does_not_tilt_the_plane() {
        let planes = [[0.0, 0.001, 0.0]; 3];
        let mut samples = view(planes, [30.0; 3]);
        // A reflection: a few samples whose red reads a quarter turn off.
        for s in samples.iter_mut().take(12) {
            s.colours[0] = (-s.colours[0].1, s.colours[0].0);
        }
        let fit = Offsets::fit(&samples, (160, 120)).expect("offsets");
        assert!((fit.rad(0, 150.0, 100.0) - 0.15).abs() < 1e-6);
    }

    #[test]
    fn offsets_are_clamped_and_weighted_by_the_colour_s_share() {
        let planes = [[0.0, 0.01, 0.0], [0.0; 3], [0.0, -0.001, 0.0]];
        let fit = Offsets::fit(&view(planes, [30.0; 3]), (160, 120)).expect("offsets");
        assert_eq!(fit.rad(0, 150.0, 0.0), Offsets::MAX_RAD);
        let [r, g, b] = fit.weighted([128, 64, 64], |v| v);
        assert!((r[159] - 0.5 * Offsets::MAX_RAD).abs() < 1e-12);
        assert!(g.iter().all(|&v| v.abs() < 1e-9));
        assert!((b[100] + 0.25 * 0.1).abs() < 1e-9);
    }
}
