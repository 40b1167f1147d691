//! The coarse grid: the background's samples, its noise floor and the contact tiles.

use super::{TILE_MIN_SAMPLES, TILE_PX};
use crate::mask::dilate;
use crate::phase::{PhaseMap, GRID};

/// Contact tiles ([`TILE_PX`] working pixels square) from the coarse grid (`cw × ch`
/// samples, [`GRID`] pixels apart): a sample is above when it is `rel`iable and its phase
/// `phi` exceeds `thr` in magnitude (units), and a tile is active when at least
/// [`TILE_MIN_SAMPLES`] of its samples are above; the active tiles dilated by one tile are
/// the region (`tw × th` tiles). `None` when there is none, or when fewer than `min_total`
/// samples are above in all: the band-pass spreads any indentation over about a period
/// each way, so a blob smaller than a disc one period across is a speck of the image (an
/// illumination edge under a shifted grating, a hot pixel), not a contact.
///
/// `thr` holds where the reference's fringe amplitude `amp_r` reaches its median
/// `amp_med`. Where the fringes are fainter (a glare spot washing them out, a dim corner,
/// a low-contrast border) the phase's noise grows as the amplitude falls, and a noise floor
/// measured over the whole view must not let it read as a contact: there must be a
/// contact by the same rules with each sample's threshold raised as its fringes are
/// fainter (`|phi| · min(amp_r, amp_med) > thr · amp_med`). Once there is one, its region
/// is every tile above `thr` itself, the fainter samples of a press included.
///
/// A press whose peak stands less than twice the threshold above the background holds
/// fewer samples above it than a disc a period across, however wide the band spreads it:
/// it is found by its own shape instead (its half-peak flood, with `faint_sign` the
/// indentation's phase sign; `None` where none is looked for), and said to be faint.
pub fn contact_tiles(
    phi: &[i32],
    rel: &[bool],
    (amp_r, amp_med): (&[u32], u32),
    (thr, faint_sign): (i32, Option<i32>),
    (cw, ch): (usize, usize),
    (tw, th): (usize, usize),
    min_total: usize,
) -> Option<ContactTiles> {
    const PER: usize = TILE_PX / GRID;
    let thr_units = thr.max(0);
    let thr = thr_units.unsigned_abs();
    let mut count = vec![0usize; tw * th];
    let above = |p: &[i32], r: &[bool]| -> usize {
        p.iter()
            .zip(r)
            .map(|(p, r)| usize::from(*r && p.unsigned_abs() > thr))
            .sum()
    };
    let rows = phi.chunks_exact(cw).zip(rel.chunks_exact(cw)).take(ch);
    for (cy, (prow, rrow)) in rows.enumerate() {
        let trow = &mut count[(cy / PER) * tw..(cy / PER + 1) * tw];
        // A tile's samples along the row at a time (fixed-size runs: no division per
        // sample, and the run's test unrolls), then the row's partial last tile.
        let ((pr, p_rest), (rr, r_rest)) = (prow.as_chunks::<PER>(), rrow.as_chunks::<PER>());
        for ((t, p), r) in trow.iter_mut().zip(pr).zip(rr) {
            *t += above(p, r);
        }
        if let Some(t) = trow.get_mut(pr.len()) {
            *t += above(p_rest, r_rest);
        }
    }
    if count.iter().all(|&c| c < TILE_MIN_SAMPLES) {
        return None;
    }
    let bar = i64::from(thr) * i64::from(amp_med);
    let stands = |p: i32, a: u32| weighed_by_fringes(p.unsigned_abs().into(), a, amp_med) > bar;
    let samples = Samples {
        phi,
        rel,
        amp_r,
        cw,
    };
    let plain = count.iter().sum::<usize>() >= min_total
        && samples.make_contact(&count, tw, min_total, |p, a, _| stands(p, a));
    let active: Vec<bool> = if plain {
        count.iter().map(|&c| c >= TILE_MIN_SAMPLES).collect()
    } else {
        // A faint press's region is its own flood's tiles: a speck elsewhere that passed
        // the threshold is not its place.
        let sign = faint_sign?;
        let flood = samples.faint_press((ch, sign, thr_units), min_total, amp_med)?;
        let mut tiles = vec![false; tw * th];
        for k in flood {
            if let Some(t) = tiles.get_mut((k / cw / PER) * tw + (k % cw) / PER) {
                *t = true;
            }
        }
        tiles
    };
    let on = dilate(&active, tw, th);
    let n = on.iter().filter(|t| **t).count();
    Some(ContactTiles {
        on,
        n,
        faint: !plain,
    })
}

/// A contact's tiles, as [`contact_tiles`] finds them.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ContactTiles {
    /// Per tile, whether it is in the contact region.
    pub on: Vec<bool>,
    /// How many are.
    pub n: usize,
    /// Whether the contact was found by its shape alone, by its half-peak flood.
    pub faint: bool,
}

/// The coarse grid's samples as the contact test reads them (`cw` across).
pub(super) struct Samples<'a> {
    pub(super) phi: &'a [i32],
    pub(super) rel: &'a [bool],
    pub(super) amp_r: &'a [u32],
    pub(super) cw: usize,
}

impl Samples<'_> {
    /// Whether the reliable samples that `stand` out (given a sample's phase, its
    /// reference's amplitude and its index) make a contact by [`contact_tiles`]'s rules: a
    /// tile with [`TILE_MIN_SAMPLES`] of them, `min_total` in all. They are a subset of the
    /// samples above the plain threshold, so only the tiles where those were counted
    /// (`plain`, `tw` across) are read, and the reading stops once a contact is made.
    pub(super) fn make_contact(
        &self,
        plain: &[usize],
        tw: usize,
        min_total: usize,
        stand: impl Fn(i32, u32, usize) -> bool,
    ) -> bool {
        const PER: usize = TILE_PX / GRID;
        let mut count = vec![0usize; plain.len()];
        let (mut total, mut tile_made) = (0usize, false);
        let rows = (self.phi.chunks_exact(self.cw))
            .zip(self.rel.chunks_exact(self.cw))
            .zip(self.amp_r.chunks_exact(self.cw));
        for (cy, ((prow, rrow), arow)) in rows.enumerate() {
            let t0 = (cy / PER) * tw;
            for (cx, ((p, r), a)) in prow.iter().zip(rrow).zip(arow).enumerate() {
                let t = t0 + cx / PER;
                if plain.get(t).is_some_and(|&n| n > 0) && *r && stand(*p, *a, cy * self.cw + cx) {
                    count[t] += 1;
                    total += 1;
                    tile_made |= count[t] >= TILE_MIN_SAMPLES;
                }
            }
            if tile_made && total >= min_total {
                return true;
            }
        }
        false
    }

    /// The half-peak flood of a faint press standing among the samples (`ch` rows,
    /// threshold `thr`), if one does: from a reliable sample, the samples joined to it
    /// above half its phase. A flood covering `min_total` samples or more (a disc a period
    /// across) and at most [`FAINT_PRESS_MAX_DISCS`] times that is press-sized: the band
    /// spreads a narrow press over its own width whatever its depth, so its flood is that
    /// wide even where few samples pass the threshold, while a speck of the image (a
    /// glare's edge under the grating) swings both ways within a period and floods a few
    /// samples, and a field near the threshold floods far beyond a press's width.
    ///
    /// The band spreads the phase's noise to the same width, so the frame's noise makes
    /// press-sized floods of both signs. The phase's noise grows as the fringes are fainter,
    /// so floods are weighed by their peak against their own fringes
    /// ([`weighed_by_fringes`], capped at the median `amp_med`), the measure by which a
    /// sample stands beyond the threshold in [`contact_tiles`]. A dim corner's noise then cannot
    /// hold back a press where the fringes are bright. A faint press is the heaviest
    /// press-sized flood of the indentation's sign (`sign`), it stands beyond the
    /// threshold `thr`, and it weighs [`FAINT_STANDS_OUT`] times or more as much as every
    /// other press-sized flood of either sign.
    pub(super) fn faint_press(
        &self,
        (ch, sign, thr): (usize, i32, i32),
        min_total: usize,
        amp_med: u32,
    ) -> Option<Vec<usize>> {
        let n = self.cw * ch;
        if [self.phi.len(), self.rel.len(), self.amp_r.len()]
            .iter()
            .any(|&l| l < n)
        {
            return None;
        }
        // Floods weighing less than this cannot hold a press back.
        let bar = i64::from(thr) * i64::from(amp_med);
        let floor = (bar as f64 / f64::from(FAINT_STANDS_OUT)) as i64;
        // The heaviest two of the indentation's sign, the heaviest one of the other.
        let press = self.press_floods((ch, sign), (floor, amp_med), (min_total, 2));
        let &(peak, seed) = press.first()?;
        let other = (press.get(1).into_iter())
            .chain(
                self.press_floods((ch, -sign), (floor, amp_med), (min_total, 1))
                    .first(),
            )
            .map(|&(p, _)| p)
            .max();
        let press = peak > bar
            && other.is_none_or(|o| peak as f64 >= f64::from(FAINT_STANDS_OUT) * o as f64);
        press.then(|| self.flood((ch, sign), seed, &mut vec![false; n]))
    }

    /// Sample `k`'s phase signed by `sign`, weighed by its fringes
    /// ([`weighed_by_fringes`] with `amp_med`).
    fn weighed(&self, k: usize, sign: i32, amp_med: u32) -> i64 {
        match self.rel[k] {
            true => weighed_by_fringes(self.signed(k, sign).into(), self.amp_r[k], amp_med),
            false => i64::MIN,
        }
    }

    /// The half-peak flood from `seed` of the samples' phase signed by `sign`
    /// ([`Self::faint_press`]): the samples joined to it above half its phase, each marked
    /// in `seen`.
    fn flood(&self, (ch, sign): (usize, i32), seed: usize, seen: &mut [bool]) -> Vec<usize> {
        let half = self.signed(seed, sign) / 2;
        crate::mask::component(seen, (self.cw, ch), seed, |j| self.signed(j, sign) > half)
    }

    /// Sample `k`'s phase signed by `sign`; the lowest there is where it is unreliable.
    fn signed(&self, k: usize, sign: i32) -> i32 {
        match self.rel[k] {
            true => self.phi[k].saturating_mul(sign),
            false => i32::MIN,
        }
    }

    /// The heaviest `wanted` press-sized half-peak floods ([`Self::faint_press`]) of the
    /// samples' phase signed by `sign`, from seeds weighing more than `floor` (units times
    /// amplitude, [`Self::weighed`] with `amp_med`) that no heavier seed's flood took in:
    /// each one's weight and seed, heaviest first.
    fn press_floods(
        &self,
        (ch, sign): (usize, i32),
        (floor, amp_med): (i64, u32),
        (min_total, wanted): (usize, usize),
    ) -> Vec<(i64, usize)> {
        let n = self.cw * ch;
        let weighed = |k: usize| self.weighed(k, sign, amp_med);
        let mut seeds: Vec<usize> = (0..n).filter(|&k| weighed(k) > floor).collect();
        seeds.sort_unstable_by_key(|&k| std::cmp::Reverse(weighed(k)));
        // One buffer for every flood, cleared behind it: a flood marks only what it takes.
        let (mut taken, mut seen) = (vec![false; n], vec![false; n]);
        let mut out = Vec::new();
        for seed in seeds {
            if out.len() == wanted {
                break;
            }
            if taken[seed] {
                continue;
            }
            let flood = self.flood((ch, sign), seed, &mut seen);
            for &j in &flood {
                (taken[j], seen[j]) = (true, false);
            }
            if (min_total..=FAINT_PRESS_MAX_DISCS * min_total).contains(&flood.len()) {
                out.push((weighed(seed), seed));
            }
        }
        out
    }
}

/// A phase (units) weighed by the fringes it was read on: times their reference amplitude
/// `amp`, capped at the median `amp_med`. The phase's noise grows as the fringes fade, so a
/// phase on faint fringes counts for less, and one on bright fringes for no more than at
/// the median ([`contact_tiles`]' threshold holds there).
fn weighed_by_fringes(units: i64, amp: u32, amp_med: u32) -> i64 {
    units * i64::from(amp.min(amp_med))
}

/// How many discs a period across a faint press's half-peak flood may cover
/// ([`contact_tiles`]): a press that faint is narrower than the band, so the band's
/// own spread sets its width; wider is a field.
pub const FAINT_PRESS_MAX_DISCS: usize = 8;
/// How many times as much as every other press-sized flood of the frame, of either sign, a
/// faint press must weigh, its peak weighed by its fringes ([`Samples::faint_press`]):
/// those are the frame's own noise, which the band spreads to a press's width.
pub const FAINT_STANDS_OUT: f32 = 1.25;

/// Per coarse sample (`cw × ch`), whether its tile is set in `tiles` (`tw` across). The
/// rows of a tile row are the same: the first is built, the others copied.
pub(super) fn samples_in(tiles: &[bool], (cw, ch): (usize, usize), tw: usize) -> Vec<bool> {
    const PER: usize = TILE_PX / GRID;
    let mut out = vec![false; cw * ch];
    for cy in 0..ch {
        if cy % PER == 0 {
            let trow = &tiles[(cy / PER) * tw..(cy / PER + 1) * tw];
            let row = &mut out[cy * cw..(cy + 1) * cw];
            // Whole tiles as fixed-size runs, then the row's partial last tile.
            let (runs, rest) = row.as_chunks_mut::<PER>();
            for (run, &t) in runs.iter_mut().zip(trow) {
                *run = [t; PER];
            }
            if let Some(&t) = trow.get(runs.len()) {
                rest.fill(t);
            }
        } else {
            out.copy_within((cy - 1) * cw..cy * cw, cy * cw);
        }
    }
    out
}

/// The upper median (the `len / 2`-th smallest), 0 for none.
pub(super) fn median<T: Ord + Copy + Default>(mut v: Vec<T>) -> T {
    if v.is_empty() {
        return T::default();
    }
    let k = v.len() / 2;
    *v.select_nth_unstable(k).1
}

/// Step between the samples whose deviation enters the noise floor's median, each way:
/// every second coarse sample (4 800 at 320×240 working) estimates a MAD within about 2 %,
/// at a quarter of the cost of all of them.
pub const NOISE_STEP: usize = 2;

/// Phase noise (1σ, phase units): the robust spread of the phase minus its local mean over
/// a box of `box_px` samples (about two periods), so smooth deformation does not count as
/// noise. `phi` is `w × h` samples (the coarse grid); the spread is taken over every
/// `NOISE_STEP`-th of them each way.
pub fn local_noise_units(phi: &[i32], reliable: &[bool], w: usize, h: usize, box_px: usize) -> i32 {
    let r = (box_px / 2).max(1);
    let area = ((2 * r + 1) * (2 * r + 1)) as i64;
    let mut dev = Vec::new();
    let row = |y: usize| &phi[y * w..(y + 1) * w];
    if h > 2 * r && w > 2 * r {
        // Column sums over the box's rows, slid down NOISE_STEP rows at a time, and their
        // prefix sums along the row: a box sum is one difference, and only the sampled rows
        // are ever summed across (no integral image of the whole grid).
        let mut col = vec![0i64; w];
        for y in 0..=2 * r {
            for (c, &v) in col.iter_mut().zip(row(y)) {
                *c += i64::from(v);
            }
        }
        let mut pre = vec![0i64; w + 1];
        let mut y = r;
        loop {
            let mut acc = 0i64;
            for (p, &c) in pre[1..].iter_mut().zip(&col) {
                acc += c;
                *p = acc;
            }
            // Every NOISE_STEP-th x in r..w − r: the deviation times the box's area
            // (dividing is monotone, so the median is divided once, below), the box sum
            // being pre[x + r + 1] − pre[x − r].
            let xs = y * w + r..(y + 1) * w - r;
            let boxes = pre[2 * r + 1..].iter().zip(&pre[..w - 2 * r]);
            let samples = phi[xs.clone()].iter().zip(&reliable[xs]).zip(boxes);
            dev.extend(
                samples
                    .step_by(NOISE_STEP)
                    .filter(|((_, ok), _)| **ok)
                    .map(|((&p, _), (&hi, &lo))| (i64::from(p) * area - (hi - lo)).unsigned_abs()),
            );
            if y + NOISE_STEP >= h - r {
                break;
            }
            for k in 0..NOISE_STEP {
                for ((c, &out), &new) in col.iter_mut().zip(row(y - r + k)).zip(row(y + r + 1 + k))
                {
                    *c += i64::from(new) - i64::from(out);
                }
            }
            y += NOISE_STEP;
        }
    }
    // 1.4826 × MAD, in integers (×1518 / 1024), the deviation rounded up to a unit.
    let mad = median(dev).div_ceil(area as u64);
    ((mad as i64 * 1518 / 1024) as i32).max(1)
}

/// The trusted area of a `w × h` working image: pixels at least `m` from every edge. Near
/// the edge neither the FFT (periodic wrap) nor the box filters (padded edges) see a whole
/// neighbourhood.
#[derive(Debug, Clone)]
pub(super) struct Margin {
    /// Trusted columns and rows.
    pub(super) xs: std::ops::Range<usize>,
    pub(super) ys: std::ops::Range<usize>,
}

impl Margin {
    pub(super) fn new(m: usize, w: usize, h: usize) -> Margin {
        let span = |n: usize| m.min(n)..n.saturating_sub(m).max(m.min(n));
        Margin {
            xs: span(w),
            ys: span(h),
        }
    }

    pub(super) fn contains(&self, x: usize, y: usize) -> bool {
        self.xs.contains(&x) && self.ys.contains(&y)
    }
}

/// The coarse grid's samples: every [`GRID`]-th working pixel each way, row-major.
pub(super) struct Coarse<'a, P> {
    /// Samples across.
    pub(super) cw: usize,
    /// Wrapped phase difference.
    pub(super) phase: Vec<P>,
    /// Frame and reference fringe amplitudes.
    pub(super) amp: Vec<u32>,
    pub(super) amp_r: std::borrow::Cow<'a, [u32]>,
    /// Inside the margin, with both amplitudes above `lim`.
    pub(super) rel: Vec<bool>,
    /// The same inside the contact's margin (narrower): where a contact's phase is read.
    pub(super) rel_contact: Vec<bool>,
    /// Samples inside the margin, and those reliable.
    pub(super) inside_n: usize,
    pub(super) reliable_n: usize,
    /// The amplitude a reliable sample exceeds in both maps.
    lim: u32,
}

impl<P> Coarse<'_, P> {
    /// Whether the reference's fringe at sample `k` was bright enough to read.
    pub(super) fn reference_readable(&self, k: usize) -> bool {
        self.amp_r.get(k).is_some_and(|&a| a > self.lim)
    }
}

/// The coarse samples (`cw × ch`) inside `m`, one run per row: columns `cx` with `cx·GRID`
/// in `xs`, rows likewise.
fn sample_runs(
    m: &Margin,
    (cw, ch): (usize, usize),
) -> impl Iterator<Item = std::ops::Range<usize>> + '_ {
    let cols = m.xs.start.div_ceil(GRID).min(cw)..m.xs.end.div_ceil(GRID).min(cw);
    (0..ch)
        .filter(|cy| m.ys.contains(&(cy * GRID)))
        .map(move |cy| cy * cw + cols.start..cy * cw + cols.end)
}

/// Reads the coarse grid: the only place the background's phase is computed. Samples are
/// reliable inside `margin` (the background's) or `contact_margin` (a contact's, no wider
/// than the background's) where both amplitudes exceed `lim`.
pub(super) fn read_coarse<'a, M: PhaseMap>(
    map: &'a M,
    lim: u32,
    margin: &Margin,
    contact_margin: &Margin,
) -> Coarse<'a, M::P> {
    let (w, h) = map.size();
    let (cw, ch) = (w.div_ceil(GRID), h.div_ceil(GRID));
    let n = cw * ch;
    // One plain pass per map (collected from exact-size iterators: no capacity test per
    // sample).
    let phase: Vec<M::P> = map.wrapped_all();
    let amp = map.amp_frame_all();
    let amp_r = map.amp_ref_all();
    let mut rel_contact = vec![false; n];
    for run in sample_runs(contact_margin, (cw, ch)) {
        let pairs = amp[run.clone()].iter().zip(&amp_r[run.clone()]);
        for (r, (&a, &b)) in rel_contact[run].iter_mut().zip(pairs) {
            *r = a > lim && b > lim;
        }
    }
    let (mut inside_n, mut reliable_n) = (0, 0);
    let mut rel = vec![false; n];
    for run in sample_runs(margin, (cw, ch)) {
        rel[run.clone()].copy_from_slice(&rel_contact[run.clone()]);
        inside_n += run.len();
        reliable_n += rel[run].iter().map(|&r| usize::from(r)).sum::<usize>();
    }
    Coarse {
        cw,
        phase,
        amp,
        amp_r,
        rel,
        rel_contact,
        inside_n,
        reliable_n,
        lim,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The noise floor by an integral image of the whole grid, as it was computed before
    /// the sliding column sums.
    fn noise_by_integral_image(
        phi: &[i32],
        reliable: &[bool],
        w: usize,
        h: usize,
        box_px: usize,
    ) -> i32 {
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
        for y in (r..h.saturating_sub(r)).step_by(NOISE_STEP) {
            for x in (r..w.saturating_sub(r)).step_by(NOISE_STEP) {
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
        ((i64::from(median(dev)) * 1518 / 1024) as i32).max(1)
    }

    /// Sliding column sums give the integral image's noise floor, box by box, on grids of
    /// odd and even sides and boxes of several sizes.
    #[test]
    fn noise_floor_follows_the_integral_image() {
        let mut rng = crate::test_rng::XorShift(0x0123_4567_89ab_cdef);
        let mut next = move || rng.next();
        for (w, h) in [(160usize, 120usize), (37, 23), (9, 8), (5, 4)] {
            for box_px in [2usize, 5, 8, 12] {
                let phi: Vec<i32> = (0..w * h)
                    .map(|i| (i % w) as i32 * 40 + (next() % 900) as i32 - 450)
                    .collect();
                let rel: Vec<bool> = (0..w * h).map(|_| next() % 7 != 0).collect();
                assert_eq!(
                    local_noise_units(&phi, &rel, w, h, box_px),
                    noise_by_integral_image(&phi, &rel, w, h, box_px),
                    "{w}x{h} box {box_px}"
                );
            }
        }
    }

    /// Random masks of working sizes whose sides are not multiples of a tile.
    fn masks() -> impl Iterator<Item = (Vec<bool>, (usize, usize))> {
        let mut rng = crate::test_rng::XorShift(0x9e37_79b9_7f4a_7c15);
        [(320usize, 240usize), (322, 243), (38, 17)]
            .into_iter()
            .flat_map(|(w, h)| [1u64, 5, 40].map(|ppm| (w, h, ppm)))
            .map(move |(w, h, ppm)| {
                let (cw, ch) = (w.div_ceil(GRID), h.div_ceil(GRID));
                let mask = (0..cw * ch).map(|_| rng.next() % 100 < ppm).collect();
                (mask, (w, h))
            })
    }

    /// A phase map of random amplitudes, for the reliability rule.
    struct RandomAmps {
        size: (usize, usize),
        amp: Vec<u32>,
        amp_ref: Vec<u32>,
    }

    impl PhaseMap for RandomAmps {
        type P = i32;
        fn size(&self) -> (usize, usize) {
            self.size
        }
        fn wrapped(&self, k: usize) -> i32 {
            k as i32
        }
        fn amp_frame(&self, k: usize) -> u32 {
            self.amp[k]
        }
        fn amp_ref(&self, k: usize) -> u32 {
            self.amp_ref[k]
        }
        fn amp_ref_median(&self) -> u32 {
            500
        }
        fn saturated_fraction(&self) -> f32 {
            0.0
        }
        fn depth_um(&self, x: i32) -> i32 {
            x
        }
    }

    /// Reliability per coarse sample against its plain reading: inside the margin (the
    /// sample's working pixel, `GRID·cx`, `GRID·cy`) with both amplitudes above the limit,
    /// for the background's margin and a contact's narrower one; odd and even sizes and
    /// margins, one wider than the image.
    #[test]
    fn reliable_samples_follow_the_margin_and_amplitudes() {
        let mut rng = crate::test_rng::XorShift(0x2545_f491_4f6c_dd1d);
        for ((w, h), m) in [
            ((320usize, 240usize), 24),
            ((37, 23), 5),
            ((38, 17), 3),
            ((9, 7), 20),
        ] {
            let n = w.div_ceil(GRID) * h.div_ceil(GRID);
            let map = RandomAmps {
                size: (w, h),
                amp: (0..n).map(|_| (rng.next() % 1000) as u32).collect(),
                amp_ref: (0..n).map(|_| (rng.next() % 1000) as u32).collect(),
            };
            let (margin, contact_margin) = (Margin::new(m, w, h), Margin::new(m * 2 / 3, w, h));
            let c = read_coarse(&map, 300, &margin, &contact_margin);
            let cw = w.div_ceil(GRID);
            let (mut inside_n, mut reliable_n) = (0, 0);
            for k in 0..n {
                let (x, y) = (GRID * (k % cw), GRID * (k / cw));
                let bright = map.amp[k] > 300 && map.amp_ref[k] > 300;
                let (inside, want) = (margin.contains(x, y), margin.contains(x, y) && bright);
                assert_eq!(c.rel[k], want, "{w}×{h} margin {m}, sample {k}");
                let want_contact = contact_margin.contains(x, y) && bright;
                assert_eq!(
                    c.rel_contact[k], want_contact,
                    "{w}×{h} margin {m}, sample {k}"
                );
                inside_n += usize::from(inside);
                reliable_n += usize::from(want);
            }
            assert_eq!((c.inside_n, c.reliable_n), (inside_n, reliable_n));
            assert_eq!((c.phase.len(), c.amp.len(), c.amp_r.len()), (n, n, n));
        }
    }

    /// Where the reference's fringes are a third of their median amplitude, a sample needs
    /// three times the phase for a contact to be found; brighter fringes than the median
    /// do not lower the threshold. A contact found holds its fainter samples above the
    /// plain threshold too.
    #[test]
    fn faint_fringes_need_a_phase_their_noise_cannot_reach() {
        let per = TILE_PX / GRID;
        let (cw, ch) = (3 * per, per);
        let (tw, th) = (3, 1);
        // Two samples of tile `t` stand out by `p`.
        let stand_out = |phi: &mut Vec<i32>, t: usize, p: i32| {
            phi[t * per + 1] = p;
            phi[t * per + 2] = -p;
        };
        let phase = |p: i32| {
            let mut phi = vec![0i32; cw * ch];
            stand_out(&mut phi, 1, p);
            phi
        };
        let rel = vec![true; cw * ch];
        let tiles = |phi: &[i32], amp_r: &[u32]| {
            contact_tiles(phi, &rel, (amp_r, 90), (10, Some(1)), (cw, ch), (tw, th), 0)
        };
        let found = |phi: &[i32], amp: u32| tiles(phi, &vec![amp; cw * ch]).is_some();
        assert!(found(&phase(11), 90));
        assert!(found(&phase(11), 900));
        assert!(!found(&phase(10), 900));
        assert!(!found(&phase(30), 30));
        assert!(found(&phase(31), 30));
        // Tile 0 bright, tiles 1 and 2 faint: only tile 1's phase is high enough there, but
        // tile 2's samples above 10 belong to the contact it makes.
        let mut amp_r = vec![30; cw * ch];
        amp_r[..per].fill(90);
        let mut phi = phase(31);
        stand_out(&mut phi, 2, 11);
        let want = ContactTiles {
            on: vec![true; 3],
            n: 3,
            faint: false,
        };
        assert_eq!(tiles(&phi, &amp_r), Some(want));
        let mut faint_only = vec![0i32; cw * ch];
        stand_out(&mut faint_only, 2, 11);
        assert_eq!(tiles(&faint_only, &amp_r), None);
    }

    /// A press the band spread wider than the few samples its peak lifts above the
    /// threshold is found by its half-peak flood, and said to be faint; a speck as high and
    /// a field that floods the view are not, nor is a raised spot (the sign is the
    /// indentation's), nor a press the frame's own noise matches elsewhere.
    #[test]
    fn a_faint_press_is_found_by_its_shape() {
        let (cw, ch) = (40usize, 40usize);
        let (tw, th) = (cw * GRID / TILE_PX, ch * GRID / TILE_PX);
        let thr = 100;
        let (min_total, sign) = (22, -1);
        let bump_at = |(x, y): (f32, f32), peak: f32, sigma: f32| -> Vec<i32> {
            (0..cw * ch)
                .map(|k| {
                    let (dx, dy) = ((k % cw) as f32 - x, (k / cw) as f32 - y);
                    let g = (-(dx * dx + dy * dy) / (2.0 * sigma * sigma)).exp();
                    (sign as f32 * peak * thr as f32 * g).round() as i32
                })
                .collect()
        };
        let bump = |peak: f32, sigma: f32| bump_at((20.0, 20.0), peak, sigma);
        let rel = vec![true; cw * ch];
        let amp = vec![9u32; cw * ch];
        let find_by = |phi: &[i32], sign: Option<i32>| {
            let amp = (&amp[..], 9);
            contact_tiles(phi, &rel, amp, (thr, sign), (cw, ch), (tw, th), min_total)
        };
        let find = |phi: &[i32], sign: i32| find_by(phi, Some(sign));
        // Peak 1.3 thresholds, σ 3 samples: about 15 samples above the threshold, 39 above
        // half the peak.
        let press = bump(1.3, 3.0);
        let above = press.iter().filter(|p| p.abs() > thr).count();
        assert!((TILE_MIN_SAMPLES..min_total).contains(&above), "{above}");
        assert!(find(&press, sign).is_some_and(|t| t.faint && t.on.iter().any(|&o| o)));
        // Nor where no faint press is looked for (the colour's field taken out).
        assert!(find_by(&press, None).is_none());
        // The same spot raised instead of sunk is no press.
        assert!(find(&press, -sign).is_none());
        // A speck three thresholds high, σ one sample: its flood is a few samples.
        assert!(find(&bump(3.0, 1.0), sign).is_none());
        // A field at 0.6 thresholds over the view with a bump lifting one place past it.
        let field: Vec<i32> = bump(0.45, 1.5)
            .iter()
            .map(|&b| b + sign * 6 * thr / 10)
            .collect();
        assert!(field.iter().any(|p| p.abs() > thr));
        assert!(find(&field, sign).is_none());
        // Beside a raised spot of the frame's noise as wide and nearly as high, nothing
        // tells the press from noise; beside a lower one it stands out.
        let beside = |other: f32| -> Vec<i32> {
            let noise = bump_at((32.0, 8.0), other, 3.0);
            bump_at((12.0, 30.0), 1.3, 3.0)
                .iter()
                .zip(&noise)
                .map(|(p, n)| p - n)
                .collect()
        };
        assert!(find(&beside(1.1), sign).is_none());
        assert!(find(&beside(0.9), sign).is_some_and(|t| t.faint));
        // A speck elsewhere, two samples of one tile above the threshold, is not the faint
        // press's place: the region is the press's own.
        let per = TILE_PX / GRID;
        let tile_of = |(x, y): (usize, usize)| (y / per) * tw + x / per;
        let with_speck: Vec<i32> = bump_at((12.0, 30.0), 1.3, 3.0)
            .iter()
            .zip(bump_at((32.5, 8.0), 2.0, 0.8))
            .map(|(p, s)| p + s)
            .collect();
        let above = with_speck.iter().filter(|p| p.abs() > thr).count();
        assert!(above < min_total, "{above}");
        let found = find(&with_speck, sign).expect("the faint press");
        assert!(found.faint && found.on[tile_of((12, 30))]);
        assert!(!found.on[tile_of((32, 8))]);
        // A press standing high enough is found as every press is, not as a faint one.
        assert!(find(&bump(3.0, 3.0), sign).is_some_and(|t| !t.faint));
    }

    /// A faint press where the fringes are bright stands out of noise as high where they
    /// are faint: the phase's noise grows as the fringes fade, so the floods are weighed by
    /// their fringes. The same noise where the fringes are bright still holds it back.
    #[test]
    fn a_dim_corners_noise_does_not_hold_back_a_faint_press() {
        let (cw, ch) = (40usize, 40usize);
        let (tw, th) = (cw * GRID / TILE_PX, ch * GRID / TILE_PX);
        let (thr, min_total, sign) = (100, 22, -1);
        let bump_at = |(x, y): (f32, f32), peak: f32| -> Vec<f32> {
            (0..cw * ch)
                .map(|k| {
                    let (dx, dy) = ((k % cw) as f32 - x, (k / cw) as f32 - y);
                    peak * thr as f32 * (-(dx * dx + dy * dy) / 18.0).exp()
                })
                .collect()
        };
        // The press peaks at 1.3 thresholds, a noise bump of the other sign at 1.1.
        let phi: Vec<i32> = bump_at((12.0, 30.0), 1.3)
            .iter()
            .zip(bump_at((32.0, 8.0), 1.1))
            .map(|(p, n)| (sign as f32 * (p - n)).round() as i32)
            .collect();
        let rel = vec![true; cw * ch];
        let find = |amp_r: &[u32]| {
            let amp = (amp_r, 9);
            contact_tiles(
                &phi,
                &rel,
                amp,
                (thr, Some(sign)),
                (cw, ch),
                (tw, th),
                min_total,
            )
        };
        let bright = vec![9u32; cw * ch];
        assert!(
            find(&bright).is_none(),
            "noise as high where the fringes are as bright"
        );
        // The noise's corner at under half the median amplitude, the press's at the median.
        let dim: Vec<u32> = (0..cw * ch)
            .map(|k| if k % cw >= 24 && k / cw < 16 { 4 } else { 9 })
            .collect();
        let per = TILE_PX / GRID;
        let found = find(&dim).expect("the faint press beside the dim corner's noise");
        assert!(found.faint && found.on[(30 / per) * tw + 12 / per]);
        assert!(!found.on[(8 / per) * tw + 32 / per]);
    }

    /// Tile counts and per-sample tile membership against a plain reading, sample by
    /// sample (`cx / per`).
    #[test]
    fn tiles_and_samples_follow_the_grid() {
        let per = TILE_PX / GRID;
        for (above, (w, h)) in masks() {
            let (cw, ch) = (w.div_ceil(GRID), h.div_ceil(GRID));
            let (tw, th) = (w.div_ceil(TILE_PX), h.div_ceil(TILE_PX));
            let mut count = vec![0usize; tw * th];
            for (k, a) in above.iter().enumerate() {
                count[(k / cw / per) * tw + (k % cw) / per] += usize::from(*a);
            }
            let active: Vec<bool> = count.iter().map(|&c| c >= TILE_MIN_SAMPLES).collect();
            // A tile is set when any tile of its 3 × 3 neighbourhood is active.
            let want: Vec<bool> = (0..tw * th)
                .map(|t| {
                    let (tx, ty) = (t % tw, t / tw);
                    (ty.saturating_sub(1)..(ty + 2).min(th)).any(|y| {
                        (tx.saturating_sub(1)..(tx + 2).min(tw)).any(|x| active[y * tw + x])
                    })
                })
                .collect();
            assert_eq!(dilate(&active, tw, th), want, "{w}x{h}");
            // The mask as phases: above the threshold where set, on reliable samples
            // or not, and a reliable sample below it elsewhere.
            let phi: Vec<i32> = above
                .iter()
                .enumerate()
                .map(|(k, a)| {
                    if *a {
                        [50, -50][k % 2]
                    } else {
                        7 * (k % 2) as i32
                    }
                })
                .collect();
            let amp = (&vec![9; phi.len()][..], 9);
            let with_rel = |rel: bool| {
                let rel = vec![rel; phi.len()];
                contact_tiles(&phi, &rel, amp, (10, Some(1)), (cw, ch), (tw, th), 0)
            };
            let got = with_rel(true);
            assert!(with_rel(false).is_none());
            match got {
                Some(ContactTiles { on, n, faint }) => {
                    assert_eq!(on, want, "{w}x{h}");
                    assert_eq!(n, want.iter().filter(|t| **t).count());
                    assert!(!faint, "{w}x{h}");
                }
                None => assert!(active.iter().all(|a| !a), "{w}x{h}"),
            }
            let samples = samples_in(&want, (cw, ch), tw);
            assert_eq!(samples.len(), cw * ch);
            for (k, s) in samples.iter().enumerate() {
                assert_eq!(
                    *s,
                    want[(k / cw / per) * tw + (k % cw) / per],
                    "{w}x{h} {k}"
                );
            }
        }
    }
}
