//! The coldest and hottest places of a temperature map, read where the neighbours confirm
//! them and where they stand out from the noise. A block is one stripe pair (about 2 mm)
//! and its reading carries that little area's noise; the most extreme of several hundred
//! such readings is mostly the noisiest one, so the skin's extremes taken block by block
//! sit well outside its true range even on a uniform skin. Each block is therefore read as
//! what more than half of its 5 × 5 neighbourhood reads before the extremes are taken
//! (`ranks`): a place is as warm as its [`MIN_NEIGHBOURS`]-th warmest block and as cold
//! as its [`MIN_NEIGHBOURS`]-th coldest.
//!
//! The neighbourhood is that wide because neighbouring blocks are not independent: the
//! black stripes are read over 3 × 3 blocks and shared by each 2 × 2 (`evaluate`), and
//! outside the pigment's transition they carry most of a reading, so a 3 × 3 neighbourhood
//! holds only a few independent readings and one misread cell (a dim corner, glare) fills
//! half of it. In 5 × 5 blocks no single cell is a majority. Where all 25 blocks are
//! measured a place reads the neighbourhood's median; of 24, the lower of the two middle
//! values for a hot place (the upper for a cold one), so a tie between a misread cell and
//! the skin goes to the skin. A warm object still is the hottest place when it covers most
//! of a neighbourhood (about 7 × 7 mm); a contact's own temperature is read over the
//! contact region itself, not here.
//!
//! The majority is of the whole neighbourhood, not of its measured blocks. Blocks go
//! unmeasured at the border of what the FTP trusts and where the reference showed glare
//! ([`super::static_light`]); beside such a gap a misread cell, or the lit ring around a
//! glare spot, would be most of what is left, and would pass for a warm object.
//!
//! **Standing out.** Where the pigments hardly change colour with temperature (above the
//! coloured stripes' transition the black stripes alone carry a reading, and their colour
//! moves by a fraction of a per cent per degree) a block's reading scatters by degrees,
//! and even the median of a neighbourhood scatters by about a degree: the most extreme of
//! a few hundred such medians would still sit degrees off on a uniform skin. So a
//! neighbourhood is a hot (cold) place only where its reading departs from the median of
//! the whole map (the skin) by more than [`STAND_OUT_SIGMAS`] of its own noise, read from
//! the calibration's variance of the block that gives the reading, as a median's
//! ([`median_sigma_c`]). Where none does, the skin has no hottest (coldest) place and its
//! median stands for both. The threshold follows the noise: inside the transition, where
//! a block reads to a few tenths of a degree or better, a place a degree warmer than the
//! skin stands out.
//!
//! The noise is the larger of the place's own and the skin's (the variance of the block
//! that reads the skin's median): a place at the skin's temperature scatters as the skin
//! does, whatever it reads. Above the transition, a misread neighbourhood of a warm skin
//! can land on the coloured stripes' slope, where a block's variance is small; judged by
//! that variance alone, a warm skin would show a coldest place degrees below it.
//!
//! [`STAND_OUT_SIGMAS`] is the least threshold, what independent noise needs. A uniform
//! skin's readings also wander together over many blocks with the light across the view,
//! which no block's variance holds; a calibration raises the threshold where its kit's own
//! uniform frames showed places departing further
//! ([`super::model::TemperatureModel::stand_out_sigmas`]).

/// Blocks from a block to the edge of its neighbourhood (5 × 5 blocks).
pub const REACH: usize = 2;
/// More than half of a neighbourhood's 25 blocks: the fewest it must have measured to
/// stand for its block, and how many of them must read as warm (cold) as a place.
pub const MIN_NEIGHBOURS: usize = 13;
const _: () = assert!((2 * REACH + 1) * (2 * REACH + 1) < 2 * MIN_NEIGHBOURS);
/// Standard deviations of its median by which a neighbourhood must depart from the skin's
/// median to be an extreme, at least: beyond what the largest of a few hundred medians of
/// independent noise reaches (a map holds a few hundred disjoint neighbourhoods).
pub const STAND_OUT_SIGMAS: f32 = 3.5;
/// Blocks that share one black-stripe estimate (2 × 2, `evaluate`): a neighbourhood of `n`
/// blocks holds about `n / 4` independent readings where the black stripes carry them.
pub const SHARING: f32 = 4.0;

/// A map's extremes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Extremes {
    /// Coldest and hottest place, °C: a neighbourhood median that stands out from the
    /// skin, or the skin's median where none does (±∞ when nothing was measured).
    pub min_c: f32,
    /// See `min_c`.
    pub max_c: f32,
    /// The block whose neighbourhood is hottest, when one stands out.
    pub hottest: Option<usize>,
    /// The skin: the map's median, °C (NaN when nothing was measured).
    pub skin_c: f32,
    /// The standard deviations by which a place had to depart from that skin to stand out
    /// ([`STAND_OUT_SIGMAS`] when nothing was measured): what a contact is held to too.
    pub stand_out_sigmas: f32,
}

/// Standard deviation of the median of `n` readings of variance `var_c2` each, °C, with
/// [`SHARING`] blocks to an independent reading (the median of `m` normal readings
/// scatters `√(π/2)` times as far as their mean); infinite when the variance is unknown.
pub fn median_sigma_c(var_c2: f32, n: usize) -> f32 {
    if var_c2.is_nan() {
        return f32::INFINITY;
    }
    let independent = (n as f32 / SHARING).max(1.0);
    var_c2.max(0.0).sqrt() * (std::f32::consts::FRAC_PI_2 / independent).sqrt()
}

/// Whether a reading `departure_c` °C from the skin's median, with standard deviation
/// `sigma_c`, stands out of its noise by more than `sigmas` of it (at least
/// [`STAND_OUT_SIGMAS`], more where the calibration's kit showed more,
/// [`super::model::TemperatureModel::stand_out_sigmas`]): a neighbourhood's median here, a
/// contact's own reading in [`super::Thermometer::measure`].
pub fn stands_out(departure_c: f32, sigma_c: f32, sigmas: f32) -> bool {
    departure_c > sigmas * sigma_c
}

/// The extremes of a `bw × bh` map (°C, NaN where unmeasured), each block's reading of
/// variance `var_c2` (°C², from the calibration's tables); `sigmas` says by how many
/// standard deviations a place must depart from a skin whose median reads `skin_c` to
/// stand out ([`stands_out`]).
pub fn extremes(
    map_c: &[f32],
    var_c2: &[f32],
    (bw, bh): (usize, usize),
    sigmas: impl Fn(f32) -> f32,
) -> Extremes {
    let mut e = Extremes {
        min_c: f32::INFINITY,
        max_c: f32::NEG_INFINITY,
        hottest: None,
        skin_c: f32::NAN,
        stand_out_sigmas: STAND_OUT_SIGMAS,
    };
    let Some(skin) = Skin::of(map_c, var_c2, bw * bh) else {
        return e;
    };
    e.skin_c = skin.c;
    e.stand_out_sigmas = sigmas(skin.c);
    let threshold = e.stand_out_sigmas;
    let confirmed = each_place(map_c, var_c2, (bw, bh), |b, p| {
        let (hot, cold) = (p.hot.0, p.cold.0);
        if hot > e.max_c && skin.departure_sigmas(hot - skin.c, p.hot.1, p.count) > threshold {
            e.max_c = hot;
            e.hottest = Some(b);
        }
        if cold < e.min_c && skin.departure_sigmas(skin.c - cold, p.cold.1, p.count) > threshold {
            e.min_c = cold;
        }
    });
    if !confirmed {
        return e;
    }
    if e.hottest.is_none() {
        e.max_c = skin.c;
    }
    if e.min_c == f32::INFINITY {
        e.min_c = skin.c;
    }
    e
}

/// How far the coldest and the hottest neighbourhood of a `bw × bh` map depart from its
/// skin, in standard deviations of a place at the skin's temperature (0 when none departs
/// that way; see [`extremes`]): on a uniform skin, what its places show of its noise, for
/// the calibration's threshold ([`super::model::TemperatureModel::stand_out`]).
pub fn departures_sigmas(map_c: &[f32], var_c2: &[f32], (bw, bh): (usize, usize)) -> [f32; 2] {
    let mut out = [0.0f32; 2];
    let Some(skin) = Skin::of(map_c, var_c2, bw * bh) else {
        return out;
    };
    each_place(map_c, var_c2, (bw, bh), |_, p| {
        out[0] = out[0].max(skin.departure_sigmas(skin.c - p.cold.0, p.cold.1, p.count));
        out[1] = out[1].max(skin.departure_sigmas(p.hot.0 - skin.c, p.hot.1, p.count));
    });
    out
}

/// The skin a map's places depart from.
struct Skin {
    /// The median of the measured blocks' readings, °C.
    c: f32,
    /// The variance of the block that reads it, °C² (0 when unknown): the variance of a
    /// reading at the skin's temperature.
    var_c2: f32,
}

impl Skin {
    /// The skin of the first `n` blocks of a map; `None` when none was measured.
    fn of(map_c: &[f32], var_c2: &[f32], n: usize) -> Option<Skin> {
        let mut measured: Vec<(f32, f32)> = (0..n.min(map_c.len()))
            .filter(|&b| !map_c[b].is_nan())
            .map(|b| (map_c[b], var_c2.get(b).copied().unwrap_or(f32::NAN)))
            .collect();
        if measured.is_empty() {
            return None;
        }
        let mid = measured.len() / 2;
        let (_, &mut (c, var), _) =
            measured.select_nth_unstable_by(mid, |a, b| a.0.total_cmp(&b.0));
        let var_c2 = if var.is_nan() { 0.0 } else { var };
        Some(Skin { c, var_c2 })
    }

    /// A departure `d` (°C) of a neighbourhood's middle of variance `var` (°C²), over its
    /// `count` blocks, in standard deviations of a place at the skin's temperature,
    /// whatever it reads (see the module documentation): the larger of its variance and
    /// the skin's.
    fn departure_sigmas(&self, d: f32, var: f32, count: usize) -> f32 {
        let var = if var.is_nan() {
            var
        } else {
            var.max(self.var_c2)
        };
        d / median_sigma_c(var, count)
    }
}

/// A neighbourhood's warm and cold readings ([`ranks`]), (reading, variance) each, and how
/// many measured blocks it holds.
struct Place {
    hot: (f32, f32),
    cold: (f32, f32),
    count: usize,
}

/// Calls `f(b, place)` for each measured block `b` of a `bw × bh` map whose neighbourhood
/// holds enough measured blocks ([`MIN_NEIGHBOURS`]) to stand for it; returns whether any
/// did.
fn each_place(
    map_c: &[f32],
    var_c2: &[f32],
    (bw, bh): (usize, usize),
    mut f: impl FnMut(usize, Place),
) -> bool {
    let mut near = [(0f32, 0f32); (2 * REACH + 1) * (2 * REACH + 1)];
    let mut confirmed = false;
    for b in 0..map_c.len().min(bw * bh) {
        if map_c[b].is_nan() {
            continue;
        }
        let count = neighbourhood(map_c, var_c2, (bw, bh), b, &mut near);
        if count < MIN_NEIGHBOURS {
            continue;
        }
        confirmed = true;
        let (hot, cold) = ranks(&mut near[..count]);
        f(b, Place { hot, cold, count });
    }
    confirmed
}

/// Fills `near` with the measured (reading, variance) pairs of block `b`'s neighbourhood
/// and returns how many there are.
fn neighbourhood(
    map_c: &[f32],
    var_c2: &[f32],
    (bw, bh): (usize, usize),
    b: usize,
    near: &mut [(f32, f32)],
) -> usize {
    let (x, y) = (b % bw, b / bw);
    let mut n = 0;
    for j in y.saturating_sub(REACH)..(y + REACH + 1).min(bh) {
        for i in x.saturating_sub(REACH)..(x + REACH + 1).min(bw) {
            let k = j * bw + i;
            if let Some(&v) = map_c.get(k).filter(|v| !v.is_nan()) {
                near[n] = (v, var_c2.get(k).copied().unwrap_or(f32::NAN));
                n += 1;
            }
        }
    }
    n
}

/// The [`MIN_NEIGHBOURS`]-th warmest and the [`MIN_NEIGHBOURS`]-th coldest of `near` by
/// reading, each with its variance: what more than half of a whole neighbourhood reads at
/// least (at most). Of 25 blocks both are the median; of 24, its lower and upper middle, so
/// a tie between a misread cell and the skin goes to the skin. `near` holds at least
/// [`MIN_NEIGHBOURS`] blocks (fewer give the nearest ranks it has).
fn ranks(near: &mut [(f32, f32)]) -> ((f32, f32), (f32, f32)) {
    let Some(last) = near.len().checked_sub(1) else {
        return ((f32::NAN, f32::NAN), (f32::NAN, f32::NAN));
    };
    let hot = (last + 1).saturating_sub(MIN_NEIGHBOURS);
    let cold = (MIN_NEIGHBOURS - 1).min(last);
    let by_reading = |a: &(f32, f32), b: &(f32, f32)| a.0.total_cmp(&b.0);
    // One selection places the hot rank. A neighbourhood holds fewer than twice
    // MIN_NEIGHBOURS blocks, so the cold rank is never below it: it is the hot block
    // itself, or among those the selection left above.
    let (_, &mut warm, above) = near.select_nth_unstable_by(hot, by_reading);
    let cool = match cold.saturating_sub(hot).checked_sub(1) {
        None => warm,
        Some(k) => *above.select_nth_unstable_by(k, by_reading).1,
    };
    (warm, cool)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Variance of every block in the tests below where the pigments resolve a tenth of a
    /// degree, °C².
    const FINE_C2: f32 = 0.01;

    /// The threshold of a calibration whose kit showed nothing beyond independent noise.
    fn standard(_skin_c: f32) -> f32 {
        STAND_OUT_SIGMAS
    }

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
        let e = extremes(&m, &vec![FINE_C2; bw * bh], (bw, bh), standard);
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
        let e = extremes(&m, &vec![FINE_C2; bw * bh], (bw, bh), standard);
        assert_eq!((e.min_c, e.max_c, e.hottest), (38.0, 38.0, None));
    }

    /// The ranks are those of the sorted readings for every count a neighbourhood can
    /// hold, each with its own variance.
    #[test]
    fn ranks_are_the_sorted_readings_at_the_majority() {
        let mut rng = crate::test_rng::XorShift(0x5851_f42d_4c95_7f2d);
        for n in MIN_NEIGHBOURS..=25 {
            let mut near: Vec<(f32, f32)> = (0..n)
                .map(|_| {
                    let v = (rng.next() % 1000) as f32 / 10.0;
                    (v, v + 0.5)
                })
                .collect();
            let mut sorted = near.clone();
            sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
            let (hot, cold) = ranks(&mut near);
            assert_eq!(hot.0, sorted[n - MIN_NEIGHBOURS].0, "{n} blocks");
            assert_eq!(cold.0, sorted[MIN_NEIGHBOURS - 1].0, "{n} blocks");
            assert_eq!((hot.1, cold.1), (hot.0 + 0.5, cold.0 + 0.5));
        }
    }

    /// Two misread 2 × 2 cells side by side at the border (a row the FTP did not trust
    /// above them) are 8 of the 15 blocks a border neighbourhood measures, a majority of
    /// those but not of its 25: no hottest place. A warm object filling those
    /// neighbourhoods is.
    #[test]
    fn misread_cells_beside_unmeasured_blocks_are_not_an_extreme() {
        let (bw, bh, skin) = (16, 10, 22.0f32);
        let mut m = vec![skin; bw * bh];
        m[..bw].fill(f32::NAN);
        for y in 1..3 {
            for x in 6..10 {
                m[y * bw + x] = 45.0;
            }
        }
        let var = vec![FINE_C2; bw * bh];
        let e = extremes(&m, &var, (bw, bh), standard);
        assert_eq!((e.min_c, e.max_c, e.hottest), (skin, skin, None));
        for y in 1..4 {
            for x in 5..12 {
                m[y * bw + x] = 30.0;
            }
        }
        let e = extremes(&m, &var, (bw, bh), standard);
        assert_eq!(e.max_c, 30.0);
        let h = e.hottest.expect("a hottest place");
        assert!(
            (5..12).contains(&(h % bw)) && (1..4).contains(&(h / bw)),
            "{h}"
        );
    }

    #[test]
    fn unmeasured_blocks_neither_count_nor_confirm() {
        let (bw, bh) = (5, 5);
        let var = vec![FINE_C2; 25];
        let mut m = vec![f32::NAN; 25];
        for (b, v) in m.iter_mut().take(12).enumerate() {
            *v = 20.0 + b as f32;
        }
        let e = extremes(&m, &var, (bw, bh), standard);
        assert_eq!(
            (e.min_c, e.max_c, e.hottest),
            (f32::INFINITY, f32::NEG_INFINITY, None)
        );
        m[12] = 40.0;
        // The middle column's neighbourhoods hold all 13: 20…31 and 40, whose middle is
        // 26, the skin's median too, so nothing stands out from it.
        let e = extremes(&m, &var, (bw, bh), standard);
        assert_eq!((e.min_c, e.max_c, e.hottest), (26.0, 26.0, None));
    }

    /// A uniform skin where a block reads to ±2 °C (the black stripes alone, above the
    /// coloured transition), one reading per 2 × 2 cell: the largest neighbourhood median
    /// stands about two degrees above the skin, and none stands out of its noise, so the
    /// extremes are the skin's.
    #[test]
    fn noise_beyond_the_transition_is_not_an_extreme() {
        let (bw, bh, skin, sigma) = (60, 44, 39.0f32, 2.0f32);
        let mut rng = crate::test_rng::XorShift(0x9e37_79b9_7f4a_7c15);
        let m = cells_of_noise(bw, bh, skin, sigma, &mut rng);
        let var = vec![sigma * sigma; bw * bh];
        let largest_median = extremes(&m, &vec![0.0; bw * bh], (bw, bh), standard).max_c;
        assert!(largest_median > skin + 1.0, "{largest_median}");
        let e = extremes(&m, &var, (bw, bh), standard);
        assert!((e.max_c - skin).abs() < 0.3, "hottest {}", e.max_c);
        assert!((e.min_c - skin).abs() < 0.3, "coldest {}", e.min_c);
        assert_eq!(e.hottest, None);
    }

    /// A warm skin whose blocks read to ±2 °C, with a patch of 6 × 6 blocks misread 3 °C
    /// low where the calibration's variance is a tenth of a degree's: the patch is at the
    /// skin's temperature and scatters as the skin does, so it is no coldest place; ten
    /// degrees below, it is.
    #[test]
    fn a_misread_patch_of_a_noisy_skin_is_judged_by_the_skins_noise() {
        let (bw, bh, skin, sigma) = (60, 44, 39.0f32, 2.0f32);
        let mut rng = crate::test_rng::XorShift(0x853c_49e6_748f_ea9b);
        let mut m = vec![skin; bw * bh];
        let mut var = vec![sigma * sigma; bw * bh];
        let patch: Vec<usize> = (10..16)
            .flat_map(|y| (20..26).map(move |x| y * bw + x))
            .collect();
        for &b in &patch {
            m[b] = skin - 3.0 + 0.1 * (rng.next() % 3) as f32;
            var[b] = FINE_C2;
        }
        let e = extremes(&m, &var, (bw, bh), standard);
        assert_eq!(e.min_c, skin);
        // Judged by the patch's own variance, it would stand out by about 5 σ.
        let [cold, _] = departures_sigmas(&m, &var, (bw, bh));
        assert!(cold > 1.0 && cold < STAND_OUT_SIGMAS, "{cold} σ");
        for &b in &patch {
            m[b] -= 7.0;
        }
        let e = extremes(&m, &var, (bw, bh), standard);
        assert!((e.min_c - (skin - 10.0)).abs() < 0.3, "coldest {}", e.min_c);
    }

    /// A place a degree below a skin read to a tenth of a degree stands out by about 8 σ:
    /// the coldest place at the least threshold, the skin's own median where the kit's
    /// uniform frames showed departures that far.
    #[test]
    fn a_place_stands_out_only_beyond_the_threshold() {
        let (bw, bh, skin) = (30, 24, 25.0f32);
        let mut m = vec![skin; bw * bh];
        for y in 8..14 {
            for x in 10..16 {
                m[y * bw + x] = skin - 1.0;
            }
        }
        let var = vec![FINE_C2; bw * bh];
        let e = extremes(&m, &var, (bw, bh), standard);
        assert_eq!(e.min_c, skin - 1.0);
        let [z, hot] = departures_sigmas(&m, &var, (bw, bh));
        let expected = 1.0 / median_sigma_c(FINE_C2, 25);
        assert!(
            (z - expected).abs() < 1e-3 * expected,
            "{z} σ, {expected} σ expected"
        );
        assert_eq!(hot, 0.0);
        let wide = extremes(&m, &var, (bw, bh), |_| 1.1 * expected);
        assert_eq!((wide.min_c, wide.max_c), (skin, skin));
    }

    /// …but a warm object of 6 × 6 blocks (12 mm) ten degrees above that noisy skin, and a
    /// cold one ten below, are its extremes, read within the noise of a few cells.
    #[test]
    fn a_warm_and_a_cold_object_stand_out_of_the_noise() {
        let (bw, bh, skin, sigma) = (60, 44, 39.0f32, 2.0f32);
        let mut rng = crate::test_rng::XorShift(0x2545_f491_4f6c_dd1d);
        let mut m = cells_of_noise(bw, bh, skin, sigma, &mut rng);
        for y in 10..16 {
            for x in 20..26 {
                m[y * bw + x] += 10.0;
                m[(y + 20) * bw + x + 20] -= 10.0;
            }
        }
        let e = extremes(&m, &vec![sigma * sigma; bw * bh], (bw, bh), standard);
        assert!((e.max_c - (skin + 10.0)).abs() < 2.5, "hottest {}", e.max_c);
        assert!((e.min_c - (skin - 10.0)).abs() < 2.5, "coldest {}", e.min_c);
        let h = e.hottest.expect("a hottest place");
        assert!(
            (20..26).contains(&(h % bw)) && (10..16).contains(&(h / bw)),
            "{h}"
        );
    }

    /// A `bw × bh` map at `skin` °C, each 2 × 2 cell off by one draw of roughly normal
    /// noise of `sigma` °C (the sum of twelve uniform draws).
    fn cells_of_noise(
        bw: usize,
        bh: usize,
        skin: f32,
        sigma: f32,
        rng: &mut crate::test_rng::XorShift,
    ) -> Vec<f32> {
        let (gw, gh) = (bw.div_ceil(2), bh.div_ceil(2));
        let cells: Vec<f32> = (0..gw * gh)
            .map(|_| {
                let u: f32 = (0..12)
                    .map(|_| (rng.next() >> 40) as f32 / (1u64 << 24) as f32)
                    .sum();
                skin + sigma * (u - 6.0)
            })
            .collect();
        (0..bw * bh)
            .map(|b| cells[(b / bw / 2) * gw + (b % bw) / 2])
            .collect()
    }
}
