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

/// Marks the linear value of code 255 in [`linear_q16`]: a saturated channel, whose pixel
/// is left out. Above any linear value (≤ 2¹⁶), and three marked values still fit 32 bits.
pub const SATURATED: u32 = 1 << 24;

/// Linear light of an 8-bit sRGB code, Q16 (65 536 = 1.0): fine enough that the darkest
/// codes of the black stripes keep three significant digits. Code 255 also carries
/// [`SATURATED`].
pub fn linear_q16() -> [u32; 256] {
    let mut t = linear_table().map(|v| (v * 65_536.0).round() as u32);
    t[255] |= SATURATED;
    t
}

/// Colour sums of one block (or of the contact region), linear Q16 (64-bit sums: a contact
/// region may hold 10⁵ samples). Index 0 is the coloured stripes, 1 the black.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Sums {
    /// Σ linear R, G, B over stripe centres, per population.
    pub sum: [[u64; 3]; 2],
    /// Samples per population.
    pub n: [u32; 2],
}

impl Sums {
    /// Fewest samples of each population for a block to be measured.
    pub const MIN_SAMPLES: u32 = 4;

    /// Whether both populations were seen often enough.
    pub fn enough(&self) -> bool {
        self.n[0] >= Self::MIN_SAMPLES && self.n[1] >= Self::MIN_SAMPLES
    }

    /// Adds another block's sums.
    pub fn add(&mut self, o: &Sums) {
        for p in 0..2 {
            for k in 0..3 {
                self.sum[p][k] += o.sum[p][k];
            }
            self.n[p] += o.n[p];
        }
    }

    /// Mean linear colours (coloured, black), 0…1.
    pub fn means(&self) -> ([f64; 3], [f64; 3]) {
        let m = |p: usize| self.sum[p].map(|v| v as f64 / 65_536.0 / f64::from(self.n[p].max(1)));
        (m(0), m(1))
    }
}

/// Where a working pixel lies relative to the contact, for [`accumulate`].
pub mod region {
    /// Not in the contact region.
    pub const NONE: u8 = 0;
    /// In the contact region.
    pub const CONTACT: u8 = 1;
    /// In the contact region's core.
    pub const CORE: u8 = 2;
}

/// Population of a phase (units ≫ 6): 0 coloured, 1 black, 2 neither (near an edge).
fn class_table() -> [u8; 1024] {
    std::array::from_fn(|k| {
        let t = i32::from(((k as u32) << 6) as u16 as i16);
        if t.abs() < KEEP_UNITS {
            0
        } else if t.abs() >= 32_768 - KEEP_UNITS {
            1
        } else {
            2
        }
    })
}

/// A phase at a stripe edge (a quarter turn from either centre): what [`class_table`] never
/// keeps.
const EDGE_UNITS: u16 = 16_384;

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
    /// Phase of every input pixel (row-major, `factor × factor`) of a working pixel,
    /// relative to its centre; units. The contact region is read at full density.
    pub offsets_all: Vec<i32>,
    /// Working rows advanced between the rows a block reads: a third of a block, so every
    /// block reads three rows (the black stripes are pooled over nine blocks anyway).
    pub row_step: usize,
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
        let at = |kx: f64, ky: f64| {
            units(f64::from(fx) / f as f64 * (kx - c) + f64::from(fy) / f as f64 * ky)
        };
        let offsets = (0..f).map(|k| at(k as f64, row)).collect();
        let offsets_all = (0..f * f)
            .map(|k| at((k % f) as f64, (k / f) as f64 - c))
            .collect();
        Geometry {
            w,
            h,
            factor: f,
            block_px,
            bw: w.div_ceil(block_px),
            bh: h.div_ceil(block_px),
            offsets,
            offsets_all,
            row_step: (block_px / 3).max(1),
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

/// Sums colours per block, and over the contact region and its core (`regions`, one
/// [`region`] code per working pixel). `theta(y, row)` fills `row` with the frame's grating
/// phase along working row `y`, units; only working pixels where `reliable` (the FTP trusted their phase: away
/// from the image edge, with fringe contrast) are read, since elsewhere the stripes cannot
/// be told apart. Blocks read one input row of every [`Geometry::row_step`]-th working row;
/// the contact region, small and what a user asks about most, reads every input pixel.
pub fn accumulate(
    frame: &RgbImage,
    g: &Geometry,
    theta: impl FnMut(usize, &mut [u16]),
    reliable: &[bool],
    regions: Option<&[u8]>,
    lin: &[u32; 256],
) -> (Vec<Sums>, [Sums; 2]) {
    // The inner loop is specialised for the common factors, so it unrolls.
    match (g.factor, regions) {
        (1, None) => run::<1, false>(frame, g, theta, reliable, &[], lin),
        (2, None) => run::<2, false>(frame, g, theta, reliable, &[], lin),
        (3, None) => run::<3, false>(frame, g, theta, reliable, &[], lin),
        (4, None) => run::<4, false>(frame, g, theta, reliable, &[], lin),
        (1, Some(r)) => run::<1, true>(frame, g, theta, reliable, r, lin),
        (2, Some(r)) => run::<2, true>(frame, g, theta, reliable, r, lin),
        (3, Some(r)) => run::<3, true>(frame, g, theta, reliable, r, lin),
        (4, Some(r)) => run::<4, true>(frame, g, theta, reliable, r, lin),
        (_, None) => run::<0, false>(frame, g, theta, reliable, &[], lin),
        (_, Some(r)) => run::<0, true>(frame, g, theta, reliable, r, lin),
    }
}

/// [`accumulate`] for factor `F` (0: any, read from `g`), with or without contact regions.
fn run<const F: usize, const REGIONS: bool>(
    frame: &RgbImage,
    g: &Geometry,
    theta: impl FnMut(usize, &mut [u16]),
    reliable: &[bool],
    regions: &[u8],
    lin: &[u32; 256],
) -> (Vec<Sums>, [Sums; 2]) {
    let f = if F == 0 { g.factor } else { F };
    let mut theta = theta;
    let mut trow = vec![0u16; g.w];
    let mut blocks = vec![Sums::default(); g.bw * g.bh];
    let mut contact = [Sums::default(); 2];
    let class = class_table();
    let offsets: Vec<u16> = g.offsets.iter().map(|&o| o as u16).collect();
    let width = frame.width() as usize;
    let raw: &[u8] = frame.as_raw();
    let offsets_all: Vec<u16> = g.offsets_all.iter().map(|&o| o as u16).collect();
    let f3 = 3 * f;
    let stride = width * 3;
    let mut tin = vec![0u16; g.w * f];
    for yw in 0..g.h {
        let on_grid = yw % g.row_step == 0;
        let row = yw * g.w..(yw + 1) * g.w;
        // The row's stretch of contact region, if any.
        let (rx0, rx1) = if REGIONS {
            let r = &regions[row.clone()];
            match r.iter().position(|&v| v != region::NONE) {
                Some(a) => (
                    a,
                    r.len() - r.iter().rev().take_while(|&&v| v == region::NONE).count(),
                ),
                None => (0, 0),
            }
        } else {
            (0, 0)
        };
        if !on_grid && rx1 == rx0 {
            continue;
        }
        theta(yw, &mut trow);
        let rel = &reliable[row.clone()];
        if on_grid {
            // The sampled input row's phases; an unreliable working pixel's inputs get a
            // stripe edge's phase, so the pixel loop has no other test.
            for ((tk, &t0), &ok) in tin.chunks_exact_mut(f).zip(&trow).zip(rel) {
                for (t, &o) in tk.iter_mut().zip(&offsets) {
                    *t = if ok { t0.wrapping_add(o) } else { EDGE_UNITS };
                }
            }
            let y = yw * f + f / 2;
            let (line, _) = raw[y * stride..y * stride + g.w * f3].as_chunks::<3>();
            let brow = &mut blocks[(yw / g.block_px) * g.bw..(yw / g.block_px + 1) * g.bw];
            // Block by block along the row: no division per pixel, and 32-bit sums (a
            // block row holds at most 16 · 8 samples of ≤ 2¹⁶).
            for (bx, acc) in brow.iter_mut().enumerate() {
                let x0 = bx * g.block_px * f;
                let x1 = (x0 + g.block_px * f).min(g.w * f);
                let mut part = Part::default();
                for (p, &t) in line[x0..x1].iter().zip(&tin[x0..x1]) {
                    part.sample(&class, lin, t, p);
                }
                part.add_to(acc);
            }
        }
        // Every input pixel of the row's contact working pixels.
        for xw in (rx0..rx1).filter(|&x| rel[x]) {
            let reg = regions[row.start + xw];
            if reg == region::NONE {
                continue;
            }
            let t0 = trow[xw];
            let mut part = Part::default();
            for ky in 0..f {
                let base = (yw * f + ky) * stride + xw * f3;
                let (px, _) = raw[base..base + f3].as_chunks::<3>();
                let offs = &offsets_all[ky * f..(ky + 1) * f];
                for (p, &o) in px.iter().zip(offs) {
                    part.sample(&class, lin, t0.wrapping_add(o), p);
                }
            }
            part.add_to(&mut contact[0]);
            if reg == region::CORE {
                part.add_to(&mut contact[1]);
            }
        }
    }
    (blocks, contact)
}

/// A few samples' sums in 32 bits (linear R, G, B and the count, per population), added
/// to a [`Sums`] at the end.
#[derive(Default)]
struct Part([[u32; 4]; 2]);

impl Part {
    /// One input pixel `p` (sRGB bytes) at grating phase `t` (units): skipped at a stripe
    /// edge (before any colour is read: half the pixels) or with a saturated channel
    /// ([`SATURATED`] in its linear value).
    #[inline(always)]
    fn sample(&mut self, class: &[u8; 1024], lin: &[u32; 256], t: u16, p: &[u8; 3]) {
        let pop = usize::from(class[usize::from(t >> 6)]);
        if pop > 1 {
            return;
        }
        let (r, g, b) = (
            lin[usize::from(p[0])],
            lin[usize::from(p[1])],
            lin[usize::from(p[2])],
        );
        if (r | g | b) & SATURATED != 0 {
            return;
        }
        let s = &mut self.0[pop];
        s[0] += r;
        s[1] += g;
        s[2] += b;
        s[3] += 1;
    }

    fn add_to(&self, acc: &mut Sums) {
        for p in 0..2 {
            for k in 0..3 {
                acc.sum[p][k] += u64::from(self.0[p][k]);
            }
            acc.n[p] += self.0[p][3];
        }
    }
}

/// Block (`bx`, `by`)'s sums pooled with its neighbours within `r` blocks (a (2r+1)²
/// window, clipped at the edges).
pub fn pool_at(blocks: &[Sums], bw: usize, bh: usize, bx: usize, by: usize, r: usize) -> Sums {
    let mut o = Sums::default();
    for y in by.saturating_sub(r)..(by + r + 1).min(bh) {
        for x in bx.saturating_sub(r)..(bx + r + 1).min(bw) {
            o.add(&blocks[y * bw + x]);
        }
    }
    o
}

/// Each block's sums pooled with its neighbours within `r` blocks (a (2r+1)² window,
/// clipped at the edges).
pub fn pool(blocks: &[Sums], bw: usize, bh: usize, r: usize) -> Vec<Sums> {
    (0..bw * bh)
        .map(|b| pool_at(blocks, bw, bh, b % bw, b / bw, r))
        .collect()
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

    /// Any factor, with or without a contact region (the specialised and the general loop
    /// read the same pixels).
    #[test]
    fn every_factor_reads_the_same_stripes() {
        let img = RgbImage::from_fn(200, 100, |x, _| {
            if (f64::from(x) * std::f64::consts::TAU / 20.0).cos() > 0.0 {
                image::Rgb([180, 60, 60])
            } else {
                image::Rgb([30, 30, 30])
            }
        });
        let lin = linear_q16();
        for f in 1..=6 {
            let (w, h) = (200 / f, 100 / f);
            let g = Geometry::new(w, h, f, f as f32 / 20.0, 0.0);
            let theta = |_: usize, row: &mut [u16]| {
                for (xw, t) in row.iter_mut().enumerate() {
                    let x = xw as f64 * f as f64 + (f as f64 - 1.0) / 2.0 + 0.5;
                    *t = (x / 20.0 * 65_536.0).round() as i64 as u16;
                }
            };
            let rel = vec![true; w * h];
            let regions = vec![region::CONTACT; w * h];
            let (plain, none) = accumulate(&img, &g, theta, &rel, None, &lin);
            let (with, contact) = accumulate(&img, &g, theta, &rel, Some(&regions), &lin);
            assert_eq!(plain, with, "factor {f}");
            assert_eq!(none, [Sums::default(); 2]);
            assert!(contact[0].n[0] > 0 && contact[0].n[1] > 0, "factor {f}");
        }
    }

    /// The block loop against a plain reading of its rule, pixel by pixel, on a frame of
    /// random colours (saturated channels included), phases, reliability and regions.
    #[test]
    fn block_and_contact_sums_follow_the_rule_pixel_by_pixel() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        let lin = linear_q16();
        for f in [1usize, 2, 3, 5] {
            let (w, h) = (37usize, 29usize);
            let img = RgbImage::from_fn((w * f + 1) as u32, (h * f + 2) as u32, |_, _| {
                let v = next();
                // One channel in eight saturated.
                let c = |s: u32| {
                    if (v >> (s + 8)) & 7 == 0 {
                        255
                    } else {
                        (v >> s) as u8
                    }
                };
                image::Rgb([c(0), c(16), c(32)])
            });
            let g = Geometry::new(w, h, f, 0.11 * f as f32, 0.03 * f as f32);
            let theta: Vec<u16> = (0..w * h).map(|_| next() as u16).collect();
            let rel: Vec<bool> = (0..w * h).map(|_| next() % 5 != 0).collect();
            let regions: Vec<u8> = (0..w * h)
                .map(|i| {
                    if (i % w) > 20 {
                        (next() % 3) as u8
                    } else {
                        region::NONE
                    }
                })
                .collect();
            let (blocks, contact) = accumulate(
                &img,
                &g,
                |y, row: &mut [u16]| row.copy_from_slice(&theta[y * w..(y + 1) * w]),
                &rel,
                Some(&regions),
                &lin,
            );
            let mut want = vec![Sums::default(); g.bw * g.bh];
            let mut want_contact = [Sums::default(); 2];
            let read = |x: usize, y: usize, t: i32, s: &mut Sums| {
                let p = img.get_pixel(x as u32, y as u32).0;
                // Classified in steps of 64 units, as the table does.
                let t = i32::from((t as u16 & !63) as i16).abs();
                if p.contains(&255) {
                    return;
                }
                let pop = if t < KEEP_UNITS {
                    0
                } else if t >= 32_768 - KEEP_UNITS {
                    1
                } else {
                    return;
                };
                for k in 0..3 {
                    s.sum[pop][k] += u64::from(lin[usize::from(p[k])]);
                }
                s.n[pop] += 1;
            };
            for yw in 0..h {
                for xw in (0..w).filter(|&x| rel[yw * w + x]) {
                    let t0 = i32::from(theta[yw * w + xw]);
                    if yw % g.row_step == 0 {
                        let b = &mut want[(yw / g.block_px) * g.bw + xw / g.block_px];
                        for k in 0..f {
                            read(xw * f + k, yw * f + f / 2, t0 + g.offsets[k], b);
                        }
                    }
                    let reg = regions[yw * w + xw];
                    for k in (0..f * f).filter(|_| reg != region::NONE) {
                        let (x, y) = (xw * f + k % f, yw * f + k / f);
                        read(x, y, t0 + g.offsets_all[k], &mut want_contact[0]);
                        if reg == region::CORE {
                            read(x, y, t0 + g.offsets_all[k], &mut want_contact[1]);
                        }
                    }
                }
            }
            for (i, (a, b)) in blocks.iter().zip(&want).enumerate() {
                assert_eq!(
                    a, b,
                    "factor {f} block {i} of {}x{} bp {}",
                    g.bw, g.bh, g.block_px
                );
            }
            assert_eq!(contact, want_contact, "factor {f}");
            assert!(contact[1].n[0] > 0 && want.iter().any(|b| b.n[1] > 0));
        }
    }

    #[test]
    fn pooling_sums_the_neighbourhood() {
        let one = Sums {
            sum: [[1, 2, 3], [4, 5, 6]],
            n: [1, 2],
        };
        let p = pool(&vec![one; 12], 4, 3, 1);
        assert_eq!(p[0].n[0], 4); // corner: 2 × 2
        assert_eq!(p[5].n[0], 9); // inside: 3 × 3
        assert_eq!(p[5].sum[1], [36, 45, 54]);
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
        let (blocks, inside) = accumulate(
            &img,
            &g,
            |y, row: &mut [u16]| row.copy_from_slice(&theta[y * row.len()..(y + 1) * row.len()]),
            &vec![true; theta.len()],
            None,
            &lin,
        );
        assert_eq!(inside, [Sums::default(); 2]);
        for b in &blocks {
            assert!(b.enough());
            let (c, k) = b.means();
            assert!((c[0] - super::super::lab::srgb_to_linear(200.0 / 255.0)).abs() < 1e-3);
            assert!((k[0] - super::super::lab::srgb_to_linear(20.0 / 255.0)).abs() < 1e-3);
        }
    }
}
