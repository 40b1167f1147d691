//! Stripe segmentation from the grating itself, and the colour sums per block.
//!
//! The FTP analytic signal already knows, at every working pixel, the grating's phase θ:
//! the luminance there goes as `A + B·cos θ` with the (bright) coloured stripe's centre at
//! θ = 0 and the black stripe's at θ = π. Inside a working pixel the phase advances by the
//! carrier per input pixel, so every input pixel gets its own phase with one addition. The
//! frame's own phase is the reference's plus the wrapped phase difference the FTP has just
//! measured, so stripes are found where they are, also where the skin is indented.
//!
//! Only pixels within ±[`KEEP_UNITS`] of a stripe centre count (the middle half of each
//! stripe), so the blur across stripe edges does not mix the two populations. One input row
//! per working row is read: a block still sees every phase of the grating, at a fraction of
//! the cost. Saturated pixels are left out. Everything is integer: phases in units of
//! 2π/65 536, colours as linear light in Q16 from a 256-entry table.

use image::RgbImage;

use super::lab::linear_table;

/// Half-width of the kept band around a stripe centre, phase units (±45°).
pub const KEEP_UNITS: i32 = 65_536 / 8;

/// Linear light of an 8-bit sRGB code, Q16 (65 536 = 1.0): fine enough that the darkest
/// codes of the black stripes keep three significant digits.
pub fn linear_q16() -> [u32; 256] {
    linear_table().map(|v| (v * 65_536.0).round() as u32)
}

/// Colour sums of one block (or of the contact region), linear Q16 (64-bit sums: a contact region may hold 10⁵ samples).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Sums {
    /// Σ linear R, G, B over coloured-stripe centres.
    pub coloured: [u64; 3],
    /// Number of coloured-stripe samples.
    pub n_coloured: u32,
    /// Σ linear R, G, B over black-stripe centres.
    pub black: [u64; 3],
    /// Number of black-stripe samples.
    pub n_black: u32,
}

impl Sums {
    /// Fewest samples of each population for a block to be measured.
    pub const MIN_SAMPLES: u32 = 4;

    /// Whether both populations were seen often enough.
    pub fn enough(&self) -> bool {
        self.n_coloured >= Self::MIN_SAMPLES && self.n_black >= Self::MIN_SAMPLES
    }

    /// Adds another block's sums.
    pub fn add(&mut self, o: &Sums) {
        for k in 0..3 {
            self.coloured[k] += o.coloured[k];
            self.black[k] += o.black[k];
        }
        self.n_coloured += o.n_coloured;
        self.n_black += o.n_black;
    }

    /// Mean linear colours (coloured, black), 0…1.
    pub fn means(&self) -> ([f64; 3], [f64; 3]) {
        let m = |s: [u64; 3], n: u32| s.map(|v| v as f64 / 65_536.0 / f64::from(n.max(1)));
        (
            m(self.coloured, self.n_coloured),
            m(self.black, self.n_black),
        )
    }
}

/// Where the blocks are and how the phase advances between input pixels.
#[derive(Debug, Clone, PartialEq)]
pub struct Geometry {
    /// Working width and height, pixels.
    pub w: usize,
    /// See `w`.
    pub h: usize,
    /// Input pixels per working pixel.
    pub factor: usize,
    /// Side of a block, working pixels (about one stripe pair).
    pub block_px: usize,
    /// Blocks across and down.
    pub bw: usize,
    /// See `bw`.
    pub bh: usize,
    /// Phase of input pixel `k` (0…factor−1) of a working pixel, relative to the working
    /// pixel's centre, on the sampled input row; units.
    pub offsets: Vec<i32>,
}

impl Geometry {
    /// For a working image `w × h` at `factor`, whose carrier runs `fx`, `fy` cycles per
    /// working pixel. Blocks span at least one grating period.
    pub fn new(w: usize, h: usize, factor: usize, fx: f32, fy: f32) -> Geometry {
        let period = 1.0 / f64::from(fx.hypot(fy)).max(1e-6);
        let block_px = (period.ceil() as usize).clamp(4, 16);
        let f = factor.max(1);
        let c = (f as f64 - 1.0) / 2.0; // the working pixel's centre, input pixels
        let row = (f / 2) as f64 - c; // the sampled input row, relative to that centre
        let units = |cycles: f64| (cycles * 65_536.0).round() as i32;
        let offsets = (0..f)
            .map(|k| {
                units(f64::from(fx) / f as f64 * (k as f64 - c) + f64::from(fy) / f as f64 * row)
            })
            .collect();
        Geometry {
            w,
            h,
            factor: f,
            block_px,
            bw: w.div_ceil(block_px),
            bh: h.div_ceil(block_px),
            offsets,
        }
    }

    /// Centre of block `b` in input pixels.
    pub fn block_center_px(&self, b: usize) -> (f32, f32) {
        let (bx, by) = (b % self.bw, b / self.bw);
        let side = |k: usize, n: usize| {
            let lo = k * self.block_px;
            let hi = ((k + 1) * self.block_px).min(n);
            (lo + hi) as f32 / 2.0 * self.factor as f32
        };
        (side(bx, self.w), side(by, self.h))
    }
}

/// Sums colours per block (and over `contact`, working pixels in the contact region).
/// `theta(i)` is the frame's grating phase at working pixel `i`, units; only working pixels
/// where `reliable` (the FTP trusted their phase: away from the image edge, with fringe
/// contrast) are read, since elsewhere the stripes cannot be told apart.
pub fn accumulate(
    frame: &RgbImage,
    g: &Geometry,
    theta: impl Fn(usize) -> u16,
    reliable: &[bool],
    contact: Option<&[bool]>,
    lin: &[u32; 256],
) -> (Vec<Sums>, Sums) {
    let mut blocks = vec![Sums::default(); g.bw * g.bh];
    let mut inside = Sums::default();
    let width = frame.width() as usize;
    let raw: &[u8] = frame.as_raw();
    for yw in 0..g.h {
        let y = yw * g.factor + g.factor / 2;
        let line = &raw[y * width * 3..(y + 1) * width * 3];
        let brow = &mut blocks[(yw / g.block_px) * g.bw..(yw / g.block_px + 1) * g.bw];
        for xw in 0..g.w {
            let i = yw * g.w + xw;
            if !reliable[i] {
                continue;
            }
            let t0 = i32::from(theta(i));
            let in_contact = contact.is_some_and(|c| c[i]);
            let acc = &mut brow[xw / g.block_px];
            for (k, off) in g.offsets.iter().enumerate() {
                let t = i32::from((t0 + off) as u16 as i16);
                let coloured = t.abs() < KEEP_UNITS;
                if !coloured && t.abs() <= 32_768 - KEEP_UNITS {
                    continue;
                }
                let p = &line[(xw * g.factor + k) * 3..(xw * g.factor + k) * 3 + 3];
                if p[0] == 255 || p[1] == 255 || p[2] == 255 {
                    continue;
                }
                let c = [lin[p[0] as usize], lin[p[1] as usize], lin[p[2] as usize]];
                let add = |s: &mut Sums| {
                    let (sum, n) = if coloured {
                        (&mut s.coloured, &mut s.n_coloured)
                    } else {
                        (&mut s.black, &mut s.n_black)
                    };
                    for (a, v) in sum.iter_mut().zip(c) {
                        *a += u64::from(v);
                    }
                    *n += 1;
                };
                add(acc);
                if in_contact {
                    add(&mut inside);
                }
            }
        }
    }
    (blocks, inside)
}

/// Each block's sums pooled with its neighbours within `r` blocks (a (2r+1)² window,
/// clipped at the edges).
pub fn pool(blocks: &[Sums], bw: usize, bh: usize, r: usize) -> Vec<Sums> {
    let mut out = vec![Sums::default(); blocks.len()];
    for by in 0..bh {
        for bx in 0..bw {
            let o = &mut out[by * bw + bx];
            for y in by.saturating_sub(r)..(by + r + 1).min(bh) {
                for x in bx.saturating_sub(r)..(bx + r + 1).min(bw) {
                    o.add(&blocks[y * bw + x]);
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn geometry_tiles_the_working_image_with_stripe_pair_blocks() {
        let g = Geometry::new(100, 50, 2, 1.0 / 7.5, 0.0);
        assert_eq!(g.block_px, 8);
        assert_eq!((g.bw, g.bh), (13, 7));
        // Two input pixels per working pixel, ½ input px either side of its centre, at
        // 1/15 cycle per input pixel.
        let half = (65_536.0 / 15.0 * 0.5f64).round() as i32;
        assert_eq!(g.offsets, vec![-half, half]);
        assert_eq!(g.block_center_px(0), (8.0, 8.0));
    }

    #[test]
    fn pooling_sums_the_neighbourhood() {
        let one = Sums {
            coloured: [1, 2, 3],
            n_coloured: 1,
            black: [4, 5, 6],
            n_black: 2,
        };
        let p = pool(&vec![one; 12], 4, 3, 1);
        assert_eq!(p[0].n_coloured, 4); // corner: 2 × 2
        assert_eq!(p[5].n_coloured, 9); // inside: 3 × 3
        assert_eq!(p[5].black, [36, 45, 54]);
    }

    #[test]
    fn stripes_are_found_by_phase() {
        // Vertical stripes of period 8: coloured (red) where cos θ > 0, black elsewhere.
        let (w, h) = (64u32, 16u32);
        let img = RgbImage::from_fn(w, h, |x, _| {
            let th = std::f64::consts::TAU * (f64::from(x) + 0.5) / 8.0;
            if th.cos() > 0.0 {
                image::Rgb([200, 40, 40])
            } else {
                image::Rgb([20, 20, 20])
            }
        });
        let g = Geometry::new(w as usize, h as usize, 1, 1.0 / 8.0, 0.0);
        let theta: Vec<u16> = (0..w * h)
            .map(|i| ((f64::from(i % w) + 0.5) / 8.0 * 65_536.0).round() as i64 as u16)
            .collect();
        let lin = linear_q16();
        let (blocks, inside) =
            accumulate(&img, &g, |i| theta[i], &vec![true; theta.len()], None, &lin);
        assert_eq!(inside, Sums::default());
        for b in &blocks {
            assert!(b.enough());
            let (c, k) = b.means();
            assert!((c[0] - super::super::lab::srgb_to_linear(200.0 / 255.0)).abs() < 1e-3);
            assert!((k[0] - super::super::lab::srgb_to_linear(20.0 / 255.0)).abs() < 1e-3);
        }
    }
}
