//! The float reference: full 2-D Fourier-transform profilometry with rustfft. The oracle the
//! device path is tested against.
//!
//! Per frame: luminance at the working resolution → mean removed → 2-D FFT → separable
//! band-pass window centred on the first order → inverse FFT → analytic signal `z`. The
//! wrapped phase difference is `arg(z_frame · conj(z_ref))`, the reference's `z` being
//! computed once. Where the lens puts the colours' gratings apart, each colour's fringe is
//! turned onto the luminance's first, as on the device path: `analytic(L) − i·analytic(Q)`
//! ([`super::lateral`]), one more transform pair per frame.
//!
//! Two windows ([`BandWindow`]):
//! * **Matched** (default): per axis `|D_L(Δν)|²`, the exact frequency response of the
//!   device path's two box passes of length `L` (`D_L` the Dirichlet kernel). It is a
//!   smooth, non-negative taper with nulls exactly on DC and the second order when `L` is
//!   the period, and it makes this path compute the *same operator* as
//!   [`super::fixed`] in floating point, so comparing the two isolates the fixed-point
//!   error, which is what an oracle is for.
//! * **Hann**: a separable Hann window of half-width [`BAND_HALF_WIDTH`] × the carrier
//!   frequency (the classic FTP choice), kept for the speed/accuracy trade-off study. It is
//!   a different filter, so its depth maps differ from the device path's by a few percent
//!   where the surface is curved, and it needs its own calibration.

use crate::input::Pixels;
use rustfft::num_complex::Complex32;
use rustfft::FftPlanner;

use super::band::{
    box2_length_of_variance, box2_response, box_lengths, hann_variance_px2, BandWindow,
    BAND_HALF_WIDTH,
};
use super::carrier::{self, Carrier};
use super::lateral::{self, Offsets, Sample};
use crate::calibration::DepthModel;
use crate::image_ops::{colours_down_f32, gray_down_f32, saturated_fraction};
use crate::input::{luma, Colour};
use crate::phase::{PhaseMap, GRID};

/// The wrapped phase difference of a frame against the reference.
#[derive(Debug, Clone)]
pub struct PhaseField {
    /// Working width, pixels.
    pub w: usize,
    /// Working height, pixels.
    pub h: usize,
    /// Wrapped phase difference, rad, in (−π, π].
    pub wrapped: Vec<f32>,
    /// Fringe amplitude of the frame, luminance units.
    pub amp_frame: Vec<f32>,
    /// Fringe amplitude of the reference, luminance units.
    pub amp_ref: Vec<f32>,
}

/// Reference-side state of the float pipeline.
pub struct FloatFtp {
    w: usize,
    h: usize,
    factor: usize,
    carrier: Carrier,
    window: Vec<f32>,
    /// The band-pass's blur as two-box lengths (x, y) ([`FloatFtp::blur_box_lengths`]).
    blur: (usize, usize),
    z_ref: Vec<Complex32>,
    /// The lateral correction ([`super::lateral`]): per colour and working pixel
    /// `weightₖ/256 · εₖ`, where the colours' gratings need one.
    quadrature: Option<[Vec<f32>; 3]>,
    offsets: Option<Offsets>,
    ref_median: u32,
    fwd: carrier::Plan2,
    inv: carrier::Plan2,
}

impl std::fmt::Debug for FloatFtp {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FloatFtp")
            .field("w", &self.w)
            .field("h", &self.h)
            .field("factor", &self.factor)
            .field("carrier", &self.carrier)
            .finish_non_exhaustive()
    }
}

impl FloatFtp {
    /// Prepares the reference, whose carrier `working` describes.
    pub fn new<'i>(
        reference: impl Into<Pixels<'i>>,
        working: &carrier::Working,
        band: BandWindow,
    ) -> FloatFtp {
        let (factor, carrier) = (working.factor, working.carrier);
        let reference = reference.into();
        let (gray, w, h) = gray_down_f32(reference, factor);
        let mut planner = FftPlanner::new();
        let fwd = carrier::plan2(&mut planner, w, h, false);
        let inv = carrier::plan2(&mut planner, w, h, true);
        let rho = BAND_HALF_WIDTH * carrier.freq();
        let hann = |d: f32| {
            if d.abs() >= rho {
                0.0
            } else {
                0.5 + 0.5 * (std::f32::consts::PI * d / rho).cos()
            }
        };
        let (lx, ly) = box_lengths(&carrier);
        let blur = match band {
            BandWindow::Matched => (lx, ly),
            BandWindow::Hann => {
                let l = box2_length_of_variance(hann_variance_px2(rho));
                (l, l)
            }
        };
        let taper = |d: f32, l: usize| match band {
            BandWindow::Matched => box2_response(d, l),
            BandWindow::Hann => hann(d),
        };
        let signed = |k: usize, n: usize| {
            if k <= n / 2 {
                k as f32 / n as f32
            } else {
                k as f32 / n as f32 - 1.0
            }
        };
        let mut window = vec![0.0f32; w * h];
        for v in 0..h {
            let wy = taper(signed(v, h) - carrier.fy, ly);
            for u in 0..w {
                // Hann is compact inside the carrier's half-plane; the matched response is
                // periodic and acts on the whole plane, exactly as the box filters do.
                window[v * w + u] = wy * taper(signed(u, w) - carrier.fx, lx);
            }
        }
        let mut ftp = FloatFtp {
            w,
            h,
            factor,
            carrier,
            window,
            blur,
            z_ref: Vec::new(),
            quadrature: None,
            offsets: None,
            ref_median: 0,
            fwd,
            inv,
        };
        ftp.offsets = ftp.offsets_of(reference, &gray);
        let weights = luma(Colour::Rgb).weights;
        ftp.quadrature = (ftp.offsets.as_ref()).map(|o| o.weighted(weights, |v| v as f32));
        ftp.z_ref = ftp.analytic_with_quadrature(reference, &gray);
        let mut a: Vec<u32> = ftp
            .z_ref
            .iter()
            .map(|c| (c.norm() * PhaseField::AMP_SCALE) as u32)
            .collect();
        let k = a.len() / 2;
        ftp.ref_median = *a.select_nth_unstable(k).1;
        ftp
    }

    /// Working size (w, h) and the downsampling factor from input pixels.
    pub fn geometry(&self) -> (usize, usize, usize) {
        (self.w, self.h, self.factor)
    }

    /// The carrier at the working resolution.
    pub fn carrier(&self) -> Carrier {
        self.carrier
    }

    /// The blur the phase map carries, as the lengths `(lx, ly)` of the two-box triangle
    /// it equals (or matches in variance): the peak depth takes it back out
    /// ([`crate::measure::apex`]).
    pub fn blur_box_lengths(&self) -> (usize, usize) {
        self.blur
    }

    /// The analytic signal of a working-resolution luminance image.
    fn analytic(&self, gray: &[f32]) -> Vec<Complex32> {
        let mean = gray.iter().sum::<f32>() / gray.len().max(1) as f32;
        let mut z: Vec<Complex32> = gray.iter().map(|v| Complex32::new(v - mean, 0.0)).collect();
        carrier::fft2(&mut z, &self.fwd);
        for (c, wv) in z.iter_mut().zip(&self.window) {
            *c *= *wv;
        }
        carrier::fft2(&mut z, &self.inv);
        // Unnormalised inverse: scale by 1/N, ×2 for the one-sided band (amplitude = fringe
        // half peak-to-peak).
        let s = 2.0 / (self.w * self.h) as f32;
        z.iter_mut().for_each(|c| *c *= s);
        z
    }

    /// Each colour's offset ([`super::lateral`]) fitted on the reference's coarse samples,
    /// every colour's analytic signal taken as the luminance's is; `None` unless RGB or
    /// where the colours need none.
    fn offsets_of(&self, reference: Pixels<'_>, gray: &[f32]) -> Option<Offsets> {
        if reference.colour() != Colour::Rgb {
            return None;
        }
        let (w, h) = (self.w, self.h);
        let z_luma = self.analytic(gray);
        let z: [Vec<Complex32>; 3] =
            colours_down_f32(reference, self.factor).map(|plane| self.analytic(&plane));
        let pair = |c: Complex32| (f64::from(c.re), f64::from(c.im));
        let samples: Vec<Sample> = (0..h)
            .step_by(GRID)
            .flat_map(|y| (0..w).step_by(GRID).map(move |x| (x, y)))
            .filter(|&(x, y)| lateral::clear_of_padding((x, y), (w, h), self.blur))
            .map(|(x, y)| Sample {
                at: (x as f64, y as f64),
                colours: std::array::from_fn(|k| pair(z[k][y * w + x])),
                luma: pair(z_luma[y * w + x]),
            })
            .collect();
        Offsets::fit(&samples, (w, h))
    }

    /// Each colour's grating against the luminance's, where this reference's colours need
    /// turning onto one grating ([`super::lateral`]).
    pub fn colour_offsets(&self) -> Option<&Offsets> {
        self.offsets.as_ref()
    }

    /// The analytic signal of a frame whose luminance is `gray`, each colour's fringe
    /// turned onto the luminance's grating first where the reference needs it
    /// ([`super::lateral`]): `analytic(L) − i·analytic(Q)`.
    fn analytic_with_quadrature(&self, frame: Pixels<'_>, gray: &[f32]) -> Vec<Complex32> {
        let mut z = self.analytic(gray);
        if let Some(k) = &self.quadrature {
            let colours = colours_down_f32(frame, self.factor);
            let q: Vec<f32> = (0..gray.len())
                .map(|i| (0..3).map(|c| k[c][i] * colours[c][i]).sum())
                .collect();
            for (z, zq) in z.iter_mut().zip(self.analytic(&q)) {
                *z -= Complex32::i() * zq;
            }
        }
        z
    }

    /// The wrapped phase difference of `frame` against the reference.
    ///
    /// # Panics
    /// If `frame` is not the reference's size (checked by the caller, [`crate::Analyzer`]).
    pub fn phase<'i>(&self, frame: impl Into<Pixels<'i>>) -> PhaseField {
        let frame = frame.into();
        let (gray, w, h) = gray_down_f32(frame, self.factor);
        assert_eq!(
            (w, h),
            (self.w, self.h),
            "frame size differs from the reference"
        );
        let z = self.analytic_with_quadrature(frame, &gray);
        let wrapped = z
            .iter()
            .zip(&self.z_ref)
            .map(|(a, b)| (a * b.conj()).arg())
            .collect();
        PhaseField {
            w,
            h,
            wrapped,
            amp_frame: z.iter().map(|c| c.norm()).collect(),
            amp_ref: self.z_ref.iter().map(|c| c.norm()).collect(),
        }
    }
}

impl PhaseField {
    /// Amplitude scale into the shared `u32` amplitude units (1/256 luminance step).
    const AMP_SCALE: f32 = 256.0;
}

/// The float field as the measurement sees it: phases in f32 radians; depth through the
/// calibration's model evaluated in floating point.
#[derive(Debug)]
pub struct FloatMap<'a> {
    field: PhaseField,
    saturated: f32,
    ref_median: u32,
    depth: &'a DepthModel,
}

impl FloatFtp {
    /// A frame's phase field as the measurement sees it.
    pub fn field<'a, 'i>(
        &self,
        frame: impl Into<Pixels<'i>>,
        depth: &'a DepthModel,
    ) -> FloatMap<'a> {
        let frame = frame.into();
        FloatMap {
            field: self.phase(frame),
            saturated: saturated_fraction(frame),
            ref_median: self.ref_median,
            depth,
        }
    }

    /// The reference's grating phase per working pixel, units of 2π/65 536: the analytic
    /// signal here keeps the carrier, so it is the argument itself.
    pub fn grating_phase(&self) -> Vec<u16> {
        self.z_ref
            .iter()
            .map(|z| (f64::from(z.arg()) / std::f64::consts::TAU * 65_536.0).round() as i64 as u16)
            .collect()
    }
}

impl FloatMap<'_> {
    /// The working pixel of coarse sample `k`.
    fn pixel(&self, k: usize) -> usize {
        let cw = self.field.w.div_ceil(GRID);
        (k / cw) * GRID * self.field.w + (k % cw) * GRID
    }
}

impl PhaseMap for FloatMap<'_> {
    type P = f32;
    fn size(&self) -> (usize, usize) {
        (self.field.w, self.field.h)
    }
    fn wrapped(&self, k: usize) -> f32 {
        self.field.wrapped[self.pixel(k)]
    }
    fn amp_frame(&self, k: usize) -> u32 {
        (self.field.amp_frame[self.pixel(k)] * PhaseField::AMP_SCALE) as u32
    }
    fn amp_ref(&self, k: usize) -> u32 {
        (self.field.amp_ref[self.pixel(k)] * PhaseField::AMP_SCALE) as u32
    }
    fn amp_ref_median(&self) -> u32 {
        self.ref_median
    }
    fn saturated_fraction(&self) -> f32 {
        self.saturated
    }
    fn depth_um(&self, x: f32) -> i32 {
        (self.depth.depth_mm(f64::from(x)) * 1000.0).round() as i32
    }
}
