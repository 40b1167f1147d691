//! The contact region, read at every working pixel: its window on the coarse grid, the
//! indentation phase unwrapped where it can have wrapped and upsampled, the depth through
//! the calibration, and what the region's samples say about the measurement's limits.

use vistaf_protocol::{Flag, QualityFlags};

use super::coarse::{samples_in, Coarse, Margin};
use super::features::slope_p98_exceeds;
use super::profile::Shape;
use super::window::upsample2;
use super::{
    depth_model_doubts, reading_error, Context, Grid, Unwrap, AMPLITUDE_EDGE_RATIO,
    BAND_LOSS_FRACTION, BAND_LOSS_MIN, BLUNTNESS_RATIO, DEPTH_RANGE_SLACK, DIPOLE_RATIO,
    LOAD_RATIO, MAX_RESIDUES, RIM_DIPOLE_RATIO, SHARPNESS_RATIO, SLOPE_LIMIT, TILE_PX,
    UNWRAP_TRIGGER_RAD,
};
use crate::calibration::{ForceInputs, LoadSignature};
use crate::ftp::band::BAND_HALF_WIDTH;
use crate::ftp::carrier::Carrier;
use crate::phase::{PhaseMap, PhaseNum, GRID};
use crate::unwrap::unwrap_window;

/// Coarse samples of border around the region's tiles: they seed the unwrapping and feed
/// the interpolation.
const BORDER: usize = 2;

/// The contact region's window: coarse columns and rows, and the working pixels they span.
#[derive(Debug, Clone)]
pub(super) struct Window {
    /// Coarse columns `[x0, x1)`.
    pub(super) cols: (usize, usize),
    /// Coarse rows.
    pub(super) rows: std::ops::Range<usize>,
}

impl Window {
    /// The bounding box of the region's tiles (each `TILE_PX / GRID` samples square,
    /// clipped to the grid), with [`BORDER`] samples around.
    pub(super) fn around(tiles_on: &[bool], grid: &Grid) -> Window {
        const PER: usize = TILE_PX / GRID;
        let ((cw, ch), (tw, th)) = (grid.coarse, grid.tiles);
        let (mut tx0, mut ty0, mut tx1, mut ty1) = (tw, th, 0, 0);
        for (ty, row) in tiles_on.chunks_exact(tw).enumerate() {
            if let (Some(a), Some(b)) = (row.iter().position(|t| *t), row.iter().rposition(|t| *t))
            {
                (tx0, ty0, tx1, ty1) = (tx0.min(a), ty0.min(ty), tx1.max(b), ty1.max(ty));
            }
        }
        let (cx0, cy0) = (tx0 * PER, ty0 * PER);
        let (cx1, cy1) = (((tx1 + 1) * PER).min(cw) - 1, ((ty1 + 1) * PER).min(ch) - 1);
        Window {
            cols: (cx0.saturating_sub(BORDER), (cx1 + BORDER + 1).min(cw)),
            rows: cy0.saturating_sub(BORDER)..(cy1 + BORDER + 1).min(ch),
        }
    }

    /// Coarse samples across and down.
    pub(super) fn coarse_size(&self) -> (usize, usize) {
        (self.cols.1 - self.cols.0, self.rows.len())
    }

    /// The working pixels the upsampled window covers: origin and size.
    pub(super) fn pixels(&self) -> ((usize, usize), (usize, usize)) {
        let (cbw, cbh) = self.coarse_size();
        (
            (GRID * self.cols.0, GRID * self.rows.start),
            (GRID * cbw - 1, GRID * cbh - 1),
        )
    }

    /// The samples of a coarse map (`cw` across) in the window, row by row.
    pub(super) fn of<T: Copy>(&self, v: &[T], cw: usize) -> Vec<T> {
        let mut out = Vec::with_capacity(self.coarse_size().0 * self.rows.len());
        for cy in self.rows.clone() {
            out.extend_from_slice(&v[cy * cw + self.cols.0..cy * cw + self.cols.1]);
        }
        out
    }
}

/// The window's indentation phase (signed so that indentation is positive, units),
/// unwrapped when it can have wrapped; and, of the unwrapping, the region's samples it
/// could not reach and the residues it met in the region.
///
/// The samples outside the region seed the unwrapping as background. An untrusted sample
/// (in the margin along the edge, or with fringes too faint) was never tested for
/// contact: a press reaching the edge has its deep, wrapped part there, and taken for
/// background it would unwrap the press a turn low, until it read as no contact. An
/// untrusted sample whose phase stands beyond the contact threshold `thr` (units) is
/// therefore unwrapped with the region instead of seeding it; what the unwrapping meets
/// outside the region is not counted against the contact. A press whose surround stands
/// above the threshold over the whole window (a deep press on a small view) leaves no
/// background at all: its shallowest trusted sample, far out on the surround where the
/// phase cannot have wrapped, seeds the unwrapping instead ([`seed_when_none`]).
pub(super) fn indentation_phase<P: PhaseNum>(
    coarse: &Coarse<'_, P>,
    (region, thr): (&[bool], i32),
    win: &Window,
    (offset, sign): (P, i32),
    when: Unwrap,
) -> (Vec<i32>, usize, usize) {
    let cw = coarse.cw;
    let (cbw, cbh) = win.coarse_size();
    let local: Vec<P> = win
        .of(&coarse.phase, cw)
        .into_iter()
        .map(|p| p.minus(offset))
        .collect();
    let in_region = win.of(region, cw);
    // Over the region (a sample outside it counts 0, which no |phase| is below).
    let max_abs = local
        .iter()
        .zip(&in_region)
        .map(|(p, &r)| if r { p.units().abs() } else { 0 })
        .max()
        .unwrap_or(0);
    let unwrap = match when {
        Unwrap::WhenNeeded => max_abs > P::from_rad(UNWRAP_TRIGGER_RAD).units(),
        Unwrap::Always => true,
        Unwrap::Never => false,
    };
    let (u, unreached, residues) = if unwrap {
        let trusted = win.of(&coarse.rel_contact, cw);
        let mut not_seeds: Vec<bool> = in_region
            .iter()
            .zip(&local)
            .zip(&trusted)
            .map(|((&r, p), &ok)| r || (!ok && p.units().abs() > thr))
            .collect();
        seed_when_none(&mut not_seeds, &local, &trusted);
        unwrap_window(&local, (&not_seeds, &in_region), cbw, cbh, || {
            let (a, r) = (win.of(&coarse.amp, cw), win.of(&coarse.amp_r, cw));
            a.iter().zip(&r).map(|(a, r)| *a.min(r)).collect()
        })
    } else {
        (local, 0, 0)
    };
    let signed = u.iter().map(|p| p.signed(sign).units()).collect();
    (signed, unreached, residues)
}

/// When every sample of the window is to be unwrapped (`not_seeds` all set), frees the
/// trusted sample of least |phase| to seed it: the contact's far surround, whose phase is
/// its own (untrusted ones only when none is trusted). Without a seed nothing is reached,
/// and a deep press's wrapped core would read as the other sign.
fn seed_when_none<P: PhaseNum>(not_seeds: &mut [bool], local: &[P], trusted: &[bool]) {
    if not_seeds.iter().any(|&n| !n) {
        return;
    }
    let least = |only_trusted: bool| {
        (0..local.len())
            .filter(|&i| !only_trusted || trusted[i])
            .min_by_key(|&i| local[i].units().abs())
    };
    if let Some(i) = least(true).or_else(|| least(false)) {
        not_seeds[i] = false;
    }
}

/// Per working pixel of the window (`bw × bh` from `origin`), whether its tile is in the
/// region (every such pixel lies in the image: the grid's last sample is at most its
/// last pixel). The rows of one tile row are the same: the first is built, the others
/// copied.
pub(super) fn region_pixels(
    tiles_on: &[bool],
    tw: usize,
    (x0, y0): (usize, usize),
    (bw, bh): (usize, usize),
) -> Vec<bool> {
    let mut on = vec![false; bw * bh];
    for ly in 0..bh {
        if ly > 0 && (y0 + ly) % TILE_PX != 0 {
            on.copy_within((ly - 1) * bw..ly * bw, ly * bw);
            continue;
        }
        let trow = &tiles_on[((y0 + ly) / TILE_PX) * tw..((y0 + ly) / TILE_PX + 1) * tw];
        for (lx, o) in on[ly * bw..(ly + 1) * bw].iter_mut().enumerate() {
            *o = trow[(x0 + lx) / TILE_PX];
        }
    }
    on
}

/// One pass over the window's region: depth, the deformed pixels, their integrated phase
/// and the dipole test's sums.
#[derive(Debug)]
pub(super) struct DepthPass {
    /// Depth per window pixel, µm (0 outside the deformed pixels).
    pub(super) depth_um: Vec<i32>,
    /// The region's pixels deeper than the contact threshold.
    pub(super) deformed: Vec<bool>,
    /// Indentation phase summed over the deformed pixels, units.
    pub(super) integrated_units: i64,
    /// Phase beyond the threshold on each side over the reliable region, units.
    positive: i64,
    negative: i64,
}

/// The fringe amplitudes on the coarse grid (`cw` samples across, [`GRID`] working pixels
/// apart), the frame's and the reference's, with their medians over the view: where
/// either's fringes are fainter (a glare spot, a dim corner), the phase's noise grows as
/// the amplitude falls, and a sample stands out only where its phase would still pass the
/// threshold raised as much (`|v| · min(a/median, 1) > threshold` for the fainter of the
/// two): the rule a contact must meet to be found ([`super::coarse::contact_tiles`]), which
/// reads the reference's fringes alone, with the frame's read too.
#[derive(Debug, Clone, Copy)]
pub(super) struct Faint<'a> {
    /// The frame's amplitude per coarse sample.
    pub(super) amp: &'a [u32],
    /// The reference's.
    pub(super) amp_r: &'a [u32],
    /// Their medians over the view (frame, reference).
    pub(super) medians: (u32, u32),
    /// Coarse samples across.
    pub(super) cw: usize,
}

impl Faint<'_> {
    /// Whether phase `v` (units) at working pixel `(x, y)` stands beyond `threshold` with
    /// the threshold raised as the fringes there are fainter than their median.
    pub(super) fn stands(&self, v: i32, at: (usize, usize), threshold: i32) -> bool {
        let i = self.sample(at);
        let (mf, mr) = (u128::from(self.medians.0), u128::from(self.medians.1));
        let a = |amp: &[u32], median: u128| amp.get(i).map_or(median, |&a| u128::from(a));
        // min(a_f/m_f, a_r/m_r, 1), over the common denominator m_f·m_r.
        let share = (a(self.amp, mf) * mr)
            .min(a(self.amp_r, mr) * mf)
            .min(mf * mr);
        u128::from(v.unsigned_abs()) * share > u128::from(threshold.unsigned_abs()) * mf * mr
    }

    /// Whether the frame's fringe amplitude against the reference's at working pixel
    /// `(x, y)` departs from the view's (their medians') by more than
    /// [`AMPLITUDE_EDGE_RATIO`] either way: the pigment's colour, and with it the stripes'
    /// contrast, changed there and not over the view (a heated object's print).
    pub(super) fn recoloured(&self, at: (usize, usize)) -> bool {
        let i = self.sample(at);
        let amp = |v: &[u32]| u128::from(v.get(i).copied().unwrap_or(0));
        let (mf, mr) = (u128::from(self.medians.0), u128::from(self.medians.1));
        // (a_f / a_r) against (m_f / m_r), over the common denominator a_r·m_r.
        ratios_apart(amp(self.amp) * mr, mf * amp(self.amp_r))
    }

    /// Whether the pigment's colour changed ([`Faint::recoloured`]) within `reach` coarse
    /// samples of working pixel `(x, y)`, across or down: the demodulator's kernel reaches
    /// that far, and a print's change pulls the phase on its rim's outer side too.
    pub(super) fn recoloured_near(&self, (x, y): (usize, usize), reach: usize) -> bool {
        let d = reach * GRID;
        let across = (x.saturating_sub(d)..=x + d).step_by(GRID).map(|x| (x, y));
        let down = (y.saturating_sub(d)..=y + d).step_by(GRID).map(|y| (x, y));
        across.chain(down).any(|at| self.recoloured(at))
    }

    /// The coarse sample holding working pixel `(x, y)`.
    fn sample(&self, (x, y): (usize, usize)) -> usize {
        (y / GRID) * self.cw + (x / GRID).min(self.cw.saturating_sub(1))
    }
}

/// Whether more of the depth `depth_um` over `samples` (indices into a window `bw` pixels
/// wide whose origin is working pixel `(x0, y0)`) lies where the pigment's colour changed
/// against the reference, or within half a grating period of such a change
/// ([`Faint::recoloured_near`]), or on the rim of one ([`AmplitudeEdge::steep`]), than
/// elsewhere.
pub(super) fn mostly_recoloured(
    (depth_um, samples): (&[i32], &[usize]),
    (faint, edge): (Faint<'_>, AmplitudeEdge<'_>),
    (x0, y0, bw): (usize, usize, usize),
) -> bool {
    let (mut on, mut off) = (0i64, 0i64);
    for &i in samples {
        let d = i64::from(depth_um.get(i).map_or(0, |&d| d.max(0)));
        if recoloured_at((faint, edge), (x0 + i % bw, y0 + i / bw)) {
            on += d;
        } else {
            off += d;
        }
    }
    on > off
}

/// Whether the pigment's colour changed against the reference at working pixel `at`, or
/// within half a grating period of it ([`Faint::recoloured_near`]), or `at` lies on the
/// rim of such a change ([`AmplitudeEdge::steep`]): the phase there may be the change's
/// pull.
pub(super) fn recoloured_at(
    (faint, edge): (Faint<'_>, AmplitudeEdge<'_>),
    at: (usize, usize),
) -> bool {
    faint.recoloured_near(at, edge.reach) || edge.steep(at)
}

/// Where the frame's fringe amplitude, against the reference's, changes by more than
/// [`AMPLITUDE_EDGE_RATIO`] within a grating period: the rim of a heated object, where the
/// pigment's colour and with it the stripes' contrast change over a few pixels. There the
/// demodulator's kernel spans fringes of unequal amplitude (and a background that moves
/// with them), and the phase it reads is pulled in proportion to the relative change, one
/// way and the other across the rim, whatever the surface does. Such phase is evidence
/// neither of a press nor of a dipole: a press inside a heated object's rim stands where
/// the pigment is cleared evenly, while the rim's pull can outweigh it where only part of
/// the rim lies in view. Amplitudes are compared only within `margin`, where the
/// demodulator's kernel lies wholly in the image: nearer the edge the kernel averages
/// padding, and the amplitudes fall there, the frame's and the reference's by different
/// amounts, whatever the skin does.
#[derive(Debug, Clone, Copy)]
pub(super) struct AmplitudeEdge<'a> {
    /// The frame's fringe amplitude per coarse sample.
    amp: &'a [u32],
    /// The reference's.
    amp_r: &'a [u32],
    /// Coarse samples across.
    cw: usize,
    /// Half a grating period, coarse samples (at least one).
    reach: usize,
    /// The first and last coarse column, and row, within the margin.
    trusted: [(usize, usize); 2],
}

/// Trusted coarse columns and rows about a sample, and the sample ([`AmplitudeEdge::spans`]).
type Spans = (
    std::ops::RangeInclusive<usize>,
    std::ops::RangeInclusive<usize>,
    (usize, usize),
);

impl<'a> AmplitudeEdge<'a> {
    /// The edges of amplitudes `amp` (the frame's) and `amp_r` (the reference's) on a
    /// coarse grid `cw × ch`, compared `reach` samples either side within `margin`
    /// (working pixels).
    pub(super) fn new(
        (amp, amp_r): (&'a [u32], &'a [u32]),
        (cw, ch): (usize, usize),
        reach: usize,
        margin: &Margin,
    ) -> AmplitudeEdge<'a> {
        let samples = |px: &std::ops::Range<usize>, n: usize| {
            let last = (px.end.saturating_sub(1) / GRID).min(n.saturating_sub(1));
            (px.start.div_ceil(GRID), last)
        };
        AmplitudeEdge {
            amp,
            amp_r,
            cw,
            reach: reach.max(1),
            trusted: [samples(&margin.xs, cw), samples(&margin.ys, ch)],
        }
    }

    /// Whether the amplitude ratio changes steeply through working pixel `(x, y)`: across
    /// the trusted samples half a period either side of it, along either axis.
    pub(super) fn steep(&self, (x, y): (usize, usize)) -> bool {
        let Some((xs, ys, (cx, cy))) = self.spans((x, y), self.reach) else {
            return false;
        };
        let cw = self.cw;
        self.changes(cy * cw + xs.start(), cy * cw + xs.end())
            || self.changes(ys.start() * cw + cx, ys.end() * cw + cx)
    }

    /// How far the amplitude ratio (the frame's against the reference's) spreads over the
    /// trusted samples within a grating period of working pixel `(x, y)`, across and down:
    /// the natural log of the largest over the smallest (0 where none is trusted). A rim's
    /// pull on the phase grows with it ([`RIM_PULL_RAD`](super::RIM_PULL_RAD)).
    pub(super) fn log_span(&self, (x, y): (usize, usize)) -> f32 {
        let Some((xs, ys, (cx, cy))) = self.spans((x, y), 2 * self.reach) else {
            return 0.0;
        };
        let across = xs.map(|c| cy * self.cw + c);
        let down = ys.map(|r| r * self.cw + cx);
        let ratio = |i: usize| {
            let (&a, &r) = (self.amp.get(i)?, self.amp_r.get(i)?);
            (a > 0 && r > 0).then(|| a as f32 / r as f32)
        };
        let (lo, hi) = (across.chain(down).filter_map(ratio))
            .fold((f32::MAX, 0.0f32), |(lo, hi), r| (lo.min(r), hi.max(r)));
        if hi > 0.0 {
            (hi / lo).ln()
        } else {
            0.0
        }
    }

    /// The trusted coarse columns and rows within `reach` samples of working pixel
    /// `(x, y)`'s sample, and that sample; `None` where the sample itself is not trusted.
    fn spans(&self, (x, y): (usize, usize), reach: usize) -> Option<Spans> {
        let (cx, cy) = (x / GRID, y / GRID);
        let span = |c: usize, (first, last): (usize, usize)| {
            c.saturating_sub(reach).max(first)..=(c + reach).min(last)
        };
        let (xs, ys) = (span(cx, self.trusted[0]), span(cy, self.trusted[1]));
        (xs.contains(&cx) && ys.contains(&cy)).then_some((xs, ys, (cx, cy)))
    }

    /// Whether the amplitude ratio at sample `b` lies beyond [`AMPLITUDE_EDGE_RATIO`] of the
    /// one at sample `a`, either way.
    fn changes(&self, a: usize, b: usize) -> bool {
        let at = |v: &[u32], i: usize| u128::from(v.get(i).copied().unwrap_or(0));
        // r_b / r_a with r = amp / amp_r, over the common denominator.
        ratios_apart(
            at(self.amp, b) * at(self.amp_r, a),
            at(self.amp, a) * at(self.amp_r, b),
        )
    }
}

/// Whether two amplitude ratios, given as `p` and `q` over a common denominator, lie
/// beyond [`AMPLITUDE_EDGE_RATIO`] of each other, either way.
fn ratios_apart(p: u128, q: u128) -> bool {
    let (num, den) = AMPLITUDE_EDGE_RATIO;
    let (num, den) = (u128::from(num), u128::from(den));
    den * p > num * q || den * q > num * p
}

impl DepthPass {
    /// Depth is reported (and counted in the volume) only above the depth of the contact
    /// threshold (`threshold`, units; `threshold_um`): the map carries deformation, not
    /// noise.
    pub(super) fn run<M: PhaseMap>(
        map: &M,
        up: &[i32],
        region: &[bool],
        reliable: &[bool],
        (w, x0, y0, bw): (usize, usize, usize, usize),
        (threshold, threshold_um): (i32, i32),
    ) -> DepthPass {
        let from_units = <M::P as PhaseNum>::from_units;
        let m = up.len();
        let mut pass = DepthPass {
            depth_um: vec![0i32; m],
            deformed: vec![false; m],
            integrated_units: 0,
            positive: 0,
            negative: 0,
        };
        let (mut pos, mut neg, mut integrated) = (0i64, 0i64, 0i64);
        let rows = up.chunks_exact(bw).zip(region.chunks_exact(bw)).zip(
            pass.depth_um
                .chunks_exact_mut(bw)
                .zip(pass.deformed.chunks_exact_mut(bw)),
        );
        for (ly, ((urow, orow), (drow, frow))) in rows.enumerate() {
            let rrow = &reliable[(y0 + ly) * w + x0..(y0 + ly) * w + x0 + bw];
            for ((((&v, &on), &ok), d), f) in urow.iter().zip(orow).zip(rrow).zip(drow).zip(frow) {
                if !on {
                    continue;
                }
                let z = map.depth_um(from_units(v));
                if z > threshold_um {
                    (*d, *f) = (z, true);
                    integrated += i64::from(v);
                }
                if ok {
                    if v > threshold {
                        pos += i64::from(v);
                    } else if v < -threshold {
                        neg -= i64::from(v);
                    }
                }
            }
        }
        (pass.positive, pass.negative, pass.integrated_units) = (pos, neg, integrated);
        pass
    }

    /// An indentation moves the phase one way. A temperature gradient across the stripes
    /// (or a grating shifted under an illumination edge) skews their brightness profile and
    /// moves it both ways around the spot (a dipole): when the opposite-signed phase
    /// carries a comparable share, there is no contact to report.
    pub(super) fn is_dipole(&self) -> bool {
        dipole(self.positive, self.negative, DIPOLE_RATIO)
    }

    /// Whether a region [`DepthPass::is_dipole`] calls a dipole is still one with the
    /// phase of faint fringes set aside ([`Faint`]; `up`, `region`, `reliable` and the
    /// window as [`DepthPass::run`] read them). Where fringes are faint (glare spots, dim
    /// corners) their phase's noise reaches past the threshold in both signs, and over a
    /// region spanning the view it can outweigh a press standing clear of it. So where
    /// most of the indentation-signed phase stands out against its own fringes' noise,
    /// only what stands is weighed on either side; where most of it does not, the region's
    /// indentation is itself mostly such noise, and the whole region's verdict holds. The
    /// phase on an amplitude edge ([`AmplitudeEdge`]) is set aside too, but a region only
    /// that clears must keep next to nothing of the other sign off the edges
    /// ([`RIM_DIPOLE_RATIO`]): a heated press's opposite-signed phase lies on the rim, all of
    /// it, while a rim set aside beside noise of both signs (a warm spot with no press
    /// under it) leaves some of the noise's. Read only for a region the whole-region test
    /// rejects: one it accepts stays accepted.
    pub(super) fn dipole_where_it_stands(
        &self,
        (up, region, reliable): (&[i32], &[bool], &[bool]),
        (faint, edge): (Faint<'_>, AmplitudeEdge<'_>),
        (w, x0, y0, bw): (usize, usize, usize, usize),
        threshold: i32,
    ) -> bool {
        // Indentation-signed and opposite-signed phase that stands, and of it what lies off
        // the amplitude edges.
        let (mut standing, mut off_edges) = ([0i64; 2], [0i64; 2]);
        let rows = up.chunks_exact(bw).zip(region.chunks_exact(bw));
        for (ly, (urow, orow)) in rows.enumerate() {
            let rrow = &reliable[(y0 + ly) * w + x0..(y0 + ly) * w + x0 + bw];
            for (lx, ((&v, &on), &ok)) in urow.iter().zip(orow).zip(rrow).enumerate() {
                let at = (x0 + lx, y0 + ly);
                if on && ok && v.abs() > threshold && faint.stands(v, at, threshold) {
                    let side = usize::from(v < 0);
                    standing[side] += i64::from(v.unsigned_abs());
                    if !edge.steep(at) {
                        off_edges[side] += i64::from(v.unsigned_abs());
                    }
                }
            }
        }
        let holds =
            |[pos, neg]: [i64; 2], ratio: f32| 2 * pos < self.positive || dipole(pos, neg, ratio);
        holds(standing, DIPOLE_RATIO) && holds(off_edges, RIM_DIPOLE_RATIO)
    }
}

/// Whether the opposite-signed phase `neg` carries more than `ratio` of the
/// indentation-signed `pos` (units).
fn dipole(pos: i64, neg: i64, ratio: f32) -> bool {
    (neg as f32) > ratio * pos as f32
}

/// What the region's samples say about the limits of the measurement: the phase slope
/// beyond the band, residues the unwrapping met, a depth beyond the calibration, an apex too
/// narrow to resolve.
pub(super) struct Limits<'a, P> {
    pub(super) coarse: &'a Coarse<'a, P>,
    /// Where a contact's phase is trusted: a grating period in from the edge.
    pub(super) margin: &'a Margin,
    pub(super) win: &'a Window,
    pub(super) pass: &'a DepthPass,
    pub(super) up: &'a [i32],
    /// Median fringe amplitudes of the frame and the reference.
    pub(super) amp_medians: (u32, u32),
    /// Unreached samples and residues of the unwrapping.
    pub(super) unwrap: (usize, usize),
    /// Whether the apex is as wide as the blur correction resolves (a plateau always is).
    pub(super) resolved: bool,
    /// The contact's shape as its profile shows it.
    pub(super) shape: Shape,
    /// Whether the contact's skirt cannot have sunk the registration by more than the
    /// depth tolerance ([`super::register::Background::skirt_free`]).
    pub(super) skirt_free: bool,
    /// Where the apex was read, working pixels of the image.
    pub(super) apex_px: (usize, usize),
}

/// Whether a contact's reciprocal load is unlike the calibrated indenter's at the depth it
/// reads, times `scale`: beyond [`LOAD_RATIO`] either way. Within the kit's depths only,
/// and never without a load signature (a file written before it).
fn unlike_load(signature: Option<&LoadSignature>, read: &ForceInputs, scale: f64) -> bool {
    let Some(calibrated) = signature.and_then(|l| l.load_mm2_at(f64::from(read.peak_mm))) else {
        return false;
    };
    let calibrated = calibrated * scale;
    let load = f64::from(read.reciprocal_load_mm2);
    calibrated > 0.0 && (load > LOAD_RATIO * calibrated || load * LOAD_RATIO < calibrated)
}

impl<P> Limits<'_, P> {
    /// The flags the contact earns, from what it reads (`read`: depth, area, load).
    pub(super) fn flags(
        &self,
        read: &ForceInputs,
        carrier: Carrier,
        ctx: &Context<'_>,
    ) -> QualityFlags {
        let mut flags = QualityFlags::NONE;
        // A contact much sharper than the calibrated indenter (less area at the same depth)
        // is smoothed by the band more than the calibration knows: its depth reads low; a
        // much blunter one is smoothed less: its depth reads deep. The shape is compared
        // where the signature was measured: beyond the calibrated depth it extrapolates,
        // and an unresolved contact's depth is open whatever its shape; both carry their
        // own flag instead.
        let beyond = ctx
            .calib
            .calibrated_depth_mm()
            .is_some_and(|d| f64::from(read.peak_mm) > DEPTH_RANGE_SLACK * d);
        let comparable = self.resolved && !beyond;
        // A contact whose profile is clearly a sphere's is read as one whatever its radius
        // (its area against the calibrated sphere's is its radius against the calibrated
        // one), and its load is a sphere's of that radius: Hertz's load at a given depth
        // grows as the square root of the radius. A plateau's depth is its own level, and it
        // is spared the tests when its skirt cannot have sunk the registration: otherwise (a
        // punch whose skirt covers the small view's background) the whole plateau may read
        // shallow, and the calibrated sphere's area and load are the only check left on its
        // depth, so it keeps the tests of an unknown shape.
        let unlike = comparable
            && ctx.calib.shape.as_ref().is_some_and(|s| {
                let calibrated = s.area_mm2_at(f64::from(read.peak_mm));
                let area = f64::from(read.area_mm2);
                let radius_ratio = area / calibrated.max(f64::MIN_POSITIVE);
                let like_calibrated = (SHARPNESS_RATIO..=BLUNTNESS_RATIO).contains(&radius_ratio);
                match self.shape {
                    Shape::Sphere => {
                        let scale = if like_calibrated {
                            1.0
                        } else {
                            radius_ratio.sqrt()
                        };
                        unlike_load(s.load.as_ref(), read, scale)
                    }
                    Shape::Flat if self.skirt_free => false,
                    Shape::Flat | Shape::Unknown => {
                        !like_calibrated || unlike_load(s.load.as_ref(), read, 1.0)
                    }
                }
            });
        let slope_limit = SLOPE_LIMIT * 65_536.0 * BAND_HALF_WIDTH * carrier.freq();
        let ((_, (bw, bh)), deformed) = (self.win.pixels(), &self.pass.deformed);
        if unlike
            || self.band_lost()
            || (self.shape != Shape::Flat && self.apex_beside_lost(ctx.blur_loss.lengths()))
            || slope_p98_exceeds(self.up, deformed, bw, bh, slope_limit)
        {
            flags.insert(Flag::PhaseSlope);
        }
        let (unreached, residues) = self.unwrap;
        if unreached > 0 || residues > MAX_RESIDUES {
            flags.insert(Flag::UnwrapFailure);
        }
        // Deeper than the calibration saw: the depth model extrapolates.
        if beyond {
            flags.insert(Flag::DepthOutOfRange);
        }
        // The calibration expects a reading at this depth to miss by more than its
        // tolerance allows: its depth model missed its own kit by that much, or its presses
        // of one depth read that far apart from place to place.
        if depth_model_doubts(reading_error(ctx.calib), f64::from(read.peak_mm)) {
            flags.insert(Flag::DepthUncertain);
        }
        if !self.resolved {
            flags.insert(Flag::DepthUnresolved);
        }
        flags
    }

    /// Whether a coarse sample inside the margin that the apex reading reaches lost its
    /// fringe as [`Self::band_lost`] counts them: the apex averages a phase the demodulator
    /// could not read there (the overshoot at a punch's rim, say, where the shading darkens
    /// the stripes as the phase jumps). The reading reaches a kernel's length (`lx`, `ly`
    /// working pixels) each way, and the upsampling of the coarse samples two pixels more.
    /// A plateau's depth is its core's level, not the apex's: the flags do not ask for one.
    fn apex_beside_lost(&self, (lx, ly): (usize, usize)) -> bool {
        let c = self.coarse;
        let (ax, ay) = self.apex_px;
        let span = |a: usize, l: usize| {
            let reach = l + GRID;
            a.saturating_sub(reach).div_ceil(GRID)..=(a + reach) / GRID
        };
        let near = span(ay, ly).flat_map(|cy| span(ax, lx).map(move |cx| (cx, cy)));
        let lost = |(cx, cy): (usize, usize)| {
            let k = cy * c.cw + cx;
            k < c.amp.len() && self.margin.contains(cx * GRID, cy * GRID) && self.fringe_lost(k)
        };
        near.filter(|&(cx, _)| cx < c.cw).any(lost)
    }

    /// Whether coarse sample `k` lost its fringe: unreliable, or its amplitude fell below
    /// half its reference's after the frame's overall contrast change (so a dimmer or
    /// washed-out frame does not count).
    fn fringe_lost(&self, k: usize) -> bool {
        let c = self.coarse;
        let (fm, rm) = (
            u64::from(self.amp_medians.0.max(1)),
            u64::from(self.amp_medians.1),
        );
        !c.rel_contact[k] || u64::from(c.amp[k]) * 2 * rm < u64::from(c.amp_r[k]) * fm
    }

    /// Beyond the band the demodulator cannot even report the slope; what it shows is the
    /// fringe amplitude falling (by the filter's response at the local frequency offset).
    /// Deformed samples whose amplitude fell below half the reference's (after the frame's
    /// overall contrast change, so a dimmer or washed-out frame does not count), or that
    /// became unreliable, mean the spectrum has left the band there. A sample whose
    /// reference fringe was already too faint to read (a pale patch of pigment, a glare
    /// spot) says nothing about the band: it was never readable, so it is not counted.
    fn band_lost(&self) -> bool {
        let c = self.coarse;
        let ((x0, y0), (bw, _)) = self.win.pixels();
        let m = self.pass.deformed.len();
        let (mut lost, mut seen) = (0usize, 0usize);
        let (cx0, cx1) = self.win.cols;
        for (cx, cy) in self
            .win
            .rows
            .clone()
            .flat_map(|cy| (cx0..cx1).map(move |cx| (cx, cy)))
        {
            let (x, y) = (cx * GRID, cy * GRID);
            let lj = (y - y0) * bw + (x - x0);
            let k = cy * c.cw + cx;
            let outside = lj >= m || !self.pass.deformed[lj] || !self.margin.contains(x, y);
            if outside || !c.reference_readable(k) {
                continue;
            }
            seen += 1;
            if self.fringe_lost(k) {
                lost += 1;
            }
        }
        lost as f32 > BAND_LOSS_FRACTION * seen as f32 && lost >= BAND_LOSS_MIN
    }
}

/// The region's samples on the coarse grid (`cw × ch`), from its tiles (`tw` across).
pub(super) fn region_samples(tiles_on: &[bool], grid: &Grid) -> Vec<bool> {
    samples_in(tiles_on, grid.coarse, grid.tiles.0)
}

/// The ×2 upsampled indentation phase of the window: every working pixel of it, by cubic
/// convolution (midpoint weights −1, 9, 9, −1 over 16: exact for quadratics, so a round
/// contact's peak is not shaved). The analytic signal is smooth over a carrier period, so
/// the coarse samples hold it.
pub(super) fn upsampled(signed: &[i32], win: &Window) -> Vec<i32> {
    let (cbw, cbh) = win.coarse_size();
    upsample2(signed, cbw, cbh)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::unwrap::{unwrap_window, Phase};

    /// A phase beyond the threshold stands where both fringes are at their medians or
    /// brighter; twice the threshold does not where either is under half its median (the
    /// frame's dim corner, the reference's glare spot).
    #[test]
    fn phase_stands_against_the_fainter_of_the_two_fringes() {
        let cw = 2;
        let amp = [100, 100, 30, 400];
        let amp_r = [1000, 300, 1000, 4000];
        let faint = Faint {
            amp: &amp,
            amp_r: &amp_r,
            medians: (100, 1000),
            cw,
        };
        let at = |i: usize| ((i % cw) * GRID, (i / cw) * GRID);
        let thr = 50;
        assert!(faint.stands(101, at(0), thr));
        assert!(faint.stands(-101, at(0), thr));
        assert!(!faint.stands(49, at(0), thr));
        assert!(!faint.stands(101, at(1), thr), "the reference's glare");
        assert!(!faint.stands(101, at(2), thr), "the frame's dim corner");
        assert!(
            faint.stands(101, at(3), thr),
            "brighter than the median counts as it"
        );
        assert!(
            faint.stands(101, (0, 9 * GRID), thr),
            "below the grid: the medians"
        );
    }

    /// The whole region's dipole verdict and the verdict where it stands
    /// ([`DepthPass::dipole_where_it_stands`]) for one row of pixels `up`, every one in the
    /// region and reliable, read by `faint` and `edge` against the threshold `thr`.
    fn row_verdicts(
        up: &[i32],
        (faint, edge): (Faint<'_>, AmplitudeEdge<'_>),
        thr: i32,
    ) -> (bool, bool) {
        let side = |f: &dyn Fn(i32) -> bool| -> i64 {
            up.iter()
                .filter(|&&v| f(v))
                .map(|&v| i64::from(v.unsigned_abs()))
                .sum()
        };
        let pass = DepthPass {
            depth_um: Vec::new(),
            deformed: Vec::new(),
            integrated_units: 0,
            positive: side(&|v| v > thr),
            negative: side(&|v| v < -thr),
        };
        let n = up.len();
        let all = vec![true; n];
        let stands =
            pass.dipole_where_it_stands((up, &all, &all), (faint, edge), (n, 0, 0, n), thr);
        (pass.is_dipole(), stands)
    }

    /// A region whose opposite-signed phase lies where fringes are faint is no dipole when
    /// most of its indentation stands; when most of its indentation is faint itself, the
    /// whole region's verdict holds.
    #[test]
    fn faint_fringes_phase_does_not_make_a_press_a_dipole() {
        // One row of four pixels over two coarse samples: bright fringes, then a spot
        // where the frame's fringes are a fifth of their median.
        let (amp, amp_r) = ([100, 20], [100, 100]);
        let faint = Faint {
            amp: &amp,
            amp_r: &amp_r,
            medians: (100, 100),
            cw: 2,
        };
        let thr = 10;
        // The amplitude ratio even across the row: no amplitude edge.
        let even = [100, 100];
        let edge = AmplitudeEdge::new((&even, &even), (2, 1), 1, &Margin::new(0, 4, 1));
        let verdicts = |up: [i32; 4]| row_verdicts(&up, (faint, edge), thr);
        // A press in the bright fringes, noise of the other sign in the faint spot.
        assert_eq!(verdicts([40, 40, -30, -30]), (true, false));
        // Indentation only in the faint spot, the other sign in the bright fringes.
        assert_eq!(verdicts([-40, -40, 30, 30]), (true, true));
        // Both signs in the bright fringes.
        assert_eq!(verdicts([40, -30, 0, 0]), (true, true));
    }

    /// A region whose opposite-signed phase lies on an amplitude edge (a heated object's
    /// rim) is no dipole when the press stands off the edge; when the indentation lies on
    /// the edge itself, the whole region's verdict holds.
    #[test]
    fn an_amplitude_edges_phase_does_not_make_a_press_a_dipole() {
        // One row of eight pixels over four coarse samples: the frame's fringes four times
        // the reference's from the third sample on, steep at the second and third.
        let (bright, ring) = ([100u32; 4], [100u32, 100, 400, 400]);
        let faint = Faint {
            amp: &bright,
            amp_r: &bright,
            medians: (100, 100),
            cw: 4,
        };
        let whole = Margin::new(0, 8, 1);
        fn edge<'a>(amp: &'a [u32], amp_r: &'a [u32], margin: &Margin) -> AmplitudeEdge<'a> {
            AmplitudeEdge::new((amp, amp_r), (4, 1), 1, margin)
        }
        let steep = edge(&ring, &bright, &whole);
        let verdicts =
            |up: [i32; 8], amp: &[u32]| row_verdicts(&up, (faint, edge(amp, &bright, &whole)), 10);
        let (edge_steep, edge_even) = ([2, 3, 4, 5], [0, 1, 6, 7]);
        for x in edge_steep {
            assert!(steep.steep((x, 0)), "pixel {x}");
        }
        for x in edge_even {
            assert!(!steep.steep((x, 0)), "pixel {x}");
        }
        // A press beyond the rim, the rim's pull of the other sign on it.
        let press = [0, 0, -30, -30, -30, -30, 40, 40];
        assert_eq!(verdicts(press, &ring), (true, false));
        // Without the rim, the same phase is a dipole.
        assert_eq!(verdicts(press, &bright), (true, true));
        // Beside a little of the other sign off the rim, still a press; beside more, the
        // rim is no longer all of the dipole, and the whole region's verdict holds.
        let beside = |v| [v, 0, -30, -30, -30, -30, 80, 80];
        assert_eq!(verdicts(beside(-12), &ring), (true, false));
        assert_eq!(verdicts(beside(-20), &ring), (true, true));
        // The indentation on the rim alone, the other sign beside it.
        assert_eq!(
            verdicts([-30, -30, 40, 40, 40, 40, 0, 0], &ring),
            (true, true)
        );
    }

    /// An amplitude edge across the rows is read as one across the columns, and only
    /// between samples where the kernel lies wholly in the image.
    #[test]
    fn an_amplitude_edge_is_read_along_either_axis_within_the_margin() {
        // A 3 × 3 coarse grid (6 × 6 working pixels) whose bottom row's fringes are twice
        // the reference's.
        let amp_r = [100u32; 9];
        let amp = [100u32, 100, 100, 100, 100, 100, 200, 200, 200];
        let (whole, inner) = (Margin::new(0, 6, 6), Margin::new(2, 6, 6));
        let edge = |amp, margin| AmplitudeEdge::new((amp, &amp_r), (3, 3), 1, margin);
        // The middle row's samples straddle the change; the top row's do not.
        assert!(edge(&amp, &whole).steep((2, 2)));
        assert!(!edge(&amp, &whole).steep((2, 0)));
        // A change within the ratio is no edge.
        let mild = [100u32, 100, 100, 100, 100, 100, 140, 140, 140];
        assert!(!edge(&mild, &whole).steep((2, 2)));
        // The bottom row lies where the kernel reaches past the image: its fall (as the
        // padding's) is no edge, and the middle row has nothing within reach to compare.
        let fall = [100u32, 100, 100, 100, 100, 100, 30, 30, 30];
        assert!(!edge(&fall, &inner).steep((2, 2)));
        assert!(edge(&fall, &whole).steep((2, 2)));
    }

    /// The amplitude ratio's spread about a pixel is read a grating period (two `reach`)
    /// across and down, within the margin only; the recoloured ground is found within
    /// `reach` of a pixel, not beyond.
    #[test]
    fn a_rims_spread_and_its_ground_are_read_within_their_reach() {
        // A 5 × 5 coarse grid (10 × 10 working pixels) whose last column's fringes are
        // twice the reference's and whose first column's are half.
        let amp_r = [100u32; 25];
        let mut amp = [100u32; 25];
        for row in amp.chunks_exact_mut(5) {
            (row[0], row[4]) = (50, 200);
        }
        let whole = Margin::new(0, 10, 10);
        let edge = |amp, reach, margin| AmplitudeEdge::new((amp, &amp_r), (5, 5), reach, margin);
        let ln = |r: f32| r.ln();
        assert!((edge(&amp, 1, &whole).log_span((6, 4)) - ln(2.0)).abs() < 1e-6);
        assert!((edge(&amp, 2, &whole).log_span((4, 4)) - ln(4.0)).abs() < 1e-6);
        assert_eq!(edge(&amp_r, 2, &whole).log_span((4, 4)), 0.0);
        // Outside the margin nothing is trusted, and within it only what lies inside.
        let (narrow, inner) = (Margin::new(4, 10, 10), Margin::new(2, 10, 10));
        assert_eq!(edge(&amp, 2, &narrow).log_span((0, 0)), 0.0);
        assert!((edge(&amp, 2, &inner).log_span((4, 4))).abs() < 1e-6);
        let faint = Faint {
            amp: &amp,
            amp_r: &amp_r,
            medians: (100, 100),
            cw: 5,
        };
        assert!(faint.recoloured((8, 4)) && !faint.recoloured((6, 4)));
        assert!(faint.recoloured_near((6, 4), 1) && !faint.recoloured_near((4, 4), 1));
        assert!(faint.recoloured_near((4, 4), 2));
    }

    /// A dome of 5 rad over a whole window, wrapped, with no sample outside the region:
    /// unseeded, the unwrapping reaches nothing and the core stays of the other sign; seeded
    /// at its shallowest trusted sample, it is read whole.
    #[test]
    fn a_press_over_the_whole_window_is_unwrapped_from_its_surround() {
        let (w, h) = (14usize, 11usize);
        let truth: Vec<f32> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32 - 6.5, (i / w) as f32 - 5.0);
                5.0 * (-(x * x + y * y) / 30.0).exp()
            })
            .collect();
        let wrapped: Vec<f32> = truth.iter().map(|&t| f32::wrapped_diff(t, 0.0)).collect();
        let quality = || vec![1u32; w * h];
        let mut trusted = vec![true; w * h];
        trusted[0] = false; // the least |phase|, untrusted: not the seed
        let all = vec![true; w * h];
        let (_, unreached, _) = unwrap_window(&wrapped, (&all, &all), w, h, quality);
        assert_eq!(unreached, w * h);

        let mut not_seeds = all.clone();
        seed_when_none(&mut not_seeds, &wrapped, &trusted);
        let seeds: Vec<usize> = (0..w * h).filter(|&i| !not_seeds[i]).collect();
        assert_eq!(seeds.len(), 1);
        let least = (0..w * h)
            .filter(|&i| trusted[i])
            .map(|i| truth[i])
            .fold(f32::INFINITY, f32::min);
        assert!(trusted[seeds[0]] && truth[seeds[0]] == least, "{seeds:?}");
        let (u, unreached, _) = unwrap_window(&wrapped, (&not_seeds, &all), w, h, quality);
        assert_eq!(unreached, 0);
        for (got, want) in u.iter().zip(&truth) {
            assert!((got - want).abs() < 1e-4, "{got} vs {want}");
        }
        // A window with background keeps its own seeds.
        let mut with_background = all.clone();
        with_background[3] = false;
        let before = with_background.clone();
        seed_when_none(&mut with_background, &wrapped, &trusted);
        assert_eq!(with_background, before);
    }

    /// A contact carrying the calibrated indenter's load for its depth, or within the
    /// ratio of it, is alike; beyond the ratio either way it is not; outside the kit's
    /// depths, or without a signature, nothing is said.
    #[test]
    fn a_load_unlike_the_calibrated_indenter_s_is_told() {
        let l = LoadSignature {
            depth_mm: vec![0.5, 1.0, 2.0],
            load_mm2: vec![1.0, 3.0, 8.0],
        };
        let at = |d: f64, load: f64| {
            let read = ForceInputs {
                peak_mm: d as f32,
                reciprocal_load_mm2: load as f32,
                ..ForceInputs::default()
            };
            unlike_load(Some(&l), &read, 1.0)
        };
        assert!(!at(1.0, 3.0));
        assert!(!at(1.0, 3.0 * (LOAD_RATIO - 0.01)));
        assert!(!at(1.0, 3.0 / (LOAD_RATIO - 0.01)));
        assert!(at(1.0, 3.0 * (LOAD_RATIO + 0.01)));
        assert!(at(1.0, 3.0 / (LOAD_RATIO + 0.01)));
        assert!(!at(0.3, 100.0), "shallower than the kit");
        assert!(!at(2.5, 0.1), "deeper than the kit");
        assert!(!unlike_load(None, &ForceInputs::default(), 1.0));
    }
}
