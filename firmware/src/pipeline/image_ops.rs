//! Frame preparation: luminance and area downsampling, in float (reference) and integer
//! (device) form.
//!
//! The working resolution keeps about 6–8 px per grating period: [`downsample_factor`]
//! picks the largest integer factor that leaves at least 6 px. The area (box) filter
//! averages each `f × f` block: at ≥ 6 px per period the stripes' third harmonic (at 3/P')
//! either stays below Nyquist or aliases to above 1.5/P', outside the first-order band
//! [0.5/P', 1.5/P'], and the box response attenuates it further.

use image::RgbImage;

/// Fewest working pixels per grating period.
pub const MIN_WORKING_PERIOD_PX: f32 = 6.0;

/// The downsampling factor for a grating period of `period_px` input pixels.
pub fn downsample_factor(period_px: f32) -> usize {
    ((period_px / MIN_WORKING_PERIOD_PX).floor() as usize).clamp(1, 8)
}

/// Luminance weights (BT.601) in Q8: 77 R + 150 G + 29 B = 256.
const LUMA_Q8: [u32; 3] = [77, 150, 29];

/// Integer luminance, area-downsampled by `f`: each output is the mean of an `f × f` block,
/// in 8.8 fixed point (0…65 280). Partial blocks at the right and bottom edges are dropped.
/// Also returns the number of input pixels with a saturated channel (one pass over the
/// frame for both).
pub fn gray_down_q8(img: &RgbImage, f: usize) -> (Vec<u16>, usize, usize, usize) {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let (ow, oh) = (w / f, h / f);
    let raw: &[u8] = img.as_raw();
    let mut out = vec![0u16; ow * oh];
    let mut row = vec![0u32; ow];
    let n = (f * f) as u32;
    let mut saturated = 0usize;
    for oy in 0..oh {
        row.iter_mut().for_each(|v| *v = 0);
        for y in oy * f..(oy + 1) * f {
            let line = &raw[y * w * 3..(y * w + ow * f) * 3];
            for (acc, block) in row.iter_mut().zip(line.chunks_exact(3 * f)) {
                for px in block.chunks_exact(3) {
                    *acc += LUMA_Q8[0] * u32::from(px[0])
                        + LUMA_Q8[1] * u32::from(px[1])
                        + LUMA_Q8[2] * u32::from(px[2]);
                    saturated += usize::from(px[0].max(px[1]).max(px[2]) == 255);
                }
            }
        }
        for (o, acc) in out[oy * ow..(oy + 1) * ow].iter_mut().zip(&row) {
            *o = ((acc + n / 2) / n) as u16;
        }
    }
    (out, ow, oh, saturated)
}

/// Float luminance (0…255), area-downsampled by `f`: the reference path's twin of
/// [`gray_down_q8`], with the same weights so both paths see the same image.
pub fn gray_down_f32(img: &RgbImage, f: usize) -> (Vec<f32>, usize, usize) {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let (ow, oh) = (w / f, h / f);
    let mut out = vec![0.0f32; ow * oh];
    let inv = 1.0 / (f * f) as f32;
    for (i, p) in img.pixels().enumerate() {
        let (x, y) = (i % w, i / w);
        let (ox, oy) = (x / f, y / f);
        if ox < ow && oy < oh {
            let l = (LUMA_Q8[0] as f32 * f32::from(p[0])
                + LUMA_Q8[1] as f32 * f32::from(p[1])
                + LUMA_Q8[2] as f32 * f32::from(p[2]))
                / 256.0;
            out[oy * ow + ox] += l * inv;
        }
    }
    (out, ow, oh)
}

/// Fraction of pixels with a channel at 255 (over-exposure).
pub fn saturated_fraction(img: &RgbImage) -> f32 {
    let n = img.pixels().filter(|p| p.0.contains(&255)).count();
    n as f32 / (img.width() as f32 * img.height() as f32).max(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

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
