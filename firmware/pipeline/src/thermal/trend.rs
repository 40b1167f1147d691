//! The light's first-order trend across the contact region, taken out of both stripe
//! populations before their ratio is read.
//!
//! A contact's temperature comes from the ratio of its coloured and black stripes' mean
//! colours. The two populations lie in alternate stripes, so their centroids differ by up
//! to half a grating period, and over a region one to three stripe pairs wide the
//! difference does not average out. Where the light changes across the region, each mean is
//! the light at its own centroid, and the ratio carries the light's change between the two.
//! An oblique ring lights a dimple's slopes to first order in the slope, and inside a
//! sphere's contact the slope grows linearly from its centre: across the contact the light
//! is a plane, tilted by tens of per cent between rims. Above the coloured transition the
//! reading hangs on a per cent of the ratio, so such a tilt moves a heated contact's
//! reading by degrees, changing sign as the stripes slide under the contact with depth.
//!
//! So the light's relative slope across the region is fitted to both populations' samples
//! at once, by least squares (the light multiplies both stripes alike, each about its own
//! mean lightness, the sum of its linear channels), and both populations' means are read at
//! one point, the midpoint of their centroids. A light linear across the region cancels
//! by construction, whatever its direction and strength; nothing about the light is
//! assumed or calibrated. Each population's own plane would also keep a trend of the
//! pigment's own, but would carry the dark black stripes' noise into the correction
//! (`docs/temperature.md` compares the variants). Reading a mean away from its centroid
//! costs noise: where the region is too narrow across the stripes to tell the slope there
//! (about one stripe of each population), the step would grow a mean's variance more than
//! [`MAX_NOISE_GAIN`] times, and both means are left as they are.
//!
//! The moments are summed exactly in integers with the colour sums, on both paths; the
//! fit is a 2 × 2 solve once per frame in floating point (a few dozen operations, which the
//! board's FPU does in as many instructions), so the device path and the float reference
//! read the same levelled sums.

/// Largest growth of a population mean's variance from reading it at the common point
/// instead of its centroid (`n · L̄² · dᵀ N⁻¹ d`, with `n` and `L̄` the population's samples
/// and mean lightness, `N` the shared slope's normal matrix and `d` the step to the common
/// point): beyond it the slope is too poorly known across the stripes for the step it must
/// bridge.
pub const MAX_NOISE_GAIN: f64 = 3.0;

/// Fewest samples of each population before the slope is fitted.
const MIN_SAMPLES: i64 = 24;

/// Spatial moments of a region's kept samples, per population (index 0 the coloured
/// stripes, 1 the black), in input pixels: `n, Σx, Σy, Σx², Σxy, Σy², ΣL, ΣLx, ΣLy`, with
/// `L` the sample's summed linear channels (Q16 each, so `L` < 2¹⁸). Exact in 64 bits for
/// any frame up to 8192 pixels on a side (2²⁶ samples, each term < 2³¹).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Trend {
    m: [[i64; 9]; 2],
}

impl Trend {
    /// One input pixel at (`x`, `y`) of population `pop`, of lightness `l` (its linear
    /// channels' sum, Q16 each).
    #[inline(always)]
    pub fn add(&mut self, pop: usize, (x, y): (usize, usize), l: u32) {
        let (x, y, l) = (x as i64, y as i64, i64::from(l));
        let m = &mut self.m[pop];
        for (v, d) in m
            .iter_mut()
            .zip([1, x, y, x * x, x * y, y * y, l, l * x, l * y])
        {
            *v += d;
        }
    }

    /// Adds another region's moments.
    pub fn add_all(&mut self, o: &Trend) {
        for (a, b) in self.m.iter_mut().zip(&o.m) {
            for (v, d) in a.iter_mut().zip(b) {
                *v += d;
            }
        }
    }

    /// The factor each population's colour sums are scaled by to read them at the midpoint
    /// of the two centroids (see the module doc); `None` when either population is too
    /// small, or the region too narrow across the stripes to tell the light's slope there.
    pub fn factors(&self) -> Option<[f64; 2]> {
        let pops = [Population::of(&self.m[0])?, Population::of(&self.m[1])?];
        let g = Slope::shared(&pops)?;
        let at = (
            (pops[0].centre.0 + pops[1].centre.0) / 2.0,
            (pops[0].centre.1 + pops[1].centre.1) / 2.0,
        );
        let mut factors = [1.0; 2];
        for (f, p) in factors.iter_mut().zip(&pops) {
            let d = (at.0 - p.centre.0, at.1 - p.centre.1);
            // The corrected mean's variance against the plain mean's (same noise per sample).
            if p.n * p.mean * p.mean * g.reach(d) > MAX_NOISE_GAIN {
                return None;
            }
            *f = 1.0 + g.along(d);
        }
        factors.iter().all(|&f| f > 0.0).then_some(factors)
    }
}

/// One population's samples over the region: where they lie, and how their lightness goes
/// with position.
struct Population {
    n: f64,
    /// Centroid, input pixels.
    centre: (f64, f64),
    /// Scatter matrix about the centroid (`Sxx`, `Sxy`, `Syy`), px².
    scatter: Sym,
    /// Mean lightness.
    mean: f64,
    /// `Σ (L − L̄)(x − x̄)`, `Σ (L − L̄)(y − ȳ)`.
    cross: (f64, f64),
}

impl Population {
    fn of(m: &[i64; 9]) -> Option<Population> {
        if m[0] < MIN_SAMPLES || m[6] <= 0 {
            return None;
        }
        let n = m[0] as f64;
        let (cx, cy) = (m[1] as f64 / n, m[2] as f64 / n);
        let mean = m[6] as f64 / n;
        Some(Population {
            n,
            centre: (cx, cy),
            scatter: Sym(
                m[3] as f64 - n * cx * cx,
                m[4] as f64 - n * cx * cy,
                m[5] as f64 - n * cy * cy,
            ),
            mean,
            cross: (m[7] as f64 - n * mean * cx, m[8] as f64 - n * mean * cy),
        })
    }
}

/// A symmetric 2 × 2 matrix `[a b; b c]`.
#[derive(Clone, Copy)]
struct Sym(f64, f64, f64);

impl Sym {
    fn det(&self) -> f64 {
        self.0 * self.2 - self.1 * self.1
    }

    /// `M + w·o`.
    fn plus(self, w: f64, o: &Sym) -> Sym {
        Sym(self.0 + w * o.0, self.1 + w * o.1, self.2 + w * o.2)
    }

    /// `M⁻¹ v`.
    fn solve(&self, v: (f64, f64)) -> (f64, f64) {
        let det = self.det();
        (
            (self.2 * v.0 - self.1 * v.1) / det,
            (self.0 * v.1 - self.1 * v.0) / det,
        )
    }
}

/// The light's relative slope across the region, shared by both populations (the light is
/// multiplicative and the same for both), per input pixel, with the normal matrix it was
/// solved from.
struct Slope {
    g: (f64, f64),
    normal: Sym,
}

impl Slope {
    /// Weighted least squares over both populations' samples, each population about its
    /// own mean: `L ≈ L̄ₚ · (1 + g · (x − x̄ₚ))`. With the same noise on every sample, the
    /// normal equations are `(Σ L̄ₚ² Sₚ) g = Σ L̄ₚ bₚ` (`Sₚ` the scatter, `bₚ` the cross
    /// moments): the bright coloured stripes weigh most. `None` when the samples do not
    /// span both directions.
    fn shared(pops: &[Population; 2]) -> Option<Slope> {
        let (mut normal, mut rhs) = (Sym(0.0, 0.0, 0.0), (0.0, 0.0));
        for p in pops {
            normal = normal.plus(p.mean * p.mean, &p.scatter);
            rhs = (rhs.0 + p.mean * p.cross.0, rhs.1 + p.mean * p.cross.1);
        }
        if normal.det() <= f64::EPSILON * (normal.0 * normal.2).max(f64::MIN_POSITIVE) {
            return None;
        }
        Some(Slope {
            g: normal.solve(rhs),
            normal,
        })
    }

    /// The relative change of the light over the step `d`.
    fn along(&self, d: (f64, f64)) -> f64 {
        self.g.0 * d.0 + self.g.1 * d.1
    }

    /// `dᵀ N⁻¹ d`: the variance of [`Slope::along`] per unit of a sample's variance.
    fn reach(&self, d: (f64, f64)) -> f64 {
        let s = self.normal.solve(d);
        d.0 * s.0 + d.1 * s.1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const PERIOD_PX: f64 = 16.0;
    const COLOURED: f64 = 0.6;
    const BLACK: f64 = 0.15;

    /// The kept samples of a tilted grating inside a disc of `radius_px` about `centre`,
    /// lit by `light(x, y)`: each population's summed lightness (Q16) and the trend.
    fn region(
        centre: (f64, f64),
        radius_px: f64,
        light: impl Fn(f64, f64) -> f64,
    ) -> ([f64; 2], Trend) {
        let (mut sums, mut trend) = ([0.0; 2], Trend::default());
        let tilt = 0.1f64;
        for y in 0..200usize {
            for x in 0..200usize {
                let (fx, fy) = (x as f64, y as f64);
                if (fx - centre.0).hypot(fy - centre.1) > radius_px {
                    continue;
                }
                // Phase in turns; the middle half of each stripe is kept.
                let turn = ((fx * tilt.cos() + fy * tilt.sin()) / PERIOD_PX).rem_euclid(1.0);
                let pop = match turn {
                    t if !(0.125..0.875).contains(&t) => 0,
                    t if (0.375..0.625).contains(&t) => 1,
                    _ => continue,
                };
                let l = ([COLOURED, BLACK][pop] * light(fx, fy) * 65_536.0).round() as u32;
                sums[pop] += f64::from(l);
                trend.add(pop, (x, y), l);
            }
        }
        (sums, trend)
    }

    /// The black over the coloured stripes' mean lightness, against the pigments' own ratio.
    fn ratio_error(sums: [f64; 2], trend: &Trend, factors: [f64; 2]) -> f64 {
        let n = |p: usize| trend.m[p][0] as f64;
        let mean = |p: usize| sums[p] * factors[p] / n(p);
        mean(1) / mean(0) / (BLACK / COLOURED) - 1.0
    }

    /// A light tilted by a few per cent per stripe pair across a contact two pairs wide,
    /// centred between stripes so the populations' centroids differ: the plain ratio is a
    /// third of a per cent or more off, the levelled one within a twentieth of that (the
    /// fit is first order in the light's change between the centroids), wherever the
    /// contact sits and whichever way the light falls.
    #[test]
    fn a_planar_light_leaves_the_levelled_ratio_exact() {
        for (k, slope) in [(0.004, 0.0), (-0.003, 0.002), (0.003, -0.004)]
            .into_iter()
            .enumerate()
        {
            let centre = (100.0 + 3.7 * k as f64, 96.0 - 2.1 * k as f64);
            let light = |x: f64, y: f64| 1.0 + slope.0 * (x - centre.0) + slope.1 * (y - centre.1);
            let (sums, trend) = region(centre, 17.0, light);
            let plain = ratio_error(sums, &trend, [1.0; 2]);
            let factors = trend
                .factors()
                .expect("a region two stripe pairs wide is levelled");
            let levelled = ratio_error(sums, &trend, factors);
            assert!(plain.abs() > 0.003, "case {k}: plain ratio off by {plain}");
            assert!(
                levelled.abs() < plain.abs() / 20.0,
                "case {k}: levelled ratio off by {levelled}, plain by {plain}"
            );
        }
    }

    /// Under an even light the factors are one: nothing is moved that was not tilted.
    #[test]
    fn an_even_light_is_left_alone() {
        let (_, trend) = region((101.3, 98.2), 17.0, |_, _| 1.0);
        let f = trend
            .factors()
            .expect("a region two stripe pairs wide is levelled");
        assert!(f.iter().all(|f| (f - 1.0).abs() < 1e-6), "{f:?}");
    }

    /// A region holding a single stripe of each population cannot tell a slope across the
    /// stripes from the ratio: it is left as it is, however strong the light's slope; and
    /// so is a region with too few samples of a population.
    #[test]
    fn a_region_too_narrow_across_the_stripes_is_left_alone() {
        let light = |x: f64, _: f64| 1.0 + 0.01 * (x - 100.0);
        let (sums, trend) = region((100.0, 100.0), 7.0, light);
        assert!(sums[0] > 0.0 && sums[1] > 0.0);
        assert_eq!(trend.factors(), None);
        let (_, few) = region((100.0, 100.0), 2.0, light);
        assert_eq!(few.factors(), None);
    }
}
