//! Frames as cameras deliver them, and their conversion to the pipeline's input (8-bit RGB).

use std::time::Duration;

use image::RgbImage;

/// Most pixels a frame may have (4096 × 4096: a 4K camera fits). Sizes are checked from
/// a file's or a JPEG's header against it before anything is decoded, so a small file that
/// declares an enormous image is refused with its size named instead of exhausting memory.
pub const MAX_FRAME_PX: u64 = 4096 * 4096;

/// Whether `width × height` is a frame size this software accepts.
pub fn size_ok(width: u32, height: u32) -> bool {
    width > 0 && height > 0 && u64::from(width) * u64::from(height) <= MAX_FRAME_PX
}

/// Why a size is refused, in words.
pub fn size_refused(width: u32, height: u32) -> String {
    format!(
        "{width}×{height} px: a frame has 1 to {} pixels ({}×{} at most)",
        MAX_FRAME_PX, 4096, 4096
    )
}

/// How a decoded pixel's three bytes encode its colour.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Colour {
    /// sRGB: R, G, B.
    #[default]
    Rgb,
    /// Y, Cb, Cr, BT.601, full range (JPEG/JFIF; a grey frame's Y).
    YCbCrFull,
    /// Y, Cb, Cr, BT.601, limited range: Y 16…235, Cb and Cr 16…240 (YUYV from a UVC
    /// camera).
    YCbCrLimited,
}

impl Colour {
    /// sRGB bytes of one pixel `p` in this encoding (integer BT.601, 8.8 fixed point).
    #[inline(always)]
    pub fn to_rgb(self, p: [u8; 3]) -> [u8; 3] {
        self.to_rgb_q8(p)
            .map(|x| ((x + 128) >> 8).clamp(0, 255) as u8)
    }

    /// Whether one of `p`'s sRGB bytes ([`Colour::to_rgb`]) is 255: a channel at or
    /// past the top, told before clamping.
    #[inline(always)]
    pub fn saturates(self, p: [u8; 3]) -> bool {
        let [r, g, b] = self.to_rgb_q8(p);
        r.max(g).max(b) + 128 >= 255 << 8
    }

    /// `p`'s sRGB channels in 8.8 fixed point, before rounding and clamping to 0…255.
    #[inline(always)]
    fn to_rgb_q8(self, p: [u8; 3]) -> [i32; 3] {
        let (y, cb, cr) = (
            i32::from(p[0]),
            i32::from(p[1]) - 128,
            i32::from(p[2]) - 128,
        );
        match self {
            Colour::Rgb => p.map(|v| i32::from(v) << 8),
            // R = Y + 1.402 Cr, G = Y − 0.344 Cb − 0.714 Cr, B = Y + 1.772 Cb.
            Colour::YCbCrFull => {
                let c = y * 256;
                [c + 359 * cr, c - 88 * cb - 183 * cr, c + 454 * cb]
            }
            // The same on Y, Cb, Cr stretched from 219 and 224 levels to 255.
            Colour::YCbCrLimited => {
                let c = (y - 16).max(0) * 298;
                [c + 409 * cr, c - 100 * cb - 208 * cr, c + 516 * cb]
            }
        }
    }
}

/// Pixel layout of a captured frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PixelFormat {
    /// Packed 8-bit R, G, B.
    Rgb8,
    /// 8-bit grey.
    Gray8,
    /// YUV 4:2:2, Y0 U Y1 V per two pixels (V4L2 `YUYV`).
    Yuyv,
    /// Motion JPEG: one JPEG image per frame.
    Mjpeg,
}

impl PixelFormat {
    /// Bytes per frame of `width × height` pixels; `None` for compressed formats.
    pub fn frame_len(self, width: u32, height: u32) -> Option<usize> {
        let px = width as usize * height as usize;
        match self {
            PixelFormat::Rgb8 => Some(px * 3),
            PixelFormat::Gray8 => Some(px),
            PixelFormat::Yuyv => Some(px * 2),
            PixelFormat::Mjpeg => None,
        }
    }
}

/// One captured frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Layout of `data`.
    pub format: PixelFormat,
    /// Pixel bytes.
    pub data: Vec<u8>,
    /// Capture time: on the device's clock ([`crate::clock`]) from a camera or the
    /// simulated skin, the recorded time from a replayed set.
    pub timestamp: Duration,
    /// Sequence number from the source; gaps mean frames the source dropped.
    pub seq: u64,
}

/// A frame could not be converted: the bytes do not match what the header says.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    /// Uncompressed frame with the wrong number of bytes.
    #[error("frame {seq}: {got} bytes, a {width}×{height} {format:?} frame has {want}")]
    WrongLength {
        /// Frame sequence number.
        seq: u64,
        /// Width, pixels.
        width: u32,
        /// Height, pixels.
        height: u32,
        /// Format.
        format: PixelFormat,
        /// Bytes received.
        got: usize,
        /// Bytes expected.
        want: usize,
    },
    /// A compressed frame that does not decode (truncated MJPEG, say).
    #[error("frame {seq}: cannot decode {format:?}: {detail}")]
    Decode {
        /// Frame sequence number.
        seq: u64,
        /// Format.
        format: PixelFormat,
        /// The decoder's message.
        detail: String,
    },
    /// A decoded frame whose size differs from its header.
    #[error("frame {seq}: decoded {got_w}×{got_h}, expected {width}×{height}")]
    WrongSize {
        /// Frame sequence number.
        seq: u64,
        /// Expected width.
        width: u32,
        /// Expected height.
        height: u32,
        /// Decoded width.
        got_w: u32,
        /// Decoded height.
        got_h: u32,
    },
}

impl Frame {
    /// A frame holding an RGB image.
    pub fn from_rgb(img: RgbImage, timestamp: Duration, seq: u64) -> Frame {
        Frame {
            width: img.width(),
            height: img.height(),
            format: PixelFormat::Rgb8,
            data: img.into_raw(),
            timestamp,
            seq,
        }
    }

    /// An uncompressed frame whose bytes are not its size's: an error naming both.
    pub fn check_len(&self) -> Result<(), FrameError> {
        match self.format.frame_len(self.width, self.height) {
            Some(want) if self.data.len() != want => Err(FrameError::WrongLength {
                seq: self.seq,
                width: self.width,
                height: self.height,
                format: self.format,
                got: self.data.len(),
                want,
            }),
            _ => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn saturates_exactly_where_a_converted_channel_is_255() {
        let levels = (0..=255u8).step_by(3).chain([1, 2, 254, 255]);
        let grid: Vec<u8> = levels.collect();
        for c in [Colour::Rgb, Colour::YCbCrFull, Colour::YCbCrLimited] {
            let mut both = [0usize; 2];
            for &a in &grid {
                for &b in &grid {
                    for &d in &grid {
                        let p = [a, b, d];
                        let want = c.to_rgb(p).contains(&255);
                        assert_eq!(c.saturates(p), want, "{c:?} {p:?}");
                        both[usize::from(want)] += 1;
                    }
                }
            }
            assert!(both[0] > 0 && both[1] > 0, "{c:?}: {both:?}");
        }
    }

    #[test]
    fn ycbcr_primaries_convert_to_rgb() {
        let full = Colour::YCbCrFull;
        assert_eq!(full.to_rgb([0, 128, 128]), [0, 0, 0]);
        assert_eq!(full.to_rgb([255, 128, 128]), [255, 255, 255]);
        let red = full.to_rgb([76, 85, 255]);
        assert!(red[0] >= 253 && red[1] <= 2 && red[2] <= 2, "{red:?}");
        let lim = Colour::YCbCrLimited;
        assert_eq!(lim.to_rgb([16, 128, 128]), [0, 0, 0]);
        assert_eq!(lim.to_rgb([235, 128, 128]), [255, 255, 255]);
        let red = lim.to_rgb([81, 90, 240]);
        assert!(red[0] > 250 && red[1] < 5 && red[2] < 5, "{red:?}");
    }
}
