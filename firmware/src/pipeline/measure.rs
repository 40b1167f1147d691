//! From a wrapped phase-difference map to a [`Deformation`]: registration, noise floor,
//! early exit, contact tiles, unwrapping where needed, depth, features and quality flags.
//!
//! Thresholds are set from what each frame measures, never magic depths: the noise floor is
//! the robust spread (1.4826 × MAD) of the background phase, contact needs
//! [`CONTACT_SIGMAS`] times that, and the volume counts pixels deeper than the depth of
//! that phase.

use vistaf_protocol::{Flag, QualityFlags};

use super::carrier::Carrier;
use super::float_ftp::BAND_HALF_WIDTH;
use super::unwrap::{residues, unwrap_region, Phase};
use super::{Deformation, TILE_PX};
use crate::calibration::{Calibration, ForceFeature};

/// Contact needs the phase to exceed this many noise σ.
pub const CONTACT_SIGMAS: f32 = 6.0;
/// …and at least this much, rad (a floor for very clean frames).
pub const MIN_CONTACT_RAD: f32 = 0.02;
/// Pixels above threshold a tile needs to count as contact.
pub const TILE_MIN_PIXELS: usize = 3;
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
/// Phase-slope flag: local phase slope above this fraction of the band half-width.
pub const SLOPE_LIMIT: f32 = 0.55;
/// A region whose opposite-signed phase exceeds this fraction of its indentation-signed
/// phase is a thermal or shading dipole, not a contact.
pub const DIPOLE_RATIO: f32 = 0.35;
/// Phase-slope flag: more than this fraction of the deformed pixels lost half their fringe
/// amplitude.
pub const BAND_LOSS_FRACTION: f32 = 0.01;
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

/// Features of a depth map.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Features {
    /// Deepest point, mm.
    pub peak_mm: f32,
    /// Area with depth ≥ half the peak, mm².
    pub area_mm2: f32,
    /// Σ depth × pixel area over pixels deeper than the threshold, mm³.
    pub volume_mm3: f32,
    /// Depth-weighted centre of the contact area, input pixels.
    pub centroid_px: Option<(f32, f32)>,
}

/// Features of a working-resolution depth map (µm), in integer sums: shared by both paths.
pub fn summarize(
    depth_um: &[i32],
    w: usize,
    factor: usize,
    mm_per_px: f32,
    thr_um: i32,
) -> Features {
    let peak = depth_um.iter().copied().max().unwrap_or(0).max(0);
    if peak <= thr_um {
        return Features::default();
    }
    let half = peak / 2;
    let (mut vol, mut n_area) = (0i64, 0i64);
    for &d in depth_um {
        if d > thr_um {
            vol += i64::from(d);
        }
        if d >= half && d > thr_um {
            n_area += 1;
        }
    }
    // The centre is that of the contact holding the peak (its 8-connected component above
    // half the peak), so a second, shallower blob cannot drag it.
    let h = depth_um.len() / w.max(1);
    let start = depth_um.iter().position(|&d| d == peak).unwrap_or(0);
    let (mut wx, mut wy, mut ws) = (0i64, 0i64, 0i64);
    let mut seen = vec![false; depth_um.len()];
    let mut stack = vec![start];
    seen[start] = true;
    while let Some(i) = stack.pop() {
        let (x, y) = (i % w, i / w);
        let d = i64::from(depth_um[i]);
        wx += d * x as i64;
        wy += d * y as i64;
        ws += d;
        for ny in y.saturating_sub(1)..(y + 2).min(h) {
            for nx in x.saturating_sub(1)..(x + 2).min(w) {
                let j = ny * w + nx;
                if !seen[j] && depth_um[j] >= half && depth_um[j] > thr_um {
                    seen[j] = true;
                    stack.push(j);
                }
            }
        }
    }
    let px_mm = mm_per_px * factor as f32;
    let px_area = px_mm * px_mm;
    let to_input = |v: f32| (v + 0.5) * factor as f32;
    Features {
        peak_mm: peak as f32 / 1000.0,
        area_mm2: n_area as f32 * px_area,
        volume_mm3: vol as f32 / 1000.0 * px_area,
        centroid_px: (ws > 0).then(|| {
            (
                to_input(wx as f32 / ws as f32),
                to_input(wy as f32 / ws as f32),
            )
        }),
    }
}

/// Force from the calibration's model.
pub fn force_of(calib: &Calibration, f: &Features, integrated_phase: f32) -> f32 {
    let Some(fm) = &calib.force else { return 0.0 };
    let u = match fm.model.feature {
        ForceFeature::Volume => f.volume_mm3,
        ForceFeature::IntegratedPhase => integrated_phase,
        ForceFeature::ContactArea => f.area_mm2,
        ForceFeature::PeakDepth => f.peak_mm,
    };
    fm.model.force_n(f64::from(u)) as f32
}

/// Active contact tiles, dilated by one tile, as a pixel mask; `None` when there is none.
pub fn contact_region(
    above: impl Fn(usize) -> bool,
    w: usize,
    h: usize,
) -> Option<(Vec<bool>, usize)> {
    let (tw, th) = (w.div_ceil(TILE_PX), h.div_ceil(TILE_PX));
    let mut active = vec![false; tw * th];
    let mut any = false;
    for ty in 0..th {
        for tx in 0..tw {
            let mut n = 0;
            for y in ty * TILE_PX..((ty + 1) * TILE_PX).min(h) {
                for x in tx * TILE_PX..((tx + 1) * TILE_PX).min(w) {
                    n += usize::from(above(y * w + x));
                }
            }
            if n >= TILE_MIN_PIXELS {
                active[ty * tw + tx] = true;
                any = true;
            }
        }
    }
    if !any {
        return None;
    }
    let mut dil = vec![false; tw * th];
    for ty in 0..th {
        for tx in 0..tw {
            if active[ty * tw + tx] {
                for y in ty.saturating_sub(1)..(ty + 2).min(th) {
                    for x in tx.saturating_sub(1)..(tx + 2).min(tw) {
                        dil[y * tw + x] = true;
                    }
                }
            }
        }
    }
    let tiles = dil.iter().filter(|t| **t).count();
    let mask = (0..w * h)
        .map(|i| dil[(i / w / TILE_PX) * tw + (i % w) / TILE_PX])
        .collect();
    Some((mask, tiles))
}

/// Phase units per radian in the integer representation (65 536 per turn).
pub const UNITS_PER_RAD: f32 = 65_536.0 / std::f32::consts::TAU;

/// A phase representation the measurement can run on.
pub trait PhaseNum: Phase {
    /// `self − offset`, wrapped.
    fn minus(self, offset: Self) -> Self {
        Self::wrapped_diff(self, offset)
    }
    /// The value in integer phase units (2π = 65 536), for statistics.
    fn units(self) -> i32;
    /// A value from radians.
    fn from_rad(r: f32) -> Self;
    /// `sign · self` for a sign of ±1.
    fn signed(self, sign: i32) -> Self;
}

impl PhaseNum for f32 {
    fn units(self) -> i32 {
        (self * UNITS_PER_RAD).round() as i32
    }
    fn from_rad(r: f32) -> f32 {
        r
    }
    fn signed(self, sign: i32) -> f32 {
        self * sign as f32
    }
}

impl PhaseNum for i32 {
    fn units(self) -> i32 {
        self
    }
    fn from_rad(r: f32) -> i32 {
        (r * UNITS_PER_RAD).round() as i32
    }
    fn signed(self, sign: i32) -> i32 {
        self * sign
    }
}

/// A wrapped phase-difference map with fringe amplitudes: what either path hands to the
/// measurement.
pub trait PhaseMap {
    /// Phase representation.
    type P: PhaseNum;
    /// Working width and height.
    fn size(&self) -> (usize, usize);
    /// Wrapped phase difference at pixel `i`.
    fn wrapped(&self, i: usize) -> Self::P;
    /// Fringe amplitude of the frame at `i` (any fixed scale shared with `amp_ref`).
    fn amp_frame(&self, i: usize) -> u32;
    /// Fringe amplitude of the reference at `i`.
    fn amp_ref(&self, i: usize) -> u32;
    /// Median reference amplitude (computed once per reference).
    fn amp_ref_median(&self) -> u32;
    /// Amplitude-weighted mean direction of the phase over the pixels `keep` accepts.
    fn mean_direction(&self, keep: &dyn Fn(usize) -> bool) -> Self::P;
    /// Fraction of the frame's input pixels with a saturated channel.
    fn saturated_fraction(&self) -> f32;
    /// Depth (µm) of an indentation phase `x` (already signed, ≥ 0 under indentation).
    fn depth_um(&self, x: Self::P) -> i32;
}

fn median_u32(mut v: Vec<u32>) -> u32 {
    if v.is_empty() {
        return 0;
    }
    let k = v.len() / 2;
    *v.select_nth_unstable(k).1
}

/// Phase noise (1σ, phase units): the robust spread of the phase minus its local mean over
/// a box of `box_px` (about two periods), so smooth deformation does not count as noise.
pub fn local_noise_units(phi: &[i32], reliable: &[bool], w: usize, h: usize, box_px: usize) -> i32 {
    let r = (box_px / 2).max(1);
    let mut ii = vec![0i64; (w + 1) * (h + 1)];
    for y in 0..h {
        let mut row = 0i64;
        for x in 0..w {
            row += i64::from(phi[y * w + x]);
            ii[(y + 1) * (w + 1) + x + 1] = ii[y * (w + 1) + x + 1] + row;
        }
    }
    let area = ((2 * r + 1) * (2 * r + 1)) as i64;
    let mut dev = Vec::new();
    for y in (r..h.saturating_sub(r)).step_by(2) {
        for x in (r..w.saturating_sub(r)).step_by(2) {
            let i = y * w + x;
            if !reliable[i] {
                continue;
            }
            let (x0, x1, y0, y1) = (x - r, x + r + 1, y - r, y + r + 1);
            let sum = ii[y1 * (w + 1) + x1] - ii[y0 * (w + 1) + x1] - ii[y1 * (w + 1) + x0]
                + ii[y0 * (w + 1) + x0];
            dev.push(
                (i64::from(phi[i]) * area - sum)
                    .unsigned_abs()
                    .div_ceil(area as u64) as u32,
            );
        }
    }
    // 1.4826 × MAD, in integers (×1518 / 1024).
    ((i64::from(median_u32(dev)) * 1518 / 1024) as i32).max(1)
}

/// 98th percentile of the phase slope (units per working pixel) over `mask`.
fn slope_p98(u: &[i32], mask: &[bool], w: usize, h: usize) -> i32 {
    let mut s = Vec::new();
    for y in 1..h.saturating_sub(1) {
        for x in 1..w.saturating_sub(1) {
            let i = y * w + x;
            if mask[i] {
                let gx = i64::from(u[i + 1] - u[i - 1]) / 2;
                let gy = i64::from(u[i + w] - u[i - w]) / 2;
                s.push(((gx * gx + gy * gy) as f64).sqrt() as u32);
            }
        }
    }
    if s.is_empty() {
        return 0;
    }
    let k = (s.len() * 98 / 100).min(s.len() - 1);
    *s.select_nth_unstable(k).1 as i32
}

/// The measurement, shared by both paths: registration, noise floor, early exit, contact
/// tiles, unwrapping where needed, depth, features and flags.
pub fn measure<M: PhaseMap>(
    map: &M,
    factor: usize,
    carrier: Carrier,
    ctx: &Context<'_>,
) -> Deformation {
    let (w, h) = map.size();
    let n = w * h;
    let med_ref = map.amp_ref_median().max(1);
    let lim = |m: u32| (u64::from(m) * (RELIABLE_AMPLITUDE * 1024.0) as u64 / 1024) as u32;
    // Near the image edge neither the FFT (periodic wrap) nor the box filters (replicated
    // edges) see a whole neighbourhood: the two box passes reach one period each way, so
    // pixels within a period and a half of the edge are not trusted.
    let margin = (1.5 * carrier.period_px()).ceil() as usize;
    let inside = |i: usize| {
        let (x, y) = (i % w, i / w);
        x >= margin && y >= margin && x + margin < w && y + margin < h
    };
    let reliable: Vec<bool> = (0..n)
        .map(|i| inside(i) && map.amp_ref(i) > lim(med_ref) && map.amp_frame(i) > lim(med_ref))
        .collect();
    let mut flags = QualityFlags::NONE;
    let med_frame = median_u32((0..n).step_by(3).map(|i| map.amp_frame(i)).collect());
    let reliable_n = reliable.iter().filter(|r| **r).count();
    let inside_n = (0..n).filter(|&i| inside(i)).count();
    if (med_frame as f32) < LOW_CONTRAST_RATIO * med_ref as f32 || reliable_n * 2 < inside_n {
        flags.insert(Flag::LowContrast);
    }
    if map.saturated_fraction() - ctx.ref_saturated_fraction > OVER_EXPOSED_FRACTION {
        flags.insert(Flag::OverExposure);
    }

    // Registration: amplitude-weighted mean direction of the background phase; first over
    // everything, then without outliers, then outside the contact region once it is known.
    let first = map.mean_direction(&|i| reliable[i]);
    let near = <M::P as PhaseNum>::from_rad(0.5).units();
    let mut offset =
        map.mean_direction(&|i| reliable[i] && map.wrapped(i).minus(first).units().abs() < near);
    let phase_of =
        |offset: M::P| -> Vec<M::P> { (0..n).map(|i| map.wrapped(i).minus(offset)).collect() };
    let mut phi = phase_of(offset);
    let box_px = (2.0 * carrier.period_px()).round() as usize;
    let noise_outside = |phi: &[M::P], keep: &dyn Fn(usize) -> bool| {
        let units: Vec<i32> = phi.iter().map(|p| p.units()).collect();
        let mask: Vec<bool> = (0..n).map(|i| reliable[i] && keep(i)).collect();
        local_noise_units(&units, &mask, w, h, box_px)
    };
    let min_thr = <M::P as PhaseNum>::from_rad(MIN_CONTACT_RAD).units();
    let mut noise = noise_outside(&phi, &|_| true);
    let mut thr = ((CONTACT_SIGMAS * noise as f32) as i32).max(min_thr);
    let sign: i32 = if ctx.calib.phase_sign < 0.0 { -1 } else { 1 };
    let mut found = contact_region(|i| reliable[i] && phi[i].units().abs() > thr, w, h);
    if let Some((region, _)) = &found {
        // With the contact known, registration and noise come from the background only.
        offset = map.mean_direction(&|i| reliable[i] && !region[i]);
        phi = phase_of(offset);
        // The background must be big enough to measure; otherwise keep the first estimate.
        if region.iter().filter(|r| !**r).count() * 4 > n {
            noise = noise_outside(&phi, &|i| !region[i]);
        }
        thr = ((CONTACT_SIGMAS * noise as f32) as i32).max(min_thr);
        found = contact_region(|i| reliable[i] && phi[i].units().abs() > thr, w, h);
    }
    let offset_rad = offset.units() as f32 / UNITS_PER_RAD;
    if offset_rad.abs() > MISREGISTRATION_RAD {
        flags.insert(Flag::Misregistration);
    }
    let noise_rad = noise as f32 / UNITS_PER_RAD;
    // Fringes too weak for the sensor's noise.
    if noise_rad > NOISY_RAD {
        flags.insert(Flag::LowContrast);
    }
    let empty = |flags| Deformation {
        w,
        h,
        factor,
        depth_um: vec![0; n],
        reliable: reliable.clone(),
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
        temperature: None,
    };
    // The region is found on |Δφ|: at the centre of a deep press the wrapped phase has
    // wrapped to the other sign, and it must be unwrapped, not seeded from. Only
    // indentation (positive signed phase) is reported as depth.
    let Some((region, tiles)) = found else {
        return empty(flags);
    };

    let trigger = <M::P as PhaseNum>::from_rad(UNWRAP_TRIGGER_RAD).units();
    let max_abs = (0..n)
        .filter(|&i| region[i])
        .map(|i| phi[i].units().abs())
        .max()
        .unwrap_or(0);
    let unwrap = match ctx.unwrap {
        Unwrap::WhenNeeded => max_abs > trigger,
        Unwrap::Always => true,
        Unwrap::Never => false,
    };
    let (u, unreached, n_res) = if unwrap {
        let quality: Vec<u32> = (0..n)
            .map(|i| map.amp_frame(i).min(map.amp_ref(i)))
            .collect();
        let (u, unreached) = unwrap_region(&phi, &quality, &region, w, h);
        (u, unreached, residues(&phi, &region, w, h))
    } else {
        (phi, 0, 0)
    };

    // Depth is reported (and counted in the volume) only above the depth of the contact
    // threshold: the map carries deformation, not noise.
    let thr_um = map.depth_um(<M::P as PhaseNum>::from_rad(thr as f32 / UNITS_PER_RAD));
    // An indentation moves the phase one way. A temperature gradient across the stripes
    // skews their brightness profile and moves it both ways around the hot spot (a
    // dipole): when the opposite-signed phase carries a comparable share, there is no
    // contact to report.
    let (mut pos, mut neg) = (0i64, 0i64);
    for i in (0..n).filter(|&i| region[i] && reliable[i]) {
        let x = i64::from(u[i].signed(sign).units());
        if x > i64::from(thr) {
            pos += x;
        } else if x < -i64::from(thr) {
            neg -= x;
        }
    }
    if (neg as f32) > DIPOLE_RATIO * pos as f32 {
        return empty(flags);
    }
    let depth_um: Vec<i32> = (0..n)
        .map(|i| {
            if region[i] {
                map.depth_um(u[i].signed(sign))
            } else {
                0
            }
        })
        .map(|d| if d > thr_um { d } else { 0 })
        .collect();
    let feats = summarize(&depth_um, w, factor, ctx.mm_per_px, thr_um);
    if feats.peak_mm == 0.0 {
        return empty(flags);
    }
    let px_mm = ctx.mm_per_px * factor as f32;
    let integrated_units: i64 = (0..n)
        .filter(|&i| depth_um[i] > thr_um)
        .map(|i| i64::from(u[i].signed(sign).units()))
        .sum();
    let integrated = integrated_units as f32 / UNITS_PER_RAD * px_mm * px_mm;
    let deformed: Vec<bool> = depth_um.iter().map(|&d| d > thr_um).collect();
    let slope_limit = SLOPE_LIMIT * 65_536.0 * BAND_HALF_WIDTH * carrier.freq();
    let u_units: Vec<i32> = u.iter().map(|p| p.units()).collect();
    // Beyond the band the demodulator cannot even report the slope; what it shows is the
    // fringe amplitude falling (by the filter's response at the local frequency offset).
    // Deformed pixels whose amplitude fell below half the reference's (after the frame's
    // overall contrast change, so a dimmer or washed-out frame does not count), or that
    // became unreliable, mean the spectrum has left the band there.
    let (mut lost, mut seen) = (0usize, 0usize);
    let (fm, rm) = (u64::from(med_frame.max(1)), u64::from(med_ref));
    for i in (0..n).filter(|&i| deformed[i] && inside(i)) {
        seen += 1;
        if !reliable[i] || u64::from(map.amp_frame(i)) * 2 * rm < u64::from(map.amp_ref(i)) * fm {
            lost += 1;
        }
    }
    let band_lost = lost as f32 > BAND_LOSS_FRACTION * seen as f32 && lost >= 4;
    // A contact much sharper than the calibrated indenter (less area at the same depth) is
    // smoothed by the band more than the calibration knows: its depth reads low.
    let sharper = ctx.calib.shape.as_ref().is_some_and(|s| {
        f64::from(feats.area_mm2) < SHARPNESS_RATIO * s.area_mm2_at(f64::from(feats.peak_mm))
    });
    if sharper || band_lost || slope_p98(&u_units, &deformed, w, h) as f32 > slope_limit {
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
    Deformation {
        depth_um,
        contact: true,
        peak_depth_mm: feats.peak_mm,
        contact_area_mm2: feats.area_mm2,
        volume_mm3: feats.volume_mm3,
        centroid_px: feats.centroid_px,
        integrated_phase_rad_mm2: integrated,
        force_n,
        tiles,
        floor_um: thr_um,
        ..empty(flags)
    }
}
