//! Features of a depth map (peak, area, volume, centre), force from them, and the phase
//! slope the flags judge.

use super::FORCE_RANGE_SLACK;
use crate::calibration::{Calibration, ForceInputs, MAX_FORCE_N, MODEL_REACH};

/// Features of a depth map.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Features {
    /// Deepest point, mm: the map's deepest pixel from [`summarize`]; the measurement
    /// replaces it by the apex with the band's blur taken out (`super::apex`).
    pub peak_mm: f32,
    /// Area with depth ≥ half the peak, mm².
    pub area_mm2: f32,
    /// Σ depth × pixel area over pixels deeper than the threshold, mm³.
    pub volume_mm3: f32,
    /// Depth-weighted centre of the contact area, input pixels.
    pub centroid_px: Option<(f32, f32)>,
}

/// Features of a working-resolution depth map (µm), in integer sums: shared by both paths.
///
/// `depth_um` may be a window of the working image whose top-left pixel is `origin`;
/// `peak` is the map's value at the contact's apex and `contact` the apex's component
/// ([`peak_component`]), whose centre is the contact's.
pub fn summarize(
    depth_um: &[i32],
    contact: &[usize],
    w: usize,
    origin: (usize, usize),
    factor: usize,
    mm_per_px: f32,
    (peak, thr_um): (i32, i32),
) -> Features {
    let peak = peak.max(0);
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
    // The centre is that of the contact holding the peak, so a second, shallower blob
    // cannot drag it.
    let (mut wx, mut wy, mut ws) = (0i64, 0i64, 0i64);
    for &i in contact {
        let d = i64::from(depth_um[i]);
        wx += d * (i % w) as i64;
        wy += d * (i / w) as i64;
        ws += d;
    }
    let px_mm = mm_per_px * factor as f32;
    let px_area = px_mm * px_mm;
    let to_input = |v: f32, o: usize| (v + o as f32 + 0.5) * factor as f32;
    Features {
        peak_mm: peak as f32 / 1000.0,
        area_mm2: n_area as f32 * px_area,
        volume_mm3: vol as f32 / 1000.0 * px_area,
        centroid_px: (ws > 0).then(|| {
            (
                to_input(wx as f32 / ws as f32, origin.0),
                to_input(wy as f32 / ws as f32, origin.1),
            )
        }),
    }
}

/// The contact's region: of the 8-connected components deeper than `thr_um` (`w` wide),
/// the one that holds the most indentation (the largest depth sum), as indices into
/// `depth_um`. A press wins over a spot of a few pixels that reads deeper (a glare spot
/// whose light the skin's colour change altered, a phase residue at the border): its depth
/// is spread over the contact, the spot's is not. Empty without depth.
pub fn dominant_component(depth_um: &[i32], w: usize, thr_um: i32) -> Vec<usize> {
    // Runs of pixels deeper than the level, row by row, joined to the runs of the row above
    // that they touch (diagonals included): one scan of the window, however many regions.
    let level = thr_um.max(0);
    let mut runs: Vec<Run> = Vec::new();
    let mut parent: Vec<usize> = Vec::new();
    let mut above = 0..0;
    for (y, row) in depth_um.chunks_exact(w.max(1)).enumerate() {
        let first = runs.len();
        let mut x = 0;
        while x < row.len() {
            if row[x] <= level {
                x += 1;
                continue;
            }
            let (x0, mut sum) = (x, 0i64);
            while x < row.len() && row[x] > level {
                sum += i64::from(row[x]);
                x += 1;
            }
            let id = runs.len();
            runs.push(Run { y, x0, x1: x, sum });
            parent.push(id);
            for a in above.clone() {
                if runs[a].x0 <= x && x0 <= runs[a].x1 {
                    let (ra, rb) = (root(&mut parent, a), root(&mut parent, id));
                    parent[ra.max(rb)] = ra.min(rb);
                }
            }
        }
        above = first..runs.len();
    }
    let mut totals = vec![0i64; runs.len()];
    for (i, run) in runs.iter().enumerate() {
        let r = root(&mut parent, i);
        totals[r] += run.sum;
    }
    let Some(best) = (0..runs.len()).rev().max_by_key(|&i| totals[i]) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    for (i, &Run { y, x0, x1, .. }) in runs.iter().enumerate() {
        if root(&mut parent, i) == best {
            out.extend(y * w + x0..y * w + x1);
        }
    }
    out
}

/// A row's run of pixels deeper than a level: `[x0, x1)` on row `y`, and their depth sum.
#[derive(Debug, Clone, Copy)]
struct Run {
    y: usize,
    x0: usize,
    x1: usize,
    sum: i64,
}

/// The root of `i`'s set (halving the path on the way).
fn root(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

/// The pixels of the contact whose peak is at `peak_at` (its apex, `super::apex`): its
/// 8-connected component deeper than half the peak (and than `thr_um`), as indices into
/// `depth_um` (`w` wide). Empty without depth.
pub fn peak_component(depth_um: &[i32], w: usize, peak_at: usize, thr_um: i32) -> Vec<usize> {
    let Some(&peak) = depth_um.get(peak_at) else {
        return Vec::new();
    };
    if peak <= thr_um.max(0) {
        return Vec::new();
    }
    let (h, half) = (depth_um.len() / w.max(1), peak / 2);
    let mut seen = vec![false; depth_um.len()];
    crate::mask::component(&mut seen, (w, h), peak_at, |j| {
        depth_um[j] >= half && depth_um[j] > thr_um
    })
}

/// Force from the calibration's model, N, and whether it lies beyond what the calibration
/// covers (more than [`FORCE_RANGE_SLACK`] times its largest force label). Beyond the
/// calibration's largest input the model is extrapolated
/// ([`ForceModel::extrapolated_force_n`](crate::calibration::ForceModel::extrapolated_force_n))
/// as far as it was checked ([`MODEL_REACH`] times that input) and saturated there. A file
/// that does not record its range is read as it is, flagged and bounded at
/// [`MAX_FORCE_N`]. Never NaN or infinite.
pub fn bounded_force(calib: &Calibration, x: &ForceInputs) -> (f32, bool) {
    let Some(fm) = &calib.force else {
        return (0.0, false);
    };
    let u = f64::from(fm.model.feature.of(x));
    let (top, flagged_above) = fm.range.map_or((f64::INFINITY, MAX_FORCE_N), |r| {
        (r.input[1], FORCE_RANGE_SLACK * r.output[1])
    });
    let reach = MODEL_REACH * top;
    // NaN is not within reach: it reads as the farthest the model was checked.
    let within = u <= reach;
    let f = fm
        .model
        .extrapolated_force_n(if within { u } else { reach }, top);
    let bounded = if f.is_finite() {
        f.min(MAX_FORCE_N)
    } else {
        MAX_FORCE_N
    };
    (bounded as f32, !within || f.is_nan() || f > flagged_above)
}

/// Largest gradient component the 32-bit slope count keeps: 2·G_MAX² fits an `i32`.
const G_MAX: i32 = 32_767;

/// Whether the 98th percentile of the phase slope (⌊|∇u|⌋, units per working pixel) over
/// `mask` exceeds `limit`. Counted, not selected: a monotone map keeps order statistics, so
/// the percentile reaches the integer m = ⌊limit⌋ + 1 exactly when at most k of the n
/// samples (k = ⌊0.98 n⌋) have |∇u|² < m². One pass, no buffer, no square root.
pub(super) fn slope_p98_exceeds(u: &[i32], mask: &[bool], w: usize, h: usize, limit: f32) -> bool {
    if limit.is_nan() {
        return false;
    }
    let m = if limit < 0.0 {
        0
    } else {
        limit.floor() as i64 + 1
    };
    // 32-bit lanes where the vector unit multiplies them (A64); baseline x86-64 has no
    // 32-bit vector multiply, and its 64-bit loop is cheaper there.
    let narrow = cfg!(target_arch = "aarch64") && m <= i64::from(G_MAX);
    let (n, below) = slope_counts(u, mask, (w, h), m, narrow);
    if n == 0 {
        return 0.0 > limit;
    }
    let k = (n * 98 / 100).min(n - 1);
    below <= k
}

/// Over the interior of `u` (`w × h`): the samples where `mask` holds, and those among them
/// whose slope |∇u|² (central differences halved, truncated) is below `m²`. `narrow`
/// (only for `m ≤ G_MAX`) counts in 32 bits, four lanes to a vector: a gradient component
/// clamped to ±G_MAX keeps its test (|g| > G_MAX ≥ m fails it either way; a saturated
/// difference is beyond G_MAX too), and two squares of G_MAX fit.
fn slope_counts(
    u: &[i32],
    mask: &[bool],
    (w, h): (usize, usize),
    m: i64,
    narrow: bool,
) -> (usize, usize) {
    let m2 = m.saturating_mul(m);
    let (mut n, mut below) = (0usize, 0usize);
    if w >= 3 {
        // Row by row over shifted slices, branch-free: the masked-out samples count zero.
        for y in 1..h.saturating_sub(1) {
            let (above, row, under) = (
                &u[(y - 1) * w + 1..y * w - 1],
                &u[y * w..(y + 1) * w],
                &u[(y + 1) * w + 1..(y + 2) * w - 1],
            );
            let (left, right) = (&row[..w - 2], &row[2..]);
            let on = &mask[y * w + 1..(y + 1) * w - 1];
            let samples = on
                .iter()
                .zip(left.iter().zip(right))
                .zip(above.iter().zip(under));
            if narrow {
                let m2 = m2 as i32;
                let g = |a: i32, b: i32| (a.saturating_sub(b) / 2).clamp(-G_MAX, G_MAX);
                for ((&on, (&l, &r)), (&a, &b)) in samples {
                    let (gx, gy) = (g(r, l), g(b, a));
                    n += usize::from(on);
                    below += usize::from(on & (gx * gx + gy * gy < m2));
                }
            } else {
                for ((&on, (&l, &r)), (&a, &b)) in samples {
                    let gx = (i64::from(r) - i64::from(l)) / 2;
                    let gy = (i64::from(b) - i64::from(a)) / 2;
                    n += usize::from(on);
                    below += usize::from(on & (gx * gx + gy * gy < m2));
                }
            }
        }
    }
    (n, below)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::{FitRange, ForceFeature, ForceForm};

    /// Within the kit a force is the model's; past 1.1 × its largest label it is flagged
    /// and read on; past twice its largest input, and for a reading that is not a number,
    /// it stays where the check ended. A file without a range is read as it is up to what
    /// any skin can carry.
    #[test]
    fn a_force_is_read_on_past_the_kit_as_far_as_it_was_checked() {
        let mut calib = Calibration::default_sim();
        let fm = calib
            .force
            .as_mut()
            .expect("the default calibration has a force model");
        fm.model.feature = ForceFeature::ReciprocalLoad;
        fm.model.form = ForceForm::Linear { a: 2.0 };
        fm.range = Some(FitRange {
            input: [0.1, 5.0],
            output: [0.2, 10.0],
        });
        let at = |c: &Calibration, l: f32| {
            let x = ForceInputs {
                reciprocal_load_mm2: l,
                ..Default::default()
            };
            bounded_force(c, &x)
        };
        assert_eq!(at(&calib, 3.0), (6.0, false));
        assert_eq!(at(&calib, 5.4), (10.8, false));
        assert_eq!(at(&calib, 6.0), (12.0, true));
        assert_eq!(at(&calib, 40.0), (20.0, true));
        assert_eq!(at(&calib, f32::NAN), (20.0, true));
        if let Some(f) = calib.force.as_mut() {
            f.range = None;
        }
        assert_eq!(at(&calib, 3.0), (6.0, false));
        assert_eq!(at(&calib, 1e5), (MAX_FORCE_N as f32, true));
        assert_eq!(at(&calib, f32::NAN), (MAX_FORCE_N as f32, true));
    }

    /// The percentile by selection, as it was computed before it was counted.
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

    /// The 32-bit count equals the 64-bit one at every limit it is used for, with gradients
    /// far beyond ±G_MAX (clamped) and differences that overflow 32 bits (saturated).
    #[test]
    fn narrow_slope_counts_equal_the_wide_ones() {
        let mut rng = crate::test_rng::XorShift(0x5851_f42d_4c95_7f2d);
        for (w, h, spread) in [
            (31usize, 19usize, 1_000u64),
            (17, 23, 200_000),
            (9, 9, 1 << 32),
        ] {
            let u: Vec<i32> = (0..w * h)
                .map(|_| ((rng.next() % spread) as i64 - (spread / 2) as i64) as i32)
                .collect();
            let mask: Vec<bool> = (0..w * h).map(|_| !rng.next().is_multiple_of(5)).collect();
            for m in [0, 1, 7, 300, 9_999, 32_766, i64::from(G_MAX)] {
                let wide = slope_counts(&u, &mask, (w, h), m, false);
                assert_eq!(
                    slope_counts(&u, &mask, (w, h), m, true),
                    wide,
                    "{w}×{h} m {m}"
                );
                assert!(wide.0 > 0);
            }
        }
        // Neighbours at opposite ends of the range: their difference overflows 32 bits, to
        // a small value if it wrapped.
        let ends = [i32::MIN + 5, 0, i32::MAX - 5, 0];
        let u: Vec<i32> = (0..25).map(|i| ends[(i % 5) % 4]).collect();
        let mask = vec![true; 25];
        let wide = slope_counts(&u, &mask, (5, 5), 100, false);
        assert_eq!(slope_counts(&u, &mask, (5, 5), 100, true), wide);
        assert_eq!(wide, (9, 3));
    }

    /// The count decides as the selected percentile does, at limits on and around it.
    #[test]
    fn slope_percentile_by_count_matches_selection() {
        let mut rng = crate::test_rng::XorShift(0x2545_f491_4f6c_dd1d);
        let mut next = move || rng.next();
        for (w, h, spread) in [
            (30usize, 20usize, 3_000i64),
            (57, 41, 200),
            (3, 3, 50),
            (9, 2, 9),
        ] {
            let u: Vec<i32> = (0..w * h)
                .map(|_| (next() % (2 * spread as u64)) as i32 - spread as i32)
                .collect();
            let mask: Vec<bool> = (0..w * h).map(|_| next() % 4 != 0).collect();
            let p = slope_p98(&u, &mask, w, h);
            for limit in [
                -1.0,
                0.0,
                0.5,
                p as f32 - 1.0,
                p as f32 - 0.5,
                p as f32,
                p as f32 + 0.25,
                p as f32 + 1.0,
                f32::NAN,
            ] {
                assert_eq!(
                    slope_p98_exceeds(&u, &mask, w, h, limit),
                    p as f32 > limit,
                    "{w}x{h} p98 {p} limit {limit}"
                );
            }
        }
    }

    /// A press (a wide cone, 600 µm deep) and a spot of four pixels reading deeper (700 µm)
    /// far from it: the press is the contact's region, and its centre the contact's.
    #[test]
    fn a_deeper_spot_of_a_few_pixels_does_not_take_the_press_s_place() {
        let w = 60;
        let mut z: Vec<i32> = (0..w * 40)
            .map(|i| {
                let (x, y) = ((i % w) as f32 - 20.0, (i / w) as f32 - 20.0);
                (600.0 - 60.0 * x.hypot(y)).max(0.0) as i32
            })
            .collect();
        for i in [55 + 35 * w, 56 + 35 * w, 55 + 36 * w, 56 + 36 * w] {
            z[i] = 700;
        }
        let region = dominant_component(&z, w, 20);
        assert!(
            region.iter().all(|&i| (i % w) < 40),
            "the spot is no part of the region"
        );
        let at = 20 + 20 * w;
        assert!(region.contains(&at));
        let contact = peak_component(&z, w, at, 20);
        assert!(
            contact.iter().all(|&i| (i % w) < 40),
            "the spot is no part of it"
        );
        let f = summarize(&z, &contact, w, (0, 0), 1, 0.1, (z[at], 20));
        let (cx, cy) = f.centroid_px.unwrap();
        assert!(
            (cx - 20.5).abs() < 0.1 && (cy - 20.5).abs() < 0.1,
            "{cx}, {cy}"
        );
        // Without the press, the spot is the contact.
        let spot: Vec<i32> = z.iter().map(|&d| if d == 700 { d } else { 0 }).collect();
        assert_eq!(dominant_component(&spot, w, 20).len(), 4);
        assert!(dominant_component(&vec![0; w * 40], w, 20).is_empty());
    }

    /// Two arms that meet only further down, and a pixel touching by a corner, are one
    /// region; a pixel two columns away is not.
    #[test]
    fn regions_joined_below_or_by_a_corner_are_one() {
        #[rustfmt::skip]
        let z = [
            9, 0, 0, 9, 0, 0, 0,
            9, 0, 0, 9, 0, 0, 0,
            9, 9, 9, 9, 0, 0, 0,
            0, 0, 0, 0, 5, 0, 9,
        ];
        let mut region = dominant_component(&z, 7, 0);
        region.sort_unstable();
        assert_eq!(region, [0, 3, 7, 10, 14, 15, 16, 17, 25]);
    }
}
