//! Frame preparation: luminance and area downsampling, in float (reference) and integer
//! (device) form.
//!
//! The working resolution keeps about 6–8 px per grating period: [`downsample_factor`]
//! picks the largest integer factor that leaves at least 6 px. The area (box) filter
//! averages each `f × f` block: at ≥ 6 px per period the stripes' third harmonic (at 3/P')
//! either stays below Nyquist or aliases to above 1.5/P', outside the first-order band
//! [0.5/P', 1.5/P'], and the box response attenuates it further.

use crate::input::{luma, Luma, Pixels};

/// Fewest working pixels per grating period.
pub const MIN_WORKING_PERIOD_PX: f32 = 6.0;

/// The downsampling factor for a grating period of `period_px` input pixels.
pub fn downsample_factor(period_px: f32) -> usize {
    ((period_px / MIN_WORKING_PERIOD_PX).floor() as usize).clamp(1, 8)
}

/// Input rows read for the saturation statistic: one in this many. Over-exposure is a
/// fraction of the frame (0.2 %), which a sample of a quarter of the rows estimates well,
/// at a quarter of the cost of a test on every pixel.
pub const SATURATION_ROW_STEP: usize = 4;

/// Integer luminance, area-downsampled by `f` (1…8): each output is the mean of an `f × f`
/// block, in 8.8 fixed point (0…65 280), read as the image's colour encoding gives it
/// ([`crate::input::luma`]: weighted RGB, or Y). Partial blocks at the right and bottom edges are
/// dropped. Also returns the fraction of pixels with a saturated channel
/// ([`saturated_fraction`]).
///
/// Two orders of the same integer sums, chosen by the target: pixels first on AArch64,
/// rows first elsewhere (see the two functions; measured on AArch64 and x86-64 only).
pub fn gray_down_q8<'a>(img: impl Into<Pixels<'a>>, f: usize) -> (Vec<u16>, usize, usize, f32) {
    let mut gray = Vec::new();
    let (ow, oh, saturated) = gray_down_q8_into(img, f, &mut gray);
    (gray, ow, oh, saturated)
}

/// Calls `$func::<F>($args)` for the downsampling factor `$f` as a constant (0 and 1 → 1,
/// above 8 → 8), so each factor's loops are compiled for it.
macro_rules! by_factor {
    ($f:expr, $func:ident($($arg:expr),*)) => {
        match $f {
            0 | 1 => $func::<1>($($arg),*),
            2 => $func::<2>($($arg),*),
            3 => $func::<3>($($arg),*),
            4 => $func::<4>($($arg),*),
            5 => $func::<5>($($arg),*),
            6 => $func::<6>($($arg),*),
            7 => $func::<7>($($arg),*),
            _ => $func::<8>($($arg),*),
        }
    };
}

/// What a downsampling by `f` (as [`by_factor!`] takes it) returns: the output's width and
/// height, and the saturated fraction of `img`.
fn downsampled(img: Pixels<'_>, f: usize) -> (usize, usize, f32) {
    let f = f.clamp(1, 8);
    let (ow, oh) = (img.width() as usize / f, img.height() as usize / f);
    (ow, oh, saturated_fraction(img))
}

/// [`gray_down_q8`] into a buffer the caller keeps from frame to frame (its contents are
/// replaced); returns the output's width and height and the saturated fraction.
pub fn gray_down_q8_into<'a>(
    img: impl Into<Pixels<'a>>,
    f: usize,
    out: &mut Vec<u16>,
) -> (usize, usize, f32) {
    let img = img.into();
    out.clear();
    by_factor!(f, gray_down_with(&img, out));
    downsampled(img, f)
}

/// The mean luminance of a block of `n` pixels whose weighted channel sums are `acc`
/// (see [`Luma`]), 8.8 fixed point, rounded and clamped to 0…65 280. `narrow`:
/// [`Luma::fits_32_bits`] for blocks of `n`, decided once per image so that the branch is
/// the loop's, not each block's.
#[inline(always)]
fn block_mean(acc: u32, n: u32, l: &Luma, narrow: bool) -> u16 {
    if l.gain_q8 == 256 && l.offset_q8 == 0 {
        return ((acc + n / 2) / n) as u16;
    }
    if narrow {
        return l.mean_q8_narrow(acc, n) as u16;
    }
    l.mean_q8(u64::from(acc), u64::from(n)) as u16
}

fn gray_down_with<const F: usize>(img: &Pixels<'_>, out: &mut Vec<u16>) {
    // The two orders give the same integers; each is the cheaper on one kind of core.
    if cfg!(target_arch = "aarch64") {
        gray_down_pixels_first::<F>(img, out)
    } else {
        gray_down_rows_first::<F>(img, out)
    }
}

/// [`gray_down_q8`] summing the block's rows channel by channel first (`u16`, a loop the
/// compiler vectorises on any core), then weighting each block once: three
/// multiplications per output pixel instead of three per input pixel. The cheaper order
/// where vectors have no 32-bit multiply (baseline x86-64).
fn gray_down_rows_first<const F: usize>(img: &Pixels<'_>, out: &mut Vec<u16>) {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let (ow, oh) = (w / F, h / F);
    let raw: &[u8] = img.raw();
    let luma = luma(img.colour());
    let lw = luma.weights;
    // Every output is written once: no zeroed buffer first.
    out.reserve(ow * oh);
    let mut sum = vec![0u16; ow * F * 3];
    let n = (F * F) as u32;
    let narrow = luma.fits_32_bits(n);
    for oy in 0..oh {
        sum_rows::<F>(raw, w, oy, &mut sum);
        out.extend(sum.chunks_exact(3 * F).map(|block| {
            let [r, g, b] = block_rgb(block);
            block_mean(lw[0] * r + lw[1] * g + lw[2] * b, n, &luma, narrow)
        }));
    }
}

/// The bytes of output row `oy`'s `F` input rows (`w` pixels wide) summed column by column
/// into `sum` (its length: the bytes of the row's whole blocks; `u16`, a loop the compiler
/// vectorises on any core).
#[inline(always)]
fn sum_rows<const F: usize>(raw: &[u8], w: usize, oy: usize, sum: &mut [u16]) {
    let span = sum.len();
    let first = oy * F * w * 3;
    for (s, v) in sum.iter_mut().zip(&raw[first..first + span]) {
        *s = u16::from(*v);
    }
    for y in oy * F + 1..(oy + 1) * F {
        let line = &raw[y * w * 3..y * w * 3 + span];
        for (s, v) in sum.iter_mut().zip(line) {
            *s += u16::from(*v);
        }
    }
}

/// A block's three colour sums from its columns' sums ([`sum_rows`], three per column).
#[inline(always)]
fn block_rgb(block: &[u16]) -> [u32; 3] {
    let (mut r, mut g, mut b) = (0u32, 0u32, 0u32);
    for px in block.chunks_exact(3) {
        r += u32::from(px[0]);
        g += u32::from(px[1]);
        b += u32::from(px[2]);
    }
    [r, g, b]
}

/// [`gray_down_q8`] weighting every input pixel first, in 16 bits (a luminance is at most
/// 65 280, so 16-bit arithmetic is exact), then summing the block's rows and columns in 32
/// bits. The pixel loop vectorises where loads de-interleave RGB (AArch64's `ld3`), which
/// makes this the cheaper order there; on x86-64 it is the dearer one (both measured in
/// `docs/pipeline.md`).
fn gray_down_pixels_first<const F: usize>(img: &Pixels<'_>, out: &mut Vec<u16>) {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let (ow, oh) = (w / F, h / F);
    let raw: &[u8] = img.raw();
    let l = luma(img.colour());
    // Every output is written once: no zeroed buffer first.
    out.reserve(ow * oh);
    let span = ow * F;
    let mut luma = vec![0u16; span];
    let mut sum = vec![0u32; span];
    let n = (F * F) as u32;
    let narrow = l.fits_32_bits(n);
    // Each weight times 255 fits 16 bits (a weight is at most 256).
    let wq = l.weights.map(|x| x as u16);
    for oy in 0..oh {
        for (k, y) in (oy * F..(oy + 1) * F).enumerate() {
            let (line, _) = raw[y * w * 3..(y * w + span) * 3].as_chunks::<3>();
            for (l, p) in luma.iter_mut().zip(line) {
                *l = wq[0] * u16::from(p[0]) + wq[1] * u16::from(p[1]) + wq[2] * u16::from(p[2]);
            }
            if k == 0 {
                for (s, &l) in sum.iter_mut().zip(&luma) {
                    *s = u32::from(l);
                }
            } else {
                for (s, &l) in sum.iter_mut().zip(&luma) {
                    *s += u32::from(l);
                }
            }
        }
        out.extend(
            sum.chunks_exact(F)
                .map(|block| block_mean(block.iter().sum::<u32>(), n, &l, narrow)),
        );
    }
}

/// [`gray_down_q8_into`] of an RGB image, with the lateral correction's quadrature term
/// beside the luminance ([`crate::ftp::lateral`]): per output pixel
/// `q = Σₖ kₖ·(colour k's block mean)`, 8.8 fixed point, `kₖ` Q15 per output pixel (each
/// colour's weight times its offset, |Σₖ kₖ| under 0.5). Rows first on every core: the
/// block's colour sums are what both need.
pub fn gray_lateral_down_q8_into<'a>(
    img: impl Into<Pixels<'a>>,
    f: usize,
    k: &[Vec<i16>; 3],
    gray: &mut Vec<u16>,
    q: &mut Vec<i16>,
) -> (usize, usize, f32) {
    let img = img.into();
    by_factor!(f, gray_lateral_with(&img, k, (gray, q)));
    downsampled(img, f)
}

/// [`gray_down_rows_first`] with the quadrature term of each block from the same colour
/// sums. The products stay within `i32`: a colour's sum over 64 pixels is at most 16 320,
/// and each `|kₖ|` under 16 384.
fn gray_lateral_with<const F: usize>(
    img: &Pixels<'_>,
    k: &[Vec<i16>; 3],
    (gray, q): (&mut Vec<u16>, &mut Vec<i16>),
) {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let (ow, oh) = (w / F, h / F);
    let raw: &[u8] = img.raw();
    let luma = luma(img.colour());
    let lw = luma.weights;
    // Every output is written by index (cheaper here than a push per block).
    gray.clear();
    q.clear();
    gray.resize(ow * oh, 0);
    q.resize(ow * oh, 0);
    let mut sum = vec![0u16; ow * F * 3];
    let n = (F * F) as u32;
    let narrow = luma.fits_32_bits(n);
    for oy in 0..oh {
        sum_rows::<F>(raw, w, oy, &mut sum);
        let row = oy * ow..(oy + 1) * ow;
        let factors = k[0][row.clone()]
            .iter()
            .zip(&k[1][row.clone()])
            .zip(&k[2][row.clone()]);
        let outs = gray[row.clone()].iter_mut().zip(&mut q[row]);
        for ((block, ((&k0, &k1), &k2)), (g_out, q_out)) in
            sum.chunks_exact(3 * F).zip(factors).zip(outs)
        {
            let [r, g, b] = block_rgb(block);
            *g_out = block_mean(lw[0] * r + lw[1] * g + lw[2] * b, n, &luma, narrow);
            // Q15 factors times colour sums of n pixels: over n for the means, then Q15 → Q8.
            let acc =
                i32::from(k0) * r as i32 + i32::from(k1) * g as i32 + i32::from(k2) * b as i32;
            *q_out = ((acc / n as i32) >> 7) as i16;
        }
    }
}

/// Each colour's mean (0…255) over `f × f` blocks, as floats: the reference path's twin of
/// the colour sums [`gray_lateral_down_q8_into`] reads. RGB images only (the caller's
/// check).
pub fn colours_down_f32<'a>(img: impl Into<Pixels<'a>>, f: usize) -> [Vec<f32>; 3] {
    let img = img.into();
    let (w, h) = (img.width() as usize, img.height() as usize);
    let (ow, oh) = (w / f, h / f);
    let mut out: [Vec<f32>; 3] = std::array::from_fn(|_| vec![0.0f32; ow * oh]);
    let inv = 1.0 / (f * f) as f32;
    for (i, p) in img.raw().chunks_exact(3).enumerate() {
        let (ox, oy) = ((i % w) / f, (i / w) / f);
        if ox < ow && oy < oh {
            for (plane, &v) in out.iter_mut().zip(p) {
                plane[oy * ow + ox] += f32::from(v) * inv;
            }
        }
    }
    out
}

/// Float luminance (0…255), area-downsampled by `f`: the reference path's twin of
/// [`gray_down_q8`], with the same weights so both paths see the same image.
pub fn gray_down_f32<'a>(img: impl Into<Pixels<'a>>, f: usize) -> (Vec<f32>, usize, usize) {
    let img = img.into();
    let (w, h) = (img.width() as usize, img.height() as usize);
    let l = luma(img.colour());
    let (gain, offset) = (l.gain_q8 as f32 / 256.0, l.offset_q8 as f32 / 256.0);
    let (ow, oh) = (w / f, h / f);
    let mut out = vec![0.0f32; ow * oh];
    let inv = 1.0 / (f * f) as f32;
    for (i, p) in img.raw().chunks_exact(3).enumerate() {
        let (x, y) = (i % w, i / w);
        let (ox, oy) = (x / f, y / f);
        if ox < ow && oy < oh {
            let weighted = (l.weights[0] as f32 * f32::from(p[0])
                + l.weights[1] as f32 * f32::from(p[1])
                + l.weights[2] as f32 * f32::from(p[2]))
                / 256.0;
            out[oy * ow + ox] += (weighted * gain - offset).clamp(0.0, 255.0) * inv;
        }
    }
    (out, ow, oh)
}

/// Fraction of pixels with an sRGB channel at 255 (over-exposure), over every
/// [`SATURATION_ROW_STEP`]-th row ([`Pixels::saturated_in_row`]: a Y, Cb, Cr image's
/// pixels are tested without converting them).
pub fn saturated_fraction<'a>(img: impl Into<Pixels<'a>>) -> f32 {
    let img = img.into();
    let (w, h) = (img.width() as usize, img.height() as usize);
    let rows = (0..h).step_by(SATURATION_ROW_STEP);
    let seen = rows.len() * w;
    let n: usize = rows.map(|y| img.saturated_in_row(y)).sum();
    n as f32 / seen.max(1) as f32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::Colour;
    use image::RgbImage;

    #[test]
    fn factors_keep_six_to_twelve_px_per_period() {
        for p in [7.0f32, 11.9, 12.0, 16.0, 24.0, 30.0] {
            let f = downsample_factor(p);
            assert!(
                p / f as f32 >= 6.0 && (p / f as f32) < 12.0 || f == 1,
                "{p} → {f}"
            );
        }
        assert_eq!(downsample_factor(16.0), 2);
        assert_eq!(downsample_factor(30.0), 5);
    }

    /// The luminance beside the quadrature term is the luminance alone's, and the term is
    /// each block's colour means weighted by the factors, for every factor and with a
    /// partial block at the edges.
    #[test]
    fn the_quadrature_term_weighs_each_block_s_colour_means() {
        let mut rng = crate::test_rng::XorShift(0x2545_f491_4f6c_dd1d);
        let (w, h) = (37usize, 29usize);
        let img = RgbImage::from_fn(w as u32, h as u32, |_, _| {
            let b = rng.next().to_le_bytes();
            image::Rgb([b[0], b[1], b[2]])
        });
        for f in 1..=8 {
            let (ow, oh) = (w / f, h / f);
            let k: [Vec<i16>; 3] = std::array::from_fn(|c| {
                (0..ow * oh)
                    .map(|i| ((i * 811 + c * 4099) % 9_600) as i16 - 4_800)
                    .collect()
            });
            let (mut gray, mut q) = (Vec::new(), Vec::new());
            let got = gray_lateral_down_q8_into(&img, f, &k, &mut gray, &mut q);
            let (want, _, _, sat) = gray_down_q8(&img, f);
            assert_eq!(got, (ow, oh, sat), "f {f}");
            assert_eq!(gray, want, "f {f}");
            let means = Pixels::from(&img).box_means_q8(f, ow, oh);
            for (i, &qi) in q.iter().enumerate() {
                let plain: f64 = (0..3)
                    .map(|c| f64::from(k[c][i]) / 32_768.0 * f64::from(means[3 * i + c]))
                    .sum();
                assert!(
                    (f64::from(qi) - plain).abs() <= 1.5,
                    "f {f} at {i}: {qi} vs {plain}"
                );
            }
        }
    }

    /// The row test only skips rows with nothing to count: the fraction is the plain
    /// pixel-by-pixel one over the sampled rows.
    #[test]
    fn saturated_fraction_counts_every_saturated_pixel_of_the_sampled_rows() {
        let mut state = 7u32;
        let img = RgbImage::from_fn(37, 29, |_, y| {
            state = state.wrapping_mul(1_103_515_245).wrapping_add(12_345);
            let v = state >> 8;
            // Saturated channels in rows 0, 8 and 13 only.
            let c = |s: u32| {
                if [0, 8, 13].contains(&y) && (v >> s).is_multiple_of(5) {
                    255
                } else {
                    (v >> s) as u8 % 255
                }
            };
            image::Rgb([c(0), c(5), c(10)])
        });
        let rows: Vec<u32> = (0..29).step_by(SATURATION_ROW_STEP).collect();
        let n = rows
            .iter()
            .flat_map(|&y| (0..37).map(move |x| (x, y)))
            .filter(|&(x, y)| img.get_pixel(x, y).0.contains(&255))
            .count();
        assert!(n > 10);
        let want = n as f32 / (rows.len() * 37) as f32;
        assert_eq!(saturated_fraction(&img), want);
    }

    /// Both orders of the integer luminance against its plain reading ([`Luma::mean_q8`] of
    /// each block's weighted sum), pixel by pixel, for every factor, every colour encoding
    /// and sizes that leave partial blocks.
    #[test]
    fn both_luminance_orders_give_the_block_means() {
        let mut rng = crate::test_rng::XorShift(0x51_7cc1_b727_220a);
        let (w, h) = (37usize, 29usize);
        let raw: Vec<u8> = (0..w * h)
            .flat_map(|_| rng.next().to_le_bytes()[..3].to_vec())
            .collect();
        for colour in [Colour::Rgb, Colour::YCbCrFull, Colour::YCbCrLimited] {
            let img = Pixels::new(w as u32, h as u32, &raw, colour).unwrap();
            let l = luma(colour);
            let plain = |f: usize| -> Vec<u16> {
                let (ow, oh) = (w / f, h / f);
                (0..ow * oh)
                    .map(|k| {
                        let (ox, oy) = (k % ow, k / ow);
                        let mut acc = 0u64;
                        for y in oy * f..(oy + 1) * f {
                            for x in ox * f..(ox + 1) * f {
                                let p = &raw[(y * w + x) * 3..][..3];
                                acc += u64::from(l.weighted(&[p[0], p[1], p[2]]));
                            }
                        }
                        l.mean_q8(acc, (f * f) as u64) as u16
                    })
                    .collect()
            };
            fn both<const F: usize>(img: &Pixels<'_>) -> [Vec<u16>; 2] {
                // A buffer with stale contents: each order replaces them.
                let (mut rows, mut pixels) = (vec![7u16; 3], vec![9u16; 5]);
                rows.clear();
                pixels.clear();
                gray_down_rows_first::<F>(img, &mut rows);
                gray_down_pixels_first::<F>(img, &mut pixels);
                [rows, pixels]
            }
            let orders = [
                both::<1>(&img),
                both::<2>(&img),
                both::<3>(&img),
                both::<4>(&img),
                both::<5>(&img),
                both::<6>(&img),
                both::<7>(&img),
                both::<8>(&img),
            ];
            for (i, [rows, pixels]) in orders.iter().enumerate() {
                let want = plain(i + 1);
                assert_eq!(rows, &want, "{colour:?}, rows first, factor {}", i + 1);
                assert_eq!(pixels, &want, "{colour:?}, pixels first, factor {}", i + 1);
            }
        }
    }

    /// The 32-bit block mean is the 64-bit one for every encoding's luminance up to 8 × 8
    /// blocks, at the extremes of a block's sum; a gain too large for it is left to the
    /// 64-bit one.
    #[test]
    fn thirty_two_bits_hold_every_encodings_block_means() {
        for colour in [Colour::Rgb, Colour::YCbCrFull, Colour::YCbCrLimited] {
            let l = luma(colour);
            for n in [1u32, 4, 9, 64] {
                assert!(l.fits_32_bits(n), "{colour:?}, {n} pixels");
                let top = 256 * 255 * n;
                for acc in [0, 1, 16 * 256 * n, 17 * 256 * n - 1, top / 2, top - 1, top] {
                    let wide = l.mean_q8(u64::from(acc), u64::from(n)) as u16;
                    assert_eq!(block_mean(acc, n, &l, true), wide, "{colour:?} {n} {acc}");
                }
            }
        }
        let strong = Luma {
            weights: [256, 0, 0],
            gain_q8: 1 << 12,
            offset_q8: 0,
        };
        assert!(!strong.fits_32_bits(64));
        assert!(strong.fits_32_bits(1));
    }

    #[test]
    fn integer_and_float_luminance_agree() {
        let mut img = RgbImage::new(9, 7);
        for (i, p) in img.pixels_mut().enumerate() {
            *p = image::Rgb([
                (i * 37 % 256) as u8,
                (i * 91 % 256) as u8,
                (i * 13 % 256) as u8,
            ]);
        }
        for f in [1, 2, 3] {
            let (q, w, h, _) = gray_down_q8(&img, f);
            let (fl, w2, h2) = gray_down_f32(&img, f);
            assert_eq!((w, h), (w2, h2));
            for (a, b) in q.iter().zip(&fl) {
                assert!((f32::from(*a) / 256.0 - b).abs() < 0.01, "{a} {b}");
            }
        }
    }
}
