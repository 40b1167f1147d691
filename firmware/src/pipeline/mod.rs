//! The force-and-shape pipeline: from a reference frame and each new frame to the depth
//! map, peak depth, contact area, volume, contact centre and force, with quality flags.
//!
//! ```text
//!  reference ─▶ carrier (once) ─▶ reference analytic signal (once)
//!  frame ─▶ luminance, area-downsampled ─▶ analytic signal ─▶ Δφ = arg(z · conj z_ref)
//!        ─▶ registration offset, noise floor ─▶ no contact? leave early
//!        ─▶ contact tiles ─▶ unwrap (only if it can have wrapped) ─▶ depth (calibration)
//!        ─▶ peak, area, volume, centre, force ─▶ flags
//! ```
//!
//! Two implementations share this contract: [`float_ftp`] (rustfft, the oracle) and
//! [`fixed_ftp`] (integer arithmetic per frame, the device path). Both return a
//! [`Deformation`], and [`measure::summarize`] turns either depth map into the same
//! features.
//!
//! Side by side on the simulated reference unit (640×480 camera, 320×240 working, 1.9 mm
//! press, force and shape; `docs/pipeline.md`, `docs/performance.md` for how each figure
//! is measured and the other configurations):
//!
//! | | device path (`fixed_ftp`) | float reference (`float_ftp`) |
//! |---|---|---|
//! | instructions per frame, aarch64 (target ≤ 6 M) | 5.89 M | |
//! | instructions per frame, x86-64 | 12.1 M | 57.2 M |
//! | time per frame, x86-64 (criterion) | 0.65 ms | 4.46 ms |
//! | peak depth error / tolerance, calibration presses | 0.030 | 0.030 |
//! | force RMSE | 0.046 N | 0.046 N |
//! | peak depth, device against float | 1.894 against 1.896 mm | |

pub mod carrier;
pub mod fixed_ftp;
pub mod float_ftp;
pub mod image_ops;
pub mod measure;
pub mod unwrap;

use image::RgbImage;
use vistaf_protocol::QualityFlags;

use crate::calibration::{Calibration, CalibrationError};
use crate::thermal::stripes::Geometry;
use crate::thermal::Thermometer;

/// Side of a contact tile at the working resolution, pixels.
pub const TILE_PX: usize = 8;

/// Which implementation runs per frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Implementation {
    /// rustfft float FTP: the reference.
    Float,
    /// Integer demodulation: the device path.
    #[default]
    Fixed,
}

impl std::str::FromStr for Implementation {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "float" => Ok(Implementation::Float),
            "fixed" => Ok(Implementation::Fixed),
            other => Err(format!("pipeline {other:?}: expected float or fixed")),
        }
    }
}

/// Why a frame or reference cannot be analysed at all (as opposed to a flagged result).
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    /// No usable grating in the reference.
    #[error("reference: {0}")]
    Carrier(#[from] carrier::CarrierError),
    /// The frame's size differs from the reference's.
    #[error("frame is {got_w}×{got_h} px, the reference is {w}×{h} px")]
    SizeMismatch {
        /// Reference width.
        w: u32,
        /// Reference height.
        h: u32,
        /// Frame width.
        got_w: u32,
        /// Frame height.
        got_h: u32,
    },
    /// The calibration does not fit this sensor.
    #[error(transparent)]
    Calibration(#[from] CalibrationError),
}

/// The result of analysing one frame.
#[derive(Clone, PartialEq)]
pub struct Deformation {
    /// Working width, pixels.
    pub w: usize,
    /// Working height, pixels.
    pub h: usize,
    /// Input pixels per working pixel (each axis).
    pub factor: usize,
    /// Depth per working pixel, µm (0 where there is no deformation).
    pub depth_um: Vec<i32>,
    /// Whether each working pixel's phase was trusted.
    pub reliable: Vec<bool>,
    /// Whether any contact was found.
    pub contact: bool,
    /// Deepest point, mm.
    pub peak_depth_mm: f32,
    /// Contact area (depth ≥ half the peak: the Hertz contact radius for a sphere), mm².
    pub contact_area_mm2: f32,
    /// Deformation volume over pixels deeper than the noise floor, mm³.
    pub volume_mm3: f32,
    /// Contact centre in input-image pixels (depth-weighted over the contact area).
    pub centroid_px: Option<(f32, f32)>,
    /// Indentation phase integrated over the deformed area, rad·mm².
    pub integrated_phase_rad_mm2: f32,
    /// Normal force from the calibration's force model, N.
    pub force_n: f32,
    /// What may be wrong.
    pub flags: QualityFlags,
    /// Measured phase noise floor (1σ), rad.
    pub noise_rad: f32,
    /// Global phase offset removed (registration), rad.
    pub offset_rad: f32,
    /// Depth of the contact threshold (6 σ of phase noise): the map reports depth above it, µm.
    pub floor_um: i32,
    /// Contact tiles processed.
    pub tiles: usize,
    /// The contact window `[x0, y0, x1, y1)`, working pixels: `depth_um` is zero outside it.
    pub window: Option<[usize; 4]>,
    /// Temperatures, when the calibration has a colour → temperature model.
    pub temperature: Option<crate::thermal::Temperature>,
}

impl std::fmt::Debug for Deformation {
    /// The summary numbers; the maps only by size.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Deformation")
            .field(
                "map",
                &format_args!("{}×{} (÷{})", self.w, self.h, self.factor),
            )
            .field("contact", &self.contact)
            .field("peak_depth_mm", &self.peak_depth_mm)
            .field("contact_area_mm2", &self.contact_area_mm2)
            .field("volume_mm3", &self.volume_mm3)
            .field("centroid_px", &self.centroid_px)
            .field("force_n", &self.force_n)
            .field(
                "flags",
                &self.flags.iter().map(|f| f.name()).collect::<Vec<_>>(),
            )
            .field("noise_rad", &self.noise_rad)
            .field("offset_rad", &self.offset_rad)
            .field("floor_um", &self.floor_um)
            .field("tiles", &self.tiles)
            .field(
                "temperature_c",
                &self
                    .temperature
                    .as_ref()
                    .map(|t| (t.min_c, t.mean_c, t.max_c, t.contact_c)),
            )
            .finish()
    }
}

/// Options of an [`Analyzer`].
#[derive(Debug, Clone, Copy, Default)]
pub struct AnalyzerOptions {
    /// Override the downsampling factor chosen from the carrier period.
    pub factor: Option<usize>,
    /// Use a calibration made for another geometry.
    pub force_calibration: bool,
    /// Band-pass window of the float path.
    pub band: float_ftp::BandWindow,
    /// When to unwrap the contact region's phase.
    pub unwrap: measure::Unwrap,
    /// Device path: low-pass along rows only (a 1-D band-pass per row) instead of 2-D.
    pub rows_only: bool,
}

/// Adds the frame's temperatures to its force-side result `d`: the frame's grating phase
/// (`phase(y, reference, row)`: the reference's plus the FTP's wrapped phase difference,
/// units, a working row at a time) places the stripes, the contact region (depth ≥ half
/// the peak, read from its core at ≥ ¾ of the peak where that is big enough) gets its own
/// temperature, and a reading outside the calibration is flagged.
fn with_temperature(
    mut d: Deformation,
    frame: &RgbImage,
    thermo: &Thermometer,
    phase: impl Fn(usize, &[u16], &mut [u16]),
) -> Deformation {
    if !thermo.has_model() {
        return d;
    }
    use crate::thermal::stripes::{region, Regions};
    let peak_um = d.peak_depth_mm * 1000.0;
    let (half, core) = (
        (peak_um * 0.5).round() as i32,
        (peak_um * 0.75).round() as i32,
    );
    // Branch-free, so the pass over the map vectorises: the codes count the thresholds
    // passed.
    const _: () = assert!(region::NONE == 0 && region::CONTACT == 1 && region::CORE == 2);
    let (half, core) = (half.max(1), core.max(1));
    // Over the contact window only (clipped to the map): depth is zero outside it.
    let window = d.window.filter(|_| d.contact).map(|[x0, y0, x1, y1]| {
        let (x1, y1) = (x1.min(d.w), y1.min(d.h));
        [x0.min(x1), y0.min(y1), x1, y1]
    });
    let mut codes = Vec::new();
    if let Some([x0, y0, x1, y1]) = window {
        codes.reserve((x1 - x0) * (y1 - y0));
        for y in y0..y1 {
            let row = &d.depth_um[y * d.w + x0..y * d.w + x1];
            codes.extend(
                row.iter()
                    .map(|&u| u8::from(u >= half) + u8::from(u >= core)),
            );
        }
    }
    let regions = window.map(|[x0, y0, x1, _]| Regions::new(&codes, x0, y0, x1 - x0));
    d.temperature = thermo.measure(frame, phase, &d.reliable, regions);
    if d.temperature.as_ref().is_some_and(|t| t.out_of_range) {
        d.flags.insert(vistaf_protocol::Flag::TemperatureOutOfRange);
    }
    d
}

enum Imp {
    Float(float_ftp::FloatFtp),
    Fixed(Box<fixed_ftp::FixedFtp>),
}

/// A prepared pipeline: reference-side work done, ready for frames.
pub struct Analyzer {
    imp: Imp,
    unwrap: measure::Unwrap,
    thermo: Thermometer,
    calib: Calibration,
    size: (u32, u32),
    mm_per_px: f32,
    period_px: f32,
    ref_saturation: f32,
}

impl std::fmt::Debug for Analyzer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Analyzer")
            .field("size", &self.size)
            .field("mm_per_px", &self.mm_per_px)
            .finish_non_exhaustive()
    }
}

impl Analyzer {
    /// Prepares a pipeline for `reference` (a no-contact frame).
    pub fn new(
        reference: &RgbImage,
        calib: Calibration,
        imp: Implementation,
        opts: AnalyzerOptions,
    ) -> Result<Analyzer, PipelineError> {
        let working = carrier::working(reference, opts.factor)?;
        let c = working.full;
        if !opts.force_calibration {
            calib.check_fits(
                reference.width(),
                reference.height(),
                f64::from(c.period_px()),
            )?;
        }
        let imp = match imp {
            Implementation::Float => {
                Imp::Float(float_ftp::FloatFtp::new(reference, &working, opts.band)?)
            }
            Implementation::Fixed => Imp::Fixed(Box::new(fixed_ftp::FixedFtp::with_filter(
                reference,
                &working,
                &calib,
                opts.rows_only,
            )?)),
        };
        let mm_per_px = calib.unit.grating_period_mm as f32 / c.period_px();
        let thermo = {
            let (theta, (w, h, factor), table) = match &imp {
                Imp::Float(f) => (f.grating_phase(), f.geometry(), false),
                Imp::Fixed(f) => (f.grating_phase(reference), f.geometry(), true),
            };
            let wc = working.carrier;
            Thermometer::new(
                Geometry::new(w, h, factor, wc.fx, wc.fy),
                theta,
                calib.temperature.clone(),
                table,
                mm_per_px,
            )
        };
        Ok(Analyzer {
            imp,
            unwrap: opts.unwrap,
            thermo,
            mm_per_px,
            period_px: c.period_px(),
            calib,
            size: reference.dimensions(),
            ref_saturation: image_ops::saturated_fraction(reference),
        })
    }

    /// Input scale, mm per pixel (from the measured carrier period).
    pub fn mm_per_px(&self) -> f32 {
        self.mm_per_px
    }

    /// Measured carrier period, input pixels.
    pub fn period_px(&self) -> f32 {
        self.period_px
    }

    /// The calibration in use.
    pub fn calibration(&self) -> &Calibration {
        &self.calib
    }

    /// The frame's force-side result and its colour sums per block (for calibrating
    /// colour → temperature; no model needed).
    pub fn colour_sums(
        &self,
        frame: &RgbImage,
    ) -> Result<(Deformation, Vec<crate::thermal::stripes::Sums>), PipelineError> {
        self.run(frame, |d, wrapped| {
            let (s, _) = self.thermo.sums(
                frame,
                |y, r, row| wrapped.frame_row(y, r, row),
                &d.reliable,
                None,
            );
            (d, s)
        })
    }

    /// Phase and measurement of a frame on either path; `then` gets the force-side result
    /// and the wrapped phase difference as the measurement read it.
    fn run<R>(
        &self,
        frame: &RgbImage,
        then: impl FnOnce(Deformation, &measure::WrappedPhase) -> R,
    ) -> Result<R, PipelineError> {
        self.check_size(frame)?;
        let ctx = self.context();
        let (d, wrapped) = match &self.imp {
            Imp::Float(f) => {
                let map = f.field(frame, &ctx);
                measure::measure(&map, f.geometry().2, f.carrier(), &ctx)
            }
            Imp::Fixed(f) => {
                let field = f.phase(frame);
                measure::measure(&field, f.geometry().2, f.carrier(), &ctx)
            }
        };
        Ok(then(d, &wrapped))
    }

    /// The temperature side's prepared state.
    pub fn thermometer(&self) -> &Thermometer {
        &self.thermo
    }

    fn check_size(&self, frame: &RgbImage) -> Result<(), PipelineError> {
        if frame.dimensions() != self.size {
            return Err(PipelineError::SizeMismatch {
                w: self.size.0,
                h: self.size.1,
                got_w: frame.width(),
                got_h: frame.height(),
            });
        }
        Ok(())
    }

    fn context(&self) -> measure::Context<'_> {
        measure::Context {
            calib: &self.calib,
            mm_per_px: self.mm_per_px,
            ref_saturated_fraction: self.ref_saturation,
            unwrap: self.unwrap,
        }
    }

    /// Analyses one frame.
    pub fn analyze(&self, frame: &RgbImage) -> Result<Deformation, PipelineError> {
        self.run(frame, |d, wrapped| {
            with_temperature(d, frame, &self.thermo, |y, r, row| {
                wrapped.frame_row(y, r, row)
            })
        })
    }
}
