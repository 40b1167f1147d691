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
//! calibration's models and their fusion, [`fit`] their fitting and [`lut`] the device
//! table.

pub mod fit;
pub mod fixed;
pub mod lab;
pub mod model;
pub mod stripes;

use image::RgbImage;

use self::fixed::FixedModel;
use self::lab::Invariants;
use self::model::TemperatureModel;
use self::stripes::{Geometry, Sums};

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

    /// Colour sums of a frame whose wrapped phase difference to the reference is
    /// `wrapped(i)` (units) at working pixel `i`, over the working pixels the FTP found
    /// `reliable`; `contact` marks the contact region.
    pub fn sums(
        &self,
        frame: &RgbImage,
        wrapped: impl Fn(usize) -> i32,
        reliable: &[bool],
        contact: Option<&[bool]>,
    ) -> (Vec<Sums>, Sums) {
        stripes::accumulate(
            frame,
            &self.geom,
            |i| self.theta_ref[i].wrapping_add(wrapped(i) as u16),
            reliable,
            contact,
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
        let (model, eval) = self.model.as_ref()?;
        if !own.enough() || !pooled.enough() {
            return None;
        }
        let device = match eval {
            Eval::Fixed(f) if !exact => Some(f),
            _ => None,
        };
        let (t, var, trusted) = match device {
            None => {
                let inv = |s: &Sums| {
                    let (c, k) = s.means();
                    Invariants::from_linear(c, k)
                };
                let (vo, vp) = (inv(own)?, inv(pooled)?);
                let e = model.estimate(&vo, &vp);
                let inside = model.domain.contains(&vo) && model.domain.contains(&vp);
                (
                    e.t_c,
                    e.var_c2,
                    inside && !model.out_of_range(e.t_c, e.var_c2),
                )
            }
            Some(f) => f.read(fixed::invariants_q16(own)?, fixed::invariants_q16(pooled)?),
        };
        Some(Reading {
            t_c: t as f32,
            var_c2: var as f32,
            trusted,
        })
    }

    /// Measures a frame (see [`Thermometer::sums`]); `None` without a model. `core`, a
    /// smaller region inside `contact`, gives the contact temperature when it holds enough
    /// stripe samples (its edge is where heat spreads into the cooler skin around).
    pub fn measure(
        &self,
        frame: &RgbImage,
        wrapped: impl Fn(usize) -> i32,
        reliable: &[bool],
        contact: Option<(&[bool], &[bool])>,
    ) -> Option<Temperature> {
        self.model.as_ref()?;
        let g = &self.geom;
        let (blocks, inside) = self.sums(frame, &wrapped, reliable, contact.map(|c| c.0));
        let core = contact.map(|c| self.sums(frame, &wrapped, reliable, Some(c.1)).1);
        let pooled = stripes::pool(&blocks, g.bw, g.bh, BLACK_POOL);
        let mut map_c = vec![f32::NAN; blocks.len()];
        let mut out_of_range = false;
        let (mut sum, mut n) = (0.0f64, 0usize);
        let (mut min_c, mut max_c) = (f32::INFINITY, f32::NEG_INFINITY);
        let mut hottest = None;
        for (b, (s, p)) in blocks.iter().zip(&pooled).enumerate() {
            let Some(r) = self.read(s, p) else {
                continue;
            };
            map_c[b] = r.t_c;
            out_of_range |= !r.trusted;
            sum += f64::from(r.t_c);
            n += 1;
            min_c = min_c.min(r.t_c);
            if r.t_c > max_c {
                max_c = r.t_c;
                hottest = Some(b);
            }
        }
        let region = match core {
            Some(c) if c.n_coloured >= CORE_SAMPLES && c.n_black >= CORE_SAMPLES => c,
            _ => inside,
        };
        let contact_c = contact.and_then(|_| self.read(&region, &region)).map(|r| {
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
