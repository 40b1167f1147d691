//! A flat punch of any footprint on an elastic half-space, solved numerically: the pressure
//! on a grid of square cells over the footprint such that the surface under it sinks by
//! exactly the indentation, and from that same pressure the displacement everywhere and the
//! force (their sum). Exact in the limit of fine cells; a disc reproduces Boussinesq's
//! `F = 2·E*·a·δ` within the tests' tolerance.
//!
//! Surface displacement of a half-space under pressure `p` (contact modulus `E*`):
//! `u(x) = 1/(π·E*) ∫ p(ξ)/|x − ξ| dξ`. A cell of side `s` carrying uniform pressure gives
//! at its own centre `4·s·ln(1 + √2)/(π·E*)` per unit pressure, and at a distance `r ≥ s`
//! very nearly `s²/(π·E*·r)` (the two differ by under 1 % at `r = s`).
//!
//! The solution scales with the indentation and with `1/E*`, so it is computed once per
//! footprint at unit depth and unit modulus and kept.

use std::collections::HashMap;
use std::f32::consts::PI;
use std::sync::{Arc, Mutex, OnceLock};

use crate::footprint::{Footprint, Mm};

/// Most cells a footprint is split into (the grid coarsens for large footprints).
const MAX_CELLS: f32 = 1600.0;
/// Finest cell side, mm.
const MIN_CELL_MM: f32 = 0.15;
/// How far beyond the footprint the displacement is tabulated, mm: farther out the finite
/// layer has cut it to nothing (its decay length is a few mm), and a point load stands in.
const FIELD_REACH_MM: f32 = 25.0;

/// A flat punch at unit depth and unit contact modulus: closed form for a disc, numerical
/// for any other footprint.
#[derive(Debug, Clone)]
pub enum Punch {
    /// Boussinesq's circular punch of radius `r_mm`: `F = 2·a`, and outside it
    /// `w = (2/π)·asin(a/r)`.
    Disc {
        /// Radius, mm.
        r_mm: f32,
    },
    /// Any other footprint, solved on cells.
    Solved(Arc<PunchSolution>),
}

impl Punch {
    /// The punch of footprint `fp` (a non-disc footprint is solved once and kept).
    pub fn of(fp: &Footprint) -> Punch {
        match fp {
            Footprint::Disc { r_mm } => Punch::Disc { r_mm: *r_mm },
            _ => Punch::Solved(PunchSolution::of(fp)),
        }
    }

    /// Force per mm of depth per MPa of contact modulus, N/(mm·MPa) (= mm²).
    pub fn stiffness(&self) -> f32 {
        match self {
            Punch::Disc { r_mm } => 2.0 * r_mm,
            Punch::Solved(s) => s.force,
        }
    }

    /// Surface displacement per mm of depth at `p` (mm from the centre), outside the
    /// footprint; 1 under it.
    pub fn displacement(&self, p: Mm) -> f32 {
        match self {
            Punch::Disc { r_mm } => {
                let r = p.0.hypot(p.1);
                if r <= *r_mm {
                    1.0
                } else {
                    2.0 / PI * (r_mm / r).asin()
                }
            }
            Punch::Solved(s) => s.field.at(p).unwrap_or_else(|| s.far_field(p)),
        }
    }
}

/// A footprint's pressure at unit depth and unit contact modulus, and the displacement it
/// makes around the footprint.
#[derive(Debug)]
pub struct PunchSolution {
    /// Cell side, mm.
    pub cell_mm: f32,
    /// Cell centres inside the footprint, mm from its centre.
    pub cells: Vec<Mm>,
    /// Pressure on each cell, MPa per mm of depth per MPa of modulus.
    pub pressure: Vec<f32>,
    /// Force at unit depth and modulus: the pressure's sum times the cell area, N.
    pub force: f32,
    /// The displacement tabulated around the footprint.
    field: Field,
}

impl PunchSolution {
    /// Solves `fp`.
    pub fn solve(fp: &Footprint) -> PunchSolution {
        let b = fp.bound_mm();
        let cell = (fp.area_mm2() / MAX_CELLS).sqrt().max(MIN_CELL_MM);
        let n = (2.0 * b / cell).ceil() as i32;
        let mut cells = Vec::new();
        for iy in 0..n {
            for ix in 0..n {
                let p = (-b + (ix as f32 + 0.5) * cell, -b + (iy as f32 + 0.5) * cell);
                if fp.signed_distance(p) <= 0.0 {
                    cells.push(p);
                }
            }
        }
        let pressure = conjugate_gradient(&cells, cell);
        let force = pressure.iter().sum::<f32>() * cell * cell;
        let mut s = PunchSolution {
            cell_mm: cell,
            cells,
            pressure,
            force,
            field: Field::default(),
        };
        s.field = Field::tabulate(fp, &s);
        s
    }

    /// The solution for `fp`, solved once per footprint and kept.
    pub fn of(fp: &Footprint) -> Arc<PunchSolution> {
        static CACHE: OnceLock<Mutex<HashMap<String, Arc<PunchSolution>>>> = OnceLock::new();
        let key = format!("{fp:?}");
        let cache = CACHE.get_or_init(Mutex::default);
        if let Some(s) = cache.lock().ok().and_then(|c| c.get(&key).cloned()) {
            return s;
        }
        let s = Arc::new(PunchSolution::solve(fp));
        if let Ok(mut c) = cache.lock() {
            c.insert(key, s.clone());
        }
        s
    }

    /// Displacement at `p` (mm from the footprint's centre) at unit depth and modulus,
    /// summed over every cell, mm.
    pub fn displacement(&self, p: Mm) -> f32 {
        let s = self.cell_mm;
        self.cells
            .iter()
            .zip(&self.pressure)
            .map(|(c, q)| q * influence(p.0 - c.0, p.1 - c.1, s))
            .sum()
    }

    /// Far from the footprint it acts as a point load: `w = F/(π·r)`.
    fn far_field(&self, p: Mm) -> f32 {
        self.force / (PI * p.0.hypot(p.1).max(self.cell_mm))
    }
}

/// The displacement outside a footprint on a square grid around it (inside, 1).
#[derive(Debug, Default)]
struct Field {
    /// Half-width of the grid, mm (it is centred on the footprint).
    half_mm: f32,
    step_mm: f32,
    n: usize,
    w: Vec<f32>,
}

impl Field {
    fn tabulate(fp: &Footprint, s: &PunchSolution) -> Field {
        let half = fp.bound_mm() + FIELD_REACH_MM;
        let step = s.cell_mm;
        let n = (2.0 * half / step).ceil() as usize + 1;
        let at = |i: usize| -half + i as f32 * step;
        let w = (0..n * n)
            .map(|k| {
                let p = (at(k % n), at(k / n));
                if fp.signed_distance(p) <= 0.0 {
                    1.0
                } else {
                    s.displacement(p)
                }
            })
            .collect();
        Field {
            half_mm: half,
            step_mm: step,
            n,
            w,
        }
    }

    /// Bilinear reading at `p`; `None` off the grid.
    fn at(&self, p: Mm) -> Option<f32> {
        let (fx, fy) = (
            (p.0 + self.half_mm) / self.step_mm,
            (p.1 + self.half_mm) / self.step_mm,
        );
        let last = (self.n as f32) - 1.0;
        if !(0.0..last).contains(&fx) || !(0.0..last).contains(&fy) {
            return None;
        }
        let (ix, iy) = (fx as usize, fy as usize);
        let (tx, ty) = (fx - ix as f32, fy - iy as f32);
        let v = |x: usize, y: usize| self.w[y * self.n + x];
        let top = v(ix, iy) * (1.0 - tx) + v(ix + 1, iy) * tx;
        let bottom = v(ix, iy + 1) * (1.0 - tx) + v(ix + 1, iy + 1) * tx;
        Some(top * (1.0 - ty) + bottom * ty)
    }
}

/// Displacement at offset `(dx, dy)` from a cell of side `s` under unit pressure, unit
/// modulus.
fn influence(dx: f32, dy: f32, s: f32) -> f32 {
    let r = dx.hypot(dy);
    if r < 0.5 * s {
        4.0 * s * (1.0 + std::f32::consts::SQRT_2).ln() / PI
    } else {
        s * s / (PI * r.max(s))
    }
}

/// Pressures `p` with `K·p = 1` on `cells` (unit depth), by conjugate gradients (`K` is
/// symmetric and positive definite).
fn conjugate_gradient(cells: &[Mm], s: f32) -> Vec<f32> {
    let n = cells.len();
    let k: Vec<f32> = (0..n * n)
        .map(|ij| {
            let (a, b) = (cells[ij / n], cells[ij % n]);
            influence(a.0 - b.0, a.1 - b.1, s)
        })
        .collect();
    let mul = |v: &[f32]| -> Vec<f32> {
        k.chunks_exact(n.max(1))
            .map(|row| row.iter().zip(v).map(|(a, b)| a * b).sum())
            .collect()
    };
    let dot = |a: &[f32], b: &[f32]| -> f32 { a.iter().zip(b).map(|(x, y)| x * y).sum() };
    let mut x = vec![0.0f32; n];
    let mut r = vec![1.0f32; n];
    let mut p = r.clone();
    let mut rr = dot(&r, &r);
    for _ in 0..400 {
        if rr <= 1e-10 * n as f32 {
            break;
        }
        let kp = mul(&p);
        let alpha = rr / dot(&p, &kp).max(f32::MIN_POSITIVE);
        for i in 0..n {
            x[i] += alpha * p[i];
            r[i] -= alpha * kp[i];
        }
        let next = dot(&r, &r);
        let beta = next / rr;
        rr = next;
        for i in 0..n {
            p[i] = r[i] + beta * p[i];
        }
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_disc_is_boussinesq() {
        for a in [2.0f32, 4.0, 6.0] {
            let s = PunchSolution::solve(&Footprint::Disc { r_mm: a });
            let exact = Punch::Disc { r_mm: a };
            let want = 2.0 * a;
            assert!(
                (s.force - want).abs() < 0.04 * want,
                "a {a}: {} vs {want}",
                s.force
            );
            assert_eq!(exact.stiffness(), want);
            // Under the punch the surface sinks by the depth; outside it follows
            // (2/π)·asin(a/r).
            assert!((s.displacement((0.3 * a, 0.0)) - 1.0).abs() < 0.02);
            for r in [1.5 * a, 3.0 * a] {
                let want = 2.0 / PI * (a / r).asin();
                let got = s.displacement((r, 0.0));
                assert!((got - want).abs() < 0.03, "r {r}: {got} vs {want}");
                assert!((exact.displacement((r, 0.0)) - want).abs() < 1e-6);
                // The tabulated field reads the sum.
                let grid = s.field.at((r, 0.3)).unwrap();
                assert!((grid - s.displacement((r, 0.3))).abs() < 0.01, "{grid}");
            }
        }
    }

    #[test]
    fn a_letter_is_bounded_by_the_disc_of_its_area_and_its_enclosing_disc() {
        let e = Footprint::letter_e(12.0);
        let s = PunchSolution::solve(&e);
        // Stiffness is the footprint's capacity: among plane shapes of one area the disc
        // has the least (Pólya–Szegő), and a shape inside another is less stiff.
        let same_area = 2.0 * (e.area_mm2() / PI).sqrt();
        let enclosing = 2.0 * std::f32::consts::SQRT_2 * e.bound_mm();
        assert!(
            s.force > same_area && s.force < enclosing,
            "{} in {same_area}..{enclosing}",
            s.force
        );
    }
}
