//! The black stripes' brightness against the coloured ones, block by block, as the
//! reference shows it: a flat field for the ratio every temperature feature is built on.
//!
//! A block's stripe samples do not sit at the same places for the two populations (the
//! coloured stripes' centres in one band, the black ones' in another), so wherever the light
//! changes across a block (vignetting falls off by several per cent per block near the
//! border) the two populations see it differently, and their ratio carries a fixed pattern
//! of a few per cent from block to block. Pigment mottle, which darkens the coloured
//! stripes alone, can add to it. Inside the pigments' transition that is a fraction of a
//! degree; beyond it, where the colours hardly change with temperature, the same few per
//! cent read as degrees, and the hottest place of a uniform skin stands out from it by
//! several.
//!
//! The pattern belongs to the camera and the skin, not to the temperature: the reference,
//! a skin at rest and one temperature throughout, shows it, and every later frame's black
//! stripes are scaled by the reference's ratio to the field's median. The chromaticity
//! features, which take their white from the black stripes, do not change under that
//! scaling (it is common to the three channels); the lightness ratio loses the pattern. A
//! block the reference cannot read keeps its colours as they are, and no block is scaled
//! by more than [`MAX_GAIN_LN`]: a departure larger than that is light added (a glare
//! spot, [`super::static_light`]), not the pattern.

use super::stripes::{region, Geometry, Regions, Sums};

/// Largest correction, as a natural log (about 20 %).
pub const MAX_GAIN_LN: f64 = 0.2;

/// Scale of [`RatioField`]'s gains: 65 536 is 1.
const ONE: u64 = 1 << 16;

/// Per-block gains for the black stripes' sums, Q16 (see the module doc).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct RatioField {
    gain_q16: Vec<u32>,
}

impl RatioField {
    /// Learns the field from the reference's sums per block; blocks marked in `skip`
    /// (static light) or too thin to read keep a gain of 1.
    pub fn learn(reference: &[Sums], skip: &[bool]) -> RatioField {
        let ratio: Vec<Option<f64>> = reference
            .iter()
            .enumerate()
            .map(|(b, s)| {
                let skipped = skip.get(b).copied().unwrap_or(false);
                black_over_coloured(s).filter(|_| !skipped)
            })
            .collect();
        let mut seen: Vec<f64> = ratio.iter().flatten().copied().collect();
        if seen.is_empty() {
            return RatioField::default();
        }
        let mid = seen.len() / 2;
        let (_, &mut median, _) = seen.select_nth_unstable_by(mid, f64::total_cmp);
        let gain_q16 = ratio
            .iter()
            .map(|r| {
                let ln = r.map_or(0.0, |r| (median / r).ln());
                let g = ln.clamp(-MAX_GAIN_LN, MAX_GAIN_LN).exp();
                (g * ONE as f64).round() as u32
            })
            .collect();
        RatioField { gain_q16 }
    }

    /// Scales each block's black-stripe sums by its gain (blocks beyond the field's are
    /// left as they are).
    pub fn apply(&self, blocks: &mut [Sums]) {
        for (s, &g) in blocks.iter_mut().zip(&self.gain_q16) {
            scale_black(s, u64::from(g));
        }
    }

    /// Scales the contact region's black-stripe sums (`contact`: the region, its core) by
    /// the mean gain of the blocks its working pixels lie in (`regions`, blocks of
    /// `geom`): read over several blocks, the region's ratio carries their pattern in
    /// proportion. Each row is taken a block's run of pixels at a time.
    pub fn apply_regions(&self, regions: &Regions<'_>, geom: &Geometry, contact: &mut [Sums; 2]) {
        if self.gain_q16.is_empty() {
            return;
        }
        // (Σ gain × pixels, pixels) of the region and of its core.
        let mut acc = [(0u64, 0u64); 2];
        let side = geom.block_px.max(1);
        for (y, x0, codes) in regions.rows().filter(|&(y, ..)| y < geom.h) {
            let codes = &codes[..codes.len().min(geom.w.saturating_sub(x0))];
            let (mut x, mut rest) = (x0, codes);
            while !rest.is_empty() {
                let (run, next) = rest.split_at(rest.len().min(side - x % side));
                let b = (y / side) * geom.bw + x / side;
                let g = u64::from(self.gain_q16.get(b).copied().unwrap_or(ONE as u32));
                for (a, n) in acc.iter_mut().zip(region_pixels(run)) {
                    *a = (a.0 + g * n, a.1 + n);
                }
                x += run.len();
                rest = next;
            }
        }
        for (s, (sum, n)) in contact.iter_mut().zip(acc) {
            if let Some(g) = (sum + n / 2).checked_div(n) {
                scale_black(s, g);
            }
        }
    }

    /// A block's gain (1 where none was learnt).
    #[cfg(test)]
    pub fn gain(&self, block: usize) -> f64 {
        self.gain_q16
            .get(block)
            .map_or(1.0, |&g| f64::from(g) / ONE as f64)
    }
}

/// Pixels of a run of region codes in the region, and in its core.
fn region_pixels(run: &[u8]) -> [u64; 2] {
    run.iter().fold([0, 0], |[n, core], &c| {
        [
            n + u64::from(c != region::NONE),
            core + u64::from(c == region::CORE),
        ]
    })
}

/// Scales the black stripes' sums by `gain_q16`.
fn scale_black(s: &mut Sums, gain_q16: u64) {
    for v in &mut s.sum[1] {
        *v = (*v * gain_q16 + ONE / 2) >> 16;
    }
}

/// The black stripes over the coloured, the lightness feature's ratio (`q` of
/// [`super::lab::Invariants`]); `None` when a channel of either is black.
fn black_over_coloured(s: &Sums) -> Option<f64> {
    s.invariants(s).map(|v| v.q)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn block(c: [f64; 3], k: [f64; 3], n: u32) -> Sums {
        let q = |v: [f64; 3]| v.map(|x| (x * 65_536.0 * f64::from(n)).round() as u64);
        Sums {
            sum: [q(c), q(k)],
            n: [n, n],
            clipped: [0, 0],
        }
    }

    /// A pattern of a few per cent in the black stripes' brightness against the coloured
    /// is learnt from the reference and taken out of a frame at another temperature,
    /// whatever the light on each block; the chromaticity is untouched.
    #[test]
    fn the_references_pattern_leaves_the_black_over_coloured_ratio() {
        let pattern = [1.0, 1.04, 0.97, 1.02, 0.95, 1.0];
        let light = [1.0, 0.8, 0.6, 0.9, 0.7, 0.5];
        let at = |c: [f64; 3], k: [f64; 3]| -> Vec<Sums> {
            (0..6)
                .map(|b| {
                    let l = light[b];
                    block(c.map(|v| v * l), k.map(|v| v * l * pattern[b]), 40)
                })
                .collect()
        };
        let reference = at([0.30, 0.22, 0.12], [0.05, 0.048, 0.046]);
        let field = RatioField::learn(&reference, &[]);
        let mut hot = at([0.45, 0.40, 0.33], [0.07, 0.066, 0.065]);
        let before: Vec<f64> = hot.iter().filter_map(black_over_coloured).collect();
        field.apply(&mut hot);
        let after: Vec<f64> = hot.iter().filter_map(black_over_coloured).collect();
        let spread = |v: &[f64]| {
            let (lo, hi) = v
                .iter()
                .fold((f64::MAX, f64::MIN), |(a, b), &x| (a.min(x), b.max(x)));
            hi / lo - 1.0
        };
        assert!(spread(&before) > 0.08, "{before:?}");
        assert!(spread(&after) < 1e-3, "{after:?}");
        let chroma = |s: &Sums| s.invariants(s).map(|v| (v.r, v.g));
        let plain = at([0.45, 0.40, 0.33], [0.07, 0.066, 0.065]);
        for (a, b) in hot.iter().zip(&plain) {
            let ((ra, ga), (rb, gb)) = (chroma(a).unwrap(), chroma(b).unwrap());
            assert!((ra - rb).abs() < 1e-4 && (ga - gb).abs() < 1e-4);
        }
    }

    /// Skipped, unreadable and far-off blocks: gain 1 for the first two, at most
    /// `MAX_GAIN_LN` for the last.
    #[test]
    fn skipped_thin_and_far_off_blocks_are_bounded() {
        let c = [0.3, 0.2, 0.1];
        let k = [0.05, 0.05, 0.05];
        let mut reference: Vec<Sums> = (0..5).map(|_| block(c, k, 40)).collect();
        reference[1] = block(c, k.map(|v| v * 1.1), 40);
        reference[2] = block(c, k.map(|v| v * 1.1), 2);
        reference[3] = block(c, k.map(|v| v * 3.0), 40);
        let field = RatioField::learn(&reference, &[false, true]);
        assert_eq!(field.gain(0), 1.0);
        assert_eq!(field.gain(1), 1.0);
        assert_eq!(field.gain(2), 1.0);
        assert!((field.gain(3) - (-MAX_GAIN_LN).exp()).abs() < 1e-4);
        assert_eq!(field.gain(99), 1.0);
        assert_eq!(RatioField::learn(&[], &[]), RatioField::default());
    }

    /// The contact region's black stripes are scaled by the mean gain of the blocks its
    /// working pixels lie in, the core's by its own pixels' blocks.
    #[test]
    fn the_contact_region_takes_the_mean_gain_of_its_blocks() {
        let c = [0.3, 0.2, 0.1];
        let k = [0.05, 0.05, 0.05];
        // Two blocks of 4 × 4 working pixels side by side; the second's ratio is 10 % up.
        let reference = [
            block(c, k, 40),
            block(c, k.map(|v| v * 1.1), 40),
            block(c, k, 40),
        ];
        let field = RatioField::learn(&reference, &[]);
        let geom = Geometry::new(8, 4, 1, 0.25, 0.0);
        assert_eq!((geom.block_px, geom.bw, geom.bh), (4, 2, 1));
        // A region of one row: three pixels in block 0, three in block 1, the core's in 1.
        let codes = [
            0,
            region::CONTACT,
            region::CONTACT,
            region::CONTACT,
            region::CORE,
            region::CORE,
            region::CORE,
            0,
        ];
        let g1 = 1.0 / 1.1;
        let want = [(1.0 + g1) / 2.0, g1];
        // The whole row, and the same region in a box that starts at its first pixel.
        for regions in [
            Regions::new(&codes, 0, 0, 8),
            Regions::new(&codes[1..7], 1, 0, 6),
        ] {
            let mut contact = [block(c, k, 100), block(c, k, 50)];
            field.apply_regions(&regions, &geom, &mut contact);
            for (s, w) in contact.iter().zip(want) {
                let got = s.means().1[0] / k[0];
                assert!((got - w).abs() < 1e-3, "{got} {w}");
            }
        }
    }
}
