//! The device path's colour → temperature: the calibration's models in integer arithmetic.
//!
//! Per block, from the 64-bit colour sums: the invariants (chromaticity r, g and the
//! black-to-coloured luminance ratio q) in Q16 by integer division; CIELAB's XYZ matrix in
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
//! Cost per block: three divisions for the invariants, one per chromaticity channel, six
//! table reads, and per model either its monomials or three multiply-adds per curve segment.

use super::lab::D65;
use super::model::{ColourModel, TemperatureModel, VarianceTable};
use super::stripes::Sums;

const ONE: i64 = 1 << 16;

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

/// A population's model in integers.
#[derive(Debug, Clone)]
enum Eval {
    Poly {
        mean: Vec<i64>,
        inv_std: Vec<i64>,
        exps: Vec<Vec<u32>>,
        coef: Vec<i64>,
    },
    Curve {
        /// Knots, raw features, Q16.
        knots: Vec<Vec<i64>>,
        /// 1/σ per feature, Q16.
        inv_scale: Vec<i64>,
        /// Whitened segment vectors, Q16.
        d: Vec<Vec<i64>>,
        /// Their squared lengths, Q32.
        bb: Vec<i128>,
        /// Knot temperatures, Q16 °C.
        t: Vec<i64>,
    },
}

#[derive(Debug, Clone)]
struct Table {
    t0: i64,
    step: i64,
    var: Vec<i64>,
}

const UNKNOWN_Q16: i64 = (VarianceTable::UNKNOWN_C2 * 65_536.0) as i64;

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
        // Position in Q16 bins.
        let x = (i128::from(t - self.t0) << 16) / i128::from(self.step);
        let last = i128::from((n - 1) * ONE);
        let beyond = if x < 0 {
            -x
        } else if x > last {
            x - last
        } else {
            0
        };
        if beyond >= i128::from(ONE / 2) {
            return UNKNOWN_Q16;
        }
        let x = x.clamp(0, last) as i64;
        let k = (x >> 16).min(n - 1) as usize;
        let f = x & (ONE - 1);
        let next = self.var[(k + 1).min(self.var.len() - 1)];
        let v = self.var[k] + (((next - self.var[k]) as i128 * i128::from(f)) >> 16) as i64;
        let keep = i128::from(ONE) - 2 * beyond; // > 0 here
        ((i128::from(v) << 16) / keep).min(i128::from(UNKNOWN_Q16)) as i64
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
                mean: p.mean.iter().map(|&v| q16(v)).collect(),
                inv_std: p.std.iter().map(|&s| q16(1.0 / s)).collect(),
                exps: super::model::monomials(p.mean.len(), p.degree),
                coef: p.coef.iter().map(|&c| q16(c)).collect(),
            },
            ColourModel::Curve(c) => {
                let inv: Vec<i64> = c.scale.iter().map(|&s| q16(1.0 / s)).collect();
                let d: Vec<Vec<i64>> = c
                    .knots
                    .windows(2)
                    .map(|w| {
                        w[0].iter()
                            .zip(&w[1])
                            .zip(&c.scale)
                            .map(|((a, b), s)| q16((b - a) / s))
                            .collect()
                    })
                    .collect();
                let bb = d
                    .iter()
                    .map(|v| v.iter().map(|&x| i128::from(x) * i128::from(x)).sum())
                    .collect();
                Eval::Curve {
                    knots: c
                        .knots
                        .iter()
                        .map(|k| k.iter().map(|&v| q16(v)).collect())
                        .collect(),
                    inv_scale: inv,
                    d,
                    bb,
                    t: c.t_c.iter().map(|&t| q16(t)).collect(),
                }
            }
        };
        Pop {
            eval,
            table: Table::new(&m.variance),
        }
    }

    /// Temperature (Q16 °C) at features `x` (Q16).
    fn eval(&self, x: &[i64]) -> i64 {
        match &self.eval {
            Eval::Poly {
                mean,
                inv_std,
                exps,
                coef,
            } => {
                let z: Vec<i64> = x
                    .iter()
                    .zip(mean.iter().zip(inv_std))
                    .map(|(v, (m, s))| (((v - m) as i128 * i128::from(*s)) >> 16) as i64)
                    .collect();
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
                (acc >> 16) as i64
            }
            Eval::Curve {
                knots,
                inv_scale,
                d,
                bb,
                t,
            } => {
                let n = t.len();
                let (mut best, mut best_t) = (i128::MAX, t.first().copied().unwrap_or(0));
                for k in 0..n.saturating_sub(1) {
                    let (mut ab, mut ax) = (0i128, 0i128);
                    for j in 0..x.len() {
                        let e = ((x[j] - knots[k][j]) as i128 * i128::from(inv_scale[j])) >> 16;
                        ab += i128::from(d[k][j]) * e;
                        ax += e * e;
                    }
                    let mut u: i128 = if bb[k] > 0 { (ab << 16) / bb[k] } else { 0 };
                    if k > 0 {
                        u = u.max(0);
                    }
                    if k + 2 < n {
                        u = u.min(i128::from(ONE));
                    }
                    let dist = ax - ((2 * u * ab) >> 16) + ((((u * u) >> 16) * bb[k]) >> 16);
                    if dist < best {
                        best = dist;
                        best_t = t[k] + ((u * i128::from(t[k + 1] - t[k])) >> 16) as i64;
                    }
                }
                best_t
            }
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
    domain: [[i64; 2]; 3],
}

/// Invariants of a block in Q16 (r, g, q), or `None` when the coloured stripes are black.
pub fn invariants_q16(s: &Sums) -> Option<[i64; 3]> {
    let total: u64 = s.coloured.iter().sum();
    let y = |c: &[u64; 3]| -> u128 {
        c.iter()
            .zip(Y_Q16)
            .map(|(v, w)| u128::from(*v) * w as u128)
            .sum()
    };
    let (yc, yk) = (y(&s.coloured), y(&s.black));
    if total == 0 || yc == 0 || s.n_black == 0 {
        return None;
    }
    let r = ((u128::from(s.coloured[0]) << 16) / u128::from(total)) as i64;
    let g = ((u128::from(s.coloured[1]) << 16) / u128::from(total)) as i64;
    let q = ((yk * u128::from(s.n_coloured)) << 16) / (yc * u128::from(s.n_black));
    Some([r, g, q.min(i64::MAX as u128) as i64])
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
            domain: [d.r, d.g, d.q].map(|r| [q16(r[0]), q16(r[1])]),
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
    fn estimates(&self, own: [i64; 3], pooled: [i64; 3]) -> (i64, i64) {
        let fo = self.features(own);
        let fp = self.features(pooled);
        (
            self.coloured.eval(&fo),
            self.black.eval(&[fp[2], fp[0], fp[1]]),
        )
    }

    /// Temperature (°C), variance (°C²) and whether it is inside what was calibrated, from a
    /// block's invariants and its neighbourhood's.
    pub fn read(&self, own: [i64; 3], pooled: [i64; 3]) -> (f64, f64, bool) {
        let (tc, tb) = self.estimates(own, pooled);
        let (vc, vb) = (self.coloured.table.at(tc), self.black.table.at(tb));
        let w = i128::from(vc) + i128::from(vb);
        let (t, var) = if w == 0 {
            ((tc + tb) / 2, 0)
        } else {
            (
                ((i128::from(tc) * i128::from(vb) + i128::from(tb) * i128::from(vc)) / w) as i64,
                ((i128::from(vc) * i128::from(vb)) / w) as i64,
            )
        };
        // Two standard deviations (capped like the float model's), Q16: 2·sqrt(var · 2¹⁶).
        let sigma = ((var.max(0) as u64).saturating_mul(1 << 16)).isqrt() as i64;
        let two_sigma = 2 * sigma.min(q16(super::model::OUT_OF_RANGE_SIGMA_C));
        let in_range =
            t - two_sigma <= self.range[1] + ONE / 2 && t + two_sigma >= self.range[0] - ONE / 2;
        let in_domain = [own, pooled].iter().all(|v| {
            v.iter()
                .zip(&self.domain)
                .all(|(x, d)| *x >= d[0] && *x <= d[1])
        });
        (
            t as f64 / 65_536.0,
            var as f64 / 65_536.0,
            in_range && in_domain,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::Calibration;
    use crate::thermal::lab::Invariants;
    use crate::thermal::model::Population;

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
            let (fc, _) = model.population(Population::Coloured, &v);
            let (fb, _) = model.population(Population::Black, &v);
            for e in [tc as f64 / 65_536.0 - fc, tb as f64 / 65_536.0 - fb] {
                far += usize::from(e.abs() > 0.02);
                n += 1;
            }
        }
        assert!(far * 200 < n, "{far} of {n} estimates differ by more than 0.02 °C");
    }
}
