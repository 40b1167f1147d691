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
    let unreached = region
        .iter()
        .zip(&done)
        .filter(|(r, d)| **r && !**d)
        .count();
    (out, unreached)
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
