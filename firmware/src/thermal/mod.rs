//! Temperature from the same frame: per-block thermochromic thermometry, fused across the
//! coloured and the black stripes.
//!
//! ```text
//!  reference ─▶ grating phase per working pixel (once)
//!  frame + FTP's Δφ ─▶ frame's grating phase ─▶ stripe centres, per input pixel
//!        ─▶ linear colour sums per block (one stripe pair) and over the contact
//!        ─▶ invariants (chromaticity, black/coloured ratio)
//!        ─▶ float: CIELAB + both polynomials + inverse-variance fusion
//!           device: integer invariants + 3-D look-up table of the same
//!        ─▶ map, min / mean / max, hottest block, contact temperature, range flag
//! ```
//!
//! [`lab`] holds the colour science, [`stripes`] the segmentation, [`model`] the
//! calibration's models and their fusion, [`fit`] their fitting and [`fixed`] the device
//! path's integer evaluation of the models.

pub mod fit;
pub mod fixed;
pub mod lab;
pub mod model;
pub mod stripes;

use image::RgbImage;

use self::fixed::FixedModel;
use self::lab::Invariants;
use self::model::{Population, TemperatureModel};
use self::stripes::{Geometry, Regions, Sums};

/// A frame's temperatures.
#[derive(Debug, Clone, PartialEq)]
pub struct Temperature {
    /// Blocks across and down.
    pub bw: usize,
    /// See `bw`.
    pub bh: usize,
    /// Side of a block on the skin, mm.
    pub block_mm: f32,
    /// Temperature per block, °C (NaN where a block could not be measured).
    pub map_c: Vec<f32>,
    /// Coldest, mean and hottest block, °C (NaN when no block was measured).
    pub min_c: f32,
    /// See `min_c`.
    pub mean_c: f32,
    /// See `min_c`.
    pub max_c: f32,
    /// Centre of the hottest block, input pixels.
    pub hottest_px: Option<(f32, f32)>,
    /// Temperature over the contact region, °C, when there is contact.
    pub contact_c: Option<f32>,
    /// A block read outside the calibrated range (or outside the calibrated colours).
    pub out_of_range: bool,
    /// Blocks measured.
    pub measured: usize,
}

/// The black stripes are read over a block and its neighbours within this many blocks (a
/// 3 × 3 window, about 6 mm): they are dark, so one block's worth is noisy, and their model
/// is the wide, coarse one. The coloured stripes are read per block.
pub const BLACK_POOL: usize = 1;

/// Blocks that must read outside the calibration (at least; or 1 % of the measured ones)
/// for the frame to be flagged: a single block out of range is noise, a hot or cold object
/// covers several. The contact region's own reading is flagged on its own.
pub const OUT_OF_RANGE_BLOCKS: usize = 2;

/// Fewest samples of each population in the contact core before the whole contact region
/// is used instead.
const CORE_SAMPLES: u32 = 24;

/// Which colour → temperature implementation runs.
#[derive(Debug, Clone)]
enum Eval {
    /// Exact CIELAB and the models.
    Float,
    /// Integer arithmetic.
    Fixed(Box<FixedModel>),
}

/// One population's estimate in the arithmetic of the path that made it.
#[derive(Debug, Clone, Copy)]
enum PopEstimate {
    /// °C, in the calibrated box.
    Float(f64, bool),
    /// Q16 °C, in the calibrated box.
    Fixed((i64, bool)),
}

impl PopEstimate {
    /// The temperature as an integer that orders estimates of one path as their
    /// temperatures: the Q16 value itself, or a float's bits mapped as `f64::total_cmp`
    /// orders them.
    fn key(&self) -> i64 {
        match self {
            PopEstimate::Float(t, _) => {
                let b = t.to_bits() as i64;
                b ^ (((b >> 63) as u64) >> 1) as i64
            }
            PopEstimate::Fixed((t, _)) => *t,
        }
    }
}

/// Where a block's blend first reads the populations' variances: the black estimate of
/// its neighbourhood, prepared once for every block that shares it.
#[derive(Debug, Clone, Copy)]
enum Guess {
    /// °C.
    Float(f64),
    /// The black estimate's weight there, Q16 ([`FixedModel::guess_weight`]).
    Fixed(i64),
}

/// One reading: temperature (°C), variance (°C²), and whether it is trusted (inside the
/// calibrated colours and range).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reading {
    /// Fused temperature, °C.
    pub t_c: f32,
    /// Its variance, °C².
    pub var_c2: f32,
    /// Inside what was calibrated.
    pub trusted: bool,
}

/// Reference-side state: stripe geometry, the reference's grating phase, the model.
#[derive(Debug, Clone)]
pub struct Thermometer {
    geom: Geometry,
    theta_ref: Vec<u16>,
    lin: [u32; 256],
    model: Option<(TemperatureModel, Eval)>,
    mm_per_px: f32,
}

impl Thermometer {
    /// Prepares for frames of a reference whose grating phase per working pixel is
    /// `theta_ref` (units of 2π/65 536), on the device path (`fixed`) or the float
    /// reference. Without a model it only sums colours (for calibration).
    pub fn new(
        geom: Geometry,
        theta_ref: Vec<u16>,
        model: Option<TemperatureModel>,
        fixed: bool,
        mm_per_px: f32,
    ) -> Thermometer {
        let model = model.map(|m| {
            let eval = if fixed {
                Eval::Fixed(Box::new(FixedModel::new(&m)))
            } else {
                Eval::Float
            };
            (m, eval)
        });
        Thermometer {
            geom,
            theta_ref,
            lin: stripes::linear_q16(),
            model,
            mm_per_px,
        }
    }

    /// Whether temperatures can be measured (the calibration has a model).
    pub fn has_model(&self) -> bool {
        self.model.is_some()
    }

    /// Block geometry.
    pub fn geometry(&self) -> &Geometry {
        &self.geom
    }

    /// Colour sums of a frame whose grating phase along working row `y` is what
    /// `phase(y, reference, row)` writes into `row` (units) from the reference's along that
    /// row (`reference`), over the working pixels the FTP found `reliable`; `regions` marks
    /// the contact region and its core.
    pub fn sums(
        &self,
        frame: &RgbImage,
        phase: impl Fn(usize, &[u16], &mut [u16]),
        reliable: &[bool],
        regions: Option<Regions<'_>>,
    ) -> (Vec<Sums>, [Sums; 2]) {
        let w = self.geom.w;
        stripes::accumulate(
            frame,
            &self.geom,
            |y, row: &mut [u16]| {
                let reference = self.theta_ref.get(y * w..(y + 1) * w).unwrap_or(&[]);
                phase(y, reference, row);
            },
            reliable,
            regions,
            &self.lin,
        )
    }

    /// The reading of a block from its own sums (coloured stripes) and its neighbourhood's
    /// (black stripes).
    pub fn read(&self, own: &Sums, pooled: &Sums) -> Option<Reading> {
        self.read_with(own, pooled, false)
    }

    /// [`Thermometer::read`] through the float models even on the device path: the oracle
    /// the integer arithmetic is tested against.
    pub fn read_exact(&self, own: &Sums, pooled: &Sums) -> Option<Reading> {
        self.read_with(own, pooled, true)
    }

    fn read_with(&self, own: &Sums, pooled: &Sums, exact: bool) -> Option<Reading> {
        let c = self.population(Population::Coloured, own, exact)?;
        let b = self.population(Population::Black, pooled, exact)?;
        self.fuse(c, b, self.guess(b)?)
    }

    /// One population's estimate from sums: (°C, in the calibrated box) in the path's own
    /// arithmetic (Q16 on the device, `exact` forcing the float models).
    fn population(&self, p: Population, s: &Sums, exact: bool) -> Option<PopEstimate> {
        let (model, eval) = self.model.as_ref()?;
        if !s.enough() {
            return None;
        }
        Some(match eval {
            Eval::Fixed(f) if !exact => {
                PopEstimate::Fixed(f.population(p, fixed::invariants_q16(s)?))
            }
            _ => {
                let (c, k) = s.means();
                let v = Invariants::from_linear(c, k)?;
                PopEstimate::Float(model.population(p, &v), model.domain.contains(&v))
            }
        })
    }

    /// The blend's first pass at the black estimate `b` (a block's own, or its
    /// neighbourhood's median), in `b`'s arithmetic.
    fn guess(&self, b: PopEstimate) -> Option<Guess> {
        Some(match (b, &self.model.as_ref()?.1) {
            (PopEstimate::Fixed((t, _)), Eval::Fixed(f)) => Guess::Fixed(f.guess_weight(t)),
            (PopEstimate::Float(t, _), _) => Guess::Float(t),
            (PopEstimate::Fixed(_), Eval::Float) => return None,
        })
    }

    /// The inverse-variance blend of a coloured and a black estimate, the populations'
    /// variances read first at the `guess` ([`Thermometer::guess`]), then at the result.
    fn fuse(&self, c: PopEstimate, b: PopEstimate, guess: Guess) -> Option<Reading> {
        let (model, eval) = self.model.as_ref()?;
        let (t, var, trusted) = match (c, b, guess) {
            (PopEstimate::Fixed(c), PopEstimate::Fixed(b), Guess::Fixed(w)) => match eval {
                Eval::Fixed(f) => f.fuse(c, b, w),
                Eval::Float => return None,
            },
            (PopEstimate::Float(tc, ic), PopEstimate::Float(tb, ib), Guess::Float(g)) => {
                let (t, var) = model.blend(tc, tb, g);
                (t, var, ic && ib && !model.out_of_range(t, var))
            }
            _ => return None,
        };
        Some(Reading {
            t_c: t as f32,
            var_c2: var as f32,
            trusted,
        })
    }

    /// Measures a frame (see [`Thermometer::sums`]); `None` without a model. The contact's
    /// core gives the contact temperature when it holds enough stripe samples (the region's
    /// edge is where heat spreads into the cooler skin around).
    pub fn measure(
        &self,
        frame: &RgbImage,
        phase: impl Fn(usize, &[u16], &mut [u16]),
        reliable: &[bool],
        regions: Option<Regions<'_>>,
    ) -> Option<Temperature> {
        self.model.as_ref()?;
        let g = &self.geom;
        let (blocks, [inside, core]) = self.sums(frame, &phase, reliable, regions);
        // The black stripes' estimate on every other block each way (their 3 × 3 pooling
        // makes neighbours nearly the same), shared by the 2 × 2 blocks it stands for.
        let (gw, gh) = (g.bw.div_ceil(2), g.bh.div_ceil(2));
        let black: Vec<Option<PopEstimate>> = (0..gw * gh)
            .map(|k| {
                let p =
                    stripes::pool_at(&blocks, g.bw, g.bh, 2 * (k % gw), 2 * (k / gw), BLACK_POOL);
                self.population(Population::Black, &p, false)
            })
            .collect();
        // Where each block reads the populations' variances: the median black estimate of
        // its 3 × 3 neighbourhood on that grid (about 6 blocks, 12 mm, across). A single
        // block's black estimate is noisy (a few °C on a pale unit), and where it decides
        // whether the coloured stripes are inside their transition, its noise would choose
        // blocks by their error and bias the map.
        let guess: Vec<Option<Guess>> = (0..gw * gh)
            .map(|k| {
                let (x, y) = (k % gw, k / gw);
                // (temperature, index) of the measured neighbours; their median by key.
                let mut near = [(0i64, 0usize); 9];
                let mut m = 0;
                for j in y.saturating_sub(1)..(y + 2).min(gh) {
                    for i in x.saturating_sub(1)..(x + 2).min(gw) {
                        if let Some(b) = black[j * gw + i] {
                            near[m] = (b.key(), j * gw + i);
                            m += 1;
                        }
                    }
                }
                let near = &mut near[..m];
                if m == 0 {
                    return None;
                }
                let (_, mid, _) = near.select_nth_unstable_by_key(m / 2, |a| a.0);
                self.guess(black[mid.1]?)
            })
            .collect();
        let mut map_c = vec![f32::NAN; blocks.len()];
        // Blocks read outside the calibration: one is noise, a hot or cold object covers
        // several (see `OUT_OF_RANGE_BLOCKS`).
        let mut outside = 0usize;
        let (mut sum, mut n) = (0.0f64, 0usize);
        let (mut min_c, mut max_c) = (f32::INFINITY, f32::NEG_INFINITY);
        let mut hottest = None;
        for (b, s) in blocks.iter().enumerate() {
            let (bx, by) = (b % g.bw, b / g.bw);
            let cell = (by / 2) * gw + bx / 2;
            let Some(r) = black[cell]
                .zip(guess[cell])
                .and_then(|k| Some((self.population(Population::Coloured, s, false)?, k)))
                .and_then(|(c, (k, guess))| self.fuse(c, k, guess))
            else {
                continue;
            };
            map_c[b] = r.t_c;
            outside += usize::from(!r.trusted);
            sum += f64::from(r.t_c);
            n += 1;
            min_c = min_c.min(r.t_c);
            if r.t_c > max_c {
                max_c = r.t_c;
                hottest = Some(b);
            }
        }
        let region = if core.n[0] >= CORE_SAMPLES && core.n[1] >= CORE_SAMPLES {
            core
        } else {
            inside
        };
        let mut out_of_range = outside >= OUT_OF_RANGE_BLOCKS.max(n / 100);
        let contact_c = regions.and_then(|_| self.read(&region, &region)).map(|r| {
            out_of_range |= !r.trusted;
            r.t_c
        });
        let nan = |v: f32| if n == 0 { f32::NAN } else { v };
        Some(Temperature {
            bw: g.bw,
            bh: g.bh,
            block_mm: (g.block_px * g.factor) as f32 * self.mm_per_px,
            map_c,
            min_c: nan(min_c),
            mean_c: nan((sum / n.max(1) as f64) as f32),
            max_c: nan(max_c),
            hottest_px: hottest.map(|b| g.block_center_px(b)),
            contact_c,
            out_of_range,
            measured: n,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Estimates order by their integer keys as by their temperatures, on either path
    /// (negative, zero and positive, near and far apart).
    #[test]
    fn keys_order_estimates_as_their_temperatures() {
        let mut rng = crate::test_rng::XorShift(0x2545_f491_4f6c_dd1d);
        let mut ts: Vec<f64> = (0..400)
            .map(|_| (rng.next() as i32) as f64 / (1 + rng.next() % 1000) as f64)
            .collect();
        ts.extend([
            0.0,
            -0.0,
            1e-300,
            -1e-300,
            37.5,
            37.500_000_000_000_01,
            -40.0,
        ]);
        for a in &ts {
            for b in &ts {
                let (ka, kb) = (
                    PopEstimate::Float(*a, true).key(),
                    PopEstimate::Float(*b, true).key(),
                );
                assert_eq!(ka.cmp(&kb), a.total_cmp(b), "{a} {b}");
                let (qa, qb) = ((a * 65_536.0) as i64, (b * 65_536.0) as i64);
                let (ka, kb) = (
                    PopEstimate::Fixed((qa, true)).key(),
                    PopEstimate::Fixed((qb, false)).key(),
                );
                assert_eq!(ka.cmp(&kb), qa.cmp(&qb));
            }
        }
    }
}
