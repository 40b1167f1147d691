//! The device path: integer arithmetic per frame, O(1) work per pixel.
//!
//! **Demodulation instead of a per-frame FFT.** Multiplying the luminance by
//! `e^{−i·2π(fx·x + fy·y)}` moves the first order to DC and everything else (DC, the other
//! side band, harmonics) to multiples of the carrier; a separable low-pass then keeps the
//! first order: the same analytic signal an FTP band-pass gives. The low-pass is a
//! triangle (two cascaded boxes) each way, computed as a decimating
//! cascaded-integrator-comb filter whose cost does not depend on its length, its combs
//! evaluated only on the coarse grid the measurement reads (`demodulate`). Along x the
//! box spans one carrier period, so
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
//! **Phases** are `i32` in units of 2π/65 536 ([`crate::fixed_point`]), computed where the
//! measurement reads them: on the coarse grid, whose contact window `measure` unwraps and
//! upsamples.
//!
//! **Colours.** Where the lens puts the colours' gratings apart, each colour's fringe is
//! turned onto the luminance's before the low-pass ([`super::lateral`]): the downsampling
//! gives a quadrature term `q` beside the luminance, and the mixing takes two products per
//! plane instead of one. A unit whose colours agree pays nothing.
//!
//! Reference-side work (carrier, mixing table, the colours' offsets, reference analytic signal,
//! depth table) is done once in [`FixedFtp::new`]; the carrier itself is estimated in floating
//! point there, once per reference.

use crate::input::Pixels;

use super::band::box_lengths;
use super::carrier::{self, Carrier};
use super::lateral::{self, Offsets, Sample};
use crate::calibration::Calibration;
use crate::fixed_point::{atan2_units, atan_table, UNITS_PER_RAD};
use crate::image_ops::{gray_down_q8, gray_down_q8_into, gray_lateral_down_q8_into};
use crate::input::{luma, Colour};
use crate::phase::{PhaseMap, GRID};

/// `arg(z · conj z_ref)` in phase units, `z` and `z_ref` as (re, im): the product in 64
/// bits, then the integer `atan2`.
#[inline]
fn phase_difference(z: (i32, i32), z_ref: (i32, i32), table: &[u16; 257]) -> i32 {
    let (a, b) = (i64::from(z.0), i64::from(z.1));
    let (c, d) = (i64::from(z_ref.0), i64::from(z_ref.1));
    atan2_units(b * c - a * d, a * c + b * d, table)
}

/// The demodulated signal's planes, sampled every `step` working pixels each way.
#[derive(Debug, Clone, Default)]
struct Sampled {
    re: Vec<i32>,
    im: Vec<i32>,
}

/// Mixes a `w × h` Q8 luminance image down by the carrier (`mix`: Q15 cos, sin per pixel, shifted
/// down by `sh` bits after the product), with the lateral correction's quadrature term `q` where
/// given (`(g − i·q)·e^{−iθ}`, [`super::lateral`]), and low-passes it with the centred triangle of
/// length `2·l − 1` each way (`lx` along rows, `ly` along columns; a length of 1 is the identity),
/// writing every `step`-th sample each way into `out` (row-major, `w.div_ceil(step)` across) and
/// working in `buf`.
///
/// The triangles are cascaded-integrator-comb filters, streamed one input row at a time:
/// per column two running integrators, `I₂` of the last `2·ly + 1` rows kept in a ring, and
/// the comb `I₂[k] − 2·I₂[k − ly] + I₂[k − 2·ly]` evaluated only on the rows that are
/// sampled; then the same along that row, its comb only at the sampled columns. Two
/// additions per input sample and plane, whatever the lengths; the combs run at the output
/// rate (a decimating CIC). Lines are zero-padded at both ends (the measurement's margin
/// excludes the pixels that see the padding).
///
/// Arithmetic wraps: the integrators overflow, and each comb's result is still exact as
/// long as it fits in an `i32` ([`headroom_shift`] makes the mixed samples small enough).
/// The column pass runs first because its integrators vectorise across the row.
fn demodulate(
    (gray, quadrature): (&[u16], Option<&[i16]>),
    (w, h): (usize, usize),
    (mix, sh): (&Mix, u32),
    (lx, ly): (usize, usize),
    step: usize,
    buf: &mut Demod,
    out: &mut Sampled,
) {
    let step = step.max(1);
    let (ow, oh) = (w.div_ceil(step), h.div_ceil(step));
    out.re.clear();
    out.im.clear();
    out.re.reserve(ow * oh);
    out.im.reserve(ow * oh);
    let ring_n = 2 * ly + 1;
    buf.prepare(w, ring_n, lx);
    // Per plane (re, im): the columns' I₁ and I₂, and I₂ of the last rows; the column
    // combs of the sampled rows, two rows at a time (their re and im: the four lanes of
    // the row pass).
    let Demod {
        i1,
        i2,
        ring,
        cols,
        work,
        comb,
    } = buf;
    let mut pending = 0;
    for k in 0..h + ly - 1 {
        let slot = (k % ring_n) * w;
        for p in 0..2 {
            let (a, b) = (&mut i1[p], &mut i2[p]);
            let dst = &mut ring[p][slot..slot + w];
            if let (true, Some(quadrature)) = (k < h, quadrature) {
                let row = k * w..(k + 1) * w;
                let rows = (&gray[row.clone()], &quadrature[row.clone()]);
                let mix = (&mix.planes[0][row.clone()], &mix.planes[1][row]);
                if p == 0 {
                    integrate_quadrature::<0>(rows, mix, sh, (a, b), dst);
                } else {
                    integrate_quadrature::<1>(rows, mix, sh, (a, b), dst);
                }
            } else if k < h {
                // re = g·cos ≫ sh, im = −(g·sin ≫ sh): the product with e^{−iθ}.
                let (g, m) = (
                    &gray[k * w..(k + 1) * w],
                    &mix.planes[p][k * w..(k + 1) * w],
                );
                for ((((a, b), d), g), m) in a.iter_mut().zip(b.iter_mut()).zip(dst).zip(g).zip(m) {
                    let v = (i32::from(*g) * i32::from(*m)) >> sh;
                    *a = if p == 0 {
                        a.wrapping_add(v)
                    } else {
                        a.wrapping_sub(v)
                    };
                    *b = b.wrapping_add(*a);
                    *d = *b;
                }
            } else {
                // Past the last row the input is zero: I₁ stays, I₂ keeps growing by it.
                for ((a, b), d) in a.iter().zip(b.iter_mut()).zip(dst) {
                    *b = b.wrapping_add(*a);
                    *d = *b;
                }
            }
        }
        // I₂[k] is in; output row y needs I₂ up to y + ly − 1.
        let Some(y) = (k + 1).checked_sub(ly) else {
            continue;
        };
        if y % step != 0 {
            continue;
        }
        for p in 0..2 {
            let ring = &ring[p];
            let row = |j: usize| &ring[(j % ring_n) * w..(j % ring_n + 1) * w];
            let col = &mut cols[pending][p];
            // The comb I₂[k] − 2·I₂[k − ly] + I₂[k − 2·ly], rows before the first being 0.
            match (k.checked_sub(ly), k.checked_sub(2 * ly)) {
                (Some(j1), Some(j2)) => {
                    for ((c, &v0), (&v1, &v2)) in
                        col.iter_mut().zip(row(k)).zip(row(j1).iter().zip(row(j2)))
                    {
                        *c = v0.wrapping_sub(v1.wrapping_mul(2)).wrapping_add(v2);
                    }
                }
                (Some(j1), None) => {
                    for ((c, &v0), &v1) in col.iter_mut().zip(row(k)).zip(row(j1)) {
                        *c = v0.wrapping_sub(v1.wrapping_mul(2));
                    }
                }
                _ => col.copy_from_slice(row(k)),
            }
        }
        pending += 1;
        if pending == 2 {
            along_rows(cols, 2, work, comb, (lx, step), out);
            pending = 0;
        }
    }
    if pending == 1 {
        along_rows(cols, 1, work, comb, (lx, step), out);
    }
}

/// One input row of plane `P` (0: re, 1: im) mixed with the quadrature term, into the
/// columns' integrators `a` (I₁) and `b` (I₂) and the ring's row `dst`:
/// `(g − i·q)·e^{−iθ}`, so re = g·cos − q·sin and im = −(g·sin + q·cos), each product
/// shifted down by `sh`. The plane is a constant, so the loop has no branch; out of line,
/// so that the luminance-only loop beside it compiles as it would alone.
#[inline(never)]
fn integrate_quadrature<const P: usize>(
    (g, q): (&[u16], &[i16]),
    (cos, sin): (&[i16], &[i16]),
    sh: u32,
    (a, b): (&mut [i32], &mut [i32]),
    dst: &mut [i32],
) {
    let terms = g.iter().zip(q).zip(cos.iter().zip(sin));
    for (((a, b), d), ((&g, &q), (&c, &s))) in a.iter_mut().zip(b.iter_mut()).zip(dst).zip(terms) {
        let (g, q, c, s) = (i32::from(g), i32::from(q), i32::from(c), i32::from(s));
        *a = if P == 0 {
            a.wrapping_add(((g * c) >> sh) - ((q * s) >> sh))
        } else {
            a.wrapping_sub(((g * s) >> sh) + ((q * c) >> sh))
        };
        *b = b.wrapping_add(*a);
        *d = *b;
    }
}

/// The demodulator's working buffers, kept from frame to frame in a [`Scratch`].
#[derive(Debug, Clone, Default)]
struct Demod {
    /// Per plane (re, im): the columns' integrators I₁ and I₂.
    i1: [Vec<i32>; 2],
    i2: [Vec<i32>; 2],
    /// Per plane: I₂ of the last `2·ly + 1` rows.
    ring: [Vec<i32>; 2],
    /// The column combs of two sampled rows, per plane.
    cols: [[Vec<i32>; 2]; 2],
    /// `work[j]` = the rows' I₂ at sample j − (lx + 1), four lanes; zero for j ≤ lx.
    work: Vec<[i32; 4]>,
    /// The row combs at the sampled columns.
    comb: Vec<[i32; 4]>,
}

impl Demod {
    /// Sized for rows of `w` samples, a ring of `ring_n` rows and a row filter of length
    /// `lx`: the integrators and the row pass's lead-in zeroed; the ring and the combs are
    /// written before they are read.
    fn prepare(&mut self, w: usize, ring_n: usize, lx: usize) {
        let zeroed = |v: &mut Vec<i32>, n: usize| {
            v.clear();
            v.resize(n, 0);
        };
        for p in 0..2 {
            zeroed(&mut self.i1[p], w);
            zeroed(&mut self.i2[p], w);
            self.ring[p].resize(ring_n * w, 0);
            for row in &mut self.cols {
                row[p].resize(w, 0);
            }
        }
        self.work.resize(w + 2 * lx, [0; 4]);
        self.work[..=lx].fill([0; 4]);
        self.comb.clear();
    }
}

/// What the device path keeps from frame to frame: the luminance image, the demodulator's
/// buffers and the frame's analytic signal. One per stream of frames, owned by the caller
/// (as RustFFT's scratch is), so a frame allocates none of them.
#[derive(Debug, Clone, Default)]
pub struct Scratch {
    gray: Vec<u16>,
    /// The frame's quadrature term, where the reference needs one ([`Quadrature`]).
    quadrature: Vec<i16>,
    demod: Demod,
    frame: Sampled,
}

/// The triangle along the rows of the first `rows` (1 or 2) column-comb rows in `cols`,
/// appending every `step`-th sample of each to `out`: their re and im are the four lanes of
/// one pair of running sums (a lane's sums do not depend on the others', and four of them
/// fill a vector register where one row's serial sums would leave it a quarter used). The
/// lanes of a missing second row are computed and dropped.
fn along_rows(
    cols: &[[Vec<i32>; 2]; 2],
    rows: usize,
    work: &mut [[i32; 4]],
    comb: &mut Vec<[i32; 4]>,
    (lx, step): (usize, usize),
    out: &mut Sampled,
) {
    let w = cols[0][0].len();
    let (mut a, mut b) = ([0i32; 4], [0i32; 4]);
    let (head, tail) = work[lx + 1..].split_at_mut(w);
    let lanes = cols[0][0]
        .iter()
        .zip(&cols[0][1])
        .zip(cols[1][0].iter().zip(&cols[1][1]));
    for (d, ((&r0, &i0), (&r1, &i1))) in head.iter_mut().zip(lanes) {
        let v = [r0, i0, r1, i1];
        for l in 0..4 {
            a[l] = a[l].wrapping_add(v[l]);
            b[l] = b[l].wrapping_add(a[l]);
        }
        *d = b;
    }
    for d in tail.iter_mut() {
        for l in 0..4 {
            b[l] = b[l].wrapping_add(a[l]);
        }
        *d = b;
    }
    // The comb at the sampled columns, the four lanes at once, then each lane to its row.
    comb.clear();
    let taps = work[2 * lx..]
        .iter()
        .step_by(step)
        .zip(work[lx..].iter().step_by(step))
        .zip(work.iter().step_by(step))
        .take(w.div_ceil(step));
    comb.extend(taps.map(|((p, q), r)| {
        std::array::from_fn(|l| p[l].wrapping_sub(q[l].wrapping_mul(2)).wrapping_add(r[l]))
    }));
    for r in 0..rows {
        out.re.extend(comb.iter().map(|c| c[2 * r]));
        out.im.extend(comb.iter().map(|c| c[2 * r + 1]));
    }
}

/// The mixing table: Q15 `cos θ` and `sin θ` of the carrier phase per working pixel.
#[derive(Debug, Clone)]
struct Mix {
    planes: [Vec<i16>; 2],
}

/// The quadrature term of the lateral correction ([`super::lateral`]) on this path: each
/// colour's offsets, and per colour and working pixel `weightₖ/256 · εₖ`, Q15.
#[derive(Debug, Clone)]
struct Quadrature {
    k: [Vec<i16>; 3],
    offsets: Offsets,
}

impl Quadrature {
    /// Each colour's offset fitted on the reference's coarse samples (every colour
    /// demodulated as the luminance is); `None` unless RGB or where the colours need none.
    fn of(f: &FixedFtp, reference: Pixels<'_>) -> Option<Quadrature> {
        if reference.colour() != Colour::Rgb {
            return None;
        }
        let (w, h) = (f.w, f.h);
        let means = reference.box_means_q8(f.factor, w, h);
        let colours: [Sampled; 3] = std::array::from_fn(|k| {
            let plane: Vec<u16> = means.iter().skip(k).step_by(3).copied().collect();
            f.analytic(&plane, None, GRID)
        });
        let cw = w.div_ceil(GRID);
        let pair = |s: &Sampled, i: usize| (f64::from(s.re[i]), f64::from(s.im[i]));
        let samples: Vec<Sample> = (0..f.reference.re.len())
            .map(|i| ((i % cw) * GRID, (i / cw) * GRID, i))
            .filter(|&(x, y, _)| lateral::clear_of_padding((x, y), (w, h), (f.lx, f.ly)))
            .map(|(x, y, i)| Sample {
                at: (x as f64, y as f64),
                colours: std::array::from_fn(|k| pair(&colours[k], i)),
                luma: pair(&f.reference, i),
            })
            .collect();
        let offsets = Offsets::fit(&samples, (w, h))?;
        let weights = luma(Colour::Rgb).weights;
        Some(Quadrature {
            k: offsets.weighted(weights, |v| (v * 32_767.0).round() as i16),
            offsets,
        })
    }

    /// The largest |q| a frame can give, Q8 luminance units: the weights sum to one.
    fn top(&self) -> u32 {
        (self.offsets.largest_rad() * 65_280.0).ceil() as u32 + 1
    }
}

/// Right shift of the mixed samples that keeps the triangle filters' results within an
/// `i32`: their gain is `lx²·ly²` on samples of at most 65 280.
fn headroom_shift(lx: usize, ly: usize, top: u32) -> u32 {
    let gain = (lx * lx * ly * ly) as u64 * u64::from(top);
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
        // Inside the table: between two entries, so within `i32` without a clamp.
        if let Some(&[d0, d1]) = self.um.get(k..k + 2) {
            let dx = i64::from(x % Self::STEP);
            return (i64::from(d0) + (i64::from(d1) - i64::from(d0)) * dx / i64::from(Self::STEP))
                as i32;
        }
        // Beyond the last entry: the last two's slope continues, clamped to `i32`.
        let last = self.um.len() - 1;
        let (d0, d1) = (i64::from(self.um[last - 1]), i64::from(self.um[last]));
        let dx = i64::from(x) - (last as i64 - 1) * i64::from(Self::STEP);
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
    mix: Mix,
    /// The lateral correction's quadrature term, where the colours' gratings need one.
    quadrature: Option<Quadrature>,
    lx: usize,
    ly: usize,
    shift: u32,
    /// The reference's analytic signal and amplitude on the coarse grid.
    reference: Sampled,
    amp_ref: Vec<u32>,
    ref_median: u32,
    atan: &'static [u16; 257],
    lut: DepthLut,
}

/// |z| approximated as max + ⅜·min (within 7 %): enough for reliability and ordering.
fn amp(re: i32, im: i32) -> u32 {
    let (a, b) = (u64::from(re.unsigned_abs()), u64::from(im.unsigned_abs()));
    let (hi, lo) = if a > b { (a, b) } else { (b, a) };
    (hi + ((3 * lo) >> 3)).min(u64::from(u32::MAX)) as u32
}

impl FixedFtp {
    /// Prepares the reference, whose carrier `working` describes.
    pub fn new<'i>(
        reference: impl Into<Pixels<'i>>,
        working: &carrier::Working,
        calib: &Calibration,
    ) -> FixedFtp {
        FixedFtp::with_filter(reference, working, calib, false)
    }

    /// As [`FixedFtp::new`]; `rows_only` low-passes along rows only (a 1-D band-pass per
    /// row instead of 2-D: a trade-off configuration, cheaper and noisier).
    pub fn with_filter<'i>(
        reference: impl Into<Pixels<'i>>,
        working: &carrier::Working,
        calib: &Calibration,
        rows_only: bool,
    ) -> FixedFtp {
        let (factor, carrier) = (working.factor, working.carrier);
        let reference = reference.into();
        let (mut gray, w, h, _) = gray_down_q8(reference, factor);
        let q15 = |f: fn(f64) -> f64| -> Vec<i16> {
            (0..w * h)
                .map(|i| {
                    let th = std::f64::consts::TAU
                        * (f64::from(carrier.fx) * (i % w) as f64
                            + f64::from(carrier.fy) * (i / w) as f64);
                    (f(th) * 32_767.0).round() as i16
                })
                .collect()
        };
        let mix = Mix {
            planes: [q15(f64::cos), q15(f64::sin)],
        };
        let (lx, ly) = box_lengths(&carrier);
        let ly = if rows_only { 1 } else { ly };
        let shift = headroom_shift(lx, ly, 65_280);
        let mut f = FixedFtp {
            w,
            h,
            factor,
            carrier,
            mix,
            quadrature: None,
            lx,
            ly,
            shift,
            reference: Sampled::default(),
            amp_ref: Vec::new(),
            ref_median: 0,
            atan: atan_table(),
            lut: DepthLut::new(calib),
        };
        f.reference = f.analytic(&gray, None, GRID);
        if let Some(quad) = Quadrature::of(&f, reference) {
            f.shift = headroom_shift(lx, ly, 65_280 + quad.top());
            let mut q = Vec::new();
            gray_lateral_down_q8_into(reference, factor, &quad.k, &mut gray, &mut q);
            f.quadrature = Some(quad);
            f.reference = f.analytic(&gray, Some(&q), GRID);
        }
        f.amp_ref = f
            .reference
            .re
            .iter()
            .zip(&f.reference.im)
            .map(|(&a, &b)| amp(a, b))
            .collect();
        let mut a = f.amp_ref.clone();
        let k = a.len() / 2;
        f.ref_median = a.select_nth_unstable(k).1.to_owned();
        f
    }

    /// Working size (w, h) and the downsampling factor.
    pub fn geometry(&self) -> (usize, usize, usize) {
        (self.w, self.h, self.factor)
    }

    /// The carrier at the working resolution.
    pub fn carrier(&self) -> Carrier {
        self.carrier
    }

    /// Each colour's grating against the luminance's, where this reference's colours need
    /// turning onto one grating ([`super::lateral`]).
    pub fn colour_offsets(&self) -> Option<&Offsets> {
        self.quadrature.as_ref().map(|q| &q.offsets)
    }

    /// The blur the phase map carries, as the lengths `(lx, ly)` of the two-box triangle
    /// it equals (the demodulator's two box passes): the peak depth takes it back out
    /// ([`crate::measure::apex`]).
    pub fn blur_box_lengths(&self) -> (usize, usize) {
        (self.lx, self.ly)
    }

    /// The analytic signal of a Q8 luminance image every `step` working pixels each way, in
    /// luminance Q8 units times the filters' gain over `2^shift`.
    fn analytic(&self, gray: &[u16], quadrature: Option<&[i16]>, step: usize) -> Sampled {
        let mut out = Sampled::default();
        self.analytic_into((gray, quadrature), step, &mut Demod::default(), &mut out);
        out
    }

    /// [`FixedFtp::analytic`] into `out`, with the demodulator's buffers in `buf`.
    fn analytic_into(
        &self,
        gray: (&[u16], Option<&[i16]>),
        step: usize,
        buf: &mut Demod,
        out: &mut Sampled,
    ) {
        demodulate(
            gray,
            (self.w, self.h),
            (&self.mix, 15 + self.shift),
            (self.lx, self.ly),
            step,
            buf,
            out,
        );
    }

    /// The frame's analytic signal on the coarse grid ([`GRID`]): the only samples the
    /// measurement reads (it upsamples the contact window's phase from them), computed in
    /// the caller's `scratch`.
    ///
    /// # Panics
    /// If `frame` is not the reference's size (checked by the caller, [`crate::Analyzer`]).
    pub fn phase<'a, 'i>(
        &'a self,
        frame: impl Into<Pixels<'i>>,
        scratch: &'a mut Scratch,
    ) -> FixedField<'a> {
        let frame = frame.into();
        let Scratch {
            gray,
            quadrature,
            demod,
            frame: sampled,
        } = scratch;
        // Before the downsampling: the quadrature term's factors are the reference's size.
        let f = self.factor.clamp(1, 8);
        let (w, h) = (frame.width() as usize / f, frame.height() as usize / f);
        assert_eq!(
            (w, h),
            (self.w, self.h),
            "frame size differs from the reference"
        );
        let (_, _, saturated) = match &self.quadrature {
            Some(quad) => gray_lateral_down_q8_into(frame, self.factor, &quad.k, gray, quadrature),
            None => gray_down_q8_into(frame, self.factor, gray),
        };
        let q = self.quadrature.as_ref().map(|_| quadrature.as_slice());
        self.analytic_into((gray, q), GRID, demod, sampled);
        FixedField {
            ftp: self,
            frame: sampled,
            saturated_fraction: saturated,
        }
    }

    /// The reference's grating phase per working pixel, units of 2π/65 536: the mixing
    /// phase plus the demodulated signal's argument. Once per reference: the analytic
    /// signal of `reference` at every working pixel.
    pub fn grating_phase<'i>(&self, reference: impl Into<Pixels<'i>>) -> Vec<u16> {
        let reference = reference.into();
        let (mut gray, mut q) = (Vec::new(), Vec::new());
        match &self.quadrature {
            Some(quad) => {
                gray_lateral_down_q8_into(reference, self.factor, &quad.k, &mut gray, &mut q)
            }
            None => gray_down_q8_into(reference, self.factor, &mut gray),
        };
        let z = self.analytic(&gray, self.quadrature.as_ref().map(|_| q.as_slice()), 1);
        let (fx, fy) = (f64::from(self.carrier.fx), f64::from(self.carrier.fy));
        z.re.iter()
            .zip(&z.im)
            .enumerate()
            .map(|(i, (&re, &im))| {
                let mix = (fx * (i % self.w) as f64 + fy * (i / self.w) as f64) * 65_536.0;
                let arg = f64::from(im).atan2(f64::from(re)) / std::f64::consts::TAU;
                (mix + arg * 65_536.0).round().rem_euclid(65_536.0) as u16
            })
            .collect()
    }
}

/// A frame on the device path: its analytic signal on the coarse grid, whose phase
/// difference to the reference's is computed where it is read.
#[derive(Debug)]
pub struct FixedField<'a> {
    ftp: &'a FixedFtp,
    frame: &'a Sampled,
    /// Fraction of the sampled input pixels with a saturated channel.
    pub saturated_fraction: f32,
}

impl PhaseMap for FixedField<'_> {
    type P = i32;
    fn size(&self) -> (usize, usize) {
        (self.ftp.w, self.ftp.h)
    }
    fn wrapped(&self, k: usize) -> i32 {
        let r = &self.ftp.reference;
        let z = (self.frame.re[k], self.frame.im[k]);
        phase_difference(z, (r.re[k], r.im[k]), self.ftp.atan)
    }
    /// [`PhaseMap::wrapped`] of every sample in one loop over the four planes.
    fn wrapped_all(&self) -> Vec<i32> {
        let (f, r, table) = (self.frame, &self.ftp.reference, self.ftp.atan);
        // The frame's and the reference's planes are sampled on the same coarse grid.
        debug_assert!(f.re.len() == r.re.len() && f.im.len() == r.im.len());
        f.re.iter()
            .zip(&f.im)
            .zip(r.re.iter().zip(&r.im))
            .map(|((&a, &b), (&c, &d))| phase_difference((a, b), (c, d), table))
            .collect()
    }
    fn amp_frame(&self, k: usize) -> u32 {
        amp(self.frame.re[k], self.frame.im[k])
    }
    fn amp_ref(&self, k: usize) -> u32 {
        self.ftp.amp_ref[k]
    }
    fn amp_frame_all(&self) -> Vec<u32> {
        let f = self.frame;
        f.re.iter().zip(&f.im).map(|(&a, &b)| amp(a, b)).collect()
    }
    fn amp_ref_all(&self) -> std::borrow::Cow<'_, [u32]> {
        std::borrow::Cow::Borrowed(&self.ftp.amp_ref)
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
    use image::RgbImage;

    /// The one-pass phases and amplitudes equal the per-sample ones, on a frame with a bump
    /// and a shift.
    #[test]
    fn all_phases_and_amplitudes_in_one_pass_equal_each_one() {
        let stripes = |shift: f64, bump: f64| {
            RgbImage::from_fn(160, 120, move |x, y| {
                let (dx, dy) = (f64::from(x) - 80.0, f64::from(y) - 60.0);
                let d = bump * (-(dx * dx + dy * dy) / 200.0).exp();
                let t =
                    (f64::from(x) + 0.1 * f64::from(y) + shift + d) * std::f64::consts::TAU / 13.0;
                let v = (127.0 + 100.0 * t.cos()) as u8;
                image::Rgb([v, v, v])
            })
        };
        let reference = stripes(0.0, 0.0);
        let working = carrier::working(&reference, None).expect("carrier");
        let ftp = FixedFtp::new(&reference, &working, &Calibration::default_sim());
        let mut scratch = Scratch::default();
        let field = ftp.phase(&stripes(0.7, 3.0), &mut scratch);
        let all = field.wrapped_all();
        let (w, h) = field.size();
        assert_eq!(all.len(), w.div_ceil(GRID) * h.div_ceil(GRID));
        let (amps, amps_ref) = (field.amp_frame_all(), field.amp_ref_all());
        assert_eq!((amps.len(), amps_ref.len()), (all.len(), all.len()));
        for (k, &p) in all.iter().enumerate() {
            assert_eq!(p, field.wrapped(k), "sample {k}");
            assert_eq!(amps[k], field.amp_frame(k), "sample {k}");
            assert_eq!(amps_ref[k], field.amp_ref(k), "sample {k}");
        }
        assert!(all.iter().any(|&p| p != all[0]));
    }

    /// The table against its plain reading (the neighbouring entries, or the last two
    /// beyond the end, linear between, truncated toward zero, clamped to `i32`): rising,
    /// falling and extreme entries, every phase of two steps and some beyond the end.
    #[test]
    fn depth_table_interpolates_its_entries() {
        let lut = DepthLut {
            um: vec![
                0,
                100,
                3_000,
                2_000,
                -1_000_000_000,
                1_000_000_000,
                1_000_000_063,
            ],
        };
        let plain = |x: i32| -> i32 {
            if x <= 0 {
                return 0;
            }
            let last = lut.um.len() - 1;
            let k0 = ((x / DepthLut::STEP) as usize).min(last - 1);
            let (d0, d1) = (i64::from(lut.um[k0]), i64::from(lut.um[k0 + 1]));
            let dx = i64::from(x) - k0 as i64 * i64::from(DepthLut::STEP);
            (d0 + (d1 - d0) * dx / i64::from(DepthLut::STEP))
                .clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
        };
        let step = DepthLut::STEP;
        let xs = (-3..2 * step).chain((0..7 * step).step_by(7)).chain([
            6 * step - 1,
            6 * step,
            6 * step + 5,
            100 * step,
            i32::MAX,
        ]);
        for x in xs {
            assert_eq!(lut.depth_um(x), plain(x), "x {x}");
        }
        assert_eq!(lut.depth_um(step / 2), 50);
        assert_eq!(lut.depth_um(i32::MAX), i32::MAX);
    }

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

    /// The centred triangle of length `2l − 1` (weights `l − |d|`), directly, in `i64`.
    fn triangle(line: &[i64], l: usize, at: usize) -> i64 {
        (0..2 * l - 1)
            .filter_map(|t| {
                let i = (at + t).checked_sub(l - 1)?;
                let d = (t as i64 - (l as i64 - 1)).abs();
                line.get(i).map(|v| v * (l as i64 - d))
            })
            .sum()
    }

    #[test]
    fn streamed_demodulation_equals_the_direct_triangle_filters() {
        let (w, h) = (37, 23);
        let gray: Vec<u16> = (0..w * h)
            .map(|i| ((i * 7919 + (i / w) * 131) % 65_281) as u16)
            .collect();
        let phase = |i: usize| 0.7 * i as f64 + 0.3 * (i / w) as f64;
        let mix = Mix {
            planes: [
                (0..w * h)
                    .map(|i| (phase(i).cos() * 32_767.0) as i16)
                    .collect(),
                (0..w * h)
                    .map(|i| (phase(i).sin() * 32_767.0) as i16)
                    .collect(),
            ],
        };
        // One set of buffers for every configuration, dirtied in between: each call must
        // leave nothing of the last in its result.
        let quadrature: Vec<i16> = (0..w * h)
            .map(|i| ((i * 2_749) % 30_001) as i16 - 15_000)
            .collect();
        let (mut buf, mut got) = (Demod::default(), Sampled::default());
        let configurations = [(5, 4, 1), (5, 4, 2), (7, 1, 2), (3, 6, 3), (5, 4, 1)];
        for ((lx, ly, step), q) in configurations.into_iter().zip([false, true].iter().cycle()) {
            let q = q.then_some(quadrature.as_slice());
            let sh = 15 + headroom_shift(lx, ly, 65_280 + 15_000);
            for v in buf.i1.iter_mut().chain(&mut buf.i2).chain(&mut buf.ring) {
                v.fill(0x5a5a_5a5a);
            }
            buf.work.fill([-7; 4]);
            demodulate(
                (&gray, q),
                (w, h),
                (&mix, sh),
                (lx, ly),
                step,
                &mut buf,
                &mut got,
            );
            let (ow, oh) = (w.div_ceil(step), h.div_ceil(step));
            assert_eq!((got.re.len(), got.im.len()), (ow * oh, ow * oh));
            let got = got.clone();
            for (plane, p) in [(&got.re, 0), (&got.im, 1)] {
                // re = g·cos − q·sin, im = −(g·sin + q·cos), each product shifted.
                let mixed: Vec<i64> = (0..w * h)
                    .map(|i| {
                        let [c, s] = [0, 1].map(|k| i64::from(mix.planes[k][i]));
                        let (g, qi) = (i64::from(gray[i]), q.map_or(0, |q| i64::from(q[i])));
                        if p == 0 {
                            ((g * c) >> sh) - ((qi * s) >> sh)
                        } else {
                            -(((g * s) >> sh) + ((qi * c) >> sh))
                        }
                    })
                    .collect();
                // Columns, then rows, directly.
                let cols: Vec<i64> = (0..w * h)
                    .map(|i| {
                        let col: Vec<i64> = (0..h).map(|y| mixed[y * w + i % w]).collect();
                        triangle(&col, ly, i / w)
                    })
                    .collect();
                for oy in 0..oh {
                    let y = oy * step;
                    let row = &cols[y * w..(y + 1) * w];
                    for ox in 0..ow {
                        let want = triangle(row, lx, ox * step);
                        assert_eq!(
                            i64::from(plane[oy * ow + ox]),
                            want,
                            "lx {lx} ly {ly} step {step} at ({ox}, {oy})"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn triangle_keeps_constants_nulls_its_period_and_fits_the_headroom() {
        let (w, h, l) = (40, 3, 8);
        let gain = (l * l) as i32;
        // A constant under a unit mixer (cos = 1): the gain, away from the padded ends.
        let flat = vec![1000u16 << 2; w * h];
        let one = Mix {
            planes: [vec![32_767i16; w * h], vec![0; w * h]],
        };
        let demod = |g: &[u16]| {
            let mut z = Sampled::default();
            demodulate(
                (g, None),
                (w, h),
                (&one, 15),
                (l, 1),
                1,
                &mut Demod::default(),
                &mut z,
            );
            z
        };
        let z = demod(&flat);
        for x in l..w - l {
            assert!((z.re[w + x] - 4000 * gain).abs() <= gain, "x={x}");
        }
        // A wave of the filter's own period: nulled.
        let wave: Vec<u16> = (0..w * h)
            .map(|i| {
                (30_000.0 + 20_000.0 * (std::f64::consts::TAU * (i % w) as f64 / 8.0).cos()) as u16
            })
            .collect();
        let z = demod(&wave);
        for x in l..w - l {
            assert!((z.re[w + x] - 30_000 * gain).abs() <= 2 * gain, "x={x}");
        }
        let s = headroom_shift(64, 64, 65_280);
        let worst = (65_280u64 >> s) * 64u64.pow(4);
        assert!(worst <= i32::MAX as u64);
    }
}
