//! A camera frame's bytes to the pipeline's input: three bytes per pixel, in the colour
//! encoding the bytes decode to most cheaply ([`Colour`]), at `1/scale` of the camera's
//! size, with no RGB image on the way.
//!
//! * **YUYV** (BT.601, limited range): Y, U and V are read as they are; at a scale of 2 or
//!   more, each output pixel is the mean of its `scale × scale` block (chroma is shared by
//!   two pixels across, so it is averaged over the same block); the crate's `yuyv` module.
//! * **MJPEG**: decoded straight to the scale asked for (the crate's `jpeg` module).
//!   JPEG's 8 × 8 blocks allow a scaled inverse DCT (a 4 × 4, 2 × 2 or 1 × 1 transform of
//!   each block's lowest frequencies, as libjpeg-turbo's scaled decoding does), so a
//!   1/4-scale decode never forms the full image; its planes come out interleaved as Y,
//!   Cb, Cr (JFIF, full range), without a colour conversion. UVC cameras may leave out
//!   the Huffman tables (the standard ones are implied). A JPEG that is not a camera's
//!   baseline frame (progressive, several scans) goes to `jpeg-decoder`, at the same
//!   scales.
//! * **RGB and grey** (files, test sources): averaged per block when scaled.
//!
//! A scaled decode is an area filter of its own: what it removes is finer than the
//! pipeline's working resolution (the calibration chooses the scale so:
//! `vistaf_pipeline::input::decode_scale`).

pub use crate::frame::Colour;
use image::RgbImage;

use crate::frame::{size_ok, size_refused, Frame, FrameError, PixelFormat};
pub use crate::jpeg::{scale_fits, SCALES};
use crate::jpeg::{Jpeg, JpegError};
use crate::yuyv::yuyv;

/// A decoded frame: `width × height` pixels of three bytes in `colour`, row-major.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Decoded {
    /// Width, pixels (the camera's width over the scale).
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Three bytes per pixel.
    pub data: Vec<u8>,
    /// What the bytes mean.
    pub colour: Colour,
}

impl Frame {
    /// Decodes this frame at `1/scale` of its size, into `buf`'s buffer where it needs one:
    /// an RGB frame read whole hands its own bytes over, uncopied.
    pub fn into_decoded(self, scale: u32, mut buf: Decoded) -> Result<Decoded, FrameError> {
        if self.format == PixelFormat::Rgb8 && scale == 1 {
            self.check_len()?;
            return Ok(Decoded {
                width: self.width,
                height: self.height,
                data: self.data,
                colour: Colour::Rgb,
            });
        }
        self.decode_into(scale, &mut buf)?;
        Ok(buf)
    }

    /// Converts to 8-bit RGB, keeping this frame (copies its bytes when already RGB).
    pub fn to_rgb(&self) -> Result<RgbImage, FrameError> {
        self.clone().into_rgb()
    }

    /// Converts to 8-bit RGB: decoded whole ([`Frame::into_decoded`]), then each pixel's
    /// colour converted; an RGB frame's bytes are taken over without a copy.
    pub fn into_rgb(self) -> Result<RgbImage, FrameError> {
        let (w, h, seq, format) = (self.width, self.height, self.seq, self.format);
        let d = self.into_decoded(1, Decoded::default())?;
        let data = match d.colour {
            Colour::Rgb => d.data,
            c => d
                .data
                .as_chunks::<3>()
                .0
                .iter()
                .flat_map(|&p| c.to_rgb(p))
                .collect(),
        };
        let got = data.len();
        RgbImage::from_raw(w, h, data).ok_or(FrameError::WrongLength {
            seq,
            width: w,
            height: h,
            format,
            got,
            want: w as usize * h as usize * 3,
        })
    }

    /// Decodes this frame at `1/scale` of its size into `out` (its buffer reused).
    pub fn decode_into(&self, scale: u32, out: &mut Decoded) -> Result<(), FrameError> {
        let (w, h) = (self.width, self.height);
        if !size_ok(w, h) || !scale_fits(w, h, scale) {
            return Err(self.decode_error(format!(
                "{}; cannot be read at 1/{scale} (a scale of 1, 2, 4 or 8 that divides both sides)",
                size_refused(w, h)
            )));
        }
        self.check_len()?;
        let s = scale as usize;
        out.width = w / scale;
        out.height = h / scale;
        out.data.clear();
        match self.format {
            PixelFormat::Rgb8 => {
                out.colour = Colour::Rgb;
                if s == 1 {
                    out.data.extend_from_slice(&self.data);
                } else {
                    box_mean::<3>(&self.data, w as usize, s, &mut out.data, |p| p);
                }
            }
            PixelFormat::Gray8 => {
                out.colour = Colour::YCbCrFull;
                box_mean::<1>(&self.data, w as usize, s, &mut out.data, |p| {
                    [p[0], 128, 128]
                });
            }
            PixelFormat::Yuyv => {
                out.colour = Colour::YCbCrLimited;
                yuyv(&self.data, w as usize, s, &mut out.data);
            }
            PixelFormat::Mjpeg => {
                out.colour = Colour::YCbCrFull;
                self.jpeg(scale, out)?;
            }
        }
        Ok(())
    }

    /// Decodes this frame at `1/scale` of its size.
    pub fn decode(&self, scale: u32) -> Result<Decoded, FrameError> {
        let mut out = Decoded::default();
        self.decode_into(scale, &mut out)?;
        Ok(out)
    }

    fn decode_error(&self, detail: String) -> FrameError {
        FrameError::Decode {
            seq: self.seq,
            format: self.format,
            detail,
        }
    }

    /// An MJPEG frame at `1/scale`, as Y, Cb, Cr: the header's size checked first, so
    /// nothing larger than the frame is decoded. A camera's baseline JPEG decodes here
    /// ([`crate::jpeg`]); any other JPEG (a progressive file, say) in `jpeg-decoder`.
    fn jpeg(&self, scale: u32, out: &mut Decoded) -> Result<(), FrameError> {
        let jpeg = match Jpeg::parse(&self.data) {
            Ok(jpeg) => jpeg,
            Err(JpegError::Unsupported(_)) => return self.general_jpeg(scale, out),
            Err(e) => return Err(self.decode_error(e.to_string())),
        };
        self.check_header_size(jpeg.size())?;
        out.data
            .resize(out.width as usize * out.height as usize * 3, 0);
        jpeg.decode_into(scale, &mut out.data)
            .map_err(|e| self.decode_error(e.to_string()))
    }

    fn check_header_size(&self, (got_w, got_h): (u32, u32)) -> Result<(), FrameError> {
        if (got_w, got_h) == (self.width, self.height) {
            return Ok(());
        }
        Err(FrameError::WrongSize {
            seq: self.seq,
            width: self.width,
            height: self.height,
            got_w,
            got_h,
        })
    }

    /// [`Frame::jpeg`] by `jpeg-decoder`, for what a camera does not send.
    fn general_jpeg(&self, scale: u32, out: &mut Decoded) -> Result<(), FrameError> {
        let bytes = with_implied_tables(&self.data);
        let mut dec = jpeg_decoder::Decoder::new(std::io::Cursor::new(&bytes[..]));
        let err = |e: jpeg_decoder::Error| self.decode_error(e.to_string());
        dec.read_info().map_err(err)?;
        let info = dec
            .info()
            .ok_or_else(|| self.decode_error("no frame header".into()))?;
        self.check_header_size((u32::from(info.width), u32::from(info.height)))?;
        let want = (out.width, out.height);
        let got = dec.scale(want.0 as u16, want.1 as u16).map_err(err)?;
        if (u32::from(got.0), u32::from(got.1)) != want {
            return Err(self.decode_error(format!(
                "decoded at {}×{}, not at 1/{scale} ({}×{})",
                got.0, got.1, want.0, want.1
            )));
        }
        // The "RGB" transform interleaves the components as they are: Y, Cb, Cr here.
        // (`None` writes each component's padded line buffer whole, which overruns a
        // subsampled frame's rows.)
        match info.pixel_format {
            jpeg_decoder::PixelFormat::RGB24 => {
                dec.set_color_transform(jpeg_decoder::ColorTransform::RGB)
            }
            jpeg_decoder::PixelFormat::L8 => {}
            other => {
                return Err(self.decode_error(format!(
                    "{other:?} pixels: a camera frame is Y, Cb, Cr or grey"
                )))
            }
        }
        // A decoder that panics on bytes it did not expect must not take the capture
        // thread with it: a corrupt frame is an error like any other.
        let decoded = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| dec.decode()));
        let data = decoded
            .map_err(|_| self.decode_error("the decoder failed on these bytes".into()))?
            .map_err(err)?;
        let n = want.0 as usize * want.1 as usize;
        match data.len() / n.max(1) {
            3 if data.len() == 3 * n => out.data = data,
            1 if data.len() == n => out.data.extend(data.iter().flat_map(|&y| [y, 128, 128])),
            _ => {
                return Err(self.decode_error(format!(
                    "{} bytes for {}×{} pixels: not Y, Cb, Cr or grey",
                    data.len(),
                    want.0,
                    want.1
                )))
            }
        }
        Ok(())
    }
}

/// The JPEG's bytes, with an `AVI1` application marker after the start of image when no
/// Huffman table comes before the first scan: a UVC camera's MJPEG frame leaves the
/// standard tables out, and that marker is how `jpeg-decoder` knows to use them (a frame
/// with tables of its own keeps them: the decoder fills only the missing ones).
fn with_implied_tables(data: &[u8]) -> std::borrow::Cow<'_, [u8]> {
    const DHT: u8 = 0xC4;
    const SOS: u8 = 0xDA;
    let mut i = 2;
    while i + 4 <= data.len() && data[i] == 0xFF {
        let marker = data[i + 1];
        if marker == DHT {
            return data.into();
        }
        if marker == SOS {
            break;
        }
        if marker == 0xFF {
            i += 1;
            continue;
        }
        i += 2 + usize::from(u16::from_be_bytes([data[i + 2], data[i + 3]]));
    }
    if data.len() < 2 {
        return data.into();
    }
    const AVI1: [u8; 9] = [0xFF, 0xE0, 0x00, 0x07, b'A', b'V', b'I', b'1', 0];
    let mut v = Vec::with_capacity(data.len() + AVI1.len());
    v.extend_from_slice(&data[..2]);
    v.extend_from_slice(&AVI1);
    v.extend_from_slice(&data[2..]);
    v.into()
}

/// Per-channel mean of each `s × s` block of an image of `C` bytes per pixel and `w`
/// columns, appended to `out` as three bytes per pixel (`three` maps a pixel's `C` bytes
/// to them).
fn box_mean<const C: usize>(
    data: &[u8],
    w: usize,
    s: usize,
    out: &mut Vec<u8>,
    three: impl Fn([u8; C]) -> [u8; 3],
) {
    let h = data.len() / (w * C).max(1);
    let (ow, oh) = (w / s, h / s);
    out.reserve(ow * oh * 3);
    if s == 1 {
        let (px, _) = data.as_chunks::<C>();
        out.extend(px.iter().flat_map(|&p| three(p)));
        return;
    }
    let n = (s * s) as u32;
    let mut sum = vec![0u32; ow * C];
    for oy in 0..oh {
        sum.fill(0);
        for y in oy * s..(oy + 1) * s {
            let line = &data[y * w * C..(y * w + ow * s) * C];
            for (x, p) in line.as_chunks::<C>().0.iter().enumerate() {
                let o = x / s * C;
                for c in 0..C {
                    sum[o + c] += u32::from(p[c]);
                }
            }
        }
        out.extend(
            sum.as_chunks::<C>()
                .0
                .iter()
                .flat_map(|b| three(b.map(|v| ((v + n / 2) / n) as u8))),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    fn frame(format: PixelFormat, w: u32, h: u32, data: Vec<u8>) -> Frame {
        Frame {
            width: w,
            height: h,
            format,
            data,
            timestamp: Duration::ZERO,
            seq: 5,
        }
    }

    #[test]
    fn wrong_lengths_and_bad_jpeg_are_errors() {
        let f = Frame {
            width: 4,
            height: 2,
            format: PixelFormat::Yuyv,
            data: vec![0; 15],
            timestamp: Duration::ZERO,
            seq: 3,
        };
        let e = f.to_rgb().unwrap_err().to_string();
        assert!(
            e.contains("frame 3") && e.contains("15 bytes") && e.contains("16"),
            "{e}"
        );
        let j = Frame {
            format: PixelFormat::Mjpeg,
            data: vec![0xff, 0xd8, 0xff],
            ..f
        };
        assert!(matches!(j.to_rgb(), Err(FrameError::Decode { .. })));
    }

    #[test]
    fn yuyv_converts_every_pixel() {
        let f = Frame {
            width: 2,
            height: 1,
            format: PixelFormat::Yuyv,
            data: vec![16, 128, 235, 128],
            timestamp: Duration::ZERO,
            seq: 0,
        };
        let img = f.to_rgb().unwrap();
        assert_eq!(img.get_pixel(0, 0).0, [0, 0, 0]);
        assert_eq!(img.get_pixel(1, 0).0, [255, 255, 255]);
    }
    #[test]
    fn yuyv_reads_y_u_v_as_they_are_and_averages_blocks() {
        let f = frame(PixelFormat::Yuyv, 2, 1, vec![16, 100, 235, 200]);
        let d = f.decode(1).unwrap();
        assert_eq!(d.colour, Colour::YCbCrLimited);
        assert_eq!(d.data, [16, 100, 200, 235, 100, 200]);
        // 4 × 2 at 1/2: two blocks of 2 × 2.
        let f = frame(
            PixelFormat::Yuyv,
            4,
            2,
            vec![
                10, 100, 20, 200, 50, 60, 70, 80, //
                30, 102, 40, 202, 90, 64, 110, 84,
            ],
        );
        let d = f.decode(2).unwrap();
        assert_eq!((d.width, d.height), (2, 1));
        assert_eq!(d.data, [25, 101, 201, 80, 62, 82]);
    }

    #[test]
    fn rgb_and_grey_average_blocks() {
        let rgb = frame(
            PixelFormat::Rgb8,
            2,
            2,
            vec![0, 10, 20, 2, 10, 20, 4, 10, 20, 6, 14, 20],
        );
        let d = rgb.decode(2).unwrap();
        assert_eq!((d.colour, d.data), (Colour::Rgb, vec![3, 11, 20]));
        let grey = frame(PixelFormat::Gray8, 2, 1, vec![7, 9]);
        assert_eq!(grey.decode(1).unwrap().data, [7, 128, 128, 9, 128, 128]);
    }

    #[test]
    fn scales_that_do_not_divide_and_bad_bytes_are_errors() {
        let f = frame(PixelFormat::Yuyv, 6, 2, vec![0; 24]);
        let e = f.decode(4).unwrap_err().to_string();
        assert!(e.contains("frame 5") && e.contains("1/4"), "{e}");
        assert!(f.decode(3).is_err());
        let short = frame(PixelFormat::Yuyv, 6, 2, vec![0; 23]);
        assert!(matches!(
            short.decode(1),
            Err(FrameError::WrongLength { .. })
        ));
        for junk in [vec![], vec![0xFF, 0xD8], vec![0xFF, 0xD8, 0xFF, 0xC4, 0xFF]] {
            let j = frame(PixelFormat::Mjpeg, 8, 8, junk);
            assert!(matches!(j.decode(1), Err(FrameError::Decode { .. })));
        }
    }

    /// A JPEG at 1/2, 1/4 and 1/8 matches the full decode averaged over the same blocks,
    /// within what separates a truncated inverse DCT from a box filter; a frame without Huffman tables (as a
    /// UVC camera sends it) decodes the same.
    #[test]
    fn scaled_jpeg_is_the_full_decode_averaged() {
        let (w, h) = (256u32, 96u32);
        let jpeg_of = |period: f32| {
            let img = crate::encode::grating(w, h, period);
            let jpeg = crate::encode::Encoding::Mjpeg(95).encode(&img).unwrap();
            frame(PixelFormat::Mjpeg, w, h, jpeg)
        };
        for s in [2u32, 4, 8] {
            // A grating as coarse as a camera's whose frames are decoded at 1/s
            // (`vistaf_pipeline::input::decode_scale`).
            let f = jpeg_of(12.0 * s as f32);
            let full = f.decode(1).unwrap();
            assert_eq!(full.colour, Colour::YCbCrFull);
            let scaled = f.decode(s).unwrap();
            let mut want = Vec::new();
            box_mean::<3>(&full.data, w as usize, s as usize, &mut want, |p| p);
            // Luminance, what the phase is read from, within a few levels: the truncated
            // transform passes the stripes' fundamental, which a box dims by a few per
            // cent. Chroma within its own subsampling's difference. Neither is biased: a
            // block's mean colour, what the temperature reads, is kept.
            for (c, worst_max, mean_max) in [(0, 10, 3.0), (1, 20, 6.0), (2, 20, 6.0)] {
                let (worst, mean, bias) = crate::jpeg::tests::stats(&scaled.data, &want, c);
                assert!(
                    worst <= worst_max && mean < mean_max && bias.abs() < 1.0,
                    "1/{s} channel {c}: worst {worst}, mean {mean:.2}, bias {bias:.2}"
                );
            }
        }
        // The same image without its DHT segments.
        let f = jpeg_of(11.0);
        let jpeg = f.data.clone();
        let mut stripped = Vec::new();
        let mut i = 2;
        stripped.extend_from_slice(&jpeg[..2]);
        while jpeg[i + 1] != 0xDA {
            let len = usize::from(u16::from_be_bytes([jpeg[i + 2], jpeg[i + 3]]));
            if jpeg[i + 1] != 0xC4 {
                stripped.extend_from_slice(&jpeg[i..i + 2 + len]);
            }
            i += 2 + len;
        }
        stripped.extend_from_slice(&jpeg[i..]);
        assert!(stripped.len() < jpeg.len());
        // The encoder writes the standard tables, so the implied ones decode it.
        let bare = frame(PixelFormat::Mjpeg, w, h, stripped);
        assert_eq!(bare.decode(2).unwrap(), f.decode(2).unwrap());
    }

    /// Corrupt and truncated JPEG frames decode to an error or to pixels, at every scale,
    /// and never panic.
    #[test]
    fn corrupt_jpeg_frames_are_errors_not_panics() {
        let img = crate::encode::grating(64, 48, 12.0);
        let good = crate::encode::Encoding::Mjpeg(85).encode(&img).unwrap();
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        for i in 0..3000 {
            let mut bytes = good.clone();
            // Half the changes land in the headers (tables, sizes, sampling factors).
            let header_len = bytes.len().min(650);
            for _ in 0..1 + next() % 8 {
                let span = if i % 2 == 0 { header_len } else { bytes.len() };
                let k = (next() as usize) % span;
                bytes[k] = next() as u8;
            }
            if i % 3 == 0 {
                bytes.truncate((next() as usize) % bytes.len());
            }
            let f = frame(PixelFormat::Mjpeg, 64, 48, bytes);
            let scale = [1, 2, 4, 8][i % 4];
            if let Ok(d) = f.decode(scale) {
                assert_eq!(d.data.len(), (64 / scale * 48 / scale * 3) as usize);
            }
        }
    }

    #[test]
    fn a_jpeg_of_another_size_is_refused_before_decoding() {
        let img = image::RgbImage::new(16, 16);
        let mut jpeg = Vec::new();
        image::codecs::jpeg::JpegEncoder::new(&mut jpeg)
            .encode_image(&img)
            .unwrap();
        let f = frame(PixelFormat::Mjpeg, 32, 16, jpeg);
        assert!(matches!(f.decode(1), Err(FrameError::WrongSize { .. })));
    }
}
