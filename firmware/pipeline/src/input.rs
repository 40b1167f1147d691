//! The pipeline's input: an image of three bytes per pixel, in the colour encoding the
//! camera's bytes decode to most cheaply.
//!
//! A camera sends RGB only from a file; a UVC camera sends YUYV (BT.601, limited range) or
//! MJPEG (JFIF: BT.601, full range). Converting a whole frame to RGB first costs more
//! than the pipeline reads: the phase needs only luminance (which is Y), and the
//! temperature reads colour at a few sampled rows and at the contact. So the pipeline
//! takes the frame as it decodes ([`Pixels`]), reads luminance from Y, and converts to RGB
//! only the pixels the temperature side samples ([`Pixels::rgb_row`]).
//!
//! [`decode_scale`] says how much smaller than the camera's image the decoder may deliver
//! it: a JPEG decodes at 1/2, 1/4 or 1/8 of its size for a fraction of the full decode's
//! cost, and the pipeline downsamples anyway.

use image::RgbImage;

pub use vistaf_hardware::decode::Colour;
use vistaf_hardware::decode::Decoded;

/// Luminance of a pixel from its three bytes, in 8.8 fixed point: `(Σ wₖ·bₖ)·gain/256 −
/// offset`. Linear, so a block's mean is the luminance of its channels' means, and the
/// downsampling sums channels first and weighs once per block.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Luma {
    /// Weights of the three bytes, Q8 (they sum to 256).
    pub weights: [u32; 3],
    /// Gain, Q8 (256 = 1).
    pub gain_q8: u32,
    /// Subtracted after the gain, 8.8 fixed point per pixel.
    pub offset_q8: u32,
}

impl Luma {
    /// A pixel's three bytes weighted (`Σ wₖ·bₖ`): summed over pixels, the input of
    /// [`Luma::mean_q8`].
    #[inline(always)]
    pub fn weighted(&self, p: &[u8; 3]) -> u32 {
        self.weights[0] * u32::from(p[0])
            + self.weights[1] * u32::from(p[1])
            + self.weights[2] * u32::from(p[2])
    }

    /// The mean luminance of `n` pixels whose weighted bytes sum to `weighted`, 8.8 fixed
    /// point, rounded and clamped to 0…65 280.
    #[inline(always)]
    pub fn mean_q8(&self, weighted: u64, n: u64) -> u64 {
        let n = n.max(1);
        let scaled = (weighted * u64::from(self.gain_q8)) >> 8;
        let v = scaled.saturating_sub(u64::from(self.offset_q8) * n);
        ((v + n / 2) / n).min(65_280)
    }

    /// [`Luma::mean_q8`] in 32-bit arithmetic, the same integers where
    /// [`Luma::fits_32_bits`] for blocks of `n` (a loop of these vectorises where 64-bit
    /// products do not).
    #[inline(always)]
    pub fn mean_q8_narrow(&self, weighted: u32, n: u32) -> u32 {
        let n = n.max(1);
        let v = ((weighted * self.gain_q8) >> 8).saturating_sub(self.offset_q8 * n);
        ((v + n / 2) / n).min(65_280)
    }

    /// Whether the weighted sum of `n` pixels times the gain, and `n` times the offset,
    /// fit 32 bits (for every encoding's [`luma`] they do up to 8 × 8 blocks).
    pub fn fits_32_bits(&self, n: u32) -> bool {
        let top = u64::from(self.weights.iter().sum::<u32>()) * 255 * u64::from(n);
        top * u64::from(self.gain_q8) <= u64::from(u32::MAX)
            && u64::from(self.offset_q8) * u64::from(n) <= u64::from(u32::MAX)
    }
}

/// How luminance (BT.601 luma of full-range sRGB, 0…255 in 8.8) is read from pixels in
/// `colour`.
pub fn luma(colour: Colour) -> Luma {
    match colour {
        // 77 R + 150 G + 29 B = 256.
        Colour::Rgb => Luma {
            weights: [77, 150, 29],
            gain_q8: 256,
            offset_q8: 0,
        },
        Colour::YCbCrFull => Luma {
            weights: [256, 0, 0],
            gain_q8: 256,
            offset_q8: 0,
        },
        // (Y − 16) · 255/219.
        Colour::YCbCrLimited => Luma {
            weights: [256, 0, 0],
            gain_q8: 298,
            offset_q8: 16 * 298,
        },
    }
}

/// Why bytes are not an image.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{got} bytes are not a {width}×{height} image of 3 bytes per pixel ({want} bytes)")]
pub struct InputError {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Bytes given.
    pub got: usize,
    /// Bytes needed.
    pub want: usize,
}

/// A frame as the pipeline reads it: `width × height` pixels of three bytes, row-major,
/// no padding, in `colour`. Borrowed: the caller owns the bytes.
#[derive(Debug, Clone, Copy)]
pub struct Pixels<'a> {
    width: u32,
    height: u32,
    data: &'a [u8],
    colour: Colour,
}

impl<'a> From<&'a RgbImage> for Pixels<'a> {
    fn from(img: &'a RgbImage) -> Pixels<'a> {
        Pixels {
            width: img.width(),
            height: img.height(),
            data: img.as_raw(),
            colour: Colour::Rgb,
        }
    }
}

/// A decoded camera frame; its length is three bytes per pixel by construction (a
/// shorter buffer reads as an empty image, which no reference matches).
impl<'a> From<&'a Decoded> for Pixels<'a> {
    fn from(d: &'a Decoded) -> Pixels<'a> {
        Pixels::new(d.width, d.height, &d.data, d.colour).unwrap_or(Pixels {
            width: 0,
            height: 0,
            data: &[],
            colour: d.colour,
        })
    }
}

impl<'a> Pixels<'a> {
    /// `data` as a `width × height` image in `colour`; an error when its length is not
    /// three bytes per pixel.
    pub fn new(
        width: u32,
        height: u32,
        data: &'a [u8],
        colour: Colour,
    ) -> Result<Pixels<'a>, InputError> {
        let want = width as usize * height as usize * 3;
        if data.len() != want {
            return Err(InputError {
                width,
                height,
                got: data.len(),
                want,
            });
        }
        Ok(Pixels {
            width,
            height,
            data,
            colour,
        })
    }

    /// Width, pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height, pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Width and height, pixels.
    pub fn dimensions(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// The bytes, three per pixel, row-major.
    pub fn raw(&self) -> &'a [u8] {
        self.data
    }

    /// How the bytes encode colour.
    pub fn colour(&self) -> Colour {
        self.colour
    }

    /// Pixels `x0..x1` of row `y` as sRGB bytes: the image's own bytes when it is RGB,
    /// else converted into `buf` (its contents replaced). Out-of-range columns are
    /// clipped to the image.
    pub fn rgb_row<'b>(&self, y: usize, x0: usize, x1: usize, buf: &'b mut Vec<u8>) -> &'b [u8]
    where
        'a: 'b,
    {
        if self.colour == Colour::Rgb {
            return self.row(y, x0, x1);
        }
        buf.clear();
        self.append_rgb(y, x0, x1, buf);
        buf
    }

    /// Appends pixels `x0..x1` of row `y` to `out` as sRGB bytes (clipped to the image).
    pub fn append_rgb(&self, y: usize, x0: usize, x1: usize, out: &mut Vec<u8>) {
        // One loop per encoding, so the conversion inlines and the match is not per pixel;
        // indexed over a slice cut to whole pixels, so that it vectorises (`whole_pixels`).
        fn convert(row: &[u8], out: &mut [u8], f: impl Fn([u8; 3]) -> [u8; 3]) {
            let n = row.len().min(out.len()) / 3;
            let (row, out) = (&row[..3 * n], &mut out[..3 * n]);
            for i in 0..n {
                let [a, b, c] = f([row[3 * i], row[3 * i + 1], row[3 * i + 2]]);
                (out[3 * i], out[3 * i + 1], out[3 * i + 2]) = (a, b, c);
            }
        }
        let row = self.row(y, x0, x1);
        let start = out.len();
        out.resize(start + row.len(), 0);
        let tail = &mut out[start..];
        match self.colour {
            Colour::Rgb => tail.copy_from_slice(row),
            Colour::YCbCrFull => convert(row, tail, |p| Colour::YCbCrFull.to_rgb(p)),
            Colour::YCbCrLimited => convert(row, tail, |p| Colour::YCbCrLimited.to_rgb(p)),
        }
    }

    /// How many pixels of row `y` have an sRGB channel at 255 (the row as
    /// [`Pixels::rgb_row`] would give it), without converting the row: for Y, Cb, Cr the
    /// conversion's channels are tested before they are clamped ([`Colour::saturates`]).
    pub fn saturated_in_row(&self, y: usize) -> usize {
        let row = self.row(y, 0, self.width as usize);
        match self.colour {
            // Most rows hold no 255, which the row's maximum (a vectorised loop) tells at a
            // fraction of the pixel test's cost.
            Colour::Rgb if row.iter().fold(0u8, |m, &b| m.max(b)) < 255 => 0,
            Colour::Rgb => count_saturated(row, |p| Colour::Rgb.saturates(p)),
            // Likewise: no pixel of the row saturates unless the brightest corner of the box
            // its Y, Cb and Cr span does (each channel grows with Y, and is linear in Cb
            // and Cr, so a box's largest value is at a corner of largest Y).
            c if !corner_saturates(c, row) => 0,
            Colour::YCbCrFull => count_saturated(row, |p| Colour::YCbCrFull.saturates(p)),
            Colour::YCbCrLimited => count_saturated(row, |p| Colour::YCbCrLimited.saturates(p)),
        }
    }

    /// The mean of each of a pixel's three bytes over `factor × factor` blocks, for the
    /// `w × h` blocks from the top left, 8.8 fixed point, in the image's own encoding
    /// (three values a block, row-major). A block past the image's edge averages what is
    /// inside it. Not on the per-frame path: for settling tests, figures and full maps.
    pub fn box_means_q8(&self, factor: usize, w: usize, h: usize) -> Vec<u16> {
        let f = factor.max(1);
        let mut out = Vec::with_capacity(w * h * 3);
        let (mut sums, mut counts) = (vec![0u32; w * 3], vec![0u32; w]);
        for y in 0..h {
            sums.fill(0);
            counts.fill(0);
            for yy in (y * f..(y + 1) * f).take_while(|&yy| yy < self.height as usize) {
                for (x, px) in self.row(yy, 0, w * f).as_chunks::<3>().0.iter().enumerate() {
                    counts[x / f] += 1;
                    for (s, &c) in sums[(x / f) * 3..][..3].iter_mut().zip(px) {
                        *s += u32::from(c);
                    }
                }
            }
            for (s, &n) in sums.as_chunks::<3>().0.iter().zip(&counts) {
                let n = n.max(1);
                out.extend(s.map(|v| (((v << 8) + n / 2) / n) as u16));
            }
        }
        out
    }

    /// The image shrunk to `w × h`: each pixel the mean colour of the `factor × factor`
    /// pixels it stands for ([`Pixels::box_means_q8`], converted to sRGB per block: the
    /// colour conversions are affine, so the mean converts as the pixels would), 8-bit RGB.
    pub fn box_rgb(&self, factor: usize, w: usize, h: usize) -> Vec<u8> {
        self.box_means_q8(factor, w, h)
            .as_chunks::<3>()
            .0
            .iter()
            .flat_map(|m| {
                self.colour
                    .to_rgb(m.map(|v| ((u32::from(v) + 128) >> 8).min(255) as u8))
            })
            .collect()
    }

    /// The bytes of pixels `x0..x1` of row `y`, clipped to the image.
    fn row(&self, y: usize, x0: usize, x1: usize) -> &'a [u8] {
        let w = self.width as usize;
        let (x0, x1) = (x0.min(w), x1.min(w));
        &self.data[(y * w + x0) * 3..(y * w + x1) * 3]
    }
}

/// Whether a pixel at the largest Y of `row` (three bytes each) and at a corner of its
/// Cb and Cr ranges saturates in `colour`.
fn corner_saturates(colour: Colour, row: &[u8]) -> bool {
    let (row, n) = whole_pixels(row);
    let (mut hi, mut lo) = ([0u8; 3], [255u8; 3]);
    for i in 0..n {
        let p = pixel(row, i);
        for k in 0..3 {
            (hi[k], lo[k]) = (hi[k].max(p[k]), lo[k].min(p[k]));
        }
    }
    [
        (lo[1], lo[2]),
        (lo[1], hi[2]),
        (hi[1], lo[2]),
        (hi[1], hi[2]),
    ]
    .iter()
    .any(|&(cb, cr)| colour.saturates([hi[0], cb, cr]))
}

/// How many pixels of `row` (three bytes each) `saturates`; one loop per encoding.
#[inline(always)]
fn count_saturated(row: &[u8], saturates: impl Fn([u8; 3]) -> bool) -> usize {
    let (row, n) = whole_pixels(row);
    (0..n)
        .map(|i| u32::from(saturates(pixel(row, i))))
        .sum::<u32>() as usize
}

/// `row` cut to its whole pixels of three bytes, and how many there are. Loops over
/// `0..n` reading [`pixel`]s of a slice cut so are the form the compiler vectorises (with
/// three-byte structure loads and stores); loops over chunks of the same bytes are not.
#[inline(always)]
fn whole_pixels(row: &[u8]) -> (&[u8], usize) {
    let n = row.len() / 3;
    (&row[..3 * n], n)
}

/// Pixel `i` of a row of three-byte pixels.
#[inline(always)]
fn pixel(row: &[u8], i: usize) -> [u8; 3] {
    [row[3 * i], row[3 * i + 1], row[3 * i + 2]]
}

/// Fewest input pixels per grating period left by a scaled decode: twice the working
/// resolution's ([`crate::image_ops::MIN_WORKING_PERIOD_PX`]), so the pipeline still
/// downsamples at least twice and the temperature side still has two samples per working
/// pixel across each stripe pair's phases.
pub const MIN_DECODED_PERIOD_PX: f64 = 12.0;

/// Fewest columns left by a scaled decode: the sizes the pipeline is built and measured
/// for (320 × 240 to 800 × 600 and up) are never reduced, only larger cameras.
pub const MIN_DECODED_WIDTH_PX: u32 = 640;

/// How many times smaller (1, 2, 4 or 8, each way) a `width_px × height_px` camera image
/// with a grating of `period_px` pixels may be decoded without losing what the pipeline
/// reads: the largest power of two that divides both sides and leaves at least
/// [`MIN_DECODED_PERIOD_PX`] per period and [`MIN_DECODED_WIDTH_PX`] columns.
pub fn decode_scale(width_px: u32, height_px: u32, period_px: f64) -> u32 {
    let mut s = 1;
    while s < 8
        && vistaf_hardware::decode::scale_fits(width_px, height_px, 2 * s)
        && period_px / f64::from(2 * s) >= MIN_DECODED_PERIOD_PX
        && width_px / (2 * s) >= MIN_DECODED_WIDTH_PX
    {
        s *= 2;
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn luma_of_grey_is_the_grey_level_in_every_colour_encoding() {
        for (enc, p, want) in [
            (Colour::Rgb, [100u8, 100, 100], 100 * 256),
            (Colour::YCbCrFull, [100, 128, 128], 100 * 256),
            (
                Colour::YCbCrLimited,
                [16 + 219 / 2, 128, 128],
                255 * 256 / 2,
            ),
        ] {
            let l = luma(enc);
            // One pixel, and the mean of four alike.
            for n in [1u64, 4] {
                let got = l.mean_q8(u64::from(l.weighted(&p)) * n, n) as i32;
                assert!((got - want).abs() <= 300, "{enc:?}: {got} vs {want}");
            }
        }
    }

    #[test]
    fn saturated_pixels_are_counted_as_their_converted_row_shows_them() {
        let (w, h) = (37usize, 5usize);
        let data: Vec<u8> = (0..w * h * 3).map(|i| (i * 97 % 256) as u8).collect();
        let mut buf = Vec::new();
        for c in [Colour::Rgb, Colour::YCbCrFull, Colour::YCbCrLimited] {
            let px = Pixels::new(w as u32, h as u32, &data, c).unwrap();
            let mut total = 0;
            for y in 0..h {
                let row = px.rgb_row(y, 0, w, &mut buf).to_vec();
                let want = row
                    .as_chunks::<3>()
                    .0
                    .iter()
                    .filter(|p| p.contains(&255))
                    .count();
                assert_eq!(px.saturated_in_row(y), want, "{c:?} row {y}");
                total += want;
            }
            assert!(total > 0, "{c:?}: no saturated pixel drawn");
        }
        // A dim row, then the same row with one pixel bright enough in red: only that one.
        let mut row: Vec<u8> = (0..64)
            .flat_map(|i| [90 + i % 7, 120 + i % 5, 130])
            .collect();
        for c in [Colour::YCbCrFull, Colour::YCbCrLimited] {
            let px = Pixels::new(64, 1, &row, c).unwrap();
            assert_eq!(px.saturated_in_row(0), 0, "{c:?}");
        }
        row[30..33].copy_from_slice(&[200, 128, 250]);
        for c in [Colour::YCbCrFull, Colour::YCbCrLimited] {
            let px = Pixels::new(64, 1, &row, c).unwrap();
            assert_eq!(px.saturated_in_row(0), 1, "{c:?}");
        }
    }

    #[test]
    fn rows_are_borrowed_when_rgb_and_converted_otherwise() {
        let img = RgbImage::from_fn(4, 2, |x, y| image::Rgb([x as u8, y as u8, 7]));
        let p = Pixels::from(&img);
        let mut buf = Vec::new();
        assert_eq!(p.rgb_row(1, 1, 3, &mut buf), &[1, 1, 7, 2, 1, 7]);
        assert!(buf.is_empty());
        let data = [16u8, 128, 128, 235, 128, 128];
        let y = Pixels::new(2, 1, &data, Colour::YCbCrLimited).unwrap();
        assert_eq!(y.rgb_row(0, 0, 9, &mut buf), &[0, 0, 0, 255, 255, 255]);
        assert!(Pixels::new(2, 2, &data, Colour::Rgb).is_err());
    }

    #[test]
    fn decode_scale_keeps_the_period_and_small_cameras() {
        assert_eq!(decode_scale(640, 480, 30.0), 1);
        assert_eq!(decode_scale(800, 600, 30.0), 1);
        assert_eq!(decode_scale(1280, 720, 30.0), 2);
        assert_eq!(decode_scale(1280, 720, 20.0), 1);
        assert_eq!(decode_scale(1920, 1080, 48.0), 2);
        assert_eq!(decode_scale(3840, 2160, 96.0), 4);
        assert_eq!(decode_scale(3840, 2160, 40.0), 2);
        assert_eq!(decode_scale(4096, 4096, 1000.0), 4);
        assert_eq!(decode_scale(8192, 4096, 1000.0), 8);
        // A side the scale does not divide.
        assert_eq!(decode_scale(1281, 720, 30.0), 1);
    }
}
