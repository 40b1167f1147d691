//! Temperature from the same frame: per-block thermochromic thermometry, fused across the
//! coloured and the black stripes.
//!
//! ```text
//!  reference ─▶ grating phase per working pixel (once)
//!  frame + FTP's Δφ ─▶ frame's grating phase ─▶ stripe centres, per input pixel
//!        ─▶ linear colour sums per block (one stripe pair) and over the contact
//!        ─▶ contact: both populations read at one point, the light's slope taken out
//!        ─▶ black stripes flat-fielded by the reference's pattern of their ratio
//!        ─▶ invariants (chromaticity, black/coloured ratio)
//!        ─▶ float: CIELAB + both polynomials + inverse-variance fusion
//!           device: integer invariants + 3-D look-up table of the same
//!        ─▶ map, min / mean / max, hottest block, contact temperature, range flag
//! ```
//!
//! [`lab`] holds the colour science, [`stripes`] the segmentation, [`model`] the
//! calibration's models and their fusion, [`evaluate`] the map over blocks in either
//! arithmetic ([`Evaluator`]), and [`fixed`] the device path's integer evaluation of the
//! models. [`static_light`] finds the blocks glare misreads, from the reference,
//! [`ratio_field`] takes the reference's block-to-block pattern out of the stripes' ratio,
//! [`trend`] the light's slope across the contact out of its two populations' means,
//! and [`extremes`] reads the map's coldest and hottest places. Fitting the models is the
//! calibration's job (`vistaf-calibrate`).

pub mod evaluate;
pub mod extremes;
pub mod fixed;
pub mod lab;
pub mod model;
pub mod ratio_field;
pub mod static_light;
pub mod stripes;
pub mod trend;

use crate::input::Pixels;

pub use self::evaluate::{BlockMap, Evaluator, FloatModel, Temperatures};
use self::fixed::FixedModel;
use self::model::TemperatureModel;
use self::ratio_field::RatioField;
use self::stripes::{Geometry, Regions, Sums};

/// A frame's temperatures.
#[derive(Debug, Clone, PartialEq)]
pub struct Temperature {
    /// Blocks across and down.
    pub bw: usize,
    /// See `bw`.
    pub bh: usize,
    /// Side of a block on the skin, mm.
    pub block_mm: f32,
    /// Temperature per block, °C (NaN where a block could not be measured).
    pub map_c: Vec<f32>,
    /// Each block's variance, °C², from the calibration's tables (NaN where unmeasured):
    /// what the extremes were judged by ([`extremes::departures_sigmas`]).
    pub var_c2: Vec<f32>,
    /// Coldest place, mean and hottest place, °C (NaN when no block was measured); the
    /// extremes are read over each block's neighbourhood, and are the skin's median where
    /// no place stands out of the noise ([`extremes`]). The mean, and the skin's median
    /// where it stands for an extreme, are read through the calibration's table of the
    /// skin's mean ([`TemperatureModel::skin_mean_c`]); a place that stands out, and the
    /// map's blocks, are as read.
    pub min_c: f32,
    /// See `min_c`.
    pub mean_c: f32,
    /// See `min_c`.
    pub max_c: f32,
    /// Centre of the hottest place, input pixels (`None` where no place stands out).
    pub hottest_px: Option<(f32, f32)>,
    /// The hottest place is the contact's own reading (warmer than every neighbourhood, or
    /// standing for the hottest neighbourhood, centred on the contact):
    /// whatever doubts the contact's temperature doubts `max_c`.
    pub max_at_contact: bool,
    /// Temperature over the contact region, °C, when there is contact.
    pub contact_c: Option<f32>,
    /// Its standard deviation, °C: the calibration's variance tables, widened by how
    /// far the reading moves with the contact's stripe ratio and with its chromaticity
    /// ([`Temperatures::read_contact`]).
    pub contact_sigma_c: Option<f32>,
    /// A block read outside the calibrated range (or outside the calibrated colours), or a
    /// coldest or hottest place read beyond it.
    pub out_of_range: bool,
    /// The calibration's own held-out test missed by more than [`HELD_OUT_MISS_LIMIT_C`]
    /// near a reading this frame reports (the skin's mean, coldest and hottest places,
    /// the contact), or its kit's reading moved by as much there with another reference:
    /// the reading may be off by as much ([`TemperatureModel::held_out_error_c`],
    /// [`TemperatureModel::held_out_miss_read_near_c`],
    /// [`TemperatureModel::reference_shift_c`]).
    pub calibration_misses: bool,
    /// The mean lies further than [`MEAN_APART_LIMIT_C`] outside the span from the
    /// coldest place to the hottest ([`mean_apart`]).
    pub mean_apart: bool,
    /// Blocks measured.
    pub measured: usize,
}

impl Temperature {
    /// Whether the contact's standard deviation exceeds [`CONTACT_SIGMA_LIMIT_C`].
    pub fn contact_uncertain(&self) -> bool {
        self.contact_sigma_c
            .is_some_and(|s| s > CONTACT_SIGMA_LIMIT_C)
    }

    /// Whether a reported temperature is not held to its tolerance: the contact's
    /// deviation, or the calibration's held-out miss near a reading, exceeds it, or the
    /// mean lies apart from the places.
    pub fn uncertain(&self) -> bool {
        self.contact_uncertain() || self.calibration_misses || self.mean_apart
    }
}

/// The black stripes are read over a block and its neighbours within this many blocks (a
/// 3 × 3 window, about 6 mm): they are dark, so one block's worth is noisy, and their model
/// is the wide, coarse one. The coloured stripes are read per block.
pub const BLACK_POOL: usize = 1;

/// Blocks that must read outside the calibration (at least; or 1 % of the measured ones)
/// for the frame to be flagged: a single block out of range is noise, a hot or cold object
/// covers several. The contact region's own reading is flagged on its own.
pub const OUT_OF_RANGE_BLOCKS: usize = 2;

/// Largest standard deviation of a contact temperature reported without
/// `Flag::TemperatureUncertain`, °C: the one-degree tolerance a reading is held to.
pub const CONTACT_SIGMA_LIMIT_C: f32 = 1.0;

/// Largest miss of the calibration's held-out test near a reported temperature without
/// `Flag::TemperatureUncertain`, °C: half the tolerance, so that the tolerance is at least
/// twice the miss (one draw of the error there), as a depth is held
/// (`measure::DEPTH_CONFIDENCE_SIGMAS`).
pub const HELD_OUT_MISS_LIMIT_C: f32 = CONTACT_SIGMA_LIMIT_C / 2.0;

/// A setpoint the calibration's held-out test read further off than this, °C (the
/// tolerance), is one the models could not tell from where it read: a reading within
/// [`HELD_OUT_MISS_LIMIT_C`] of there carries `Flag::TemperatureUncertain`
/// ([`TemperatureModel::held_out_miss_read_near_c`]). A miss within the tolerance is judged
/// at its setpoint alone.
pub const HELD_OUT_FAILED_C: f32 = CONTACT_SIGMA_LIMIT_C;

/// Furthest the mean may lie outside the span from the coldest place to the hottest
/// without `Flag::TemperatureUncertain`, °C: the held-out miss's limit, for its reason
/// (the tolerance at least twice the disagreement).
pub const MEAN_APART_LIMIT_C: f32 = HELD_OUT_MISS_LIMIT_C;

/// Fewest samples of each population in the contact core before the whole contact region
/// is used instead.
const CORE_SAMPLES: u32 = 24;

/// One reading: temperature (°C), variance (°C²), and whether it is trusted (inside the
/// calibrated colours and range).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reading {
    /// Fused temperature, °C.
    pub t_c: f32,
    /// Its variance, °C².
    pub var_c2: f32,
    /// Inside what was calibrated.
    pub trusted: bool,
}

/// Reference-side state: stripe geometry, the reference's grating phase, the model and
/// the arithmetic it is evaluated in.
#[derive(Debug)]
pub struct Thermometer {
    geom: Geometry,
    theta_ref: Vec<u16>,
    lin: [u32; 256],
    model: Option<TemperatureModel>,
    evaluator: Option<Box<dyn Temperatures>>,
    mm_per_px: f32,
    /// Blocks the reference shows misread by static light ([`static_light`]).
    misread: Vec<bool>,
    /// The reference's pattern in the stripes' ratio ([`ratio_field`]).
    ratio: RatioField,
}

impl Thermometer {
    /// Prepares for frames of a reference whose grating phase per working pixel is
    /// `theta_ref` (units of 2π/65 536), on the device path (`fixed`: integer evaluation)
    /// or the float reference. Without a model it only sums colours (for calibration).
    pub fn new(
        geom: Geometry,
        theta_ref: Vec<u16>,
        model: Option<TemperatureModel>,
        fixed: bool,
        mm_per_px: f32,
    ) -> Thermometer {
        let evaluator = model.as_ref().map(|m| -> Box<dyn Temperatures> {
            if fixed {
                Box::new(FixedModel::new(m))
            } else {
                Box::new(FloatModel(m.clone()))
            }
        });
        Thermometer {
            geom,
            theta_ref,
            lin: stripes::linear_q16(),
            model,
            evaluator,
            mm_per_px,
            misread: Vec::new(),
            ratio: RatioField::default(),
        }
    }

    /// A reading over many blocks of the skin (`read_c`, °C) as the skin temperature it
    /// stands for, through the calibration's table of the skin's mean
    /// ([`TemperatureModel::skin_mean_c`]); as read without a model.
    fn as_skin(&self, read_c: f64) -> f32 {
        self.model
            .as_ref()
            .map_or(read_c, |m| m.skin_mean_c(read_c)) as f32
    }

    /// By how many standard deviations a place must depart from a skin whose map's median
    /// reads `skin_c` to stand out: the calibration's threshold at the skin temperature
    /// that median stands for ([`TemperatureModel::stand_out_sigmas`]).
    fn stand_out_sigmas(&self, skin_c: f32) -> f32 {
        let skin = f64::from(self.as_skin(f64::from(skin_c)));
        self.model
            .as_ref()
            .map_or(extremes::STAND_OUT_SIGMAS, |m| m.stand_out_sigmas(skin))
    }

    /// Learns what the reference shows of the light and the skin from its colour sums per
    /// block (`reference`: a skin at rest, one temperature throughout, summed before any
    /// of this was learnt): where static light misreads the skin, and the pattern of the
    /// stripes' ratio ([`ratio_field`]), taken out of every later frame.
    pub fn learn_reference(&mut self, reference: &[Sums]) {
        self.misread = self.static_light(reference);
        self.ratio = RatioField::learn(reference, &self.misread);
    }

    /// The blocks static light (glare) misreads in `reference` ([`static_light`]): they go
    /// unmeasured from then on. Without a model none (the reading is what shows them).
    fn static_light(&self, reference: &[Sums]) -> Vec<bool> {
        let Some(evaluator) = self.evaluator.as_ref() else {
            return Vec::new();
        };
        let g = &self.geom;
        let map = evaluator.map(reference, g.bw, g.bh);
        let view: Vec<static_light::BlockView> = reference
            .iter()
            .zip(&map.map_c)
            .map(|(s, &t_c)| {
                let (c, k) = s.means();
                let lum = |m: [f64; 3]| (m.iter().sum::<f64>() / 3.0) as f32;
                static_light::BlockView {
                    t_c,
                    brightness: [lum(c), lum(k)],
                    readable: s.enough(),
                }
            })
            .collect();
        static_light::misread(&view, g.bw, g.bh)
    }

    /// Whether temperatures can be measured (the calibration has a model).
    pub fn has_model(&self) -> bool {
        self.model.is_some()
    }

    /// Block geometry.
    pub fn geometry(&self) -> &Geometry {
        &self.geom
    }

    /// Colour sums of a frame whose grating phase along working row `y` is what
    /// `phase(y, reference, row)` writes into `row` (units) from the reference's along that
    /// row (`reference`), over the working pixels the FTP found `reliable`; `regions` marks
    /// the contact region and its core. Blocks that saw only a sliver of a stripe pair
    /// (`drop_partial`), blocks the camera clipped (`drop_clipped`) and blocks static light
    /// misreads ([`static_light`]) come back empty; the others' black stripes are
    /// flat-fielded ([`ratio_field`]). The contact region's and its core's sums are read at
    /// the midpoint of their two populations' centroids ([`trend`]).
    pub fn sums(
        &self,
        frame: Pixels<'_>,
        phase: impl Fn(usize, &[u16], &mut [u16]),
        reliable: &[bool],
        regions: Option<Regions<'_>>,
    ) -> (Vec<Sums>, [Sums; 2]) {
        let w = self.geom.w;
        let (mut blocks, contact) = stripes::accumulate(
            frame,
            &self.geom,
            |y, row: &mut [u16]| {
                let reference = self.theta_ref.get(y * w..(y + 1) * w).unwrap_or(&[]);
                phase(y, reference, row);
            },
            reliable,
            regions,
            &self.lin,
        );
        // The light's slope across the contact is taken out before the reference's pattern:
        // the pattern is the skin's, the slope the indentation's.
        let mut contact = contact.levelled();
        drop_partial(&mut blocks);
        drop_clipped(&mut blocks);
        self.ratio.apply(&mut blocks);
        if let Some(r) = &regions {
            self.ratio.apply_regions(r, &self.geom, &mut contact);
        }
        for (s, _) in blocks.iter_mut().zip(&self.misread).filter(|(_, &m)| m) {
            *s = Sums::default();
        }
        (blocks, contact)
    }

    /// The reading of a block from its own sums (coloured stripes) and its neighbourhood's
    /// (black stripes), in the path's arithmetic.
    pub fn read(&self, own: &Sums, pooled: &Sums) -> Option<Reading> {
        self.evaluator.as_ref()?.read(own, pooled)
    }

    /// [`Thermometer::read`] through the float models even on the device path: the oracle
    /// the integer arithmetic is tested against.
    pub fn read_exact(&self, own: &Sums, pooled: &Sums) -> Option<Reading> {
        FloatModel(self.model.clone()?).read(own, pooled)
    }

    /// Measures a frame from its colour sums, `blocks` and `contact_sums` as
    /// [`Thermometer::sums`] gives them over the contact `regions`; `None` without a model.
    /// The contact's core gives the contact temperature when it holds enough stripe samples
    /// (the region's edge is where heat spreads into the cooler skin around).
    pub fn measure(
        &self,
        blocks: &[Sums],
        contact_sums: [Sums; 2],
        regions: Option<Regions<'_>>,
    ) -> Option<Temperature> {
        let evaluator = self.evaluator.as_ref()?;
        let g = &self.geom;
        let map = evaluator.map(blocks, g.bw, g.bh);
        let region = reading_region(contact_sums);
        let n = map.measured;
        let mut out_of_range = map.outside >= OUT_OF_RANGE_BLOCKS.max(n / 100);
        // A clipped contact is read but not trusted: a hot object on a camera near full
        // scale clears the pigment to white and the top of its stripes is cut.
        let contact = regions
            .and_then(|_| evaluator.read_contact(&region))
            .map(|r| Reading {
                trusted: r.trusted && !region.is_clipped(),
                ..r
            });
        out_of_range |= contact.is_some_and(|r| !r.trusted);
        let ext = extremes::extremes(&map.map_c, &map.var_c2, (g.bw, g.bh), |skin_c| {
            self.stand_out_sigmas(skin_c)
        });
        let nan = |v: f32| if v.is_finite() { v } else { f32::NAN };
        let (mut max_c, mut hottest_px) =
            (nan(ext.max_c), ext.hottest.map(|b| g.block_center_px(b)));
        // A contact is a region read as one, over far more samples than a neighbourhood:
        // warmer than every neighbourhood, it is the hottest place (a warm object smaller
        // than a neighbourhood is seen there and nowhere else). Where no neighbourhood
        // stood out, `max_c` is the skin's median, and the contact must stand out of its
        // own noise as a neighbourhood would.
        let above_skin = |r: &Reading| {
            ext.hottest.is_some()
                || extremes::stands_out(
                    r.t_c - max_c,
                    r.var_c2.max(0.0).sqrt(),
                    ext.stand_out_sigmas,
                )
        };
        // The hottest neighbourhood centred on the contact reads blocks of skin the press
        // tilts, which the contact's own reading takes out (both populations read at one
        // point): the contact's reading stands for it, warmer or not.
        let f = g.factor as f32;
        let hottest_on_contact = hottest_px.is_some_and(|(x, y)| {
            let at = ((x / f) as usize, (y / f) as usize);
            regions.as_ref().is_some_and(|r| r.contains(at))
        });
        let hottest_contact = contact.filter(|r| {
            r.trusted && (max_c.is_nan() || hottest_on_contact || (r.t_c > max_c && above_skin(r)))
        });
        // The region's centre is found only for such a contact.
        let at = hottest_contact.and_then(|r| Some((r.t_c, regions.as_ref()?.centre()?)));
        if let Some((t_c, (x, y))) = at {
            (max_c, hottest_px) = (t_c, Some((x * f, y * f)));
        }
        // Where no place stands out, an extreme is the skin's median (exactly; one that
        // stands out departs from it): an aggregate of the whole map, read through the
        // table of the skin's mean as the mean is.
        let skin_c = self.as_skin(f64::from(ext.skin_c));
        let or_skin = |extreme_c: f32| {
            if extreme_c == ext.skin_c {
                skin_c
            } else {
                extreme_c
            }
        };
        let (max_c, min_c) = (or_skin(max_c), or_skin(ext.min_c));
        // A place read beyond the calibrated range is no temperature the kit showed (a
        // neighbourhood of blocks misread together, beside a deep press say), however few
        // blocks it holds.
        out_of_range |= self.model.as_ref().is_some_and(|m| {
            [min_c, max_c]
                .iter()
                .any(|&t| t.is_finite() && m.out_of_range(f64::from(t), 0.0))
        });
        let mean_c = if n == 0 {
            f32::NAN
        } else {
            self.as_skin(map.sum_c / n as f64)
        };
        let reported = [mean_c, min_c, max_c, contact.map_or(f32::NAN, |r| r.t_c)];
        // As reported: a coldest place no neighbourhood confirmed is none (NaN), not +∞.
        let mean_apart = mean_apart(mean_c, nan(min_c), max_c);
        let calibration_misses = self
            .model
            .as_ref()
            .is_some_and(|m| misses_near(m, &reported));
        Some(Temperature {
            bw: g.bw,
            bh: g.bh,
            block_mm: (g.block_px * g.factor) as f32 * self.mm_per_px,
            min_c: nan(min_c),
            mean_c,
            max_c,
            hottest_px,
            max_at_contact: at.is_some(),
            map_c: map.map_c,
            var_c2: map.var_c2,
            contact_c: contact.map(|r| r.t_c),
            contact_sigma_c: contact.map(|r| r.var_c2.max(0.0).sqrt()),
            out_of_range,
            calibration_misses,
            mean_apart,
            measured: n,
        })
    }
}

/// Whether the calibration's held-out test missed by more than [`HELD_OUT_MISS_LIMIT_C`]
/// near any of the finite `readings` (°C), or its kit's mean moved by as much there when
/// another uniform frame served as the reference ([`TemperatureModel::reference_shift_c`]),
/// or the test read a setpoint within that limit of the reading more than
/// [`HELD_OUT_FAILED_C`] off. The readings the table of the skin's mean moved are judged
/// here too: the blocks' test says where the models could not follow the colours, which no
/// table of the kit's means mends between its setpoints.
fn misses_near(model: &TemperatureModel, readings: &[f32]) -> bool {
    let limit_c = f64::from(HELD_OUT_MISS_LIMIT_C);
    readings.iter().filter(|t| t.is_finite()).any(|&t| {
        let t = f64::from(t);
        let miss = model.held_out_error_c(t).max(model.reference_shift_c(t));
        miss > limit_c || model.held_out_miss_read_near_c(t, limit_c) > f64::from(HELD_OUT_FAILED_C)
    })
}

/// Whether the map's mean (°C) lies further than [`MEAN_APART_LIMIT_C`] outside the span
/// from its coldest place to its hottest. Each place is read over a neighbourhood's
/// majority, and one that does not stand out of the noise is the skin's median
/// ([`extremes`]); the mean takes every block as read. A mean colder than the coldest place
/// (or warmer than the hottest) averages readings no neighbourhood confirmed, scattered or
/// in thin bands: either they are misread and carry the mean away from the skin, or they
/// are real and the places missed them. Not a number anywhere: no verdict.
pub fn mean_apart(mean_c: f32, min_c: f32, max_c: f32) -> bool {
    mean_c < min_c - MEAN_APART_LIMIT_C || mean_c > max_c + MEAN_APART_LIMIT_C
}

/// The sums a contact's temperature is read from, of the contact region's and its core's
/// (as [`Thermometer::sums`] gives them): the core's where it holds `CORE_SAMPLES` of
/// each population (the region's edge is where heat spreads into the cooler skin around).
pub fn reading_region([inside, core]: [Sums; 2]) -> Sums {
    if core.n[0] >= CORE_SAMPLES && core.n[1] >= CORE_SAMPLES {
        core
    } else {
        inside
    }
}

/// The chromaticity (`r`, `g`) of a contact's `region` over that of every block's stripes
/// summed, less one; `None` where either has no colour to read. On a skin at one
/// temperature it is what the press alone does to the colour; the calibration takes its
/// scatter over the kit's presses ([`TemperatureModel::contact_chroma_spread`]).
pub fn chroma_vs_skin(region: &Sums, blocks: &[Sums]) -> Option<[f32; 2]> {
    let mut skin = Sums::default();
    for b in blocks {
        skin.add(b);
    }
    let (own, all) = (
        fixed::invariants_q16(region, region)?,
        fixed::invariants_q16(&skin, &skin)?,
    );
    let rel = |k: usize| (own[k] as f64 / all[k].max(1) as f64 - 1.0) as f32;
    Some([rel(0), rel(1)])
}

/// Empties the blocks the camera clipped ([`Sums::is_clipped`]): what is left of their
/// stripes is the darker part of each, and reads as another temperature.
fn drop_clipped(blocks: &mut [Sums]) {
    for s in blocks.iter_mut().filter(|s| s.is_clipped()) {
        *s = Sums::default();
    }
}

/// Empties the blocks that saw less than half the stripe samples of a typical block (of
/// either population): at the edge of what the FTP trusts, a block holds a sliver of a
/// stripe pair whose colour is the edge's, not the skin's.
fn drop_partial(blocks: &mut [Sums]) {
    let seen = |s: &Sums| s.n[0].min(s.n[1]);
    let mut counts: Vec<u32> = blocks.iter().map(seen).filter(|&n| n > 0).collect();
    if counts.is_empty() {
        return;
    }
    let mid = counts.len() / 2;
    let (_, &mut typical, _) = counts.select_nth_unstable(mid);
    for s in blocks.iter_mut().filter(|s| 2 * seen(s) < typical) {
        *s = Sums::default();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The reference unit's temperature model with its held-out test replaced: each pair a
    /// setpoint and how far the test read it off, °C.
    fn held_out_as(misses: &[(f64, f64)]) -> TemperatureModel {
        let mut m = crate::calibration::Calibration::default_sim()
            .temperature
            .unwrap_or_else(|| unreachable!("the default calibration has a temperature model"));
        m.held_out = (misses.iter())
            .map(|&(setpoint_c, e)| model::SetpointError {
                setpoint_c,
                estimate_c: setpoint_c + e,
            })
            .collect();
        m
    }

    /// A reading where the calibration's held-out test missed by more than half the
    /// tolerance is doubted, one where it missed by less is not; readings that are not a
    /// number are not judged.
    #[test]
    fn a_reading_where_the_held_out_test_missed_by_half_the_tolerance_is_doubted() {
        let m = held_out_as(&[(22.0, 0.7), (24.0, 0.1), (26.0, -0.4)]);
        assert!(misses_near(&m, &[22.0]));
        assert!(misses_near(&m, &[f32::NAN, 25.0, 22.5]));
        assert!(!misses_near(&m, &[23.5, 25.0, 26.0, 30.0]));
        assert!(!misses_near(&m, &[f32::NAN]));
    }

    /// A skin whose held-out reading the models carried 2.2 °C away, from 29 °C to 31.2 °C,
    /// doubts a reading of 31.6 °C, within half the tolerance of where it read, though the
    /// setpoints either side of 31.6 °C were read within 0.2 °C; a reading of 31.8 °C, further
    /// from it, is not doubted. A setpoint read within the tolerance (36 °C read 0.8 °C
    /// cold) doubts readings near its own temperature alone, not 35.2 °C where it read.
    #[test]
    fn a_reading_near_where_a_failed_setpoint_read_is_doubted() {
        let mut m = held_out_as(&[
            (28.0, 0.1),
            (29.0, 2.2),
            (30.0, 0.2),
            (32.0, 0.0),
            (34.0, 0.0),
            (36.0, -0.8),
        ]);
        m.reference_shift.clear();
        assert!(misses_near(&m, &[31.6]));
        assert!(!misses_near(&m, &[31.8]));
        assert!(!misses_near(&m, &[35.2]));
        assert!(misses_near(&m, &[35.8]));
    }

    /// A reading near setpoints where the kit's mean moved by more than half the tolerance
    /// with another reference is doubted, one where it moved less is not, whatever the
    /// held-out test says.
    #[test]
    fn a_reading_that_follows_the_reference_by_half_the_tolerance_is_doubted() {
        let mut m = held_out_as(&[]);
        let at = |setpoint_c: f64, shift_c: f64| model::ReferenceShift {
            setpoint_c,
            shift_c,
        };
        m.reference_shift = vec![at(30.0, 0.1), at(40.0, 0.3), at(45.0, 0.9)];
        assert!(!misses_near(&m, &[20.0, 30.0, 40.0]));
        assert!(misses_near(&m, &[42.0]));
        assert!(misses_near(&m, &[f32::NAN, 50.0]));
        assert!(!misses_near(&m, &[41.0]));
        assert!(model::reference_shift_ordered(&m.reference_shift));
        m.reference_shift.swap(0, 1);
        assert!(!model::reference_shift_ordered(&m.reference_shift));
        m.reference_shift = vec![at(30.0, -0.1)];
        assert!(!model::reference_shift_ordered(&m.reference_shift));
    }

    /// A mean within half the tolerance of the span between the coldest and hottest
    /// places passes; one further out on either side does not; a map without a reading
    /// anywhere gives no verdict.
    #[test]
    fn a_mean_outside_the_span_of_its_places_is_doubted() {
        assert!(!mean_apart(25.0, 25.0, 25.0));
        assert!(!mean_apart(26.0, 24.0, 30.0));
        assert!(!mean_apart(24.6, 25.0, 25.0));
        assert!(!mean_apart(25.4, 25.0, 25.0));
        assert!(mean_apart(23.2, 24.9, 24.9));
        assert!(mean_apart(25.6, 24.0, 25.0));
        assert!(!mean_apart(f32::NAN, 25.0, 25.0));
        assert!(!mean_apart(25.0, f32::NAN, f32::NAN));
    }

    /// Estimates order by their integer keys as by their temperatures, on either path
    /// (negative, zero and positive, near and far apart).
    #[test]
    fn keys_order_estimates_as_their_temperatures() {
        let mut rng = crate::test_rng::XorShift(0x2545_f491_4f6c_dd1d);
        let mut ts: Vec<f64> = (0..400)
            .map(|_| (rng.next() as i32) as f64 / (1 + rng.next() % 1000) as f64)
            .collect();
        ts.extend([
            0.0,
            -0.0,
            1e-300,
            -1e-300,
            37.5,
            37.500_000_000_000_01,
            -40.0,
        ]);
        for a in &ts {
            for b in &ts {
                let (ka, kb) = (FloatModel::key(&(*a, true)), FloatModel::key(&(*b, true)));
                assert_eq!(ka.cmp(&kb), a.total_cmp(b), "{a} {b}");
                let (qa, qb) = ((a * 65_536.0) as i64, (b * 65_536.0) as i64);
                let (ka, kb) = (FixedModel::key(&(qa, true)), FixedModel::key(&(qb, false)));
                assert_eq!(ka.cmp(&kb), qa.cmp(&qb));
            }
        }
    }
}
