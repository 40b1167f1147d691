//! A contact's far field, told apart from a shift of the whole frame.
//!
//! A skin on a thin layer returns to rest within a few millimetres of a contact, and the
//! background beyond it reads the frame's own shift. A thick or soft skin does not: as on a
//! half-space, its surface sinks as `1/r` around the contact (Boussinesq), over the whole
//! view. The mean of that background is then part of the press; registered on it, the
//! press reads shallow by it, and the view's far side, less sunk than the mean, stands
//! raised above the registration over a large area: the frame looks like a thermal
//! dipole, and the press would be dropped as one.
//!
//! The background's tiles are fitted with `o + b·f`, `f` the contact's field at a tile,
//! `e^(−r/λ)/r` at `r` tiles from the contact's centre, by least squares weighted by each
//! tile's reliable samples; `o` is the background's level far from the contact, the
//! frame's shift. The decay `λ` is chosen by the data among one to eight grating periods
//! (a layer's surface returns to rest over a few) and none (a half-space): of the decays
//! that fit about as well as the best, the one that moves the registration least. The fit
//! is taken only where it explains most of the background's spread ([`MIN_EXPLAINED`])
//! with `b` of the indentation's sign: a shift, a thermal field or a glare spot is no field
//! of the contact. It runs only on frames whose background stands raised over much of the
//! view ([`super::register`]), on a few hundred tiles, so in `f64` on both paths.

use super::{Grid, TILE_PX};
use crate::mask::dilate;
use crate::phase::GRID;

/// The share of the background's spread (weighted variance) the contact's field must
/// explain to be taken out of the registration: most of it.
const MIN_EXPLAINED: f64 = 0.6;
/// Fits leaving up to this multiple of the best fit's unexplained spread tie with it.
const UNEXPLAINED_TIE: f64 = 1.25;
/// The decays fitted, grating periods: a layer's surface returns to rest over a few of
/// them; a half-space's never does.
const DECAYS_PERIODS: [f64; 5] = [1.0, 2.0, 4.0, 8.0, f64::INFINITY];
/// Background tiles the fit needs.
const MIN_TILES: usize = 48;

/// A contact's far field as the background showed it.
#[derive(Debug)]
pub(super) struct FarField {
    /// The background's level far from the contact (the frame's shift), units of the phase
    /// it was fitted on.
    pub(super) level: i32,
    /// The field at each tile's centre above that level, units (row-major tiles).
    pub(super) per_tile: Vec<i32>,
}

impl FarField {
    /// `phi`, registered on the level, less the field at each sample's tile: what stands
    /// out of the far field (the contact itself).
    pub(super) fn residual(&self, phi: &[i32], grid: &Grid) -> Vec<i32> {
        phi.iter()
            .enumerate()
            .map(|(k, p)| p - self.per_tile[grid.tile_of(k)])
            .collect()
    }
}

/// The contact's far field in `phi` (the coarse phase as registered, `rel` its reliable
/// samples), where the view shows it sinking the background (`sign`: the indentation's
/// phase sign); `None` where it does not. `period_tiles`: the grating's period in tiles,
/// the decays' unit.
pub(super) fn far_field(
    phi: &[i32],
    rel: &[bool],
    grid: &Grid,
    sign: i32,
    period_tiles: f64,
) -> Option<FarField> {
    let tiles = Tiles::of(phi, rel, grid, sign);
    let contact = Contact::of(&tiles)?;
    let fitted: Vec<usize> = (0..tiles.sunk.len())
        .filter(|&t| !contact.near[t] && tiles.read[t])
        .collect();
    if fitted.len() < MIN_TILES {
        return None;
    }
    let distance = |t: usize| contact.distance(tiles.at(t));
    let fit = |decay: f64| {
        let points: Vec<(f64, f64, f64)> = fitted
            .iter()
            .map(|&t| (field(distance(t), decay), tiles.sunk[t], tiles.n[t]))
            .collect();
        weighted_line(&points).map(|line| (decay, line))
    };
    let fits: Vec<(f64, Line)> = DECAYS_PERIODS
        .iter()
        .filter_map(|&periods| fit(periods * period_tiles))
        .filter(|(_, line)| line.slope > 0.0)
        .collect();
    let best = fits.iter().map(|(_, l)| l.explained).fold(0.0, f64::max);
    let (decay, line) = fits
        .into_iter()
        .filter(|(_, l)| 1.0 - l.explained <= UNEXPLAINED_TIE * (1.0 - best))
        .min_by(|a, b| a.1.level.abs().total_cmp(&b.1.level.abs()))?;
    (line.explained >= MIN_EXPLAINED).then(|| FarField {
        level: sign * line.level.round() as i32,
        per_tile: (0..tiles.sunk.len())
            .map(|t| sign * (line.slope * field(distance(t), decay)).round() as i32)
            .collect(),
    })
}

/// The tiles' mean phase, signed so that indentation is positive, where at least half
/// their samples are reliable.
struct Tiles {
    tw: usize,
    th: usize,
    /// Mean signed phase, units (0 where not read).
    sunk: Vec<f64>,
    /// Reliable samples per tile.
    n: Vec<f64>,
    /// Whether at least half a tile's samples are reliable.
    read: Vec<bool>,
}

impl Tiles {
    fn of(phi: &[i32], rel: &[bool], grid: &Grid, sign: i32) -> Tiles {
        let (cw, ch) = grid.coarse;
        let (tw, th) = grid.tiles;
        let per = TILE_PX / GRID;
        let (mut sum, mut n) = (vec![0i64; tw * th], vec![0u32; tw * th]);
        for k in (0..cw * ch).filter(|&k| rel[k]) {
            let t = grid.tile_of(k);
            sum[t] += i64::from(phi[k]);
            n[t] += 1;
        }
        let half = (per * per / 2) as u32;
        let read: Vec<bool> = n.iter().map(|&n| n >= half).collect();
        let sunk = (0..tw * th)
            .map(|t| {
                if read[t] {
                    f64::from(sign) * sum[t] as f64 / f64::from(n[t])
                } else {
                    0.0
                }
            })
            .collect();
        Tiles {
            tw,
            th,
            sunk,
            n: n.into_iter().map(f64::from).collect(),
            read,
        }
    }

    /// Tile `t`'s place, tiles.
    fn at(&self, t: usize) -> (f64, f64) {
        ((t % self.tw) as f64, (t / self.tw) as f64)
    }
}

/// The contact: the tiles sunk by at least half the deepest tile's mean, their centre
/// (weighted by how much each is sunk), and the tiles within two of them (where a tile's
/// centre stands for its field poorly).
struct Contact {
    centre: (f64, f64),
    near: Vec<bool>,
}

impl Contact {
    fn of(tiles: &Tiles) -> Option<Contact> {
        let deepest = tiles.sunk.iter().copied().fold(0.0, f64::max);
        if deepest <= 0.0 {
            return None;
        }
        let core: Vec<bool> = tiles.sunk.iter().map(|&s| s >= 0.5 * deepest).collect();
        let (mut cx, mut cy, mut total) = (0.0, 0.0, 0.0);
        for t in (0..core.len()).filter(|&t| core[t]) {
            let ((x, y), w) = (tiles.at(t), tiles.sunk[t]);
            (cx, cy, total) = (cx + w * x, cy + w * y, total + w);
        }
        let (tw, th) = (tiles.tw, tiles.th);
        Some(Contact {
            centre: (cx / total, cy / total),
            near: dilate(&dilate(&core, tw, th), tw, th),
        })
    }

    /// Tiles from the centre to `(x, y)`, at least one.
    fn distance(&self, (x, y): (f64, f64)) -> f64 {
        (x - self.centre.0).hypot(y - self.centre.1).max(1.0)
    }
}

/// A contact's surface `distance` from it (tiles, at least one) on a layer whose surface
/// returns to rest over `decay` (tiles; infinite: a half-space), up to a factor.
fn field(distance: f64, decay: f64) -> f64 {
    (-distance / decay).exp() / distance
}

/// A weighted least-squares line.
#[derive(Debug, Clone, Copy)]
struct Line {
    /// Where it crosses zero field.
    level: f64,
    slope: f64,
    /// The share of the weighted variance it explains.
    explained: f64,
}

/// The weighted least-squares line through `(x, y, weight)`; `None` where `x` or `y` does
/// not vary.
fn weighted_line(points: &[(f64, f64, f64)]) -> Option<Line> {
    let w: f64 = points.iter().map(|p| p.2).sum();
    let mx = points.iter().map(|p| p.0 * p.2).sum::<f64>() / w;
    let my = points.iter().map(|p| p.1 * p.2).sum::<f64>() / w;
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for &(x, y, pw) in points {
        sxx += pw * (x - mx) * (x - mx);
        sxy += pw * (x - mx) * (y - my);
        syy += pw * (y - my) * (y - my);
    }
    if sxx <= 0.0 || syy <= 0.0 {
        return None;
    }
    let slope = sxy / sxx;
    Some(Line {
        level: my - slope * mx,
        slope,
        explained: sxy * sxy / (sxx * syy),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A coarse phase map: `shift` everywhere, a little noise, and a press of `peak` units
    /// at `centre` (coarse samples) whose surround sinks as `far·peak·a/r` beyond its
    /// radius `a`.
    fn press(g: &Grid, centre: (f64, f64), peak: f64, far: f64, shift: i32) -> Vec<i32> {
        let (cw, ch) = g.coarse;
        let a = 6.0;
        (0..cw * ch)
            .map(|k| {
                let r = ((k % cw) as f64 - centre.0).hypot((k / cw) as f64 - centre.1);
                let w = if r < a {
                    peak * (1.0 - 0.5 * (r / a).powi(2))
                } else {
                    far * peak * a / r
                };
                let noise = (k * 7919 % 61) as i32 - 30;
                shift + w.round() as i32 + noise
            })
            .collect()
    }

    /// Tiles holding a sample that stands out of `phi` by more than `thr`.
    fn tiles_above(phi: &[i32], g: &Grid, thr: i32) -> Vec<usize> {
        let mut on: Vec<usize> = (0..phi.len())
            .filter(|&k| phi[k].abs() > thr)
            .map(|k| g.tile_of(k))
            .collect();
        on.sort_unstable();
        on.dedup();
        on
    }

    /// A half-space's press over a shifted frame: the level beyond the far field is the
    /// shift, where the background's mean lies far from it; what stands out of the field
    /// is the contact and its nearest tiles, not the whole view.
    #[test]
    fn a_half_space_far_field_is_told_from_the_frames_shift() {
        let g = Grid::of((320, 240));
        let shift = -700;
        let phi = press(&g, (50.0, 40.0), 20_000.0, 0.5, shift);
        let rel = vec![true; phi.len()];
        let f = far_field(&phi, &rel, &g, 1, 2.0).expect("a far field");
        assert!((f.level - shift).abs() < 60, "{}", f.level);
        let mean = phi.iter().map(|&p| i64::from(p)).sum::<i64>() / phi.len() as i64;
        assert!((mean - i64::from(shift)).abs() > 500, "{mean}");
        let registered: Vec<i32> = phi.iter().map(|p| p - f.level).collect();
        let thr = 300;
        assert!(tiles_above(&registered, &g, thr).len() > 1000);
        // The press is 6 samples (1.5 tiles) in radius, at tile (12.5, 10).
        for t in tiles_above(&f.residual(&registered, &g), &g, thr) {
            let (x, y) = ((t % g.tiles.0) as f64, (t / g.tiles.0) as f64);
            assert!(
                (x - 12.5).hypot(y - 10.0) < 6.0,
                "tile ({x}, {y}) stands out"
            );
        }
    }

    /// A thin layer's press (no far field) and a raised spot with a far field of the other
    /// sign give none.
    #[test]
    fn without_a_far_field_of_the_indentations_sign_there_is_none() {
        let g = Grid::of((320, 240));
        let phi = press(&g, (50.0, 40.0), 20_000.0, 0.0, 300);
        let rel = vec![true; phi.len()];
        assert!(far_field(&phi, &rel, &g, 1, 2.0).is_none());
        let raised = press(&g, (50.0, 40.0), -20_000.0, 0.5, 0);
        assert!(far_field(&raised, &rel, &g, 1, 2.0).is_none());
        // Read with the other indentation sign, the raised spot is a press.
        assert!(far_field(&raised, &rel, &g, -1, 2.0).is_some());
    }
}
