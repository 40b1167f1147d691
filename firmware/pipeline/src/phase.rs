//! Phase representations (float radians, integer units) and what the measurement reads
//! from either path.

use crate::fixed_point::{atan2_units, atan_table, UNITS_PER_RAD};
use crate::unwrap::Phase;

/// Step of the coarse grid, working pixels each way: registration, noise, contrast and
/// contact detection read the phase every `GRID`-th pixel (the analytic signal is smooth
/// over a carrier period, 6–12 working pixels); the contact region is read at every pixel.
pub const GRID: usize = 2;

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
    fn resultant(samples: impl Iterator<Item = (Self, u32)>) -> Resultant<Self::Sum> {
        let mut r = Resultant::default();
        Self::accumulate(&mut r, samples);
        r
    }
    /// Adds `samples` to the resultant `r`, in order: a set read in several runs sums as
    /// one pass over it would, even in floating point.
    fn accumulate(r: &mut Resultant<Self::Sum>, samples: impl Iterator<Item = (Self, u32)>);
    /// The resultant of the samples where `mask` holds, in order, reading `MASK_RUN` (16) at a
    /// time and skipping the runs without any (registration's later sets are sparse or
    /// clustered: a few outliers, a contact's tiles, the background around a large one).
    fn masked_resultant(phase: &[Self], amp: &[u32], mask: &[bool]) -> Resultant<Self::Sum> {
        let mut r = Resultant::default();
        let runs = phase
            .chunks(MASK_RUN)
            .zip(amp.chunks(MASK_RUN))
            .zip(mask.chunks(MASK_RUN));
        for ((p, a), m) in runs {
            if m.iter().fold(false, |any, &on| any | on) {
                let picked = p.iter().zip(a).zip(m).filter(|(_, on)| **on);
                Self::accumulate(&mut r, picked.map(|((p, a), _)| (*p, *a)));
            }
        }
        r
    }
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

/// Samples per run of [`PhaseNum::masked_resultant`]: a run's mask is tested in one vector
/// reduction.
const MASK_RUN: usize = 16;

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
    fn accumulate(r: &mut Resultant<f64>, samples: impl Iterator<Item = (f32, u32)>) {
        let (mut s, mut c) = (r.s, r.c);
        for (p, a) in samples {
            s += f64::from(a) * f64::from(p).sin();
            c += f64::from(a) * f64::from(p).cos();
        }
        *r = Resultant { s, c };
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
    fn accumulate(r: &mut Resultant<i64>, samples: impl Iterator<Item = (i32, u32)>) {
        let trig = trig_q15();
        let (mut s, mut c) = (r.s, r.c);
        for (p, a) in samples {
            let t = trig[((p.wrapping_add(8) as u32 >> 4) & 4095) as usize];
            c += i64::from(a) * i64::from(t[0]);
            s += i64::from(a) * i64::from(t[1]);
        }
        *r = Resultant { s, c };
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
    /// Every coarse sample's wrapped phase difference, in order: [`PhaseMap::wrapped`] for
    /// `k` = 0, 1, …; a path may compute them in one pass.
    fn wrapped_all(&self) -> Vec<Self::P> {
        (0..self.coarse_len()).map(|k| self.wrapped(k)).collect()
    }
    /// Fringe amplitude of the frame at coarse sample `k` (any fixed scale shared with
    /// `amp_ref`).
    fn amp_frame(&self, k: usize) -> u32;
    /// Fringe amplitude of the reference at coarse sample `k`.
    fn amp_ref(&self, k: usize) -> u32;
    /// Every coarse sample's [`PhaseMap::amp_frame`], in order; a path may compute them in
    /// one pass.
    fn amp_frame_all(&self) -> Vec<u32> {
        (0..self.coarse_len()).map(|k| self.amp_frame(k)).collect()
    }
    /// Every coarse sample's [`PhaseMap::amp_ref`], in order; a path that keeps them may
    /// lend them.
    fn amp_ref_all(&self) -> std::borrow::Cow<'_, [u32]> {
        (0..self.coarse_len()).map(|k| self.amp_ref(k)).collect()
    }
    /// Samples of the coarse grid: `w.div_ceil(GRID) · h.div_ceil(GRID)`.
    fn coarse_len(&self) -> usize {
        let (w, h) = self.size();
        w.div_ceil(GRID) * h.div_ceil(GRID)
    }
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
    pub(crate) cw: usize,
    pub(crate) coarse: Vec<i32>,
    /// The region's window: origin, width, height and values (every pixel of it is read).
    pub(crate) local: Option<(usize, usize, usize, usize, Vec<i32>)>,
    /// The registration the measurement found and its contact threshold, units: where
    /// [`WrappedPhase::at_rest`] puts a sample back, and how far it may have moved.
    pub(crate) offset: i32,
    pub(crate) threshold: i32,
    /// Whether the measurement took a field of the colour's phase out before reading
    /// ([`colour_phase`](crate::measure::colour_phase)).
    pub(crate) colour_field: bool,
}

impl WrappedPhase {
    /// The difference as a frame known to be at rest reads it (a calibration frame
    /// labelled without contact): each sample that moved from the registration by more
    /// than the contact threshold is put back on it, and the contact region's pixels are
    /// dropped. With nothing pressing, the stripes lie where the reference's do, moved by
    /// the registration; a phase moved there is a misreading (under a glare spot, or where
    /// the pigment's colour lowers the grating's contrast), and stripes placed by it mix
    /// the two populations. Samples within the threshold keep their reading, so a slow
    /// drift of the grating under it (the skin warming) is followed as the service
    /// follows it.
    pub fn at_rest(&self) -> WrappedPhase {
        let moved = |d: i32| i32::from(d.wrapping_sub(self.offset) as i16).abs() > self.threshold;
        WrappedPhase {
            cw: self.cw,
            coarse: (self.coarse.iter())
                .map(|&d| if moved(d) { self.offset } else { d })
                .collect(),
            local: None,
            offset: self.offset,
            threshold: self.threshold,
            colour_field: self.colour_field,
        }
    }

    /// Adds back to the contact window's pixels the field (units per coarse sample) the
    /// measurement took out of the phase before reading them
    /// ([`colour_phase`](crate::measure::colour_phase)), each its coarse sample's: the
    /// stripes lie where the phase as read puts them.
    pub fn restore_local(&mut self, field: &[i32]) {
        let cw = self.cw;
        if let Some((x0, y0, bw, _, v)) = &mut self.local {
            for (i, u) in v.iter_mut().enumerate() {
                let (x, y) = (*x0 + i % *bw, *y0 + i / *bw);
                let f = field.get((y / GRID) * cw + x / GRID).copied().unwrap_or(0);
                *u = i32::from(u.wrapping_add(f) as i16);
            }
        }
    }

    /// The frame's grating phase along working row `y` into `out` (units): `reference` (the
    /// reference's phase along that row) plus the wrapped phase difference, in one pass.
    pub fn frame_row(&self, y: usize, reference: &[u16], out: &mut [u16]) {
        let n = out.len().min(reference.len());
        let (out, reference) = (&mut out[..n], &reference[..n]);
        let c = (y / GRID) * self.cw;
        let crow = self.coarse.get(c..c + self.cw).unwrap_or(&[]);
        let full = (n / GRID).min(crow.len()) * GRID;
        let groups = out[..full]
            .chunks_exact_mut(GRID)
            .zip(reference[..full].chunks_exact(GRID))
            .zip(crow);
        for ((o, r), &d) in groups {
            for (v, &t) in o.iter_mut().zip(r) {
                *v = t.wrapping_add(d as u16);
            }
        }
        // A partial last group (odd width): the last sample; no sample: no difference.
        let d = crow.last().map_or(0, |&d| d as u16);
        for (v, &t) in out[full..].iter_mut().zip(&reference[full..]) {
            *v = t.wrapping_add(d);
        }
        if let Some((x0, y0, bw, bh, v)) = &self.local {
            if y >= *y0 && y < y0 + bh {
                let src = &v[(y - y0) * bw..(y - y0 + 1) * bw];
                let at = (*x0).min(n);
                for ((o, &t), &u) in out[at..].iter_mut().zip(&reference[at..]).zip(src) {
                    *o = t.wrapping_add(u as u16);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The masked resultant skips only runs without a sample: it equals the plain
    /// filtered sum, in integers and (the same order) in floating point, for sparse,
    /// clustered and dense masks and a length that is not a whole number of runs.
    #[test]
    fn masked_resultants_equal_the_plain_filtered_sums() {
        let mut rng = crate::test_rng::XorShift(0x0123_4567_89ab_cdef);
        let n = 1000 + MASK_RUN / 2;
        let phase: Vec<i32> = (0..n).map(|_| rng.next() as i16 as i32).collect();
        let amp: Vec<u32> = (0..n).map(|_| (rng.next() % 100_000) as u32).collect();
        let phase_f: Vec<f32> = phase.iter().map(|&p| p as f32 / UNITS_PER_RAD).collect();
        let masks: [Vec<bool>; 4] = [
            (0..n).map(|_| rng.next().is_multiple_of(100)).collect(),
            (0..n).map(|i| (300..420).contains(&i)).collect(),
            (0..n).map(|_| !rng.next().is_multiple_of(10)).collect(),
            (0..n).map(|i| i == n - 1).collect(),
        ];
        for mask in &masks {
            let pick = |p: &[i32]| {
                p.iter()
                    .zip(&amp)
                    .zip(mask)
                    .filter(|(_, m)| **m)
                    .map(|((p, a), _)| (*p, *a))
                    .collect::<Vec<_>>()
            };
            let want = i32::resultant(pick(&phase).into_iter());
            assert_eq!(i32::masked_resultant(&phase, &amp, mask), want);
            assert_ne!(want, Resultant::default());
            let want_f = f32::resultant(
                phase_f
                    .iter()
                    .zip(&amp)
                    .zip(mask)
                    .filter(|(_, m)| **m)
                    .map(|((p, a), _)| (*p, *a)),
            );
            assert_eq!(f32::masked_resultant(&phase_f, &amp, mask), want_f);
        }
    }

    /// A frame at rest reads the registration wherever its phase moved beyond the contact
    /// threshold, either way and across the wrap, keeps its reading within it, and drops
    /// the contact region's pixels.
    #[test]
    fn a_frame_at_rest_puts_its_moved_samples_back_on_the_registration() {
        let (offset, threshold) = (32_000, 400);
        let read = [
            (32_000, 32_000),   // on the registration
            (32_399, 32_399),   // within the threshold
            (31_601, 31_601),   // within, the other way
            (-33_137, -33_137), // within, across the wrap (32_399 one cycle down)
            (32_401, offset),   // just beyond
            (-32_000, offset),  // beyond, across the wrap
            (20_000, offset),   // far the other way
        ];
        let wrapped = WrappedPhase {
            cw: read.len(),
            coarse: read.iter().map(|r| r.0).collect(),
            local: Some((0, 0, 1, 1, vec![9_000])),
            offset,
            threshold,
            colour_field: false,
        };
        let rest = wrapped.at_rest();
        assert_eq!(rest.coarse, read.iter().map(|r| r.1).collect::<Vec<_>>());
        assert!(rest.local.is_none());
        let mut out = [0u16; 1];
        rest.frame_row(0, &[0], &mut out);
        assert_eq!(
            out[0], offset as u16,
            "the region's pixel reads the registration"
        );
    }

    /// The frame's phase row against its plain reading, pixel by pixel: the reference's
    /// phase plus the contact window's value inside it and the nearest coarse sample
    /// elsewhere, on odd and even widths, with and without a window.
    #[test]
    fn frame_rows_add_the_difference_to_the_reference() {
        let mut rng = crate::test_rng::XorShift(0x9e37_79b9_7f4a_7c15);
        for (w, h) in [(9usize, 7usize), (10, 6), (1, 3)] {
            let cw = w.div_ceil(GRID);
            let coarse: Vec<i32> = (0..cw * h.div_ceil(GRID))
                .map(|_| rng.next() as i16 as i32)
                .collect();
            let reference: Vec<u16> = (0..w * h).map(|_| rng.next() as u16).collect();
            for local in [None, Some((w / 3, 1, w - w / 3, h - 2))] {
                let local = local.map(|(x0, y0, bw, bh)| {
                    let v = (0..bw * bh).map(|_| rng.next() as i16 as i32).collect();
                    (x0, y0, bw, bh, v)
                });
                let wrapped = WrappedPhase {
                    cw,
                    coarse: coarse.clone(),
                    local: local.clone(),
                    ..Default::default()
                };
                for y in 0..h {
                    let r = &reference[y * w..(y + 1) * w];
                    let mut out = vec![0u16; w];
                    wrapped.frame_row(y, r, &mut out);
                    for x in 0..w {
                        let d = match &local {
                            Some((x0, y0, bw, bh, v))
                                if (*x0..x0 + bw).contains(&x) && (*y0..y0 + bh).contains(&y) =>
                            {
                                v[(y - y0) * bw + x - x0]
                            }
                            _ => coarse[(y / GRID) * cw + x / GRID],
                        };
                        assert_eq!(out[x], r[x].wrapping_add(d as u16), "{w}×{h} ({x}, {y})");
                    }
                }
            }
        }
    }
}
