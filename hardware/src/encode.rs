//! An RGB image as a UVC camera sends it: YUYV (BT.601, limited range, chroma shared by
//! two pixels across) or MJPEG (baseline JPEG, 4:2:2, at a quality). The simulated skin
//! and the fixtures use it, so the pipeline is tested on the bytes a camera delivers, with
//! their chroma subsampling and compression error, not only on lossless RGB.

use image::RgbImage;

use crate::frame::{Frame, PixelFormat};

/// How frames are stored or sent: as they are (RGB), or as a camera encodes them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Encoding {
    /// Lossless RGB (PNG in a frame set).
    #[default]
    Rgb,
    /// YUYV 4:2:2.
    Yuyv,
    /// JPEG 4:2:2 at a quality (1–100).
    Mjpeg(u8),
}

impl std::str::FromStr for Encoding {
    type Err = String;
    fn from_str(s: &str) -> Result<Encoding, String> {
        let bad = || format!("encoding {s:?}: expected rgb, yuyv or mjpeg:QUALITY (1–100)");
        match s {
            "rgb" | "png" => Ok(Encoding::Rgb),
            "yuyv" => Ok(Encoding::Yuyv),
            _ => {
                let q = s.strip_prefix("mjpeg:").ok_or_else(bad)?;
                match q.parse::<u8>() {
                    Ok(q @ 1..=100) => Ok(Encoding::Mjpeg(q)),
                    _ => Err(bad()),
                }
            }
        }
    }
}

impl std::fmt::Display for Encoding {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Encoding::Rgb => write!(f, "rgb"),
            Encoding::Yuyv => write!(f, "yuyv"),
            Encoding::Mjpeg(q) => write!(f, "mjpeg:{q}"),
        }
    }
}

impl Encoding {
    /// The frame format of bytes in this encoding.
    pub fn pixel_format(self) -> PixelFormat {
        match self {
            Encoding::Rgb => PixelFormat::Rgb8,
            Encoding::Yuyv => PixelFormat::Yuyv,
            Encoding::Mjpeg(_) => PixelFormat::Mjpeg,
        }
    }

    /// `img` as a camera sends it in this encoding: a frame captured at time zero,
    /// sequence number 0.
    pub fn frame(self, img: &RgbImage) -> Result<Frame, String> {
        Ok(Frame {
            width: img.width(),
            height: img.height(),
            format: self.pixel_format(),
            data: self.encode(img)?,
            timestamp: std::time::Duration::ZERO,
            seq: 0,
        })
    }

    /// `img` encoded. YUYV needs an even width; an error names what cannot be encoded.
    pub fn encode(self, img: &RgbImage) -> Result<Vec<u8>, String> {
        match self {
            Encoding::Rgb => Ok(img.as_raw().clone()),
            Encoding::Yuyv => yuyv(img),
            Encoding::Mjpeg(q) => mjpeg(img, q),
        }
    }
}

/// BT.601 limited range of an sRGB pixel, 8.8 fixed point: (Y, Cb, Cr).
fn ycbcr_limited(p: [u8; 3]) -> [i32; 3] {
    let [r, g, b] = p.map(i32::from);
    [
        (66 * r + 129 * g + 25 * b + 128 + (16 << 8)),
        (-38 * r - 74 * g + 112 * b + 128 + (128 << 8)),
        (112 * r - 94 * g - 18 * b + 128 + (128 << 8)),
    ]
}

fn yuyv(img: &RgbImage) -> Result<Vec<u8>, String> {
    if !img.width().is_multiple_of(2) {
        return Err(format!("YUYV needs an even width, not {} px", img.width()));
    }
    let px = img.as_raw().as_chunks::<3>().0;
    let mut out = Vec::with_capacity(px.len() * 2);
    for pair in px.as_chunks::<2>().0 {
        let (a, b) = (ycbcr_limited(pair[0]), ycbcr_limited(pair[1]));
        let byte = |v: i32| (v >> 8).clamp(0, 255) as u8;
        out.extend_from_slice(&[
            byte(a[0]),
            byte((a[1] + b[1]) / 2),
            byte(b[0]),
            byte((a[2] + b[2]) / 2),
        ]);
    }
    Ok(out)
}

fn mjpeg(img: &RgbImage, quality: u8) -> Result<Vec<u8>, String> {
    let too_big = || {
        format!(
            "{}×{} px is too large for a JPEG",
            img.width(),
            img.height()
        )
    };
    let w = u16::try_from(img.width()).map_err(|_| too_big())?;
    let h = u16::try_from(img.height()).map_err(|_| too_big())?;
    let mut out = Vec::new();
    let mut enc = jpeg_encoder::Encoder::new(&mut out, quality.clamp(1, 100));
    enc.set_sampling_factor(jpeg_encoder::SamplingFactor::R_4_2_2);
    enc.encode(img.as_raw(), w, h, jpeg_encoder::ColorType::Rgb)
        .map_err(|e| format!("JPEG encoding: {e}"))?;
    Ok(out)
}

/// A test image like the skin's: coloured stripes (an orange pigment) between black ones,
/// `period` px, slightly tilted, under a light falling off to one side.
#[cfg(test)]
pub(crate) fn grating(w: u32, h: u32, period: f32) -> RgbImage {
    RgbImage::from_fn(w, h, |x, y| {
        let phase = std::f32::consts::TAU * (x as f32 + 0.12 * y as f32) / period;
        let v = (0.5 + 0.5 * phase.cos()) * (1.0 - 0.3 * x as f32 / w as f32);
        let c = |k: f32| (20.0 + k * v) as u8;
        image::Rgb([c(210.0), c(130.0), c(60.0)])
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn decoded_rgb(e: Encoding, img: &RgbImage) -> RgbImage {
        e.frame(img).unwrap().to_rgb().unwrap()
    }

    #[test]
    fn encodings_parse_and_print_back() {
        for s in ["rgb", "yuyv", "mjpeg:85"] {
            assert_eq!(s.parse::<Encoding>().unwrap().to_string(), s);
        }
        for bad in ["mjpeg", "mjpeg:0", "mjpeg:101", "h264"] {
            assert!(bad.parse::<Encoding>().unwrap_err().contains(bad));
        }
    }

    /// Each encoding decodes back to the image within its own loss: YUYV's rounding and
    /// shared chroma, JPEG's quantisation and its chroma at half the columns, repeated
    /// (which on stripes of 11 px costs the red and blue channels a few levels even at
    /// quality 95).
    #[test]
    fn encoded_frames_decode_back_to_the_image() {
        let img = grating(64, 48, 11.0);
        for (e, mean_max) in [
            (Encoding::Yuyv, 5.0),
            (Encoding::Mjpeg(95), 5.0),
            (Encoding::Mjpeg(75), 6.5),
        ] {
            let back = decoded_rgb(e, &img);
            let diffs: Vec<f64> = img
                .as_raw()
                .iter()
                .zip(back.as_raw())
                .map(|(a, b)| (f64::from(*a) - f64::from(*b)).abs())
                .collect();
            let mean = diffs.iter().sum::<f64>() / diffs.len() as f64;
            assert!(mean < mean_max, "{e}: mean error {mean:.2}");
        }
        assert!(Encoding::Yuyv.encode(&RgbImage::new(3, 2)).is_err());
    }

    /// The JPEG is 4:2:2, as a UVC camera sends it: the luminance component is sampled
    /// twice across, once down (SOF0's sampling factors 0x21).
    #[test]
    fn jpeg_is_four_two_two() {
        let jpeg = Encoding::Mjpeg(90).encode(&grating(64, 48, 11.0)).unwrap();
        let sof = jpeg
            .windows(2)
            .position(|m| m == [0xFF, 0xC0])
            .expect("baseline frame header");
        // FF C0, length (2), precision, height (2), width (2), count, then id, factors.
        assert_eq!(jpeg[sof + 9], 3);
        assert_eq!(jpeg[sof + 11], 0x21);
        assert_eq!(jpeg[sof + 14], 0x11);
    }
}
