//! Temperature fields on the skin.
//!
//! A heated contact conducts into the skin under its footprint and spreads sideways with an
//! exponential fall-off of length `spread_mm` (steady-state lateral conduction in a thin
//! layer over a cooler base decays as `e^{−d/λ}`). A heated bar is a linear gradient.

use crate::contact::{Contact, Indenter};
use crate::footprint::{Footprint, Mm};

/// A temperature source on the skin.
#[derive(Debug, Clone, PartialEq)]
pub enum HeatSource {
    /// A body at `temp_c` touching (or hovering over) `footprint` centred at `center_mm`.
    Spot {
        /// Centre on the skin, mm.
        center_mm: Mm,
        /// Footprint of the hot area.
        footprint: Footprint,
        /// Temperature under the footprint, °C.
        temp_c: f32,
        /// Lateral fall-off length, mm.
        spread_mm: f32,
    },
    /// A linear gradient: `base + (hot − base)·t` along `direction`, t ∈ [0, 1] across
    /// `from_mm` → `to_mm`, clamped at both ends.
    Gradient {
        /// Where the base temperature holds.
        from_mm: Mm,
        /// Where the hot temperature holds.
        to_mm: Mm,
        /// Temperature at `to_mm`, °C.
        hot_c: f32,
    },
}

impl HeatSource {
    /// The heat a body at `temp_c` conducts into the skin through contact `c`: a spot over
    /// its contact footprint (a sphere's disc of radius `√(R·d)`, a punch's own shape),
    /// falling off `spread_mm` beyond it.
    pub fn under(c: &Contact, temp_c: f32, spread_mm: f32) -> HeatSource {
        let footprint = match &c.indenter {
            Indenter::Sphere { r_mm } => Footprint::Disc {
                r_mm: (r_mm * c.depth_mm.max(0.0)).sqrt(),
            },
            Indenter::Punch(fp) => fp.clone(),
        };
        HeatSource::Spot {
            center_mm: c.center_mm,
            footprint,
            temp_c,
            spread_mm,
        }
    }
}

/// The skin's temperature: a uniform base plus heat sources (the hottest one wins).
#[derive(Debug, Clone, PartialEq)]
pub struct TempField {
    /// Temperature away from every source, °C.
    pub base_c: f32,
    /// Heat sources.
    pub sources: Vec<HeatSource>,
}

impl TempField {
    /// A uniform skin.
    pub fn uniform(t_c: f32) -> TempField {
        TempField {
            base_c: t_c,
            sources: Vec::new(),
        }
    }

    /// Temperature at skin point `p`, °C.
    pub fn at(&self, p: Mm) -> f32 {
        let mut t = self.base_c;
        for s in &self.sources {
            let ts = match s {
                HeatSource::Spot {
                    center_mm,
                    footprint,
                    temp_c,
                    spread_mm,
                } => {
                    let d = footprint.signed_distance((p.0 - center_mm.0, p.1 - center_mm.1));
                    let g = if d <= 0.0 {
                        1.0
                    } else {
                        (-d / spread_mm.max(1e-3)).exp()
                    };
                    self.base_c + (temp_c - self.base_c) * g
                }
                HeatSource::Gradient {
                    from_mm,
                    to_mm,
                    hot_c,
                } => {
                    let (dx, dy) = (to_mm.0 - from_mm.0, to_mm.1 - from_mm.1);
                    let len2 = (dx * dx + dy * dy).max(1e-6);
                    let u =
                        (((p.0 - from_mm.0) * dx + (p.1 - from_mm.1) * dy) / len2).clamp(0.0, 1.0);
                    self.base_c + (hot_c - self.base_c) * u
                }
            };
            if (ts - self.base_c).abs() > (t - self.base_c).abs() {
                t = ts;
            }
        }
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spot_is_hot_inside_and_decays_outside() {
        let f = TempField {
            base_c: 25.0,
            sources: vec![HeatSource::Spot {
                center_mm: (10.0, 10.0),
                footprint: Footprint::Disc { r_mm: 3.0 },
                temp_c: 45.0,
                spread_mm: 2.0,
            }],
        };
        assert_eq!(f.at((10.0, 10.0)), 45.0);
        let near = f.at((15.0, 10.0));
        let far = f.at((25.0, 10.0));
        assert!(near < 45.0 && near > far && far > 25.0, "{near} {far}");
    }

    #[test]
    fn gradient_is_clamped_linear() {
        let f = TempField {
            base_c: 25.0,
            sources: vec![HeatSource::Gradient {
                from_mm: (0.0, 0.0),
                to_mm: (10.0, 0.0),
                hot_c: 45.0,
            }],
        };
        assert_eq!(f.at((-5.0, 3.0)), 25.0);
        assert_eq!(f.at((5.0, 3.0)), 35.0);
        assert_eq!(f.at((50.0, 0.0)), 45.0);
    }
}
