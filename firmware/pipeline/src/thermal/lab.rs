//! Colour science of the float reference: sRGB decoding, CIE XYZ and CIELAB (D65), exactly
//! as the standards define them, and the illumination-invariant stripe colour features.
//!
//! **Why invariants.** A block's colour is the pigment's reflectance times the light that
//! reaches it: vignetting, LED-ring reflections, exposure, the camera's white balance and —
//! under an indentation — the darkening of the tilted surface. The light's brightness and
//! the camera's gain per channel are common to a coloured stripe and the black stripe
//! beside it, a millimetre away, so the features are built from the two stripes' ratio per
//! channel, `C_k / K_k`, which neither the light nor the gains change:
//! - the coloured stripes' colour with the black stripes beside them as the white: the
//!   chromaticity of `C_k / K_k` (its CIELAB a*, b* at a fixed lightness);
//! - the black stripes' lightness against the coloured stripes: CIELAB L* of
//!   `Σ_k Y_k · K_k / C_k` (Y_k the luminance weights).
//!
//! The coloured stripes' own chromaticity would follow a drifting white balance (a camera's
//! automatic white balance, or one a few per cent off after the reference) as if the
//! temperature had changed; the ratio leaves that out by construction, whatever the
//! pigments. What it gives up is the dark black stripes' noise in
//! every feature; so the chromaticity takes its white from the black stripes of the block's
//! neighbourhood (the same light and gains a few millimetres away, nine times the samples),
//! and the calibration's variance tables carry what noise is left.

/// sRGB-encoded value (0…1) → linear light (IEC 61966-2-1).
pub fn srgb_to_linear(v: f64) -> f64 {
    if v <= 0.040_45 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// 8-bit sRGB code → linear light, for every code.
pub fn linear_table() -> [f64; 256] {
    std::array::from_fn(|k| srgb_to_linear(k as f64 / 255.0))
}

/// Relative luminance Y of linear sRGB (Rec. 709 primaries, D65).
pub fn luminance(rgb: [f64; 3]) -> f64 {
    0.212_672_9 * rgb[0] + 0.715_152_2 * rgb[1] + 0.072_175 * rgb[2]
}

/// Linear sRGB → CIE XYZ (D65).
pub fn xyz(rgb: [f64; 3]) -> [f64; 3] {
    let [r, g, b] = rgb;
    [
        0.412_456_4 * r + 0.357_576_1 * g + 0.180_437_5 * b,
        luminance(rgb),
        0.019_333_9 * r + 0.119_192 * g + 0.950_304_1 * b,
    ]
}

/// D65 reference white, XYZ.
pub const D65: [f64; 3] = [0.950_47, 1.0, 1.088_83];

fn lab_f(t: f64) -> f64 {
    const D: f64 = 6.0 / 29.0;
    if t > D * D * D {
        t.cbrt()
    } else {
        t / (3.0 * D * D) + 4.0 / 29.0
    }
}

/// CIE XYZ → CIELAB against `white`.
pub fn lab(xyz: [f64; 3], white: [f64; 3]) -> [f64; 3] {
    let f: [f64; 3] = std::array::from_fn(|k| lab_f(xyz[k] / white[k]));
    [
        116.0 * f[1] - 16.0,
        500.0 * (f[0] - f[1]),
        200.0 * (f[1] - f[2]),
    ]
}

/// CIELAB L* of a luminance ratio (Y / Y_white).
pub fn lightness(y_ratio: f64) -> f64 {
    116.0 * lab_f(y_ratio) - 16.0
}

/// Luminance the coloured stripes' chromaticity is evaluated at: mid-grey (L* ≈ 76).
pub const CHROMA_Y: f64 = 0.5;

/// What a block's stripes say about temperature, independent of the light on them and of the
/// camera's gain per channel (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Invariants {
    /// Chromaticity of the coloured stripes over the black, per channel: `ρ_R / Σρ` with
    /// `ρ_k = C_k / K_k`.
    pub r: f64,
    /// See `r`.
    pub g: f64,
    /// The black stripes over the coloured, per channel, weighted as luminance:
    /// `Σ_k Y_k · K_k / C_k`.
    pub q: f64,
}

impl Invariants {
    /// From mean linear colours of the coloured and black stripes of a region, and of the
    /// black stripes the coloured chromaticity is measured against (`white`: the region's
    /// own, or its neighbourhood's, whose mean over more stripes is less noisy); `None` when
    /// a channel of any is black (nothing to measure against).
    pub fn from_linear(coloured: [f64; 3], black: [f64; 3], white: [f64; 3]) -> Option<Invariants> {
        if [coloured, black, white]
            .iter()
            .flatten()
            .any(|v| *v <= 1e-9)
        {
            return None;
        }
        let ratio: [f64; 3] = std::array::from_fn(|k| coloured[k] / white[k]);
        let s: f64 = ratio.iter().sum();
        let q = luminance(std::array::from_fn(|k| black[k] / coloured[k]));
        Some(Invariants {
            r: ratio[0] / s,
            g: ratio[1] / s,
            q,
        })
    }

    /// The coloured stripes' CIELAB a*, b* at luminance [`CHROMA_Y`].
    pub fn chroma_ab(&self) -> [f64; 2] {
        let rgb = [self.r, self.g, 1.0 - self.r - self.g];
        let y = luminance(rgb);
        if y <= 1e-9 {
            return [0.0, 0.0];
        }
        let n = rgb.map(|c| c * CHROMA_Y / y);
        let l = lab(xyz(n), D65);
        [l[1], l[2]]
    }

    /// The black stripes' CIELAB L* with the coloured stripes beside them as the white.
    pub fn black_lightness(&self) -> f64 {
        lightness(self.q.max(0.0))
    }

    /// Features of the coloured stripes' model: a*, b*, and their lightness against the
    /// black stripes beside them (as the black stripes' L*, which is monotone in it).
    pub fn coloured_features(&self) -> Vec<f64> {
        let [a, b] = self.chroma_ab();
        vec![a, b, self.black_lightness()]
    }

    /// Features of the black stripes' model: L* against the coloured white, and the
    /// coloured a*, b* (which tell the two sides of the coloured transition apart, where
    /// the lightness ratio alone takes the same value twice).
    pub fn black_features(&self) -> Vec<f64> {
        let [a, b] = self.chroma_ab();
        vec![self.black_lightness(), a, b]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn white_and_primaries_match_published_lab() {
        let w = lab(xyz([1.0, 1.0, 1.0]), D65);
        assert!((w[0] - 100.0).abs() < 1e-3 && w[1].abs() < 0.01 && w[2].abs() < 0.01);
        // sRGB red: L* 53.24, a* 80.09, b* 67.20.
        let r = lab(xyz([1.0, 0.0, 0.0]), D65);
        assert!((r[0] - 53.24).abs() < 0.02, "{r:?}");
        assert!(
            (r[1] - 80.09).abs() < 0.05 && (r[2] - 67.20).abs() < 0.05,
            "{r:?}"
        );
        // Mid grey code 119: L* ≈ 50.
        let g = srgb_to_linear(119.0 / 255.0);
        assert!((lightness(g) - 50.0).abs() < 0.3);
    }

    #[test]
    fn invariants_ignore_the_light_and_the_white_balance() {
        let c = [0.31, 0.22, 0.12];
        let k = [0.05, 0.048, 0.046];
        let a = Invariants::from_linear(c, k, k).unwrap();
        let gain = [0.6 * 1.04, 0.6, 0.6 * 0.96];
        let k2: [f64; 3] = std::array::from_fn(|j| k[j] * gain[j]);
        let b = Invariants::from_linear(std::array::from_fn(|j| c[j] * gain[j]), k2, k2).unwrap();
        assert!((a.r - b.r).abs() < 1e-12 && (a.g - b.g).abs() < 1e-12);
        assert!((a.q - b.q).abs() < 1e-12);
        // A warmer coloured stripe (more red against the same black) moves r.
        let warm = Invariants::from_linear([0.34, 0.22, 0.12], k, k).unwrap();
        assert!(warm.r > a.r + 0.01);
        assert_eq!(a.black_features().len(), 3);
        assert!(Invariants::from_linear([0.0; 3], k, k).is_none());
        assert!(Invariants::from_linear(c, [0.05, 0.0, 0.046], k).is_none());
        assert!(Invariants::from_linear(c, k, [0.05, 0.0, 0.046]).is_none());
    }
}
