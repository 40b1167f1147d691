//! The contact's peak depth, corrected for the demodulator's blur.
//!
//! The phase map is the true phase convolved with the demodulator's low-pass `K` (a
//! triangle a grating period each way, [`crate::ftp::band::box_lengths`]). At a smooth apex
//! that convolution lowers the peak by half the kernel's variance times the surface's
//! curvature: a paraboloid `d − r²/2R` blurred by a kernel of variances `(σx², σy²)` has its
//! apex at `d − (σx² + σy²)/2R`, with the same curvature. A flat punch's plateau loses
//! nothing. A calibration on a sphere that read the blurred apex would learn a gain that
//! makes every flatter indenter read too deep and every sharper one too shallow; so both
//! calibration and use read the apex with the blur taken back out.
//!
//! Each further blur by `K` lowers a paraboloid by the same amount again, so from the map
//! `b` blurred once more (`s₁ = K∗b`) and twice (`s₂ = K∗K∗b`) at the deepest point of
//! `s₁` the loss per blur is `s₁ − s₂` and the apex is `s₁ + 2·(s₁ − s₂)`. Both readings
//! are averages over a kernel footprint, so neither the noise that made the deepest pixel
//! the deepest (the raw maximum of a noisy plateau sits a few σ above it) nor a narrow
//! bump where the phase turns sharply at a punch's rim sets the peak; `K` is the
//! demodulator's own kernel, so no scale is chosen. The step is first order: exact for a
//! paraboloid, a partial restoration where the kernels reach a punch's rim. The loss is
//! bounded to `[0, s₁]`: at a maximum a blur cannot raise the peak.
//!
//! **Where it stops.** A sphere is a paraboloid only inside its contact radius `a`; with
//! `a` under about three of the kernel's σ (σ is about 0.4 of a grating period, whatever
//! the camera) the kernels reach Hertz's flatter surround and the step restores only part
//! of the loss, and a flat punch of such a size, which lost little, is raised. Neither can
//! be told from the map: a sphere's and a punch's blurred profiles, surrounds included,
//! match to under a percent at depths a tenth apart. The calibration's depth model, fitted
//! on a sphere, takes up the sphere's remainder; contacts much blunter or sharper than the
//! calibrated indenter are flagged ([`super::BLUNTNESS_RATIO`], [`super::SHARPNESS_RATIO`]).

/// A contact's apex: its blur-corrected depth and where it is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Apex {
    /// The peak depth with the blur taken out, µm.
    pub peak_um: i32,
    /// The deepest point of the once-blurred map, an index into the depth map.
    pub at: usize,
}

/// The apex of the contact whose region is `region` (indices into `depth_um`, `w` pixels
/// wide; `super::features::dominant_component`): at the deepest point of `s₁ = K∗b`,
/// `s₁ + 2·(s₁ − K∗s₁)`, `K` the separable triangle of two boxes of lengths `(lx, ly)`, its
/// weights renormalised where the window crops it. `None` without depth.
///
/// `s₁` is sought over the bounding box of the region's pixels at least half as deep as its
/// deepest (no shallower point can hold its maximum; another blob of the window is no part
/// of this contact), and only that box grown by two kernel reaches is blurred: `K∗s₁` reads
/// one reach around it, so every value used sees the map as the whole window would. The
/// blurred maximum, not the raw one, places the apex: a few pixels that read deeper than
/// the contact around them cannot.
pub fn apex(
    depth_um: &[i32],
    w: usize,
    region: &[usize],
    (lx, ly): (usize, usize),
) -> Option<Apex> {
    let deepest = region.iter().map(|&i| depth_um[i]).max()?;
    let bbox = deep_box(depth_um, w, region, deepest)?;
    let h = depth_um.len() / w;
    let (rx, ry) = (lx.max(1) - 1, ly.max(1) - 1);
    let grow = |(a, b): (usize, usize), r: usize, n: usize| (a.saturating_sub(r), (b + r).min(n));
    let (xs, ys) = (grow(bbox.0, 2 * rx, w), grow(bbox.1, 2 * ry, h));
    let sw = xs.1 - xs.0;
    let sub: Vec<i32> = (ys.0..ys.1)
        .flat_map(|y| depth_um[y * w + xs.0..y * w + xs.1].iter().copied())
        .collect();
    let once = blur(&sub, sw, (lx, ly));
    let ((ax, ay), s1) = (bbox.1 .0..bbox.1 .1)
        .flat_map(|y| (bbox.0 .0..bbox.0 .1).map(move |x| (x, y)))
        .map(|(x, y)| ((x, y), once[(y - ys.0) * sw + x - xs.0]))
        .max_by_key(|&((x, y), d)| (d, std::cmp::Reverse((y, x))))?;
    if s1 <= 0 {
        return None;
    }
    let (tx, ty) = (triangle(lx), triangle(ly));
    let s2 = weighted_mean(&once, sw, (ax - xs.0, ay - ys.0), &tx, &ty);
    let loss = (f64::from(s1) - s2).clamp(0.0, f64::from(s1));
    Some(Apex {
        peak_um: (f64::from(s1) + 2.0 * loss).round() as i32,
        at: ay * w + ax,
    })
}

/// The half-open column and row spans of the pixels of `region` at least half as deep as
/// `deepest` (`None` without any, or a map `w` = 0 wide).
fn deep_box(
    depth_um: &[i32],
    w: usize,
    region: &[usize],
    deepest: i32,
) -> Option<((usize, usize), (usize, usize))> {
    if w == 0 || deepest <= 0 {
        return None;
    }
    let (mut xs, mut ys) = ((usize::MAX, 0), (usize::MAX, 0));
    for &i in region.iter().filter(|&&i| 2 * depth_um[i] >= deepest) {
        let (x, y) = (i % w, i / w);
        xs = (xs.0.min(x), xs.1.max(x + 1));
        ys = (ys.0.min(y), ys.1.max(y + 1));
    }
    Some((xs, ys))
}

/// `z` (`w` wide) blurred by the separable triangle of box lengths `(lx, ly)`, weights
/// renormalised over the part of the kernel inside the window.
fn blur(z: &[i32], w: usize, (lx, ly): (usize, usize)) -> Vec<i32> {
    let h = z.len() / w;
    let mut scratch = Scratch::default();
    let mut rows = vec![0i64; w * h];
    for y in 0..h {
        let row = z[y * w..(y + 1) * w].iter().map(|&v| i64::from(v));
        scratch.triangle(row, lx, &mut rows[y * w..(y + 1) * w], 1);
    }
    let mut cols = vec![0i64; w * h];
    for x in 0..w {
        let col = (0..h).map(|y| rows[y * w + x]);
        scratch.triangle(col, ly, &mut cols[x..], w);
    }
    cols.into_iter().map(|v| v as i32).collect()
}

/// Prefix sums for [`Scratch::triangle`], kept from line to line.
#[derive(Default)]
struct Scratch {
    /// `Σ_{j<i} v_j` and `Σ_{j<i} j·v_j`.
    p0: Vec<i64>,
    p1: Vec<i64>,
}

impl Scratch {
    /// The line `v` filtered by the triangle `l − |d|` (`|d| < l`), renormalised where the
    /// line ends, written to every `stride`-th element of `out`. O(1) per sample whatever
    /// `l`: the triangle's two ramps are sums of `v` and of `i·v` over a span.
    fn triangle(&mut self, v: impl Iterator<Item = i64>, l: usize, out: &mut [i64], stride: usize) {
        let (p0, p1) = (&mut self.p0, &mut self.p1);
        p0.clear();
        p1.clear();
        let (mut s0, mut s1) = (0i64, 0i64);
        p0.push(0);
        p1.push(0);
        for (i, x) in v.enumerate() {
            s0 += x;
            s1 += i as i64 * x;
            p0.push(s0);
            p1.push(s1);
        }
        let n = p0.len() - 1;
        let l = l.max(1) as i64;
        for c in 0..n {
            let (lo, hi) = (c.saturating_sub(l as usize - 1), (c + l as usize).min(n));
            let ci = c as i64;
            // Left ramp i ∈ [lo, c]: weight (l − c) + i; right ramp i ∈ (c, hi): (l + c) − i.
            let left = (l - ci) * (p0[c + 1] - p0[lo]) + (p1[c + 1] - p1[lo]);
            let right = (l + ci) * (p0[hi] - p0[c + 1]) - (p1[hi] - p1[c + 1]);
            let (n_l, n_r) = ((c + 1 - lo) as i64, (hi - c - 1) as i64);
            let w_l = (l - ci) * n_l + (lo as i64 + ci) * n_l / 2;
            let w_r = (l + ci) * n_r - (ci + hi as i64) * n_r / 2;
            out[c * stride] = (left + right) / (w_l + w_r).max(1);
        }
    }
}

/// The triangle of two boxes of length `l`: weights `l − |d|` for `|d| < l`.
fn triangle(l: usize) -> Vec<i64> {
    let l = l.max(1) as i64;
    (1 - l..l).map(|d| l - d.abs()).collect()
}

/// The mean of `z` (`w` wide) around `(cx, cy)` under the separable centred kernel
/// `kx ⊗ ky`, over the part of it inside the window.
fn weighted_mean(z: &[i32], w: usize, (cx, cy): (usize, usize), kx: &[i64], ky: &[i64]) -> f64 {
    let h = z.len() / w;
    let (rx, ry) = (kx.len() / 2, ky.len() / 2);
    let xs = cx.saturating_sub(rx)..(cx + rx + 1).min(w);
    let ys = cy.saturating_sub(ry)..(cy + ry + 1).min(h);
    let (mut s, mut ws) = (0i128, 0i128);
    for y in ys {
        let wy = i128::from(ky[y + ry - cy]);
        let row = &z[y * w..(y + 1) * w];
        let sx: i128 = xs
            .clone()
            .map(|x| i128::from(kx[x + rx - cx]) * i128::from(row[x]))
            .sum();
        s += wy * sx;
        ws += wy;
    }
    let wx: i64 = xs.map(|x| kx[x + rx - cx]).sum();
    s as f64 / (ws * i128::from(wx)).max(1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The blur-corrected peak of `z`, its region found as the measurement finds it.
    fn corrected(z: &[i32], w: usize, blur: (usize, usize)) -> i32 {
        let region = super::super::features::dominant_component(z, w, 0);
        apex(z, w, &region, blur).map_or(0, |a| a.peak_um)
    }

    /// A paraboloid of curvature `k` µm/px² and apex depth `d` µm at `(cx, cy)` on a
    /// `w × h` window.
    fn paraboloid(w: usize, h: usize, (cx, cy): (f64, f64), d: f64, k: f64) -> Vec<i32> {
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f64 - cx, (i / w) as f64 - cy);
                (d - 0.5 * k * (x * x + y * y)).round() as i32
            })
            .collect()
    }

    /// A few pixels reading deeper than the press at its rim, in its region: the apex stays
    /// at the press's centre with its depth, not at the spot.
    #[test]
    fn a_deeper_spot_at_the_rim_does_not_place_the_apex() {
        let (w, h) = (81, 81);
        let z0: Vec<i32> = paraboloid(w, h, (40.0, 40.0), 800.0, 4.0)
            .into_iter()
            .map(|v| v.max(0))
            .collect();
        let alone = corrected(&z0, w, (5, 5));
        let mut z = z0.clone();
        for (x, y) in [(55, 40), (56, 40), (55, 41)] {
            z[y * w + x] = 1_200;
        }
        let region = super::super::features::dominant_component(&z, w, 0);
        let a = apex(&z, w, &region, (5, 5)).unwrap();
        assert_eq!((a.at % w, a.at / w), (40, 40));
        assert!(
            (a.peak_um - alone).abs() <= 30,
            "{} against {alone}",
            a.peak_um
        );
    }

    /// Unit-depth elastic surfaces at radius `r` for contact radius `a`: Hertz's sphere
    /// (surround included) and Boussinesq's flat punch.
    fn hertz(r: f64, a: f64) -> f64 {
        if r <= a {
            return 1.0 - r * r / (2.0 * a * a);
        }
        let p = r / a;
        ((2.0 - p * p) * (1.0 / p).asin() + (p * p - 1.0).sqrt()) / std::f64::consts::PI
    }
    fn punch(r: f64, a: f64) -> f64 {
        if r <= a {
            1.0
        } else {
            2.0 / std::f64::consts::PI * (a / r).asin()
        }
    }

    /// `surface` of depth `d` µm about the centre of an `n × n` window, as the
    /// demodulator's triangle of box length `l` blurs it.
    fn blurred(surface: fn(f64, f64) -> f64, a: f64, d: f64, n: usize, l: usize) -> Vec<i32> {
        let c = (n / 2) as f64;
        let z: Vec<i32> = (0..n * n)
            .map(|i| {
                let r = ((i % n) as f64 - c).hypot((i / n) as f64 - c);
                (d * surface(r, a)).round() as i32
            })
            .collect();
        blur(&z, n, (l, l))
    }

    /// Where the step stops (the module's last paragraph): with the contact radius at 2σ a
    /// sphere's reading keeps about a fifth of its loss, and a punch at 3σ is raised above
    /// its plateau.
    #[test]
    fn narrow_spheres_read_shallow_and_punches_deep() {
        let (l, n, d) = (7, 121, 1000.0);
        let sigma = 8.0f64.sqrt();
        let sphere = blurred(hertz, 2.0 * sigma, d, n, l);
        let got = corrected(&sphere, n, (l, l));
        assert!((760..=820).contains(&got), "sphere at 2σ: {got}");
        let flat = blurred(punch, 3.0 * sigma, d, n, l);
        let got = corrected(&flat, n, (l, l));
        assert!((1040..=1110).contains(&got), "punch at 3σ: {got}");
    }

    /// …and the map cannot tell them there: a sphere of contact radius 2σ and a punch of
    /// 1.5σ about an eighth shallower blur to profiles within a percent of each other.
    #[test]
    fn a_narrow_sphere_and_a_shallower_punch_blur_alike() {
        let (l, n) = (7, 121);
        let sigma = 8.0f64.sqrt();
        let sphere = blurred(hertz, 2.0 * sigma, 1000.0, n, l);
        let flat = blurred(punch, 1.5 * sigma, 1000.0, n, l);
        // The centre row out to 5σ, the punch scaled to fit the sphere.
        let row = (n / 2) * n + n / 2;
        let span = (5.0 * sigma) as usize;
        let (s, f): (Vec<f64>, Vec<f64>) = (0..span)
            .map(|x| (f64::from(sphere[row + x]), f64::from(flat[row + x])))
            .unzip();
        let scale = s.iter().zip(&f).map(|(a, b)| a * b).sum::<f64>()
            / f.iter().map(|b| b * b).sum::<f64>();
        let rms = (s
            .iter()
            .zip(&f)
            .map(|(a, b)| (a - scale * b).powi(2))
            .sum::<f64>()
            / span as f64)
            .sqrt();
        assert!(
            rms < 0.01 * s[0],
            "profiles differ by {rms} µm rms of {}",
            s[0]
        );
        assert!(
            (0.84..=0.92).contains(&scale),
            "punch depth {scale} of the sphere's"
        );
    }

    /// Two boxes of length `l` have variance `(l² − 1)/6`: lengths 5 and 7 give 4 and 8 px².
    #[test]
    fn a_paraboloid_gets_back_half_the_variance_times_its_curvature() {
        let (d, k) = (800.0, 10.0);
        let z = paraboloid(31, 31, (15.0, 15.0), d, k);
        let got = corrected(&z, 31, (5, 7));
        let want = d + 0.5 * k * (4.0 + 8.0);
        assert!((f64::from(got) - want).abs() <= 1.0, "{got} vs {want}");
    }

    /// The triangle is symmetric, so a window that cuts it through the apex keeps nearly its
    /// second moment: an apex on the window's edge still gets back its loss to within a
    /// sixth (the centre column weighs a little more in each half-kernel).
    #[test]
    fn an_apex_on_the_window_edge_is_corrected_alike() {
        let (d, k) = (600.0, 8.0);
        let z = paraboloid(20, 31, (0.0, 15.0), d, k);
        let got = corrected(&z, 20, (6, 6));
        let loss = 0.5 * k * 2.0 * 35.0 / 6.0;
        let want = d + loss;
        assert!(
            (f64::from(got) - want).abs() <= loss / 6.0,
            "{got} vs {want}"
        );
    }

    /// Blurring only around the contact sees what the whole window would: a shallower,
    /// smaller blob elsewhere in the window leaves the corrected peak as it was.
    #[test]
    fn a_blob_elsewhere_does_not_move_the_peak() {
        let (w, h) = (120, 41);
        let mut z: Vec<i32> = paraboloid(w, h, (20.0, 20.0), 800.0, 10.0)
            .into_iter()
            .map(|v| v.max(0))
            .collect();
        let alone = corrected(&z, w, (5, 5));
        for y in 15..22 {
            for x in 90..97 {
                z[y * w + x] = 700;
            }
        }
        assert_eq!(corrected(&z, w, (5, 5)), alone);
        assert!(alone > 800, "{alone}");
    }

    /// The prefix-sum triangle equals the direct weighted sum, renormalised at the ends.
    #[test]
    fn the_running_triangle_is_the_direct_one() {
        let v: Vec<i64> = (0..37).map(|i| (i * 7919 % 113) - 40).collect();
        for l in [1, 2, 5, 9, 40] {
            let mut got = vec![0i64; v.len()];
            Scratch::default().triangle(v.iter().copied(), l, &mut got, 1);
            let k = triangle(l);
            let r = k.len() / 2;
            for (c, &g) in got.iter().enumerate() {
                let (mut s, mut ws) = (0i64, 0i64);
                for (i, &x) in v.iter().enumerate() {
                    let d = i as i64 - c as i64;
                    if d.unsigned_abs() as usize <= r {
                        s += k[(d + r as i64) as usize] * x;
                        ws += k[(d + r as i64) as usize];
                    }
                }
                assert_eq!(g, s / ws, "l {l} at {c}");
            }
        }
    }

    #[test]
    fn a_plateau_loses_nothing_and_a_lone_deep_pixel_is_averaged_away() {
        let w = 31;
        assert_eq!(corrected(&vec![500; w * w], w, (7, 7)), 500);
        let mut spike = vec![0; w * w];
        spike[15 * w + 15] = 400;
        // K∗b at the spike is its weight, 7·7 of 49², and the loss at most that again twice.
        let s1 = 400 * 49 / 2401;
        let got = corrected(&spike, w, (7, 7));
        assert!((s1..=3 * s1).contains(&got), "{got}");
        assert_eq!(corrected(&vec![0; w * w], w, (7, 7)), 0);
        assert_eq!(corrected(&[], w, (7, 7)), 0);
    }
}
