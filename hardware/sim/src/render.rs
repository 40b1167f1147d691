//! Rendering a sensor frame from a unit and a skin state.
//!
//! Per pixel, in linear light: the grating's stripe profile (between sine and square, at
//! the unit's period, tilt and duty, its phase moved by the indentation through the unit's
//! phase response) mixes the coloured and black stripes' reflectances at the local
//! temperature; the surface tilt of the indentation darkens it slightly (cross-talk); the
//! camera-fixed illumination (vignetting, LED-ring reflections) and exposure scale it. The
//! image is then blurred (optics), encoded to sRGB, and sensor noise is added in digital
//! numbers before rounding. A unit's [`crate::imperfections::Imperfections`] add oblique
//! light, glare, white balance, mottle, a wobbling and distorted grating, a lens's lateral
//! chromatic aberration and JPEG compression, each as its module documents. Everything is
//! deterministic for a given noise seed.

use image::RgbImage;

use crate::contact::{depth_field, Indenter};
use crate::plane::{blur, magnify};
use crate::rng::Rng;
use crate::state::SkinState;
use crate::unit::SensorUnit;

/// Ground truth of a rendered frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Truth {
    /// Indentation depth per pixel, mm.
    pub depth_mm: Vec<f32>,
    /// Temperature per pixel, °C.
    pub temperature_c: Vec<f32>,
    /// Deepest indentation, mm.
    pub peak_depth_mm: f32,
    /// Total normal force, N.
    pub force_n: f32,
    /// Centre of the deepest contact, image pixels.
    pub contact_px: Option<(f32, f32)>,
    /// Mean temperature over the deepest contact's footprint, °C.
    pub contact_temp_c: Option<f32>,
}

/// Reflectance look-up over temperature: −20…120 °C in 0.01 °C steps.
struct ColourLut {
    coloured: Vec<[f32; 3]>,
    black: Vec<[f32; 3]>,
}

const LUT_T0: f32 = -20.0;
const LUT_STEP: f32 = 0.01;

impl ColourLut {
    fn new(u: &SensorUnit) -> ColourLut {
        let n = ((140.0 / LUT_STEP) as usize) + 1;
        let ts = (0..n).map(|i| LUT_T0 + i as f32 * LUT_STEP);
        ColourLut {
            coloured: ts.clone().map(|t| u.coloured_reflectance(t)).collect(),
            black: ts.map(|t| u.black_reflectance(t)).collect(),
        }
    }

    fn index(&self, t: f32) -> usize {
        (((t - LUT_T0) / LUT_STEP).round().max(0.0) as usize).min(self.coloured.len() - 1)
    }
}

fn linear_to_srgb(c: f32) -> f32 {
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// A unit's renderer: look-up tables and the camera-fixed illumination, computed once.
pub struct Renderer {
    unit: SensorUnit,
    lut: ColourLut,
    /// Vignetting × LED-ring reflections per pixel (exposure not included).
    illum: Vec<f32>,
    /// Added glare radiance per pixel (empty without glare).
    glare: Vec<[f32; 3]>,
    srgb: Vec<f32>,
    normals: Vec<f32>,
}

impl std::fmt::Debug for Renderer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Renderer")
            .field("unit", &self.unit)
            .finish_non_exhaustive()
    }
}

/// Renders one frame of `unit` in `state` (builds a [`Renderer`] each call; keep one for
/// sequences).
pub fn render(unit: &SensorUnit, state: &SkinState, noise_seed: u64) -> (RgbImage, Truth) {
    Renderer::new(unit.clone()).render(state, noise_seed)
}

impl Renderer {
    /// Precomputes what does not change between frames.
    pub fn new(unit: SensorUnit) -> Renderer {
        let (w, h) = (unit.width_px as usize, unit.height_px as usize);
        let (cx, cy) = (w as f32 / 2.0, h as f32 / 2.0);
        let corner2 = cx * cx + cy * cy;
        let imp = &unit.imperfections;
        let (vx, vy) = (
            cx + imp.vignetting_offset.0 * w as f32,
            cy + imp.vignetting_offset.1 * h as f32,
        );
        let spot_s = 0.08 * cx.min(cy);
        let spots = lamp_reflections_px(&unit, 0.0);
        let mut illum = vec![0.0f32; w * h];
        for y in 0..h {
            for x in 0..w {
                let (dx, dy) = (x as f32 + 0.5 - vx, y as f32 + 0.5 - vy);
                let vig = 1.0 - unit.vignetting * (dx * dx + dy * dy) / corner2;
                let hot: f32 = spots
                    .iter()
                    .map(|&(sx, sy)| {
                        let r2 = (x as f32 - sx).powi(2) + (y as f32 - sy).powi(2);
                        (-r2 / (2.0 * spot_s * spot_s)).exp()
                    })
                    .sum();
                illum[y * w + x] = vig * (1.0 + unit.hotspot_gain * hot);
            }
        }
        let glare = if imp.glare.is_empty() {
            Vec::new()
        } else {
            (0..w * h)
                .map(|i| imp.glare_at(((i % w) as f32 + 0.5, (i / w) as f32 + 0.5)))
                .collect()
        };
        Renderer {
            lut: ColourLut::new(&unit),
            illum,
            glare,
            srgb: (0..=4096)
                .map(|i| 255.0 * linear_to_srgb(i as f32 / 4096.0))
                .collect(),
            normals: crate::rng::normal_table(),
            unit,
        }
    }

    /// The unit being rendered.
    pub fn unit(&self) -> &SensorUnit {
        &self.unit
    }

    /// Renders one frame; `noise_seed` makes the sensor noise repeatable.
    pub fn render(&self, state: &SkinState, noise_seed: u64) -> (RgbImage, Truth) {
        let unit = &self.unit;
        let (w, h) = (unit.width_px as usize, unit.height_px as usize);
        let mmpp = unit.mm_per_px();
        let mut depth = vec![0.0f32; w * h];
        depth_field(
            &state.contacts,
            w,
            h,
            mmpp,
            state.shift_px,
            unit.layer_decay_mm,
            &mut depth,
        );

        let mut temp = vec![0.0f32; w * h];
        let uniform = state.temperature.sources.is_empty();
        for y in 0..h {
            for x in 0..w {
                temp[y * w + x] = if uniform {
                    state.temperature.base_c
                } else {
                    state.temperature.at((
                        (x as f32 + 0.5 + state.shift_px.0) * mmpp,
                        (y as f32 + 0.5 + state.shift_px.1) * mmpp,
                    ))
                };
            }
        }

        let (ct, st) = {
            let a = unit.tilt_deg.to_radians();
            (a.cos(), a.sin())
        };
        let kf = std::f32::consts::TAU / unit.period_px;
        let cd = (std::f32::consts::PI * unit.duty).cos();
        let ks = unit.edge_sharpness.max(0.2);
        let (lo, hi) = ((ks * (-1.0 - cd)).tanh(), (ks * (1.0 - cd)).tanh());
        let contrast = state.contrast_scale.clamp(0.0, 1.0);
        let gain = unit.exposure * state.exposure_scale;
        let imp = &unit.imperfections;
        let wb: [f32; 3] = std::array::from_fn(|k| imp.white_balance[k] * state.white_balance[k]);
        let plain = wb == [1.0; 3] && self.glare.is_empty();
        let centre = (w as f32 / 2.0, h as f32 / 2.0);
        let half_diagonal = (centre.0 * centre.0 + centre.1 * centre.1).sqrt();
        let light = (imp.oblique_dir_rad.cos(), imp.oblique_dir_rad.sin());

        let mut planes = [
            vec![0.0f32; w * h],
            vec![0.0f32; w * h],
            vec![0.0f32; w * h],
        ];
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let (xd, yd) = imp.distort((x as f32 + 0.5, y as f32 + 0.5), centre, half_diagonal);
                let xs = xd + state.shift_px.0;
                let ys = yd + state.shift_px.1;
                let skin_mm = (xs * mmpp, ys * mmpp);
                let d = depth[i];
                let mut theta = kf * (xs * ct + ys * st) + unit.phase0_rad + unit.phase_of_depth(d);
                if imp.wobble_rad != 0.0 {
                    theta += imp.wobble_at(skin_mm);
                }
                let mut wcol = ((ks * (theta.cos() - cd)).tanh() - lo) / (hi - lo);
                wcol = 0.5 + (wcol - 0.5) * contrast;
                let li = self.lut.index(temp[i]);
                let (mut c, b) = (self.lut.coloured[li], self.lut.black[li]);
                if imp.mottle != 0.0 {
                    let m = imp.mottle_at(skin_mm);
                    c = c.map(|v| v * m);
                }
                let shade = if d > 0.0 {
                    // Surface tilt from the depth gradient (central differences, mm/mm).
                    let gx = (depth[y * w + (x + 1).min(w - 1)]
                        - depth[y * w + x.saturating_sub(1)])
                        / (2.0 * mmpp);
                    let gy = (depth[(y + 1).min(h - 1) * w + x]
                        - depth[y.saturating_sub(1) * w + x])
                        / (2.0 * mmpp);
                    let cos_tilt = 1.0 / (1.0 + gx * gx + gy * gy).sqrt();
                    // The surface height is −w, so its normal leans along ∇w: towards the
                    // light by ∇w·l̂.
                    let towards_light = gx * light.0 + gy * light.1;
                    (1.0 - unit.shading_gain * (1.0 - cos_tilt))
                        * (1.0 + imp.oblique_gain * towards_light).max(0.0)
                } else {
                    1.0
                };
                let illum = gain * self.illum[i] * shade;
                for k in 0..3 {
                    let v = (wcol * c[k] + (1.0 - wcol) * b[k]) * illum;
                    planes[k][i] = if plain {
                        v
                    } else {
                        let glare = self.glare.get(i).map_or(0.0, |g| g[k]);
                        (v + gain * glare) * wb[k]
                    };
                }
            }
        }
        // The lens images red and blue at their own scales (lateral chromatic aberration).
        for (p, chi) in [0, 2].into_iter().zip(imp.chromatic) {
            magnify(&mut planes[p], w, h, chi);
        }
        for p in &mut planes {
            blur(p, w, h, unit.blur_px);
        }

        // Encode: linear → sRGB 8-bit, with sensor noise in digital numbers.
        let sigma = unit.noise_dn * state.noise_scale;
        let mut rng = Rng::derive(noise_seed, "noise");
        let mut img = RgbImage::new(unit.width_px, unit.height_px);
        let raw: &mut [u8] = &mut img;
        for i in 0..w * h {
            let n = rng.normal4(&self.normals);
            for (k, n) in n.into_iter().take(3).enumerate() {
                let v = planes[k][i].clamp(0.0, 1.0);
                let base = self.srgb[(v * 4096.0) as usize];
                raw[i * 3 + k] = (base + sigma * n).round().clamp(0.0, 255.0) as u8;
            }
        }

        if let Some(q) = imp.jpeg_quality {
            img = through_jpeg(img, q);
        }
        let truth = truth_of(unit, state, depth, temp);
        (img, truth)
    }
}

/// Where the LED ring's twelve lamps reflect in the image, pixels (each a spot of the unit's
/// `hotspot_gain`): evenly round a ring at 0.9 of the half-height (or half-width) from the
/// centre, or `inward_px` inside it.
pub fn lamp_reflections_px(unit: &SensorUnit, inward_px: f32) -> [(f32, f32); 12] {
    let (cx, cy) = (unit.width_px as f32 / 2.0, unit.height_px as f32 / 2.0);
    let r = 0.9 * cx.min(cy) - inward_px;
    std::array::from_fn(|i| {
        let a = std::f32::consts::TAU * (i as f32 + 0.5) / 12.0;
        (cx + r * a.cos(), cy + r * a.sin())
    })
}

/// The image as a camera compressing at JPEG `quality` sends it (unchanged should the codec
/// refuse it, which it does not for an RGB image in memory).
fn through_jpeg(img: RgbImage, quality: u8) -> RgbImage {
    let mut bytes = Vec::new();
    let enc = image::codecs::jpeg::JpegEncoder::new_with_quality(&mut bytes, quality);
    if img.write_with_encoder(enc).is_err() {
        return img;
    }
    match image::load_from_memory_with_format(&bytes, image::ImageFormat::Jpeg) {
        Ok(decoded) => decoded.to_rgb8(),
        Err(_) => img,
    }
}

fn truth_of(unit: &SensorUnit, state: &SkinState, depth: Vec<f32>, temp: Vec<f32>) -> Truth {
    let (w, h) = (unit.width_px as usize, unit.height_px as usize);
    let mmpp = unit.mm_per_px();
    let peak = depth.iter().copied().fold(0.0f32, f32::max);
    let force_n = state
        .contacts
        .iter()
        .map(|c| c.indenter.force_n(c.depth_mm, unit.modulus_mpa))
        .sum();
    let deepest = state
        .contacts
        .iter()
        .filter(|c| c.depth_mm > 0.0)
        .max_by(|a, b| a.depth_mm.total_cmp(&b.depth_mm));
    let contact_px = deepest.map(|c| {
        (
            c.center_mm.0 / mmpp - state.shift_px.0,
            c.center_mm.1 / mmpp - state.shift_px.1,
        )
    });
    let uniform = state.temperature.sources.is_empty();
    let contact_temp_c = deepest.and_then(|c| {
        if uniform {
            return Some(state.temperature.base_c);
        }
        let (mut sum, mut n) = (0.0f64, 0u32);
        for y in 0..h {
            for x in 0..w {
                let p = (
                    (x as f32 + 0.5 + state.shift_px.0) * mmpp - c.center_mm.0,
                    (y as f32 + 0.5 + state.shift_px.1) * mmpp - c.center_mm.1,
                );
                let inside = match &c.indenter {
                    Indenter::Sphere { r_mm } => p.0 * p.0 + p.1 * p.1 <= r_mm * c.depth_mm,
                    Indenter::Punch(fp) => fp.signed_distance(p) <= 0.0,
                };
                if inside {
                    sum += f64::from(temp[y * w + x]);
                    n += 1;
                }
            }
        }
        (n > 0).then(|| (sum / f64::from(n)) as f32)
    });
    Truth {
        depth_mm: depth,
        temperature_c: temp,
        peak_depth_mm: peak,
        force_n,
        contact_px,
        contact_temp_c,
    }
}
