//! The device path: integer arithmetic per frame, O(1) work per pixel.
//!
//! **Demodulation instead of a per-frame FFT.** Multiplying the luminance by
//! `e^{−i·2π(fx·x + fy·y)}` moves the first order to DC and everything else (DC, the other
//! side band, harmonics) to multiples of the carrier; a separable low-pass then keeps the
//! first order: the same analytic signal an FTP band-pass gives. The low-pass is a
//! triangle (two cascaded boxes) each way, computed as a cascaded-integrator-comb filter
//! whose cost does not depend on its length. Along x the box spans one carrier period, so
//! its nulls fall exactly on the unwanted orders; along y it spans one period too, for a
//! round footprint.
//!
//! **Scaling.** Luminance is 8.8 fixed point (≤ 65 280). The mixing table is Q15, so a
//! mixed sample is `(g·c) >> 15`, |·| ≤ 65 280. The filters are not normalised: their gain
//! `lx²·ly²` is kept (every amplitude test compares amplitudes of the same gain, and the
//! phase does not depend on it), and `headroom_shift` shifts the mixed samples down just
//! enough for the filtered value to fit an `i32` (no shift for periods up to 13 working
//! pixels). The integrators wrap; the comb's result is exact because it fits. Nothing is
//! rescaled between stages, so no stage loses the precision of a small signal. The product
//! with the conjugate reference is taken in 64 bits.
//!
//! **atan2** reduces to the first octant, divides once (Q16 ratio), and interpolates a
//! 257-entry table: error below 2·10⁻⁵ rad. Phases are `i32` in units of 2π/65 536, so
//! wrapping is a cast to `i16`. They are computed where the measurement reads them (a
//! coarse grid and the contact window, `measure`), not for every pixel.
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

/// `atan(k/256)` for k = 0…256, in phase units (2π = 65 536), built once.
pub fn atan_table() -> &'static [u16; 257] {
    static TABLE: std::sync::OnceLock<[u16; 257]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        std::array::from_fn(|k| {
            ((k as f64 / 256.0).atan() * 65_536.0 / std::f64::consts::TAU).round() as u16
        })
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

/// The centred triangle low-pass of length `2·len − 1` (two cascaded boxes of length
/// `len`, the same response as two running-sum box passes) along rows or columns, by the
/// cascaded-integrator-comb structure: two running integrators and the comb
/// `I₂[k+len−1] − 2·I₂[k−1] + I₂[k−len−1]`. Two additions per sample and a comb of three
/// taps, whatever `len`, and no normalisation: the phase does not depend on the gain, and
/// every amplitude test compares amplitudes of the same gain. Lines are zero-padded at both
/// ends (the measurement's margin excludes the pixels that see the padding).
///
/// Arithmetic wraps: the integrators overflow, and the comb's result is still exact as long
/// as it fits in an `i32` ([`headroom_shift`] scales the input so that it does). Columns
/// are filtered a whole row at a time, so that pass reads memory in order and vectorises.
struct Cic {
    len: usize,
}

impl Cic {
    /// Filters every row of `buf` (`w × h`) along x, using `work` for one row of `I₂`.
    fn rows(&self, buf: &mut [i32], w: usize, work: &mut Vec<i32>) {
        let l = self.len;
        // work[k] = I₂ at sample k − (l + 1); zero for k ≤ l.
        work.clear();
        work.resize(w + 2 * l, 0);
        for row in buf.chunks_exact_mut(w) {
            let (mut i1, mut i2) = (0i32, 0i32);
            let (head, tail) = work[l + 1..].split_at_mut(w);
            for (slot, v) in head.iter_mut().zip(row.iter()) {
                i1 = i1.wrapping_add(*v);
                i2 = i2.wrapping_add(i1);
                *slot = i2;
            }
            // Past the end the input is zero: I₁ stays, I₂ keeps growing by it.
            for slot in tail.iter_mut() {
                i2 = i2.wrapping_add(i1);
                *slot = i2;
            }
            for (x, out) in row.iter_mut().enumerate() {
                *out = work[x + 2 * l]
                    .wrapping_sub(work[x + l].wrapping_mul(2))
                    .wrapping_add(work[x]);
            }
        }
    }

    /// Filters every column of `buf` (`w × h`) along y, a whole row of columns at a time;
    /// `work` holds `I₂` for `h + 2·len` rows.
    fn columns(&self, buf: &mut [i32], w: usize, h: usize, work: &mut Vec<i32>) {
        let l = self.len;
        work.clear();
        work.resize(w * (h + 2 * l), 0);
        let mut i1 = vec![0i32; w];
        let mut i2 = vec![0i32; w];
        for k in l + 1..h + 2 * l {
            let y = k - (l + 1);
            if y < h {
                for (a, v) in i1.iter_mut().zip(&buf[y * w..(y + 1) * w]) {
                    *a = a.wrapping_add(*v);
                }
            }
            for (b, a) in i2.iter_mut().zip(&i1) {
                *b = b.wrapping_add(*a);
            }
            work[k * w..(k + 1) * w].copy_from_slice(&i2);
        }
        for (y, out) in buf.chunks_exact_mut(w).enumerate() {
            let (r0, r1, r2) = (y * w, (y + l) * w, (y + 2 * l) * w);
            for (x, o) in out.iter_mut().enumerate() {
                *o = work[r2 + x]
                    .wrapping_sub(work[r1 + x].wrapping_mul(2))
                    .wrapping_add(work[r0 + x]);
            }
        }
    }
}

/// Right shift of the mixed samples that keeps the triangle filters' results within an
/// `i32`: their gain is `lx²·ly²` on samples of at most 65 280.
fn headroom_shift(lx: usize, ly: usize) -> u32 {
    let gain = (lx * lx * ly * ly) as u64 * 65_280;
    let mut shift = 0;
    while (gain >> shift) > i32::MAX as u64 {
        shift += 1;
    }
    shift
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
    shift: u32,
    re_ref: Vec<i32>,
    im_ref: Vec<i32>,
    amp_ref: Vec<u32>,
    ref_median: u32,
    atan: &'static [u16; 257],
    lut: DepthLut,
    rows_only: bool,
}

/// |z| approximated as max + ⅜·min (within 7 %): enough for reliability and ordering.
fn amp(re: i32, im: i32) -> u32 {
    let (a, b) = (u64::from(re.unsigned_abs()), u64::from(im.unsigned_abs()));
    let (hi, lo) = if a > b { (a, b) } else { (b, a) };
    (hi + ((3 * lo) >> 3)).min(u64::from(u32::MAX)) as u32
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
        let shift = headroom_shift(lx, if rows_only { 1 } else { ly });
        let mut f = FixedFtp {
            w,
            h,
            factor,
            carrier,
            mix,
            lx,
            ly,
            shift,
            re_ref: Vec::new(),
            im_ref: Vec::new(),
            amp_ref: Vec::new(),
            ref_median: 0,
            atan: atan_table(),
            lut: DepthLut::new(calib),
            rows_only,
        };
        (f.re_ref, f.im_ref) = f.analytic(&gray);
        f.amp_ref = f
            .re_ref
            .iter()
            .zip(&f.im_ref)
            .map(|(&a, &b)| amp(a, b))
            .collect();
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

    /// The analytic signal of a Q8 luminance image as (re, im) planes, in luminance Q8
    /// units times the filters' gain over `2^shift`.
    fn analytic(&self, gray: &[u16]) -> (Vec<i32>, Vec<i32>) {
        let (w, h) = (self.w, self.h);
        let sh = 15 + self.shift;
        let (re, im): (Vec<i32>, Vec<i32>) = gray
            .iter()
            .zip(&self.mix)
            .map(|(g, m)| {
                let g = i32::from(*g);
                ((g * i32::from(m[0])) >> sh, -((g * i32::from(m[1])) >> sh))
            })
            .unzip();
        let (mut re, mut im) = (re, im);
        let mut work = Vec::new();
        for buf in [&mut re, &mut im] {
            Cic { len: self.lx }.rows(buf, w, &mut work);
            if !self.rows_only {
                Cic { len: self.ly }.columns(buf, w, h, &mut work);
            }
        }
        (re, im)
    }

    /// The frame's analytic signal; its phase difference to the reference is computed per
    /// pixel where the measurement asks for it (a coarse grid and the contact region).
    pub fn phase(&self, frame: &RgbImage) -> FixedField<'_> {
        let (gray, w, h, saturated) = gray_down_q8(frame, self.factor);
        assert_eq!(
            (w, h),
            (self.w, self.h),
            "frame size differs from the reference"
        );
        let (re, im) = self.analytic(&gray);
        FixedField {
            ftp: self,
            re,
            im,
            saturated_fraction: saturated,
        }
    }

    /// The reference's grating phase per working pixel, units of 2π/65 536: the mixing
    /// phase plus the demodulated signal's argument.
    pub fn grating_phase(&self) -> Vec<u16> {
        let (fx, fy) = (f64::from(self.carrier.fx), f64::from(self.carrier.fy));
        self.re_ref
            .iter()
            .zip(&self.im_ref)
            .enumerate()
            .map(|(i, (&re, &im))| {
                let mix = (fx * (i % self.w) as f64 + fy * (i / self.w) as f64) * 65_536.0;
                let arg = f64::from(im).atan2(f64::from(re)) / std::f64::consts::TAU;
                (mix + arg * 65_536.0).round().rem_euclid(65_536.0) as u16
            })
            .collect()
    }
}

/// A frame on the device path: its analytic signal, whose phase difference to the
/// reference's is computed where it is read.
#[derive(Debug)]
pub struct FixedField<'a> {
    ftp: &'a FixedFtp,
    re: Vec<i32>,
    im: Vec<i32>,
    /// Fraction of the sampled input pixels with a saturated channel.
    pub saturated_fraction: f32,
}

impl PhaseMap for FixedField<'_> {
    type P = i32;
    fn size(&self) -> (usize, usize) {
        (self.ftp.w, self.ftp.h)
    }
    /// `arg(z · conj z_ref)` in phase units: the product in 64 bits, then the integer
    /// `atan2`.
    fn wrapped(&self, i: usize) -> i32 {
        let (a, b) = (i64::from(self.re[i]), i64::from(self.im[i]));
        let (c, d) = (i64::from(self.ftp.re_ref[i]), i64::from(self.ftp.im_ref[i]));
        atan2_units(b * c - a * d, a * c + b * d, self.ftp.atan)
    }
    fn amp_frame(&self, i: usize) -> u32 {
        amp(self.re[i], self.im[i])
    }
    fn amp_ref(&self, i: usize) -> u32 {
        self.ftp.amp_ref[i]
    }
    fn amp_ref_median(&self) -> u32 {
        self.ftp.ref_median
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
                let got = f64::from(atan2_units(y, x, t)) / 65_536.0 * std::f64::consts::TAU;
                let want = (y as f64).atan2(x as f64);
                let mut e = (got - want).abs();
                e = e.min((e - std::f64::consts::TAU).abs());
                if r > 10.0 {
                    worst = worst.max(e);
                }
            }
        }
        assert!(worst < 2e-4, "worst error {worst} rad");
        assert_eq!(atan2_units(0, 0, t), 0);
    }

    #[test]
    fn triangle_filter_keeps_constants_and_nulls_its_period() {
        let (w, h, l) = (40, 30, 8);
        let gain = (l * l) as i32;
        let mut work = Vec::new();
        let mut flat = vec![1000i32; w * h];
        Cic { len: l }.rows(&mut flat, w, &mut work);
        for x in l..w - l {
            assert_eq!(flat[w + x], 1000 * gain, "x={x}");
        }
        let mut wave: Vec<i32> = (0..w * h)
            .map(|i| (1000.0 * (std::f64::consts::TAU * (i % w) as f64 / 8.0).cos()) as i32)
            .collect();
        Cic { len: l }.rows(&mut wave, w, &mut work);
        for x in l..w - l {
            assert!(wave[w + x].abs() <= 2 * gain, "x={x}: {}", wave[w + x]);
        }
        // Columns: the same filter along y, and the headroom shift keeps the largest
        // input inside an i32 through both.
        let mut col: Vec<i32> = (0..w * h).map(|i| 500 + (i / w) as i32).collect();
        Cic { len: 4 }.columns(&mut col, w, h, &mut work);
        for y in 4..h - 4 {
            assert_eq!(col[y * w + 3], (500 + y as i32) * 16, "y={y}");
        }
        let s = headroom_shift(64, 64);
        let worst = (65_280u64 >> s) * 64u64.pow(4);
        assert!(worst <= i32::MAX as u64);
    }
}
