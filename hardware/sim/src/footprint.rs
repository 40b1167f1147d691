//! Flat footprints on the skin as signed distances: discs, letters drawn from rectangles,
//! a hex nut. Shared by the contact mechanics (where a punch presses) and the temperature
//! fields (where a heated object touches).

use std::f32::consts::PI;

/// A 2-D point on the skin, mm.
pub type Mm = (f32, f32);

/// Footprint of a flat punch, as a signed distance (mm, negative inside).
#[derive(Debug, Clone, PartialEq)]
pub enum Footprint {
    /// A disc of radius `r_mm`.
    Disc {
        /// Radius, mm.
        r_mm: f32,
    },
    /// Union of axis-aligned rectangles (x0, y0, x1, y1) in mm, relative to the centre.
    Rects(Vec<[f32; 4]>),
    /// A hexagon with across-flats `af_mm` and a round hole of diameter `hole_mm`.
    HexNut {
        /// Width across flats, mm.
        af_mm: f32,
        /// Hole diameter, mm.
        hole_mm: f32,
    },
}

fn sd_rect(p: Mm, r: &[f32; 4]) -> f32 {
    let (cx, cy) = ((r[0] + r[2]) / 2.0, (r[1] + r[3]) / 2.0);
    let (hx, hy) = ((r[2] - r[0]) / 2.0, (r[3] - r[1]) / 2.0);
    let (dx, dy) = ((p.0 - cx).abs() - hx, (p.1 - cy).abs() - hy);
    let outside = (dx.max(0.0).powi(2) + dy.max(0.0).powi(2)).sqrt();
    outside + dx.max(dy).min(0.0)
}

impl Footprint {
    /// A letter `h_mm` tall and `0.6·h` wide, with strokes `h/5` wide, drawn on the stem
    /// (left vertical bar) from the named strokes.
    fn letter(h_mm: f32, strokes: &[Stroke]) -> Footprint {
        let s = h_mm / 5.0;
        let (w, y0) = (h_mm * 0.6, -h_mm / 2.0);
        let (left, right) = (-w / 2.0, w / 2.0);
        let mut rects = vec![[left, y0, left + s, y0 + h_mm]];
        for stroke in strokes {
            rects.push(match stroke {
                Stroke::Top => [left, y0, right, y0 + s],
                Stroke::Middle => [left, -s / 2.0, right - s / 2.0, s / 2.0],
                Stroke::MiddleFull => [left, -s / 2.0, right, s / 2.0],
                Stroke::Bottom => [left, y0 + h_mm - s, right, y0 + h_mm],
                Stroke::UpperRight => [right - s, y0, right, s / 2.0],
            });
        }
        Footprint::Rects(rects)
    }

    /// Letter E, `h_mm` tall.
    pub fn letter_e(h_mm: f32) -> Footprint {
        Self::letter(h_mm, &[Stroke::Top, Stroke::Middle, Stroke::Bottom])
    }

    /// Letter F.
    pub fn letter_f(h_mm: f32) -> Footprint {
        Self::letter(h_mm, &[Stroke::Top, Stroke::Middle])
    }

    /// Letter P.
    pub fn letter_p(h_mm: f32) -> Footprint {
        Self::letter(h_mm, &[Stroke::Top, Stroke::MiddleFull, Stroke::UpperRight])
    }

    /// Signed distance from `p` (relative to the footprint's centre) to its edge, mm.
    pub fn signed_distance(&self, p: Mm) -> f32 {
        match self {
            Footprint::Disc { r_mm } => (p.0 * p.0 + p.1 * p.1).sqrt() - r_mm,
            Footprint::Rects(rs) => rs
                .iter()
                .map(|r| sd_rect(p, r))
                .fold(f32::INFINITY, f32::min),
            Footprint::HexNut { af_mm, hole_mm } => {
                // Regular hexagon with flats at top and bottom.
                let (x, y) = (p.0.abs(), p.1.abs());
                let k = (0.866_025_4f32, 0.5f32);
                let apo = af_mm / 2.0;
                let proj = k.0 * x + k.1 * y;
                let hex = proj.max(y) - apo;
                let hole = hole_mm / 2.0 - (p.0 * p.0 + p.1 * p.1).sqrt();
                hex.max(hole)
            }
        }
    }

    /// Half-width of a square around the centre that holds the whole footprint, mm.
    pub fn bound_mm(&self) -> f32 {
        match self {
            Footprint::Disc { r_mm } => *r_mm,
            Footprint::Rects(rs) => rs.iter().flatten().fold(0.0f32, |m, v| m.max(v.abs())),
            Footprint::HexNut { af_mm, .. } => af_mm / 3.0f32.sqrt(),
        }
    }

    /// Footprint area, mm² (exact for a disc, else counted on a 200 × 200 grid: within 1 %).
    pub fn area_mm2(&self) -> f32 {
        if let Footprint::Disc { r_mm } = self {
            return PI * r_mm * r_mm;
        }
        let b = self.bound_mm();
        let cells = 200i32;
        let step = 2.0 * b / cells as f32;
        let mut n = 0u32;
        for iy in 0..cells {
            for ix in 0..cells {
                let p = (-b + (ix as f32 + 0.5) * step, -b + (iy as f32 + 0.5) * step);
                if self.signed_distance(p) <= 0.0 {
                    n += 1;
                }
            }
        }
        n as f32 * step * step
    }
}

/// Strokes of the letter punches, besides the stem.
#[derive(Debug, Clone, Copy)]
enum Stroke {
    Top,
    Middle,
    MiddleFull,
    Bottom,
    UpperRight,
}
