//! From a wrapped phase-difference map to a [`Deformation`]: registration, noise floor,
//! early exit, contact tiles, unwrapping where needed, depth, features and quality flags.
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

mod coarse;
mod features;
mod phase;
mod window;

pub use coarse::{contact_tiles, local_noise_units};
pub use features::{force_of, summarize, Features};
pub use phase::{PhaseMap, PhaseNum, WrappedPhase, UNITS_PER_RAD};
pub use window::upsample2;

use coarse::{dilate, median, read_coarse, samples_in, Coarse, Margin, NOISE_STEP};
use features::slope_p98_exceeds;

use super::carrier::Carrier;
use super::float_ftp::BAND_HALF_WIDTH;
use super::unwrap::unwrap_window;
use super::{Deformation, TILE_PX};
use crate::calibration::Calibration;

/// Contact needs the phase to exceed this many noise σ.
pub const CONTACT_SIGMAS: f32 = 6.0;
/// …and at least this much, rad (a floor for very clean frames).
pub const MIN_CONTACT_RAD: f32 = 0.02;
/// Step of the coarse grid, working pixels each way: registration, noise, contrast and
/// contact detection read the phase every `GRID`-th pixel (the analytic signal is smooth
/// over a carrier period, 6–12 working pixels); the contact region is read at every pixel.
pub const GRID: usize = 2;
/// Coarse samples above threshold a tile needs to count as contact (of the 16 a tile has).
pub const TILE_MIN_SAMPLES: usize = 2;
/// Unwrap only when some phase in the contact region exceeds this, rad (below it nothing
/// can have wrapped: the background is at 0 and the phase is continuous).
pub const UNWRAP_TRIGGER_RAD: f32 = 0.6 * std::f32::consts::PI;
/// A pixel is unreliable when its fringe amplitude is below this fraction of the
/// reference's median.
pub const RELIABLE_AMPLITUDE: f32 = 0.3;
/// Low contrast: the frame's median fringe amplitude below this fraction of the reference's
/// (the stability sweep: depth is still within tolerance at 0.35 of the unit's contrast
/// and lost at 0.25).
pub const LOW_CONTRAST_RATIO: f32 = 0.32;
/// Phase noise (1σ per working pixel) above which the fringes count as too weak for the
/// sensor's noise, rad. The stability sweep: depth stays within tolerance up to 0.021 rad
/// (12× the reference build's sensor noise) and starts to leave it at 0.027 rad (16×); a
/// 2.5 mm press reads 0.019 rad (its residual raises the estimate).
pub const NOISY_RAD: f32 = 0.024;
/// Depth beyond the deepest calibrated indentation by this factor is flagged.
pub const DEPTH_RANGE_SLACK: f64 = 1.1;
/// Phase-slope flag: local phase slope (98th percentile over the deformed pixels) above
/// this fraction of the band half-width. An unseen unit (seed 54: 20 px period at 320×240)
/// read a 2.5 mm press within tolerance (2.534 mm) at 0.56; the stability sweeps hold at
/// 0.6.
pub const SLOPE_LIMIT: f32 = 0.6;
/// A region whose opposite-signed phase exceeds this fraction of its indentation-signed
/// phase is a thermal or shading dipole, not a contact.
pub const DIPOLE_RATIO: f32 = 0.35;
/// Phase-slope flag: more than this fraction of the deformed pixels lost half their fringe
/// amplitude.
pub const BAND_LOSS_FRACTION: f32 = 0.01;
/// …and at least this many coarse samples ([`GRID`]² working pixels each).
pub const BAND_LOSS_MIN: usize = 2;
/// Phase-slope flag: a contact area below this fraction of the calibrated indenter's area at
/// the same depth.
pub const SHARPNESS_RATIO: f64 = 0.7;
/// Misregistration flag: a global offset beyond this, rad (0.4 of a period: up to there the
/// offset is removed exactly; towards half a period it becomes ambiguous).
pub const MISREGISTRATION_RAD: f32 = 0.8 * std::f32::consts::PI;
/// Over-exposure flag: more than this fraction of newly saturated pixels.
pub const OVER_EXPOSED_FRACTION: f32 = 0.002;
/// Residues in the contact region tolerated before the unwrap is distrusted.
pub const MAX_RESIDUES: usize = 2;

/// What the measurement needs besides the phase.
#[derive(Debug, Clone, Copy)]
pub struct Context<'a> {
    /// The calibration.
    pub calib: &'a Calibration,
    /// Input scale, mm per pixel.
    pub mm_per_px: f32,
    /// Fraction of the reference's pixels with a saturated channel.
    pub ref_saturated_fraction: f32,
    /// When to unwrap the contact region's phase.
    pub unwrap: Unwrap,
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
) -> (Deformation, WrappedPhase) {
    let (w, h) = map.size();
    let n = w * h;
    let (cw, ch) = (w.div_ceil(GRID), h.div_ceil(GRID));
    let (tw, th) = (w.div_ceil(TILE_PX), h.div_ceil(TILE_PX));
    let med_ref = map.amp_ref_median().max(1);
    let lim = (u64::from(med_ref) * (RELIABLE_AMPLITUDE * 1024.0) as u64 / 1024) as u32;
    // The two box passes reach one period each way: pixels within a period and a half of
    // the edge are not trusted.
    let margin = Margin::new((1.5 * carrier.period_px()).ceil() as usize, w, h);

    let Coarse {
        phase,
        amp,
        amp_r,
        rel,
        inside_n,
        reliable_n,
    } = read_coarse(map, lim, &margin);
    let mut flags = QualityFlags::NONE;
    // The frame's median fringe amplitude, over every fourth coarse sample (as many as the
    // noise floor's).
    let med_frame = median(
        amp.iter()
            .step_by(NOISE_STEP * NOISE_STEP)
            .copied()
            .collect(),
    );
    if (med_frame as f32) < LOW_CONTRAST_RATIO * med_ref as f32 || reliable_n * 2 < inside_n {
        flags.insert(Flag::LowContrast);
    }
    if map.saturated_fraction() - ctx.ref_saturated_fraction > OVER_EXPOSED_FRACTION {
        flags.insert(Flag::OverExposure);
    }

    // Registration: amplitude-weighted mean direction of the background phase; first over
    // everything, then without outliers, then outside the contact region once it is known.
    // Each later set is the reliable samples less some: its resultant is the whole's less
    // that of the samples it drops (`dropped`), or, when it keeps fewer than it drops, its
    // own.
    let dropped = |keep: &[bool]| {
        let mask: Vec<bool> = rel.iter().zip(keep).map(|(r, k)| *r && !*k).collect();
        <M::P as PhaseNum>::masked_resultant(&phase, &amp, &mask)
    };
    // Every sample, an unreliable one weighing nothing (no branch per sample).
    let all = <M::P as PhaseNum>::resultant(
        phase
            .iter()
            .zip(&amp)
            .zip(&rel)
            .map(|((p, a), r)| (*p, a * u32::from(*r))),
    );
    // The direction of the reliable samples where `keep` holds.
    let direction = |keep: &[bool]| <M::P as PhaseNum>::angle(all - dropped(keep));
    let first = <M::P as PhaseNum>::angle(all);
    let near = <M::P as PhaseNum>::from_rad(0.5).units();
    let close: Vec<bool> = phase
        .iter()
        .map(|p| p.minus(first).units().abs() < near)
        .collect();
    let mut offset = direction(&close);
    let units_of =
        |offset: M::P| -> Vec<i32> { phase.iter().map(|p| p.minus(offset).units()).collect() };
    let mut phi = units_of(offset);
    let box_c = ((2.0 * carrier.period_px()) / GRID as f32).round().max(2.0) as usize;
    let min_thr = <M::P as PhaseNum>::from_rad(MIN_CONTACT_RAD).units();
    let mut noise = local_noise_units(&phi, &rel, cw, ch, box_c);
    let mut thr = ((CONTACT_SIGMAS * noise as f32) as i32).max(min_thr);
    let sign: i32 = if ctx.calib.phase_sign < 0.0 { -1 } else { 1 };
    // A disc one period across, in coarse samples.
    let min_total = ((carrier.period_px() / GRID as f32).powi(2) * std::f32::consts::FRAC_PI_4)
        .round()
        .max(TILE_MIN_SAMPLES as f32) as usize;
    let mut found = contact_tiles(&phi, &rel, thr, (cw, ch), (tw, th), min_total);
    // Whether the noise was measured on the background alone (a contact's curvature
    // counts as noise in the first estimate).
    let mut noise_clean = found.is_none();
    if let Some((region, _)) = &found {
        // With the contact known, registration and noise come from the background only:
        // the reliable samples outside a set of tiles (`inside`: the samples in them).
        let outside = |inside: &[bool]| -> Vec<bool> {
            inside.iter().zip(&rel).map(|(r, ok)| !r && *ok).collect()
        };
        let in_region = samples_in(region, (cw, ch), tw);
        let background = outside(&in_region);
        // Registration from the background a tile further out still: an indentation's
        // skirt (the skin around a contact sinks with it, and the band-pass spreads it a
        // period further) stays below the contact threshold but moves the mean. A mean
        // direction needs few samples (4 tiles' worth, 64: a σ/8 estimate); with fewer
        // than that beyond the skirt, the nearer background; with fewer there too (a
        // contact filling the view), there is nothing outside the contact to register on,
        // and the frame is taken as unshifted: on unit 55 the last few samples around a
        // 2.5 mm press read −0.18 rad, a twentieth of its depth.
        //
        // A background's direction sums whichever is smaller: its own samples, or those it
        // drops (taken off the whole's resultant). A large contact leaves few.
        let tile_samples = (TILE_PX / GRID) * (TILE_PX / GRID);
        let beyond = |keep: &[bool]| {
            let kept = keep.iter().filter(|k| **k).count();
            (kept >= 4 * tile_samples).then(|| {
                if 2 * kept < reliable_n {
                    <M::P as PhaseNum>::angle(<M::P as PhaseNum>::masked_resultant(
                        &phase, &amp, keep,
                    ))
                } else {
                    direction(keep)
                }
            })
        };
        let far = outside(&samples_in(&dilate(region, tw, th), (cw, ch), tw));
        offset = beyond(&far)
            .or_else(|| beyond(&background))
            .unwrap_or(<M::P as PhaseNum>::from_units(0));
        phi = units_of(offset);
        // The background must be big enough to measure; otherwise keep the first estimate.
        if in_region.iter().filter(|r| !**r).count() * 4 > phi.len() {
            noise = local_noise_units(&phi, &background, cw, ch, box_c);
            noise_clean = true;
        }
        thr = ((CONTACT_SIGMAS * noise as f32) as i32).max(min_thr);
        found = contact_tiles(&phi, &rel, thr, (cw, ch), (tw, th), min_total);
    }
    let offset_rad = offset.units() as f32 / UNITS_PER_RAD;
    if offset_rad.abs() > MISREGISTRATION_RAD {
        flags.insert(Flag::Misregistration);
    }
    let noise_rad = noise as f32 / UNITS_PER_RAD;
    // Fringes too weak for the sensor's noise; not judged when a contact covering most of
    // the view left no background to measure the noise on (the amplitude tests above
    // still are).
    if noise_clean && noise_rad > NOISY_RAD {
        flags.insert(Flag::LowContrast);
    }
    // Reliability per working pixel, from the coarse grid (the region's window refines it).
    let mut reliable = vec![false; n];
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
    let mut wrapped = WrappedPhase {
        cw,
        coarse: phase.iter().map(|p| p.units()).collect(),
        local: None,
    };
    // A result without contact; the contact's fields are filled in below when there is one.
    let result = |flags, reliable: Vec<bool>, depth_um: Vec<i32>| Deformation {
        w,
        h,
        factor,
        depth_um,
        reliable,
        contact: false,
        peak_depth_mm: 0.0,
        contact_area_mm2: 0.0,
        volume_mm3: 0.0,
        centroid_px: None,
        integrated_phase_rad_mm2: 0.0,
        force_n: 0.0,
        flags,
        noise_rad,
        offset_rad,
        floor_um: 0,
        tiles: 0,
        window: None,
        temperature: None,
    };
    // The region is found on |Δφ|: at the centre of a deep press the wrapped phase has
    // wrapped to the other sign, and it must be unwrapped, not seeded from. Only
    // indentation (positive signed phase) is reported as depth.
    let Some((tiles_on, tiles)) = found else {
        return (result(flags, reliable, vec![0; n]), wrapped);
    };

    // The region on the coarse grid, in a window around it: two samples of border, which
    // seed the unwrapping and feed the interpolation.
    let creg = samples_in(&tiles_on, (cw, ch), tw);
    // Its bounding box in coarse samples: that of the tiles, each `PER` samples square,
    // clipped to the grid as `samples_in` clips them.
    const PER: usize = TILE_PX / GRID;
    let (mut tx0, mut ty0, mut tx1, mut ty1) = (tw, th, 0, 0);
    for (ty, row) in tiles_on.chunks_exact(tw).enumerate() {
        if let (Some(a), Some(b)) = (row.iter().position(|t| *t), row.iter().rposition(|t| *t)) {
            (tx0, ty0, tx1, ty1) = (tx0.min(a), ty0.min(ty), tx1.max(b), ty1.max(ty));
        }
    }
    let (cx0, cy0) = (tx0 * PER, ty0 * PER);
    let (cx1, cy1) = (((tx1 + 1) * PER).min(cw) - 1, ((ty1 + 1) * PER).min(ch) - 1);
    let (wx0, wy0) = (cx0.saturating_sub(2), cy0.saturating_sub(2));
    let (wx1, wy1) = ((cx1 + 3).min(cw), (cy1 + 3).min(ch));
    let (cbw, cbh) = (wx1 - wx0, wy1 - wy0);
    let (wxs, wys) = ((wx0, wx1), wy0..wy1);
    let lphi: Vec<M::P> = window_of(&phase, cw, wxs, wys.clone())
        .into_iter()
        .map(|p| p.minus(offset))
        .collect();
    let lreg: Vec<bool> = window_of(&creg, cw, wxs, wys.clone());

    let trigger = <M::P as PhaseNum>::from_rad(UNWRAP_TRIGGER_RAD).units();
    // Over the region (a sample outside it counts 0, which no |phase| is below).
    let max_abs = lphi
        .iter()
        .zip(&lreg)
        .map(|(p, &r)| if r { p.units().abs() } else { 0 })
        .max()
        .unwrap_or(0);
    let unwrap = match ctx.unwrap {
        Unwrap::WhenNeeded => max_abs > trigger,
        Unwrap::Always => true,
        Unwrap::Never => false,
    };
    let (u, unreached, n_res) = if unwrap {
        unwrap_window(&lphi, &lreg, cbw, cbh, || {
            let (a, r) = (
                window_of(&amp, cw, wxs, wys.clone()),
                window_of(&amp_r, cw, wxs, wys),
            );
            a.iter().zip(&r).map(|(a, r)| *a.min(r)).collect()
        })
    } else {
        (lphi, 0, 0)
    };
    // Indentation phase (signed), units.
    let su: Vec<i32> = u.iter().map(|p| p.signed(sign).units()).collect();

    // Every working pixel of the window: the indentation phase upsampled ×2 each way by
    // cubic convolution (midpoint weights −1, 9, 9, −1 over 16: exact for quadratics, so a
    // round contact's peak is not shaved), then depth through the calibration. The
    // analytic signal is smooth over a carrier period, so the coarse samples hold it.
    let up = upsample2(&su, cbw, cbh);
    let (bw, bh) = (GRID * cbw - 1, GRID * cbh - 1);
    let (x0, y0) = (GRID * wx0, GRID * wy0);
    let m = bw * bh;
    // The window's pixels that belong to the region (all inside the image: the coarse
    // grid's last sample is at most the last pixel).
    let mut won = vec![false; m];
    for ly in 0..bh {
        // The rows of one tile row are the same: the first is built, the others copied.
        if ly > 0 && (y0 + ly) % TILE_PX != 0 {
            won.copy_within((ly - 1) * bw..ly * bw, ly * bw);
            continue;
        }
        let trow = &tiles_on[((y0 + ly) / TILE_PX) * tw..((y0 + ly) / TILE_PX + 1) * tw];
        for (lx, o) in won[ly * bw..(ly + 1) * bw].iter_mut().enumerate() {
            *o = trow[(x0 + lx) / TILE_PX];
        }
    }
    let from_units = <M::P as PhaseNum>::from_units;
    // Depth is reported (and counted in the volume) only above the depth of the contact
    // threshold: the map carries deformation, not noise.
    let thr_um = map.depth_um(from_units(thr));
    let off_units = offset.units();
    let raw: Vec<i32> = up
        .iter()
        .map(|&v| i32::from((sign * v).wrapping_add(off_units) as i16))
        .collect();
    wrapped.local = Some((x0, y0, bw, bh, raw));
    // One pass over the window's region: depth, the deformed pixels (the region's, deeper
    // than the threshold) and their integrated phase, and the dipole test's sums. An
    // indentation moves the phase one way. A temperature gradient across the stripes (or a
    // grating shifted under an illumination edge) skews their brightness profile and moves
    // it both ways around the spot (a dipole): when the opposite-signed phase carries a
    // comparable share, there is no contact to report.
    let mut depth_local = vec![0i32; m];
    let mut deformed = vec![false; m];
    let (mut pos, mut neg, mut integrated_units) = (0i64, 0i64, 0i64);
    let rows = up.chunks_exact(bw).zip(won.chunks_exact(bw)).zip(
        depth_local
            .chunks_exact_mut(bw)
            .zip(deformed.chunks_exact_mut(bw)),
    );
    for (ly, ((urow, orow), (drow, frow))) in rows.enumerate() {
        let rrow = &reliable[(y0 + ly) * w + x0..(y0 + ly) * w + x0 + bw];
        for ((((&v, &on), &ok), d), f) in urow.iter().zip(orow).zip(rrow).zip(drow).zip(frow) {
            if !on {
                continue;
            }
            let z = map.depth_um(from_units(v));
            if z > thr_um {
                (*d, *f) = (z, true);
                integrated_units += i64::from(v);
            }
            if ok {
                if v > thr {
                    pos += i64::from(v);
                } else if v < -thr {
                    neg -= i64::from(v);
                }
            }
        }
    }
    if (neg as f32) > DIPOLE_RATIO * pos as f32 {
        return (result(flags, reliable, vec![0; n]), wrapped);
    }
    let feats = summarize(&depth_local, bw, (x0, y0), factor, ctx.mm_per_px, thr_um);
    if feats.peak_mm == 0.0 {
        return (result(flags, reliable, vec![0; n]), wrapped);
    }
    let px_mm = ctx.mm_per_px * factor as f32;
    let integrated = integrated_units as f32 / UNITS_PER_RAD * px_mm * px_mm;
    let slope_limit = SLOPE_LIMIT * 65_536.0 * BAND_HALF_WIDTH * carrier.freq();
    // Beyond the band the demodulator cannot even report the slope; what it shows is the
    // fringe amplitude falling (by the filter's response at the local frequency offset).
    // Deformed samples whose amplitude fell below half the reference's (after the frame's
    // overall contrast change, so a dimmer or washed-out frame does not count), or that
    // became unreliable, mean the spectrum has left the band there.
    let (mut lost, mut seen) = (0usize, 0usize);
    let (fm, rm) = (u64::from(med_frame.max(1)), u64::from(med_ref));
    for (cx, cy) in (wy0..wy1).flat_map(|cy| (wx0..wx1).map(move |cx| (cx, cy))) {
        let (x, y) = (cx * GRID, cy * GRID);
        let lj = (y - y0) * bw + (x - x0);
        if lj >= m || !deformed[lj] || !margin.contains(x, y) {
            continue;
        }
        let k = cy * cw + cx;
        seen += 1;
        if !rel[k] || u64::from(amp[k]) * 2 * rm < u64::from(amp_r[k]) * fm {
            lost += 1;
        }
    }
    let band_lost = lost as f32 > BAND_LOSS_FRACTION * seen as f32 && lost >= BAND_LOSS_MIN;
    // A contact much sharper than the calibrated indenter (less area at the same depth) is
    // smoothed by the band more than the calibration knows: its depth reads low.
    let sharper = ctx.calib.shape.as_ref().is_some_and(|s| {
        f64::from(feats.area_mm2) < SHARPNESS_RATIO * s.area_mm2_at(f64::from(feats.peak_mm))
    });
    if sharper || band_lost || slope_p98_exceeds(&up, &deformed, bw, bh, slope_limit) {
        flags.insert(Flag::PhaseSlope);
    }
    if unreached > 0 || n_res > MAX_RESIDUES {
        flags.insert(Flag::UnwrapFailure);
    }
    // Deeper than the calibration saw: the depth model extrapolates.
    if ctx
        .calib
        .calibrated_depth_mm()
        .is_some_and(|d| f64::from(feats.peak_mm) > DEPTH_RANGE_SLACK * d)
    {
        flags.insert(Flag::DepthOutOfRange);
    }
    let force_n = force_of(ctx.calib, &feats, integrated);
    let mut depth_um = vec![0; n];
    let cols = bw.min(w - x0);
    for ly in 0..bh.min(h - y0) {
        let row = (y0 + ly) * w + x0;
        depth_um[row..row + cols].copy_from_slice(&depth_local[ly * bw..ly * bw + cols]);
    }
    let d = Deformation {
        contact: true,
        peak_depth_mm: feats.peak_mm,
        contact_area_mm2: feats.area_mm2,
        volume_mm3: feats.volume_mm3,
        centroid_px: feats.centroid_px,
        integrated_phase_rad_mm2: integrated,
        force_n,
        tiles,
        floor_um: thr_um,
        window: Some([x0, y0, x0 + cols, y0 + bh.min(h - y0)]),
        ..result(flags, reliable, depth_um)
    };
    (d, wrapped)
}

/// The samples of a coarse map (`cw` across) in the window of columns `xs` and rows `ys`,
/// row by row.
fn window_of<T: Copy>(
    v: &[T],
    cw: usize,
    xs: (usize, usize),
    ys: std::ops::Range<usize>,
) -> Vec<T> {
    let mut out = Vec::with_capacity((xs.1 - xs.0) * ys.len());
    for cy in ys {
        out.extend_from_slice(&v[cy * cw + xs.0..cy * cw + xs.1]);
    }
    out
}
