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

/// The blur-corrected peak of a window's depth map (`w` pixels wide), µm: at the deepest
/// point of `s₁ = K∗b`, `s₁ + 2·(s₁ − K∗s₁)`, `K` the separable triangle of two boxes of
/// lengths `(lx, ly)`, its weights renormalised where the window crops it.
pub fn corrected_peak_um(depth_um: &[i32], w: usize, (lx, ly): (usize, usize)) -> i32 {
    if w == 0 || depth_um.len() < w {
        return 0;
    }
    let (tx, ty) = (triangle(lx), triangle(ly));
    let once = blur(depth_um, w, &tx, &ty);
    let Some((at, &s1)) = once
        .iter()
        .enumerate()
        .max_by_key(|&(i, &d)| (d, usize::MAX - i))
    else {
        return 0;
    };
    if s1 <= 0 {
        return 0;
    }
    let s2 = weighted_mean(&once, w, (at % w, at / w), &tx, &ty);
    let loss = (f64::from(s1) - s2).clamp(0.0, f64::from(s1));
    (f64::from(s1) + 2.0 * loss).round() as i32
}

/// `z` (`w` wide) blurred by the separable kernel `kx ⊗ ky`, weights renormalised over the
/// part of the kernel inside the window.
fn blur(z: &[i32], w: usize, kx: &[i64], ky: &[i64]) -> Vec<i32> {
    let h = z.len() / w;
    let mut line = Vec::with_capacity(w.max(h));
    let mut rows = vec![0i64; w * h];
    for y in 0..h {
        line.clear();
        line.extend(z[y * w..(y + 1) * w].iter().map(|&v| i64::from(v)));
        along(&line, kx, &mut rows[y * w..(y + 1) * w], 1);
    }
    let mut cols = vec![0i64; w * h];
    for x in 0..w {
        line.clear();
        line.extend((0..h).map(|y| rows[y * w + x]));
        along(&line, ky, &mut cols[x..], w);
    }
    cols.into_iter().map(|v| v as i32).collect()
}

/// `v` filtered by the centred kernel `k`, renormalised where `v` ends, written to every
/// `stride`-th element of `out`.
fn along(v: &[i64], k: &[i64], out: &mut [i64], stride: usize) {
    let (n, r) = (v.len(), k.len() / 2);
    for c in 0..n {
        let (lo, hi) = (c.saturating_sub(r), (c + r + 1).min(n));
        let taps = &k[lo + r - c..hi + r - c];
        let s: i64 = v[lo..hi].iter().zip(taps).map(|(a, b)| a * b).sum();
        let ws: i64 = taps.iter().sum();
        out[c * stride] = s / ws.max(1);
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

    /// Two boxes of length `l` have variance `(l² − 1)/6`: lengths 5 and 7 give 4 and 8 px².
    #[test]
    fn a_paraboloid_gets_back_half_the_variance_times_its_curvature() {
        let (d, k) = (800.0, 10.0);
        let z = paraboloid(31, 31, (15.0, 15.0), d, k);
        let got = corrected_peak_um(&z, 31, (5, 7));
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
        let got = corrected_peak_um(&z, 20, (6, 6));
        let loss = 0.5 * k * 2.0 * 35.0 / 6.0;
        let want = d + loss;
        assert!(
            (f64::from(got) - want).abs() <= loss / 6.0,
            "{got} vs {want}"
        );
    }

    #[test]
    fn a_plateau_loses_nothing_and_a_lone_deep_pixel_is_averaged_away() {
        let w = 31;
        assert_eq!(corrected_peak_um(&vec![500; w * w], w, (7, 7)), 500);
        let mut spike = vec![0; w * w];
        spike[15 * w + 15] = 400;
        // K∗b at the spike is its weight, 7·7 of 49², and the loss at most that again twice.
        let s1 = 400 * 49 / 2401;
        let got = corrected_peak_um(&spike, w, (7, 7));
        assert!((s1..=3 * s1).contains(&got), "{got}");
        assert_eq!(corrected_peak_um(&vec![0; w * w], w, (7, 7)), 0);
        assert_eq!(corrected_peak_um(&[], w, (7, 7)), 0);
    }
}
