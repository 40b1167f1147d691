//! The coldest and hottest places of a temperature map, read where the neighbours confirm
//! them. A block is one stripe pair (about 2 mm) and its reading carries that little area's
//! noise; the most extreme of several hundred such readings is mostly the noisiest one, so
//! the skin's extremes taken block by block sit well outside its true range even on a
//! uniform skin. Each block is therefore read as the median of its 3 × 3 neighbourhood
//! (when at least five of them are measured) before the extremes are taken: a single stray
//! block cannot be the hottest point, while a warm object, which spreads its heat over
//! several blocks, still is. A contact's own temperature is read over the contact region
//! itself, not here.

/// Fewest measured blocks of a 3 × 3 neighbourhood for its median to stand for the block.
pub const MIN_NEIGHBOURS: usize = 5;

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
    let mut near = [0f32; 9];
    for b in 0..map_c.len().min(bw * bh) {
        if map_c[b].is_nan() {
            continue;
        }
        let (x, y) = (b % bw, b / bw);
        let mut n = 0;
        for j in y.saturating_sub(1)..(y + 2).min(bh) {
            for i in x.saturating_sub(1)..(x + 2).min(bw) {
                if let Some(&v) = map_c.get(j * bw + i).filter(|v| !v.is_nan()) {
                    near[n] = v;
                    n += 1;
                }
            }
        }
        if n < MIN_NEIGHBOURS {
            continue;
        }
        let (_, &mut t, _) = near[..n].select_nth_unstable_by(n / 2, f32::total_cmp);
        e.min_c = e.min_c.min(t);
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
        let (bw, bh) = (10, 8);
        let mut m = vec![25.0f32; bw * bh];
        m[3 * bw + 2] = 60.0;
        for (x, y) in [(6, 4), (7, 4), (6, 5), (7, 5), (8, 5)] {
            m[y * bw + x] = 31.0;
        }
        m[5 * bw + 7] = 32.0;
        let e = extremes(&m, bw, bh);
        assert_eq!(e.max_c, 31.0);
        assert_eq!(e.min_c, 25.0);
        let h = e.hottest.expect("a hottest block");
        assert!(
            (6..=8).contains(&(h % bw)) && (4..=5).contains(&(h / bw)),
            "{h}"
        );
    }

    #[test]
    fn unmeasured_blocks_neither_count_nor_confirm() {
        let (bw, bh) = (3, 3);
        let mut m = vec![f32::NAN; 9];
        for b in [0, 1, 3, 4] {
            m[b] = 20.0 + b as f32;
        }
        let e = extremes(&m, bw, bh);
        assert_eq!(
            (e.min_c, e.max_c, e.hottest),
            (f32::INFINITY, f32::NEG_INFINITY, None)
        );
        m[2] = 30.0;
        assert_eq!(extremes(&m, bw, bh).max_c, 23.0);
    }
}
