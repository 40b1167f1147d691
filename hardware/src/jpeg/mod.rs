//! A camera's MJPEG frame decoded at 1/1, 1/2, 1/4 or 1/8 of its size into Y, Cb, Cr
//! bytes per pixel: baseline JPEG as UVC cameras send it (8-bit, Huffman coded, one
//! interleaved scan, grey or Y, Cb, Cr at 4:4:4, 4:2:2 or 4:2:0, restart markers or none,
//! the standard Huffman tables implied when left out).
//!
//! Our own because the device decodes every frame on its capture thread and the general
//! decoders do work the pipeline never reads: `jpeg-decoder` decodes at the same scales but
//! starts a thread per colour component for every frame, dequantises and stores every
//! coefficient, upsamples chroma to full width with a filter and clears and interleaves
//! whole-image buffers; `zune-jpeg` decodes only at full size. Here one thread decodes,
//! the coefficients a reduced transform does not read are skipped past in the bit stream,
//! the transform skips rows and columns without coefficients ([`idct`]), and chroma
//! samples are written straight into the output, repeated over the pixels they cover
//! (interpolating them as `jpeg-decoder` does costs more for no accuracy the battery
//! sees; `docs/service.md`). Anything else (progressive, arithmetic, 12-bit,
//! several scans) is [`JpegError::Unsupported`], and `crate::decode` hands it to
//! `jpeg-decoder`. The cost against `jpeg-decoder`'s is in `docs/service.md`.

mod header;
mod huffman;
mod idct;
mod scan;

/// Why a JPEG did not decode here.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum JpegError {
    /// Bytes that are not a JPEG, or one cut short.
    #[error("{0}")]
    Corrupt(String),
    /// A JPEG this decoder leaves to a general one.
    #[error("not a camera's baseline JPEG: {0}")]
    Unsupported(String),
}

/// A JPEG's headers, read; its scan decodes on demand.
pub struct Jpeg<'a> {
    data: &'a [u8],
    header: header::Header,
}

impl<'a> Jpeg<'a> {
    /// Reads the markers up to the first scan.
    pub fn parse(data: &'a [u8]) -> Result<Jpeg<'a>, JpegError> {
        Ok(Jpeg {
            data,
            header: header::parse(data)?,
        })
    }

    /// Width and height, pixels, from the frame header.
    pub fn size(&self) -> (u32, u32) {
        (self.header.width, self.header.height)
    }

    /// Decodes at `1/scale` (1, 2, 4 or 8, dividing both sides) into `out`, which holds
    /// three bytes for each pixel of the scaled image (Y, Cb, Cr, full range).
    pub fn decode_into(&self, scale: u32, out: &mut [u8]) -> Result<(), JpegError> {
        let (w, h) = self.size();
        if !scale_fits(w, h, scale) {
            return Err(JpegError::Corrupt(format!(
                "{w}×{h} cannot be read at 1/{scale}"
            )));
        }
        let (header, data) = (&self.header, self.data);
        match scale {
            1 => scan::decode::<8>(header, data, out),
            2 => scan::decode::<4>(header, data, out),
            4 => scan::decode::<2>(header, data, out),
            _ => scan::decode::<1>(header, data, out),
        }
    }
}

/// Scales a decode may use: the inverse DCT sizes of JPEG.
pub const SCALES: [u32; 4] = [1, 2, 4, 8];

/// Whether a `width × height` frame can be decoded at `1/scale`: a scale of [`SCALES`]
/// that divides both sides.
pub fn scale_fits(width: u32, height: u32, scale: u32) -> bool {
    SCALES.contains(&scale) && width.is_multiple_of(scale) && height.is_multiple_of(scale)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::encode::{grating, Encoding};

    /// `jpeg-decoder`'s output at `1/scale`, as Y, Cb, Cr.
    fn general(jpeg: &[u8], scale: u32) -> Vec<u8> {
        let mut dec = jpeg_decoder::Decoder::new(jpeg);
        dec.read_info().unwrap();
        let (w, h) = dec.info().map(|i| (i.width, i.height)).unwrap();
        dec.scale(w / scale as u16, h / scale as u16).unwrap();
        dec.set_color_transform(jpeg_decoder::ColorTransform::RGB);
        dec.decode().unwrap()
    }

    /// Worst and mean absolute difference of channel `c` of two images of three bytes per
    /// pixel, and the mean difference (the bias).
    pub(crate) fn stats(a: &[u8], b: &[u8], c: usize) -> (i32, f64, f64) {
        let d: Vec<i32> = a[c..]
            .iter()
            .step_by(3)
            .zip(b[c..].iter().step_by(3))
            .map(|(x, y)| i32::from(*x) - i32::from(*y))
            .collect();
        let n = d.len() as f64;
        let worst = d.iter().map(|v| v.abs()).max().unwrap_or(0);
        let mean = f64::from(d.iter().map(|v| v.abs()).sum::<i32>()) / n;
        (worst, mean, f64::from(d.iter().sum::<i32>()) / n)
    }

    /// Luminance as `jpeg-decoder` makes it, within a level of rounding; chroma within
    /// what its smoother upsampling changes (a chroma sample here is repeated over the
    /// pixels it covers, there interpolated: on stripes a few pixels wide the two part by
    /// several levels, but neither is biased).
    fn assert_decodes_as_the_general_decoder(jpeg: &[u8], what: &str) {
        let j = Jpeg::parse(jpeg).unwrap_or_else(|e| panic!("{what}: {e}"));
        let (w, h) = j.size();
        for scale in [1, 2, 4, 8] {
            if !scale_fits(w, h, scale) {
                continue;
            }
            let mut out = vec![0; (w * h / scale / scale * 3) as usize];
            j.decode_into(scale, &mut out).unwrap();
            let mut want = general(jpeg, scale);
            if want.len() == out.len() / 3 {
                want = want.iter().flat_map(|&y| [y, 128, 128]).collect();
            }
            let at = format!("{what} {w}×{h} 1/{scale}");
            let (y_worst, y_mean, _) = stats(&out, &want, 0);
            assert!(
                y_worst <= 1 && y_mean < 0.7,
                "{at}: Y {y_worst} {y_mean:.2}"
            );
            for c in [1, 2] {
                let (worst, mean, bias) = stats(&out, &want, c);
                assert!(
                    worst <= 24 && mean < 6.0 && bias.abs() < 1.0,
                    "{at}: chroma {c} {worst} {mean:.2} {bias:.2}"
                );
            }
        }
    }

    #[test]
    fn camera_frames_decode_as_the_general_decoder_does() {
        for (w, h, period, q) in [(64, 48, 11.0, 90), (200, 120, 23.0, 75), (96, 64, 13.0, 95)] {
            let jpeg = Encoding::Mjpeg(q).encode(&grating(w, h, period)).unwrap();
            assert_decodes_as_the_general_decoder(&jpeg, &format!("q{q}"));
        }
    }

    /// What else a baseline JPEG may be: other chroma sampling, grey, restart markers; and
    /// a size that is not a whole number of blocks. A JPEG of several scans is left to the
    /// general decoder, and decodes there.
    #[test]
    fn other_baseline_jpegs_decode_too() {
        use jpeg_encoder::{ColorType, Encoder, SamplingFactor};
        let img = grating(104, 72, 17.0);
        let encode = |f: &dyn Fn(&mut Encoder<&mut Vec<u8>>), grey: bool| -> Vec<u8> {
            let mut out = Vec::new();
            let mut enc = Encoder::new(&mut out, 85);
            f(&mut enc);
            let luma: Vec<u8> = img.pixels().map(|p| p.0[1]).collect();
            let (data, colour) = if grey {
                (&luma[..], ColorType::Luma)
            } else {
                (img.as_raw().as_slice(), ColorType::Rgb)
            };
            enc.encode(data, 104, 72, colour).unwrap();
            out
        };
        type Setting<'a> = &'a dyn Fn(&mut Encoder<&mut Vec<u8>>);
        let cases: [(&str, Setting<'_>, bool); 4] = [
            (
                "4:4:4",
                &|e| e.set_sampling_factor(SamplingFactor::F_1_1),
                false,
            ),
            (
                "4:2:0",
                &|e| e.set_sampling_factor(SamplingFactor::R_4_2_0),
                false,
            ),
            ("grey", &|_| {}, true),
            ("restarts", &|e| e.set_restart_interval(3), false),
        ];
        for (what, f, grey) in cases {
            assert_decodes_as_the_general_decoder(&encode(f, grey), what);
        }
        let progressive = encode(&|e| e.set_progressive(true), false);
        let separate = encode(&|e| e.set_optimized_huffman_tables(true), false);
        for jpeg in [progressive, separate] {
            assert!(matches!(Jpeg::parse(&jpeg), Err(JpegError::Unsupported(_))));
            let frame = crate::Frame {
                width: 104,
                height: 72,
                format: crate::PixelFormat::Mjpeg,
                data: jpeg,
                timestamp: std::time::Duration::ZERO,
                seq: 0,
            };
            assert_eq!(frame.decode(2).unwrap().data.len(), 52 * 36 * 3);
        }
    }

    /// A frame cut short, or a restart marker lost, is an error, not a picture.
    #[test]
    fn frames_cut_short_are_errors() {
        let jpeg = Encoding::Mjpeg(90).encode(&grating(64, 48, 11.0)).unwrap();
        let cut = &jpeg[..jpeg.len() * 2 / 3];
        let j = Jpeg::parse(cut).unwrap();
        let mut out = vec![0; 64 * 48 * 3];
        assert!(matches!(
            j.decode_into(1, &mut out),
            Err(JpegError::Corrupt(_))
        ));
    }
}
