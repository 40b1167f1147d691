//! Calibration from labelled frame sets: the procedure behind `vistaf-skin calibrate`.
//!
//! 1. The unit geometry (carrier period, orientation, image size) comes from the first
//!    set's reference; every set must have the same image size.
//! 2. The phase sign is the one under which the `depth_mm`-labelled frames show the most
//!    indentation.
//! 3. Phase → depth: every frame with `depth_mm > 0` is analysed with an identity depth
//!    model; its peak phase and its label form a sample, grouped by depth setpoint.
//! 4. Measurement → force: frames with `force_n > 0` are analysed with the fitted depth
//!    model; volume, integrated phase, contact area and peak depth are candidate inputs,
//!    grouped by force level.
//!
//! Frames whose analysis carries a quality flag are left out of the fits (and reported once,
//! with every stage that left them out and why, after the fits):
//! a flagged number is not trusted, so it must not teach the model either. A flag that
//! most of the kit's depth frames carry (`low_contrast`: fringes too faint or too noisy for
//! the sensor) speaks of the unit, not of a frame: leaving those frames out would refuse
//! the unit outright, so the fits take them, the calibration says so, and every frame it
//! reads carries the flag as the kit's did ([`KIT_WIDE_FLAGS`]). A frame of the
//! skin at one temperature (labelled without contact) in which the phase shows a contact
//! keeps all its blocks but those around that spot: the label says the skin is at rest, so
//! the spot is the phase misreading (a pigment dark at that temperature lowers the
//! grating's contrast under a glare spot), and leaving the whole frame out would take its
//! temperature out of the model's range without a word in the verdict.

use sha2::{Digest, Sha256};
use vistaf_hardware::decode::Decoded;
use vistaf_hardware::frameset::FrameSet;
use vistaf_pipeline::calibration::colour_phase::ColourPhase;
use vistaf_pipeline::calibration::{
    Calibration, DepthError, DepthModel, FitRange, Fitted, ForceFeature, ForceModel, LoadSignature,
    SetRecord, ShapeSignature, UnitGeometry, FORMAT,
};
use vistaf_pipeline::ftp::carrier;
use vistaf_pipeline::image_ops::gray_down_f32;
use vistaf_pipeline::input::decode_scale;
use vistaf_pipeline::measure::profile::Shape;
use vistaf_pipeline::measure::{DEPTH_TOLERANCE_SHARE, DEPTH_TOLERANCE_UM};
use vistaf_pipeline::thermal::extremes::{departures_sigmas, STAND_OUT_SIGMAS};
use vistaf_pipeline::thermal::model::{
    mean_read_rises, MeanRead, ReferenceShift, StandOut, TemperatureModel, CHROMA_SPREAD_LIMIT,
    CHROMA_SPREAD_MIN_PRESSES, MEAN_READ_MIN_SLOPE, REFERENCE_SHIFT_LIMIT_C, STAND_OUT_LIMIT,
    STAND_OUT_MARGIN,
};
use vistaf_pipeline::thermal::HELD_OUT_MISS_LIMIT_C;
use vistaf_pipeline::{Analyzer, AnalyzerOptions, Implementation, Measurement, PipelineError};
use vistaf_protocol::{Flag, QualityFlags};

use crate::fit::{error_by_depth, fit_depth, fit_force, held_out_depths, place_spread, Sample};
use crate::temperature::rms;

/// What went wrong.
#[derive(Debug, thiserror::Error)]
pub enum CalibrateError {
    /// No sets given.
    #[error("give at least one frame set")]
    NoSets,
    /// Sets of different image sizes.
    #[error("{0}: image size differs from the first set's; calibrate one unit at a time")]
    MixedSizes(String),
    /// Not enough labelled frames.
    #[error("{0}")]
    NotEnough(String),
    /// A set could not be read.
    #[error(transparent)]
    FrameSet(#[from] vistaf_hardware::frameset::FrameSetError),
    /// The pipeline refused a reference.
    #[error("{set}: {cause}")]
    Pipeline {
        /// The set.
        set: String,
        /// Why.
        cause: PipelineError,
    },
    /// A file could not be hashed.
    #[error("{0}: {1}")]
    Io(String, std::io::Error),
}

/// Progress and remarks while calibrating.
pub trait Observer {
    /// `done` of `total` frames analysed in `stage`.
    fn progress(&mut self, stage: &str, done: usize, total: usize);
    /// A remark (a frame left out, say).
    fn note(&mut self, text: String);
}

/// An observer that ignores everything.
#[derive(Debug, Default)]
pub struct Quiet;

impl Observer for Quiet {
    fn progress(&mut self, _: &str, _: usize, _: usize) {}
    fn note(&mut self, _: String) {}
}

/// An observer that keeps the remarks, in order, and ignores progress: for a caller that
/// shows them later, or checks them.
#[derive(Debug, Default)]
pub struct Notes(pub Vec<String>);

impl Observer for Notes {
    fn progress(&mut self, _: &str, _: usize, _: usize) {}
    fn note(&mut self, text: String) {
        self.0.push(text);
    }
}

fn sha_of(set: &FrameSet) -> Result<String, CalibrateError> {
    let mut h = Sha256::new();
    let files = std::iter::once("set.json".to_string())
        .chain(std::iter::once(set.manifest.reference.clone()))
        .chain(set.manifest.frames.iter().map(|f| f.file.clone()));
    for f in files {
        let p = set.path_of(&f);
        h.update(std::fs::read(&p).map_err(|e| CalibrateError::Io(p.display().to_string(), e))?);
    }
    Ok(h.finalize().iter().map(|b| format!("{b:02x}")).collect())
}

/// Flags that, carried by more than half the kit's depth frames, are the unit's and not a
/// frame's: the fits take frames carrying them. A skin whose fringes are faint or noisy
/// throughout is measured with that flag on every frame; refusing its calibration would
/// leave the robot no reading at all.
pub const KIT_WIDE_FLAGS: [Flag; 1] = [Flag::LowContrast];

/// Which label a stage fits.
#[derive(Clone, Copy)]
enum Label {
    /// The indentation, for the depth model.
    Depth,
    /// The indentation, for the indenter's area against its measured depth.
    Shape,
    Force,
}

impl Label {
    /// Whether a frame fitted on this label may carry `flag` and still be trusted: a force
    /// is read from the whole map, which the band's blur leaves as it was, so a peak too
    /// narrow to resolve (`depth_unresolved`, the lightest kit presses) does not spoil it;
    /// nor does it spoil the area against the depth *as measured*, which is how a frame is
    /// later compared with the calibrated indenter (`Flag::PhaseSlope`). A depth model
    /// that misses its own held-out presses (`depth_uncertain`) says nothing against any
    /// one frame.
    fn tolerates(self, flag: Flag) -> bool {
        matches!(
            (self, flag),
            (Label::Shape | Label::Force, Flag::DepthUnresolved) | (_, Flag::DepthUncertain)
        )
    }
}

/// The stage that fits phase → depth, as its left-out frames name it.
const DEPTH_STAGE: &str = "phase → depth";

struct Run<'a, O: Observer> {
    sets: &'a [FrameSet],
    imp: Implementation,
    obs: &'a mut O,
    /// Frames are decoded at `1/scale` ([`UnitGeometry::decode_scale`]).
    scale: u32,
    /// The frames left out of a fit so far, in the order first met: a frame left out of one
    /// stage is usually left out of the next too, for the same reasons or for one a later
    /// stage's model adds (`depth_out_of_range`), and is reported once, with every stage
    /// and reason ([`Run::report_left_out`]).
    left: Vec<LeftOut>,
    /// Flags the fits take because the unit carries them ([`KIT_WIDE_FLAGS`]).
    kit_wide: QualityFlags,
    /// Frames the last stage analysed, and how many carried each of [`KIT_WIDE_FLAGS`].
    tally: (usize, [usize; KIT_WIDE_FLAGS.len()]),
}

/// A kit frame left out of one or more fits.
struct LeftOut {
    /// `set: file`.
    frame: String,
    /// The stages that left it out.
    stages: Vec<String>,
    /// Why (flag names, or what its profile showed), each once.
    reasons: Vec<String>,
}

impl<'a, O: Observer> Run<'a, O> {
    /// A run over `sets`, decoded at `1/scale`, before any frame is analysed.
    fn new(sets: &'a [FrameSet], imp: Implementation, obs: &'a mut O, scale: u32) -> Self {
        Run {
            sets,
            imp,
            obs,
            scale,
            left: Vec::new(),
            kit_wide: QualityFlags::NONE,
            tally: Default::default(),
        }
    }

    /// Records `frame` (`set: file`) left out of `stage`'s fit for `reasons`.
    fn left_out(&mut self, frame: String, stage: &str, reasons: Vec<String>) {
        let l = match self.left.iter().position(|l| l.frame == frame) {
            Some(at) => &mut self.left[at],
            None => {
                self.left.push(LeftOut {
                    frame,
                    stages: Vec::new(),
                    reasons: Vec::new(),
                });
                let last = self.left.len() - 1;
                &mut self.left[last]
            }
        };
        if !l.stages.iter().any(|s| s == stage) {
            l.stages.push(stage.to_string());
        }
        for r in reasons {
            if !l.reasons.contains(&r) {
                l.reasons.push(r);
            }
        }
    }

    /// Counts a frame analysed, and the kit-wide flags it carries.
    fn count(&mut self, flags: QualityFlags) {
        self.tally.0 += 1;
        for (n, f) in self.tally.1.iter_mut().zip(KIT_WIDE_FLAGS) {
            *n += usize::from(flags.contains(f));
        }
    }

    /// Takes every flag of [`KIT_WIDE_FLAGS`] that more than half the frames of the last
    /// stage carried, says so, and forgets the frames left out so far (the stage runs again
    /// with the flag taken). Whether any was taken.
    fn take_kit_wide(&mut self) -> bool {
        let (seen, carried) = std::mem::take(&mut self.tally);
        let mut taken = false;
        for (n, f) in carried.into_iter().zip(KIT_WIDE_FLAGS) {
            if n * 2 > seen && !self.kit_wide.contains(f) {
                self.kit_wide.insert(f);
                self.obs.note(format!(
                    "{n} of {seen} depth frames carry {}: the unit's fringes are faint or \
                     noisy throughout, so the fits take such frames, and every frame this \
                     calibration reads will carry {} as these do",
                    f.name(),
                    f.name()
                ));
                taken = true;
            }
        }
        if taken {
            self.left.clear();
        }
        taken
    }

    /// Why phase → depth found too few depths: the depths its trusted `samples` hold, and
    /// the flag most of the frames it left out carried, with what that flag asks of the
    /// kit where one thing does.
    fn too_few_depths(&self, samples: &[Sample]) -> String {
        let mut depths: Vec<f64> = samples.iter().map(|s| s.y).collect();
        depths.sort_by(f64::total_cmp);
        depths.dedup_by(|a, b| setpoint(*a) == setpoint(*b));
        let trusted = match depths.as_slice() {
            [] => "no press read and trusted".to_string(),
            d => {
                let d: Vec<String> = d.iter().map(|v| format!("{v}")).collect();
                format!("presses read and trusted only at {} mm", d.join(", "))
            }
        };
        let out: Vec<&LeftOut> = (self.left.iter())
            .filter(|l| l.stages.iter().any(|s| s == DEPTH_STAGE))
            .collect();
        let carrying = |r: &String| out.iter().filter(|l| l.reasons.contains(r)).count();
        let commonest = (out.iter().flat_map(|l| &l.reasons)).max_by_key(|r| carrying(r));
        let why = commonest.map_or(String::new(), |name| {
            let n = carrying(name);
            let ask = if name.as_str() == Flag::PhaseSlope.name() {
                ": the stripes bend beyond the demodulator's band, too steep for this \
                 grating (press the kit shallower, or use a coarser grating)"
            } else {
                ""
            };
            format!(
                "; {n} of the {} frames left out carry {name}{ask}",
                out.len()
            )
        });
        format!("phase → depth needs trusted frames at three or more depths, {trusted}{why}")
    }

    /// Notes each frame left out of a fit, once: the stages that left it out and why.
    fn report_left_out(&mut self) {
        for l in std::mem::take(&mut self.left) {
            self.obs.note(format!(
                "{} left out of {} ({})",
                l.frame,
                l.stages.join(", "),
                l.reasons.join(", ")
            ));
        }
    }

    /// Analyses every frame carrying `label > 0` (and `only` accepts) with `calib`; returns
    /// (label, result) for those without a flag the label does not tolerate
    /// ([`Label::tolerates`]).
    fn analyze(
        &mut self,
        calib: &Calibration,
        label: Label,
        stage: &str,
        only: &dyn Fn(f64) -> bool,
    ) -> Result<Vec<(f64, Measurement)>, CalibrateError> {
        let read = |an: &Analyzer, f: &Decoded| an.analyze(f).map(|d| (d, ()));
        let out = self.analyze_by(calib, label, stage, only, read)?;
        Ok(out.into_iter().map(|(y, d, ())| (y, d)).collect())
    }

    /// As [`Run::analyze`], each frame read by `read`, which gives what else it reads
    /// beside the measurement.
    fn analyze_by<X>(
        &mut self,
        calib: &Calibration,
        label: Label,
        stage: &str,
        only: &dyn Fn(f64) -> bool,
        read: impl Fn(&Analyzer, &Decoded) -> Result<(Measurement, X), PipelineError>,
    ) -> Result<Vec<(f64, Measurement, X)>, CalibrateError> {
        let opts = AnalyzerOptions {
            force_calibration: true,
            ..Default::default()
        };
        let total: usize = self.sets.iter().map(|s| s.len()).sum();
        let mut done = 0;
        let mut out = Vec::new();
        let mut frame = Decoded::default();
        self.tally = Default::default();
        for s in self.sets {
            let set = s.dir().display().to_string();
            let reference = s.decoded_reference(self.scale)?;
            let an = Analyzer::new(&reference, calib.clone(), self.imp, opts).map_err(|cause| {
                CalibrateError::Pipeline {
                    set: set.clone(),
                    cause,
                }
            })?;
            for (i, f) in s.manifest.frames.iter().enumerate() {
                done += 1;
                self.obs.progress(stage, done, total);
                let y = match label {
                    Label::Depth | Label::Shape => f.depth_mm,
                    Label::Force => f.force_n,
                };
                let Some(y) = y.filter(|v| *v > 0.0 && only(*v)) else {
                    continue;
                };
                s.decoded_frame(i, self.scale, &mut frame)?;
                let (d, extra) = read(&an, &frame).map_err(|cause| CalibrateError::Pipeline {
                    set: set.clone(),
                    cause,
                })?;
                let frame_name = || format!("{set}: {}", f.file);
                self.count(d.flags);
                if d.shape == Shape::Flat {
                    // The kit's indenter is a sphere: a press whose profile reads as a
                    // plateau was read with a punch's depth, not the sphere's apex.
                    let why = "its profile reads as a flat punch's".to_string();
                    self.left_out(frame_name(), stage, vec![why]);
                } else if d
                    .flags
                    .iter()
                    .all(|f| label.tolerates(f) || self.kit_wide.contains(f))
                {
                    out.push((y, d, extra));
                } else {
                    let names = d
                        .flags
                        .iter()
                        .filter(|f| !self.kit_wide.contains(*f))
                        .map(|f| f.name().to_string())
                        .collect();
                    self.left_out(frame_name(), stage, names);
                }
            }
        }
        Ok(out)
    }
}

/// Blocks taken from one calibration frame, at most (evenly spread): enough to see the
/// whole field, few enough to keep the fit quick.
const BLOCKS_PER_FRAME: usize = 256;

/// The flags that leave a no-contact frame out of the colour → temperature fit: those that
/// say its colours are not the skin's (clipped, or read against a reference they no longer
/// match). The others judge the depth map; a pigment dark enough at some temperature to
/// lower the grating's contrast is exactly what the fit must see.
const COLOUR_FLAGS: [Flag; 3] = [
    Flag::OverExposure,
    Flag::Misregistration,
    Flag::StaleReference,
];

/// What the uniform frames of the kit give: colour → temperature and the phase the
/// colour moves at each setpoint.
type UniformFits = (
    Option<vistaf_pipeline::thermal::model::TemperatureModel>,
    Option<ColourPhase>,
);

/// Colour → temperature from the frames labelled `temperature_c` without contact
/// (`depth_mm` and `force_n` absent or 0); `None` (with a note) when there are too few.
/// Beside it, the phase those frames show against their reference at each setpoint
/// ([`ColourPhase`]), from the same frames.
fn temperature_model<O: Observer>(
    run: &mut Run<'_, O>,
    calib: &Calibration,
) -> Result<UniformFits, CalibrateError> {
    use crate::temperature::{fit_temperature, BlockSample};
    use vistaf_pipeline::thermal::stripes::pool;
    use vistaf_pipeline::thermal::BLACK_POOL;
    let no_contact = |f: &vistaf_hardware::frameset::FrameEntry| {
        f.temperature_c.is_some()
            && f.depth_mm.unwrap_or(0.0) <= 0.0
            && f.force_n.unwrap_or(0.0) <= 0.0
    };
    let total: usize = run
        .sets
        .iter()
        .map(|s| s.manifest.frames.iter().filter(|f| no_contact(f)).count())
        .sum();
    let opts = AnalyzerOptions {
        force_calibration: true,
        ..Default::default()
    };
    let (mut samples, mut labelled, mut clipped) = (Vec::new(), Vec::new(), Vec::new());
    // (set, frame, label) of every frame in the fit.
    let mut kept = Vec::new();
    // Whether a frame labelled without contact whose phase shows one was explained.
    let mut explained = false;
    // Each kept frame's setpoint and phase at the colour's nodes, and the nodes.
    let (mut fields, mut nodes) = (Vec::new(), None);
    let mut done = 0;
    for (si, s) in run.sets.iter().enumerate() {
        if !s.manifest.frames.iter().any(no_contact) {
            continue;
        }
        let set = s.dir().display().to_string();
        let pipe = |cause| CalibrateError::Pipeline {
            set: set.clone(),
            cause,
        };
        let reference = s.decoded_reference(run.scale)?;
        let an = Analyzer::new(&reference, calib.clone(), run.imp, opts).map_err(pipe)?;
        let mut frame = Decoded::default();
        for (i, f) in s.manifest.frames.iter().enumerate() {
            let Some(t) = f.temperature_c.filter(|_| no_contact(f)) else {
                continue;
            };
            done += 1;
            labelled.push(t);
            run.obs.progress("colour → temperature", done, total);
            s.decoded_frame(i, run.scale, &mut frame)?;
            // The label says the skin is at rest: a contact its phase shows is a misreading,
            // and the stripes are placed as they lie at rest.
            let (d, sums) = an.colour_sums_at_rest(&frame).map_err(pipe)?;
            let spoilt: Vec<&str> = COLOUR_FLAGS
                .iter()
                .filter(|f| d.flags.contains(**f))
                .map(|f| f.name())
                .collect();
            if d.flags.contains(Flag::OverExposure) {
                clipped.push(t);
            }
            if !spoilt.is_empty() {
                run.obs.note(format!(
                    "{set}: {} left out of the temperature fit ({})",
                    f.file,
                    spoilt.join(", ")
                ));
                continue;
            }
            if d.contact {
                // Why, the first time only: the next frames say what happened to them.
                let why = if explained {
                    ""
                } else {
                    " (the phase misread there: the pigment's colour at this temperature \
                     lowers the grating's contrast, under a glare spot say)"
                };
                explained = true;
                run.obs.note(format!(
                    "{set}: {} shows contact where its label says none{why}; kept in the \
                     temperature fit with its stripes placed by the registration where the \
                     phase moved",
                    f.file,
                ));
            }
            let (n, at_nodes) = an.colour_phase_nodes(&frame).map_err(pipe)?;
            nodes = Some(n);
            fields.push((t, at_nodes));
            let g = an.thermometer().geometry();
            let pooled = pool(&sums, g.bw, g.bh, BLACK_POOL);
            // As the thermometer reads them: the coloured stripes against the
            // neighbourhood's black stripes.
            let good: Vec<BlockSample> = sums
                .iter()
                .zip(&pooled)
                .filter_map(|(b, p)| {
                    Some(BlockSample {
                        v: b.invariants(p)?,
                        pooled: p.invariants(p)?,
                        t_c: t,
                    })
                })
                .collect();
            let step = good.len().div_ceil(BLOCKS_PER_FRAME).max(1);
            samples.extend(good.into_iter().step_by(step));
            kept.push((si, i, t));
        }
    }
    let colour_phase = nodes.and_then(|n| ColourPhase::from_frames(n, &fields));
    if samples.is_empty() {
        run.obs.note(
            "no trusted no-contact frames labelled temperature_c: no temperature model".into(),
        );
        return Ok((None, colour_phase));
    }
    let fitted: Vec<f64> = samples.iter().map(|s| s.t_c).collect();
    let mut blind_above_c = None;
    if let Some(([lo, hi], beyond)) = beyond_fitted(&labelled, &fitted) {
        let list: Vec<String> = beyond.iter().map(|t| format!("{t}")).collect();
        blind_above_c = blind_above(hi, &beyond, &clipped);
        run.obs.note(if blind_above_c.is_some() {
            format!(
                "no frame at {} °C is in the temperature fit: the camera clipped the warmer \
                 ones (over_exposure: the cleared pigment and the lamps' reflections reach \
                 full scale). The model covers {lo}–{hi} °C, and a reading that reaches \
                 {hi} °C may stand for any warmer skin: it is flagged \
                 temperature_out_of_range. Lower the LED ring's brightness (led.brightness) or \
                 the camera's exposure and capture the kit again to read warmer skin",
                list.join(", ")
            )
        } else {
            format!(
                "no frame at {} °C is in the temperature fit: the model covers {lo}–{hi} °C, \
                 and a reading beyond that is extrapolated (add frames at those setpoints)",
                list.join(", ")
            )
        });
    }
    match fit_temperature(&samples) {
        Ok(mut m) => {
            m.blind_above_c = blind_above_c;
            let reads = kit_reads(run, calib, &m, &kept, None)?;
            m.reference_shift = reference_shift(run, calib, &m, &kept, &reads)?;
            m.mean_read = mean_read(run, &reads);
            m.stand_out = stand_out(run, &reads);
            Ok((Some(m), colour_phase))
        }
        Err(e) => {
            run.obs.note(format!("{e}: no temperature model"));
            Ok((None, colour_phase))
        }
    }
}

/// What the service reads on the kit's uniform frames at one setpoint.
#[derive(Debug, Clone, Copy)]
struct KitRead {
    /// The setpoint, °C.
    setpoint_c: f64,
    /// The skin's mean as read, averaged over the setpoint's frames, °C.
    mean_c: f64,
    /// The largest departure of a place from the skin over the setpoint's frames, either
    /// way, in standard deviations ([`departures_sigmas`]).
    departure_sigmas: f64,
}

/// The skin's mean at each setpoint ([`TemperatureModel::mean_read`]), over the longest
/// stretch of setpoints where it rises, with a note of what it mends; empty (with a note)
/// where it rises nowhere.
fn mean_read<O: Observer>(run: &mut Run<'_, O>, reads: &[KitRead]) -> Vec<MeanRead> {
    let points: Vec<MeanRead> = reads
        .iter()
        .map(|r| MeanRead {
            setpoint_c: r.setpoint_c,
            read_c: r.mean_c,
        })
        .collect();
    let rising = longest_rising(&points);
    if rising.len() < 2 {
        run.obs.note(format!(
            "the skin's mean, as read on the kit's uniform frames, rises by less than \
             {MEAN_READ_MIN_SLOPE} °C per °C between every two setpoints: reported as read"
        ));
        return Vec::new();
    }
    if rising.len() < points.len() {
        run.obs.note(format!(
            "the skin's mean, as read on the kit's uniform frames, rises by less than \
             {MEAN_READ_MIN_SLOPE} °C per °C outside {}–{} °C: beyond, the offset at that \
             end fades out over one setpoint step and the mean is reported as read",
            rising[0].setpoint_c,
            rising[rising.len() - 1].setpoint_c,
        ));
    }
    run.obs.note(mean_read_note(rising));
    rising.to_vec()
}

/// How far places departed from the skin on the kit's uniform frames at each setpoint
/// ([`TemperatureModel::stand_out`]), with a note; empty where nowhere did they depart
/// further than the least threshold allows for.
fn stand_out<O: Observer>(run: &mut Run<'_, O>, reads: &[KitRead]) -> Vec<StandOut> {
    let table: Vec<StandOut> = reads
        .iter()
        .filter(|r| r.departure_sigmas.is_finite())
        .map(|r| StandOut {
            setpoint_c: r.setpoint_c,
            // A block the variance tables call exact can depart without bound; the file
            // holds what any threshold needs.
            sigmas: r.departure_sigmas.min(STAND_OUT_LIMIT),
        })
        .collect();
    let least = f64::from(STAND_OUT_SIGMAS);
    let Some(widest) = table
        .iter()
        .filter(|p| STAND_OUT_MARGIN * p.sigmas > least)
        .max_by(|a, b| a.sigmas.total_cmp(&b.sigmas))
    else {
        return Vec::new();
    };
    run.obs.note(format!(
        "places on the kit's uniform frames departed from the skin by up to {:.1} σ of \
         their noise (at {} °C): a coldest or hottest place must depart {STAND_OUT_MARGIN} \
         times as far as the kit's near its temperature, and at least {least} σ",
        widest.sigmas, widest.setpoint_c
    ));
    table
}

/// The temperatures a skin at rest, and so a reference, is taken at indoors, °C: the
/// kit's frames are read again against its uniform frames nearest each
/// ([`TemperatureModel::reference_shift`]).
const REST_C: [f64; 2] = [20.0, 30.0];

/// How far the skin's mean at each setpoint moves from `reads` (against each set's own
/// reference) when the kit's frames are read against its uniform frames nearest each of
/// [`REST_C`] instead, the larger move of the two, with a note where it exceeds
/// [`HELD_OUT_MISS_LIMIT_C`]. A unit's reference is taken at whatever temperature its skin
/// rests at; where the reading follows it, the table says by how much.
fn reference_shift<O: Observer>(
    run: &mut Run<'_, O>,
    calib: &Calibration,
    model: &TemperatureModel,
    kept: &[(usize, usize, f64)],
    reads: &[KitRead],
) -> Result<Vec<ReferenceShift>, CalibrateError> {
    let others = REST_C
        .iter()
        .map(|&rest| kit_reads(run, calib, model, kept, Some(rest)))
        .collect::<Result<Vec<_>, _>>()?;
    let table = widest_shift(reads, &others);
    let limit = f64::from(HELD_OUT_MISS_LIMIT_C);
    let moved: Vec<String> = table
        .iter()
        .filter(|p| p.shift_c > limit)
        .map(|p| format!("{} °C", p.setpoint_c))
        .collect();
    if !moved.is_empty() {
        run.obs.note(format!(
            "read against the kit's uniform frames nearest {} and {} °C as the reference, the \
             skin's mean moved by more than {limit} °C at {}: readings near there carry \
             temperature_uncertain",
            REST_C[0],
            REST_C[1],
            moved.join(", ")
        ));
    }
    Ok(table)
}

/// How far each setpoint's mean in `own` moved in each of `others` (the kit read against
/// other references): the largest move, held within [`REFERENCE_SHIFT_LIMIT_C`], one entry
/// per read of `own` in its order. A setpoint another reading has no read for, or reads no
/// finite mean at, adds nothing from it.
fn widest_shift(own: &[KitRead], others: &[Vec<KitRead>]) -> Vec<ReferenceShift> {
    let moved = |r: &KitRead| {
        others
            .iter()
            .flatten()
            .filter(|o| o.setpoint_c == r.setpoint_c)
            .map(|o| (o.mean_c - r.mean_c).abs())
            .filter(|m| m.is_finite())
            .fold(0.0, f64::max)
    };
    own.iter()
        .map(|r| ReferenceShift {
            setpoint_c: r.setpoint_c,
            shift_c: moved(r).min(REFERENCE_SHIFT_LIMIT_C),
        })
        .collect()
}

/// What the service reads on the frames `kept` (set, frame, label) at each setpoint, in
/// setpoint order, each frame read with `model` as the service reads it: against its set's
/// reference, or (`rest_c`) against the set's kept frame whose label lies nearest.
fn kit_reads<O: Observer>(
    run: &mut Run<'_, O>,
    calib: &Calibration,
    model: &TemperatureModel,
    kept: &[(usize, usize, f64)],
    rest_c: Option<f64>,
) -> Result<Vec<KitRead>, CalibrateError> {
    let calib = Calibration {
        temperature: Some(model.clone()),
        ..calib.clone()
    };
    let opts = AnalyzerOptions {
        force_calibration: true,
        ..Default::default()
    };
    // (setpoint key, frames, reading with its means summed)
    let mut sums: Vec<(f64, f64, KitRead)> = Vec::new();
    let mut frame = Decoded::default();
    for (si, s) in run.sets.iter().enumerate() {
        let frames: Vec<&(usize, usize, f64)> = kept.iter().filter(|k| k.0 == si).collect();
        if frames.is_empty() {
            continue;
        }
        let pipe = |cause| CalibrateError::Pipeline {
            set: s.dir().display().to_string(),
            cause,
        };
        let reference = match rest_c {
            None => s.decoded_reference(run.scale)?,
            Some(rest) => {
                let away = |k: &&&(usize, usize, f64)| (k.2 - rest).abs();
                let Some(&&(_, i, _)) = frames.iter().min_by(|a, b| away(a).total_cmp(&away(b)))
                else {
                    continue;
                };
                let mut r = Decoded::default();
                s.decoded_frame(i, run.scale, &mut r)?;
                r
            }
        };
        let an = Analyzer::new(&reference, calib.clone(), run.imp, opts).map_err(pipe)?;
        for (done, &&(_, i, t)) in frames.iter().enumerate() {
            run.obs.progress("the skin's mean", done + 1, frames.len());
            s.decoded_frame(i, run.scale, &mut frame)?;
            let d = an.analyze(&frame).map_err(pipe)?;
            let Some(m) = d.temperature.filter(|m| m.mean_c.is_finite()) else {
                continue;
            };
            let [cold, hot] = departures_sigmas(&m.map_c, &m.var_c2, (m.bw, m.bh));
            let read = KitRead {
                setpoint_c: t,
                mean_c: f64::from(m.mean_c),
                departure_sigmas: f64::from(cold.max(hot)),
            };
            let key = setpoint(t);
            match sums.iter_mut().find(|x| x.0 == key) {
                Some((_, n, sum)) => {
                    *n += 1.0;
                    sum.mean_c += read.mean_c;
                    sum.departure_sigmas = sum.departure_sigmas.max(read.departure_sigmas);
                }
                None => sums.push((key, 1.0, read)),
            }
        }
    }
    sums.sort_by(|a, b| a.0.total_cmp(&b.0));
    Ok(sums
        .into_iter()
        .map(|(_, n, sum)| KitRead {
            mean_c: sum.mean_c / n,
            ..sum
        })
        .collect())
}

/// The longest run of successive `points` (in setpoint order) that rises throughout
/// ([`mean_read_rises`]): where the mean stands still over a step (a population's colour
/// that stops moving at the kit's end, flagged there), it cannot be turned back.
fn longest_rising(points: &[MeanRead]) -> &[MeanRead] {
    let mut best = &points[..0];
    let mut start = 0;
    for end in 1..=points.len() {
        let breaks = end == points.len() || !mean_read_rises(&points[end - 1..=end]);
        if breaks {
            if end - start > best.len() {
                best = &points[start..end];
            }
            start = end;
        }
    }
    best
}

/// What the mean's table mends: the kit's uniform frames as read, and through the table
/// with each inner setpoint left out (read between its neighbours), RMSE °C.
fn mean_read_note(points: &[MeanRead]) -> String {
    let as_read: Vec<f64> = points.iter().map(|p| p.read_c - p.setpoint_c).collect();
    let held_out: Vec<f64> = points
        .windows(3)
        .map(|w| MeanRead::setpoint_at(&w[0], &w[2], w[1].read_c) - w[1].setpoint_c)
        .collect();
    format!(
        "the skin's mean on the kit's uniform frames: {:.3} °C RMSE as read, {:.3} °C through \
         its table with each inner setpoint left out",
        rms(&as_read),
        rms(&held_out)
    )
}

/// The span of the `fitted` temperatures (°C), and the `labelled` setpoints beyond it,
/// distinct and in order, when there are any: the kit's temperatures the model never saw
/// and would only extrapolate to.
fn beyond_fitted(labelled: &[f64], fitted: &[f64]) -> Option<([f64; 2], Vec<f64>)> {
    let lo = fitted.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = fitted.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let mut beyond: Vec<f64> = labelled
        .iter()
        .copied()
        .filter(|t| *t < lo || *t > hi)
        .collect();
    beyond.sort_by(f64::total_cmp);
    beyond.dedup_by(|a, b| setpoint(*a) == setpoint(*b));
    (lo <= hi && !beyond.is_empty()).then_some(([lo, hi], beyond))
}

/// The warmest fitted setpoint `hi` (°C), when every kit setpoint above it that the fit
/// lacks (`beyond`) was clipped by the camera (`clipped`: the labels of the frames flagged
/// over-exposed): the camera is blind above it, and a skin warmer reads as it. `None` when
/// some warmer setpoint is missing for another reason, or none is missing.
fn blind_above(hi: f64, beyond: &[f64], clipped: &[f64]) -> Option<f64> {
    let warmer: Vec<f64> = beyond.iter().copied().filter(|t| *t > hi).collect();
    let seen = |t: f64| clipped.iter().any(|c| setpoint(*c) == setpoint(t));
    (!warmer.is_empty() && warmer.iter().all(|t| seen(*t))).then_some(hi)
}

/// The setpoint a label belongs to: labels equal to 1/1000 of their unit (1 µm, 1 mN) are
/// one setpoint.
fn setpoint(label: f64) -> f64 {
    (label * 1000.0).round()
}

/// A calibration whose depth model is the identity: its "depth" in mm reads as phase in rad.
fn identity(unit: &UnitGeometry, sign: f64) -> Calibration {
    Calibration {
        format: FORMAT.into(),
        unit: unit.clone(),
        phase_sign: sign,
        depth: Fitted {
            model: DepthModel::Linear { k_mm_per_rad: 1.0 },
            equation: String::new(),
            cv_rmse: 0.0,
            in_sample_rmse: 0.0,
            n: 0,
            candidates: vec![],
            range: None,
        },
        depth_place_spread: None,
        depth_error: None,
        force: None,
        shape: None,
        temperature: None,
        colour_phase: None,
        sets: vec![],
    }
}

/// Fits a calibration from `sets` with the pipeline `imp`.
pub fn calibrate<O: Observer>(
    sets: &[FrameSet],
    imp: Implementation,
    obs: &mut O,
) -> Result<Calibration, CalibrateError> {
    let first = sets.first().ok_or(CalibrateError::NoSets)?;
    for s in sets {
        if s.size() != first.size() {
            return Err(CalibrateError::MixedSizes(s.dir().display().to_string()));
        }
    }
    let unit = unit_geometry(first)?;
    let mut run = Run::new(sets, imp, obs, unit.decode_scale);
    // The frames left out are reported whether the fits succeed or not: a fit refused for
    // too few frames is explained by them.
    let fitted = fit_models(&mut run, &unit);
    run.report_left_out();
    let mut calib = fitted?;
    calib.sets = sets
        .iter()
        .map(|s| {
            Ok(SetRecord {
                path: s.dir().display().to_string(),
                sha256: sha_of(s)?,
                frames: s.len(),
            })
        })
        .collect::<Result<_, CalibrateError>>()?;
    Ok(calib)
}

/// Every model, fitted in turn on the kit: the phase's sign, phase → depth, the indenter's
/// shape signature, force and temperature.
fn fit_models<O: Observer>(
    run: &mut Run<'_, O>,
    unit: &UnitGeometry,
) -> Result<Calibration, CalibrateError> {
    let mut sign = phase_sign(run, unit)?;
    if run.take_kit_wide() {
        sign = phase_sign(run, unit)?;
    }
    let mut calib = identity(unit, sign);
    let depth = depth_model(run, &calib)?;
    (calib.depth, calib.depth_place_spread, calib.depth_error) =
        (depth.fitted, depth.place_spread, depth.error);
    calib.shape = shape_signature(run, &calib)?;
    calib.force = force_model(run, &calib)?;
    (calib.temperature, calib.colour_phase) = temperature_model(run, &calib)?;
    if calib.temperature.is_some() {
        let spread = contact_chroma_spread(run, &calib)?;
        if let Some(m) = calib.temperature.as_mut() {
            m.contact_chroma_spread = spread;
        }
    }
    Ok(calib)
}

/// How far the kit's presses move the contact's chromaticity from the skin's
/// ([`TemperatureModel::contact_chroma_spread`]): the RMS over the trusted depth frames
/// whose contact the thermometer read, each of `r` and `g`; zero, with a note, with fewer
/// than [`CHROMA_SPREAD_MIN_PRESSES`].
fn contact_chroma_spread<O: Observer>(
    run: &mut Run<'_, O>,
    calib: &Calibration,
) -> Result<[f64; 2], CalibrateError> {
    let read = |an: &Analyzer, f: &Decoded| an.analyze_contact_chroma(f);
    let presses = run.analyze_by(calib, Label::Depth, "contact colour", &|_| true, read)?;
    let shifts: Vec<[f32; 2]> = presses
        .into_iter()
        .filter_map(|(_, _, shift)| shift)
        .filter(|s| s.iter().all(|v| v.is_finite()))
        .collect();
    if shifts.len() < CHROMA_SPREAD_MIN_PRESSES {
        run.obs.note(format!(
            "{} kit presses show the contact's colour (at least {CHROMA_SPREAD_MIN_PRESSES} \
             needed): a contact's temperature σ holds no term for what a press does to its \
             chromaticity",
            shifts.len()
        ));
        return Ok([0.0; 2]);
    }
    let rms_of = |k: usize| {
        let v: Vec<f64> = shifts.iter().map(|s| f64::from(s[k])).collect();
        rms(&v).min(CHROMA_SPREAD_LIMIT)
    };
    let spread = [rms_of(0), rms_of(1)];
    run.obs.note(format!(
        "a press moves the contact's chromaticity from the skin's by {:.2} % (r) and {:.2} % \
         (g) RMS over {} kit presses; a contact's temperature σ carries it",
        100.0 * spread[0],
        100.0 * spread[1],
        shifts.len()
    ));
    Ok(spread)
}

/// The unit geometry (carrier period, orientation, image size) from the first set's
/// reference, and the scale its frames are decoded at: the camera's image is read at full
/// size once, and at `1/decode_scale` from then on (see [`decode_scale`]).
fn unit_geometry(first: &FrameSet) -> Result<UnitGeometry, CalibrateError> {
    let carrier_of = |img: &Decoded| {
        let (g, gw, gh) = gray_down_f32(img, 1);
        carrier::estimate(&g, gw, gh).map_err(|e| CalibrateError::Pipeline {
            set: first.dir().display().to_string(),
            cause: e.into(),
        })
    };
    let full = first.decoded_reference(1)?;
    let scale = decode_scale(
        full.width,
        full.height,
        f64::from(carrier_of(&full)?.period_px()),
    );
    let reference = if scale == 1 {
        full
    } else {
        first.decoded_reference(scale)?
    };
    let c = carrier_of(&reference)?;
    Ok(UnitGeometry {
        width_px: reference.width,
        height_px: reference.height,
        period_px: f64::from(c.period_px()),
        angle_deg: f64::from(c.angle_deg()),
        grating_period_mm: first.manifest.grating_period_mm,
        decode_scale: scale,
    })
}

/// The phase sign under which the depth set's trusted frames show the most indentation.
/// Every labelled depth counts, not only the deepest: on a unit whose deepest presses bend
/// the stripes beyond the band those are flagged under the right sign, and the sign must
/// not be decided by frames the fit will not trust.
fn phase_sign<O: Observer>(
    run: &mut Run<'_, O>,
    unit: &UnitGeometry,
) -> Result<f64, CalibrateError> {
    let deepest = run
        .sets
        .iter()
        .flat_map(|s| s.manifest.frames.iter().filter_map(|f| f.depth_mm))
        .fold(0.0, f64::max);
    if deepest <= 0.0 {
        return Err(CalibrateError::NotEnough(
            "no frame is labelled with depth_mm > 0: phase → depth needs a depth set".into(),
        ));
    }
    let mut indentation_under = |sign: f64| -> Result<f64, CalibrateError> {
        let r = run.analyze(&identity(unit, sign), Label::Depth, "phase sign", &|_| true)?;
        Ok(r.iter()
            .filter(|(_, d)| d.contact)
            .map(|(_, d)| f64::from(d.peak_depth_mm))
            .sum())
    };
    Ok(if indentation_under(-1.0)? > indentation_under(1.0)? {
        -1.0
    } else {
        1.0
    })
}

/// Phase → depth: every trusted frame labelled `depth_mm > 0`, analysed with the identity
/// depth model of `calib`, gives its peak phase against its label. With it, how far the
/// fitted model may read a press off where the kit never pressed ([`place_spread`], from
/// how its presses of one depth read apart over the depths where the tolerance's share
/// outweighs its floor), and its held-out error by depth ([`error_by_depth`]).
fn depth_model<O: Observer>(
    run: &mut Run<'_, O>,
    calib: &Calibration,
) -> Result<DepthFit, CalibrateError> {
    let depth_frames = run.analyze(calib, Label::Depth, DEPTH_STAGE, &|_| true)?;
    let samples: Vec<Sample> = depth_frames
        .iter()
        .filter(|(_, d)| d.contact)
        .map(|(y, d)| Sample {
            u: f64::from(d.peak_depth_mm),
            y: *y,
            group: setpoint(*y),
        })
        .collect();
    let (model, chosen, candidates) = fit_depth(&samples, |_, _| {})
        .ok_or_else(|| CalibrateError::NotEnough(run.too_few_depths(&samples)))?;
    let share_outweighs_floor_mm = f64::from(DEPTH_TOLERANCE_UM / DEPTH_TOLERANCE_SHARE) / 1000.0;
    let spread = place_spread(&samples, |u| model.depth_mm(u), share_outweighs_floor_mm);
    let error = held_out_depths(&samples, &chosen.name).and_then(|p| error_by_depth(&p));
    let fitted = Fitted {
        equation: model.equation(),
        model,
        cv_rmse: chosen.cv_rmse,
        in_sample_rmse: chosen.in_sample_rmse,
        n: samples.len(),
        candidates,
        range: FitRange::of(samples.iter().map(|s| (s.u, s.y))),
    };
    Ok(DepthFit {
        fitted,
        place_spread: spread,
        error,
    })
}

/// The depth model and what the kit says of its errors ([`depth_model`]).
struct DepthFit {
    fitted: Fitted<DepthModel>,
    place_spread: Option<f64>,
    error: Option<DepthError>,
}

/// The calibrated indenter's contact area and reciprocal load against its measured depth,
/// each averaged per setpoint and made monotone; `None` with fewer than three setpoints
/// (the load's alone left out with fewer than three).
fn shape_signature<O: Observer>(
    run: &mut Run<'_, O>,
    calib: &Calibration,
) -> Result<Option<ShapeSignature>, CalibrateError> {
    let shaped = run.analyze(calib, Label::Shape, "indenter shape", &|_| true)?;
    let knots = |of: &dyn Fn(&Measurement) -> f32| {
        let samples: Vec<Sample> = shaped
            .iter()
            .filter(|(_, d)| d.contact)
            .map(|(y, d)| Sample {
                u: f64::from(d.peak_depth_mm),
                y: f64::from(of(d)),
                group: setpoint(*y),
            })
            .collect();
        crate::fit::monotone_knots(&samples)
    };
    let (depth_mm, area_mm2) = knots(&|d| d.contact_area_mm2);
    let (load_depth_mm, load_mm2) = knots(&|d| d.reciprocal_load_mm2);
    let load = (load_depth_mm.len() >= 3).then_some(LoadSignature {
        depth_mm: load_depth_mm,
        load_mm2,
    });
    Ok((depth_mm.len() >= 3).then_some(ShapeSignature {
        depth_mm,
        area_mm2,
        load,
    }))
}

/// Deformation → force: frames labelled `force_n > 0`, analysed with the fitted depth
/// model; every feature a candidate input. `None` (with a note) with too few levels.
fn force_model<O: Observer>(
    run: &mut Run<'_, O>,
    calib: &Calibration,
) -> Result<Option<Fitted<ForceModel>>, CalibrateError> {
    let force_frames = run.analyze(calib, Label::Force, "deformation → force", &|_| true)?;
    let feats: Vec<(ForceFeature, Vec<Sample>)> = ForceFeature::ALL
        .iter()
        .map(|&f| {
            let s = force_frames
                .iter()
                .map(|(y, d)| Sample {
                    u: f64::from(f.of(&d.force_inputs())),
                    y: *y,
                    group: setpoint(*y),
                })
                .collect();
            (f, s)
        })
        .collect();
    let force = fit_force(&feats, |_, _| {}).map(|(m, chosen, candidates)| {
        let used = feats.iter().find(|(f, _)| *f == m.feature).map(|(_, s)| s);
        Fitted {
            equation: m.equation(),
            range: used.and_then(|s| FitRange::of(s.iter().map(|s| (s.u, s.y)))),
            model: m,
            cv_rmse: chosen.cv_rmse,
            in_sample_rmse: chosen.in_sample_rmse,
            n: force_frames.len(),
            candidates,
        }
    });
    if force.is_none() {
        run.obs.note(
            "too few trusted force levels (need three): no force model, force reads 0".into(),
        );
    }
    Ok(force)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `depth_uncertain` speaks of the depth model being fitted, not of a kit frame: no
    /// stage leaves a frame out for it, while every other flag keeps its say.
    #[test]
    fn no_stage_leaves_a_frame_out_for_the_depth_models_own_miss() {
        for label in [Label::Depth, Label::Shape, Label::Force] {
            assert!(label.tolerates(Flag::DepthUncertain));
            assert!(!label.tolerates(Flag::PhaseSlope));
        }
        assert!(!Label::Depth.tolerates(Flag::DepthUnresolved));
    }

    /// A frame left out of two stages for different reasons is named once, with both
    /// stages and every reason once; frames are named in the order first met.
    #[test]
    fn a_frame_left_out_of_several_stages_is_named_once_with_every_reason() {
        let mut notes = Notes::default();
        let mut run = Run::new(&[], Implementation::Fixed, &mut notes, 1);
        let why = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        run.left_out(
            "depth: f7.png".into(),
            "phase → depth",
            why(&["phase_slope"]),
        );
        run.left_out(
            "depth: f2.png".into(),
            "phase → depth",
            why(&["low_contrast"]),
        );
        let both = why(&["phase_slope", "depth_out_of_range"]);
        run.left_out("depth: f7.png".into(), "indenter shape", both);
        run.report_left_out();
        run.report_left_out();
        assert_eq!(
            notes.0,
            [
                "depth: f7.png left out of phase → depth, indenter shape \
                 (phase_slope, depth_out_of_range)",
                "depth: f2.png left out of phase → depth (low_contrast)",
            ]
        );
    }

    /// A refusal for too few depths names the depths trusted and the flag most frames left
    /// out of phase → depth carried, with what a phase slope asks of the kit; frames left
    /// out of other stages only are not counted.
    #[test]
    fn too_few_depths_names_the_depths_trusted_and_the_commonest_flag() {
        let mut notes = Notes::default();
        let mut run = Run::new(&[], Implementation::Fixed, &mut notes, 1);
        let why = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        for (k, reasons) in [
            &["phase_slope"][..],
            &["phase_slope", "unwrap_failure"],
            &["low_contrast"],
            &["phase_slope"],
        ]
        .into_iter()
        .enumerate()
        {
            run.left_out(format!("depth: f{k}.png"), DEPTH_STAGE, why(reasons));
        }
        run.left_out("depth: f9.png".into(), "phase sign", why(&["low_contrast"]));
        let at = |y: f64| Sample {
            u: y,
            y,
            group: setpoint(y),
        };
        let said = run.too_few_depths(&[at(0.1), at(0.2), at(0.1)]);
        assert!(said.contains("trusted only at 0.1, 0.2 mm"), "{said}");
        assert!(
            said.contains("3 of the 4 frames left out carry phase_slope"),
            "{said}"
        );
        assert!(said.contains("coarser grating"), "{said}");
        let none = Run::new(&[], Implementation::Fixed, &mut notes, 1).too_few_depths(&[]);
        assert!(
            none.ends_with("depths, no press read and trusted"),
            "{none}"
        );
    }

    /// A flag on more than half the last stage's frames is the unit's: taken once, said
    /// once, and the frames it left out forgotten; on half of them, a frame's.
    #[test]
    fn a_flag_on_most_of_the_kit_is_taken_and_said_once() {
        let mut notes = Notes::default();
        let mut run = Run::new(&[], Implementation::Fixed, &mut notes, 1);
        let faint = QualityFlags::NONE.with(Flag::LowContrast);
        for flags in [faint, faint, QualityFlags::NONE, QualityFlags::NONE] {
            run.count(flags);
        }
        assert!(!run.take_kit_wide());
        for flags in [faint, faint, QualityFlags::NONE] {
            run.count(flags);
        }
        run.left_out("depth: f2.png".into(), "phase sign", vec![]);
        assert!(run.take_kit_wide());
        assert!(run.kit_wide.contains(Flag::LowContrast) && run.left.is_empty());
        for _ in 0..3 {
            run.count(faint);
        }
        assert!(!run.take_kit_wide());
        assert_eq!(notes.0.len(), 1);
        assert!(notes.0[0].starts_with("2 of 3 depth frames carry low_contrast"));
    }

    /// The mean's table keeps the longest stretch of setpoints over which the kit's mean
    /// rises, and none where it never does.
    #[test]
    fn the_means_table_keeps_the_longest_rising_stretch() {
        let pts = |v: &[(f64, f64)]| -> Vec<MeanRead> {
            v.iter()
                .map(|&(setpoint_c, read_c)| MeanRead { setpoint_c, read_c })
                .collect()
        };
        let setpoints = |m: &[MeanRead]| -> Vec<f64> { m.iter().map(|p| p.setpoint_c).collect() };
        // A cold end where the mean stands still (its model flagged there), then a rise.
        let p = pts(&[
            (15.0, 18.8),
            (17.5, 22.5),
            (20.0, 22.6),
            (22.0, 22.8),
            (25.0, 25.0),
            (30.0, 30.0),
            (35.0, 33.7),
        ]);
        assert_eq!(setpoints(longest_rising(&p)), [22.0, 25.0, 30.0, 35.0]);
        assert_eq!(longest_rising(&p[..3]).len(), 2);
        assert!(longest_rising(&pts(&[(20.0, 21.0), (22.0, 20.0)])).len() < 2);
        assert!(longest_rising(&[]).is_empty());
    }

    /// The table keeps, per setpoint, the largest move over the references tried, held
    /// within the file's limit; a setpoint another reference did not read, or read no
    /// finite mean at, adds nothing from it.
    #[test]
    fn the_reference_shift_keeps_the_largest_move_per_setpoint() {
        let reads = |v: &[(f64, f64)]| -> Vec<KitRead> {
            v.iter()
                .map(|&(setpoint_c, mean_c)| KitRead {
                    setpoint_c,
                    mean_c,
                    departure_sigmas: 0.0,
                })
                .collect()
        };
        let own = reads(&[(20.0, 20.1), (25.0, 25.0), (30.0, 29.8)]);
        let others = [
            reads(&[(20.0, 20.4), (30.0, f64::NAN)]),
            reads(&[(20.0, 19.9), (25.0, 24.4), (30.0, 1e9)]),
        ];
        let shift: Vec<f64> = widest_shift(&own, &others)
            .iter()
            .map(|p| p.shift_c)
            .collect();
        assert!((shift[0] - 0.3).abs() < 1e-9, "{shift:?}");
        assert!((shift[1] - 0.6).abs() < 1e-9, "{shift:?}");
        assert_eq!(shift[2], REFERENCE_SHIFT_LIMIT_C);
        let alone = widest_shift(&own[..2], &others[..1]);
        assert_eq!(alone.len(), 2);
        assert_eq!(
            alone[1].shift_c, 0.0,
            "a setpoint no other reference read moved nowhere"
        );
    }

    #[test]
    fn setpoints_beyond_the_fitted_span_are_named_once_each() {
        let labelled = [15.0, 15.0, 20.0, 28.0, 30.0, 30.0, 47.5, 12.5];
        let fitted = [15.0, 20.0, 28.0, 17.5];
        let (span, beyond) = beyond_fitted(&labelled, &fitted).unwrap();
        assert_eq!(span, [15.0, 28.0]);
        assert_eq!(beyond, [12.5, 30.0, 47.5]);
        assert_eq!(beyond_fitted(&[15.0, 20.0], &fitted), None);
        assert_eq!(beyond_fitted(&labelled, &[]), None);
    }

    /// Blind above the warmest fitted setpoint only when the camera clipped every warmer
    /// setpoint the fit lacks; a colder one missing says nothing about it.
    #[test]
    fn the_camera_is_blind_above_the_fit_only_where_it_clipped_every_warmer_setpoint() {
        let beyond = [12.5, 32.0, 35.0];
        assert_eq!(blind_above(31.0, &beyond, &[35.0, 32.0, 32.0]), Some(31.0));
        assert_eq!(blind_above(31.0, &beyond, &[35.0]), None);
        assert_eq!(blind_above(31.0, &[12.5], &[12.5]), None);
        assert_eq!(blind_above(31.0, &beyond, &[]), None);
    }
}
