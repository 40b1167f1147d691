//! The device path: integer arithmetic per frame, O(1) work per pixel.
//!
//! **Demodulation instead of a per-frame FFT.** Multiplying the luminance by
//! `e^{−i·2π(fx·x + fy·y)}` moves the first order to DC and everything else (DC, the other
//! side band, harmonics) to multiples of the carrier; a separable low-pass then keeps the
//! first order: the same analytic signal an FTP band-pass gives, but with running-sum box
//! filters (two passes each way, a triangular kernel) whose cost does not depend on their
//! length. Along x the box spans one carrier period, so its nulls fall exactly on the
//! unwanted orders; along y it spans one period too, for a round footprint.
//!
//! **Scaling.** Luminance is 8.8 fixed point (≤ 65 280). The mixing table is Q15, so a
//! mixed sample is `(g·c) >> 15`, |·| ≤ 65 280: no headroom problem. Each box pass is a sum
//! of ≤ L samples (≤ 2²² for L ≤ 64) normalised by a Q16 reciprocal in 64-bit: the signal
//! keeps its scale through every pass, so there is neither overflow nor the loss of
//! precision that scaling at every stage would cause. The product with the conjugate
//! reference (64-bit) is shifted per pixel to 31 bits before an integer `atan2`.
//!
//! **atan2** reduces to the first octant, divides once (Q16 ratio), and interpolates a
//! 257-entry table: error below 2·10⁻⁵ rad. Phases are `i32` in units of 2π/65 536, so
//! wrapping is a cast to `i16`.
//!
//! Reference-side work (carrier, mixing table, reference analytic signal, depth table) is
//! done once in [`FixedFtp::new`]; the carrier itself is estimated in floating point there,
//! once per reference.

use image::RgbImage;

use super::carrier::{self, Carrier};
use super::image_ops::gray_down_q8;
use super::measure::{PhaseMap, UNITS_PER_RAD};
use super::PipelineError;
use crate::calibration::Calibration;

/// `atan(k/256)` for k = 0…256, in phase units (2π = 65 536).
fn atan_table() -> [u16; 257] {
    std::array::from_fn(|k| {
        ((k as f64 / 256.0).atan() * 65_536.0 / std::f64::consts::TAU).round() as u16
    })
}

/// Integer `atan2(y, x)` in phase units, in [−32 768, 32 767].
pub fn atan2_units(y: i64, x: i64, table: &[u16; 257]) -> i32 {
    let (ax, ay) = (x.unsigned_abs(), y.unsigned_abs());
    if ax == 0 && ay == 0 {
        return 0;
    }
    let (lo, hi) = if ay > ax { (ay, ax) } else { (ax, ay) };
    // hi / lo in Q16 (≤ 65 536); lo > 0 here. Shift both down to 47 bits first so the
    // 64-bit division cannot overflow.
    let shift = 64 - lo.leading_zeros();
    let (hi, lo) = if shift > 47 {
        (hi >> (shift - 47), (lo >> (shift - 47)).max(1))
    } else {
        (hi, lo)
    };
    let t = ((hi << 16) / lo) as u32;
    let (k, f) = ((t >> 8) as usize, t & 0xff);
    let a0 = u32::from(table[k.min(256)]);
    let a1 = u32::from(table[(k + 1).min(256)]);
    let mut a = (a0 + (((a1 - a0) * f + 128) >> 8)) as i32; // 0 … 8192 (π/4)
    if ay > ax {
        a = 16_384 - a;
    }
    if x < 0 {
        a = 32_768 - a;
    }
    if y < 0 {
        a = -a;
    }
    i32::from(a as i16)
}

/// One running-sum box pass of length `len` over `src` (a line of `n` samples), edge-
/// replicated, `before` samples to the left of each output; normalised by `recip` (Q16).
#[inline]
fn box_line(src: &[i32], dst: &mut [i32], len: usize, before: usize, recip: i64) {
    let n = src.len();
    let at = |k: isize| src[k.clamp(0, n as isize - 1) as usize];
    let mut sum: i64 = (0..len)
        .map(|k| i64::from(at(k as isize - before as isize)))
        .sum();
    let after = (len - before) as isize;
    // Edges (clamped reads) and the interior (direct reads) in one loop with a fast path.
    for (i, d) in dst.iter_mut().enumerate() {
        *d = ((sum * recip) >> 16) as i32;
        let (add, sub) = (i as isize + after, i as isize - before as isize);
        let (a, b) = if sub >= 0 && (add as usize) < n {
            (src[add as usize], src[sub as usize])
        } else {
            (at(add), at(sub))
        };
        sum += i64::from(a) - i64::from(b);
    }
}

/// Two passes of a running-sum box of length `len` along rows (`along_x`) or columns of
/// `buf` (`w × h`), edge-replicated, normalised by a Q16 reciprocal. Columns are processed
/// a whole row at a time, so memory is read in order.
fn box2(buf: &mut [i32], w: usize, h: usize, len: usize, along_x: bool, tmp: &mut Vec<i32>) {
    let len = len.max(1);
    let recip = (((1u64 << 16) + len as u64 / 2) / len as u64) as i64;
    tmp.resize(buf.len(), 0);
    // An even box is off-centre by half a sample; the second pass leans the other way, so
    // the cascade is centred.
    for before in [len / 2, (len - 1) / 2] {
        if along_x {
            for (src, dst) in buf.chunks_exact(w).zip(tmp.chunks_exact_mut(w)) {
                box_line(src, dst, len, before, recip);
            }
        } else {
            let row = |y: isize| y.clamp(0, h as isize - 1) as usize * w;
            let mut sum: Vec<i64> = vec![0; w];
            for k in 0..len {
                let r = row(k as isize - before as isize);
                for (s, v) in sum.iter_mut().zip(&buf[r..r + w]) {
                    *s += i64::from(*v);
                }
            }
            let after = (len - before) as isize;
            for y in 0..h {
                for (d, s) in tmp[y * w..(y + 1) * w].iter_mut().zip(&sum) {
                    *d = ((s * recip) >> 16) as i32;
                }
                let (ra, rs) = (row(y as isize + after), row(y as isize - before as isize));
                for ((s, a), b) in sum.iter_mut().zip(&buf[ra..ra + w]).zip(&buf[rs..rs + w]) {
                    *s += i64::from(*a) - i64::from(*b);
                }
            }
        }
        buf.copy_from_slice(tmp);
    }
}

/// Phase → depth table: depth (µm) every [`DepthLut::STEP`] phase units, linear between.
#[derive(Debug, Clone)]
pub struct DepthLut {
    um: Vec<i32>,
}

impl DepthLut {
    /// Table step, phase units (≈ 0.006 rad).
    pub const STEP: i32 = 64;
    /// Phases covered, units (8 turns).
    pub const SPAN: i32 = 8 * 65_536;

    /// Tabulates the calibration's model.
    pub fn new(calib: &Calibration) -> DepthLut {
        let n = (Self::SPAN / Self::STEP) as usize + 1;
        let um = (0..n)
            .map(|k| {
                let x = f64::from(k as i32 * Self::STEP) / f64::from(UNITS_PER_RAD);
                (calib.depth.model.depth_mm(x) * 1000.0)
                    .round()
                    .clamp(-1e9, 1e9) as i32
            })
            .collect();
        DepthLut { um }
    }

    /// Depth of phase `x` (units; ≤ 0 → 0), µm. Beyond the table, the last slope continues.
    pub fn depth_um(&self, x: i32) -> i32 {
        if x <= 0 {
            return 0;
        }
        let k = (x / Self::STEP) as usize;
        let last = self.um.len() - 1;
        let (k0, k1) = if k < last {
            (k, k + 1)
        } else {
            (last - 1, last)
        };
        let (d0, d1) = (i64::from(self.um[k0]), i64::from(self.um[k1]));
        let dx = i64::from(x) - i64::from(k0 as i32 * Self::STEP);
        (d0 + (d1 - d0) * dx / i64::from(Self::STEP))
            .clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
    }
}

/// Reference-side state of the integer pipeline.
#[derive(Debug, Clone)]
pub struct FixedFtp {
    w: usize,
    h: usize,
    factor: usize,
    carrier: Carrier,
    mix: Vec<[i16; 2]>,
    lx: usize,
    ly: usize,
    z_ref: Vec<[i32; 2]>,
    amp_ref: Vec<u32>,
    ref_median: u32,
    atan: [u16; 257],
    trig: Vec<[i16; 2]>,
    lut: DepthLut,
    rows_only: bool,
}

/// |z| approximated as max + ⅜·min (within 7 %): enough for reliability and ordering.
fn amp(z: [i32; 2]) -> u32 {
    let (a, b) = (z[0].unsigned_abs(), z[1].unsigned_abs());
    let (hi, lo) = if a > b { (a, b) } else { (b, a) };
    hi + ((3 * lo) >> 3)
}

impl FixedFtp {
    /// Prepares the reference, whose carrier `working` describes.
    pub fn new(
        reference: &RgbImage,
        working: &carrier::Working,
        calib: &Calibration,
    ) -> Result<FixedFtp, PipelineError> {
        FixedFtp::with_filter(reference, working, calib, false)
    }

    /// As [`FixedFtp::new`]; `rows_only` low-passes along rows only (a 1-D band-pass per
    /// row instead of 2-D: a trade-off configuration, cheaper and noisier).
    pub fn with_filter(
        reference: &RgbImage,
        working: &carrier::Working,
        calib: &Calibration,
        rows_only: bool,
    ) -> Result<FixedFtp, PipelineError> {
        let (factor, carrier) = (working.factor, working.carrier);
        let (gray, w, h, _) = gray_down_q8(reference, factor);
        let mix = (0..w * h)
            .map(|i| {
                let th = std::f64::consts::TAU
                    * (f64::from(carrier.fx) * (i % w) as f64
                        + f64::from(carrier.fy) * (i / w) as f64);
                [
                    (th.cos() * 32_767.0).round() as i16,
                    (th.sin() * 32_767.0).round() as i16,
                ]
            })
            .collect();
        let (lx, ly) = super::float_ftp::box_lengths(&carrier);
        let trig = (0..4096)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / 4096.0;
                [
                    (a.cos() * 32_767.0).round() as i16,
                    (a.sin() * 32_767.0).round() as i16,
                ]
            })
            .collect();
        let mut f = FixedFtp {
            w,
            h,
            factor,
            carrier,
            mix,
            lx,
            ly,
            z_ref: Vec::new(),
            amp_ref: Vec::new(),
            ref_median: 0,
            atan: atan_table(),
            trig,
            lut: DepthLut::new(calib),
            rows_only,
        };
        f.z_ref = f.analytic(&gray);
        f.amp_ref = f.z_ref.iter().map(|&z| amp(z)).collect();
        let mut a = f.amp_ref.clone();
        let k = a.len() / 2;
        f.ref_median = a.select_nth_unstable(k).1.to_owned();
        Ok(f)
    }

    /// Working size (w, h) and the downsampling factor.
    pub fn geometry(&self) -> (usize, usize, usize) {
        (self.w, self.h, self.factor)
    }

    /// The carrier at the working resolution.
    pub fn carrier(&self) -> Carrier {
        self.carrier
    }

    /// The analytic signal of a Q8 luminance image, `[re, im]` in luminance Q8 units.
    fn analytic(&self, gray: &[u16]) -> Vec<[i32; 2]> {
        let (w, h) = (self.w, self.h);
        let mut re: Vec<i32> = Vec::with_capacity(w * h);
        let mut im: Vec<i32> = Vec::with_capacity(w * h);
        for (g, m) in gray.iter().zip(&self.mix) {
            let g = i32::from(*g);
            re.push((g * i32::from(m[0])) >> 15);
            im.push(-((g * i32::from(m[1])) >> 15));
        }
        let mut tmp = Vec::new();
        for buf in [&mut re, &mut im] {
            box2(buf, w, h, self.lx, true, &mut tmp);
            if !self.rows_only {
                box2(buf, w, h, self.ly, false, &mut tmp);
            }
        }
        re.into_iter().zip(im).map(|(a, b)| [a, b]).collect()
    }

    /// Wrapped phase difference (units) and frame amplitude per working pixel.
    pub fn phase(&self, frame: &RgbImage) -> FixedField<'_> {
        let (gray, w, h, saturated) = gray_down_q8(frame, self.factor);
        assert_eq!(
            (w, h),
            (self.w, self.h),
            "frame size differs from the reference"
        );
        let z = self.analytic(&gray);
        let mut wrapped = Vec::with_capacity(w * h);
        let mut amp_frame = Vec::with_capacity(w * h);
        for (zf, zr) in z.iter().zip(&self.z_ref) {
            let (a, b, c, d) = (
                i64::from(zf[0]),
                i64::from(zf[1]),
                i64::from(zr[0]),
                i64::from(zr[1]),
            );
            wrapped.push(atan2_units(b * c - a * d, a * c + b * d, &self.atan));
            amp_frame.push(amp(*zf));
        }
        let saturated_fraction =
            saturated as f32 / (frame.width() as f32 * frame.height() as f32).max(1.0);
        FixedField {
            ftp: self,
            wrapped,
            amp_frame,
            saturated_fraction,
        }
    }

    /// The reference's grating phase per working pixel, units of 2π/65 536: the mixing
    /// phase plus the demodulated signal's argument.
    pub fn grating_phase(&self) -> Vec<u16> {
        let (fx, fy) = (f64::from(self.carrier.fx), f64::from(self.carrier.fy));
        self.z_ref
            .iter()
            .enumerate()
            .map(|(i, z)| {
                let mix = (fx * (i % self.w) as f64 + fy * (i / self.w) as f64) * 65_536.0;
                let arg = f64::from(z[1]).atan2(f64::from(z[0])) / std::f64::consts::TAU;
                (mix + arg * 65_536.0).round().rem_euclid(65_536.0) as u16
            })
            .collect()
    }
}

/// A frame's phase on the device path.
#[derive(Debug)]
pub struct FixedField<'a> {
    ftp: &'a FixedFtp,
    /// Wrapped phase difference, units.
    pub wrapped: Vec<i32>,
    /// Frame amplitude.
    pub amp_frame: Vec<u32>,
    /// Fraction of input pixels with a saturated channel.
    pub saturated_fraction: f32,
}

impl PhaseMap for FixedField<'_> {
    type P = i32;
    fn size(&self) -> (usize, usize) {
        (self.ftp.w, self.ftp.h)
    }
    fn wrapped(&self, i: usize) -> i32 {
        self.wrapped[i]
    }
    fn amp_frame(&self, i: usize) -> u32 {
        self.amp_frame[i]
    }
    fn amp_ref(&self, i: usize) -> u32 {
        self.ftp.amp_ref[i]
    }
    fn amp_ref_median(&self) -> u32 {
        self.ftp.ref_median
    }
    fn mean_direction(&self, keep: &dyn Fn(usize) -> bool) -> i32 {
        let (mut s, mut c) = (0i64, 0i64);
        for i in (0..self.wrapped.len()).filter(|&i| keep(i)) {
            let t = self.ftp.trig[((self.wrapped[i].wrapping_add(8) as u32 >> 4) & 4095) as usize];
            let a = i64::from(self.amp_frame[i]);
            c += a * i64::from(t[0]);
            s += a * i64::from(t[1]);
        }
        atan2_units(s, c, &self.ftp.atan)
    }
    fn saturated_fraction(&self) -> f32 {
        self.saturated_fraction
    }
    fn depth_um(&self, x: i32) -> i32 {
        self.ftp.lut.depth_um(x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integer_atan2_matches_float_everywhere() {
        let t = atan_table();
        let mut worst = 0.0f64;
        for k in 0..3600 {
            let a = std::f64::consts::TAU * k as f64 / 3600.0 - std::f64::consts::PI;
            for r in [1.0, 37.0, 1e4, 3e9] {
                let (y, x) = ((a.sin() * r).round() as i64, (a.cos() * r).round() as i64);
                let got = f64::from(atan2_units(y, x, &t)) / 65_536.0 * std::f64::consts::TAU;
                let want = (y as f64).atan2(x as f64);
                let mut e = (got - want).abs();
                e = e.min((e - std::f64::consts::TAU).abs());
                if r > 10.0 {
                    worst = worst.max(e);
                }
            }
        }
        assert!(worst < 2e-4, "worst error {worst} rad");
        assert_eq!(atan2_units(0, 0, &t), 0);
    }

    #[test]
    fn box_filter_keeps_constants_and_nulls_its_period() {
        let (w, h) = (40, 3);
        let mut flat = vec![1000i32; w * h];
        let mut tmp = Vec::new();
        box2(&mut flat, w, h, 8, true, &mut tmp);
        assert!(flat.iter().all(|&v| (v - 1000).abs() <= 1), "{flat:?}");
        let mut wave: Vec<i32> = (0..w * h)
            .map(|i| (1000.0 * (std::f64::consts::TAU * (i % w) as f64 / 8.0).cos()) as i32)
            .collect();
        box2(&mut wave, w, h, 8, true, &mut tmp);
        for x in 8..32 {
            assert!(wave[w + x].abs() <= 2, "x={x}: {}", wave[w + x]);
        }
    }
}
