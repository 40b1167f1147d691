//! Carrier estimation: the grating's spatial frequency and orientation, from the reference.
//!
//! The mean-removed, Hann-windowed reference is transformed (2-D FFT); the strongest bin
//! in the half-plane `kx > 0` (away from DC) is the first order. Its position is refined
//! to a fraction of a bin by fitting a parabola to the log-magnitude along each axis,
//! which is exact for the Gaussian-like main lobe of a Hann window to within a few
//! hundredths of a bin. Done once per reference (not per frame), in floating point on
//! every platform.

use rustfft::num_complex::Complex32;
use rustfft::FftPlanner;

/// The grating's first-order spatial frequency at the working resolution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Carrier {
    /// Cycles per pixel along x.
    pub fx: f32,
    /// Cycles per pixel along y.
    pub fy: f32,
    /// Peak magnitude over the median of the spectrum (fringe visibility).
    pub prominence: f32,
}

impl Carrier {
    /// Cycles per pixel.
    pub fn freq(&self) -> f32 {
        self.fx.hypot(self.fy)
    }

    /// Grating period, pixels.
    pub fn period_px(&self) -> f32 {
        1.0 / self.freq()
    }

    /// Direction of the carrier (0° = vertical stripes), degrees.
    pub fn angle_deg(&self) -> f32 {
        self.fy.atan2(self.fx).to_degrees()
    }

    /// The same carrier at a resolution `factor` times coarser.
    pub fn scaled(&self, factor: usize) -> Carrier {
        Carrier {
            fx: self.fx * factor as f32,
            fy: self.fy * factor as f32,
            ..*self
        }
    }
}

/// Why no carrier was found.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CarrierError {
    /// The image is too small to hold a grating.
    #[error("image {0}×{1} px is too small to find the grating")]
    TooSmall(usize, usize),
    /// No spectral peak stands out: no grating in view, or contrast too low.
    #[error("no grating found: strongest peak only {0:.1}× the spectrum's median (need 8×)")]
    NoGrating(f32),
    /// The peak sits where no usable grating can be (period below 2.5 px).
    #[error("grating period {0:.2} px is below what the camera can resolve")]
    TooFine(f32),
    /// The strongest periodic pattern repeats too few times across the image to be the
    /// skin's grating (a test pattern, colour bars, a scene).
    #[error("no grating found: the strongest periodic pattern ({0:.1} px) repeats only {1:.1} times across the image (a skin's grating repeats {MIN_PERIODS_ACROSS} or more)")]
    TooCoarse(f32, f32),
}

/// Fewest grating periods across the image's longer side: every specified unit (320 to
/// 800 px wide, periods of 7 to 30 px) has at least 10.7.
pub const MIN_PERIODS_ACROSS: f32 = 10.0;

/// Fewest pixels per period the pipeline accepts at the working resolution (Nyquist is 2;
/// the stability sweep reads depths within tolerance at 4 px and garbage at 3 and 2.5 px,
/// so finer gratings are refused rather than measured).
pub const MIN_PERIOD_PX: f32 = 3.5;

/// The two 1-D transforms of a 2-D FFT: along rows (length w) and columns (length h).
pub type Plan2 = (
    std::sync::Arc<dyn rustfft::Fft<f32>>,
    std::sync::Arc<dyn rustfft::Fft<f32>>,
);

/// Plans a forward or inverse 2-D FFT of `w × h`.
pub fn plan2(planner: &mut FftPlanner<f32>, w: usize, h: usize, inverse: bool) -> Plan2 {
    if inverse {
        (planner.plan_fft_inverse(w), planner.plan_fft_inverse(h))
    } else {
        (planner.plan_fft_forward(w), planner.plan_fft_forward(h))
    }
}

/// 2-D FFT in place (row-major, rows of `plan.0`'s length): rows, then columns.
pub fn fft2(data: &mut [Complex32], (row, col): &Plan2) {
    let (w, h) = (row.len(), col.len());
    row.process(data);
    let mut column = vec![Complex32::default(); h];
    for x in 0..w {
        for (y, c) in column.iter_mut().enumerate() {
            *c = data[y * w + x];
        }
        col.process(&mut column);
        for (y, c) in column.iter().enumerate() {
            data[y * w + x] = *c;
        }
    }
}

/// The carrier of a reference, at input and at working resolution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Working {
    /// At the input resolution.
    pub full: Carrier,
    /// Input pixels per working pixel.
    pub factor: usize,
    /// At the working resolution.
    pub carrier: Carrier,
}

/// Estimates the reference's carrier once, chooses the working resolution (`factor`
/// overrides the choice), and checks the grating is still resolved there.
pub fn working<'i>(
    reference: impl Into<crate::input::Pixels<'i>>,
    factor: Option<usize>,
) -> Result<Working, CarrierError> {
    let (full, fw, fh) = crate::image_ops::gray_down_f32(reference, 1);
    let full = estimate(&full, fw, fh)?;
    let factor = factor
        .unwrap_or_else(|| crate::image_ops::downsample_factor(full.period_px()))
        .max(1);
    let carrier = full.scaled(factor);
    if carrier.period_px() < MIN_PERIOD_PX {
        return Err(CarrierError::TooFine(carrier.period_px()));
    }
    Ok(Working {
        full,
        factor,
        carrier,
    })
}

/// Estimates the carrier of `gray` (`w × h`, any scale).
pub fn estimate(gray: &[f32], w: usize, h: usize) -> Result<Carrier, CarrierError> {
    if w < 16 || h < 16 {
        return Err(CarrierError::TooSmall(w, h));
    }
    let mean = gray.iter().sum::<f32>() / gray.len() as f32;
    let hann = |i: usize, n: usize| 0.5 - 0.5 * (std::f32::consts::TAU * i as f32 / n as f32).cos();
    let mut spec: Vec<Complex32> = gray
        .iter()
        .enumerate()
        .map(|(i, v)| Complex32::new((v - mean) * hann(i % w, w) * hann(i / w, h), 0.0))
        .collect();
    let mut planner = FftPlanner::new();
    fft2(&mut spec, &plan2(&mut planner, w, h, false));
    let mag = |kx: isize, ky: isize| -> f32 {
        let x = kx.rem_euclid(w as isize) as usize;
        let y = ky.rem_euclid(h as isize) as usize;
        spec[y * w + x].norm()
    };
    let (hw, hh) = ((w / 2) as isize, (h / 2) as isize);
    let mut best = (0.0f32, 0isize, 0isize);
    let mut mags = Vec::with_capacity(w * h / 2);
    for ky in -hh + 1..hh {
        for kx in 1..hw {
            // Skip the DC neighbourhood (illumination gradients, window leakage).
            let r = ((kx as f32 / w as f32).powi(2) + (ky as f32 / h as f32).powi(2)).sqrt();
            let m = mag(kx, ky);
            mags.push(m);
            if r < 3.0 / w.min(h) as f32 {
                continue;
            }
            if m > best.0 {
                best = (m, kx, ky);
            }
        }
    }
    let (peak, kx, ky) = best;
    mags.sort_by(f32::total_cmp);
    let median = mags[mags.len() / 2].max(1e-9);
    let prominence = peak / median;
    if prominence < 8.0 {
        return Err(CarrierError::NoGrating(prominence));
    }
    let refine = |m0: f32, m1: f32, m2: f32| {
        let (a, b, c) = (m0.max(1e-9).ln(), m1.max(1e-9).ln(), m2.max(1e-9).ln());
        let d = a - 2.0 * b + c;
        if d.abs() < 1e-12 {
            0.0
        } else {
            (0.5 * (a - c) / d).clamp(-0.5, 0.5)
        }
    };
    let dx = refine(mag(kx - 1, ky), peak, mag(kx + 1, ky));
    let dy = refine(mag(kx, ky - 1), peak, mag(kx, ky + 1));
    let c = Carrier {
        fx: (kx as f32 + dx) / w as f32,
        fy: (ky as f32 + dy) / h as f32,
        prominence,
    };
    if c.period_px() < MIN_PERIOD_PX {
        return Err(CarrierError::TooFine(c.period_px()));
    }
    let across = w.max(h) as f32 / c.period_px();
    if across < MIN_PERIODS_ACROSS {
        return Err(CarrierError::TooCoarse(c.period_px(), across));
    }
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grating(w: usize, h: usize, period: f32, angle_deg: f32) -> Vec<f32> {
        let (c, s) = (angle_deg.to_radians().cos(), angle_deg.to_radians().sin());
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                128.0 + 60.0 * (std::f32::consts::TAU * (x * c + y * s) / period + 0.7).cos()
            })
            .collect()
    }

    #[test]
    fn finds_period_and_angle_to_sub_bin_accuracy() {
        for (period, angle) in [(7.3f32, 0.0f32), (16.0, 5.0), (11.1, -8.0), (25.0, 3.0)] {
            let c = estimate(&grating(320, 240, period, angle), 320, 240).unwrap();
            assert!(
                (c.period_px() - period).abs() / period < 0.004,
                "{period}: {}",
                c.period_px()
            );
            assert!(
                (c.angle_deg() - angle).abs() < 0.4,
                "{angle}: {}",
                c.angle_deg()
            );
        }
    }

    #[test]
    fn flat_image_has_no_grating() {
        // White noise around a flat grey: no peak stands out.
        let mut x = 12345u32;
        let flat: Vec<f32> = (0..64 * 64)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 17;
                x ^= x << 5;
                100.0 + (x % 1000) as f32 * 0.01
            })
            .collect();
        assert!(matches!(
            estimate(&flat, 64, 64),
            Err(CarrierError::NoGrating(_))
        ));
        assert!(matches!(
            estimate(&flat[..100], 10, 10),
            Err(CarrierError::TooSmall(10, 10))
        ));
    }
}
