//! The coldest and hottest places of a temperature map, read where the neighbours confirm
//! them. A block is one stripe pair (about 2 mm) and its reading carries that little area's
//! noise; the most extreme of several hundred such readings is mostly the noisiest one, so
//! the skin's extremes taken block by block sit well outside its true range even on a
//! uniform skin. Each block is therefore read as the median of its 5 × 5 neighbourhood
//! (when more than half of it is measured) before the extremes are taken.
//!
//! The neighbourhood is that wide because neighbouring blocks are not independent: the
//! black stripes are read over 3 × 3 blocks and shared by each 2 × 2 (`evaluate`), and
//! outside the pigment's transition they carry most of a reading, so a 3 × 3 neighbourhood
//! holds only a few independent readings and one misread cell (a dim corner, glare) fills
//! half of it. In 5 × 5 blocks no single cell is a majority. A hottest place is the lower
//! of the two middle values when the count is even (the coldest the upper), so a tie
//! between a misread cell and the skin goes to the skin. A warm object still is the hottest
//! place when it covers most of a neighbourhood (about 7 × 7 mm); a contact's own
//! temperature is read over the contact region itself, not here.

/// Blocks from a block to the edge of its neighbourhood (5 × 5 blocks).
pub const REACH: usize = 2;
/// Fewest measured blocks of a neighbourhood for its median to stand for the block: more
/// than half of it.
pub const MIN_NEIGHBOURS: usize = 13;

/// A map's extremes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Extremes {
    /// Coldest and hottest neighbourhood median, °C (±∞ when none).
    pub min_c: f32,
    /// See `min_c`.
    pub max_c: f32,
    /// The block whose neighbourhood is hottest.
    pub hottest: Option<usize>,
}

/// The extremes of a `bw × bh` map (°C, NaN where unmeasured).
pub fn extremes(map_c: &[f32], bw: usize, bh: usize) -> Extremes {
    let mut e = Extremes {
        min_c: f32::INFINITY,
        max_c: f32::NEG_INFINITY,
        hottest: None,
    };
    let mut near = [0f32; (2 * REACH + 1) * (2 * REACH + 1)];
    for b in 0..map_c.len().min(bw * bh) {
        if map_c[b].is_nan() {
            continue;
        }
        let (x, y) = (b % bw, b / bw);
        let mut n = 0;
        for j in y.saturating_sub(REACH)..(y + REACH + 1).min(bh) {
            for i in x.saturating_sub(REACH)..(x + REACH + 1).min(bw) {
                if let Some(&v) = map_c.get(j * bw + i).filter(|v| !v.is_nan()) {
                    near[n] = v;
                    n += 1;
                }
            }
        }
        if n < MIN_NEIGHBOURS {
            continue;
        }
        let (_, &mut t, above) = near[..n].select_nth_unstable_by((n - 1) / 2, f32::total_cmp);
        let upper = if n % 2 == 0 {
            above.iter().copied().fold(f32::INFINITY, f32::min)
        } else {
            t
        };
        e.min_c = e.min_c.min(upper);
        if t > e.max_c {
            e.max_c = t;
            e.hottest = Some(b);
        }
    }
    e
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stray_block_is_not_the_hottest_but_a_warm_patch_is() {
        let (bw, bh) = (14, 12);
        let mut m = vec![25.0f32; bw * bh];
        m[3 * bw + 2] = 60.0;
        for y in 5..9 {
            for x in 8..12 {
                m[y * bw + x] = 31.0;
            }
        }
        m[6 * bw + 9] = 32.0;
        let e = extremes(&m, bw, bh);
        assert_eq!(e.max_c, 31.0);
        assert_eq!(e.min_c, 25.0);
        let h = e.hottest.expect("a hottest block");
        assert!(
            (8..12).contains(&(h % bw)) && (5..9).contains(&(h / bw)),
            "{h}"
        );
    }

    /// A misread 2 × 2 cell (the blocks that share one black-stripe estimate) at the edge
    /// of the measured skin, where a 3 × 3 neighbourhood holds little else, is not the
    /// hottest place; nor is a cold one the coldest.
    #[test]
    fn a_misread_cell_at_the_edge_is_not_an_extreme() {
        let (bw, bh) = (12, 10);
        let mut m = vec![38.0f32; bw * bh];
        m[..bw].fill(f32::NAN);
        for (x, y) in [(2, 1), (3, 1), (2, 2), (3, 2)] {
            m[y * bw + x] = 43.5;
        }
        for (x, y) in [(8, 8), (9, 8), (8, 9), (9, 9)] {
            m[y * bw + x] = 30.0;
        }
        let e = extremes(&m, bw, bh);
        assert_eq!((e.min_c, e.max_c), (38.0, 38.0));
    }

    #[test]
    fn unmeasured_blocks_neither_count_nor_confirm() {
        let (bw, bh) = (5, 5);
        let mut m = vec![f32::NAN; 25];
        for (b, v) in m.iter_mut().take(12).enumerate() {
            *v = 20.0 + b as f32;
        }
        let e = extremes(&m, bw, bh);
        assert_eq!(
            (e.min_c, e.max_c, e.hottest),
            (f32::INFINITY, f32::NEG_INFINITY, None)
        );
        m[12] = 40.0;
        // The middle column's neighbourhoods hold all 13: 20…31 and 40, whose middle is 26.
        let e = extremes(&m, bw, bh);
        assert_eq!((e.min_c, e.max_c), (26.0, 26.0));
        assert_eq!(e.hottest.map(|b| b % bw), Some(2));
    }
}
