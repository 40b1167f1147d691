//! Quality-guided phase unwrapping, restricted to the contact region.
//!
//! Outside the region the phase difference is background (within noise of 0 after
//! registration), so those pixels are already unwrapped and serve as seeds. From the
//! region's border inward, the pixel of highest quality next to an unwrapped one is taken
//! next, and gets its neighbour's unwrapped value plus the wrapped difference
//! between them. Noisy, low-amplitude pixels are reached last, so an error there cannot
//! propagate into good areas. The queue is a bucket queue over [`QUALITY_LEVELS`] levels of
//! quality rather than a binary heap: constant time per pixel, and the order only differs
//! among pixels of nearly equal quality, where it does not matter. Generic over the phase
//! representation: `f32` radians on the float path, `i32` in units of 2π/65 536 on the
//! device path.
//!
//! **Residue-free windows by scan lines.** Where no 2 × 2 loop of the window has a residue,
//! the unwrapped phase does not depend on the path: it is the one field whose neighbour
//! differences are the wrapped differences, up to a constant that the seeds fix. The device
//! path's integer phases are exact, so [`unwrap_window`] builds that field along the rows
//! and checks every vertical difference against it (which is the residue test), then
//! checks the seeds against it: when everything holds, the result equals the
//! quality-guided fill's sample for sample, at a few instructions per sample instead of a
//! queue. Otherwise (a residue, no seed, a seed off the field) the quality-guided fill
//! runs. Float phases always take the fill (their loop sums are not exactly zero).

/// Quality levels of the unwrapping queue.
pub const QUALITY_LEVELS: usize = 64;

/// A phase representation.
pub trait Phase: Copy + Default {
    /// `a − b`, wrapped into (−π, π].
    fn wrapped_diff(a: Self, b: Self) -> Self;
    /// `a + b`.
    fn add(a: Self, b: Self) -> Self;
    /// Whole turns in `x` (rounded).
    fn turns(x: Self) -> i32;
    /// The unwrapped window when it is free of residues and its seeds (the samples outside
    /// `region`) agree with it, by scan lines (see the module doc); `None` otherwise, and
    /// always for a representation whose arithmetic is not exact.
    fn scan_unwrap(wrapped: &[Self], region: &[bool], w: usize, h: usize) -> Option<Vec<Self>> {
        let _ = (wrapped, region, w, h);
        None
    }
}

impl Phase for f32 {
    fn wrapped_diff(a: f32, b: f32) -> f32 {
        let d = a - b;
        d - std::f32::consts::TAU * (d / std::f32::consts::TAU).round()
    }
    fn add(a: f32, b: f32) -> f32 {
        a + b
    }
    fn turns(x: f32) -> i32 {
        (x / std::f32::consts::TAU).round() as i32
    }
}

/// Phase in units of 2π/65 536: wrapping is a cast to `i16`.
impl Phase for i32 {
    fn wrapped_diff(a: i32, b: i32) -> i32 {
        i32::from(a.wrapping_sub(b) as i16)
    }
    fn add(a: i32, b: i32) -> i32 {
        a.wrapping_add(b)
    }
    fn turns(x: i32) -> i32 {
        (x + 32_768).div_euclid(65_536)
    }
    fn scan_unwrap(wrapped: &[i32], region: &[bool], w: usize, h: usize) -> Option<Vec<i32>> {
        if w == 0 || h == 0 || wrapped.len() != w * h || region.len() != w * h {
            return None;
        }
        let d = |a: i32, b: i32| i32::wrapped_diff(a, b);
        // Each row from its first sample, the first samples down the first column; every
        // vertical difference is then checked against the field: all hold exactly when no
        // 2 × 2 loop has a residue. Sums stay within ±2³¹: a window holds far fewer than
        // 65 536 samples along any path. The checks fold without an early exit, so they
        // vectorise.
        let mut u = vec![0i32; w * h];
        let mut first = wrapped[0];
        for y in 0..h {
            let row = &wrapped[y * w..(y + 1) * w];
            if y > 0 {
                first = first.wrapping_add(d(row[0], wrapped[(y - 1) * w]));
            }
            let (done, rest) = u.split_at_mut(y * w);
            let here = &mut rest[..w];
            let mut v = first;
            here[0] = v;
            for (f, pair) in here[1..].iter_mut().zip(row.windows(2)) {
                v = v.wrapping_add(d(pair[1], pair[0]));
                *f = v;
            }
            if y > 0 {
                let above = &done[(y - 1) * w..];
                let up = &wrapped[(y - 1) * w..y * w];
                let consistent = above
                    .iter()
                    .zip(here.iter())
                    .zip(up.iter().zip(row))
                    .fold(true, |ok, ((&a, &b), (&p, &q))| {
                        ok & (b.wrapping_sub(a) == d(q, p))
                    });
                if !consistent {
                    return None;
                }
            }
        }
        // The seeds fix the constant, and must all agree with it.
        let s = region.iter().position(|r| !r)?;
        let c = wrapped[s].wrapping_sub(u[s]);
        let agree = u
            .iter()
            .zip(wrapped)
            .zip(region)
            .fold(true, |ok, ((&f, &p), &r)| {
                ok & (r | (f.wrapping_add(c) == p))
            });
        if !agree {
            return None;
        }
        for f in &mut u {
            *f = f.wrapping_add(c);
        }
        Some(u)
    }
}

/// Unwraps the window `wrapped` (`w × h`) inside `unwrapped`, seeded from the samples
/// outside it: by scan lines when the window is free of residues (exact representations;
/// see the module doc), otherwise by the quality-guided fill ordered by `quality()`
/// (computed only then). Returns the unwrapped phase, and the samples of `counted` (within
/// `unwrapped`: those whose failures matter) no seed reaches and the residues among them.
pub fn unwrap_window<P: Phase>(
    wrapped: &[P],
    (unwrapped, counted): (&[bool], &[bool]),
    w: usize,
    h: usize,
    quality: impl FnOnce() -> Vec<u32>,
) -> (Vec<P>, usize, usize) {
    if let Some(u) = P::scan_unwrap(wrapped, unwrapped, w, h) {
        return (u, 0, 0);
    }
    let (u, done) = fill(wrapped, &quality(), unwrapped, w, h);
    (
        u,
        unreached(counted, &done),
        residues(wrapped, counted, w, h),
    )
}

/// Unwraps `wrapped` inside `region` (both `w × h`), seeded from the pixels outside it.
/// `quality` orders the fill. Returns the unwrapped phase (equal to `wrapped` outside the
/// region) and the number of region pixels that could not be reached.
pub fn unwrap_region<P: Phase>(
    wrapped: &[P],
    quality: &[u32],
    region: &[bool],
    w: usize,
    h: usize,
) -> (Vec<P>, usize) {
    let (out, done) = fill(wrapped, quality, region, w, h);
    (out, unreached(region, &done))
}

/// How many samples of `of` the fill left without a value (`done` false).
fn unreached(of: &[bool], done: &[bool]) -> usize {
    of.iter().zip(done).filter(|(o, d)| **o && !**d).count()
}

/// The quality-guided fill of [`unwrap_region`]: the unwrapped phase, and which samples
/// hold an unwrapped value (the seeds and every region sample reached).
fn fill<P: Phase>(
    wrapped: &[P],
    quality: &[u32],
    region: &[bool],
    w: usize,
    h: usize,
) -> (Vec<P>, Vec<bool>) {
    let mut out = wrapped.to_vec();
    let mut done: Vec<bool> = region.iter().map(|r| !r).collect();
    let qmax = u64::from(quality.iter().copied().max().unwrap_or(0).max(1));
    // Each pixel's queue level, once (a pixel is queued once per neighbour reached).
    let level: Vec<u8> = quality
        .iter()
        .map(|&q| ((u64::from(q) * (QUALITY_LEVELS as u64 - 1)) / qmax) as u8)
        .collect();
    let mut buckets: Vec<Vec<usize>> = vec![Vec::new(); QUALITY_LEVELS];
    let mut top = 0usize;
    // Pixel `i` at (`x`, `y`): left, right, up, down.
    let neighbours = |i: usize, x: usize, y: usize| {
        [
            (x > 0).then(|| i - 1),
            (x + 1 < w).then(|| i + 1),
            (y > 0).then(|| i - w),
            (y + 1 < h).then(|| i + w),
        ]
    };
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if region[i]
                && neighbours(i, x, y)
                    .into_iter()
                    .flatten()
                    .any(|n| !region[n])
            {
                let l = usize::from(level[i]);
                buckets[l].push(i);
                top = top.max(l);
            }
        }
    }
    loop {
        while top > 0 && buckets[top].is_empty() {
            top -= 1;
        }
        let Some(i) = buckets[top].pop() else { break };
        if done[i] {
            continue;
        }
        let near = neighbours(i, i % w, i / w);
        let best = near
            .into_iter()
            .flatten()
            .filter(|&n| done[n])
            .max_by_key(|&n| quality[n]);
        let Some(n) = best else { continue };
        out[i] = P::add(out[n], P::wrapped_diff(wrapped[i], wrapped[n]));
        done[i] = true;
        for m in near.into_iter().flatten() {
            if !done[m] {
                let l = usize::from(level[m]);
                buckets[l].push(m);
                top = top.max(l);
            }
        }
    }
    (out, done)
}

/// Phase residues (2 × 2 loops whose wrapped differences do not sum to zero) inside
/// `region`: where they are, no unwrapping path is consistent.
pub fn residues<P: Phase>(wrapped: &[P], region: &[bool], w: usize, h: usize) -> usize {
    let mut n = 0;
    for y in 0..h.saturating_sub(1) {
        for x in 0..w.saturating_sub(1) {
            let (a, b, c, d) = (
                y * w + x,
                y * w + x + 1,
                (y + 1) * w + x + 1,
                (y + 1) * w + x,
            );
            if !(region[a] && region[b] && region[c] && region[d]) {
                continue;
            }
            let loop_sum = P::add(
                P::add(
                    P::wrapped_diff(wrapped[b], wrapped[a]),
                    P::wrapped_diff(wrapped[c], wrapped[b]),
                ),
                P::add(
                    P::wrapped_diff(wrapped[d], wrapped[c]),
                    P::wrapped_diff(wrapped[a], wrapped[d]),
                ),
            );
            if P::turns(loop_sum) != 0 {
                n += 1;
            }
        }
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bowl(w: usize, h: usize, depth: f32) -> Vec<f32> {
        (0..w * h)
            .map(|i| {
                let (x, y) = (
                    (i % w) as f32 - w as f32 / 2.0,
                    (i / w) as f32 - h as f32 / 2.0,
                );
                -depth * (-(x * x + y * y) / 60.0).exp()
            })
            .collect()
    }

    #[test]
    fn unwraps_a_deep_bowl_in_both_representations() {
        let (w, h) = (48, 40);
        let truth = bowl(w, h, 9.0);
        let wrapped: Vec<f32> = truth.iter().map(|&p| f32::wrapped_diff(p, 0.0)).collect();
        let region: Vec<bool> = truth.iter().map(|p| p.abs() > 0.05).collect();
        let quality = vec![1u32; w * h];
        let (u, unreached) = unwrap_region(&wrapped, &quality, &region, w, h);
        assert_eq!(unreached, 0);
        for (a, b) in u.iter().zip(&truth) {
            assert!((a - b).abs() < 1e-3, "{a} {b}");
        }
        let q: Vec<i32> = wrapped
            .iter()
            .map(|p| (p / std::f32::consts::TAU * 65_536.0).round() as i32)
            .collect();
        let (ui, _) = unwrap_region(&q, &quality, &region, w, h);
        for (a, b) in ui.iter().zip(&truth) {
            assert!((*a as f32 / 65_536.0 * std::f32::consts::TAU - b).abs() < 1e-3);
        }
        assert_eq!(residues(&wrapped, &region, w, h), 0);
    }

    /// A deep bowl in integer units with noise, its region, and random qualities.
    fn noisy_bowl(seed: u64) -> (Vec<i32>, Vec<bool>, Vec<u32>, usize, usize) {
        let (w, h) = (41, 37);
        let mut rng = crate::test_rng::XorShift(seed);
        let truth = bowl(w, h, 11.0);
        let wrapped: Vec<i32> = truth
            .iter()
            .map(|&p| {
                let noise = (rng.next() % 301) as i32 - 150;
                i32::wrapped_diff((p / std::f32::consts::TAU * 65_536.0) as i32 + noise, 0)
            })
            .collect();
        let region: Vec<bool> = truth.iter().map(|p| p.abs() > 0.05).collect();
        let quality: Vec<u32> = (0..w * h).map(|_| (rng.next() % 1000) as u32).collect();
        (wrapped, region, quality, w, h)
    }

    #[test]
    fn scan_lines_equal_the_quality_guided_fill_on_a_residue_free_window() {
        for seed in [1, 2, 3, 0x9e37_79b9] {
            let (wrapped, region, quality, w, h) = noisy_bowl(seed);
            let scanned = i32::scan_unwrap(&wrapped, &region, w, h).expect("residue-free");
            let (filled, unreached) = unwrap_region(&wrapped, &quality, &region, w, h);
            assert_eq!(unreached, 0);
            assert_eq!(scanned, filled, "seed {seed}");
            // More than a turn deep: the scan did unwrap.
            assert!(scanned.iter().any(|&p| p < -65_536));
            let (u, unreached, n_res) = unwrap_window(&wrapped, (&region, &region), w, h, || {
                panic!("the quality is only computed for the fill")
            });
            assert_eq!((u, unreached, n_res), (filled, 0, 0));
        }
    }

    #[test]
    fn windows_the_scan_cannot_take_fall_back_to_the_fill() {
        let (wrapped, region, quality, w, h) = noisy_bowl(7);
        // A residue: one sample of the deep slope moved by half a turn.
        let mut twisted = wrapped.clone();
        let i = (h / 2) * w + w / 2 + 3;
        twisted[i] = i32::wrapped_diff(twisted[i], 32_768);
        assert_eq!(i32::scan_unwrap(&twisted, &region, w, h), None);
        let (u, unreached, n_res) =
            unwrap_window(&twisted, (&region, &region), w, h, || quality.clone());
        let (filled, filled_unreached) = unwrap_region(&twisted, &quality, &region, w, h);
        assert_eq!((u, unreached), (filled, filled_unreached));
        assert_eq!(n_res, residues(&twisted, &region, w, h));
        assert!(n_res > 0);
        // Two opposite residues in one strip of rows: every row and the seed ring agree
        // with the scan, only the vertical differences across the cut between them do not.
        let (dw, dh) = (31, 21);
        let dipole: Vec<i32> = (0..dw * dh)
            .map(|i| {
                let (x, y) = ((i % dw) as f32, (i / dw) as f32);
                let a = (y - 10.5).atan2(x - 10.5) - (y - 10.5).atan2(x - 20.5);
                i32::wrapped_diff((a / std::f32::consts::TAU * 65_536.0) as i32, 0)
            })
            .collect();
        let ring: Vec<bool> = (0..dw * dh)
            .map(|i| (1..dw - 1).contains(&(i % dw)) && (1..dh - 1).contains(&(i / dw)))
            .collect();
        assert_eq!(residues(&dipole, &ring, dw, dh), 2);
        assert_eq!(i32::scan_unwrap(&dipole, &ring, dw, dh), None);
        // A seed a turn off the field: residue-free, yet the seeds disagree.
        let mut off = region.clone();
        off[(h / 2) * w + w / 2] = false;
        assert_eq!(i32::scan_unwrap(&wrapped, &off, w, h), None);
        // No seed at all: nothing fixes the constant, and the fill reaches nothing.
        let all = vec![true; w * h];
        assert_eq!(i32::scan_unwrap(&wrapped, &all, w, h), None);
        let (_, unreached, _) = unwrap_window(&wrapped, (&all, &all), w, h, || quality.clone());
        assert_eq!(unreached, w * h);
        // Only the counted samples' failures are reported.
        let half: Vec<bool> = (0..w * h).map(|i| i < w * h / 2).collect();
        let (_, unreached, _) = unwrap_window(&wrapped, (&all, &half), w, h, || quality.clone());
        assert_eq!(unreached, w * h / 2);
        // Float phases always take the fill.
        let f: Vec<f32> = wrapped.iter().map(|&p| p as f32 / 10_000.0).collect();
        assert_eq!(f32::scan_unwrap(&f, &region, w, h), None);
    }

    #[test]
    fn a_vortex_has_a_residue() {
        let (w, h) = (9, 9);
        let vortex: Vec<f32> = (0..w * h)
            .map(|i| ((i / w) as f32 - 4.5).atan2((i % w) as f32 - 4.5))
            .collect();
        let all = vec![true; w * h];
        assert_eq!(residues(&vortex, &all, w, h), 1);
        assert_eq!(i32::turns(65_536), 1);
        assert_eq!(i32::wrapped_diff(40_000, 0), 40_000 - 65_536);
    }
}
