//! The device path's colour → temperature: the calibration's models in integer arithmetic.
//!
//! Per block, from the 64-bit colour sums: the invariants (the chromaticity r, g of the
//! coloured stripes over the black, and the black over the coloured weighted as luminance,
//! q; see [`super::lab`]) in Q16 by integer division; CIELAB's XYZ matrix in
//! Q16; its cube root `f(t)` from a 4097-entry table over t ∈ [0, 4] with linear
//! interpolation (error below 10⁻⁶, far under the features' noise); then each population's
//! model — a polynomial in standardised features or the calibration curve's nearest segment —
//! with Q16 values and 128-bit products where squares of whitened distances could overflow
//! 64 bits; the variance tables and the inverse-variance blend likewise. Nothing is
//! tabulated over the colour space, so the device follows the float models exactly, up to
//! rounding (tested within 0.05 °C), whatever shape the chosen model has: a look-up table
//! over (r, g, q) was tried first, and its trilinear interpolation could not follow the
//! calibration curve where its nearest segment changes (errors above 1 °C at the default
//! resolution).
//!
//! Cost per block: eight divisions for the invariants (the two ratios per channel, then the
//! chromaticity), one per chromaticity channel for the features, six table reads, and per
//! model either its monomials or three multiply-adds per curve segment.

use super::lab::D65;
use super::model::{ColourModel, Population, TemperatureModel, VarianceTable};
use super::stripes::Sums;

/// 1 in Q16.
pub(super) const ONE: i64 = 1 << 16;

/// The widest temperature a population's estimate takes, Q16 °C (±1000 °C).
const T_LIMIT_Q16: i128 = 1000 << 16;

/// Largest whitened distance the curve evaluation represents, Q12 (4096 σ).
const WHITE_MAX: f64 = (1 << 24) as f64;

fn q16(v: f64) -> i64 {
    (v * 65_536.0).round() as i64
}

/// Rec. 709 luminance weights, Q16.
const Y_Q16: [i64; 3] = [13_938, 46_868, 4_730];

/// CIELAB's `f(t)` for t = k/1024, k = 0…4096, Q16.
fn lab_f_table() -> Vec<i64> {
    (0..=4096)
        .map(|k| q16(super::lab::lightness(k as f64 / 1024.0) / 116.0 + 16.0 / 116.0))
        .collect()
}

/// Features per population (checked when a calibration is loaded:
/// [`TemperatureModel::is_consistent`]).
const FEATURES: usize = 3;

/// A population's model in integers.
#[derive(Debug, Clone)]
enum Eval {
    Poly {
        mean: [i64; FEATURES],
        inv_std: [i64; FEATURES],
        exps: Vec<[u32; FEATURES]>,
        coef: Vec<i64>,
    },
    Curve(CurveQ),
}

/// The calibration curve in integers.
#[derive(Debug, Clone)]
struct CurveQ {
    /// Knots, whitened, Q12.
    knots: Vec<[i64; FEATURES]>,
    /// Per knot `k`: −2·k and |k|² (Q24), so a block's squared distance to it, less the
    /// block's own |x|² (the same for every knot), is |k|² − 2·x·k: three multiply-adds,
    /// and the knots rank as by distance.
    near: Vec<[i64; FEATURES + 1]>,
    /// 1/σ per feature, Q16.
    inv_scale: [i64; FEATURES],
    /// Whitened segment vectors, Q12 (σ = 4096).
    d: Vec<[i64; FEATURES]>,
    /// Their squared lengths, Q24.
    bb: Vec<i64>,
    /// Knot temperatures, Q16 °C.
    t: Vec<i64>,
    /// `e^{−Δ/2}` for Δ = k/32 σ², Q16 (see [`super::model::softmin_weight`]).
    softmin: Vec<i64>,
}

/// The first [`FEATURES`] values of `v` (a consistent model has exactly that many).
fn features_of<T: Copy + Default>(v: &[T]) -> [T; FEATURES] {
    std::array::from_fn(|j| v.get(j).copied().unwrap_or_default())
}

#[derive(Debug, Clone)]
struct Table {
    t0: i64,
    step: i64,
    var: Vec<i64>,
}

const UNKNOWN_Q16: i64 = (VarianceTable::UNKNOWN_C2 * 65_536.0) as i64;

/// The range check's cap on a reading's standard deviation, Q16 °C.
const SIGMA_CAP_Q16: i64 = (super::model::OUT_OF_RANGE_SIGMA_C * 65_536.0) as i64;

impl Table {
    fn new(v: &VarianceTable) -> Table {
        Table {
            t0: q16(v.t0_c),
            step: q16(v.step_c).max(1),
            var: v.var_c2.iter().map(|&x| q16(x)).collect(),
        }
    }

    /// Variance at `t` (Q16 °C), Q16 °C²: as the float table, with the weight falling to
    /// zero over the outer half of the end bins.
    fn at(&self, t: i64) -> i64 {
        let n = self.var.len() as i64;
        if n == 0 {
            return UNKNOWN_Q16;
        }
        // Position in Q16 bins (|t − t0| < 2¹⁵ °C, so the shift fits).
        let x = ((t - self.t0).clamp(-(1 << 46), 1 << 46) << 16) / self.step;
        let last = (n - 1) * ONE;
        let beyond = if x < 0 {
            -x
        } else if x > last {
            x - last
        } else {
            0
        };
        if beyond >= ONE / 2 {
            return UNKNOWN_Q16;
        }
        let x = x.clamp(0, last);
        let k = (x >> 16).min(n - 1) as usize;
        let f = x & (ONE - 1);
        let next = self.var[(k + 1).min(self.var.len() - 1)];
        let v = self.var[k] + (((next - self.var[k]) * f) >> 16);
        if beyond == 0 {
            return v.min(UNKNOWN_Q16);
        }
        let keep = ONE - 2 * beyond; // > 0 here
        ((v << 16) / keep).min(UNKNOWN_Q16)
    }
}

#[derive(Debug, Clone)]
struct Pop {
    eval: Eval,
    table: Table,
}

impl Pop {
    fn new(m: &super::model::PopulationModel) -> Pop {
        let eval = match &m.model {
            ColourModel::Polynomial(p) => Eval::Poly {
                mean: features_of(&p.mean).map(q16),
                inv_std: features_of(&p.std).map(|s| q16(1.0 / s)),
                exps: super::model::monomials(p.mean.len(), p.degree)
                    .iter()
                    .map(|e| features_of(e))
                    .collect(),
                coef: p.coef.iter().map(|&c| q16(c)).collect(),
            },
            ColourModel::Curve(c) => {
                let scale = features_of(&c.scale);
                let knots: Vec<[i64; FEATURES]> = c
                    .knots
                    .iter()
                    .map(|k| {
                        let k = features_of(k);
                        std::array::from_fn(|j| {
                            (k[j] / scale[j] * 4096.0).round().clamp(-8.4e6, 8.4e6) as i64
                        })
                    })
                    .collect();
                let d: Vec<[i64; FEATURES]> = c
                    .knots
                    .windows(2)
                    .map(|w| {
                        let (a, b) = (features_of(&w[0]), features_of(&w[1]));
                        std::array::from_fn(|j| {
                            ((b[j] - a[j]) / scale[j] * 4096.0)
                                .round()
                                .clamp(-WHITE_MAX, WHITE_MAX) as i64
                        })
                    })
                    .collect();
                let bb = d.iter().map(|v| v.iter().map(|&x| x * x).sum()).collect();
                let near = knots
                    .iter()
                    .map(|k| {
                        [
                            -2 * k[0],
                            -2 * k[1],
                            -2 * k[2],
                            k.iter().map(|&v| v * v).sum(),
                        ]
                    })
                    .collect();
                Eval::Curve(CurveQ {
                    knots,
                    near,
                    inv_scale: scale.map(|s| q16(1.0 / s)),
                    d,
                    bb,
                    t: c.t_c.iter().map(|&t| q16(t)).collect(),
                    softmin: (0..=(super::model::SOFTMIN_CUT * 32.0) as usize)
                        .map(|k| q16(super::model::softmin_weight(k as f64 / 32.0)))
                        .collect(),
                })
            }
        };
        Pop {
            eval,
            table: Table::new(&m.variance),
        }
    }

    /// Temperature (Q16 °C) at features `x` (Q16).
    fn eval(&self, x: [i64; FEATURES]) -> i64 {
        match &self.eval {
            Eval::Poly {
                mean,
                inv_std,
                exps,
                coef,
            } => {
                let z: [i64; FEATURES] = std::array::from_fn(|j| {
                    ((i128::from(x[j] - mean[j]) * i128::from(inv_std[j])) >> 16) as i64
                });
                let mut acc: i128 = 0;
                for (e, c) in exps.iter().zip(coef) {
                    let mut term: i128 = i128::from(ONE);
                    for (zv, &p) in z.iter().zip(e) {
                        for _ in 0..p {
                            term = (term * i128::from(*zv)) >> 16;
                        }
                    }
                    acc += term * i128::from(*c);
                }
                // Far outside any calibrated colour a polynomial runs off: the reading is
                // kept within ±1000 °C (flagged out of range), so no later product overflows.
                (acc >> 16).clamp(-T_LIMIT_Q16, T_LIMIT_Q16) as i64
            }
            Eval::Curve(c) => c.eval(x),
        }
    }
}

impl CurveQ {
    /// The calibration curve's temperature at features `x` (Q16), as `Curve::eval` in the
    /// float model: the nearest points of the end segments and of those meeting at the two
    /// nearest knots, blended by likelihood. Whitened values in Q12 (2⁻¹² σ); distances
    /// clamped at 4096 σ (far outside any calibrated colour): squares and dot products stay
    /// below 2⁵⁰, and only the projection's product takes 128 bits (a multiplication, no
    /// division).
    /// Fixed-size feature vectors and one pass over the knots.
    fn eval(&self, x: [i64; FEATURES]) -> i64 {
        let CurveQ {
            knots,
            near,
            inv_scale,
            d,
            bb,
            t,
            softmin,
        } = self;
        let n = t.len().min(knots.len()).min(near.len()).min(d.len() + 1);
        if n < 2 {
            return t.first().copied().unwrap_or(0);
        }
        // Knots lie within ±2²³ (2048 σ) of the calibrated colours; clamping the block's
        // whitened features to ±2²⁴ keeps every difference below 2²⁵. A product that would
        // overflow saturates, and the clamp then gives what 128 bits would.
        let lim = 1i64 << 24;
        let xw: [i64; FEATURES] =
            std::array::from_fn(|j| (x[j].saturating_mul(inv_scale[j]) >> 20).clamp(-lim, lim));
        let diff =
            |k: &[i64; FEATURES]| -> [i64; FEATURES] { std::array::from_fn(|j| xw[j] - k[j]) };
        let dot = |a: &[i64; FEATURES], b: &[i64; FEATURES]| -> i64 {
            a.iter().zip(b).map(|(p, q)| p * q).sum()
        };
        // The two nearest knots (the earlier one on a tie), and the segments meeting at either.
        // Ranked by |k|² − 2·x·k, the squared distance less |x|²: exact integers (below
        // 2⁵⁰ in magnitude), so the order and the ties are the distances'.
        let (mut k1, mut k2) = ((i64::MAX, 0usize), (i64::MAX, 0usize));
        for (k, kn) in near[..n].iter().enumerate() {
            let d2 = kn[3] + xw[0] * kn[0] + xw[1] * kn[1] + xw[2] * kn[2];
            if d2 < k2.0 {
                if d2 < k1.0 {
                    k2 = k1;
                    k1 = (d2, k);
                } else {
                    k2 = (d2, k);
                }
            }
        }
        let last = n - 2;
        let mut segs = [
            0,
            k1.1.saturating_sub(1),
            k1.1.min(last),
            k2.1.saturating_sub(1),
            k2.1.min(last),
            last,
        ];
        segs.sort_unstable();
        let mut found = [(i64::MAX, 0i64); 6];
        for (i, &k) in segs.iter().enumerate() {
            if i > 0 && segs[i - 1] == k {
                continue;
            }
            let e = diff(&knots[k]);
            let (ab, ax) = (dot(&d[k], &e), dot(&e, &e));
            let bk = bb[k].max(1);
            // u in Q16; the end segments extrapolate without bound.
            let mut u = (ab << 8) / (bk >> 8).max(1);
            let lo = if k == 0 { i64::MIN } else { 0 };
            let hi = if k + 2 == n { i64::MAX } else { ONE };
            let dist = if u < lo || u > hi {
                u = u.clamp(lo, hi);
                if u == 0 {
                    ax
                } else {
                    ax - 2 * ab + bk
                }
            } else {
                // ab·u = ab²/bb ≤ ax in exact arithmetic; the clamp only guards.
                let proj = (i128::from(ab) * i128::from(u)) >> 16;
                ax - proj.clamp(0, i128::from(i64::MAX)) as i64
            };
            found[i] = (
                dist,
                t[k] + ((i128::from(u) * i128::from(t[k + 1] - t[k])) >> 16) as i64,
            );
        }
        // Likelihood-weighted mean of the segments' nearest points (see `Curve::eval`): weights
        // e^{−Δd/2} from a table in 1/32 σ² steps.
        let best = found.iter().map(|f| f.0).min().unwrap_or(i64::MAX);
        let (mut sw, mut st) = (0i64, 0i128);
        for &(dist, ti) in &found {
            if dist == i64::MAX {
                continue;
            }
            // Δd is Q24 σ²; the table steps are 1/32 σ² = 2¹⁹; keep 8 fraction bits.
            let pos = (dist - best) >> 11;
            let k = (pos >> 8) as usize;
            if k + 1 >= softmin.len() {
                continue;
            }
            let f = pos & 255;
            let w = softmin[k] + (((softmin[k + 1] - softmin[k]) * f) >> 8);
            sw += w;
            st += i128::from(w) * i128::from(ti);
        }
        match (sw, i64::try_from(st)) {
            (0, _) => t[0],
            // The common case in 64 bits (a 128-bit division is a library call).
            (_, Ok(st)) => st / sw,
            (_, Err(_)) => (st / i128::from(sw)) as i64,
        }
    }
}

/// Both populations and the range, in integers.
#[derive(Debug, Clone)]
pub struct FixedModel {
    coloured: Pop,
    black: Pop,
    f: Vec<i64>,
    /// XYZ rows over the white point, Q16.
    m: [[i64; 3]; 3],
    range: [i64; 2],
    /// [`TemperatureModel::blind_above_c`], Q16 °C.
    blind_above: Option<i64>,
    domain: [[i64; 2]; 3],
    /// [`TemperatureModel::contact_chroma_spread`], Q16.
    pub(super) chroma_spread: [i64; 2],
}

/// Invariants of a block in Q16 (r, g, q; see [`super::lab::Invariants`]), the coloured
/// chromaticity measured against the black stripes of `white`; `None` when a channel of
/// either population is black. Means first (Q16 linear), so every ratio stays below 2³²
/// and every product fits 64 bits.
pub fn invariants_q16(s: &Sums, white: &Sums) -> Option<[i64; 3]> {
    if s.n[0] == 0 || s.n[1] == 0 || white.n[1] == 0 {
        return None;
    }
    let mean = |s: &Sums, p: usize| s.sum[p].map(|v| (v / u64::from(s.n[p])) as i64);
    let (c, k, w) = (mean(s, 0), mean(s, 1), mean(white, 1));
    if c.iter().chain(&k).chain(&w).any(|v| *v <= 0) {
        return None;
    }
    let ratio: [i64; 3] = std::array::from_fn(|j| (c[j] << 16) / w[j]);
    let total: i64 = ratio.iter().sum();
    let q: i64 = (0..3)
        .map(|j| Y_Q16[j] * ((k[j] << 16) / c[j]))
        .sum::<i64>()
        >> 16;
    Some([(ratio[0] << 16) / total, (ratio[1] << 16) / total, q])
}

impl FixedModel {
    /// The calibration's models in integers.
    pub fn new(model: &TemperatureModel) -> FixedModel {
        const M: [[f64; 3]; 3] = [
            [0.412_456_4, 0.357_576_1, 0.180_437_5],
            [0.212_672_9, 0.715_152_2, 0.072_175],
            [0.019_333_9, 0.119_192, 0.950_304_1],
        ];
        let d = &model.domain;
        FixedModel {
            coloured: Pop::new(&model.coloured),
            black: Pop::new(&model.black),
            f: lab_f_table(),
            m: std::array::from_fn(|i| std::array::from_fn(|k| q16(M[i][k] / D65[i]))),
            range: [q16(model.range_c[0]), q16(model.range_c[1])],
            blind_above: model.blind_above_c.map(q16),
            domain: [d.r, d.g, d.q].map(|r| [q16(r[0]), q16(r[1])]),
            chroma_spread: model.contact_chroma_spread.map(q16),
        }
    }

    /// CIELAB `f` of a Q16 ratio.
    fn lab_f(&self, t: i64) -> i64 {
        let t = t.clamp(0, 4 * ONE - 1);
        let (k, frac) = ((t >> 6) as usize, t & 63);
        self.f[k] + (((self.f[k + 1] - self.f[k]) * frac) >> 6)
    }

    /// Features (a*, b*, Lk) of invariants, Q16: a*, b* of the chromaticity at luminance ½,
    /// Lk the black stripes' lightness against the coloured.
    fn features(&self, v: [i64; 3]) -> [i64; 3] {
        let c = [v[0], v[1], ONE - v[0] - v[1]];
        let y: i64 = c.iter().zip(Y_Q16).map(|(a, w)| a * w).sum::<i64>() >> 16;
        let y = y.max(1);
        let n = c.map(|a| (a * (ONE / 2)) / y);
        let xyz: [i64; 3] = std::array::from_fn(|i| {
            self.m[i].iter().zip(&n).map(|(m, a)| m * a).sum::<i64>() >> 16
        });
        let f = xyz.map(|t| self.lab_f(t));
        let a = 500 * (f[0] - f[1]);
        let b = 200 * (f[1] - f[2]);
        let lk = 116 * self.lab_f(v[2]) - 16 * ONE;
        [a, b, lk]
    }

    /// The coloured (from `own`) and black (from `pooled`) estimates, Q16 °C.
    #[cfg(test)]
    fn estimates(&self, own: [i64; 3], pooled: [i64; 3]) -> (i64, i64) {
        (
            self.population(Population::Coloured, own).0,
            self.population(Population::Black, pooled).0,
        )
    }

    /// One population's estimate (Q16 °C), and whether the invariants lie in the
    /// calibrated box.
    pub fn population(&self, p: Population, v: [i64; 3]) -> (i64, bool) {
        let f = self.features(v);
        let t = match p {
            Population::Coloured => self.coloured.eval(f),
            Population::Black => self.black.eval([f[2], f[0], f[1]]),
        };
        let in_domain = v
            .iter()
            .zip(&self.domain)
            .all(|(x, d)| *x >= d[0] && *x <= d[1]);
        (t, in_domain)
    }

    /// The black estimate's weight in the inverse-variance blend, vc / (vc + vb) as a Q16
    /// fraction (so every product fits 64 bits), and the black variance vb (Q16 °C²), both
    /// variances read at `at` (Q16 °C).
    fn weight(&self, at: i64) -> (i64, i64) {
        let (vc, vb) = (self.coloured.table.at(at), self.black.table.at(at));
        ((vc << 16) / (vc + vb).max(1), vb)
    }

    /// The black estimate's weight (Q16) with the variances read at `guess` (Q16 °C): the
    /// blend's first pass, the same for every block that shares the guess.
    pub fn guess_weight(&self, guess: i64) -> i64 {
        self.weight(guess).0
    }

    /// The two populations' estimates blended as [`super::model::blend`] does, from the
    /// black estimate's weight at the guess ([`FixedModel::guess_weight`]): temperature
    /// (°C), variance (°C²) and whether it is inside what was calibrated.
    pub fn fuse(&self, c: (i64, bool), b: (i64, bool), guess_weight: i64) -> (f64, f64, bool) {
        let ((tc, ic), (tb, ib)) = (c, b);
        // (tc·vb + tb·vc) / (vc + vb) = tc + (tb − tc)·w; the variance vc·vb / (vc + vb) = vb·w.
        let blend = |w: i64| tc + (((tb - tc) * w) >> 16);
        let (w, vb) = self.weight(blend(guess_weight));
        let (t, var) = (blend(w), (vb * w) >> 16);
        (
            t as f64 / 65_536.0,
            var as f64 / 65_536.0,
            self.in_range(t, var) && ic && ib,
        )
    }

    /// Whether a reading `t` (Q16 °C) of variance `var` (Q16 °C²) lies inside the
    /// calibrated range (± half a degree) within two standard deviations, capped like the
    /// float model's, and does not reach what the camera could not see
    /// ([`TemperatureModel::blind_above_c`]).
    fn in_range(&self, t: i64, var: i64) -> bool {
        let need = (t - self.range[1] - ONE / 2).max(self.range[0] - ONE / 2 - t);
        let blind = self
            .blind_above
            .is_some_and(|b| two_sigma_reaches(var, b - ONE / 2 - t));
        two_sigma_reaches(var, need) && !blind
    }
}

/// Whether two standard deviations of a variance `var` (Q16 °C²), capped like the float
/// model's, reach `need` (Q16 °C): 2·min(σ, cap) ≥ need, with σ = ⌊√(var · 2¹⁶)⌋ in Q16
/// °C. That holds exactly when min(σ, cap) ≥ m = ⌈need / 2⌉, that is cap ≥ m and
/// var · 2¹⁶ ≥ m², so no square root is taken.
fn two_sigma_reaches(var: i64, need: i64) -> bool {
    let m = (need + 1) >> 1;
    need <= 0
        || (m <= SIGMA_CAP_Q16 && (var.max(0) as u64).saturating_mul(1 << 16) >= (m * m) as u64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::Calibration;
    use crate::thermal::lab::Invariants;

    /// The range check decides as its square-root form does, also at the edges where
    /// rounding matters: the calibrated range's, and that of a camera blind above 31 °C.
    #[test]
    fn range_check_matches_its_square_root_form() {
        let mut model = Calibration::default_sim().temperature.unwrap();
        model.blind_above_c = Some(31.0);
        let fixed = FixedModel::new(&model);
        let blind = q16(31.0) - ONE / 2;
        let sqrt_form = |t: i64, var: i64| {
            let sigma = ((var.max(0) as u64).saturating_mul(1 << 16)).isqrt() as i64;
            let two_sigma = 2 * sigma.min(SIGMA_CAP_Q16);
            t - two_sigma <= fixed.range[1] + ONE / 2
                && t + two_sigma >= fixed.range[0] - ONE / 2
                && t + two_sigma < blind
        };
        let (mut inside, mut outside) = (0, 0);
        for edge in [fixed.range[0] - ONE / 2, blind, fixed.range[1] + ONE / 2] {
            // Coarse steps, and the edge itself and two capped deviations away, finely.
            let fine = [0, 2 * ONE, -2 * ONE].map(|c| c - 40..c + 40);
            for dt in (-3 * ONE..3 * ONE)
                .step_by(997)
                .chain(fine.into_iter().flatten())
            {
                for var in [
                    0,
                    1,
                    2,
                    3,
                    1_000,
                    16_383,
                    16_384,
                    65_535,
                    65_536,
                    1 << 20,
                    -5,
                ] {
                    let t = edge + dt;
                    let want = sqrt_form(t, var);
                    assert_eq!(fixed.in_range(t, var), want, "t {t} var {var}");
                    if want {
                        inside += 1;
                    } else {
                        outside += 1;
                    }
                }
            }
        }
        assert!(inside > 100 && outside > 100);
    }

    /// Over the whole box of calibrated colours, almost everywhere. (Far from the calibration
    /// curve two of its segments can be nearly equally near, and rounding may pick the other
    /// one; on real blocks the two paths agree within 0.05 °C, tested end to end.)
    #[test]
    fn integer_models_follow_the_float_models() {
        let model = Calibration::default_sim().temperature.unwrap();
        let fixed = FixedModel::new(&model);
        let d = &model.domain;
        let (mut far, mut n) = (0usize, 0usize);
        let mut state = 12_345u64;
        let mut next = |r: [f64; 2]| {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1);
            r[0] + (r[1] - r[0]) * ((state >> 11) as f64 / (1u64 << 53) as f64)
        };
        for _ in 0..4000 {
            let v = Invariants {
                r: next(d.r),
                g: next(d.g),
                q: next(d.q),
            };
            let vq = [q16(v.r), q16(v.g), q16(v.q)];
            let (tc, tb) = fixed.estimates(vq, vq);
            let fc = model.population(Population::Coloured, &v);
            let fb = model.population(Population::Black, &v);
            for e in [tc as f64 / 65_536.0 - fc, tb as f64 / 65_536.0 - fb] {
                far += usize::from(e.abs() > 0.02);
                n += 1;
            }
        }
        assert!(
            far * 200 < n,
            "{far} of {n} estimates differ by more than 0.02 °C"
        );
    }
}
