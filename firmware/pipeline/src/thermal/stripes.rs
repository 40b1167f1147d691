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
//!
//! The contact region, where a user reads the temperature of what touches the skin, is read
//! at every input pixel and at the frame's local grating: each input pixel's phase follows
//! the local phase gradient, and where the indentation squeezes the stripes the kept band
//! narrows so it stays as far from the stripe edges in pixels as on flat skin
//! (`keep_units`).

use crate::input::Pixels;

use super::lab::{linear_table, Invariants};
use super::trend::Trend;

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
    /// Samples per population left out because a channel was saturated.
    pub clipped: [u32; 2],
}

impl Sums {
    /// Fewest samples of each population for a block to be measured.
    pub const MIN_SAMPLES: u32 = 4;

    /// A region is clipped when saturation took more than this share (1/64) of either
    /// population's samples ([`Sums::clipped`]).
    pub const CLIPPED_SHARE_LOG2: u32 = 6;

    /// Whether both populations were seen often enough.
    pub fn enough(&self) -> bool {
        self.n[0] >= Self::MIN_SAMPLES && self.n[1] >= Self::MIN_SAMPLES
    }

    /// Whether the camera clipped enough of these stripes (more than 1/64 of either
    /// population's samples, [`Sums::CLIPPED_SHARE_LOG2`]) that their mean colour is not
    /// the skin's: a saturated sample is left out, and what is left is the darker part of
    /// a distribution whose top was cut, so a region near full scale reads darker than it
    /// is. Where the coloured stripes have cleared (above their transition) the reading
    /// hangs on a per cent of the stripes' ratio, and a cut top moves it by degrees.
    pub fn is_clipped(&self) -> bool {
        (0..2).any(|p| {
            let seen = u64::from(self.n[p]) + u64::from(self.clipped[p]);
            u64::from(self.clipped[p]) << Self::CLIPPED_SHARE_LOG2 > seen
        })
    }

    /// Adds another block's sums.
    pub fn add(&mut self, o: &Sums) {
        for p in 0..2 {
            for k in 0..3 {
                self.sum[p][k] += o.sum[p][k];
            }
            self.n[p] += o.n[p];
            self.clipped[p] += o.clipped[p];
        }
    }

    /// Mean linear colours (coloured, black), 0…1.
    pub fn means(&self) -> ([f64; 3], [f64; 3]) {
        let m = |p: usize| self.sum[p].map(|v| v as f64 / 65_536.0 / f64::from(self.n[p].max(1)));
        (m(0), m(1))
    }

    /// The colour invariants of these stripes, the coloured chromaticity measured against
    /// the black stripes of `white` ([`Invariants::from_linear`]); `None` when either holds
    /// too few samples or a channel is black.
    pub fn invariants(&self, white: &Sums) -> Option<Invariants> {
        if !self.enough() || !white.enough() {
            return None;
        }
        let (c, k) = self.means();
        Invariants::from_linear(c, k, white.means().1)
    }
}

/// The contact region's sums and its core's (index 0 the region, 1 the core), with their
/// samples' spatial moments ([`Trend`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Contact {
    /// Colour sums of the region and of its core.
    pub sums: [Sums; 2],
    /// The same samples' moments.
    pub trends: [Trend; 2],
}

impl Contact {
    /// The region's and the core's sums, each read at the midpoint of its two populations'
    /// centroids: each population's channels scaled by its factor ([`Trend::factors`]),
    /// unchanged where the trend declines.
    pub fn levelled(&self) -> [Sums; 2] {
        let mut sums = self.sums;
        for (s, t) in sums.iter_mut().zip(&self.trends) {
            let Some(factors) = t.factors() else {
                continue;
            };
            for (channels, f) in s.sum.iter_mut().zip(factors) {
                for v in channels.iter_mut() {
                    *v = (*v as f64 * f).round() as u64;
                }
            }
        }
        sums
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

/// The contact region and its core as [`region`] codes over a box of working pixels (the
/// contact window; [`region::NONE`] outside it), so rows and columns away from the contact
/// cost nothing.
#[derive(Debug, Clone, Copy, Default)]
pub struct Regions<'a> {
    codes: &'a [u8],
    x0: usize,
    y0: usize,
    w: usize,
}

impl<'a> Regions<'a> {
    /// `codes`, `w` to a row, for the box whose top-left working pixel is (`x0`, `y0`); a
    /// last partial row is ignored.
    pub fn new(codes: &'a [u8], x0: usize, y0: usize, w: usize) -> Regions<'a> {
        Regions { codes, x0, y0, w }
    }

    /// The box's rows as (working row, column of the first code, codes).
    pub fn rows(&self) -> impl Iterator<Item = (usize, usize, &'a [u8])> + '_ {
        let rows = self.codes.len().checked_div(self.w).unwrap_or(0);
        (self.y0..self.y0 + rows).map(|y| {
            let (x0, codes) = self.row(y);
            (y, x0, codes)
        })
    }

    /// The centre of the region (every pixel coded), working pixels; `None` when empty.
    pub fn centre(&self) -> Option<(f32, f32)> {
        let (mut n, mut sx, mut sy) = (0u32, 0f32, 0f32);
        for (y, x0, codes) in self.rows() {
            for (i, _) in codes.iter().enumerate().filter(|(_, &c)| c != 0) {
                n += 1;
                sx += (x0 + i) as f32;
                sy += y as f32;
            }
        }
        (n > 0).then(|| (sx / n as f32 + 0.5, sy / n as f32 + 0.5))
    }

    /// Whether working pixel (`x`, `y`) lies in the region (core included).
    pub fn contains(&self, (x, y): (usize, usize)) -> bool {
        let (x0, codes) = self.row(y);
        x.checked_sub(x0)
            .and_then(|i| codes.get(i))
            .is_some_and(|&c| c != region::NONE)
    }

    /// Working row `y`'s codes and the column of the first; empty outside the box.
    fn row(&self, y: usize) -> (usize, &'a [u8]) {
        let w = self.w;
        let codes = y
            .checked_sub(self.y0)
            .and_then(|r| self.codes.get(r * w..(r + 1) * w))
            .unwrap_or(&[]);
        (self.x0, codes)
    }
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
    /// Working rows advanced between the rows a block reads: a third of a block, rounded
    /// down (the black stripes are pooled over nine blocks anyway). The rows are every
    /// `row_step`-th of the image, so a block reads three of them when its side is a
    /// multiple of three, and three to five otherwise.
    pub row_step: usize,
    /// The reference carrier's phase advance per working pixel across and down, units: the
    /// contact region reads its local grating against it (`gradient`, `keep_units`).
    pub carrier_units: [i32; 2],
    /// Each colour's grating phase against the one the stripes are placed by, per working
    /// pixel, units, where the lens puts the colours apart ([`crate::ftp::lateral`]): each
    /// colour's samples are then placed by their own stripes.
    pub colour_units: Option<[Vec<i16>; 3]>,
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
        Geometry {
            w,
            h,
            factor: f,
            block_px,
            bw: w.div_ceil(block_px),
            bh: h.div_ceil(block_px),
            offsets,
            row_step: (block_px / 3).max(1),
            carrier_units: [units(f64::from(fx)), units(f64::from(fy))],
            colour_units: None,
        }
    }

    /// The same geometry with each colour placed by its own stripes, `offsets_rad(k, x, y)`
    /// being colour `k`'s grating phase at working pixel (x, y) against the placing one.
    pub fn with_colour_offsets(mut self, offsets_rad: impl Fn(usize, f64, f64) -> f64) -> Geometry {
        let units = |v: f64| (v / std::f64::consts::TAU * 65_536.0).round() as i16;
        let (w, h) = (self.w, self.h);
        self.colour_units = Some(std::array::from_fn(|k| {
            (0..w * h)
                .map(|i| units(offsets_rad(k, (i % w) as f64, (i / w) as f64)))
                .collect()
        }));
        self
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

/// Sums colours per block, and over the contact region and its core (`regions`).
/// `theta(y, row)` fills `row` with the frame's grating phase along working row `y`,
/// units; only working pixels where `reliable` (the FTP trusted their phase: away from the
/// image edge, with fringe contrast) are read, since elsewhere the stripes cannot be told
/// apart. Blocks read one input row of every [`Geometry::row_step`]-th working row; the
/// contact region, small and what a user asks about most, reads every input pixel, at its
/// local grating (`local_phases`, `keep_units`).
pub fn accumulate(
    frame: Pixels<'_>,
    g: &Geometry,
    theta: impl FnMut(usize, &mut [u16]),
    reliable: &[bool],
    regions: Option<Regions<'_>>,
    lin: &[u32; 256],
) -> (Vec<Sums>, Contact) {
    let regions = regions.unwrap_or_default();
    // The inner loop is specialised for the common factors, so it unrolls.
    match g.factor {
        1 => run::<1>(frame, g, theta, reliable, regions, lin),
        2 => run::<2>(frame, g, theta, reliable, regions, lin),
        3 => run::<3>(frame, g, theta, reliable, regions, lin),
        4 => run::<4>(frame, g, theta, reliable, regions, lin),
        _ => run::<0>(frame, g, theta, reliable, regions, lin),
    }
}

/// [`accumulate`] for factor `F` (0: any, read from `g`).
fn run<const F: usize>(
    frame: Pixels<'_>,
    g: &Geometry,
    mut theta: impl FnMut(usize, &mut [u16]),
    reliable: &[bool],
    regions: Regions<'_>,
    lin: &[u32; 256],
) -> (Vec<Sums>, Contact) {
    let f = if F == 0 { g.factor } else { F };
    // Rows of the frame's phase, row y in slot y mod 3: a contact row reads its neighbours
    // above and below, each computed once.
    let mut rows = [vec![0u16; g.w], vec![0u16; g.w], vec![0u16; g.w]];
    let mut rows_at = [usize::MAX; 3];
    let mut fill = |y: usize, rows: &mut [Vec<u16>; 3]| {
        if rows_at[y % 3] != y {
            theta(y, &mut rows[y % 3]);
            rows_at[y % 3] = y;
        }
    };
    // A row of blocks sums in 32 bits (a block reads at most five rows of 16 working pixels
    // of at most eight input pixels each, 640 samples of ≤ 2¹⁶), and is added to the
    // blocks' sums when the next begins.
    let mut blocks: Vec<Sums> = Vec::with_capacity(g.bw * g.bh);
    // One row of parts, of the kind the geometry asks for: colours placed together, or apart.
    let apart = g.colour_units.is_some();
    let mut parts = vec![Part::default(); if apart { 0 } else { g.bw }];
    let mut apart_parts = vec![Part::<Apart>::default(); if apart { g.bw } else { 0 }];
    fn flush<C: Counts>(parts: &mut [Part<C>], blocks: &mut Vec<Sums>) {
        blocks.extend(parts.iter_mut().map(|p| {
            let mut s = Sums::default();
            p.add_to(&mut s);
            *p = Part::default();
            s
        }));
    }
    let mut contact = Contact::default();
    let class = &class_table();
    // Each input pixel's phase offset from its working pixel's, padded to the largest factor
    // so that for a specialised factor the slice has a length the compiler knows.
    let mut offsets = [0u16; 8];
    for (o, &v) in offsets.iter_mut().zip(&g.offsets) {
        *o = v as u16;
    }
    // Where the frame is not RGB, the rows read are converted into these first.
    let (mut line_buf, mut contact_buf) = (Vec::new(), Vec::new());
    for yw in 0..g.h {
        if yw > 0 && yw % g.block_px == 0 {
            if apart {
                flush(&mut apart_parts, &mut blocks);
            } else {
                flush(&mut parts, &mut blocks);
            }
        }
        let on_grid = yw % g.row_step == 0;
        let row = yw * g.w..(yw + 1) * g.w;
        // The row's stretch of contact region, if any.
        let (cx0, codes) = regions.row(yw);
        let (a, b) = extent(codes);
        let (rx0, rx1) = ((cx0 + a).min(g.w), (cx0 + b).min(g.w));
        if !on_grid && rx1 == rx0 {
            continue;
        }
        let (ya, yb) = (yw.saturating_sub(1), (yw + 1).min(g.h - 1));
        fill(yw, &mut rows);
        if rx1 > rx0 {
            fill(ya, &mut rows);
            fill(yb, &mut rows);
        }
        let (up, trow, down) = (&rows[ya % 3], &rows[yw % 3], &rows[yb % 3]);
        let rel = &reliable[row.clone()];
        if on_grid {
            let y = yw * f + f / 2;
            let (line, _) = frame.rgb_row(y, 0, g.w * f, &mut line_buf).as_chunks::<3>();
            let row = BlockRow {
                line,
                theta: trow,
                reliable: rel,
                block_px: g.block_px,
                offsets,
                factor: f,
            };
            // Most rows hold no saturated byte, which their maximum (a loop the compiler
            // vectorises) tells; their samples then skip the test (colours placed apart
            // test every sample).
            let saturates = line.as_flattened().iter().fold(0u8, |m, &b| m.max(b)) == 255;
            if let Some(c) = &g.colour_units {
                row.add_per_colour::<F>(
                    &mut apart_parts,
                    class,
                    lin,
                    colour_row(c, yw * g.w..(yw + 1) * g.w),
                );
            } else if saturates {
                row.add_to::<F, true>(&mut parts, class, lin);
            } else {
                row.add_to::<F, false>(&mut parts, class, lin);
            }
        }
        if rx1 > rx0 {
            let pixels =
                ContactPixels::read(frame, yw * f, f, (rx0 * f, rx1 * f), &mut contact_buf);
            let row = ContactRow {
                pixels,
                up,
                theta: trow,
                down,
                ny: yb - ya,
                reliable: rel,
                codes,
                cx0,
                span: (rx0, rx1),
                carrier: g.carrier_units,
                y_px: yw * f,
                colours: g
                    .colour_units
                    .as_ref()
                    .map(|c| colour_row(c, yw * g.w..(yw + 1) * g.w)),
            };
            row.add_to::<F>(f, lin, &mut contact);
        }
    }
    if g.h > 0 {
        flush(&mut parts, &mut blocks);
        flush(&mut apart_parts, &mut blocks);
    }
    (blocks, contact)
}

/// Each colour's offsets (`c`, [`Geometry::colour_units`]) along one working row.
fn colour_row(c: &[Vec<i16>; 3], row: std::ops::Range<usize>) -> [&[i16]; 3] {
    [&c[0][row.clone()], &c[1][row.clone()], &c[2][row]]
}

/// The input pixels of one working row's contact stretch, as sRGB.
struct ContactPixels<'a> {
    /// Rows of sRGB bytes, `stride` bytes apart.
    bytes: &'a [u8],
    stride: usize,
    /// The input row of the working row's first row in `bytes`, and the input column of
    /// its first column.
    y0: usize,
    x0: usize,
}

impl<'a> ContactPixels<'a> {
    /// Input rows `y0..y0 + f`, columns `x0..x1`: the frame itself when it is RGB, else
    /// those pixels converted into `buf`.
    fn read(
        frame: Pixels<'a>,
        y0: usize,
        f: usize,
        (x0, x1): (usize, usize),
        buf: &'a mut Vec<u8>,
    ) -> ContactPixels<'a> {
        if frame.colour() == crate::input::Colour::Rgb {
            return ContactPixels {
                bytes: frame.raw(),
                stride: frame.width() as usize * 3,
                y0,
                x0: 0,
            };
        }
        buf.clear();
        for y in y0..y0 + f {
            frame.append_rgb(y, x0, x1, buf);
        }
        ContactPixels {
            bytes: buf,
            stride: (x1.min(frame.width() as usize) - x0) * 3,
            y0: 0,
            x0,
        }
    }

    /// `n` pixels of input row `y0 + ky` (of the working row) from input column `x`.
    fn run(&self, ky: usize, x: usize, n: usize) -> &'a [[u8; 3]] {
        let base = (self.y0 + ky) * self.stride + (x - self.x0) * 3;
        self.bytes[base..base + 3 * n].as_chunks::<3>().0
    }
}

/// One working row of the contact region.
struct ContactRow<'a> {
    /// The row's input pixels.
    pixels: ContactPixels<'a>,
    /// The frame's grating phase along the working rows above, this one and below, units.
    up: &'a [u16],
    theta: &'a [u16],
    down: &'a [u16],
    /// Working rows between `up` and `down` (2, or 1 at the image's top and bottom).
    ny: usize,
    /// Whether the FTP trusted each working pixel's phase.
    reliable: &'a [bool],
    /// The row's region codes, from working column `cx0`.
    codes: &'a [u8],
    cx0: usize,
    /// The working columns that hold the row's contact region.
    span: (usize, usize),
    /// The reference carrier's advance per working pixel across and down, units.
    carrier: [i32; 2],
    /// The input row of the working row's first row.
    y_px: usize,
    /// Each colour's offset along the row, units, where colours are placed apart
    /// ([`Geometry::colour_units`]).
    colours: Option<[&'a [i16]; 3]>,
}

impl ContactRow<'_> {
    /// Adds every input pixel of the row's contact working pixels to the contact region's
    /// sums (`contact`: the region, its core), at the frame's own local grating (see
    /// `local_phases` and `keep_units`): summed over the row in 32 bits (the core, and the
    /// rest of the region) and added to the region's sums at its end, with each sample's
    /// place in the trends ([`Trend`]). `f` input pixels per working pixel each way (`F`
    /// when not 0).
    fn add_to<const F: usize>(&self, f: usize, lin: &[u32; 256], contact: &mut Contact) {
        if let Some(colours) = self.colours {
            return self.add_apart::<F>(f, lin, colours, contact);
        }
        self.add_with::<F, ()>(f, contact, |part, t, _, keep, p| {
            let pop = kept(t, keep)?;
            Some((pop, part.add::<true>(pop, lin, p)?))
        });
    }

    /// [`ContactRow::add_to`] with each colour placed by its own stripes (`colours`: each
    /// colour's offset along the row, units). Out of line: the frames of a unit whose
    /// colours agree never run it.
    #[inline(never)]
    fn add_apart<const F: usize>(
        &self,
        f: usize,
        lin: &[u32; 256],
        colours: [&[i16]; 3],
        contact: &mut Contact,
    ) {
        self.add_with::<F, Apart>(f, contact, |part, t, xw, keep, p| {
            let pops = colours.map(|c| kept(t.wrapping_add(c[xw] as u16), keep));
            part.add_per_colour(pops, lin, p)
        });
    }

    /// [`ContactRow::add_to`] with each input pixel `p` at phase `t` of working pixel `xw`
    /// and band `keep` added by `sample`, which returns its population and lightness for the
    /// trends when the pixel was added whole.
    #[inline(always)]
    fn add_with<const F: usize, C: Counts>(
        &self,
        f: usize,
        contact: &mut Contact,
        sample: impl Fn(&mut Part<C>, u16, usize, i32, &[u8; 3]) -> Option<(usize, u32)>,
    ) {
        let f = if F == 0 { f } else { F };
        let w = self.theta.len();
        let (x0, x1) = self.span;
        let mut parts = RowParts::<C>::default();
        let mut row_trends = [Trend::default(); 2];
        for xw in (x0..x1.min(w)).filter(|&x| self.reliable[x]) {
            let reg = self
                .codes
                .get(xw - self.cx0)
                .copied()
                .unwrap_or(region::NONE);
            if reg == region::NONE {
                continue;
            }
            let (xa, xb) = (xw.saturating_sub(1), (xw + 1).min(w - 1));
            let gx = gradient(self.theta[xa], self.theta[xb], xb - xa, self.carrier[0]);
            let gy = gradient(self.up[xw], self.down[xw], self.ny, self.carrier[1]);
            let keep = keep_units(gx, gy, self.carrier);
            let core = reg == region::CORE;
            let part = parts.part(core, f * f, &mut contact.sums);
            let trend = &mut row_trends[usize::from(core)];
            local_phases(self.theta[xw], gx, gy, f, |ky, ts| {
                let px = self.pixels.run(ky, xw * f, f);
                for (kx, (p, &t)) in px.iter().zip(ts).enumerate() {
                    if let Some((pop, l)) = sample(part, t, xw, keep, p) {
                        trend.add(pop, (xw * f + kx, self.y_px + ky), l);
                    }
                }
            });
        }
        parts.flush(&mut contact.sums);
        let [ring, core] = row_trends;
        contact.trends[0].add_all(&ring);
        contact.trends[0].add_all(&core);
        contact.trends[1].add_all(&core);
    }
}

/// A row's contact samples in 32 bits: the region outside its core, and the core.
#[derive(Default)]
struct RowParts<C: Counts = ()> {
    ring: Part<C>,
    core: Part<C>,
    /// Samples that may have been added since the last flush.
    held: usize,
}

impl<C: Counts> RowParts<C> {
    /// Most samples held before a flush: each adds at most 2¹⁶ to a 32-bit sum.
    const MAX_HELD: usize = 65_535;

    /// The part the next `n` samples of a working pixel go to (the core's when `core`),
    /// after adding what is held to `contact` (the region's sums and its core's) if they
    /// could overflow it.
    fn part(&mut self, core: bool, n: usize, contact: &mut [Sums; 2]) -> &mut Part<C> {
        if self.held + n > Self::MAX_HELD {
            self.flush(contact);
        }
        self.held += n;
        if core {
            &mut self.core
        } else {
            &mut self.ring
        }
    }

    /// Adds what is held to `contact` and empties the parts.
    fn flush(&mut self, contact: &mut [Sums; 2]) {
        if self.held > 0 {
            self.ring.add_to(&mut contact[0]);
            self.core.add_to(&mut contact[0]);
            self.core.add_to(&mut contact[1]);
            *self = RowParts::default();
        }
    }
}

/// The stretch `(first, one past the last)` of a row's region codes that are not
/// [`region::NONE`], `(0, 0)` when there is none. The codes cover the contact window only,
/// whose rows mostly start and end with a stretch of [`region::NONE`]: it is skipped 16
/// codes at a time.
fn extent(codes: &[u8]) -> (usize, usize) {
    const _: () = assert!(region::NONE == 0);
    let none = |c: &[u8; 16]| u128::from_ne_bytes(*c) == 0;
    let skip = codes
        .as_chunks::<16>()
        .0
        .iter()
        .take_while(|c| none(c))
        .count()
        * 16;
    let Some(a) = codes[skip..].iter().position(|&v| v != 0).map(|i| skip + i) else {
        return (0, 0);
    };
    let tail = &codes[a..];
    let skip = tail
        .as_rchunks::<16>()
        .1
        .iter()
        .rev()
        .take_while(|c| none(c))
        .count()
        * 16;
    let b = tail[..tail.len() - skip]
        .iter()
        .rposition(|&v| v != 0)
        .map_or(a, |i| a + i + 1);
    (a, b)
}

/// One sampled input row of a row of blocks.
struct BlockRow<'a> {
    /// The input row's pixels (sRGB), `f` per working pixel.
    line: &'a [[u8; 3]],
    /// The frame's grating phase per working pixel, units.
    theta: &'a [u16],
    /// Whether the FTP trusted each working pixel's phase.
    reliable: &'a [bool],
    block_px: usize,
    /// Each input pixel's phase offset from its working pixel's, units: the first `factor`
    /// (≤ 8), padded to the largest factor so that for a specialised factor the slice has
    /// a length the compiler knows.
    offsets: [u16; 8],
    /// Input pixels per working pixel.
    factor: usize,
}

impl BlockRow<'_> {
    /// Adds the row's samples to its blocks' sums (`blocks`, one per block across), block
    /// by block: no division per pixel. A working pixel's inputs at a time, at its phase
    /// plus their offsets (for the specialised factors `F` the inner loop unrolls); an
    /// unreliable working pixel is skipped whole. `CHECK`: whether a channel can be
    /// saturated.
    fn add_to<const F: usize, const CHECK: bool>(
        &self,
        blocks: &mut [Part],
        class: &[u8; 1024],
        lin: &[u32; 256],
    ) {
        let f = if F == 0 { self.factor.max(1) } else { F };
        let offsets = &self.offsets[..f.min(8)];
        let n = self.block_px.max(1);
        let blocks = blocks
            .iter_mut()
            .zip(self.line.chunks(n * f))
            .zip(self.theta.chunks(n))
            .zip(self.reliable.chunks(n));
        for (((part, line), theta), reliable) in blocks {
            for ((pk, &t0), _) in line
                .chunks_exact(f)
                .zip(theta)
                .zip(reliable)
                .filter(|(_, ok)| **ok)
            {
                for (p, &o) in pk.iter().zip(offsets) {
                    part.sample::<CHECK>(class, lin, t0.wrapping_add(o), p);
                }
            }
        }
    }
}

impl BlockRow<'_> {
    /// [`BlockRow::add_to`] with each colour placed by its own stripes: colour `k` of a
    /// working pixel's inputs at their phases plus `colours[k]` there (units). Kept out of
    /// line: the frames of a unit whose colours agree never run it.
    #[inline(never)]
    fn add_per_colour<const F: usize>(
        &self,
        blocks: &mut [Part<Apart>],
        class: &[u8; 1024],
        lin: &[u32; 256],
        colours: [&[i16]; 3],
    ) {
        let f = if F == 0 { self.factor.max(1) } else { F };
        let offsets = &self.offsets[..f.min(8)];
        let n = self.block_px.max(1);
        for (b, part) in blocks.iter_mut().enumerate() {
            let xs = b * n..((b + 1) * n).min(self.theta.len());
            for x in xs.filter(|&x| self.reliable[x]) {
                let Some(pk) = self.line.get(x * f..(x + 1) * f) else {
                    continue;
                };
                let shift = colours.map(|c| c[x] as u16);
                for (p, &o) in pk.iter().zip(offsets) {
                    let t = self.theta[x].wrapping_add(o);
                    let pops = shift.map(|e| match class[usize::from(t.wrapping_add(e) >> 6)] {
                        c @ 0..=1 => Some(usize::from(c)),
                        _ => None,
                    });
                    part.add_per_colour(pops, lin, p);
                }
            }
        }
    }
}

/// A few samples' sums in 32 bits (linear R, G, B, the count and the saturated samples
/// left out, per population), added to a [`Sums`] at the end, and what the placement keeps
/// besides ([`Counts`]: nothing, or each colour's count where colours are placed apart).
#[derive(Default, Clone, Copy)]
struct Part<C: Counts = ()>([[u32; 5]; 2], C);

/// What a [`Part`] keeps besides its sums, and how they are added to a [`Sums`].
trait Counts: Default + Copy {
    /// Adds `part`'s sums to `acc`.
    fn add_to(part: &Part<Self>, acc: &mut Sums);
}

/// Colours placed together: the count of each population is every colour's.
impl Counts for () {
    fn add_to(part: &Part<Self>, acc: &mut Sums) {
        for p in 0..2 {
            for k in 0..3 {
                acc.sum[p][k] += u64::from(part.0[p][k]);
            }
            acc.n[p] += part.0[p][3];
            acc.clipped[p] += part.0[p][4];
        }
    }
}

/// Colours placed apart: each colour's own count per population. The sums are brought to
/// one count when added: each colour's sum scaled to the largest colour count of its
/// population (a population a colour missed is left out whole).
type Apart = [[u32; 3]; 2];

impl Counts for Apart {
    fn add_to(part: &Part<Self>, acc: &mut Sums) {
        for p in 0..2 {
            let per_colour = part.1[p];
            let n = per_colour.iter().copied().max().unwrap_or(0);
            if per_colour.iter().all(|&c| c > 0) {
                let sums = acc.sum[p].iter_mut().zip(&part.0[p]).zip(&per_colour);
                for ((acc, &sum), &count) in sums {
                    *acc += u64::from(sum) * u64::from(n) / u64::from(count);
                }
                acc.n[p] += n;
            }
            acc.clipped[p] += part.0[p][4];
        }
    }
}

impl<C: Counts> Part<C> {
    /// One input pixel `p` (sRGB bytes) at grating phase `t` (units): skipped at a stripe
    /// edge (before any colour is read: half the pixels) or with a saturated channel
    /// ([`SATURATED`] in its linear value; `CHECK` false: the caller knows none is).
    #[inline(always)]
    fn sample<const CHECK: bool>(
        &mut self,
        class: &[u8; 1024],
        lin: &[u32; 256],
        t: u16,
        p: &[u8; 3],
    ) {
        let pop = usize::from(class[usize::from(t >> 6)]);
        if pop <= 1 {
            self.add::<CHECK>(pop, lin, p);
        }
    }

    /// One input pixel `p` of population `pop`, unless a channel is saturated (tested when
    /// `CHECK`); its lightness (the linear channels' sum) when it was added.
    #[inline(always)]
    fn add<const CHECK: bool>(&mut self, pop: usize, lin: &[u32; 256], p: &[u8; 3]) -> Option<u32> {
        let (r, g, b) = (
            lin[usize::from(p[0])],
            lin[usize::from(p[1])],
            lin[usize::from(p[2])],
        );
        if CHECK && (r | g | b) & SATURATED != 0 {
            self.0[pop][4] += 1;
            return None;
        }
        let s = &mut self.0[pop];
        s[0] += r;
        s[1] += g;
        s[2] += b;
        s[3] += 1;
        Some(r + g + b)
    }

    /// Adds these sums to `acc` ([`Counts::add_to`]).
    fn add_to(&self, acc: &mut Sums) {
        C::add_to(self, acc);
    }
}

impl Part<Apart> {
    /// One input pixel `p` whose colours lie in populations `pops` (each colour placed by
    /// its own stripes; `None`: near an edge), unless a channel is saturated (counted
    /// against green's population). Returns the population and the pixel's lightness when
    /// all three colours fell in the same one (the trends' samples).
    #[inline(always)]
    fn add_per_colour(
        &mut self,
        pops: [Option<usize>; 3],
        lin: &[u32; 256],
        p: &[u8; 3],
    ) -> Option<(usize, u32)> {
        let v = p.map(|c| lin[usize::from(c)]);
        if (v[0] | v[1] | v[2]) & SATURATED != 0 {
            if let Some(pop) = pops[1] {
                self.0[pop][4] += 1;
            }
            return None;
        }
        for ((pop, v), k) in pops.iter().zip(v).zip(0..3) {
            if let Some(pop) = *pop {
                self.0[pop][k] += v;
                self.1[pop][k] += 1;
            }
        }
        match pops {
            [Some(a), Some(b), Some(c)] if a == b && b == c => Some((a, v[0] + v[1] + v[2])),
            _ => None,
        }
    }
}

/// Phase advance per working pixel between two phases `n` working pixels apart, units:
/// the carrier's advance `c` (units per working pixel) plus the wrapped deviation from it,
/// so a period of a few working pixels (a forced downsampling), whose advance over two
/// pixels reaches half a turn, is not read the wrong way round.
fn gradient(a: u16, b: u16, n: usize, c: i32) -> i32 {
    let n = (n as i32).max(1);
    let deviation = b.wrapping_sub(a).wrapping_sub((c * n) as u16) as i16;
    c + i32::from(deviation) / n
}

/// The phases of a contact working pixel's `f × f` input pixels, into `row(ky, phases)`
/// one input row at a time: its own phase `t0` plus the local gradient (`gx`, `gy`, units
/// per working pixel, from its neighbours) times each input pixel's offset from its centre.
/// Under an indentation the stripes are squeezed or stretched by up to half their period,
/// which the reference carrier would not follow. Fixed point with 8 fraction bits, one
/// division per working pixel; `f` ≤ 8 (the largest downsampling factor).
fn local_phases(t0: u16, gx: i32, gy: i32, f: usize, mut row: impl FnMut(usize, &[u16])) {
    let f = f.clamp(1, 8);
    let fi = f as i32;
    let (sx, sy) = ((gx << 8) / fi, (gy << 8) / fi);
    let mut start = (i32::from(t0) << 8) - (fi - 1) * (sx + sy) / 2;
    let mut phases = [0u16; 8];
    let phases = &mut phases[..f];
    for ky in 0..f {
        let mut t = start;
        for p in phases.iter_mut() {
            *p = (t >> 8) as u16;
            t += sx;
        }
        row(ky, phases);
        start += sy;
    }
}

/// Half-width of the kept band around a stripe centre, units, for a local grating advancing
/// `gx`, `gy` units per working pixel against the reference's `carrier` (the same, across
/// and down). Where an
/// indentation squeezes the stripes by a ratio ρ, the band narrows so its edge stays as far
/// from the stripe's edge in pixels as [`KEEP_UNITS`] keeps it on flat skin: the optics'
/// blur, fixed in pixels, would otherwise mix the neighbouring stripes' colour into a
/// squeezed stripe's kept pixels (a coarse grating on a small camera read a heated
/// contact high through its black stripes). Where they are stretched it stays at
/// [`KEEP_UNITS`], the calibration's band. Never below 1/64 turn.
fn keep_units(gx: i32, gy: i32, carrier: [i32; 2]) -> i32 {
    const QUARTER: i64 = 16_384;
    let square = |x: i32, y: i32| i64::from(x).pow(2) + i64::from(y).pow(2);
    let (local2, carrier2) = (square(gx, gy), square(carrier[0], carrier[1]).max(1));
    if local2 <= carrier2 {
        return KEEP_UNITS;
    }
    // ρ in Q8, above 1; from ρ = 480/256 on the floor holds, so ρ² is clamped there and
    // the square root taken in 32 bits.
    const RHO_FLOOR2: i64 = 480 * 480;
    const _: () = assert!(QUARTER - (QUARTER - KEEP_UNITS as i64) * 480 / 256 == 1_024);
    let rho = i64::from((((local2 << 16) / carrier2).min(RHO_FLOOR2) as u32).isqrt());
    (QUARTER - (((QUARTER - i64::from(KEEP_UNITS)) * rho) >> 8)).max(1_024) as i32
}

/// The population whose centre phase `t` lies within `keep` units of: 0 coloured, 1 black.
/// The blocks' band is fixed and read from [`class_table`] (one look-up per pixel); this
/// is the same rule for the contact region's band, which changes from pixel to pixel.
fn kept(t: u16, keep: i32) -> Option<usize> {
    let a = i32::from(t as i16).abs();
    if a < keep {
        Some(0)
    } else if a >= 32_768 - keep {
        Some(1)
    } else {
        None
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
    use image::RgbImage;

    /// A region's box holds its codes from its origin: a pixel is in it where its code is
    /// not `NONE`, and nothing outside the box is.
    #[test]
    fn a_region_contains_its_coded_pixels_only() {
        let (c, k, o) = (region::CONTACT, region::CORE, region::NONE);
        let codes = [o, c, c, c, k, c];
        let r = Regions::new(&codes, 10, 20, 3);
        assert!(r.contains((11, 20)) && r.contains((11, 21)) && r.contains((12, 21)));
        assert!(!r.contains((10, 20)), "a NONE code inside the box");
        for outside in [(9, 20), (13, 20), (11, 19), (11, 22)] {
            assert!(!r.contains(outside), "{outside:?}");
        }
    }

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
            let (plain, none) = accumulate((&img).into(), &g, theta, &rel, None, &lin);
            let with_regions = Some(Regions::new(&regions, 0, 0, w));
            let (with, contact) = accumulate((&img).into(), &g, theta, &rel, with_regions, &lin);
            assert_eq!(plain, with, "factor {f}");
            assert_eq!(none, Contact::default());
            assert!(
                contact.sums[0].n[0] > 0 && contact.sums[0].n[1] > 0,
                "factor {f}"
            );
        }
    }

    /// The block loop against a plain reading of its rule, pixel by pixel, on a frame of
    /// random colours (saturated channels in half the rows), phases, reliability and
    /// regions.
    #[test]
    fn block_and_contact_sums_follow_the_rule_pixel_by_pixel() {
        let mut rng = crate::test_rng::XorShift(0x2545_f491_4f6c_dd1d);
        let mut next = move || rng.next();
        let lin = linear_q16();
        for f in [1usize, 2, 3, 5] {
            let (w, h) = (37usize, 29usize);
            let img = RgbImage::from_fn((w * f + 1) as u32, (h * f + 2) as u32, |_, y| {
                let v = next();
                // One channel in eight saturated in the lower half; none in the upper half,
                // whose rows the block loop reads without the test.
                let lower = y as usize >= h * f / 2;
                let c = |s: u32| {
                    if lower && (v >> (s + 8)) & 7 == 0 {
                        255
                    } else if lower {
                        (v >> s) as u8
                    } else {
                        ((v >> s) as u8).min(254)
                    }
                };
                image::Rgb([c(0), c(16), c(32)])
            });
            let g = Geometry::new(w, h, f, 0.11 * f as f32, 0.03 * f as f32);
            let theta: Vec<u16> = (0..w * h).map(|_| next() as u16).collect();
            let rel: Vec<bool> = (0..w * h).map(|_| next() % 5 != 0).collect();
            // Codes over a box of working pixels: columns 21 to w − 3, rows 2 to h − 2.
            let (bx0, by0, bw) = (21usize, 2usize, w - 24);
            let codes: Vec<u8> = (0..bw * (h - 3)).map(|_| (next() % 3) as u8).collect();
            let code = |x: usize, y: usize| {
                let inside = (bx0..bx0 + bw).contains(&x) && (by0..h - 1).contains(&y);
                if inside {
                    codes[(y - by0) * bw + x - bx0]
                } else {
                    region::NONE
                }
            };
            let (blocks, contact) = accumulate(
                (&img).into(),
                &g,
                |y, row: &mut [u16]| row.copy_from_slice(&theta[y * w..(y + 1) * w]),
                &rel,
                Some(Regions::new(&codes, bx0, by0, bw)),
                &lin,
            );
            let mut want = vec![Sums::default(); g.bw * g.bh];
            let mut want_contact = [Sums::default(); 2];
            let mut want_trends = [Trend::default(); 2];
            // The blocks classify in steps of 64 units, as the table does.
            let grid_pop = |t: i32| {
                let t = i32::from((t as u16 & !63) as i16).abs();
                (t < KEEP_UNITS)
                    .then_some(0)
                    .or((t >= 32_768 - KEEP_UNITS).then_some(1))
            };
            let read = |x: usize, y: usize, pop: Option<usize>, s: &mut Sums| {
                let p = img.get_pixel(x as u32, y as u32).0;
                let Some(pop) = pop else {
                    return;
                };
                if p.contains(&255) {
                    s.clipped[pop] += 1;
                    return;
                }
                for k in 0..3 {
                    s.sum[pop][k] += u64::from(lin[usize::from(p[k])]);
                }
                s.n[pop] += 1;
            };
            let th = |x: usize, y: usize| theta[y * w + x];
            for yw in 0..h {
                for xw in (0..w).filter(|&x| rel[yw * w + x]) {
                    let t0 = i32::from(theta[yw * w + xw]);
                    if yw % g.row_step == 0 {
                        let b = &mut want[(yw / g.block_px) * g.bw + xw / g.block_px];
                        for k in 0..f {
                            let pop = grid_pop(t0 + g.offsets[k]);
                            read(xw * f + k, yw * f + f / 2, pop, b);
                        }
                    }
                    let reg = code(xw, yw);
                    if reg == region::NONE {
                        continue;
                    }
                    // The contact: the local gradient from the neighbours (clipped at the
                    // image's edge), the band it gives, each input pixel's own phase.
                    let (xa, xb) = (xw.saturating_sub(1), (xw + 1).min(w - 1));
                    let (ya, yb) = (yw.saturating_sub(1), (yw + 1).min(h - 1));
                    let gx = gradient(th(xa, yw), th(xb, yw), xb - xa, g.carrier_units[0]);
                    let gy = gradient(th(xw, ya), th(xw, yb), yb - ya, g.carrier_units[1]);
                    let keep = keep_units(gx, gy, g.carrier_units);
                    local_phases(th(xw, yw), gx, gy, f, |ky, ts| {
                        for (kx, &t) in ts.iter().enumerate() {
                            let (x, y) = (xw * f + kx, yw * f + ky);
                            let core = usize::from(reg == region::CORE);
                            for r in 0..=core {
                                read(x, y, kept(t, keep), &mut want_contact[r]);
                                let p = img.get_pixel(x as u32, y as u32).0;
                                if let (Some(pop), false) = (kept(t, keep), p.contains(&255)) {
                                    let l = p.iter().map(|&c| lin[usize::from(c)]).sum();
                                    want_trends[r].add(pop, (x, y), l);
                                }
                            }
                        }
                    });
                }
            }
            assert_eq!(blocks.len(), want.len());
            for (i, (a, b)) in blocks.iter().zip(&want).enumerate() {
                assert_eq!(
                    a, b,
                    "factor {f} block {i} of {}x{} bp {}",
                    g.bw, g.bh, g.block_px
                );
            }
            assert_eq!(contact.sums, want_contact, "factor {f}");
            assert_eq!(contact.trends, want_trends, "factor {f}");
            let sums = contact.sums;
            assert!(sums[1].n[0] > 0 && want.iter().any(|b| b.n[1] > 0));
            assert!(sums[0].clipped[0] > 0 && want.iter().any(|b| b.clipped[1] > 0));
        }
    }

    /// On an undisturbed grating the local phases follow the carrier from pixel to pixel
    /// (to a unit of rounding), and the band is the calibration's.
    #[test]
    fn contact_pixels_follow_the_local_grating() {
        for f in [1usize, 2, 3, 4] {
            // 0.13 and 0.05 cycles per working pixel, across and down.
            let (gx, gy) = (
                (0.13 * 65_536.0f64).round() as i32,
                (0.05 * 65_536.0f64).round() as i32,
            );
            let g = Geometry::new(40, 30, f, 0.13, 0.05);
            assert_eq!(keep_units(gx, gy, g.carrier_units), KEEP_UNITS);
            let t0 = 60_000u16;
            local_phases(t0, gx, gy, f, |ky, row| {
                for (kx, &t) in row.iter().enumerate() {
                    let c = (f as f64 - 1.0) / 2.0;
                    let want = f64::from(t0)
                        + (f64::from(gx) * (kx as f64 - c) + f64::from(gy) * (ky as f64 - c))
                            / f as f64;
                    let err = i32::from(t.wrapping_sub(want.round() as i64 as u16) as i16);
                    assert!(err.abs() <= 1, "f {f} ({kx}, {ky}): {t} for {want}");
                }
            });
        }
        // Four working pixels per period (a forced ÷4): across two pixels the grating
        // advances half a turn, read against the carrier, not the wrong way round; and a
        // grating squeezed to 110° per pixel reads as such.
        assert_eq!(gradient(0, 32_768, 2, 16_384), 16_384);
        assert_eq!(
            gradient(1_000, 1_000u16.wrapping_add(40_050), 2, 16_384),
            20_025
        );
        assert_eq!(gradient(5, 5u16.wrapping_sub(2_000), 1, -1_900), -2_000);
        // Squeezed by 1.5: the band's edge stays as far from the stripe's edge in pixels
        // (a quarter turn − 1.5 × (a quarter turn − the flat band)); stretched: the flat
        // band; squeezed beyond reason: the floor.
        let carrier = [6_000, 8_000]; // 10 000 units per working pixel
        assert_eq!(keep_units(15_000, 0, carrier), 16_384 - 8_192 * 3 / 2);
        assert_eq!(keep_units(0, 6_000, carrier), KEEP_UNITS);
        assert_eq!(keep_units(40_000, 0, carrier), 1_024);
        assert_eq!(kept(0, 4_096), Some(0));
        assert_eq!(kept(32_768, 4_096), Some(1));
        assert_eq!(kept(16_384, 4_096), None);
        assert_eq!(kept(4_095, 4_096), Some(0));
        assert_eq!(kept(4_096, 4_096), None);
        assert_eq!(kept(4_095u16.wrapping_neg(), 4_096), Some(0));
        assert_eq!(kept(32_768 - 4_096, 4_096), Some(1));
    }

    #[test]
    fn a_rows_contact_stretch_is_found_in_any_position() {
        assert_eq!(extent(&[0; 40]), (0, 0));
        assert_eq!(extent(&[]), (0, 0));
        for len in [1usize, 15, 16, 17, 40] {
            for a in 0..len {
                for b in a + 1..=len {
                    let mut row = vec![region::NONE; len];
                    row[a] = region::CORE;
                    row[b - 1] = region::CONTACT;
                    assert_eq!(extent(&row), (a, b), "{len} {a} {b}");
                }
            }
        }
    }

    /// A contact row holding more samples than 32-bit sums can take is flushed on the way.
    #[test]
    fn a_long_contact_row_does_not_overflow_its_sums() {
        let lin = [1u32 << 16; 256];
        let mut contact = [Sums::default(); 2];
        let mut parts = RowParts::<()>::default();
        let n = 8 * RowParts::<()>::MAX_HELD;
        for k in 0..n {
            let core = k % 3 == 0;
            parts
                .part(core, 1, &mut contact)
                .add::<false>(k % 2, &lin, &[7, 8, 9]);
        }
        parts.flush(&mut contact);
        let total: u32 = contact[0].n.iter().sum();
        assert_eq!(total as usize, n);
        assert_eq!(contact[1].n.iter().sum::<u32>() as usize, n.div_ceil(3));
        let sum: u64 = contact[0].sum.iter().map(|s| s[1]).sum();
        assert_eq!(sum, n as u64 * (1 << 16));
    }

    #[test]
    fn pooling_sums_the_neighbourhood() {
        let one = Sums {
            sum: [[1, 2, 3], [4, 5, 6]],
            n: [1, 2],
            clipped: [0, 1],
        };
        let p = pool(&vec![one; 12], 4, 3, 1);
        assert_eq!(p[0].n[0], 4); // corner: 2 × 2
        assert_eq!(p[5].n[0], 9); // inside: 3 × 3
        assert_eq!(p[5].sum[1], [36, 45, 54]);
        assert_eq!(p[5].clipped, [0, 9]);
    }

    /// A region is clipped when saturation took more than 1/64 of either population's
    /// samples, not at the first saturated one.
    #[test]
    fn a_region_is_clipped_past_a_share_of_its_samples() {
        let with = |n: [u32; 2], clipped: [u32; 2]| Sums {
            sum: [[0; 3]; 2],
            n,
            clipped,
        };
        assert!(!with([63, 100], [1, 0]).is_clipped());
        assert!(with([62, 100], [2, 0]).is_clipped());
        assert!(with([100, 0], [0, 1]).is_clipped());
        assert!(!with([100, 100], [0, 0]).is_clipped());
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
            (&img).into(),
            &g,
            |y, row: &mut [u16]| row.copy_from_slice(&theta[y * row.len()..(y + 1) * row.len()]),
            &vec![true; theta.len()],
            None,
            &lin,
        );
        assert_eq!(inside, Contact::default());
        for b in &blocks {
            assert!(b.enough());
            let (c, k) = b.means();
            assert!((c[0] - super::super::lab::srgb_to_linear(200.0 / 255.0)).abs() < 1e-3);
            assert!((k[0] - super::super::lab::srgb_to_linear(20.0 / 255.0)).abs() < 1e-3);
        }
    }

    /// A lens that puts the colours' stripes apart (red ahead of the placing phase on the
    /// right and behind it on the left, blue the other way, up to 0.6 rad): placed by the
    /// placing phase alone, the coloured stripes' red and blue read lower where their
    /// stripes lie off it; each
    /// colour placed by its own stripes reads the same colour over the whole view, in the
    /// blocks and in a contact region alike.
    #[test]
    fn colours_placed_by_their_own_stripes_read_alike_over_the_view() {
        let (f, w, h) = (2usize, 96usize, 32usize);
        let offset = |k: usize, x: f64| [0.6, 0.0, -0.6][k] * (2.0 * x / w as f64 - 1.0);
        let (coloured, black) = ([200.0, 140.0, 90.0], [30.0, 30.0, 30.0]);
        let img = RgbImage::from_fn((w * f) as u32, (h * f) as u32, |x, _| {
            image::Rgb(std::array::from_fn(|k| {
                let t = f64::from(x) * std::f64::consts::TAU / 16.0
                    + offset(k, f64::from(x) / f as f64);
                let s = 0.5 + 0.5 * (2.0 * t.cos()).tanh();
                (black[k] + (coloured[k] - black[k]) * s).round() as u8
            }))
        });
        let lin = linear_q16();
        let plain = Geometry::new(w, h, f, 1.0 / 8.0, 0.0);
        let apart = plain.clone().with_colour_offsets(|k, x, _| offset(k, x));
        let theta = |_: usize, row: &mut [u16]| {
            for (x, t) in row.iter_mut().enumerate() {
                *t = ((x as f64 * f as f64 + 0.5) / 16.0 * 65_536.0).round() as i64 as u16;
            }
        };
        let rel = vec![true; w * h];
        // The contact region: the first and the last twelve columns.
        let codes: Vec<u8> = (0..w * h)
            .map(|i| {
                if i % w < 12 || i % w >= w - 12 {
                    region::CONTACT
                } else {
                    region::NONE
                }
            })
            .collect();
        // The coloured stripes' linear colour in the leftmost block against the middle one's
        // (where the colours lie on the placing phase): how far apart they read.
        let spread = |g: &Geometry| {
            let (blocks, _) = accumulate((&img).into(), g, theta, &rel, None, &lin);
            let m = |b: usize| blocks[b].means().0;
            let (edge, middle) = (m(0), m(g.bw / 2));
            (0..3)
                .map(|k| (edge[k] - middle[k]).abs() / middle[k])
                .fold(0.0, f64::max)
        };
        let (placed_plain, placed_apart) = (spread(&plain), spread(&apart));
        assert!(
            placed_plain > 0.03,
            "the lens moves the plain reading ({placed_plain})"
        );
        // What is left is the grating's sampling: each colour's kept pixels sit at other
        // places on its stripes.
        assert!(placed_apart < 0.01, "{placed_apart} apart per colour");
        // The contact region's two halves read as its blocks do.
        let regions = Some(Regions::new(&codes, 0, 0, w));
        let (blocks, contact) = accumulate((&img).into(), &apart, theta, &rel, regions, &lin);
        let (c, k) = contact.sums[0].means();
        let (bc, bk) = blocks[0].means();
        for ch in 0..3 {
            assert!(
                (c[ch] - bc[ch]).abs() < 0.01 * bc[ch],
                "coloured {ch}: {c:?} vs {bc:?}"
            );
            assert!(
                (k[ch] - bk[ch]).abs() < 0.05 * bk[ch],
                "black {ch}: {k:?} vs {bk:?}"
            );
        }
    }

    /// Colours placed apart are brought to one count: each colour's mean is kept, the count
    /// is the largest colour's; a population one colour missed is left out; a saturated
    /// pixel counts as clipped in green's population and adds nothing.
    #[test]
    fn colours_placed_apart_keep_their_means_at_one_count() {
        let lin = linear_q16();
        let mut part = Part::<Apart>::default();
        let (a, b) = ([10u8, 20, 30], [50u8, 60, 70]);
        // Coloured: red twice, green and blue once each; black: red only.
        part.add_per_colour([Some(0), Some(0), Some(0)], &lin, &a);
        part.add_per_colour([Some(0), None, Some(1)], &lin, &b);
        part.add_per_colour([Some(1), Some(1), None], &lin, &[0, 255, 0]);
        let mut sums = Sums::default();
        part.add_to(&mut sums);
        assert_eq!(sums.n, [2, 0]);
        let (coloured, _) = sums.means();
        let l = |c: u8| f64::from(lin[usize::from(c)]) / 65_536.0;
        let want = [(l(10) + l(50)) / 2.0, l(20), l(30)];
        for k in 0..3 {
            assert!(
                (coloured[k] - want[k]).abs() < 1e-4,
                "{coloured:?} vs {want:?}"
            );
        }
        assert_eq!(sums.sum[1], [0; 3]);
        assert_eq!(sums.clipped, [0, 1]);
    }
}
