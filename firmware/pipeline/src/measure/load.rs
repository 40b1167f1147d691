//! The reciprocal load: a contact's force up to the skin's modulus, from its depth map alone,
//! for any indenter.
//!
//! Betti's reciprocal theorem on an elastic half-space, between the unknown contact (pressure
//! `p`, surface displacement `u`) and a rigid flat punch of radius `b` pressed a unit depth
//! (pressure `q(r) = E*/(π·√(b² − r²))`, displacement 1 everywhere under it): when `p`
//! vanishes outside the disc `r < b`, `∫ p·1 dA = ∫ q·u dA`, so
//!
//! `F = (E*/π)·∫_{r<b} u(r)/√(b² − r²) dA`
//!
//! whatever the indenter's shape: sphere, flat punch, letter. The integral is taken over
//! rings of one pixel around the contact's centre: with `ū_k` the mean depth of ring `k`
//! (radii `r_k` to `r_{k+1}`), `∫ ring u/√(b² − r²) dA = 2π·ū_k·(√(b² − r_k²) − √(b² − r_{k+1}²))`,
//! which is exact for the weight's integrable singularity at the rim. The feature is
//! `L = 2·Σ_k ū_k·(√(b² − r_k²) − √(b² − r_{k+1}²))`, mm², and `F = E*·L`: the calibration on
//! the sphere only has to find `E*`. (For a flat punch of radius `a = b` it is `2·a·d`,
//! Boussinesq's `F = 2·E*·a·d`.)
//!
//! `b` must enclose the pressure: the radius of the farthest pixel of the peak's component
//! deeper than half the peak, which is the contact radius for a sphere (Hertz's depth is
//! half its peak there), `√2` times it for a flat punch, and beyond any part of a letter;
//! the demodulator's blur only widens it. Larger discs would do in a half-space, but a real
//! skin is a finite layer whose surface returns to rest faster than a half-space's: the
//! smallest disc relies least on the far field.

/// The reciprocal load, mm², of a map summed over rings about the contact's centre
/// (`rings`, µm, [`rings`] out to at least `b_px`), over the disc of radius `b_px` that
/// encloses the contact ([`enclosing_radius_px`]), with working pixels `px_mm` wide. 0
/// without a contact.
pub fn reciprocal_load_mm2(rings: &Rings, b_px: f32, px_mm: f32) -> f32 {
    if b_px <= 0.0 {
        return 0.0;
    }
    let (sum_um, count) = (&rings.sum, &rings.count);
    let b = f64::from(b_px);
    let rim = |r: f64| (b * b - r * r).max(0.0).sqrt();
    let load_um_px: f64 = (0..count.len().min(b_px.ceil() as usize))
        .filter(|&k| count[k] > 0)
        .map(|k| {
            let mean = sum_um[k] as f64 / f64::from(count[k]);
            let (r_in, r_out) = (k as f64, ((k + 1) as f64).min(b));
            mean * (rim(r_in) - rim(r_out))
        })
        .sum();
    (2.0 * load_um_px / 1000.0) as f32 * px_mm
}

/// A map's values summed over rings one pixel wide about a centre: ring `k` holds the
/// pixels whose centres lie `k` to `k + 1` pixels from it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Rings {
    /// Σ value per ring.
    pub sum: Vec<i64>,
    /// Σ value² per ring.
    pub sum_sq: Vec<i64>,
    /// Pixels per ring.
    pub count: Vec<u32>,
}

/// The rings of `depth_um` (a map `w` pixels wide) about `centre` (pixels), over the pixels
/// within `reach_px` of it along each axis (rings up to `⌈reach_px⌉`).
pub fn rings(depth_um: &[i32], w: usize, centre: (f32, f32), reach_px: f32) -> Rings {
    let n = reach_px.max(0.0).ceil() as usize;
    let mut r = Rings {
        sum: vec![0; n],
        sum_sq: vec![0; n],
        count: vec![0; n],
    };
    let h = depth_um.len() / w.max(1);
    let (x0, x1) = span(centre.0, reach_px, w);
    let (y0, y1) = span(centre.1, reach_px, h);
    for y in y0..y1 {
        let dy = y as f32 + 0.5 - centre.1;
        for x in x0..x1 {
            let dx = x as f32 + 0.5 - centre.0;
            let k = dx.hypot(dy) as usize;
            if k < n {
                let v = i64::from(depth_um[y * w + x]);
                r.sum[k] += v;
                r.sum_sq[k] += v * v;
                r.count[k] += 1;
            }
        }
    }
    r
}

/// The distance from `centre` to the farthest of the `contact` pixels, plus half a pixel, px
/// (0 without any).
pub fn enclosing_radius_px(contact: &[usize], w: usize, centre: (f32, f32)) -> f32 {
    if contact.is_empty() || w == 0 {
        return 0.0;
    }
    let far2 = contact
        .iter()
        .map(|&i| {
            let dx = (i % w) as f32 + 0.5 - centre.0;
            let dy = (i / w) as f32 + 0.5 - centre.1;
            dx * dx + dy * dy
        })
        .fold(0.0f32, f32::max);
    far2.sqrt() + 0.5
}

/// The pixels within `r` of `c` along an axis of `n` pixels.
fn span(c: f32, r: f32, n: usize) -> (usize, usize) {
    let lo = (c - r).floor().max(0.0) as usize;
    let hi = ((c + r).ceil().max(0.0) as usize).min(n);
    (lo.min(hi), hi)
}

#[cfg(test)]
mod tests {
    use super::super::features::peak_component;
    use super::*;

    /// The reciprocal load of map `z` (`w` wide) about `c`, enclosing `contact`.
    fn load_of(z: &[i32], w: usize, contact: &[usize], c: (f32, f32), px_mm: f32) -> f32 {
        let b = enclosing_radius_px(contact, w, c);
        reciprocal_load_mm2(&rings(z, w, c, b), b, px_mm)
    }

    /// The deepest pixel's half-depth component of `z` (`w` wide).
    fn component(z: &[i32], w: usize) -> Vec<usize> {
        let at = (0..z.len()).max_by_key(|&i| z[i]).unwrap_or(0);
        peak_component(z, w, at, 0)
    }

    /// A map of `f(r)` (µm, r in px from the window's centre) on a `w × w` window.
    fn radial(w: usize, f: impl Fn(f32) -> f32) -> (Vec<i32>, (f32, f32)) {
        let c = w as f32 / 2.0;
        let z = (0..w * w)
            .map(|i| {
                let (x, y) = ((i % w) as f32 + 0.5 - c, (i / w) as f32 + 0.5 - c);
                f(x.hypot(y)).round() as i32
            })
            .collect();
        (z, (c, c))
    }

    /// A flat punch of radius `a` pressed `d` deep: Boussinesq's displacement, `d` inside
    /// and `(2d/π)·asin(a/r)` outside; its reciprocal load is `2·a·d` (`F = 2·E*·a·d`).
    #[test]
    fn a_flat_punch_reads_boussinesq() {
        let (a, d) = (20.0f32, 500.0f32);
        let (z, c) = radial(161, |r| {
            if r <= a {
                d
            } else {
                2.0 * d / std::f32::consts::PI * (a / r).asin()
            }
        });
        let got = load_of(&z, 161, &component(&z, 161), c, 0.1);
        let want = 2.0 * (a * 0.1) * (d / 1000.0);
        assert!((got - want).abs() < 0.03 * want, "{got} vs {want}");
    }

    /// A sphere of radius `R` pressed `d` deep: Hertz's displacement (`a² = R·d`); its
    /// reciprocal load is `(4/3)·a·d` (`F = (4/3)·E*·a·d`).
    #[test]
    fn a_sphere_reads_hertz() {
        let (r_px, d_px) = (400.0f32, 4.0f32);
        let a = (r_px * d_px).sqrt();
        let um_per_px = 100.0;
        let (z, c) = radial(201, |r| {
            let w = if r <= a {
                d_px - r * r / (2.0 * r_px)
            } else {
                let s = a / r;
                d_px / std::f32::consts::PI
                    * ((2.0 - r * r / (a * a)) * s.asin() + (r * r / (a * a) - 1.0).sqrt())
            };
            w * um_per_px
        });
        let got = load_of(&z, 201, &component(&z, 201), c, 0.1);
        let want = 4.0 / 3.0 * (a * 0.1) * (d_px * 0.1);
        assert!((got - want).abs() < 0.03 * want, "{got} vs {want}");
    }

    /// A second blob as deep as the press, away from it, is not the press's: the disc
    /// stays the press's own.
    #[test]
    fn another_blob_does_not_widen_the_disc() {
        let (a, d) = (10.0f32, 400.0f32);
        let (mut z, c) = radial(121, |r| if r <= a { d } else { 0.0 });
        let alone = load_of(&z, 121, &component(&z, 121), c, 0.1);
        for y in 2..6 {
            for x in 2..6 {
                z[y * 121 + x] = 390;
            }
        }
        let with = load_of(&z, 121, &component(&z, 121), c, 0.1);
        assert_eq!(alone, with);
    }

    #[test]
    fn no_depth_is_no_load() {
        assert_eq!(load_of(&[0; 100], 10, &[], (5.0, 5.0), 0.1), 0.0);
        assert_eq!(load_of(&[], 10, &[], (5.0, 5.0), 0.1), 0.0);
    }
}
