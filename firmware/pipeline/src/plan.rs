//! The plan for one reference: the carrier found, the chosen FTP path prepared, the
//! temperature side's grating phase computed, all once; then [`Analyzer::analyze`] turns
//! each frame into a [`Measurement`].
//!
//! ```text
//!  reference ─▶ carrier (once) ─▶ reference analytic signal (once)
//!  frame ─▶ luminance, area-downsampled ─▶ analytic signal ─▶ Δφ = arg(z · conj z_ref)
//!        ─▶ the colour's field out, if the frame shows one (calibration)
//!        ─▶ registration offset, noise floor ─▶ no contact? leave early
//!        ─▶ contact tiles ─▶ unwrap (only if it can have wrapped) ─▶ depth (calibration)
//!        ─▶ peak, area, volume, centre, force ─▶ flags
//!        ─▶ temperatures (stripe colours placed by the frame's grating phase)
//!        ─▶ a field the skin's temperature leaves none of? read again without it
//! ```
//!
//! Two paths share this contract behind [`FtpPath`]: [`FloatFtp`] (rustfft, the oracle) and
//! [`FixedFtp`] (integer arithmetic per frame, the device path). Both hand the measurement a
//! [`PhaseMap`](crate::phase::PhaseMap), and [`measure::measure`] turns either into the same features.

use vistaf_protocol::{Flag, QualityFlags, Reading};

use crate::input::Pixels;

use crate::calibration::colour_phase;
use crate::calibration::{Calibration, CalibrationError};
use crate::ftp::band::BandWindow;
use crate::ftp::carrier::{self, Carrier};
use crate::ftp::fixed::FixedFtp;
use crate::ftp::float::FloatFtp;
use crate::ftp::lateral::Offsets;
use crate::image_ops;
use crate::measure::apex::BlurLoss;
use crate::measure::colour_phase::Candidates;
use crate::measure::profile::Shapes;
use crate::measure::{self, Context, Unwrap};
use crate::phase::{WrappedPhase, GRID};
use crate::thermal::stripes::{region, Geometry, Regions, Sums};
use crate::thermal::{self, Temperature, Thermometer};
use crate::Measurement;

/// A frame's phase at the colour's nodes ([`Analyzer::colour_phase_nodes`]): the step
/// between nodes (coarse samples) and the nodes across and down, and the phase at each.
pub type NodePhase = ((usize, [usize; 2]), Vec<Option<i32>>);

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
    Carrier(carrier::CarrierError),
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

impl From<carrier::CarrierError> for PipelineError {
    fn from(e: carrier::CarrierError) -> PipelineError {
        PipelineError::Carrier(e)
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
    pub band: BandWindow,
    /// When to unwrap the contact region's phase.
    pub unwrap: Unwrap,
    /// Device path: low-pass along rows only (a 1-D band-pass per row) instead of 2-D.
    pub rows_only: bool,
}

/// Adds the frame's temperatures to its force-side result `d`: the frame's grating phase
/// (`phase(y, reference, row)`: the reference's plus the FTP's wrapped phase difference,
/// units, a working row at a time) places the stripes, the contact region (depth ≥ half
/// the peak, read from its core at ≥ ¾ of the peak where that is big enough) gets its own
/// temperature, and a reading outside the calibration is flagged.
fn with_temperature(
    d: Measurement,
    frame: Pixels<'_>,
    thermo: &Thermometer,
    phase: impl Fn(usize, &[u16], &mut [u16]),
) -> Measurement {
    if !thermo.has_model() {
        return d;
    }
    let codes = ContactCodes::of(&d);
    let (blocks, contact) = thermo.sums(frame, phase, &d.reliable, codes.regions());
    read_temperature(d, thermo, (&blocks, contact), &codes)
}

/// `d` with the temperatures its frame's colour sums give (`blocks` and `contact`, as
/// [`Thermometer::sums`] gives them over `codes`) and the flags they call for.
fn read_temperature(
    mut d: Measurement,
    thermo: &Thermometer,
    (blocks, contact): (&[Sums], [Sums; 2]),
    codes: &ContactCodes,
) -> Measurement {
    d.temperature = thermo.measure(blocks, contact, codes.regions());
    if let Some(t) = &d.temperature {
        temperature_flags(&mut d.flags, t);
    }
    d
}

/// Raises the temperature flags `t` calls for beside the force side's `flags`. Where the
/// contact is the hottest place, a doubt about its temperature (its stripes placed by a
/// phase the contact's flags doubt) is one about the skin's hottest place too, which only
/// the temperature flags speak for.
fn temperature_flags(flags: &mut QualityFlags, t: &Temperature) {
    if t.out_of_range {
        flags.insert(Flag::TemperatureOutOfRange);
    }
    let only_contact_doubted =
        !flags.trusts(Reading::ContactTemperature) && flags.trusts(Reading::Temperature);
    if t.uncertain() || (t.max_at_contact && only_contact_doubted) {
        flags.insert(Flag::TemperatureUncertain);
    }
}

/// The contact region (depth ≥ half the map's peak) and its core (≥ ¾) as
/// [`region`] codes over the contact window.
struct ContactCodes {
    codes: Vec<u8>,
    /// The contact window clipped to the map, working pixels; `None` without contact.
    window: Option<[usize; 4]>,
}

impl ContactCodes {
    fn of(d: &Measurement) -> ContactCodes {
        // Over the contact window only (clipped to the map): depth is zero outside it.
        let window = d.window_px.filter(|_| d.contact).map(|[x0, y0, x1, y1]| {
            let (x1, y1) = (x1.min(d.width_px), y1.min(d.height_px));
            [x0.min(x1), y0.min(y1), x1, y1]
        });
        // The thresholds are fractions of the map's own deepest value (the reported peak
        // has the band's blur taken out and may lie above every pixel of the map).
        let peak_um = d.map_peak_um as f32;
        let (half, core) = (
            (peak_um * 0.5).round() as i32,
            (peak_um * 0.75).round() as i32,
        );
        // Branch-free, so the pass over the map vectorises: the codes count the
        // thresholds passed.
        const _: () = assert!(region::NONE == 0 && region::CONTACT == 1 && region::CORE == 2);
        let (half, core) = (half.max(1), core.max(1));
        let mut codes = Vec::new();
        if let Some([x0, y0, x1, y1]) = window {
            codes.reserve((x1 - x0) * (y1 - y0));
            for y in y0..y1 {
                let row = &d.depth_um[y * d.width_px + x0..y * d.width_px + x1];
                codes.extend(
                    row.iter()
                        .map(|&u| u8::from(u >= half) + u8::from(u >= core)),
                );
            }
        }
        ContactCodes { codes, window }
    }

    fn regions(&self) -> Option<Regions<'_>> {
        self.window
            .map(|[x0, y0, x1, _]| Regions::new(&self.codes, x0, y0, x1 - x0))
    }
}

/// One FTP implementation, prepared for a reference: what the plan runs per frame.
///
/// A path demodulates the frame against the reference into a
/// [`PhaseMap`](crate::phase::PhaseMap) and hands it to
/// the shared measurement ([`measure::measure`]), in the path's own phase representation.
pub trait FtpPath: std::fmt::Debug + Send + Sync {
    /// Working width and height, pixels, and input pixels per working pixel.
    fn geometry(&self) -> (usize, usize, usize);
    /// The carrier at the working resolution.
    fn carrier(&self) -> Carrier;
    /// The blur of the phase map as two-box lengths, working pixels.
    fn blur_box_lengths(&self) -> (usize, usize);
    /// Each colour's grating against the luminance's, where the path turns the colours
    /// onto one grating ([`crate::ftp::lateral`]).
    fn colour_offsets(&self) -> Option<&Offsets>;
    /// The frame's force-side measurement (no temperatures yet) and the wrapped phase
    /// difference as the measurement read it, working in `scratch`.
    fn measure(
        &self,
        frame: Pixels<'_>,
        ctx: &Context<'_>,
        scratch: &mut Scratch,
    ) -> (Measurement, WrappedPhase);
}

/// What the pipeline keeps from frame to frame: the device path's luminance image,
/// demodulator buffers and analytic signal. Owned by the caller, one per stream of
/// frames ([`Analyzer::analyze_with`]), as RustFFT's scratch is: a frame then allocates
/// none of them. Any plan may use any scratch; a scratch adapts to the plan it meets.
#[derive(Debug, Clone, Default)]
pub struct Scratch {
    fixed: crate::ftp::fixed::Scratch,
}

impl FtpPath for FloatFtp {
    fn geometry(&self) -> (usize, usize, usize) {
        FloatFtp::geometry(self)
    }
    fn carrier(&self) -> Carrier {
        FloatFtp::carrier(self)
    }
    fn blur_box_lengths(&self) -> (usize, usize) {
        FloatFtp::blur_box_lengths(self)
    }
    fn colour_offsets(&self) -> Option<&Offsets> {
        FloatFtp::colour_offsets(self)
    }
    fn measure(
        &self,
        frame: Pixels<'_>,
        ctx: &Context<'_>,
        _: &mut Scratch,
    ) -> (Measurement, WrappedPhase) {
        let map = self.field(frame, &ctx.calib.depth.model);
        measure::measure(&map, self.geometry().2, self.carrier(), ctx)
    }
}

impl FtpPath for FixedFtp {
    fn geometry(&self) -> (usize, usize, usize) {
        FixedFtp::geometry(self)
    }
    fn carrier(&self) -> Carrier {
        FixedFtp::carrier(self)
    }
    fn blur_box_lengths(&self) -> (usize, usize) {
        FixedFtp::blur_box_lengths(self)
    }
    fn colour_offsets(&self) -> Option<&Offsets> {
        FixedFtp::colour_offsets(self)
    }
    fn measure(
        &self,
        frame: Pixels<'_>,
        ctx: &Context<'_>,
        scratch: &mut Scratch,
    ) -> (Measurement, WrappedPhase) {
        let field = self.phase(frame, &mut scratch.fixed);
        measure::measure(&field, self.geometry().2, self.carrier(), ctx)
    }
}

/// A prepared pipeline: reference-side work done, ready for frames.
pub struct Analyzer {
    path: Box<dyn FtpPath>,
    unwrap: Unwrap,
    thermo: Thermometer,
    blur_loss: BlurLoss,
    /// The shape templates of the same kernel.
    shapes: Shapes,
    calib: Calibration,
    /// The colour's phase fields relative to the reference, if the calibration has them.
    colour_phase: Option<Candidates>,
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
    pub fn new<'i>(
        reference: impl Into<Pixels<'i>>,
        calib: Calibration,
        imp: Implementation,
        opts: AnalyzerOptions,
    ) -> Result<Analyzer, PipelineError> {
        let reference = reference.into();
        let working = carrier::working(reference, opts.factor)?;
        let c = working.full;
        if !opts.force_calibration {
            calib.check_fits(
                reference.width(),
                reference.height(),
                f64::from(c.period_px()),
            )?;
        }
        // The reference's grating phase per working pixel, in the path's arithmetic, and
        // whether temperatures are read in integers (the device path) or floats.
        let (path, theta, integer): (Box<dyn FtpPath>, Vec<u16>, bool) = match imp {
            Implementation::Float => {
                let f = FloatFtp::new(reference, &working, opts.band);
                let theta = f.grating_phase();
                (Box::new(f), theta, false)
            }
            Implementation::Fixed => {
                let f = FixedFtp::with_filter(reference, &working, &calib, opts.rows_only);
                let theta = f.grating_phase(reference);
                (Box::new(f), theta, true)
            }
        };
        let mm_per_px = calib.unit.grating_period_mm as f32 / c.period_px();
        let (w, h, factor) = path.geometry();
        let wc = working.carrier;
        let mut geometry = Geometry::new(w, h, factor, wc.fx, wc.fy);
        if let Some(offsets) = path.colour_offsets() {
            geometry = geometry.with_colour_offsets(|k, x, y| offsets.rad(k, x, y));
        }
        let thermo = Thermometer::new(
            geometry,
            theta,
            calib.temperature.clone(),
            integer,
            mm_per_px,
        );
        let blur_loss = BlurLoss::new(path.blur_box_lengths(), mm_per_px * factor as f32);
        let shapes = Shapes::new(path.blur_box_lengths(), mm_per_px * factor as f32);
        let mut an = Analyzer {
            blur_loss,
            shapes,
            path,
            unwrap: opts.unwrap,
            thermo,
            mm_per_px,
            period_px: c.period_px(),
            calib,
            colour_phase: None,
            size: reference.dimensions(),
            ref_saturation: image_ops::saturated_fraction(reference),
        };
        let (_, sums) = an.colour_sums(reference)?;
        an.thermo.learn_reference(&sums);
        // The fields are taken against the reference's own temperature, as it reads.
        let reference_c = (an.thermo.measure(&sums, Default::default(), None))
            .map(|t| f64::from(t.mean_c))
            .filter(|t| t.is_finite());
        an.colour_phase = (an.calib.colour_phase.as_ref())
            .map(|c| Candidates::relative_to(c, reference_c))
            .filter(|c| !c.is_empty());
        Ok(an)
    }

    /// The frame's phase at the colour's nodes, smoothed over a period and less its
    /// registration ([`colour_phase::at_nodes`]), with the step and the nodes across and
    /// down: what the calibration records of a uniform kit frame
    /// ([`ColourPhase::from_frames`](colour_phase::ColourPhase::from_frames)).
    pub fn colour_phase_nodes<'i>(
        &self,
        frame: impl Into<Pixels<'i>>,
    ) -> Result<NodePhase, PipelineError> {
        let (w, h, _) = self.path.geometry();
        let coarse = (w.div_ceil(GRID), h.div_ceil(GRID));
        let period_px = self.path.carrier().period_px();
        self.run(frame.into(), &mut Scratch::default(), |_, wrapped| {
            colour_phase::at_nodes(&wrapped.coarse, wrapped.offset, coarse, period_px)
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

    /// The frame's force-side result and its colour sums per block, the stripes placed
    /// by the frame's phase as the service places them (no model needed).
    pub fn colour_sums<'i>(
        &self,
        frame: impl Into<Pixels<'i>>,
    ) -> Result<(Measurement, Vec<Sums>), PipelineError> {
        self.sums_placed(frame.into(), false)
    }

    /// As [`Analyzer::colour_sums`], for a frame known to be at rest (a calibration frame
    /// labelled without contact). When its phase shows a contact all the same (a misreading),
    /// the stripes are placed by the phase it reads at rest ([`WrappedPhase::at_rest`]), so
    /// the spot keeps its colours for the colour → temperature fit. Otherwise they are
    /// placed as the service places them: a phase the pigment's colour moves without a
    /// contact moves alike in service, and the fit must see the colours as read there. The
    /// result still says what the phase showed.
    pub fn colour_sums_at_rest<'i>(
        &self,
        frame: impl Into<Pixels<'i>>,
    ) -> Result<(Measurement, Vec<Sums>), PipelineError> {
        self.sums_placed(frame.into(), true)
    }

    /// The colour sums, the stripes placed at rest when `at_rest` and the phase shows a
    /// contact, by the phase as read otherwise.
    fn sums_placed(
        &self,
        frame: Pixels<'_>,
        at_rest: bool,
    ) -> Result<(Measurement, Vec<Sums>), PipelineError> {
        self.run(frame, &mut Scratch::default(), |d, wrapped| {
            let rest;
            let placed = if at_rest && d.contact {
                rest = wrapped.at_rest();
                &rest
            } else {
                wrapped
            };
            let (s, _) = self.thermo.sums(
                frame,
                |y, r, row| placed.frame_row(y, r, row),
                &d.reliable,
                None,
            );
            (d, s)
        })
    }

    /// As [`Analyzer::analyze`], and with a contact, how far it moves the contact region's
    /// chromaticity from the skin's ([`thermal::chroma_vs_skin`]): what the calibration
    /// measures on its kit's presses. The service never asks for it.
    pub fn analyze_contact_chroma<'i>(
        &self,
        frame: impl Into<Pixels<'i>>,
    ) -> Result<(Measurement, Option<[f32; 2]>), PipelineError> {
        let frame = frame.into();
        self.run(frame, &mut Scratch::default(), |d, wrapped| {
            let phase = |y: usize, r: &[u16], row: &mut [u16]| wrapped.frame_row(y, r, row);
            let codes = ContactCodes::of(&d);
            // One pass over the frame's colours serves the shift and the temperatures.
            let (blocks, contact) = self.thermo.sums(frame, phase, &d.reliable, codes.regions());
            let shift = codes
                .regions()
                .and_then(|_| thermal::chroma_vs_skin(&thermal::reading_region(contact), &blocks));
            (
                read_temperature(d, &self.thermo, (&blocks, contact), &codes),
                shift,
            )
        })
    }

    /// Phase and measurement of a frame on either path; `then` gets the force-side result
    /// and the wrapped phase difference as the measurement read it.
    fn run<R>(
        &self,
        frame: Pixels<'_>,
        scratch: &mut Scratch,
        then: impl FnOnce(Measurement, &WrappedPhase) -> R,
    ) -> Result<R, PipelineError> {
        self.run_in(frame, scratch, &self.context(), then)
    }

    /// [`Analyzer::run`] in the context `ctx`.
    fn run_in<R>(
        &self,
        frame: Pixels<'_>,
        scratch: &mut Scratch,
        ctx: &Context<'_>,
        then: impl FnOnce(Measurement, &WrappedPhase) -> R,
    ) -> Result<R, PipelineError> {
        self.check_size(frame)?;
        let (d, wrapped) = self.path.measure(frame, ctx, scratch);
        Ok(then(d, &wrapped))
    }

    /// Whether the skin's temperature that `d` reads leaves a field of the colour's phase
    /// to take out: one that reaches the frame's contact `threshold` (units) somewhere.
    /// Without a temperature the phase's own choice stands.
    fn colour_expected(&self, d: &Measurement, threshold: i32) -> bool {
        match (&self.colour_phase, &d.temperature) {
            (Some(c), Some(t)) => c.reaches_at(f64::from(t.mean_c), threshold),
            _ => true,
        }
    }

    /// The temperature side's prepared state.
    pub fn thermometer(&self) -> &Thermometer {
        &self.thermo
    }

    fn check_size(&self, frame: Pixels<'_>) -> Result<(), PipelineError> {
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

    fn context(&self) -> Context<'_> {
        Context {
            calib: &self.calib,
            blur_loss: &self.blur_loss,
            shapes: &self.shapes,
            mm_per_px: self.mm_per_px,
            ref_saturated_fraction: self.ref_saturation,
            unwrap: self.unwrap,
            colour_phase: self.colour_phase.as_ref(),
        }
    }

    /// Analyses one frame (with a scratch of its own: a stream of frames is better served
    /// by [`Analyzer::analyze_with`]).
    pub fn analyze<'i>(&self, frame: impl Into<Pixels<'i>>) -> Result<Measurement, PipelineError> {
        self.analyze_with(frame, &mut Scratch::default())
    }

    /// Analyses one frame, working in the caller's `scratch` (kept from frame to frame).
    pub fn analyze_with<'i>(
        &self,
        frame: impl Into<Pixels<'i>>,
        scratch: &mut Scratch,
    ) -> Result<Measurement, PipelineError> {
        let frame = frame.into();
        let read = |d, wrapped: &WrappedPhase| {
            let field = (wrapped.colour_field, wrapped.threshold);
            let phase = |y: usize, r: &[u16], row: &mut [u16]| wrapped.frame_row(y, r, row);
            (with_temperature(d, frame, &self.thermo, phase), field)
        };
        let (d, (field, threshold)) = self.run(frame, scratch, read)?;
        if !field || self.colour_expected(&d, threshold) {
            return Ok(d);
        }
        // The phase chose a field of the colour where the skin's temperature leaves none
        // (a large press at the reference's temperature can pass for one): read again
        // without it.
        let ctx = Context {
            colour_phase: None,
            ..self.context()
        };
        Ok(self.run_in(frame, scratch, &ctx, read)?.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A skin at 25 °C whose contact, read at 27.5 °C with σ 0.2 °C, is its hottest place
    /// or not.
    fn warm_contact(max_at_contact: bool) -> Temperature {
        Temperature {
            bw: 1,
            bh: 1,
            block_mm: 2.0,
            map_c: vec![25.0],
            var_c2: vec![0.01],
            min_c: 25.0,
            mean_c: 25.0,
            max_c: if max_at_contact { 27.5 } else { 25.0 },
            hottest_px: max_at_contact.then_some((10.0, 10.0)),
            max_at_contact,
            contact_c: Some(27.5),
            contact_sigma_c: Some(0.2),
            out_of_range: false,
            calibration_misses: false,
            mean_apart: false,
            measured: 1,
        }
    }

    /// A contact whose phase a flag doubts, read as the skin's hottest place: the hottest
    /// place carries `temperature_uncertain`; the same contact beside a hotter place, or
    /// under a doubt about the depth model alone, leaves the skin's temperatures trusted.
    #[test]
    fn a_doubted_contact_that_is_the_hottest_place_doubts_the_skins_hottest() {
        let read = |flags: QualityFlags, max_at_contact: bool| {
            let mut flags = flags;
            temperature_flags(&mut flags, &warm_contact(max_at_contact));
            flags
        };
        let sloped = QualityFlags::NONE.with(Flag::PhaseSlope);
        assert!(read(sloped, true).contains(Flag::TemperatureUncertain));
        assert!(!read(sloped, true).trusts(Reading::Temperature));
        assert_eq!(read(sloped, false), sloped);
        let depth_model = QualityFlags::NONE.with(Flag::DepthUncertain);
        assert_eq!(read(depth_model, true), depth_model);
        assert_eq!(read(QualityFlags::NONE, true), QualityFlags::NONE);
    }

    /// A skin whose mean lies outside the span of its places carries
    /// `temperature_uncertain`, whatever else the frame says.
    #[test]
    fn a_mean_apart_from_its_places_doubts_the_temperatures() {
        let mut t = warm_contact(false);
        t.mean_apart = true;
        let mut flags = QualityFlags::NONE;
        temperature_flags(&mut flags, &t);
        assert_eq!(flags, QualityFlags::NONE.with(Flag::TemperatureUncertain));
    }
}
