//! Contact mechanics: the skin surface under an indenter.
//!
//! **Model.** The skin and its clear buffer are treated as a linear elastic half-space with
//! an effective contact modulus `E*` per unit (it absorbs the stiffening of the finite
//! layer thickness). Indentation depth `δ` is the approach of the indenter. For every
//! indenter one pressure gives both the surface's displacement and the force (its sum).
//!
//! * **Sphere** of radius `R` (Hertz): contact radius `a = √(Rδ)`, force
//!   `F = 4/3·E*·√R·δ^{3/2}`; inside the contact the surface follows the sphere,
//!   `w = δ − r²/2R`; outside, `w = (a²/πR)·[(2 − r²/a²)·asin(a/r) + √(r²/a² − 1)]`.
//! * **Flat cylinder** of radius `a` (Boussinesq): `w = δ` under it, `w = δ·(2/π)·asin(a/r)`
//!   outside, `F = 2·E*·a·δ`.
//! * **Any other flat footprint** (letters, a hex nut): the half-space problem solved
//!   numerically ([`crate::elastic`]): the pressure on a grid of cells such that the surface
//!   sinks by `δ` under the footprint; the force is its sum, the displacement outside its
//!   field.
//!
//!   Punch edges are rounded by a Gaussian of σ = [`EDGE_ROUNDING_MM`] (the skin's
//!   thickness cannot bend sharper), which keeps steep but finite slopes at punch edges, as
//!   on the real skin.
//!
//! * **Finite layer.** The skin is a thin layer on a clear buffer bonded to a rigid window,
//!   not a half-space: far from the contact its surface returns to rest much faster than the
//!   half-space's `1/r`. Outside the contact the half-space displacement is therefore
//!   multiplied by `e^{−d/λ}`, `d` the distance from the contact edge and `λ` the unit's
//!   layer decay length (a few mm, of the order of the buffer thickness). The force stays
//!   the half-space's.
//!
//! Limits: no friction, no large-strain effects, no layer-thickness saturation beyond the
//! effective modulus and the decay factor, no interaction between several contacts
//! (displacements add).

use std::f32::consts::PI;

use crate::elastic::Punch;
pub use crate::footprint::{Footprint, Mm};

/// Rounding of punch edges by the skin, mm.
pub const EDGE_ROUNDING_MM: f32 = 0.3;

/// What presses on the skin.
#[derive(Debug, Clone, PartialEq)]
pub enum Indenter {
    /// A sphere of radius `r_mm` (Hertz contact).
    Sphere {
        /// Radius, mm.
        r_mm: f32,
    },
    /// A flat punch with a footprint.
    Punch(Footprint),
}

/// One indenter at a place and depth.
#[derive(Debug, Clone, PartialEq)]
pub struct Contact {
    /// Shape.
    pub indenter: Indenter,
    /// Centre on the skin, mm from the image's top-left.
    pub center_mm: Mm,
    /// Indentation depth (approach), mm.
    pub depth_mm: f32,
}

impl Indenter {
    /// Normal force at `depth_mm` for contact modulus `modulus_mpa`, N.
    pub fn force_n(&self, depth_mm: f32, modulus_mpa: f32) -> f32 {
        let d = depth_mm.max(0.0);
        match self {
            Indenter::Sphere { r_mm } => 4.0 / 3.0 * modulus_mpa * r_mm.sqrt() * d.powf(1.5),
            Indenter::Punch(fp) => modulus_mpa * Punch::of(fp).stiffness() * d,
        }
    }

    /// Depth that produces `force_n`, mm (inverse of [`Indenter::force_n`]).
    pub fn depth_for_force_mm(&self, force_n: f32, modulus_mpa: f32) -> f32 {
        let f = force_n.max(0.0);
        match self {
            Indenter::Sphere { r_mm } => {
                (3.0 * f / (4.0 * modulus_mpa * r_mm.sqrt())).powf(2.0 / 3.0)
            }
            Indenter::Punch(fp) => f / (modulus_mpa * Punch::of(fp).stiffness()),
        }
    }
}

/// Fills `depth` (row-major, `w × h`, mm) with the surface displacement of `contacts`,
/// sampled at pixel centres shifted by `shift_px`, at `mm_per_px`.
pub fn depth_field(
    contacts: &[Contact],
    w: usize,
    h: usize,
    mm_per_px: f32,
    shift_px: (f32, f32),
    layer_decay_mm: f32,
    depth: &mut [f32],
) {
    depth.iter_mut().for_each(|d| *d = 0.0);
    for c in contacts.iter().filter(|c| c.depth_mm > 0.0) {
        let mut layer = vec![0.0f32; w * h];
        let punch = match &c.indenter {
            Indenter::Punch(fp) => Some(Punch::of(fp)),
            Indenter::Sphere { .. } => None,
        };
        for y in 0..h {
            for x in 0..w {
                let p = (
                    (x as f32 + 0.5 + shift_px.0) * mm_per_px - c.center_mm.0,
                    (y as f32 + 0.5 + shift_px.1) * mm_per_px - c.center_mm.1,
                );
                let decay = |d: f32| (-d.max(0.0) / layer_decay_mm.max(1e-3)).exp();
                layer[y * w + x] = match &c.indenter {
                    Indenter::Sphere { r_mm } => {
                        let a = (r_mm * c.depth_mm).sqrt();
                        sphere_w(p, *r_mm, c.depth_mm) * decay(p.0.hypot(p.1) - a)
                    }
                    Indenter::Punch(fp) => {
                        let d = fp.signed_distance(p);
                        match &punch {
                            Some(punch) if d > 0.0 => c.depth_mm * punch.displacement(p) * decay(d),
                            _ => c.depth_mm,
                        }
                    }
                };
            }
        }
        if matches!(c.indenter, Indenter::Punch(_)) {
            crate::plane::blur(&mut layer, w, h, EDGE_ROUNDING_MM / mm_per_px);
        }
        for (d, l) in depth.iter_mut().zip(&layer) {
            *d += l;
        }
    }
}

fn sphere_w(p: Mm, r_mm: f32, delta: f32) -> f32 {
    let r2 = p.0 * p.0 + p.1 * p.1;
    let a2 = r_mm * delta;
    if r2 <= a2 {
        delta - r2 / (2.0 * r_mm)
    } else {
        let q = r2 / a2;
        let r = r2.sqrt();
        let a = a2.sqrt();
        a2 / (PI * r_mm) * ((2.0 - q) * (a / r).asin() + (q - 1.0).sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hertz_surface_is_continuous_and_decays() {
        let (r, d) = (10.0f32, 1.0f32);
        let a = (r * d).sqrt();
        let inside = sphere_w((a - 1e-3, 0.0), r, d);
        let outside = sphere_w((a + 1e-3, 0.0), r, d);
        assert!((inside - outside).abs() < 1e-3, "{inside} {outside}");
        assert!((sphere_w((0.0, 0.0), r, d) - d).abs() < 1e-6);
        // Far field ~ (4/3)·a³/(πRr).
        let far = sphere_w((50.0, 0.0), r, d);
        let expect = 4.0 / 3.0 * a.powi(3) / (PI * r * 50.0);
        assert!((far - expect).abs() / expect < 0.02, "{far} {expect}");
    }

    #[test]
    fn force_and_depth_invert() {
        for ind in [
            Indenter::Sphere { r_mm: 10.0 },
            Indenter::Punch(Footprint::letter_e(12.0)),
        ] {
            for f in [0.5, 5.0, 30.0] {
                let d = ind.depth_for_force_mm(f, 1.6);
                assert!((ind.force_n(d, 1.6) - f).abs() < 1e-3 * f);
            }
        }
        // Reference unit: a 10 mm sphere reaches 30 N near 2.6 mm.
        let d30 = Indenter::Sphere { r_mm: 10.0 }.depth_for_force_mm(30.0, 1.6);
        assert!((2.3..3.0).contains(&d30), "{d30}");
    }

    #[test]
    fn footprints_have_sensible_areas() {
        let e = Footprint::letter_e(10.0).area_mm2();
        assert!((35.0..60.0).contains(&e), "{e}");
        let nut = Footprint::HexNut {
            af_mm: 10.0,
            hole_mm: 5.0,
        };
        let hex = 10.0f32 * 10.0 * 0.866_025_4; // af² · √3/2
        let want = hex - PI * 2.5 * 2.5;
        assert!(
            (nut.area_mm2() - want).abs() < 1.0,
            "{} vs {want}",
            nut.area_mm2()
        );
        assert!(
            nut.signed_distance((0.0, 0.0)) > 0.0,
            "the hole does not touch"
        );
    }
}
