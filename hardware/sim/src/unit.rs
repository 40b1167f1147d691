//! One sensor unit: everything that differs from one manufactured skin to the next.
//!
//! [`SensorUnit::reference`] is a plausible default build (640×480 camera, 16 px grating
//! period). [`SensorUnit::from_seed`] draws another plausible unit: grating period 8–24 px,
//! tilt ±8°, duty cycle, stripe sharpness, phase response, stiffness, optics, noise and
//! pigment batch all vary, because every real unit differs and the software must estimate
//! them from its calibration kit rather than assume them. [`SensorUnit::wide`] draws over
//! wider ranges still and adds the [`Imperfections`] of a built skin, for judging the
//! software on units it was never tuned on.

use crate::imperfections::Imperfections;
use crate::rng::Rng;

/// Physical grating period of every vistaf skin, mm.
pub const GRATING_PERIOD_MM: f32 = 2.0;

/// Activation temperatures of the coloured stripes' pigments (yellow, red, blue), °C.
pub const COLOURED_ACTIVATION_C: [f32; 3] = [25.0, 28.0, 31.0];

/// Activation temperatures of the black stripes' eight pigments, °C.
pub const BLACK_ACTIVATION_C: [f32; 8] = [10.0, 18.0, 25.0, 28.0, 31.0, 38.0, 45.0, 70.0];

/// A thermochromic pigment of the coloured stripes: below its activation temperature it
/// absorbs `absorb` (linear RGB fractions); above it clears over `width_c`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pigment {
    /// Activation (clearing) temperature, °C.
    pub activation_c: f32,
    /// Logistic transition scale, °C (10–90 % over about 4.4× this).
    pub width_c: f32,
    /// Absorbed fraction of linear R, G, B when fully coloured.
    pub absorb: [f32; 3],
}

/// The unit's parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorUnit {
    /// Image width, pixels.
    pub width_px: u32,
    /// Image height, pixels.
    pub height_px: u32,
    /// Grating period in the image, pixels.
    pub period_px: f32,
    /// Carrier direction: 0° = vertical stripes (carrier along x), positive counter-clockwise.
    pub tilt_deg: f32,
    /// Fraction of a period covered by the coloured stripe.
    pub duty: f32,
    /// Stripe edge sharpness: ~1 ≈ sinusoidal profile, ≥ 6 ≈ square.
    pub edge_sharpness: f32,
    /// Grating phase at the image origin, rad.
    pub phase0_rad: f32,
    /// Phase change per mm of indentation at small depth, rad/mm.
    pub phase_gain_rad_per_mm: f32,
    /// Depth scale over which the phase response saturates, mm.
    pub phase_saturation_mm: f32,
    /// Effective contact modulus E* of skin and buffer, MPa (N/mm²).
    pub modulus_mpa: f32,
    /// Decay length of the surface displacement outside a contact (finite layer), mm.
    pub layer_decay_mm: f32,
    /// Optical blur (Gaussian σ), pixels.
    pub blur_px: f32,
    /// Sensor noise (Gaussian σ), 8-bit digital numbers.
    pub noise_dn: f32,
    /// Relative illumination loss at the image corners.
    pub vignetting: f32,
    /// Peak relative brightness of the LED-ring reflections.
    pub hotspot_gain: f32,
    /// Exposure: linear gain applied to scene radiance.
    pub exposure: f32,
    /// Reflectance of the backing seen through cleared pigment (linear).
    pub backing: [f32; 3],
    /// Coloured stripes' pigments (yellow, red, blue).
    pub pigments: [Pigment; 3],
    /// Black stripes: linear grey at 0 °C.
    pub black_base: f32,
    /// Black stripes: grey added by each of the eight pigments as it activates.
    pub black_step: f32,
    /// Black stripes: transition scale of each pigment, °C.
    pub black_width_c: f32,
    /// Darkening of a surface tilted by the indentation (cross-talk), fraction per unit of
    /// (1 − cos tilt).
    pub shading_gain: f32,
    /// What a built skin shows beyond the ideal model.
    pub imperfections: Imperfections,
}

impl SensorUnit {
    /// The reference build behind a camera of another size (the grating period in pixels
    /// kept).
    pub fn reference_sized(width_px: u32, height_px: u32) -> SensorUnit {
        SensorUnit {
            width_px,
            height_px,
            ..SensorUnit::reference()
        }
    }

    /// The reference build.
    pub fn reference() -> SensorUnit {
        SensorUnit {
            width_px: 640,
            height_px: 480,
            period_px: 16.0,
            tilt_deg: 1.5,
            duty: 0.5,
            edge_sharpness: 3.0,
            phase0_rad: 0.3,
            phase_gain_rad_per_mm: 1.6,
            phase_saturation_mm: 6.0,
            modulus_mpa: 1.6,
            layer_decay_mm: 3.0,
            blur_px: 0.8,
            noise_dn: 1.5,
            vignetting: 0.35,
            hotspot_gain: 0.25,
            exposure: 1.0,
            backing: [0.62, 0.62, 0.60],
            pigments: [
                Pigment {
                    activation_c: 25.0,
                    width_c: 0.9,
                    absorb: [0.03, 0.10, 0.55],
                },
                Pigment {
                    activation_c: 28.0,
                    width_c: 0.9,
                    absorb: [0.04, 0.55, 0.45],
                },
                Pigment {
                    activation_c: 31.0,
                    width_c: 0.9,
                    absorb: [0.55, 0.35, 0.04],
                },
            ],
            black_base: 0.018,
            black_step: 0.022,
            black_width_c: 3.0,
            shading_gain: 0.5,
            imperfections: Imperfections::none(),
        }
    }

    /// Another plausible unit, drawn from `seed` (seed 0 is the reference build).
    pub fn from_seed(seed: u64) -> SensorUnit {
        if seed == 0 {
            return SensorUnit::reference();
        }
        Envelope::PLAUSIBLE.draw(&mut Rng::derive(seed, "unit"))
    }

    /// A unit drawn from `seed` over ranges wider than we expect (grating period 7–30 px,
    /// blur to 1.8 px, noise 1–4 DN, pigments ±40 %), with every [`Imperfections`] effect.
    pub fn wide(seed: u64) -> SensorUnit {
        let mut r = Rng::derive(seed, "wide unit");
        let mut u = Envelope::WIDE.draw(&mut r);
        u.imperfections = Imperfections::draw(&mut r, u.width_px, u.height_px);
        u
    }

    /// Image scale, mm per pixel.
    pub fn mm_per_px(&self) -> f32 {
        GRATING_PERIOD_MM / self.period_px
    }

    /// The view's width and height on the skin, mm.
    pub fn view_mm(&self) -> (f32, f32) {
        let mmpp = self.mm_per_px();
        (self.width_px as f32 * mmpp, self.height_px as f32 * mmpp)
    }

    /// Grating phase change for an indentation of `depth_mm` (monotone, saturating):
    /// `−g·s·[(1−β)(1 − e^(−h/s)) + β·tanh(h/s)]` (β the imperfections' phase shape, 0 for
    /// an ideal build); negative, as indentation moves the stripes towards −carrier.
    pub fn phase_of_depth(&self, depth_mm: f32) -> f32 {
        let s = self.phase_saturation_mm;
        let x = depth_mm.max(0.0) / s;
        let b = self.imperfections.phase_shape;
        let shape = if b == 0.0 {
            1.0 - (-x).exp()
        } else {
            (1.0 - b) * (1.0 - (-x).exp()) + b * x.tanh()
        };
        -self.phase_gain_rad_per_mm * s * shape
    }

    /// Linear RGB reflectance of a coloured stripe at `t_c`.
    pub fn coloured_reflectance(&self, t_c: f32) -> [f32; 3] {
        let mut r = self.backing;
        for p in &self.pigments {
            let active = 1.0 / (1.0 + ((t_c - p.activation_c) / p.width_c).exp());
            for (c, a) in r.iter_mut().zip(p.absorb) {
                *c *= 1.0 - active * a;
            }
        }
        r
    }

    /// Linear RGB reflectance of a black stripe at `t_c`: a dark grey that brightens slowly
    /// as its eight pigments activate, with a faint tint of the coloured base beneath.
    pub fn black_reflectance(&self, t_c: f32) -> [f32; 3] {
        let g = self.black_base
            + BLACK_ACTIVATION_C
                .iter()
                .map(|&a| self.black_step / (1.0 + ((a - t_c) / self.black_width_c).exp()))
                .sum::<f32>();
        let col = self.coloured_reflectance(t_c);
        [
            g + 0.04 * col[0],
            0.98 * g + 0.04 * col[1],
            0.96 * g + 0.04 * col[2],
        ]
    }
}

/// The ranges a unit's parameters are drawn from (each uniform), in the order drawn.
struct Envelope {
    period_px: (f64, f64),
    duty: (f64, f64),
    edge_sharpness: (f64, f64),
    phase_gain_rad_per_mm: (f64, f64),
    phase_saturation_mm: (f64, f64),
    modulus_mpa: (f64, f64),
    layer_decay_mm: (f64, f64),
    blur_px: (f64, f64),
    noise_dn: (f64, f64),
    vignetting: (f64, f64),
    hotspot_gain: (f64, f64),
    exposure: (f64, f64),
    /// Backing tint: red up and blue down by the same amount.
    tint: f64,
    /// Pigment activation shift, °C (±).
    activation_c: f64,
    pigment_width_c: (f64, f64),
    /// Pigment absorption scale.
    absorb_scale: (f64, f64),
    black_base: (f64, f64),
    black_step: (f64, f64),
    black_width_c: (f64, f64),
    shading_gain: (f64, f64),
}

impl Envelope {
    /// Units as we expect them to be built.
    const PLAUSIBLE: Envelope = Envelope {
        period_px: (8.0, 24.0),
        duty: (0.42, 0.58),
        edge_sharpness: (1.0, 6.0),
        phase_gain_rad_per_mm: (1.1, 2.2),
        phase_saturation_mm: (4.0, 9.0),
        modulus_mpa: (1.2, 2.0),
        layer_decay_mm: (2.0, 4.5),
        blur_px: (0.5, 1.3),
        noise_dn: (0.8, 2.5),
        vignetting: (0.15, 0.5),
        hotspot_gain: (0.1, 0.4),
        exposure: (0.85, 1.1),
        tint: 0.04,
        activation_c: 0.6,
        pigment_width_c: (0.7, 1.2),
        absorb_scale: (0.8, 1.2),
        black_base: (0.012, 0.03),
        black_step: (0.016, 0.028),
        black_width_c: (2.5, 4.0),
        shading_gain: (0.3, 0.7),
    };

    /// Wider than we expect.
    const WIDE: Envelope = Envelope {
        period_px: (7.0, 30.0),
        duty: (0.4, 0.6),
        edge_sharpness: (0.8, 8.0),
        phase_gain_rad_per_mm: (0.9, 2.6),
        phase_saturation_mm: (2.5, 10.0),
        modulus_mpa: (1.0, 2.4),
        layer_decay_mm: (1.5, 5.0),
        blur_px: (0.5, 1.8),
        noise_dn: (1.0, 4.0),
        vignetting: (0.1, 0.6),
        hotspot_gain: (0.05, 0.5),
        exposure: (0.7, 1.2),
        tint: 0.06,
        activation_c: 1.0,
        pigment_width_c: (0.6, 1.4),
        absorb_scale: (0.6, 1.4),
        black_base: (0.01, 0.035),
        black_step: (0.014, 0.03),
        black_width_c: (2.0, 4.5),
        shading_gain: (0.2, 0.9),
    };

    /// A unit drawn from these ranges (image size one of four, tilt ±8°, any phase).
    fn draw(&self, r: &mut Rng) -> SensorUnit {
        let mut u = SensorUnit::reference();
        let sizes = [(320, 240), (480, 360), (640, 480), (800, 600)];
        let (w, h) = sizes[(r.next_u64() % sizes.len() as u64) as usize];
        let mut pick = |(lo, hi): (f64, f64)| r.range(lo, hi) as f32;
        u.width_px = w;
        u.height_px = h;
        u.period_px = pick(self.period_px);
        u.tilt_deg = pick((-8.0, 8.0));
        u.duty = pick(self.duty);
        u.edge_sharpness = pick(self.edge_sharpness);
        u.phase0_rad = pick((0.0, std::f64::consts::TAU));
        u.phase_gain_rad_per_mm = pick(self.phase_gain_rad_per_mm);
        u.phase_saturation_mm = pick(self.phase_saturation_mm);
        u.modulus_mpa = pick(self.modulus_mpa);
        u.layer_decay_mm = pick(self.layer_decay_mm);
        u.blur_px = pick(self.blur_px);
        u.noise_dn = pick(self.noise_dn);
        u.vignetting = pick(self.vignetting);
        u.hotspot_gain = pick(self.hotspot_gain);
        u.exposure = pick(self.exposure);
        let tint = pick((-self.tint, self.tint));
        u.backing = [0.62 + tint, 0.62, 0.60 - tint];
        for p in &mut u.pigments {
            p.activation_c += pick((-self.activation_c, self.activation_c));
            p.width_c = pick(self.pigment_width_c);
            for a in &mut p.absorb {
                *a = (*a * pick(self.absorb_scale)).min(0.9);
            }
        }
        u.black_base = pick(self.black_base);
        u.black_step = pick(self.black_step);
        u.black_width_c = pick(self.black_width_c);
        u.shading_gain = pick(self.shading_gain);
        u
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units_vary_within_the_envelope() {
        let a = SensorUnit::from_seed(1);
        let b = SensorUnit::from_seed(2);
        assert_ne!(a, b);
        for s in 1..50 {
            let u = SensorUnit::from_seed(s);
            assert!((8.0..24.0).contains(&u.period_px));
            assert!(u.tilt_deg.abs() <= 8.0);
            assert!(u.width_px >= 320 && u.width_px <= 800);
        }
        assert_eq!(SensorUnit::from_seed(0), SensorUnit::reference());
    }

    #[test]
    fn phase_response_is_monotone_and_saturating() {
        let u = SensorUnit::reference();
        let mut last = 0.0;
        for i in 1..100 {
            let p = u.phase_of_depth(i as f32 * 0.05);
            assert!(p < last);
            last = p;
        }
        let slope0 = u.phase_of_depth(0.01) / 0.01;
        assert!((slope0 + u.phase_gain_rad_per_mm).abs() < 0.01);
    }

    #[test]
    fn coloured_stripes_change_most_in_the_transition_and_black_brightens() {
        let u = SensorUnit::reference();
        let d = |t0: f32, t1: f32| {
            let (a, b) = (u.coloured_reflectance(t0), u.coloured_reflectance(t1));
            a.iter().zip(b).map(|(x, y)| (x - y).abs()).sum::<f32>()
        };
        assert!(d(27.0, 28.0) > 5.0 * d(40.0, 41.0));
        assert!(d(27.0, 28.0) > 5.0 * d(15.0, 16.0));
        let g = |t| u.black_reflectance(t)[1];
        assert!(g(15.0) < g(30.0) && g(30.0) < g(45.0) && g(45.0) < g(70.0));
        assert!(g(70.0) < 0.3, "black stays dark");
    }
}
