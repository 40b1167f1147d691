//! Light that does not move with the skin: an LED's reflection (glare) adds to the colour of
//! the same blocks in every frame, and there it reads as heat (or cold, by its tint) however
//! well the pigment is calibrated; near the sensor's full scale a little more exposure clips
//! it, and the reading goes anywhere. No colour invariant cancels added light, but the
//! reference shows where it falls: the reference is a skin at rest, one temperature
//! throughout, so a block that stands out from its surroundings there is lit, not heated.
//! A block stands out when either stripe population is brighter than its neighbours' (glare
//! adds light; the dark stripes show it first) or its reading departs from theirs. Such
//! blocks (a bright one with its neighbours, in the spot's fainter tail) are left
//! unmeasured in every frame (never silently hot), and their colours are kept out of their
//! neighbours' pooled black stripes.
//!
//! A block the reference could not read at all (the FTP did not trust its fringes there,
//! as under a bright spot) is left unmeasured too: a later frame whose exposure lets it be
//! read would read it through the same light.
//!
//! Standing out is judged against a local median (so vignetting or a smooth gradient of the
//! skin's temperature is not a spot) and against the reference's own spread (so a noisy,
//! pale unit does not lose blocks to its noise).

use crate::mask::dilate;

/// Blocks each side of a block in the window whose median it is compared with (a spot is
/// at most a few blocks across, so it never holds the window's majority).
pub const WINDOW_BLOCKS: usize = 4;

/// Smallest departure of a reading from the local median that marks a block, °C: the
/// tolerance of a temperature reading. (A departure in the reading alone, with no excess
/// light, is a single block's: the map's extremes already look past single blocks.)
pub const MIN_DEPARTURE_C: f32 = 1.0;

/// Smallest excess brightness over the local median that marks a block, as a natural log
/// (about 15 %): pigment mottle and noise stay below it.
pub const MIN_EXCESS_LN: f32 = 0.14;

/// Departures beyond this many robust standard deviations of the reference's own mark a
/// block.
pub const SPREADS: f32 = 4.0;

/// Fewest measured blocks in a window for its median to be trusted.
const MIN_WINDOW: usize = 9;

/// What the reference shows of each block of a `bw × bh` map.
#[derive(Debug, Clone, Copy, Default)]
pub struct BlockView {
    /// Reading, °C (NaN where unmeasured).
    pub t_c: f32,
    /// Mean linear brightness of the coloured and the black stripes, 0…1 (0 where unseen).
    pub brightness: [f32; 2],
    /// The reference could be read here.
    pub readable: bool,
}

/// The blocks of a `bw × bh` reference that static light misreads: those brighter than
/// their surroundings, grown by one block each way into the spot's fainter tail, those
/// whose reading departs from their surroundings', and those it could not read.
pub fn misread(view: &[BlockView], bw: usize, bh: usize) -> Vec<bool> {
    let mut lit = vec![false; view.len()];
    for p in 0..2 {
        let ln: Vec<f32> = view
            .iter()
            .map(|v| {
                let b = v.brightness[p];
                if v.readable && b > 0.0 {
                    b.ln()
                } else {
                    f32::NAN
                }
            })
            .collect();
        for (m, o) in lit
            .iter_mut()
            .zip(outliers(&ln, bw, bh, MIN_EXCESS_LN, false))
        {
            *m |= o;
        }
    }
    let t: Vec<f32> = view.iter().map(|v| v.t_c).collect();
    let misread = outliers(&t, bw, bh, MIN_DEPARTURE_C, true);
    dilate(&lit, bw, bh)
        .into_iter()
        .zip(misread)
        .zip(view)
        .map(|((l, m), v)| l || m || !v.readable)
        .collect()
}

/// The blocks whose value departs from their window's median by more than `min` and
/// [`SPREADS`] robust deviations (upwards only unless `both_ways`); NaN is unmeasured.
fn outliers(values: &[f32], bw: usize, bh: usize, min: f32, both_ways: bool) -> Vec<bool> {
    let departure = departures(values, bw, bh);
    let mut sizes: Vec<f32> = departure.iter().flatten().map(|d| d.abs()).collect();
    let Some(spread) = median(&mut sizes).map(|m| 1.4826 * m) else {
        return vec![false; values.len()];
    };
    let limit = min.max(SPREADS * spread);
    departure
        .iter()
        .map(|d| d.is_some_and(|d| d > limit || (both_ways && -d > limit)))
        .collect()
}

/// Each measured block's value minus the median of its window's measured blocks.
fn departures(map_c: &[f32], bw: usize, bh: usize) -> Vec<Option<f32>> {
    let mut near = Vec::with_capacity((2 * WINDOW_BLOCKS + 1).pow(2));
    (0..map_c.len().min(bw * bh))
        .map(|b| {
            let t = map_c[b];
            if t.is_nan() {
                return None;
            }
            let (x, y) = (b % bw, b / bw);
            near.clear();
            for j in y.saturating_sub(WINDOW_BLOCKS)..(y + WINDOW_BLOCKS + 1).min(bh) {
                for i in x.saturating_sub(WINDOW_BLOCKS)..(x + WINDOW_BLOCKS + 1).min(bw) {
                    match map_c.get(j * bw + i) {
                        Some(&v) if !v.is_nan() => near.push(v),
                        _ => {}
                    }
                }
            }
            if near.len() < MIN_WINDOW {
                return None;
            }
            median(&mut near).map(|m| t - m)
        })
        .collect()
}

/// The median of `v` (reordered; the upper middle when the count is even); `None` when
/// empty.
pub(super) fn median(v: &mut [f32]) -> Option<f32> {
    if v.is_empty() {
        return None;
    }
    let mid = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(mid, f32::total_cmp);
    Some(*m)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A uniform reference with reading noise, a smooth temperature gradient and
    /// vignetting; `spot` adds (x, y, °C, relative brightness of the black stripes).
    fn view(bw: usize, bh: usize, spot: &[(usize, usize, f32, f32)]) -> Vec<BlockView> {
        let mut rng = crate::test_rng::XorShift(0x9e37_79b9_7f4a_7c15);
        let mut v: Vec<BlockView> = (0..bw * bh)
            .map(|b| {
                let noise = (rng.next() % 1000) as f32 / 1000.0 - 0.5;
                let (x, y) = ((b % bw) as f32, (b / bw) as f32);
                let vignetting =
                    1.0 - 0.3 * ((x / bw as f32 - 0.5).powi(2) + (y / bh as f32 - 0.5).powi(2));
                BlockView {
                    t_c: 25.0 + 0.05 * x + 0.2 * noise,
                    brightness: [0.5 * vignetting, 0.08 * vignetting * (1.0 + 0.04 * noise)],
                    readable: true,
                }
            })
            .collect();
        for &(x, y, dt, lit) in spot {
            let b = &mut v[y * bw + x];
            b.t_c += dt;
            b.brightness[1] *= lit;
        }
        v
    }

    fn marked_at(m: &[bool], bw: usize) -> Vec<(usize, usize)> {
        (0..m.len())
            .filter(|&b| m[b])
            .map(|b| (b % bw, b / bw))
            .collect()
    }

    #[test]
    fn blocks_misread_are_marked_and_nothing_else() {
        let (bw, bh) = (30, 22);
        let spots = [(3, 1, 6.0, 1.0), (4, 1, 2.0, 1.0), (5, 1, 0.6, 1.0)];
        let m = misread(&view(bw, bh, &spots), bw, bh);
        assert_eq!(marked_at(&m, bw), [(3, 1), (4, 1)]);
    }

    #[test]
    fn a_bright_spot_that_reads_right_is_marked_too() {
        let (bw, bh) = (30, 22);
        let m = misread(&view(bw, bh, &[(20, 10, 0.0, 1.6)]), bw, bh);
        let want: Vec<(usize, usize)> = (9..=11)
            .flat_map(|y| (19..=21).map(move |x| (x, y)))
            .collect();
        let mut got = marked_at(&m, bw);
        got.sort_by_key(|&(x, y)| (y, x));
        assert_eq!(got, want);
    }

    #[test]
    fn gradients_vignetting_noise_and_shade_mark_nothing() {
        let (bw, bh) = (30, 22);
        assert!(marked_at(&misread(&view(bw, bh, &[]), bw, bh), bw).is_empty());
        let dim = misread(&view(bw, bh, &[(10, 10, 0.0, 0.6)]), bw, bh);
        assert!(marked_at(&dim, bw).is_empty());
    }

    #[test]
    fn cold_blocks_count_and_unreadable_ones_are_marked_alone() {
        let (bw, bh) = (20, 15);
        let mut v = view(bw, bh, &[(10, 7, -3.0, 1.0)]);
        v[0].t_c = f32::NAN;
        v[1] = BlockView {
            t_c: f32::NAN,
            readable: false,
            ..v[1]
        };
        let m = misread(&v, bw, bh);
        assert_eq!(marked_at(&m, bw), [(1, 0), (10, 7)]);
    }

    #[test]
    fn an_unmeasured_reference_marks_only_what_could_not_be_read() {
        let blank = |readable| BlockView {
            t_c: f32::NAN,
            brightness: [0.0; 2],
            readable,
        };
        assert_eq!(misread(&[blank(true); 12], 4, 3), vec![false; 12]);
        let v = [blank(true), blank(false), blank(true)];
        assert_eq!(misread(&v, 3, 1), [false, true, false]);
        assert!(misread(&[], 0, 0).is_empty());
    }
}
