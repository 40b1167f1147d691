//! What a built skin shows beyond the ideal model: oblique light, glare, white balance,
//! pigment mottle, a wobbling and distorted grating, a differently shaped phase response, a
//! lens's lateral chromatic aberration and a compressing camera.
//!
//! Each effect has a strength per unit; [`Imperfections::none`] switches all of them off (the
//! reference build and the units of [`crate::SensorUnit::from_seed`], whose fixtures are
//! committed), and [`Imperfections::draw`] draws every strength over a range wider than we
//! expect a real skin to show, for [`crate::SensorUnit::wide`]. The equations, with `p` a
//! pixel, `s` the matching point of the skin in mm, `w` the indentation depth (mm, into the
//! skin) and `I` linear radiance:
//!
//! * **Oblique LED-ring light**, first order in the surface slope:
//!   `I ← I·(1 + g₁·(l̂ · ∇w))`: the surface height is `−w`, so its normal leans along `∇w`,
//!   and `l̂` is the unit vector towards the brighter part of the ring. The wall facing the
//!   light brightens, the other darkens, both stripe populations alike.
//! * **Glare**: specular reflections of single LEDs near the border, added after the
//!   pigments' absorption: `I_c += e·Σ_k a_k·tint_k,c·exp(−|p − p_k|²/2σ_k²)`, `e` the exposure.
//! * **Off-centre vignetting**: the falloff's centre moves by `(o_x, o_y)` of the image size.
//! * **White balance**: `I_c ← wb_c·I_c` per unit (and per frame, [`crate::SkinState`]).
//! * **Pigment mottle**: the coloured stripes' reflectance times
//!   `1 + m·Σ_j cos(k_j·s + φ_j)/√J`, attached to the skin.
//! * **Grating wobble**: the grating phase plus `a·sin(k_w·s + φ_w)`, attached to the skin.
//! * **Grating distortion**: the grating is drawn at `c + (p − c)(1 + κ·|p − c|²/R²)`
//!   (a lens's barrel or pincushion bending the stripes; `R` the half diagonal).
//! * **Phase response shape**: `φ(w) = −g·S·[(1−β)(1 − e^(−w/S)) + β·tanh(w/S)]`, equal slope
//!   at rest, saturating sooner as β grows.
//! * **JPEG**: the frame goes through a JPEG encoder at quality `q` and back, as a UVC camera
//!   sends it above its raw sizes.
//! * **Lateral chromatic aberration**: the lens images red and blue at another scale than
//!   green, so the red plane is the scene's at `c + (p − c)/(1 + χ_R)` and the blue at
//!   `c + (p − c)/(1 + χ_B)`: each colour's stripes lie `χ·|p − c|` pixels out (or in) from
//!   green's, most at the corners (`c` the image centre).

use crate::rng::Rng;

/// One glare spot, in pixels of the image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Glare {
    /// Centre, pixels.
    pub center_px: (f32, f32),
    /// Gaussian radius, pixels.
    pub sigma_px: f32,
    /// Peak added linear radiance per channel (includes the LED's tint).
    pub peak: [f32; 3],
}

/// The strengths of every imperfection of one unit.
#[derive(Debug, Clone, PartialEq)]
pub struct Imperfections {
    /// First-order oblique shading gain g₁ (per unit of slope).
    pub oblique_gain: f32,
    /// Direction towards the brighter part of the ring, rad from +x.
    pub oblique_dir_rad: f32,
    /// Glare spots.
    pub glare: Vec<Glare>,
    /// Vignetting centre offset, fractions of width and height.
    pub vignetting_offset: (f32, f32),
    /// White balance gains, linear R, G, B.
    pub white_balance: [f32; 3],
    /// Pigment mottle amplitude m (relative).
    pub mottle: f32,
    /// Mottle waves: wave vector (rad/mm) and phase (rad).
    pub mottle_waves: Vec<((f32, f32), f32)>,
    /// Grating wobble amplitude, rad.
    pub wobble_rad: f32,
    /// Grating wobble wave vector (rad/mm) and phase (rad).
    pub wobble_wave: ((f32, f32), f32),
    /// Grating distortion κ (negative: barrel).
    pub distortion: f32,
    /// Phase response shape β (0: exponential saturation, 1: tanh).
    pub phase_shape: f32,
    /// JPEG quality, or `None` for a raw camera.
    pub jpeg_quality: Option<u8>,
    /// Lateral chromatic aberration: the red and the blue image's scale against the green's,
    /// minus one (χ_R, χ_B).
    pub chromatic: [f32; 2],
}

/// Largest lateral chromatic aberration drawn, |χ|: three quarters of a pixel at the corner
/// of an 800 × 600 image. A camera module's lens shows a pixel or two at the sensor's full
/// resolution, and the camera's scaling down to these sizes shrinks it by as much.
pub const CHROMATIC_MAX: f64 = 0.0015;

impl Imperfections {
    /// An ideal build: none of the above.
    pub fn none() -> Imperfections {
        Imperfections {
            oblique_gain: 0.0,
            oblique_dir_rad: 0.0,
            glare: Vec::new(),
            vignetting_offset: (0.0, 0.0),
            white_balance: [1.0; 3],
            mottle: 0.0,
            mottle_waves: Vec::new(),
            wobble_rad: 0.0,
            wobble_wave: ((0.0, 0.0), 0.0),
            distortion: 0.0,
            phase_shape: 0.0,
            jpeg_quality: None,
            chromatic: [0.0; 2],
        }
    }

    /// Every strength drawn for an image of `width_px` × `height_px`.
    pub fn draw(r: &mut Rng, width_px: u32, height_px: u32) -> Imperfections {
        let (w, h) = (width_px as f32, height_px as f32);
        let tau = std::f64::consts::TAU;
        let glare = (0..r.next_u64() % 5).map(|_| draw_glare(r, w, h)).collect();
        let wave = |r: &mut Rng, lo_mm: f64, hi_mm: f64| {
            let k = tau / r.range(lo_mm, hi_mm);
            let a = r.range(0.0, tau);
            (
                ((k * a.cos()) as f32, (k * a.sin()) as f32),
                r.range(0.0, tau) as f32,
            )
        };
        Imperfections {
            oblique_gain: r.range(0.2, 1.2) as f32,
            oblique_dir_rad: r.range(0.0, tau) as f32,
            glare,
            vignetting_offset: (r.range(-0.15, 0.15) as f32, r.range(-0.15, 0.15) as f32),
            white_balance: [r.range(0.8, 1.2) as f32, 1.0, r.range(0.8, 1.2) as f32],
            mottle: r.range(0.0, 0.08) as f32,
            mottle_waves: (0..6).map(|_| wave(r, 2.0, 10.0)).collect(),
            wobble_rad: r.range(0.0, 0.2) as f32,
            wobble_wave: wave(r, 8.0, 30.0),
            distortion: r.range(-0.03, 0.03) as f32,
            phase_shape: r.range(0.0, 1.0) as f32,
            jpeg_quality: (r.unit() < 0.5).then(|| r.range(75.0, 95.0) as u8),
            chromatic: [
                r.range(-CHROMATIC_MAX, CHROMATIC_MAX) as f32,
                r.range(-CHROMATIC_MAX, CHROMATIC_MAX) as f32,
            ],
        }
    }

    /// Mottle factor of the coloured stripes at skin point `s_mm`.
    pub fn mottle_at(&self, s_mm: (f32, f32)) -> f32 {
        if self.mottle == 0.0 {
            return 1.0;
        }
        let n = self.mottle_waves.len().max(1) as f32;
        let sum: f32 = self
            .mottle_waves
            .iter()
            .map(|&((kx, ky), ph)| (kx * s_mm.0 + ky * s_mm.1 + ph).cos())
            .sum();
        1.0 + self.mottle * sum / n.sqrt()
    }

    /// Grating phase wobble at skin point `s_mm`, rad.
    pub fn wobble_at(&self, s_mm: (f32, f32)) -> f32 {
        let ((kx, ky), ph) = self.wobble_wave;
        self.wobble_rad * (kx * s_mm.0 + ky * s_mm.1 + ph).sin()
    }

    /// Where the grating is drawn for pixel `p` of an image centred on `c` with half
    /// diagonal `r_px`.
    pub fn distort(&self, p: (f32, f32), c: (f32, f32), r_px: f32) -> (f32, f32) {
        if self.distortion == 0.0 {
            return p;
        }
        let (dx, dy) = (p.0 - c.0, p.1 - c.1);
        let f = 1.0 + self.distortion * (dx * dx + dy * dy) / (r_px * r_px);
        (c.0 + dx * f, c.1 + dy * f)
    }

    /// Added glare radiance at pixel `p` per channel (before exposure).
    pub fn glare_at(&self, p: (f32, f32)) -> [f32; 3] {
        let mut g = [0.0f32; 3];
        for s in &self.glare {
            let r2 = (p.0 - s.center_px.0).powi(2) + (p.1 - s.center_px.1).powi(2);
            let e = (-r2 / (2.0 * s.sigma_px * s.sigma_px)).exp();
            for (gc, pc) in g.iter_mut().zip(s.peak) {
                *gc += pc * e;
            }
        }
        g
    }
}

/// A glare spot within the outer eighth of the image, of size 1–5 % of its height, its
/// peak 0.05–0.6 of white, tinted.
fn draw_glare(r: &mut Rng, w: f32, h: f32) -> Glare {
    let band = 0.12;
    let along = r.unit() as f32;
    let inset = (r.unit() as f32) * band;
    let (x, y) = match r.next_u64() % 4 {
        0 => (along * w, inset * h),
        1 => (along * w, (1.0 - inset) * h),
        2 => (inset * w, along * h),
        _ => ((1.0 - inset) * w, along * h),
    };
    let a = r.range(0.05, 0.6) as f32;
    let tint = [
        r.range(0.85, 1.0) as f32,
        r.range(0.85, 1.0) as f32,
        r.range(0.85, 1.0) as f32,
    ];
    Glare {
        center_px: (x, y),
        sigma_px: r.range(0.01, 0.05) as f32 * h,
        peak: [a * tint[0], a * tint[1], a * tint[2]],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn none_changes_nothing() {
        let n = Imperfections::none();
        assert_eq!(n.mottle_at((3.0, 4.0)), 1.0);
        assert_eq!(n.wobble_at((3.0, 4.0)), 0.0);
        assert_eq!(n.distort((10.0, 20.0), (50.0, 50.0), 70.0), (10.0, 20.0));
        assert_eq!(n.glare_at((0.0, 0.0)), [0.0; 3]);
    }

    #[test]
    fn drawn_strengths_stay_in_their_ranges() {
        for seed in 0..200 {
            let mut r = Rng::derive(seed, "imperfections");
            let i = Imperfections::draw(&mut r, 640, 480);
            assert!(i.glare.len() <= 4);
            for g in &i.glare {
                let (x, y) = g.center_px;
                let near_border = !(0.13 * 640.0..=0.87 * 640.0).contains(&x)
                    || !(0.13 * 480.0..=0.87 * 480.0).contains(&y);
                assert!(near_border, "{x} {y}");
            }
            assert!((0.0..=0.2).contains(&i.wobble_rad));
            assert!(i.distortion.abs() <= 0.03);
            let m = i.mottle_at((1.0, 2.0));
            assert!((1.0 - 0.2..=1.2).contains(&m));
            if let Some(q) = i.jpeg_quality {
                assert!((75..=95).contains(&q));
            }
            assert!(i
                .chromatic
                .iter()
                .all(|c| f64::from(c.abs()) <= CHROMATIC_MAX));
        }
    }

    /// The oblique light brightens the dimple's wall that faces the light and darkens the
    /// other, alike: first order in the slope, unlike the symmetric darkening.
    #[test]
    fn oblique_light_brightens_the_wall_facing_it_and_darkens_the_other() {
        use crate::contact::{Contact, Indenter};
        use crate::{Renderer, SensorUnit, SkinState};
        let mut unit = SensorUnit::reference();
        unit.noise_dn = 0.0;
        let mut lit = unit.clone();
        lit.imperfections.oblique_gain = 1.0; // light towards +x
        let mut s = SkinState::idle(25.0);
        let c = (40.0, 30.0);
        s.contacts.push(Contact {
            indenter: Indenter::Sphere { r_mm: 10.0 },
            center_mm: c,
            depth_mm: 1.5,
        });
        let (plain, _) = Renderer::new(unit.clone()).render(&s, 1);
        let (oblique, _) = Renderer::new(lit).render(&s, 1);
        let px = |mm: f32| (mm / unit.mm_per_px()) as u32;
        let wall = |img: &image::RgbImage, dx_mm: f32| -> f32 {
            let (x0, y0) = (px(c.0 + dx_mm), px(c.1));
            (0..16)
                .flat_map(|dx| (0..8).map(move |dy| (x0 + dx, y0 + dy)))
                .map(|(x, y)| f32::from(img.get_pixel(x, y).0[1]))
                .sum()
        };
        // The wall at −x rises towards +x: it faces the light.
        assert!(wall(&oblique, -3.0) > 1.05 * wall(&plain, -3.0));
        assert!(wall(&oblique, 3.0) < 0.95 * wall(&plain, 3.0));
    }

    /// Lateral chromatic aberration moves the red stripes outward from the centre by χ of
    /// their distance, and leaves green where it was.
    #[test]
    fn chromatic_aberration_moves_red_stripes_out_in_proportion_to_the_distance() {
        use crate::{Renderer, SensorUnit, SkinState};
        let mut unit = SensorUnit::reference();
        unit.noise_dn = 0.0;
        let mut lens = unit.clone();
        let chi = 0.004;
        lens.imperfections.chromatic = [chi, 0.0];
        let s = SkinState::idle(25.0);
        let (plain, _) = Renderer::new(unit.clone()).render(&s, 1);
        let (aberrated, _) = Renderer::new(lens).render(&s, 1);
        let (w, h) = (unit.width_px, unit.height_px);
        let y = h / 2;
        // The shift (pixels, to a twentieth) that best lays channel `k` of `plain` onto
        // `aberrated` along row `y`, columns `x0..x0 + 60`.
        let shift = |k: usize, x0: u32| -> f32 {
            let at = |img: &image::RgbImage, x: f32| {
                let (i, f) = (x.floor() as u32, x - x.floor());
                let v = |i: u32| f32::from(img.get_pixel(i.min(w - 1), y).0[k]);
                v(i) * (1.0 - f) + v(i + 1) * f
            };
            let misfit = |s: f32| -> f32 {
                (x0..x0 + 60)
                    .map(|x| (at(&plain, x as f32 - s) - at(&aberrated, x as f32)).powi(2))
                    .sum()
            };
            (-40..=40)
                .map(|step| step as f32 / 20.0)
                .min_by(|a, b| misfit(*a).total_cmp(&misfit(*b)))
                .unwrap_or(f32::NAN)
        };
        let x0 = w - 80;
        let expected = chi * ((x0 + 30) as f32 + 0.5 - w as f32 / 2.0);
        assert!(
            (shift(0, x0) - expected).abs() < 0.1,
            "{} px, {expected} expected",
            shift(0, x0)
        );
        assert_eq!(shift(1, x0), 0.0);
        assert!(shift(0, w / 2 - 30).abs() < 0.1);
    }
}
