//! The contact's shape, a sphere's dome or a flat punch's plateau, from its radial profile.
//!
//! The apex correction ([`super::apex`]) takes a sphere's blur loss out of the peak. A flat
//! punch loses less, and its steep rim makes the demodulator overshoot just inside it, so
//! a punch read as a sphere reads deep. A contact's area against the calibrated sphere's
//! at the same depth cannot tell the two apart: a sphere of twice the radius has twice the
//! area, like a punch, so the area test flags both. The profile's shape can, once the
//! contact is several kernel σ wide.
//!
//! **How.** The depth map is the surface blurred once by the demodulator's kernel. Both
//! families of unit surfaces, Hertz's sphere (`apex::hertz`) and Boussinesq's
//! punch, each for a ladder of contact radii `a`, are blurred by a Gaussian of the kernel's
//! variance and averaged over rings one pixel wide: templates built once per plan. The
//! contact's ring means about its centre, out to where they fall below [`PROFILE_CUT`] of
//! their deepest, are fitted by each template (least squares, each ring weighted by its
//! pixels; the depth is the only free value), and each family keeps its best radius. The
//! data choose: a family is the contact's shape when its fit leaves at most [`FIT_LIMIT`]
//! of the map unexplained (over the pixels, so what varies around a ring, a letter's
//! strokes, counts against it), the other family's fit of the ring means leaves
//! [`CLEAR_RATIO`] times as much as its own, and the contact is wide enough for the choice
//! to hold ([`SPHERE_MIN_SIGMAS`], [`FLAT_MIN_SIGMAS`]; a dome narrower than
//! [`WIDE_SPHERE_SIGMAS`] must be clearer still). A plateau has looser limits of its
//! own ([`FLAT_FIT_LIMIT`], [`FLAT_CLEAR_RATIO`]): a punch's rim leaves uneven overshoot
//! around it, and a dome wide enough for a plateau's core is told apart by less. Otherwise
//! (a small contact whose blurred profiles the two families share, a letter that neither
//! describes) the shape is unknown, and the contact is judged as before by its area and
//! load against the calibrated indenter's.
//!
//! A sphere is then read as one whatever its radius: no area test, and its load against a
//! sphere's of its radius. A flat punch's depth is its plateau's level: the mean of the
//! rings that lie wholly inside its fitted rim by the kernel's reach, where the blur has
//! left the plateau as it is and a rim's overshoot does not reach (or, for a plateau too
//! narrow for such a core of two rings, the fit's depth, left open where the dome's fit
//! reads it beyond the depth tolerance: [`ShapeFit::level_open`]). A plateau is spared the
//! tests of an unknown shape unless its skirt may have sunk the frame's registration
//! (`docs/pipeline.md` gives the measured trade).

use super::apex::{hertz, punch, LAYER_DECAY_MM, RESOLVED_SIGMAS};
use super::depth_tolerance_um;
use super::load::Rings;
use crate::ftp::band::box2_sigma_px;

/// Rings whose mean falls below this fraction of the deepest ring's end the profile: the
/// part of the surround both families describe, above the noise floor's cut.
pub const PROFILE_CUT: f64 = 0.25;
/// A family's best fit explains the contact when what it leaves of the map over the
/// profile's pixels (a ring's spread included) is at most this fraction of the map (roots
/// of the sums of squares)…
pub const FIT_LIMIT: f64 = 0.08;
/// …and is the contact's shape only when the other family's fit of the ring means leaves
/// this many times as much as its own.
pub const CLEAR_RATIO: f64 = 3.0;
/// A plateau's fit may leave up to this fraction of the map: a punch's rim makes the
/// demodulator overshoot unevenly around it (higher on one side), which varies around a
/// ring, while a letter's strokes and gaps leave clearly more (and so does a dome whose
/// apex a glare spot bent; `docs/pipeline.md` has the measured spread).
pub const FLAT_FIT_LIMIT: f64 = 0.12;
/// A plateau is the contact's shape when the dome's fit of the ring means leaves this many
/// times as much as the plateau's: a dome wide enough to have a plateau's core leaves
/// clearly less than a plateau does, while a punch whose blurred rim a dome half follows
/// still leaves the dome more.
pub const FLAT_CLEAR_RATIO: f64 = 2.0;
pub use super::apex::FLAT_MIN_SIGMAS;
/// A dome is chosen only for a contact at least this many kernel σ in radius (its fit's)…
pub const SPHERE_MIN_SIGMAS: f64 = 4.5;
/// …and, narrower than this many, only when the plateau's fit of the ring means leaves
/// [`NARROW_SPHERE_CLEAR_RATIO`] times the dome's: a small punch, blurred, can fit a wider
/// sphere better than any punch, and a punch read as a sphere reads deep
/// (`docs/pipeline.md` has how much better such punches fit).
pub const WIDE_SPHERE_SIGMAS: f64 = 6.0;
/// The clear ratio a dome narrower than [`WIDE_SPHERE_SIGMAS`] must reach.
pub const NARROW_SPHERE_CLEAR_RATIO: f64 = 4.5;
/// A plateau's level is read this many kernel σ inside its fitted rim: the kernel reaches
/// `√6 σ` (a two-box triangle of length `l` has `σ² = (l² − 1)/6`), and the fitted radius
/// is a ladder's step from the true one.
pub const CORE_MARGIN_SIGMAS: f64 = 3.0;
/// A plateau's core is read only over at least this many rings: the centre's ring alone
/// is where a band-limited disc's ringing from its whole rim meets, and it reads the
/// level high or low by a share of it as the radius falls against the band.
pub const CORE_RINGS: usize = 2;
/// Successive template radii grow by this factor.
const RADIUS_STEP: f64 = 1.03;
/// Templates run up to contacts of this radius, mm (beyond any indenter a palm's skin
/// meets)…
const LARGEST_RADIUS_MM: f64 = 15.0;
/// …and out to where they fall below this fraction of their centre.
const TEMPLATE_END: f64 = 0.02;
/// Rings a template holds at most.
const MAX_RINGS: usize = 256;

/// What a contact's profile says it is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Shape {
    /// Neither family clearly: too small to tell, or of another shape.
    #[default]
    Unknown,
    /// A sphere's dome (Hertz).
    Sphere,
    /// A flat punch's plateau (Boussinesq).
    Flat,
}

impl Shape {
    /// The shape's name in reports: `unknown`, `sphere`, `flat`.
    pub fn name(self) -> &'static str {
        match self {
            Shape::Unknown => "unknown",
            Shape::Sphere => "sphere",
            Shape::Flat => "flat",
        }
    }
}

/// A contact's shape and what its fit reads.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ShapeFit {
    /// The family the data choose.
    pub shape: Shape,
    /// The chosen family's depth, in the map's units (for [`Shape::Unknown`], 0).
    pub depth: f64,
    /// The chosen family's contact radius, pixels (for [`Shape::Unknown`], 0).
    pub radius_px: f64,
    /// A plateau too narrow for [`CORE_RINGS`] rings to lie wholly [`CORE_MARGIN_SIGMAS`]
    /// inside its rim, whose level is then its template's, where the dome's best fit reads
    /// a depth beyond the depth tolerance from it: a dome whose apex reads low (its phase
    /// gain varying across the view) has such a blurred top too, and nothing in the map
    /// says which.
    pub level_open: bool,
}

/// One blurred unit surface averaged over rings.
#[derive(Debug, Clone, PartialEq)]
struct Template {
    flat: bool,
    a_px: f64,
    rings: Vec<f64>,
}

/// Both families' templates for one demodulator kernel, built once per plan.
#[derive(Debug, Clone, PartialEq)]
pub struct Shapes {
    templates: Vec<Template>,
    /// The kernel's σ, pixels.
    sigma_px: f64,
}

/// A contact's ring means and what its pixels hold beside them.
#[derive(Debug, Clone)]
struct Profile {
    /// Mean and pixel count per ring, from the centre out.
    rings: Vec<(f64, f64)>,
    /// Σ over the rings of pixel count × mean² (what a fit of the ring means explains
    /// against).
    means_sq: f64,
    /// Σ value² over the rings' pixels.
    total: f64,
    /// Σ squared deviation of each pixel from its ring's mean.
    spread: f64,
}

/// A family's best fit: its residual fractions over the ring means (`shape_err`: how
/// well the family's profile matches) and over the pixels (`err`: how much of the map it
/// leaves unexplained, a ring's spread included), depth and radius.
#[derive(Debug, Clone, Copy)]
struct Best {
    shape_err: f64,
    err: f64,
    depth: f64,
    a_px: f64,
}

impl Shapes {
    /// The templates for the kernel of two-box lengths `lengths`, on a map of working
    /// pixels `px_mm` wide, the surround decaying over [`LAYER_DECAY_MM`] beyond the
    /// contact's edge (as the apex correction's).
    pub fn new(lengths: (usize, usize), px_mm: f32) -> Shapes {
        let sigma = box2_sigma_px(lengths);
        let px_mm = f64::from(px_mm).max(1e-6);
        let decay = LAYER_DECAY_MM / px_mm;
        let largest = (LARGEST_RADIUS_MM / px_mm).max(4.0 * sigma);
        let mut templates = Vec::new();
        let mut a = RESOLVED_SIGMAS * sigma;
        while a <= largest {
            for flat in [false, true] {
                let surface = |r: f64| {
                    if flat {
                        punch(r, a, decay)
                    } else {
                        hertz(r, a, decay)
                    }
                };
                let rings = blurred_rings(surface, sigma);
                templates.push(Template {
                    flat,
                    a_px: a,
                    rings,
                });
            }
            a *= RADIUS_STEP;
        }
        Shapes {
            templates,
            sigma_px: sigma,
        }
    }

    /// The shape of the contact whose map about its centre is summed over `rings` (map
    /// units, [`super::load::rings`]). A family's residual is over the pixels: what varies
    /// around a ring (a letter's strokes, a second blob) counts against both.
    pub fn fit(&self, rings: &Rings) -> ShapeFit {
        let Some(profile) = cut_profile(rings) else {
            return ShapeFit::default();
        };
        let (sphere, flat) = (self.best(&profile, false), self.best(&profile, true));
        let (Some(sphere), Some(flat)) = (sphere, flat) else {
            return ShapeFit::default();
        };
        let chosen = |b: Best, shape| {
            let min_sigmas = match shape {
                Shape::Sphere => SPHERE_MIN_SIGMAS,
                _ => FLAT_MIN_SIGMAS,
            };
            if b.a_px < min_sigmas * self.sigma_px {
                return ShapeFit::default();
            }
            ShapeFit {
                shape,
                depth: b.depth,
                radius_px: b.a_px,
                level_open: false,
            }
        };
        let sphere_clear = if sphere.a_px < WIDE_SPHERE_SIGMAS * self.sigma_px {
            NARROW_SPHERE_CLEAR_RATIO
        } else {
            CLEAR_RATIO
        };
        if sphere.err <= FIT_LIMIT && flat.shape_err >= sphere_clear * sphere.shape_err {
            chosen(sphere, Shape::Sphere)
        } else if flat.err <= FLAT_FIT_LIMIT
            && sphere.shape_err >= FLAT_CLEAR_RATIO * flat.shape_err
        {
            let mut fit = chosen(flat, Shape::Flat);
            if fit.shape == Shape::Flat {
                match self.plateau_core(&profile.rings, flat.a_px) {
                    Some(level) => fit.depth = level,
                    None => fit.level_open = beyond_tolerance(sphere.depth, flat.depth),
                }
            }
            fit
        } else {
            ShapeFit::default()
        }
    }

    /// The plateau's level where the blur has left it untouched: the mean of the rings lying
    /// wholly within [`CORE_MARGIN_SIGMAS`] kernel σ inside the fitted radius `a_px` (none
    /// for a plateau too narrow for [`CORE_RINGS`] of them). There the map is the plateau
    /// itself, whatever the templates' approximation of the kernel and the ladder's step in
    /// radius.
    fn plateau_core(&self, profile: &[(f64, f64)], a_px: f64) -> Option<f64> {
        let inside = a_px - CORE_MARGIN_SIGMAS * self.sigma_px;
        // Ring k spans radii k to k + 1: as many lie wholly inside as whole pixels do.
        let rings = (inside.max(0.0).floor() as usize).min(profile.len());
        let (sum, n) =
            (profile[..rings].iter()).fold((0.0, 0.0), |(s, c), &(p, n)| (s + p * n, c + n));
        (rings >= CORE_RINGS && n > 0.0).then(|| sum / n)
    }

    /// The family's template that fits `profile` best.
    fn best(&self, profile: &Profile, flat: bool) -> Option<Best> {
        let (means_sq, total) = (profile.means_sq, profile.total);
        if total <= 0.0 {
            return None;
        }
        self.templates
            .iter()
            .filter(|t| t.flat == flat)
            .filter_map(|t| {
                let (mut pt, mut tt) = (0.0, 0.0);
                for (k, &(p, n)) in profile.rings.iter().enumerate() {
                    let v = t.rings.get(k).copied().unwrap_or(0.0);
                    pt += n * p * v;
                    tt += n * v * v;
                }
                (tt > 0.0).then(|| {
                    let depth = pt / tt;
                    let sse = (means_sq - depth * pt).max(0.0);
                    Best {
                        shape_err: (sse / means_sq).sqrt(),
                        err: ((profile.spread + sse) / total).sqrt(),
                        depth,
                        a_px: t.a_px,
                    }
                })
            })
            .min_by(|a, b| a.shape_err.total_cmp(&b.shape_err))
    }
}

/// Whether a reading of `other_um` lies beyond the depth tolerance from one of `level_um`.
fn beyond_tolerance(other_um: f64, level_um: f64) -> bool {
    (other_um - level_um).abs() > f64::from(depth_tolerance_um(level_um as f32))
}

/// The ring means with their pixel counts, up to the first ring below [`PROFILE_CUT`] of the
/// deepest, and over those rings' pixels the Σ value² and the Σ squared deviation from
/// their ring's mean (`None` when fewer than three rings remain, a ring inside is empty,
/// or the rings end before the cut).
fn cut_profile(rings: &Rings) -> Option<Profile> {
    let mean =
        |k: usize| (rings.count[k] > 0).then(|| rings.sum[k] as f64 / f64::from(rings.count[k]));
    let deepest = (0..rings.count.len()).filter_map(mean).fold(0.0, f64::max);
    if deepest <= 0.0 {
        return None;
    }
    let (mut profile, mut means_sq, mut total, mut spread) = (Vec::new(), 0.0, 0.0, 0.0);
    for k in 0..rings.count.len() {
        let m = mean(k)?;
        if m < PROFILE_CUT * deepest {
            return (profile.len() >= 3).then_some(Profile {
                rings: profile,
                means_sq,
                total,
                spread,
            });
        }
        let (n, sq) = (f64::from(rings.count[k]), rings.sum_sq[k] as f64);
        profile.push((m, n));
        means_sq += n * m * m;
        total += sq;
        spread += (sq - n * m * m).max(0.0);
    }
    None
}

/// The radially symmetric `surface` blurred by an isotropic Gaussian of `sigma` pixels,
/// averaged over rings one pixel wide (ring `k` read at its pixels' mean radius), out to
/// where it falls below [`TEMPLATE_END`] of its centre.
///
/// For a radial function the 2-D blur is a 1-D integral with the Rician kernel:
/// `B(r) = ∫ s(ρ)·(ρ/σ²)·e^(−(r−ρ)²/2σ²)·Ĩ₀(rρ/σ²) dρ`, `Ĩ₀(x) = e^(−x)·I₀(x)`, taken over
/// ρ within five σ of `r` by the midpoint rule.
fn blurred_rings(surface: impl Fn(f64) -> f64, sigma: f64) -> Vec<f64> {
    let h = sigma / 6.0;
    let s2 = sigma * sigma;
    let blurred = |r: f64| {
        let lo = (r - 5.0 * sigma).max(0.0);
        let steps = ((r + 5.0 * sigma - lo) / h).ceil() as usize;
        (0..steps)
            .map(|i| {
                let rho = lo + (i as f64 + 0.5) * h;
                let g = (-(r - rho) * (r - rho) / (2.0 * s2)).exp();
                surface(rho) * rho / s2 * g * i0_scaled(r * rho / s2) * h
            })
            .sum::<f64>()
    };
    let mut rings = Vec::new();
    let mut centre = None;
    for k in 0..MAX_RINGS {
        let (r0, r1) = (k as f64, k as f64 + 1.0);
        let mean_r = 2.0 / 3.0 * (r1.powi(3) - r0.powi(3)) / (r1 * r1 - r0 * r0);
        let v = blurred(mean_r);
        let c = *centre.get_or_insert(v);
        rings.push(v);
        if v < TEMPLATE_END * c {
            break;
        }
    }
    rings
}

/// `e^(−x)·I₀(x)` for `x ≥ 0`: the power series below 15, the asymptotic series above.
fn i0_scaled(x: f64) -> f64 {
    if x < 15.0 {
        let q = 0.25 * x * x;
        let (mut term, mut sum) = (1.0, 1.0);
        for k in 1..60 {
            term *= q / (k * k) as f64;
            sum += term;
            if term < 1e-16 * sum {
                break;
            }
        }
        sum * (-x).exp()
    } else {
        let y = 1.0 / (8.0 * x);
        (1.0 + y * (1.0 + y * (9.0 / 2.0 + y * 75.0 / 2.0)))
            / (2.0 * std::f64::consts::PI * x).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::super::apex::blur;
    use super::super::load::rings;
    use super::*;

    /// Working pixels of the test maps, mm, and the demodulator's two-box length there.
    const PX_MM: f32 = 0.25;
    const L: usize = 8;

    /// The map of `surface(r)` (µm, r in pixels from a centre between pixels) on a window
    /// `w` wide, blurred by the demodulator's kernel, with `noise_um` of uniform noise; and
    /// its rings about the centre.
    fn blurred_map(w: usize, noise_um: i32, surface: impl Fn(f64) -> f64) -> Rings {
        let c = (w as f32 / 2.0 + 0.3, w as f32 / 2.0 - 0.2);
        let mut rng = crate::test_rng::XorShift(0x2545_f491_4f6c_dd1d);
        let z: Vec<i32> = (0..w * w)
            .map(|i| {
                let (x, y) = ((i % w) as f32 + 0.5 - c.0, (i / w) as f32 + 0.5 - c.1);
                surface(f64::from(x.hypot(y))).round() as i32
            })
            .collect();
        let mut b = blur(&z, w, (L, L));
        if noise_um > 0 {
            for v in &mut b {
                *v += (rng.next() % (2 * noise_um as u64 + 1)) as i32 - noise_um;
            }
        }
        rings(&b, w, c, 0.45 * w as f32)
    }

    fn shapes() -> Shapes {
        Shapes::new((L, L), PX_MM)
    }

    #[test]
    fn i0_scaled_matches_its_values() {
        // e^(−x)·I₀(x) at 0, 1, 10 and 20.
        for (x, want) in [
            (0.0, 1.0),
            (1.0, 0.465_759_607),
            (10.0, 0.127_833_371),
            (20.0, 0.089_780_311),
        ] {
            let got = i0_scaled(x);
            assert!((got - want).abs() < 1e-5 * want, "{x}: {got}");
        }
    }

    /// A blurred constant is the constant: the Rician kernel integrates to one.
    #[test]
    fn a_flat_surface_stays_flat() {
        let rings = blurred_rings(|_| 1.0, 2.0);
        assert!(rings.iter().all(|v| (v - 1.0).abs() < 2e-3), "{rings:?}");
    }

    /// Spheres of several radii, blurred by the demodulator's own kernel (not the templates'
    /// Gaussian), noise included, read as spheres of about their contact radius once wide
    /// enough that no punch passes for them (from 4.5 kernel σ, the 4.2 mm one at about 5 σ
    /// by the stricter clear ratio); a narrower one is not told.
    #[test]
    fn wide_spheres_of_any_radius_read_as_spheres() {
        let decay = LAYER_DECAY_MM / f64::from(PX_MM);
        for (a_mm, d_um, wide) in [
            (3.5, 1200.0, false),
            (4.2, 1000.0, true),
            (5.5, 800.0, true),
            (7.0, 1500.0, true),
        ] {
            let a = a_mm / f64::from(PX_MM);
            let fit = shapes().fit(&blurred_map(161, 10, |r| d_um * hertz(r, a, decay)));
            if !wide {
                assert_eq!(fit.shape, Shape::Unknown, "a {a_mm} mm: {fit:?}");
                continue;
            }
            assert_eq!(fit.shape, Shape::Sphere, "a {a_mm} mm: {fit:?}");
            assert!(
                (fit.radius_px / a - 1.0).abs() < 0.15,
                "a {a_mm} mm: {fit:?}"
            );
        }
    }

    /// Flat punches of 5 to 7 mm read as plateaus, at their depth within 3 %.
    #[test]
    fn punches_read_as_plateaus_at_their_depth() {
        let decay = LAYER_DECAY_MM / f64::from(PX_MM);
        for (a_mm, d_um) in [(5.0, 500.0), (6.0, 600.0), (7.0, 900.0)] {
            let a = a_mm / f64::from(PX_MM);
            let m = blurred_map(161, 10, |r| d_um * punch(r, a, decay));
            let fit = shapes().fit(&m);
            assert_eq!(fit.shape, Shape::Flat, "a {a_mm} mm: {fit:?}");
            assert!(
                (fit.depth / d_um - 1.0).abs() < 0.03,
                "a {a_mm} mm: {fit:?}"
            );
        }
    }

    /// A plateau just wide enough to be told (3.3 kernel σ in radius) has no ring wholly
    /// inside its rim by the kernel's reach, and one a ring and a half wider has only the
    /// centre's: a dome reads either deeper than the tolerance, and its level is open. A
    /// wide one's core gives its level.
    #[test]
    fn a_plateau_too_narrow_for_a_core_leaves_its_level_open() {
        let decay = LAYER_DECAY_MM / f64::from(PX_MM);
        let sigma = shapes().sigma_px;
        for a_px in [3.3 * sigma, 3.0 * sigma + 1.5] {
            let narrow = blurred_map(161, 0, |r| 800.0 * punch(r, a_px, decay));
            let fit = shapes().fit(&narrow);
            assert_eq!(fit.shape, Shape::Flat, "{a_px} px: {fit:?}");
            assert!(fit.level_open, "{a_px} px: {fit:?}");
        }
        let wide = blurred_map(161, 0, |r| 800.0 * punch(r, 6.0 / f64::from(PX_MM), decay));
        let fit = shapes().fit(&wide);
        assert!(fit.shape == Shape::Flat && !fit.level_open, "{fit:?}");
    }

    /// What neither family describes is neither: a bar (a letter's stroke), and a press
    /// narrower than the kernel.
    #[test]
    fn other_shapes_are_unknown() {
        let (w, c) = (161usize, 80.3f32);
        let bar: Vec<i32> = (0..w * w)
            .map(|i| {
                let (x, y) = ((i % w) as f32 + 0.5 - c, (i / w) as f32 + 0.5 - c);
                if x.abs() < 24.0 && y.abs() < 5.0 {
                    600
                } else {
                    0
                }
            })
            .collect();
        let b = blur(&bar, w, (L, L));
        let fit = shapes().fit(&rings(&b, w, (c, c), 70.0));
        assert_eq!(fit.shape, Shape::Unknown, "bar: {fit:?}");
        let narrow = blurred_map(161, 0, |r| 500.0 * punch(r, 2.0, 12.0));
        assert_eq!(shapes().fit(&narrow).shape, Shape::Unknown);
    }

    #[test]
    fn no_profile_is_unknown() {
        assert_eq!(shapes().fit(&Rings::default()).shape, Shape::Unknown);
        let flat_everywhere = rings(&[300; 400], 20, (10.0, 10.0), 8.0);
        assert_eq!(shapes().fit(&flat_everywhere).shape, Shape::Unknown);
    }
}
