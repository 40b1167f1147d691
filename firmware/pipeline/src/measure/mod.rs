//! From a wrapped phase-difference map to a [`Measurement`]: the colour's field taken out
//! where the frame shows one ([`colour_phase`]), registration, noise floor, early exit,
//! contact tiles, unwrapping where needed, depth, features and quality flags.
//!
//! Work follows the scene: the background is read on a coarse grid (every [`GRID`]-th
//! working pixel each way), and only the contact region's window at every pixel, from the
//! coarse phase unwrapped and upsampled by cubic convolution ([`upsample2`]).
//!
//! Thresholds are set from what each frame measures, never magic depths: the noise floor is
//! the robust spread (1.4826 × MAD) of the background phase, contact needs
//! [`CONTACT_SIGMAS`] times that, and the volume counts pixels deeper than the depth of
//! that phase.

use vistaf_protocol::{Flag, QualityFlags};

pub mod apex;
mod coarse;
pub mod colour_phase;
mod contact;
mod far_field;
mod features;
pub mod load;
pub mod profile;
mod register;
mod window;

pub use coarse::{contact_tiles, local_noise_units, ContactTiles};
pub use features::{bounded_force, dominant_component, peak_component, summarize, Features};
pub use window::upsample2;

use coarse::{median, read_coarse, Coarse, Margin, Samples, NOISE_STEP};
use contact::{
    indentation_phase, mostly_recoloured, region_pixels, region_samples, upsampled, AmplitudeEdge,
    DepthPass, Faint, Limits, Window,
};
use profile::Shape;
use register::Background;

use crate::calibration::{Calibration, DepthError, ForceInputs};
use crate::fixed_point::UNITS_PER_RAD;
use crate::ftp::carrier::Carrier;
use crate::mask;
pub use crate::phase::GRID;
use crate::phase::{PhaseMap, PhaseNum, WrappedPhase};
use crate::Measurement;

/// Contact needs the phase to exceed this many noise σ.
pub const CONTACT_SIGMAS: f32 = 6.0;
/// …and at least this much, rad (a floor for very clean frames).
pub const MIN_CONTACT_RAD: f32 = 0.02;
/// A contact's width is read ([`apex::Apex::resolved`]) only where its map peak stands at
/// least this many contact thresholds above the background: nearer the threshold the
/// noise makes up a share of the region and of both blurred readings at the apex, and a
/// press too narrow for the band can pass for a resolved one of a fraction of its depth.
pub const RESOLVED_THRESHOLDS: i32 = 2;
/// A contact region with no peak where the demodulator's kernel lies wholly in the image
/// (a period from every edge) is a press centred nearer the edge than that, and is read up
/// to the edge, when its peak read there (the blur taken out, as any apex's) stands this
/// many contact thresholds above the background…
pub const EDGE_PEAK_THRESHOLDS: i32 = 4;
/// …and lies at least this deep, µm. Where the kernel averages padding, a skin at rest whose
/// fringes changed against the reference's (another temperature, another exposure) reads a
/// systematic depth there however clean the frame's noise, so the threshold alone cannot
/// keep it out (`docs/pipeline.md` gives its size). The floor lies near what the shallowest
/// press the product must report (0.2 mm) reads there, where the band's apex reads a press
/// low: a shallower press centred in the band is not reported.
pub const EDGE_PEAK_MIN_UM: i32 = 150;
/// Side of a contact tile at the working resolution, pixels.
pub const TILE_PX: usize = 8;
/// Coarse samples above threshold a tile needs to count as contact (of the 16 a tile has).
pub const TILE_MIN_SAMPLES: usize = 2;
/// Unwrap only when some phase in the contact region exceeds this, rad (below it nothing
/// can have wrapped: the background is at 0 and the phase is continuous).
pub const UNWRAP_TRIGGER_RAD: f32 = 0.6 * std::f32::consts::PI;
/// A pixel is unreliable when its fringe amplitude is below this fraction of the
/// reference's median.
pub const RELIABLE_AMPLITUDE: f32 = 0.3;
/// Periods from the edge within which a contact's phase is not trusted: nearer, the
/// demodulator's kernel (the two box passes reach a period each way) averages padding.
pub const CONTACT_MARGIN_PERIODS: f32 = 1.0;
/// Periods from the edge within which the background (registration, noise floor) and the
/// measurement's reliability map, which the temperature reads, are not trusted: half a
/// period further in than a contact's, so that the padding's faint pull on the phase there
/// moves neither the registration nor the stripes' placement.
pub const BACKGROUND_MARGIN_PERIODS: f32 = 1.5;
/// Low contrast: the frame's median fringe amplitude below this fraction of the reference's
/// (between where the contrast sweep of `docs/performance.md` still holds depth within
/// tolerance and where it loses it).
pub const LOW_CONTRAST_RATIO: f32 = 0.32;
/// Phase noise (1σ per working pixel) above which the fringes count as too weak for the
/// sensor's noise, rad: between where the noise sweep of `docs/performance.md` still holds
/// depth within tolerance and where it leaves it, and above what a deep press's own
/// residual raises the estimate to.
pub const NOISY_RAD: f32 = 0.024;
/// Depth beyond the deepest calibrated indentation by this factor is flagged.
pub const DEPTH_RANGE_SLACK: f64 = 1.1;
/// The tolerance a peak depth is held to: this share of the depth…
pub const DEPTH_TOLERANCE_SHARE: f32 = 0.03;
/// …plus this much, µm.
pub const DEPTH_TOLERANCE_UM: f32 = 20.0;
/// A peak depth is flagged `depth_uncertain` where the tolerance is less than this many
/// times the error the calibration expects of a reading at that depth ([`reading_error`],
/// [`depth_model_doubts`]): two, so that about 19 readings in 20 of an error of that
/// spread fall within the tolerance. The calibration measured that error on this unit,
/// with its light, noise and grating; nothing else in a frame says how well the depth
/// model fits the unit.
pub const DEPTH_CONFIDENCE_SIGMAS: f64 = 2.0;

/// Force beyond the largest calibrated force by this factor is flagged: the model is read
/// beyond its kit there ([`bounded_force`]).
pub const FORCE_RANGE_SLACK: f64 = 1.1;
/// Phase-slope flag: local phase slope (98th percentile over the deformed pixels) above
/// this fraction of the band half-width (the steepness sweep of `docs/performance.md`, and
/// unseen units with coarse gratings, read within tolerance below it).
pub const SLOPE_LIMIT: f32 = 0.6;
/// A region whose opposite-signed phase exceeds this fraction of its indentation-signed
/// phase is a thermal or shading dipole, not a contact.
pub const DIPOLE_RATIO: f32 = 0.35;
/// A region that is no dipole only with the rims of heated objects set aside keeps no more
/// than this fraction of opposite-signed phase off them (`measure::contact::AmplitudeEdge`).
pub const RIM_DIPOLE_RATIO: f32 = 0.1;
/// The change of the frame's fringe amplitude against the reference's, across a grating
/// period, beyond which the phase there is a heated object's rim's
/// (`measure::contact::AmplitudeEdge`), as a ratio `numerator / denominator`. A press
/// changes the stripes' brightness through its slope's shading by far less; the rim
/// changes it several times over.
pub const AMPLITUDE_EDGE_RATIO: (u64, u64) = (3, 2);
/// A contact whose peak stands under this many contact thresholds above the background,
/// with more of its depth where the pigment's colour changed against the reference than
/// elsewhere (`measure::contact::mostly_recoloured`), may be a heated object's print
/// alone: the colour's change pulls the phase as far as a shallow press does
/// (`faint_contact`).
pub const RECOLOURED_CONTACT_THRESHOLDS: i32 = 3;
/// The most phase (rad) the rim of a change of the pigment's colour pulls, per unit of the
/// natural log of the fringe-amplitude ratio's spread across it
/// (`measure::contact::AmplitudeEdge::log_span`): where the stripes' contrast and
/// brightness step within the demodulator's kernel, part of the step passes the band and
/// moves the phase, one way on one side of the print and the other way on the other. A
/// contact on recoloured ground standing no deeper than that may be the rim's pull alone
/// (`faint_contact`). About twice the most that the battery's heat prints showed
/// (`docs/pipeline.md`).
pub const RIM_PULL_RAD: f32 = 0.5;
/// Phase-slope flag: more than this fraction of the deformed pixels lost half their fringe
/// amplitude.
pub const BAND_LOSS_FRACTION: f32 = 0.01;
/// …and at least this many coarse samples ([`GRID`]² working pixels each).
pub const BAND_LOSS_MIN: usize = 2;
/// Phase-slope flag: a contact area below this fraction of the calibrated indenter's area at
/// the same depth.
pub const SHARPNESS_RATIO: f64 = 0.7;
/// Phase-slope flag: a contact area above this multiple of the calibrated indenter's area at
/// the same depth. The demodulator's blur (a grating period wide) lowers a rounded apex
/// and spares a plateau; the apex correction ([`apex`]) takes a sphere's loss back out, so
/// a blunter contact of a few blur σ (a flat punch, a letter's stroke) reads deep by what
/// a sphere of its sharpness would have lost more. There a sphere's and a punch's blurred
/// profiles match to under a percent at depths a tenth apart, so the map cannot tell them:
/// a contact this much wider than the calibrated indenter is flagged instead. A small
/// punch's rim also raises its plateau where the demodulator is not a linear blur, and
/// its area then stays near a sphere's: the margin is narrow so that most such presses
/// are caught, at the cost of flagging spheres over 1.3 times the calibrated radius
/// (a sphere's area at a given depth grows with its radius; `docs/pipeline.md`), except
/// where the contact's profile shows a sphere wide enough that no punch passes for one
/// ([`profile`]): there the load alone is compared, with a sphere's of its radius.
pub const BLUNTNESS_RATIO: f64 = 1.3;
/// Phase-slope flag: a reciprocal load (the depth map weighted by a flat punch's pressure,
/// [`load`]) beyond this multiple, or below its inverse, of the calibrated indenter's at
/// the same depth. Force and depth are read from the map by different routes (the load
/// integrates it, the apex reads its deepest point through the blur correction), and for
/// the calibrated indenter they agree as the kit showed; where they do not, the contact is
/// of another shape than the calibration's (a small punch whose area at half depth passes
/// for a sphere's carries more load than the sphere when shallow, less when deep) or its
/// depth was misread (a glare spot at the apex). `docs/pipeline.md` gives the measured
/// trade.
pub const LOAD_RATIO: f64 = 1.2;
/// Of several parts of a rejected region that each stand alone, one whose deepest sample
/// lies this many times beyond every other's holds the press (`docs/pipeline.md`, "One
/// part standing out").
pub const STANDS_OUT_RATIO: f32 = 2.0;
/// Misregistration flag: a global offset beyond this, rad (0.4 of a period: up to there the
/// offset is removed exactly; towards half a period it becomes ambiguous).
pub const MISREGISTRATION_RAD: f32 = 0.8 * std::f32::consts::PI;
/// Over-exposure flag: more than this fraction of newly saturated pixels.
pub const OVER_EXPOSED_FRACTION: f32 = 0.002;
/// Residues in the contact region tolerated before the unwrap is distrusted.
pub const MAX_RESIDUES: usize = 2;

/// The depth tolerance at a depth of `depth_um`, µm.
pub fn depth_tolerance_um(depth_um: f32) -> f32 {
    DEPTH_TOLERANCE_SHARE * depth_um + DEPTH_TOLERANCE_UM
}

/// The depth model's held-out error by depth ([`Calibration::depth_error`]); a file
/// written before it was recorded, its whole held-out error (`depth.cv_rmse`) at every
/// depth.
pub fn depth_error(calib: &Calibration) -> DepthError {
    calib.depth_error.unwrap_or(DepthError {
        floor_mm: calib.depth.cv_rmse,
        share: 0.0,
    })
}

/// The error a peak depth read anywhere in the view may carry, by depth (a standard
/// deviation): the depth model's held-out error ([`depth_error`]), its share of the depth
/// raised to how far the kit's presses of one depth read apart from place to place
/// ([`Calibration::depth_place_spread`]) where that is larger. The held-out error is a
/// floor and a share fitted over all the kit's depths; where the shallow presses' misses
/// outweigh the deep ones' it puts the whole error in the floor and no share, and so
/// under-states a deep press's error at a place the kit never pressed. The spread between
/// places measures that share directly, with each depth's bias taken out; the floor stays
/// the held-out one, which already holds the kit's own places' scatter at the depths it
/// pressed.
pub fn reading_error(calib: &Calibration) -> DepthError {
    depth_error(calib).with_place_spread(calib.depth_place_spread)
}

/// Whether a peak read `peak_mm` deep flags `depth_uncertain` for the expected `error`
/// ([`reading_error`]): where the depth tolerance is less than
/// [`DEPTH_CONFIDENCE_SIGMAS`] times that error at that depth. An error that is not a
/// number flags nothing.
pub fn depth_model_doubts(error: DepthError, peak_mm: f64) -> bool {
    let tolerance_mm = f64::from(depth_tolerance_um(1000.0 * peak_mm as f32)) / 1000.0;
    DEPTH_CONFIDENCE_SIGMAS * error.at_mm(peak_mm) > tolerance_mm
}

/// The peak depths [`depth_model_doubts`] flags, mm: those under the first figure (0
/// where none is, infinite where every depth is) and those over the second, if any. The
/// tolerance `t + s·d` against `k·√(f² + (c·d)²)` squared: `(k²c² − s²)·d² − 2ts·d +
/// k²f² − t²` is positive where a depth is flagged.
pub fn depths_doubted_mm(error: DepthError) -> (f64, Option<f64>) {
    let (t, s) = (
        f64::from(DEPTH_TOLERANCE_UM) / 1000.0,
        f64::from(DEPTH_TOLERANCE_SHARE),
    );
    let k2 = DEPTH_CONFIDENCE_SIGMAS * DEPTH_CONFIDENCE_SIGMAS;
    let (a, b, c) = (
        k2 * error.share * error.share - s * s,
        -2.0 * t * s,
        k2 * error.floor_mm * error.floor_mm - t * t,
    );
    if !(a.is_finite() && c.is_finite()) {
        return (0.0, None);
    }
    if a.abs() < 1e-12 {
        // Linear and falling: flagged under its root.
        return ((c / -b).max(0.0), None);
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        // Never zero: flagged everywhere where the parabola opens up, nowhere otherwise.
        return if a > 0.0 {
            (f64::INFINITY, None)
        } else {
            (0.0, None)
        };
    }
    let (r1, r2) = (
        (-b - disc.sqrt()) / (2.0 * a),
        (-b + disc.sqrt()) / (2.0 * a),
    );
    if a < 0.0 {
        // Opening down, falling from zero: flagged under its larger root, if positive.
        (r1.max(r2).max(0.0), None)
    } else {
        (r1.max(0.0), Some(r2.max(0.0)))
    }
}

/// Whether a peak read `peak_mm` deep through the sphere's blur correction would lie
/// beyond the depth tolerance if the contact were a flat punch of the same blurred
/// sharpness, `punch_excess` deeper as a sphere's ([`apex::BlurLoss::punch_excess`]; zero
/// where such a punch is wide enough for its profile to show its plateau). Below that
/// width a punch's blurred map is a sphere's a little deeper, surround included, and the
/// calibrated sphere's area and load at that depth are the punch's too: nothing in the map
/// says which pressed, so a contact whose profile is neither family's carries
/// `depth_uncertain` there. Contact mechanics sets the margin (Hertz's and Boussinesq's
/// surfaces through the plan's own kernel), not a tuned factor.
pub fn punch_beyond_tolerance(punch_excess: f64, peak_mm: f32) -> bool {
    let peak_um = 1000.0 * peak_mm;
    punch_excess / (1.0 + punch_excess) * f64::from(peak_um)
        > f64::from(depth_tolerance_um(peak_um))
}

/// What the measurement needs besides the phase.
#[derive(Debug, Clone, Copy)]
pub struct Context<'a> {
    /// The calibration.
    pub calib: &'a Calibration,
    /// The blur correction of the plan's demodulator ([`apex`]).
    pub blur_loss: &'a apex::BlurLoss,
    /// The shape templates of the plan's demodulator ([`profile`]).
    pub shapes: &'a profile::Shapes,
    /// Input scale, mm per pixel.
    pub mm_per_px: f32,
    /// Fraction of the reference's pixels with a saturated channel.
    pub ref_saturated_fraction: f32,
    /// When to unwrap the contact region's phase.
    pub unwrap: Unwrap,
    /// The phase the pigment's colour moves, relative to the reference
    /// ([`colour_phase`]): taken out before registration where a field explains the frame.
    pub colour_phase: Option<&'a colour_phase::Candidates>,
}

impl Context<'_> {
    /// The sign of an indentation's phase difference: ±1.
    fn indentation_sign(&self) -> i32 {
        if self.calib.phase_sign < 0.0 {
            -1
        } else {
            1
        }
    }
}

/// When the contact region's phase is unwrapped (a trade-off axis: cost against depth
/// beyond half a turn of phase).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Unwrap {
    /// Only when the wrapped difference can have wrapped (the default).
    #[default]
    WhenNeeded,
    /// On every frame with contact.
    Always,
    /// Never: deep presses read wrong (and the slope flags say so).
    Never,
}

/// The frame's working and coarse grids.
#[derive(Debug, Clone, Copy)]
struct Grid {
    /// Working width and height, pixels.
    w: usize,
    h: usize,
    /// Coarse samples across and down.
    coarse: (usize, usize),
    /// Contact tiles across and down.
    tiles: (usize, usize),
}

impl Grid {
    fn of((w, h): (usize, usize)) -> Grid {
        Grid {
            w,
            h,
            coarse: (w.div_ceil(GRID), h.div_ceil(GRID)),
            tiles: (w.div_ceil(TILE_PX), h.div_ceil(TILE_PX)),
        }
    }

    /// The tile holding coarse sample `k` (row-major, both).
    fn tile_of(&self, k: usize) -> usize {
        const PER: usize = TILE_PX / GRID;
        let (cw, tw) = (self.coarse.0, self.tiles.0);
        (k / cw / PER) * tw + (k % cw) / PER
    }
}

/// The measurement, shared by both paths: registration, noise floor, early exit, contact
/// tiles, unwrapping where needed, depth, features and flags.
///
/// Work follows the scene: the background is read on the coarse grid ([`GRID`]), and only
/// the contact region's window at every pixel. Returns the result and the phase as read
/// (for the temperature's stripe placement).
pub fn measure<M: PhaseMap>(
    map: &M,
    factor: usize,
    carrier: Carrier,
    ctx: &Context<'_>,
) -> (Measurement, WrappedPhase) {
    let grid = Grid::of(map.size());
    let amp_ref_median = map.amp_ref_median().max(1);
    let reliable_amp =
        (u64::from(amp_ref_median) * (RELIABLE_AMPLITUDE * 1024.0) as u64 / 1024) as u32;
    let margin_px = |periods: f32| (periods * carrier.period_px()).ceil() as usize;
    let margin = Margin::new(margin_px(BACKGROUND_MARGIN_PERIODS), grid.w, grid.h);
    let contact_margin = Margin::new(margin_px(CONTACT_MARGIN_PERIODS), grid.w, grid.h);
    let mut coarse = read_coarse(map, reliable_amp, &margin, &contact_margin);
    let colour = ctx
        .colour_phase
        .and_then(|c| c.choose(&coarse.phase, &coarse.rel_contact, grid.coarse));
    // The phase as read, before the colour's field is taken out: the stripes lie there.
    let read_units: Vec<i32> = coarse.phase.iter().map(|p| p.units()).collect();
    if let Some(field) = &colour {
        for (p, &u) in coarse.phase.iter_mut().zip(field) {
            *p = p.minus(M::P::from_units(u));
        }
    }
    // The frame's median fringe amplitude, over every fourth coarse sample (as many as the
    // noise floor's).
    let amp_frame_median = median(
        coarse
            .amp
            .iter()
            .step_by(NOISE_STEP * NOISE_STEP)
            .copied()
            .collect(),
    );
    let amp_medians = (amp_frame_median, amp_ref_median);
    let mut flags = image_flags(map, &coarse, amp_medians, ctx);
    let bg = register::background(
        &coarse,
        &grid,
        carrier,
        (ctx.indentation_sign(), colour.is_some()),
        amp_ref_median,
    );
    flags.insert_all(background_flags(&bg));
    let mut wrapped = WrappedPhase {
        cw: grid.coarse.0,
        coarse: read_units,
        local: None,
        offset: bg.offset.units(),
        threshold: bg.threshold,
        colour_field: colour.is_some(),
    };
    let frame = FrameResult {
        grid,
        factor,
        flags,
        noise_rad: bg.noise as f32 / UNITS_PER_RAD,
        offset_rad: bg.offset.units() as f32 / UNITS_PER_RAD,
    };
    // The region is found on |Δφ|: at the centre of a deep press the wrapped phase has
    // wrapped to the other sign, and it must be unwrapped, not seeded from. Only
    // indentation (positive signed phase) is reported as depth.
    let Some(ContactTiles {
        on: tiles_on,
        n: tiles,
        faint,
    }) = &bg.contact
    else {
        let reliable = reliable_pixels(&coarse.rel, &grid, &margin);
        return (frame.without_contact(reliable), wrapped);
    };
    let found = Found {
        map,
        factor,
        coarse: &coarse,
        margin: &contact_margin,
        bg: &bg,
        tiles_on,
        amp_medians,
        low_contrast: frame.flags.contains(Flag::LowContrast),
        colour_field: colour.as_deref(),
    };
    let contact_reliable = reliable_pixels(&coarse.rel_contact, &grid, &contact_margin);
    let mut c = found.measure(carrier, ctx, &contact_reliable, &mut wrapped);
    if let Some(field) = &colour {
        wrapped.restore_local(field);
        // Taking the colour's field out may explain a spot away, never make one.
        let sign = ctx.indentation_sign();
        c = c.filter(|c| !made_by_field(c, field, wrapped.cw, (map, sign)));
    }
    // What the temperature reads: the same map within the background's margin.
    let reliable = within(contact_reliable, grid.w, &margin);
    match c {
        Some(mut c) => {
            if *faint {
                c.flags.insert(Flag::FaintContact);
            }
            (frame.with_contact(c, *tiles, reliable), wrapped)
        }
        None => (frame.without_contact(reliable), wrapped),
    }
}

/// The phase (units) a rim of a change of the pigment's colour can pull where the fringe
/// amplitude ratio spreads by `span` (its natural log): [`RIM_PULL_RAD`] per unit of it.
fn rim_pull_units(span: f32) -> i32 {
    (RIM_PULL_RAD * span * UNITS_PER_RAD).round() as i32
}

/// Of several `parts` that stand alone, none standing out by its depth, the one
/// `clear` of the colour's pull ([`Found::clear_of_colour`]) when every other is not: a
/// skin away from the reference's temperature moves the phase where its light or its
/// pigment changes the stripes' contrast unevenly (a lamp's reflection, a print's rim),
/// and a press moves it where the contrast holds. `None` where no part or more than one
/// is clear.
fn only_clear_of_colour<'p>(
    parts: &[&'p Vec<bool>],
    clear: &impl Fn(&[bool]) -> bool,
) -> Option<&'p Vec<bool>> {
    let mut clear = parts.iter().filter(|part| clear(part));
    let one = clear.next()?;
    clear.next().is_none().then_some(*one)
}

/// The working pixel at the centre of tile `t`, within the image.
fn tile_centre(t: usize, grid: &Grid) -> (usize, usize) {
    let c = |i: usize, n: usize| (i * TILE_PX + TILE_PX / 2).min(n.saturating_sub(1));
    (c(t % grid.tiles.0, grid.w), c(t / grid.tiles.0, grid.h))
}

/// The deepest of the tiles `part` by their `peaks` (the first of equals): its peak and
/// the tile.
fn deepest_tile(part: &[bool], peaks: &[i32]) -> Option<(i32, usize)> {
    (peaks.iter().enumerate())
        .filter(|&(t, _)| part.get(t) == Some(&true))
        .max_by_key(|&(t, &p)| (p, std::cmp::Reverse(t)))
        .map(|(t, &p)| (p, t))
}

/// Whether contact `c`, read once the colour's `field` (units per coarse sample, `cw`
/// across) was taken out, is the field's own: at its deepest pixel the field raised the
/// indentation (`sign`: its sign) by more than the contact stands above its threshold,
/// both read as depth through `map`. A deep press stands far above any field; a spot the
/// field over-corrected stands just above the threshold.
fn made_by_field<M: PhaseMap>(
    c: &ContactResult,
    field: &[i32],
    cw: usize,
    (map, sign): (&M, i32),
) -> bool {
    let (w, _) = c.size;
    let deepest = c.depth_um.iter().enumerate().max_by_key(|&(_, &d)| d);
    let Some((at, &peak_um)) = deepest else {
        return false;
    };
    let (x, y) = (c.origin.0 + at % w.max(1), c.origin.1 + at / w.max(1));
    let raised = -sign * field.get((y / GRID) * cw + x / GRID).copied().unwrap_or(0);
    raised > 0 && peak_um - c.threshold_um < map.depth_um(M::P::from_units(raised))
}

/// A reliability map (`w` pixels across) built on a narrower margin, cut to `margin`: what
/// [`reliable_pixels`] gives there, since the samples inside both margins are reliable
/// alike. A pixel reads the coarse sample at or before it, so the margin's first row and
/// column count only when they hold a sample (a multiple of [`GRID`]).
fn within(mut reliable: Vec<bool>, w: usize, margin: &Margin) -> Vec<bool> {
    let on_grid = |r: &std::ops::Range<usize>| r.start.next_multiple_of(GRID).min(r.end)..r.end;
    let (xs, ys) = (on_grid(&margin.xs), on_grid(&margin.ys));
    for (y, row) in reliable.chunks_exact_mut(w).enumerate() {
        if ys.contains(&y) {
            row[..xs.start].fill(false);
            row[xs.end..].fill(false);
        } else {
            row.fill(false);
        }
    }
    reliable
}

/// Flags the image earns before any phase is read: fringes too faint against the
/// reference's, or too few reliable samples; newly saturated pixels.
fn image_flags<M: PhaseMap>(
    map: &M,
    coarse: &Coarse<'_, M::P>,
    (amp_frame_median, amp_ref_median): (u32, u32),
    ctx: &Context<'_>,
) -> QualityFlags {
    let mut flags = QualityFlags::NONE;
    if (amp_frame_median as f32) < LOW_CONTRAST_RATIO * amp_ref_median as f32
        || coarse.reliable_n * 2 < coarse.inside_n
    {
        flags.insert(Flag::LowContrast);
    }
    if map.saturated_fraction() - ctx.ref_saturated_fraction > OVER_EXPOSED_FRACTION {
        flags.insert(Flag::OverExposure);
    }
    flags
}

/// Flags the background earns: an offset too large to remove for sure, and fringes too
/// weak for the sensor's noise (not judged when a contact covering most of the view left
/// no background to measure the noise on; the amplitude tests still are).
fn background_flags<P: PhaseNum>(bg: &Background<P>) -> QualityFlags {
    let mut flags = QualityFlags::NONE;
    if (bg.offset.units() as f32 / UNITS_PER_RAD).abs() > MISREGISTRATION_RAD {
        flags.insert(Flag::Misregistration);
    }
    if bg.noise_clean && bg.noise as f32 / UNITS_PER_RAD > NOISY_RAD {
        flags.insert(Flag::LowContrast);
    }
    flags
}

/// Reliability per working pixel, from the coarse grid (the contact window refines it).
fn reliable_pixels(rel: &[bool], grid: &Grid, margin: &Margin) -> Vec<bool> {
    let (w, cw) = (grid.w, grid.coarse.0);
    let mut reliable = vec![false; grid.w * grid.h];
    let (xa, xb) = (margin.xs.start, margin.xs.end);
    for y in margin.ys.clone() {
        // The rows of one coarse row are the same: the first is built, the next copied.
        if y % GRID != 0 && y > margin.ys.start {
            reliable.copy_within((y - 1) * w..y * w, y * w);
            continue;
        }
        let crow = &rel[(y / GRID) * cw..(y / GRID + 1) * cw];
        let row = &mut reliable[y * w..(y + 1) * w];
        // Fixed-size runs (a `fill` of a run of unknown length would be a call per run).
        let (runs, rest) = row.as_chunks_mut::<GRID>();
        for (run, &r) in runs.iter_mut().zip(crow) {
            *run = [r; GRID];
        }
        if let Some(&r) = crow.get(runs.len()) {
            rest.fill(r);
        }
        // The coarse samples' own margin test is a pixel coarse; the pixel's is exact.
        row[..xa].fill(false);
        row[xb..].fill(false);
    }
    reliable
}

/// What every frame's result carries, contact or not.
struct FrameResult {
    grid: Grid,
    factor: usize,
    flags: QualityFlags,
    noise_rad: f32,
    offset_rad: f32,
}

/// A contact's share of the result.
struct ContactResult {
    feats: Features,
    /// The depth map's deepest value, µm.
    map_peak_um: i32,
    /// What the force model read.
    inputs: ForceInputs,
    flags: QualityFlags,
    force_n: f32,
    shape: Shape,
    threshold_um: i32,
    /// The window's depth, and its pixels: origin and size.
    depth_um: Vec<i32>,
    origin: (usize, usize),
    size: (usize, usize),
}

impl FrameResult {
    fn without_contact(&self, reliable: Vec<bool>) -> Measurement {
        let (w, h) = (self.grid.w, self.grid.h);
        self.measurement(reliable, vec![0; w * h])
    }

    /// The result with this depth map, before any contact's fields are filled in.
    fn measurement(&self, reliable: Vec<bool>, depth_um: Vec<i32>) -> Measurement {
        Measurement {
            width_px: self.grid.w,
            height_px: self.grid.h,
            factor: self.factor,
            depth_um,
            reliable,
            contact: false,
            peak_depth_mm: 0.0,
            map_peak_um: 0,
            contact_area_mm2: 0.0,
            volume_mm3: 0.0,
            centroid_px: None,
            integrated_phase_rad_mm2: 0.0,
            reciprocal_load_mm2: 0.0,
            force_n: 0.0,
            shape: Shape::Unknown,
            flags: self.flags,
            noise_rad: self.noise_rad,
            offset_rad: self.offset_rad,
            floor_um: 0,
            tiles: 0,
            window_px: None,
            temperature: None,
        }
    }

    fn with_contact(&self, c: ContactResult, tiles: usize, reliable: Vec<bool>) -> Measurement {
        let (w, h) = (self.grid.w, self.grid.h);
        let ((x0, y0), (bw, bh)) = (c.origin, c.size);
        let mut depth_um = vec![0; w * h];
        let cols = bw.min(w - x0);
        for ly in 0..bh.min(h - y0) {
            let row = (y0 + ly) * w + x0;
            depth_um[row..row + cols].copy_from_slice(&c.depth_um[ly * bw..ly * bw + cols]);
        }
        let mut flags = self.flags;
        flags.insert_all(c.flags);
        Measurement {
            contact: true,
            peak_depth_mm: c.feats.peak_mm,
            map_peak_um: c.map_peak_um,
            contact_area_mm2: c.feats.area_mm2,
            volume_mm3: c.feats.volume_mm3,
            centroid_px: c.feats.centroid_px,
            integrated_phase_rad_mm2: c.inputs.integrated_phase_rad_mm2,
            reciprocal_load_mm2: c.inputs.reciprocal_load_mm2,
            force_n: c.force_n,
            shape: c.shape,
            tiles,
            floor_um: c.threshold_um,
            window_px: Some([x0, y0, x0 + cols, y0 + bh.min(h - y0)]),
            flags,
            ..self.measurement(reliable, depth_um)
        }
    }
}

/// How far the contact's rings reach, in multiples of its enclosing radius: the profile
/// needs them out to where they fall to [`profile::PROFILE_CUT`] of the deepest
/// (Boussinesq's surround does at 2.6 contact radii, 1.8 times the half-depth radius
/// `√2 a`, and a layer's sooner).
const PROFILE_REACH: f32 = 2.5;

/// A frame with contact tiles, and what its contact stage reads.
struct Found<'a, M: PhaseMap> {
    map: &'a M,
    factor: usize,
    coarse: &'a Coarse<'a, M::P>,
    /// Where a contact's phase is trusted: a grating period in from the edge.
    margin: &'a Margin,
    bg: &'a Background<M::P>,
    tiles_on: &'a [bool],
    amp_medians: (u32, u32),
    /// Whether the frame carries `low_contrast`.
    low_contrast: bool,
    /// The colour's field taken out of the phase, units per coarse sample, if one was.
    colour_field: Option<&'a [i32]>,
}

impl<M: PhaseMap> Found<'_, M> {
    /// The contact's centre in window pixels (`x0, y0` the window's origin), from its
    /// features' centre in input pixels.
    fn window_centre(&self, feats: &Features, (x0, y0): (usize, usize)) -> (f32, f32) {
        feats.centroid_px.map_or((0.0, 0.0), |(x, y)| {
            let f = self.factor as f32;
            (x / f - x0 as f32, y / f - y0 as f32)
        })
    }

    /// The coarse grid's fringe amplitudes (`cw` samples across) the dipole test reads
    /// faint fringes by.
    fn faint(&self, cw: usize) -> Faint<'_> {
        Faint {
            amp: &self.coarse.amp,
            amp_r: &self.coarse.amp_r,
            medians: self.amp_medians,
            cw,
        }
    }

    /// The depth (µm) under which a contact on recoloured ground may be the colour's pull
    /// alone: [`RECOLOURED_CONTACT_THRESHOLDS`] contact thresholds (`threshold_um`), or
    /// what a rim can pull where the amplitude ratio spreads by `span` (its log, about the
    /// apex: [`RIM_PULL_RAD`]), whichever is deeper.
    fn recoloured_limit_um(&self, threshold_um: i32, span: f32) -> i32 {
        let rim_um = self.depth_um(rim_pull_units(span));
        (RECOLOURED_CONTACT_THRESHOLDS * threshold_um).max(rim_um)
    }

    /// The depth (µm) of a phase of `units` through the map's calibration.
    fn depth_um(&self, units: i32) -> i32 {
        self.map.depth_um(<M::P as PhaseNum>::from_units(units))
    }

    /// The contact of `region` (indices into the window whose phase as read is `up` and
    /// whose depth map is `depth_um`, `w` pixels wide, its corner working pixel `(x0, y0)`):
    /// the apex of the phase as read (surround and noise included: the blur acts on the
    /// phase, and the correction compares blurs of the whole surface), the map's value
    /// there and the half-depth component around it. `None` without a peak above
    /// `threshold_um`.
    fn contact_peak(
        &self,
        (up, depth_um): (&[i32], &[i32]),
        (x0, y0, w): (usize, usize, usize),
        region: &[usize],
        threshold_um: i32,
        ctx: &Context<'_>,
    ) -> Option<ContactPeak> {
        let apex = apex::apex(up, w, region, ctx.blur_loss)?;
        let map_peak_um = depth_um[apex.at];
        let contact = peak_component(depth_um, w, apex.at, threshold_um);
        let peak = (map_peak_um, threshold_um);
        let (origin, factor) = ((x0, y0), self.factor);
        let mut feats = summarize(depth_um, &contact, w, origin, factor, ctx.mm_per_px, peak);
        if feats.peak_mm == 0.0 {
            return None;
        }
        feats.peak_mm = self.depth_um(apex.peak) as f32 / 1000.0;
        Some(ContactPeak {
            apex,
            map_peak_um,
            contact,
            feats,
        })
    }

    /// The coarse grid's amplitude ratios the dipole test reads the rims of heated objects
    /// by, half a grating period either side of each sample.
    fn amplitude_edge(&self, grid: &Grid, carrier: Carrier) -> AmplitudeEdge<'_> {
        let reach = (carrier.period_px() / (2 * GRID) as f32).round() as usize;
        let amps = (&self.coarse.amp[..], &self.coarse.amp_r[..]);
        AmplitudeEdge::new(amps, grid.coarse, reach, self.margin)
    }

    /// What the force model reads of a contact: its features, the phase integrated over
    /// its deformed pixels and its reciprocal load `load_mm2`, working pixels `px_mm` wide.
    fn force_inputs(feats: &Features, pass: &DepthPass, load_mm2: f32, px_mm: f32) -> ForceInputs {
        ForceInputs {
            area_mm2: feats.area_mm2,
            peak_mm: feats.peak_mm,
            volume_mm3: feats.volume_mm3,
            integrated_phase_rad_mm2: pass.integrated_units as f32 / UNITS_PER_RAD * px_mm * px_mm,
            reciprocal_load_mm2: load_mm2,
        }
    }

    /// The contact of a region the dipole test rejected as a whole, read from the one part
    /// of it that makes a contact by itself (`None` when no part does). The tiles join
    /// whatever stands above the noise floor anywhere in the view, so a press's region may
    /// take in groups far from it (faint fringes' noise, a glare's edge) whose
    /// opposite-signed phase outweighs it; a dipole's two lobes lie side by side and stay
    /// one part, which the test still rejects. Where several parts stand by the
    /// indentation's sign, the view's phase departs both ways in many places (a skin far
    /// from the reference's temperature moves it against a fixed term in the band): only a
    /// part standing far beyond every other is told for a press
    /// ([`Self::press_standing_out`]), otherwise the whole region's verdict holds.
    ///
    /// Where the colour's field was taken out of the frame, what the field misses by a
    /// little is left wherever the field acts, in parts of both signs, one of which may
    /// stand alone: a candidate part stands neither where the field acts
    /// ([`Self::field_at_peak`]) nor within the colour's reach ([`Self::clear_of_colour`]),
    /// and the candidates are judged as on any frame (a press beside a lamp's reflection
    /// the field under-corrected). Where no part stands out by its depth, the one part
    /// clear of the colour is the press ([`only_clear_of_colour`]). The verdict
    /// holds where the frame's fringes are faint (`low_contrast`: noise raises parts
    /// anywhere), and for a part whose contact reaches the edge of the view
    /// (`contact_at_edge`): there the kernel averages padding, the noise floor's own groups
    /// gather, and nothing tells such a part from them.
    fn part_that_stands(
        &self,
        carrier: Carrier,
        ctx: &Context<'_>,
        reliable: &[bool],
        wrapped: &mut WrappedPhase,
    ) -> Option<ContactResult> {
        let grid = Grid::of(self.map.size());
        let mut parts = mask::parts(self.tiles_on, grid.tiles.0, grid.tiles.1);
        if parts.len() < 2 || self.low_contrast {
            return None;
        }
        let sign = ctx.indentation_sign();
        let offset = self.bg.offset;
        let signed: Vec<i32> = (self.coarse.phase.iter())
            .map(|p| sign * p.minus(offset).units())
            .collect();
        let peaks = self.tile_peaks(&signed, &grid);
        let clear = self.clear_of_colour(&peaks, &grid, carrier);
        if let Some(field) = self.colour_field {
            let size: Vec<i32> = field.iter().map(|f| f.abs()).collect();
            let field_peaks = self.tile_peaks(&size, &grid);
            parts.retain(|part| !self.field_at_peak(part, &peaks, &field_peaks) && clear(part));
        }
        let min_total = register::min_contact_samples(carrier);
        let standing: Vec<&Vec<bool>> = (parts.iter())
            .filter(|part| self.stands_alone(part, &signed, &grid, min_total))
            .collect();
        let core;
        let part = match standing[..] {
            [part] => part,
            [_, _, ..] => match self.press_standing_out(&standing, &peaks, &grid, carrier) {
                Some(c) => {
                    core = c;
                    &core
                }
                None => only_clear_of_colour(&standing, &clear)?,
            },
            [] => return None,
        };
        let whole = wrapped.local.take();
        let found = Found {
            tiles_on: part,
            ..*self
        };
        let c = found
            .measure(carrier, ctx, reliable, wrapped)
            .filter(|c| !c.flags.contains(Flag::ContactAtEdge));
        if c.is_none() {
            wrapped.local = whole;
        }
        c
    }

    /// Whether the colour's field stands beyond the contact threshold in the tile where
    /// `part` is deepest (`peaks`; `field_peaks`: the field's largest size over each
    /// tile's reliable samples): where the field moves the phase by that much, what stands
    /// there may be what it missed. A part takes in tiles a period around what stands, so
    /// its far tiles may reach a lamp's reflection beside a press; its deepest tile is
    /// where it stands.
    fn field_at_peak(&self, part: &[bool], peaks: &[i32], field_peaks: &[i32]) -> bool {
        deepest_tile(part, peaks)
            .and_then(|(_, t)| field_peaks.get(t))
            .is_some_and(|&f| f > self.bg.threshold)
    }

    /// Of several `parts` that stand alone, the press in the one whose deepest
    /// indentation-signed sample (`peaks`: each tile's, reliable samples only) lies
    /// [`STANDS_OUT_RATIO`] times or more beyond every other's: a press amid the phase
    /// that a skin away from the reference's temperature moves in many places, all near
    /// the threshold. Such a part
    /// takes in that phase around the press too, so the press is its tiles reaching
    /// beyond every other part's deepest sample, joined to the deepest tile, and a grating
    /// period of the part's tiles around them (where the press's flank falls to the
    /// threshold). `None` where no part stands that far out: nothing tells a press there.
    fn press_standing_out(
        &self,
        parts: &[&Vec<bool>],
        peaks: &[i32],
        grid: &Grid,
        carrier: Carrier,
    ) -> Option<Vec<bool>> {
        // Each part's deepest tile (the first of equals): its peak, the tile, the part.
        let mut ranked: Vec<(i32, usize, &Vec<bool>)> = (parts.iter())
            .filter_map(|&part| {
                let (peak, seed) = deepest_tile(part, peaks)?;
                Some((peak, seed, part))
            })
            .collect();
        ranked.sort_unstable_by_key(|&(peak, _, _)| std::cmp::Reverse(peak));
        let [(first, seed, part), (second, _, _), ..] = ranked[..] else {
            return None;
        };
        let second = second.max(self.bg.threshold);
        if (first as f32) < STANDS_OUT_RATIO * second as f32 {
            return None;
        }
        let (tw, th) = grid.tiles;
        let mut seen = vec![false; tw * th];
        let mut core = vec![false; tw * th];
        for i in mask::component(&mut seen, (tw, th), seed, |j| part[j] && peaks[j] > second) {
            core[i] = true;
        }
        let flank_tiles = (carrier.period_px() / TILE_PX as f32).ceil() as usize;
        for _ in 0..flank_tiles {
            core = mask::dilate(&core, tw, th);
            for (c, &on) in core.iter_mut().zip(part.iter()) {
                *c &= on;
            }
        }
        Some(core)
    }

    /// Whether a part's deepest tile (by `peaks`) is clear of what the pigment's colour
    /// can do to the phase: the fringes kept the reference's contrast at its centre (no
    /// change of colour there, nor a change's rim, [`contact::recoloured_at`]), and it
    /// stands beyond what the colour can pull there, [`RECOLOURED_CONTACT_THRESHOLDS`]
    /// contact thresholds or a rim's pull where the amplitude ratio spreads about it
    /// ([`RIM_PULL_RAD`]), whichever is more (a warm print's flank reaches past where its
    /// contrast changed, and stands there as a press no deeper than that would).
    fn clear_of_colour<'s>(
        &'s self,
        peaks: &'s [i32],
        grid: &'s Grid,
        carrier: Carrier,
    ) -> impl Fn(&[bool]) -> bool + 's {
        let (faint, edge) = (
            self.faint(grid.coarse.0),
            self.amplitude_edge(grid, carrier),
        );
        let least = RECOLOURED_CONTACT_THRESHOLDS * self.bg.threshold;
        move |part: &[bool]| {
            deepest_tile(part, peaks).is_some_and(|(peak, t)| {
                let at = tile_centre(t, grid);
                let pull = rim_pull_units(edge.log_span(at));
                !contact::recoloured_at((faint, edge), at) && peak > least.max(pull)
            })
        }
    }

    /// Per tile, the largest of `values` (one per coarse sample: the indentation-signed
    /// phase, say) over its reliable samples (`i32::MIN` where none is reliable).
    fn tile_peaks(&self, values: &[i32], grid: &Grid) -> Vec<i32> {
        let (tw, th) = grid.tiles;
        let mut peaks = vec![i32::MIN; tw * th];
        let samples = values.iter().zip(&self.coarse.rel_contact).enumerate();
        for (k, (&v, _)) in samples.filter(|(_, (_, &rel))| rel) {
            if let Some(p) = peaks.get_mut(grid.tile_of(k)) {
                *p = (*p).max(v);
            }
        }
        peaks
    }

    /// Whether the tiles `part` hold a contact by themselves, by the rules a contact must
    /// meet to be found at all ([`Samples::make_contact`]) with only the indentation's sign
    /// counted (`signed`: each coarse sample's phase against the registration, indentation
    /// positive): `min_total` reliable samples whose phase stands beyond the threshold
    /// against their own fringes' noise ([`contact::Faint`]), a tile's worth of them in one
    /// tile. Groups raised by noise where fringes are faint stand in a few samples; a press
    /// stands over a disc a period across.
    fn stands_alone(&self, part: &[bool], signed: &[i32], grid: &Grid, min_total: usize) -> bool {
        let cw = grid.coarse.0;
        let faint = self.faint(cw);
        let threshold = self.bg.threshold;
        let samples = Samples {
            phi: signed,
            rel: &self.coarse.rel_contact,
            amp_r: &self.coarse.amp_r,
            cw,
        };
        let tiles: Vec<usize> = part.iter().map(|&on| usize::from(on)).collect();
        samples.make_contact(&tiles, grid.tiles.0, min_total, |v, _, k| {
            v > threshold && faint.stands(v, ((k % cw) * GRID, (k / cw) * GRID), threshold)
        })
    }

    /// The contact read at every pixel of its window: `None` when it turns out to be no
    /// contact (a dipole, or nothing above the threshold's depth). The window's phase as
    /// read goes into `wrapped`.
    fn measure(
        &self,
        carrier: Carrier,
        ctx: &Context<'_>,
        reliable: &[bool],
        wrapped: &mut WrappedPhase,
    ) -> Option<ContactResult> {
        let grid = Grid::of(self.map.size());
        let sign = ctx.indentation_sign();
        let win = Window::around(self.tiles_on, &grid);
        let region = region_samples(self.tiles_on, &grid);
        let (signed, unreached, residues) = indentation_phase(
            self.coarse,
            (&region, self.bg.threshold),
            &win,
            (self.bg.offset, sign),
            ctx.unwrap,
        );
        let up = upsampled(&signed, &win);
        let ((x0, y0), (bw, bh)) = win.pixels();
        let threshold_um = self.depth_um(self.bg.threshold);
        // The phase as read, back in the wrapped difference's terms.
        let off_units = self.bg.offset.units();
        let raw: Vec<i32> = up
            .iter()
            .map(|&v| i32::from((sign * v).wrapping_add(off_units) as i16))
            .collect();
        wrapped.local = Some((x0, y0, bw, bh, raw));
        let on = region_pixels(self.tiles_on, grid.tiles.0, (x0, y0), (bw, bh));
        let pass = DepthPass::run(
            self.map,
            &up,
            &on,
            reliable,
            (grid.w, x0, y0, bw),
            (self.bg.threshold, threshold_um),
        );
        // Where the fringes' amplitude says the pigment's colour changed, which moves the
        // phase whatever the surface does.
        let amplitudes = || {
            (
                self.faint(grid.coarse.0),
                self.amplitude_edge(&grid, carrier),
            )
        };
        // The sign of the phase is trusted only where the unwrapping reached: a wrapped
        // core left over reads as the other sign, and a press is never dropped for it (it
        // is measured, and flagged as an unwrapping failure).
        if unreached == 0
            && pass.is_dipole()
            && pass.dipole_where_it_stands(
                (&up, &on, reliable),
                amplitudes(),
                (grid.w, x0, y0, bw),
                self.bg.threshold,
            )
        {
            return self.part_that_stands(carrier, ctx, reliable, wrapped);
        }
        // The contact: the region holding the most indentation, its apex (the blurred map's
        // deepest point there) and the half-depth component around the apex. The map's value
        // at the apex is read once for the component, the features and the temperature's
        // contact region.
        // The apex is looked for only where the demodulator's kernel lies wholly in the
        // image, a period from every edge: nearer, the kernel averages padding, and a press
        // reaching there can show a spurious peak deeper than its own, which would take the
        // apex, and with it the centre, millimetres away. The component, the depth map,
        // area, volume and integrated phase keep the edge's pixels: their values are mostly
        // sound, and without them the centre of a press near the edge moves inward and its
        // force reads short. A region with no peak inside that band is a press centred
        // nearer the edge than the kernel reaches when it stands well above the background
        // ([`EDGE_PEAK_THRESHOLDS`], [`EDGE_PEAK_MIN_UM`]) off recoloured ground, and is read
        // up to the edge (`contact_at_edge`, below); otherwise it is no contact.
        let whole_kernel = self.margin;
        let kernel_inside = |&i: &usize| whole_kernel.contains(x0 + i % bw, y0 + i / bw);
        let region = dominant_component(&pass.depth_um, bw, threshold_um);
        let window_inside =
            whole_kernel.contains(x0, y0) && whole_kernel.contains(x0 + bw - 1, y0 + bh - 1);
        let maps = (&up[..], &pass.depth_um[..]);
        let peak_of = |r: &[usize]| self.contact_peak(maps, (x0, y0, bw), r, threshold_um, ctx);
        let read = if window_inside {
            peak_of(&region)
        } else {
            let inside: Vec<usize> = region.iter().copied().filter(kernel_inside).collect();
            peak_of(&inside).or_else(|| {
                // Where the pigment's colour changed (a warm print's rim, a skin at another
                // temperature), its pull on the phase reads in the band as such a peak, and
                // nothing there tells it from a press.
                let (faint, edge) = amplitudes();
                let recoloured = (&pass.depth_um[..], &region[..]);
                if mostly_recoloured(recoloured, (faint, edge), (x0, y0, bw)) {
                    return None;
                }
                let read = peak_of(&region)?;
                let least_um = (EDGE_PEAK_THRESHOLDS * threshold_um).max(EDGE_PEAK_MIN_UM);
                (read.feats.peak_mm >= least_um as f32 / 1000.0).then_some(read)
            })
        };
        let ContactPeak {
            apex,
            map_peak_um,
            contact,
            mut feats,
        } = read?;
        // The rings about the centre serve the profile's shape fit; the load reads the
        // half-depth component itself.
        let centre = self.window_centre(&feats, (x0, y0));
        let b_px = load::enclosing_radius_px(&contact, bw, centre);
        let rings = load::rings(&pass.depth_um, bw, centre, PROFILE_REACH * b_px);
        let shape = ctx.shapes.fit(&rings);
        let mut resolved = apex.resolved && map_peak_um >= RESOLVED_THRESHOLDS * threshold_um;
        // Neither family describes the profile: a punch too narrow to show its plateau reads
        // deep by what the sphere's correction took out and its own blur did not.
        let punch_open = shape.shape == Shape::Unknown
            && punch_beyond_tolerance(ctx.blur_loss.punch_excess(apex.q), feats.peak_mm);
        if shape.shape == Shape::Flat {
            // A plateau's level, not a dome's blurred apex.
            feats.peak_mm = (shape.depth / 1000.0) as f32;
            resolved = true;
        }
        let px_mm = ctx.mm_per_px * self.factor as f32;
        let load_mm2 = load::footprint_load_mm2(&pass.depth_um, bw, &contact, px_mm);
        let inputs = Self::force_inputs(&feats, &pass, load_mm2, px_mm);
        let apex_px = (x0 + apex.at % bw, y0 + apex.at / bw);
        let limits = Limits {
            coarse: self.coarse,
            margin: self.margin,
            win: &win,
            pass: &pass,
            up: &up,
            amp_medians: self.amp_medians,
            unwrap: (unreached, residues),
            resolved,
            shape: shape.shape,
            skirt_free: self.bg.skirt_free(threshold_um, 1000.0 * feats.peak_mm),
            apex_px,
        };
        let mut flags = limits.flags(&inputs, carrier, ctx);
        if punch_open || shape.level_open {
            flags.insert(Flag::DepthUncertain);
        }
        // A shallow contact standing mostly where the pigment's colour changed may be that
        // change's pull alone, with nothing pressed.
        let (faint, edge) = amplitudes();
        if map_peak_um < self.recoloured_limit_um(threshold_um, edge.log_span(apex_px))
            && mostly_recoloured((&pass.depth_um, &contact), (faint, edge), (x0, y0, bw))
        {
            flags.insert(Flag::FaintContact);
        }
        // Half the contact's depth reaching where the kernel averages padding: the contact
        // may run on past the image, and nothing beyond it is seen.
        if !window_inside && !contact.iter().all(kernel_inside) {
            flags.insert(Flag::ContactAtEdge);
        }
        let (force_n, beyond) = bounded_force(ctx.calib, &inputs);
        if beyond {
            flags.insert(Flag::ForceOutOfRange);
        }
        Some(ContactResult {
            feats,
            map_peak_um,
            inputs,
            flags,
            force_n,
            shape: shape.shape,
            threshold_um,
            depth_um: pass.depth_um,
            origin: (x0, y0),
            size: (bw, bh),
        })
    }
}

/// A contact's apex, its map's value there, its half-depth component and features (their
/// `peak_mm` the peak as reported, the blur taken out).
struct ContactPeak {
    apex: apex::Apex,
    map_peak_um: i32,
    contact: Vec<usize>,
    feats: Features,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The depths [`depths_doubted_mm`] names are those [`depth_model_doubts`] flags, depth
    /// by depth: a floor alone doubts the shallow presses, a share alone the deep ones, both
    /// can doubt either end, and a small error none.
    #[test]
    fn the_depths_named_doubted_are_the_depths_flagged() {
        let at = |floor_mm: f64, share: f64| DepthError { floor_mm, share };
        let cases = [
            (at(0.03, 0.0), (true, false)),
            (at(0.0, 0.025), (false, true)),
            (at(0.012, 0.02), (true, true)),
            (at(0.005, 0.005), (false, false)),
            (at(0.05, 0.05), (true, true)),
            (at(f64::NAN, 0.0), (false, false)),
        ];
        for (e, (shallow, deep)) in cases {
            let (under_mm, over_mm) = depths_doubted_mm(e);
            for k in 1..=600 {
                // Off the roots themselves, where rounding may go either way.
                let d = f64::from(k) * 0.01 + 0.0037;
                let named = d < under_mm || over_mm.is_some_and(|o| d > o);
                assert_eq!(depth_model_doubts(e, d), named, "{e:?} at {d} mm");
            }
            assert_eq!(depth_model_doubts(e, 0.05), shallow, "{e:?}");
            assert_eq!(depth_model_doubts(e, 5.0), deep, "{e:?}");
        }
    }

    /// The temperature's reliability map cut from a contact's narrower one ([`within`]) is
    /// the map [`reliable_pixels`] builds on the background's margin: odd and even sizes and
    /// margins, equal margins, and a background margin wider than the image.
    #[test]
    fn a_contact_map_cut_to_the_background_margin_is_the_background_map() {
        let mut rng = crate::test_rng::XorShift(0x9e37_79b9_7f4a_7c15);
        for ((w, h), (m_bg, m_contact)) in [
            ((320usize, 240usize), (24usize, 16usize)),
            ((37, 23), (5, 3)),
            ((38, 17), (7, 4)),
            ((40, 30), (6, 6)),
            ((9, 7), (20, 3)),
        ] {
            let grid = Grid::of((w, h));
            let cw = grid.coarse.0;
            let n = cw * grid.coarse.1;
            let bright: Vec<bool> = (0..n).map(|_| !rng.next().is_multiple_of(5)).collect();
            let (bg, contact) = (Margin::new(m_bg, w, h), Margin::new(m_contact, w, h));
            // As `read_coarse` marks them: bright and inside the margin at the sample.
            let samples = |m: &Margin| -> Vec<bool> {
                (0..n)
                    .map(|k| bright[k] && m.contains(GRID * (k % cw), GRID * (k / cw)))
                    .collect()
            };
            let cut = within(reliable_pixels(&samples(&contact), &grid, &contact), w, &bg);
            let direct = reliable_pixels(&samples(&bg), &grid, &bg);
            assert!(direct.iter().any(|&r| r) || m_bg * 2 >= w.min(h));
            assert_eq!(cut, direct, "{w}×{h}, margins {m_bg} and {m_contact}");
        }
    }
}
