//! Temperatures from colour sums, in either arithmetic: the float models ([`FloatModel`],
//! the oracle) or their integer form ([`FixedModel`], the device path), each an
//! [`Evaluator`]; the map over a frame's blocks is the same code for both.
//!
//! A block's reading fuses two populations: the coloured stripes read per block, the
//! black stripes over its neighbourhood (they are dark and their model is the coarse one).
//! The coloured stripes' colour is measured against the neighbourhood's black stripes too:
//! the same light and camera gains, and nine blocks' worth of dark samples instead of one.
//! The blend reads the populations' variances first at a guess, the median black estimate
//! of the block's neighbourhood, then at the result.

use super::fixed::{invariants_q16, FixedModel, ONE};
use super::model::{Population, TemperatureModel};
use super::stripes::{pool_at, Sums};
use super::{Reading, BLACK_POOL};

/// One arithmetic for the calibration's temperature models.
pub trait Evaluator {
    /// A population's estimate: temperature, and whether its colours lie in the
    /// calibrated box.
    type Estimate: Copy;
    /// Where the blend first reads the populations' variances, prepared once for every
    /// block that shares it.
    type Guess: Copy;
    /// A population's estimate from sums that hold enough samples, the coloured
    /// chromaticity measured against the black stripes of `white` (see
    /// [`Sums::invariants`]); `None` when their colours say nothing (a channel black).
    fn population(&self, p: Population, s: &Sums, white: &Sums) -> Option<Self::Estimate>;
    /// The black stripes' estimate from sums whose black/coloured ratio `q` is taken as
    /// `scale_q16 / 2¹⁶` times what they show: how far a reading moves with that ratio
    /// ([`Temperatures::read_contact`]).
    fn black_with_ratio_scaled(&self, s: &Sums, scale_q16: i64) -> Option<Self::Estimate>;
    /// An integer that orders estimates as their temperatures.
    fn key(e: &Self::Estimate) -> i64;
    /// Both populations' estimates of `s` (against its own black stripes) with the coloured
    /// stripes' chromaticity `r` and `g` each scaled by 1 + `shift_q16` (Q16).
    fn chroma_shifted(
        &self,
        s: &Sums,
        shift_q16: [i64; 2],
    ) -> Option<(Self::Estimate, Self::Estimate)>;
    /// [`TemperatureModel::contact_chroma_spread`], Q16.
    fn chroma_spread_q16(&self) -> [i64; 2];
    /// The blend's first pass at a black estimate.
    fn guess(&self, black: Self::Estimate) -> Self::Guess;
    /// The inverse-variance blend of a coloured and a black estimate.
    fn fuse(&self, coloured: Self::Estimate, black: Self::Estimate, guess: Self::Guess) -> Reading;
}

/// The float models: exact CIELAB and the polynomials.
#[derive(Debug, Clone)]
pub struct FloatModel(pub TemperatureModel);

impl Evaluator for FloatModel {
    type Estimate = (f64, bool);
    type Guess = f64;

    fn population(&self, p: Population, s: &Sums, white: &Sums) -> Option<(f64, bool)> {
        let v = s.invariants(white)?;
        Some((self.0.population(p, &v), self.0.domain.contains(&v)))
    }

    fn black_with_ratio_scaled(&self, s: &Sums, scale_q16: i64) -> Option<(f64, bool)> {
        let mut v = s.invariants(s)?;
        v.q *= scale_q16 as f64 / ONE as f64;
        Some((
            self.0.population(Population::Black, &v),
            self.0.domain.contains(&v),
        ))
    }

    /// The float's bits mapped as `f64::total_cmp` orders them.
    fn key(e: &(f64, bool)) -> i64 {
        let b = e.0.to_bits() as i64;
        b ^ (((b >> 63) as u64) >> 1) as i64
    }

    fn chroma_shifted(&self, s: &Sums, shift_q16: [i64; 2]) -> Option<((f64, bool), (f64, bool))> {
        let mut v = s.invariants(s)?;
        let [dr, dg] = shift_q16.map(|d| d as f64 / ONE as f64);
        v.r *= 1.0 + dr;
        v.g *= 1.0 + dg;
        let inside = self.0.domain.contains(&v);
        Some((
            (self.0.population(Population::Coloured, &v), inside),
            (self.0.population(Population::Black, &v), inside),
        ))
    }

    fn chroma_spread_q16(&self) -> [i64; 2] {
        self.0
            .contact_chroma_spread
            .map(|s| (s * ONE as f64).round() as i64)
    }

    fn guess(&self, black: (f64, bool)) -> f64 {
        black.0
    }

    fn fuse(&self, (tc, ic): (f64, bool), (tb, ib): (f64, bool), guess: f64) -> Reading {
        let (t, var) = self.0.blend(tc, tb, guess);
        Reading {
            t_c: t as f32,
            var_c2: var as f32,
            trusted: ic && ib && !self.0.out_of_range(t, var),
        }
    }
}

impl Evaluator for FixedModel {
    /// Q16 °C, in the calibrated box.
    type Estimate = (i64, bool);
    /// The black estimate's weight at the guess, Q16 ([`FixedModel::guess_weight`]).
    type Guess = i64;

    fn population(&self, p: Population, s: &Sums, white: &Sums) -> Option<(i64, bool)> {
        Some(FixedModel::population(self, p, invariants_q16(s, white)?))
    }

    fn black_with_ratio_scaled(&self, s: &Sums, scale_q16: i64) -> Option<(i64, bool)> {
        let mut v = invariants_q16(s, s)?;
        v[2] = (v[2] * scale_q16) >> 16;
        Some(FixedModel::population(self, Population::Black, v))
    }

    fn key(e: &(i64, bool)) -> i64 {
        e.0
    }

    fn chroma_shifted(&self, s: &Sums, shift_q16: [i64; 2]) -> Option<((i64, bool), (i64, bool))> {
        let mut v = invariants_q16(s, s)?;
        for (x, d) in v.iter_mut().zip(shift_q16) {
            *x += (*x * d) >> 16;
        }
        Some((
            FixedModel::population(self, Population::Coloured, v),
            FixedModel::population(self, Population::Black, v),
        ))
    }

    fn chroma_spread_q16(&self) -> [i64; 2] {
        self.chroma_spread
    }

    fn guess(&self, black: (i64, bool)) -> i64 {
        self.guess_weight(black.0)
    }

    fn fuse(&self, c: (i64, bool), b: (i64, bool), guess: i64) -> Reading {
        let (t, var, trusted) = FixedModel::fuse(self, c, b, guess);
        Reading {
            t_c: t as f32,
            var_c2: var as f32,
            trusted,
        }
    }
}

/// How much a contact region's black/coloured ratio `q` scatters, relative, beyond what
/// the calibration's flat frames show. A contact's core is small, a stripe pair or a few:
/// light that changes within a stripe period (an LED's reflection) falls unequally on its
/// few black and coloured stripes, and the indentation moves them under it. On flat skin
/// many stripe pairs average this out, and the block-to-block pattern is learnt from the
/// reference (`super::ratio_field`). Where the coloured stripes are inside their
/// transition a reading hardly moves with `q`; above it the black stripes carry the
/// reading alone and move by degrees per per cent of `q`. The value is the spread the
/// shifts measured on heated contacts show as a standard deviation, so that the stated σ
/// covers their errors as a σ should (`docs/temperature.md`).
pub const CONTACT_RATIO_SPREAD: f64 = 0.02;

/// [`CONTACT_RATIO_SPREAD`] in Q16.
const SPREAD_Q16: i64 = (CONTACT_RATIO_SPREAD * ONE as f64) as i64;

/// A frame's blocks read.
#[derive(Debug, Clone, PartialEq)]
pub struct BlockMap {
    /// Temperature per block, °C (NaN where a block could not be measured).
    pub map_c: Vec<f32>,
    /// Each reading's variance, °C² (NaN where unmeasured).
    pub var_c2: Vec<f32>,
    /// Blocks measured.
    pub measured: usize,
    /// Blocks read outside the calibration.
    pub outside: usize,
    /// Sum of the measured blocks' temperatures, °C.
    pub sum_c: f64,
}

/// What the thermometer asks of an evaluator, whichever its arithmetic.
pub trait Temperatures: std::fmt::Debug + Send + Sync {
    /// A reading from a region's own sums (coloured stripes) and its neighbourhood's
    /// (black stripes).
    fn read(&self, own: &Sums, pooled: &Sums) -> Option<Reading>;
    /// A contact region's reading from its own sums, its variance widened by what the
    /// calibration's flat frames cannot show: the scatter of a contact's black/coloured
    /// ratio ([`CONTACT_RATIO_SPREAD`]) and of its chromaticity (the kit's presses',
    /// `chroma_variance`), each carried through the blend as the reading moves with it.
    /// Whether it is trusted is decided on the calibrated variance alone, as for any block.
    fn read_contact(&self, s: &Sums) -> Option<Reading>;
    /// Every block of a `bw × bh` frame (see the module doc).
    fn map(&self, blocks: &[Sums], bw: usize, bh: usize) -> BlockMap;
}

/// A population's estimate, when the sums (and the black stripes they are measured
/// against) hold enough samples.
fn estimate<E: Evaluator>(e: &E, p: Population, s: &Sums, white: &Sums) -> Option<E::Estimate> {
    if !s.enough() || !white.enough() {
        return None;
    }
    e.population(p, s, white)
}

/// Both populations' estimates of a region (the coloured stripes from its own sums, the
/// black from `pooled`), and the blend's guess.
fn both<E: Evaluator>(
    e: &E,
    own: &Sums,
    pooled: &Sums,
) -> Option<(E::Estimate, E::Estimate, E::Guess)> {
    let c = estimate(e, Population::Coloured, own, pooled)?;
    let b = estimate(e, Population::Black, pooled, pooled)?;
    Some((c, b, e.guess(b)))
}

/// The variance (°C²) a contact reading `t_c` takes from the scatter a press puts on the
/// chromaticity of the region `s` ([`Evaluator::chroma_spread_q16`]): `r` and `g` are each
/// shifted by their spread either way, both populations are read again and blended at the
/// shifted black estimate's guess, and half of each span, squared, is added. Inside the
/// coloured stripes' transition the colour moves fast with temperature and the span is
/// small. At its top the colour slows while the coloured stripes still hold the blend, and
/// a shift the kit's presses show moves the reading by tenths of a degree or more.
fn chroma_variance<E: Evaluator>(e: &E, s: &Sums, t_c: f32) -> f32 {
    let spread = e.chroma_spread_q16();
    let read = |shift: [i64; 2]| {
        e.chroma_shifted(s, shift)
            .map_or(t_c, |(c, b)| e.fuse(c, b, e.guess(b)).t_c)
    };
    (0..2)
        .filter(|&k| spread[k] > 0)
        .map(|k| {
            let mut up = [0; 2];
            up[k] = spread[k];
            let half_c = (read(up) - read(up.map(|v| -v))) / 2.0;
            half_c * half_c
        })
        .sum()
}

impl<E: Evaluator + std::fmt::Debug + Send + Sync> Temperatures for E {
    fn read(&self, own: &Sums, pooled: &Sums) -> Option<Reading> {
        let (c, b, guess) = both(self, own, pooled)?;
        Some(self.fuse(c, b, guess))
    }

    fn read_contact(&self, s: &Sums) -> Option<Reading> {
        let (c, b, guess) = both(self, s, s)?;
        let r = self.fuse(c, b, guess);
        let moved = |scale: i64| {
            self.black_with_ratio_scaled(s, scale)
                .map_or(r.t_c, |b| self.fuse(c, b, guess).t_c)
        };
        let half_span_c = (moved(ONE + SPREAD_Q16) - moved(ONE - SPREAD_Q16)) / 2.0;
        Some(Reading {
            var_c2: r.var_c2 + half_span_c * half_span_c + chroma_variance(self, s, r.t_c),
            ..r
        })
    }

    fn map(&self, blocks: &[Sums], bw: usize, bh: usize) -> BlockMap {
        // The black stripes' estimate on every other block each way (their 3 × 3 pooling
        // makes neighbours nearly the same), shared by the 2 × 2 blocks it stands for.
        let (gw, gh) = (bw.div_ceil(2), bh.div_ceil(2));
        let pooled: Vec<Sums> = (0..gw * gh)
            .map(|k| pool_at(blocks, bw, bh, 2 * (k % gw), 2 * (k / gw), BLACK_POOL))
            .collect();
        let black: Vec<Option<E::Estimate>> = pooled
            .iter()
            .map(|p| estimate(self, Population::Black, p, p))
            .collect();
        let guess = guesses(self, &black, (gw, gh));
        let mut m = BlockMap {
            map_c: vec![f32::NAN; blocks.len()],
            var_c2: vec![f32::NAN; blocks.len()],
            measured: 0,
            outside: 0,
            sum_c: 0.0,
        };
        for (b, s) in blocks.iter().enumerate() {
            let cell = (b / bw / 2) * gw + (b % bw) / 2;
            let Some(r) = black[cell]
                .zip(guess[cell])
                .and_then(|k| Some((estimate(self, Population::Coloured, s, &pooled[cell])?, k)))
                .map(|(c, (k, guess))| self.fuse(c, k, guess))
            else {
                continue;
            };
            m.map_c[b] = r.t_c;
            m.var_c2[b] = r.var_c2;
            m.outside += usize::from(!r.trusted);
            m.sum_c += f64::from(r.t_c);
            m.measured += 1;
        }
        m
    }
}

/// Where each cell of the black estimates' grid (`gw × gh`) reads the populations'
/// variances: the median black estimate of its 3 × 3 neighbourhood (about 6 blocks, 12 mm,
/// across). A single block's black estimate is noisy (a few °C on a pale unit), and where
/// it decides whether the coloured stripes are inside their transition, its noise would
/// choose blocks by their error and bias the map.
fn guesses<E: Evaluator>(
    e: &E,
    black: &[Option<E::Estimate>],
    (gw, gh): (usize, usize),
) -> Vec<Option<E::Guess>> {
    (0..gw * gh)
        .map(|k| {
            let (x, y) = (k % gw, k / gw);
            // (key, index) of the measured neighbours; their median by key.
            let mut near = [(0i64, 0usize); 9];
            let mut m = 0;
            for j in y.saturating_sub(1)..(y + 2).min(gh) {
                for i in x.saturating_sub(1)..(x + 2).min(gw) {
                    if let Some(b) = &black[j * gw + i] {
                        near[m] = (E::key(b), j * gw + i);
                        m += 1;
                    }
                }
            }
            let near = &mut near[..m];
            if m == 0 {
                return None;
            }
            let (_, mid, _) = near.select_nth_unstable_by_key(m / 2, |a| a.0);
            Some(e.guess(black[mid.1]?))
        })
        .collect()
}
