//! The reciprocal load: a contact's force up to the skin's modulus, from its depth map alone,
//! for any indenter.
//!
//! Betti's reciprocal theorem on an elastic half-space, between the unknown contact (pressure
//! `p`, surface displacement `u`) and a rigid flat punch of footprint `D` pressed a unit
//! depth (pressure `q`, displacement 1 everywhere on `D`): when `p` vanishes outside `D`,
//! `∫ p·1 dA = ∫_D q·u dA`, so `F = E*·L` with
//!
//! `L = ∫_D (q/E*)·u dA`, mm²,
//!
//! whatever the indenter's shape: sphere, flat punch, letter. The calibration on the sphere
//! only has to find `E*`. For a disc of radius `b`, `q/E* = 1/(π·√(b² − r²))`, and a flat
//! punch of radius `a = b` reads `2·a·d`, Boussinesq's `F = 2·E*·a·d`.
//!
//! **Which punch.** `D` must enclose the contact's pressure, and the less ground around the
//! contact it covers the better: a real skin is a finite layer whose surface returns to
//! rest faster than a half-space's, so wherever `D` reaches beyond the contact the map lies
//! below what the theorem weighs, and the force reads short. `D` is the contact's own
//! half-depth region (the peak's component deeper than half the peak): a sphere's contact
//! disc (Hertz's depth is half its peak at the contact radius), `√2` times a flat punch's
//! radius, a letter's strokes with the narrow gaps between them that the blur fills, but
//! not the open ground beside them that a disc enclosing the letter would cover and read
//! short (`docs/pipeline.md` measures both punches). Its pressure `q` has no closed form
//! for a footprint of any shape and is solved on cells ([`footprint_load_mm2`]); for a
//! round contact the reading is the disc's. The solve is a Cholesky factorisation written
//! here rather than taken from a linear-algebra crate: the device path solves one small
//! dense system per contact and needs nothing else of one.
//!
//! The map's rings about the contact's centre ([`rings`]) serve the profile's shape fit
//! ([`super::profile`]), out to a multiple of the radius enclosing the half-depth region
//! ([`enclosing_radius_px`]).

/// Cells the contact's own punch is solved on, at most (about): the cell side grows with
/// the contact so that the solve stays a small dense one whatever the contact's size, and
/// the map, blurred over a kernel wider than such a cell, changes little within one.
pub const MOST_CELLS: usize = 64;

/// The reciprocal load, mm², of a map `depth_um` (µm, `w` pixels wide) against a rigid punch
/// of the contact's own footprint (`contact`, the half-depth component's pixels), working
/// pixels `px_mm` wide. 0 without a contact.
///
/// The punch's pressure `q` (unit depth, unit modulus) is solved on square cells over the
/// footprint (`K·q = 1`, `K` the half-space's `1/(π·r)` influence between cell centres,
/// `4·s·ln(1 + √2)/π` of a cell of side `s` on itself) by Cholesky: the matrix is symmetric
/// positive definite and small ([`MOST_CELLS`]). A cell belongs to the footprint when most
/// of it is contact (the cells holding the most contact pixels when none is), and it reads
/// the map's mean over it; `L = Σ q·ū·s²`. For a round contact it is the disc's reading;
/// for a flat elliptical punch (semi-axes `a ≥ b`) it is `π·a·d/K(e)`, `K` the complete
/// elliptic integral of the first kind.
pub fn footprint_load_mm2(depth_um: &[i32], w: usize, contact: &[usize], px_mm: f32) -> f32 {
    load_on_cells(depth_um, w, contact, px_mm, MOST_CELLS)
}

/// [`footprint_load_mm2`] on about `most_cells` cells.
fn load_on_cells(
    depth_um: &[i32],
    w: usize,
    contact: &[usize],
    px_mm: f32,
    most_cells: usize,
) -> f32 {
    let cells = Cells::of(depth_um, w, contact, most_cells);
    if cells.centres.is_empty() {
        return 0.0;
    }
    let s_mm = f64::from(px_mm) * cells.side as f64;
    let Some(q) = unit_punch_pressure(&cells.centres, s_mm) else {
        return 0.0;
    };
    let load_um_mm: f64 = q.iter().zip(&cells.mean_um).map(|(q, u)| q * u).sum();
    (load_um_mm * s_mm * s_mm / 1000.0) as f32
}

/// The footprint's cells: their centres (in cells) and the map's mean over each.
struct Cells {
    /// Cell side, pixels.
    side: usize,
    /// Centres of the cells in the footprint, in cell units.
    centres: Vec<(f64, f64)>,
    /// The map's mean over each of them, µm.
    mean_um: Vec<f64>,
}

impl Cells {
    /// The cells of `contact` on a map `w` wide, about `most_cells` of them: the side starts
    /// where the contact's pixels fill that many and grows while a contact thinner than its
    /// cells (no cell mostly contact) leaves more than twice as many.
    fn of(depth_um: &[i32], w: usize, contact: &[usize], most_cells: usize) -> Cells {
        let h = depth_um.len() / w.max(1);
        let inside: Vec<usize> = contact.iter().copied().filter(|&i| i < w * h).collect();
        let most_cells = most_cells.max(1);
        let mut side = (inside.len() as f64 / most_cells as f64)
            .sqrt()
            .ceil()
            .max(1.0) as usize;
        loop {
            let cells = Self::of_side(depth_um, (w, h), &inside, side);
            if cells.centres.len() <= 2 * most_cells {
                return cells;
            }
            side += side.div_ceil(2);
        }
    }

    /// The cells of side `side` px over the contact pixels `inside` of a `w × h` map.
    fn of_side(depth_um: &[i32], (w, h): (usize, usize), inside: &[usize], side: usize) -> Cells {
        let mut cells = Cells {
            side,
            centres: Vec::new(),
            mean_um: Vec::new(),
        };
        let (xs, ys) = (inside.iter().map(|&i| i % w), inside.iter().map(|&i| i / w));
        let (Some(x0), Some(x1), Some(y0), Some(y1)) =
            (xs.clone().min(), xs.max(), ys.clone().min(), ys.max())
        else {
            return cells;
        };
        let (nx, ny) = ((x1 - x0) / side + 1, (y1 - y0) / side + 1);
        let mut hits = vec![0usize; nx * ny];
        for &i in inside {
            hits[(i / w - y0) / side * nx + (i % w - x0) / side] += 1;
        }
        let most = hits.iter().copied().max().unwrap_or(0);
        for (k, &n) in hits.iter().enumerate() {
            if n == 0 || (2 * n < side * side && n < most) {
                continue;
            }
            let (cx, cy) = (k % nx, k / nx);
            let (xa, ya) = (x0 + cx * side, y0 + cy * side);
            let (xb, yb) = ((xa + side).min(w), (ya + side).min(h));
            let sum: i64 = (ya..yb)
                .flat_map(|y| depth_um[y * w + xa..y * w + xb].iter())
                .map(|&v| i64::from(v))
                .sum();
            let count = ((xb - xa) * (yb - ya)).max(1);
            cells.centres.push((cx as f64, cy as f64));
            cells.mean_um.push(sum as f64 / count as f64);
        }
        cells
    }
}

/// The pressure, per cell (1/mm), that sinks cells of side `s_mm` centred at `centres`
/// (cell units) by a unit depth on a half-space of unit modulus. `None` if the system is
/// not positive definite, which the half-space's influence between distinct cells is.
fn unit_punch_pressure(centres: &[(f64, f64)], s_mm: f64) -> Option<Vec<f64>> {
    use std::f64::consts::{PI, SQRT_2};
    let n = centres.len();
    let own = 4.0 * s_mm * (1.0 + SQRT_2).ln() / PI;
    let mut k = vec![0.0f64; n * n];
    for (i, a) in centres.iter().enumerate() {
        for (j, b) in centres.iter().enumerate().take(i) {
            let (dx, dy) = (a.0 - b.0, a.1 - b.1);
            k[i * n + j] = s_mm / (PI * (dx * dx + dy * dy).sqrt());
        }
        k[i * n + i] = own;
    }
    cholesky_solve(&mut k, n, vec![1.0; n])
}

/// Solves `A·x = b` for a symmetric positive definite `A` (`n × n`, row-major, its lower
/// triangle given; overwritten by its Cholesky factor). `None` if `A` is not.
fn cholesky_solve(a: &mut [f64], n: usize, mut b: Vec<f64>) -> Option<Vec<f64>> {
    let dot = |x: &[f64], y: &[f64]| -> f64 { x.iter().zip(y).map(|(x, y)| x * y).sum() };
    for i in 0..n {
        let (done, row) = a.split_at_mut(i * n);
        let row = &mut row[..n];
        for j in 0..i {
            let above = &done[j * n..j * n + j + 1];
            row[j] = (row[j] - dot(&row[..j], &above[..j])) / above[j];
        }
        let v = row[i] - dot(&row[..i], &row[..i]);
        if v <= 0.0 || !v.is_finite() {
            return None;
        }
        row[i] = v.sqrt();
    }
    for i in 0..n {
        let row = &a[i * n..i * n + i + 1];
        b[i] = (b[i] - dot(&row[..i], &b[..i])) / row[i];
    }
    for i in (0..n).rev() {
        let tail: f64 = (i + 1..n).map(|k| a[k * n + i] * b[k]).sum();
        b[i] = (b[i] - tail) / a[i * n + i];
    }
    Some(b)
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

    /// The deepest pixel's half-depth component of `z` (`w` wide).
    fn component(z: &[i32], w: usize) -> Vec<usize> {
        let at = (0..z.len()).max_by_key(|&i| z[i]).unwrap_or(0);
        peak_component(z, w, at, 0)
    }

    /// The footprint load of map `z` (`w` wide) over its half-depth component.
    fn footprint_of(z: &[i32], w: usize, px_mm: f32) -> f32 {
        footprint_load_mm2(z, w, &component(z, w), px_mm)
    }

    /// A map of `f(r)` (µm, r in px from the centre) on a `w × w` window.
    fn radial(w: usize, f: impl Fn(f32) -> f32) -> Vec<i32> {
        let c = w as f32 / 2.0;
        (0..w * w)
            .map(|i| {
                let (x, y) = ((i % w) as f32 + 0.5 - c, (i / w) as f32 + 0.5 - c);
                f(x.hypot(y)).round() as i32
            })
            .collect()
    }

    /// A flat punch of radius `a` pressed `d` deep: Boussinesq's displacement, `d` inside
    /// and `(2d/π)·asin(a/r)` outside; its reciprocal load is `2·a·d` (`F = 2·E*·a·d`).
    #[test]
    fn a_flat_punch_reads_boussinesq() {
        let (a, d) = (20.0f32, 500.0f32);
        let z = radial(161, |r| {
            if r <= a {
                d
            } else {
                2.0 * d / std::f32::consts::PI * (a / r).asin()
            }
        });
        let got = footprint_of(&z, 161, 0.1);
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
        let z = radial(201, |r| {
            let w = if r <= a {
                d_px - r * r / (2.0 * r_px)
            } else {
                let s = a / r;
                d_px / std::f32::consts::PI
                    * ((2.0 - r * r / (a * a)) * s.asin() + (r * r / (a * a) - 1.0).sqrt())
            };
            w * um_per_px
        });
        let got = footprint_of(&z, 201, 0.1);
        let want = 4.0 / 3.0 * (a * 0.1) * (d_px * 0.1);
        assert!((got - want).abs() < 0.03 * want, "{got} vs {want}");
    }

    /// A second blob as deep as the press, away from it, is not the press's: the footprint
    /// stays the press's own.
    #[test]
    fn another_blob_does_not_enter_the_footprint() {
        let (a, d) = (10.0f32, 400.0f32);
        let mut z = radial(121, |r| if r <= a { d } else { 0.0 });
        let alone = footprint_of(&z, 121, 0.1);
        for y in 2..6 {
            for x in 2..6 {
                z[y * 121 + x] = 390;
            }
        }
        assert_eq!(alone, footprint_of(&z, 121, 0.1));
    }

    /// A map of an elliptical footprint (semi-axes `a ≥ b` px on a `w × w` window) pressed
    /// `d` µm deep, its surround at rest (a layer that cut it).
    fn ellipse(w: usize, (a, b): (f32, f32), d: f32) -> Vec<i32> {
        let c = w as f32 / 2.0;
        (0..w * w)
            .map(|i| {
                let (x, y) = ((i % w) as f32 + 0.5 - c, (i / w) as f32 + 0.5 - c);
                let inside = (x / a).powi(2) + (y / b).powi(2) <= 1.0;
                if inside {
                    d.round() as i32
                } else {
                    0
                }
            })
            .collect()
    }

    /// A flat elliptical punch (semi-axes `a ≥ b`) pressed `d` deep, its map `d` on the
    /// footprint and nothing around it: solved on fine cells, its load is Boussinesq's
    /// `π·a·d/K(e)`, where a punch on the disc enclosing it reads short by all the ground
    /// beside the ellipse that the disc covers.
    #[test]
    fn an_elliptical_punch_reads_its_own_footprint() {
        let (a, b, d, w) = (36.0f32, 12.0f32, 500.0, 101usize);
        let z = ellipse(w, (a, b), d);
        let px_mm = 0.1;
        // K(e) for e² = 1 − (b/a)², by the arithmetic-geometric mean.
        let (mut p, mut g) = (1.0f64, f64::from(b / a));
        for _ in 0..10 {
            (p, g) = ((p + g) / 2.0, (p * g).sqrt());
        }
        let k = std::f64::consts::PI / (2.0 * p);
        let want = std::f64::consts::PI * f64::from(a * px_mm) * f64::from(d) / 1000.0 / k;
        let contact = component(&z, w);
        let got = f64::from(load_on_cells(&z, w, &contact, px_mm, contact.len()));
        assert!((got - want).abs() < 0.03 * want, "{got} vs {want}");
        let c = w as f32 / 2.0;
        let r = enclosing_radius_px(&contact, w, (c, c));
        let disc: Vec<usize> = (0..w * w)
            .filter(|&i| ((i % w) as f32 + 0.5 - c).hypot((i / w) as f32 + 0.5 - c) <= r)
            .collect();
        let disc_reads = f64::from(load_on_cells(&z, w, &disc, px_mm, 600));
        assert!(
            disc_reads < 0.8 * want,
            "the disc reads {disc_reads} of {want}"
        );
    }

    /// On a map blurred as the demodulator blurs it (its triangle of a few pixels,
    /// [`super::super::apex::blur`]), the footprint's few cells read what fine cells read:
    /// the map changes little within one.
    #[test]
    fn few_cells_read_a_blurred_map_as_fine_cells_do() {
        let w = 121;
        for (axes, l) in [((36.0, 12.0), 7), ((20.0, 20.0), 7), ((40.0, 6.0), 5)] {
            let z = super::super::apex::blur(&ellipse(w, axes, 500.0), w, (l, l));
            let contact = component(&z, w);
            let fine = load_on_cells(&z, w, &contact, 0.1, contact.len());
            let few = footprint_of(&z, w, 0.1);
            assert!(
                (few - fine).abs() < 0.02 * fine,
                "{axes:?}: {few} vs {fine}"
            );
        }
    }

    /// Cholesky on a small positive definite system, and a matrix that is not one.
    #[test]
    fn cholesky_solves_and_refuses() {
        let mut a = vec![4.0, 0.0, 0.0, 2.0, 3.0, 0.0, 0.0, 1.0, 2.0];
        let x = cholesky_solve(&mut a, 3, vec![2.0, 1.0, 3.0]).expect("positive definite");
        // A·x with A = [[4,2,0],[2,3,1],[0,1,2]].
        let back = [
            4.0 * x[0] + 2.0 * x[1],
            2.0 * x[0] + 3.0 * x[1] + x[2],
            x[1] + 2.0 * x[2],
        ];
        for (got, want) in back.iter().zip([2.0, 1.0, 3.0]) {
            assert!((got - want).abs() < 1e-12, "{back:?}");
        }
        let mut not = vec![1.0, 0.0, 2.0, 1.0];
        assert!(cholesky_solve(&mut not, 2, vec![1.0, 1.0]).is_none());
    }

    #[test]
    fn no_depth_is_no_load() {
        assert_eq!(footprint_load_mm2(&[0; 100], 10, &[], 0.1), 0.0);
        assert_eq!(footprint_load_mm2(&[], 10, &[3], 0.1), 0.0);
        assert_eq!(footprint_load_mm2(&[], 10, &[], 0.1), 0.0);
        assert_eq!(enclosing_radius_px(&[], 10, (5.0, 5.0)), 0.0);
    }
}
