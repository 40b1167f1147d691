//! Phase representations (float radians, integer units) and what the measurement reads
//! from either path.

use super::GRID;
use crate::pipeline::fixed_ftp::{atan2_units, atan_table};
use crate::pipeline::unwrap::Phase;

/// Phase units per radian in the integer representation (65 536 per turn).
pub const UNITS_PER_RAD: f32 = 65_536.0 / std::f32::consts::TAU;

/// A phase representation the measurement can run on.
pub trait PhaseNum: Phase {
    /// `self − offset`, wrapped.
    fn minus(self, offset: Self) -> Self {
        Self::wrapped_diff(self, offset)
    }
    /// The value in integer phase units (2π = 65 536), for statistics.
    fn units(self) -> i32;
    /// A value from radians.
    fn from_rad(r: f32) -> Self;
    /// A value from integer phase units.
    fn from_units(u: i32) -> Self;
    /// `sign · self` for a sign of ±1.
    fn signed(self, sign: i32) -> Self;
    /// What a sum of directions is kept in: `f64` or, exactly, `i64`.
    type Sum: Copy + Default + std::ops::Sub<Output = Self::Sum>;
    /// The amplitude-weighted resultant of `(phase, amplitude)` samples: the numerator of
    /// their mean direction.
    fn resultant(samples: impl Iterator<Item = (Self, u32)>) -> Resultant<Self::Sum>;
    /// The direction of a resultant: the samples' amplitude-weighted mean direction.
    fn angle(r: Resultant<Self::Sum>) -> Self;
}

/// `(Σ a·sin φ, Σ a·cos φ)` of samples. In integers the sums are exact, so a subset's
/// resultant is the whole's minus the rest's: registration, which drops a few outliers and
/// then the contact from the same samples, sums only what it drops.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Resultant<T> {
    /// Σ a·sin φ.
    pub s: T,
    /// Σ a·cos φ.
    pub c: T,
}

impl<T: std::ops::Sub<Output = T>> std::ops::Sub for Resultant<T> {
    type Output = Resultant<T>;
    fn sub(self, o: Resultant<T>) -> Resultant<T> {
        Resultant {
            s: self.s - o.s,
            c: self.c - o.c,
        }
    }
}

/// `(cos, sin)` of 4 096 phases around the circle, Q15: the device path's mean direction.
fn trig_q15() -> &'static [[i16; 2]; 4096] {
    static TABLE: std::sync::OnceLock<[[i16; 2]; 4096]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        std::array::from_fn(|k| {
            let a = std::f64::consts::TAU * k as f64 / 4096.0;
            [
                (a.cos() * 32_767.0).round() as i16,
                (a.sin() * 32_767.0).round() as i16,
            ]
        })
    })
}

impl PhaseNum for f32 {
    fn units(self) -> i32 {
        (self * UNITS_PER_RAD).round() as i32
    }
    fn from_rad(r: f32) -> f32 {
        r
    }
    fn from_units(u: i32) -> f32 {
        u as f32 / UNITS_PER_RAD
    }
    fn signed(self, sign: i32) -> f32 {
        self * sign as f32
    }
    type Sum = f64;
    fn resultant(samples: impl Iterator<Item = (f32, u32)>) -> Resultant<f64> {
        let (mut s, mut c) = (0.0f64, 0.0f64);
        for (p, a) in samples {
            s += f64::from(a) * f64::from(p).sin();
            c += f64::from(a) * f64::from(p).cos();
        }
        Resultant { s, c }
    }
    fn angle(r: Resultant<f64>) -> f32 {
        r.s.atan2(r.c) as f32
    }
}

impl PhaseNum for i32 {
    fn units(self) -> i32 {
        self
    }
    fn from_rad(r: f32) -> i32 {
        (r * UNITS_PER_RAD).round() as i32
    }
    fn from_units(u: i32) -> i32 {
        u
    }
    fn signed(self, sign: i32) -> i32 {
        self * sign
    }
    type Sum = i64;
    fn resultant(samples: impl Iterator<Item = (i32, u32)>) -> Resultant<i64> {
        let trig = trig_q15();
        let (mut s, mut c) = (0i64, 0i64);
        for (p, a) in samples {
            let t = trig[((p.wrapping_add(8) as u32 >> 4) & 4095) as usize];
            c += i64::from(a) * i64::from(t[0]);
            s += i64::from(a) * i64::from(t[1]);
        }
        Resultant { s, c }
    }
    fn angle(r: Resultant<i64>) -> i32 {
        atan2_units(r.s, r.c, atan_table())
    }
}

/// A wrapped phase-difference map with fringe amplitudes on the coarse grid ([`GRID`]):
/// what either path hands to the measurement.
pub trait PhaseMap {
    /// Phase representation.
    type P: PhaseNum;
    /// Working width and height.
    fn size(&self) -> (usize, usize);
    /// Wrapped phase difference at coarse sample `k`: the working pixel
    /// `(GRID·(k % cw), GRID·(k / cw))`, `cw = w.div_ceil(GRID)` (the measurement reads
    /// each sample once, so a path may compute it here).
    fn wrapped(&self, k: usize) -> Self::P;
    /// Fringe amplitude of the frame at coarse sample `k` (any fixed scale shared with
    /// `amp_ref`).
    fn amp_frame(&self, k: usize) -> u32;
    /// Fringe amplitude of the reference at coarse sample `k`.
    fn amp_ref(&self, k: usize) -> u32;
    /// Median reference amplitude (computed once per reference).
    fn amp_ref_median(&self) -> u32;
    /// Fraction of the frame's input pixels with a saturated channel.
    fn saturated_fraction(&self) -> f32;
    /// Depth (µm) of an indentation phase `x` (already signed, ≥ 0 under indentation).
    fn depth_um(&self, x: Self::P) -> i32;
}

/// The wrapped phase difference (units) as the measurement read it: every [`GRID`]-th
/// pixel each way, and every pixel of the contact region and its border. Elsewhere the
/// nearest sample stands in, which is what the temperature's stripe placement needs: away
/// from contact the difference is the registration offset plus noise.
#[derive(Debug, Clone, Default)]
pub struct WrappedPhase {
    pub(super) cw: usize,
    pub(super) coarse: Vec<i32>,
    /// The region's window: origin, width, height and values (every pixel of it is read).
    pub(super) local: Option<(usize, usize, usize, usize, Vec<i32>)>,
}

impl WrappedPhase {
    /// The wrapped phase difference along working row `y` into `out` (the row's width).
    pub fn row(&self, y: usize, out: &mut [i32]) {
        let c = (y / GRID) * self.cw;
        if let Some(crow) = self.coarse.get(c..c + self.cw) {
            let mut pairs = out.chunks_exact_mut(GRID);
            for (o, &c) in (&mut pairs).zip(crow) {
                for v in o {
                    *v = c;
                }
            }
            // A partial last group (odd width): the last sample.
            if let Some(&c) = crow.last() {
                pairs.into_remainder().fill(c);
            }
        }
        if let Some((x0, y0, bw, bh, v)) = &self.local {
            if y >= *y0 && y < y0 + bh {
                let src = &v[(y - y0) * bw..(y - y0 + 1) * bw];
                for (o, &u) in out.iter_mut().skip(*x0).zip(src) {
                    *o = u;
                }
            }
        }
    }
}
