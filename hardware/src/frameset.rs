//! Frame sets: the `vistaf-frames/1` directory format (see `shared/formats/frame-set.md`).
//!
//! ```text
//! my-set/
//!   set.json        manifest: format, grating_period_mm, reference, frames[] with labels
//!   reference.png   no-contact frame
//!   f0000.png ...   frames
//! ```
//!
//! Frames are PNG, or as a camera sent them: JPEG (`.jpg`, an MJPEG camera's frame byte for
//! byte) or raw YUYV (`.yuyv`, whose size the manifest's `width_px` and `height_px` give).
//!
//! [`FrameSet::open`] validates the manifest and every referenced file's header before
//! anything is processed, and refuses a bad set with an error naming the file and the
//! problem. File names are plain relative names inside the set: absolute paths, `..`, and
//! symbolic links that lead outside the set are refused. Unknown manifest keys (richer
//! ground truth from a simulator) are kept when a set is rewritten and ignored otherwise.
//!
//! Writing is deterministic: the same images and labels give the same bytes, so a set
//! read and written again is byte-identical.

use std::fs;
use std::path::{Component, Path, PathBuf};
use std::time::Duration;

use image::RgbImage;
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};

use crate::decode::Decoded;
use crate::encode::Encoding;
use crate::frame::{Frame, PixelFormat};

/// The format tag every manifest carries.
pub const FORMAT: &str = "vistaf-frames/1";

/// Name of the manifest inside a set.
pub const MANIFEST: &str = "set.json";

/// Largest grating period a manifest may state, mm.
pub const MAX_GRATING_PERIOD_MM: f64 = 100.0;
/// Latest frame time a manifest may state, ms (11.6 days: a recording, not a clock value).
pub const MAX_T_MS: f64 = 1e9;
/// Deepest label a manifest may state, mm.
pub const MAX_DEPTH_MM: f64 = 100.0;
/// Largest force label a manifest may state, N.
pub const MAX_FORCE_N: f64 = 10_000.0;

/// One frame of a set and its optional labels.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct FrameEntry {
    /// File name, relative to the set directory.
    pub file: String,
    /// Capture time since the first frame, ms.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub t_ms: Option<f64>,
    /// Peak indentation depth, mm (0 = no contact).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub depth_mm: Option<f64>,
    /// Applied normal force, N.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub force_n: Option<f64>,
    /// Skin temperature (uniform), or the contact temperature with a heated contact, °C.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub temperature_c: Option<f64>,
    /// Contact centre, x, image pixels.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact_x_px: Option<f64>,
    /// Contact centre, y, image pixels.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact_y_px: Option<f64>,
    /// Keys this version does not know, kept verbatim.
    #[serde(flatten)]
    pub extra: Map<String, Value>,
}

/// The manifest, `set.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// Must be [`FORMAT`].
    pub format: String,
    /// Physical grating period, mm.
    pub grating_period_mm: f64,
    /// File name of the no-contact reference frame.
    pub reference: String,
    /// The frames, in order.
    pub frames: Vec<FrameEntry>,
    /// Frame width, pixels: needed by raw YUYV frames, which do not say it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub width_px: Option<u32>,
    /// Frame height, pixels (with `width_px`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub height_px: Option<u32>,
    /// Keys this version does not know, kept verbatim.
    #[serde(flatten)]
    pub extra: Map<String, Value>,
}

/// How a frame file of a set holds its image, by its name's extension.
fn file_format(name: &str) -> PixelFormat {
    let lower = name.to_ascii_lowercase();
    if lower.ends_with(".jpg") || lower.ends_with(".jpeg") {
        PixelFormat::Mjpeg
    } else if lower.ends_with(".yuyv") {
        PixelFormat::Yuyv
    } else {
        PixelFormat::Rgb8
    }
}

/// Why a frame set was refused. Every variant names the file it is about.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FrameSetError {
    /// The directory or its manifest is missing or unreadable.
    #[error("{path}: {cause}")]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The cause.
        cause: std::io::Error,
    },
    /// The manifest is not valid JSON or lacks a required key.
    #[error("{path}: invalid manifest at line {line}, column {column}: {detail}")]
    Manifest {
        /// The manifest.
        path: PathBuf,
        /// Line of the problem.
        line: usize,
        /// Column of the problem.
        column: usize,
        /// The parser's message.
        detail: String,
    },
    /// The manifest's `format` is not [`FORMAT`].
    #[error("{path}: format is {found:?}, expected {FORMAT:?}")]
    WrongFormat {
        /// The manifest.
        path: PathBuf,
        /// What it says.
        found: String,
    },
    /// A key holds a value outside its valid range.
    #[error("{path}: {key} = {value}: {why}")]
    InvalidValue {
        /// The manifest.
        path: PathBuf,
        /// The key (with the frame index for frame keys).
        key: String,
        /// The value.
        value: String,
        /// What is wrong with it.
        why: &'static str,
    },
    /// A file name that would leave the set directory.
    #[error("{path}: {key} = {value:?} leaves the set directory ({why})")]
    UnsafePath {
        /// The manifest.
        path: PathBuf,
        /// The key.
        key: String,
        /// The file name.
        value: String,
        /// Why it is refused.
        why: &'static str,
    },
    /// A referenced image is missing.
    #[error("{path}: listed in the manifest but missing")]
    MissingFile {
        /// The image.
        path: PathBuf,
    },
    /// An image that does not decode, or not 8-bit RGB/RGBA/grey.
    #[error("{path}: {detail}")]
    Image {
        /// The image.
        path: PathBuf,
        /// What is wrong with it.
        detail: String,
    },
    /// An image whose size differs from the reference's.
    #[error("{path}: {got_w}×{got_h} px, but the reference is {width}×{height} px")]
    SizeMismatch {
        /// The image.
        path: PathBuf,
        /// Reference width.
        width: u32,
        /// Reference height.
        height: u32,
        /// This image's width.
        got_w: u32,
        /// This image's height.
        got_h: u32,
    },
}

/// An opened, validated frame set.
#[derive(Debug, Clone)]
pub struct FrameSet {
    dir: PathBuf,
    /// The manifest.
    pub manifest: Manifest,
    width: u32,
    height: u32,
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> FrameSetError + '_ {
    move |cause| FrameSetError::Io {
        path: path.to_path_buf(),
        cause,
    }
}

/// Checks that `name` is a plain relative path inside the set.
fn check_name(manifest: &Path, key: &str, name: &str) -> Result<(), FrameSetError> {
    let unsafe_path = |why| FrameSetError::UnsafePath {
        path: manifest.to_path_buf(),
        key: key.to_string(),
        value: name.to_string(),
        why,
    };
    if name.is_empty() {
        return Err(unsafe_path("empty file name"));
    }
    if name.contains('\\') || name.contains('\0') {
        return Err(unsafe_path("backslash or NUL in file name"));
    }
    for c in Path::new(name).components() {
        match c {
            Component::Normal(_) | Component::CurDir => {}
            Component::ParentDir => return Err(unsafe_path("'..' is not allowed")),
            Component::RootDir | Component::Prefix(_) => {
                return Err(unsafe_path("absolute paths are not allowed"))
            }
        }
    }
    Ok(())
}

impl Manifest {
    /// Parses and checks a manifest's text (`mpath` names it in errors): its format, its
    /// file names and its values; the images it names are the set's to check.
    pub fn parse(text: &str, mpath: &Path) -> Result<Manifest, FrameSetError> {
        let mpath = mpath.to_path_buf();
        let manifest: Manifest =
            serde_json::from_str(text).map_err(|e| FrameSetError::Manifest {
                path: mpath.clone(),
                line: e.line(),
                column: e.column(),
                detail: e.to_string(),
            })?;
        if manifest.format != FORMAT {
            return Err(FrameSetError::WrongFormat {
                path: mpath,
                found: manifest.format,
            });
        }
        let invalid = |key: String, value: f64, why| FrameSetError::InvalidValue {
            path: mpath.clone(),
            key,
            // Compact for the very large and very small (1e300, not 301 digits).
            value: if value != 0.0 && !(1e-4..1e6).contains(&value.abs()) {
                format!("{value:e}")
            } else {
                value.to_string()
            },
            why,
        };
        let p = manifest.grating_period_mm;
        if !(p.is_finite() && p > 0.0 && p <= MAX_GRATING_PERIOD_MM) {
            return Err(invalid(
                "grating_period_mm".into(),
                p,
                "must be a grating period in mm, above 0 and at most 100",
            ));
        }
        check_name(&mpath, "reference", &manifest.reference)?;
        for (i, f) in manifest.frames.iter().enumerate() {
            check_name(&mpath, &format!("frames[{i}].file"), &f.file)?;
            for (key, v, max, why) in [
                (
                    "t_ms",
                    f.t_ms,
                    MAX_T_MS,
                    "a time of 0 to 10⁹ ms (11.6 days)",
                ),
                (
                    "depth_mm",
                    f.depth_mm,
                    MAX_DEPTH_MM,
                    "a depth of 0 to 100 mm",
                ),
                (
                    "force_n",
                    f.force_n,
                    MAX_FORCE_N,
                    "a force of 0 to 10 000 N",
                ),
            ] {
                if let Some(v) = v {
                    if !(v.is_finite() && (0.0..=max).contains(&v)) {
                        return Err(invalid(format!("frames[{i}].{key}"), v, why));
                    }
                }
            }
            if let Some(t) = f.temperature_c {
                if !(-50.0..=150.0).contains(&t) {
                    return Err(invalid(
                        format!("frames[{i}].temperature_c"),
                        t,
                        "outside -50…150 °C: not a skin temperature",
                    ));
                }
            }
        }
        Ok(manifest)
    }
}

impl FrameSet {
    /// Opens and validates the set in `dir`.
    pub fn open(dir: &Path) -> Result<FrameSet, FrameSetError> {
        let mpath = dir.join(MANIFEST);
        let text = fs::read_to_string(&mpath).map_err(io_err(&mpath))?;
        let manifest = Manifest::parse(&text, &mpath)?;
        let canon_dir = dir.canonicalize().map_err(io_err(dir))?;
        let mut set = FrameSet {
            dir: dir.to_path_buf(),
            manifest,
            width: 0,
            height: 0,
        };
        let (w, h) = set.check_image(&canon_dir, &set.manifest.reference.clone(), None)?;
        set.width = w;
        set.height = h;
        for f in set.manifest.frames.clone() {
            set.check_image(&canon_dir, &f.file, Some((w, h)))?;
        }
        Ok(set)
    }

    /// Validates one image's location and header; returns its size.
    fn check_image(
        &self,
        canon_dir: &Path,
        name: &str,
        want: Option<(u32, u32)>,
    ) -> Result<(u32, u32), FrameSetError> {
        let path = self.dir.join(name);
        if !path.exists() {
            return Err(FrameSetError::MissingFile { path });
        }
        let canon = path.canonicalize().map_err(io_err(&path))?;
        if !canon.starts_with(canon_dir) {
            return Err(FrameSetError::UnsafePath {
                path: self.dir.join(MANIFEST),
                key: "file".into(),
                value: name.to_string(),
                why: "a link that points outside the set",
            });
        }
        let (w, h) = self.header_size(&path, name)?;
        if !crate::frame::size_ok(w, h) {
            return Err(FrameSetError::Image {
                path,
                detail: crate::frame::size_refused(w, h),
            });
        }
        if let Some((ww, wh)) = want {
            if (w, h) != (ww, wh) {
                return Err(FrameSetError::SizeMismatch {
                    path,
                    width: ww,
                    height: wh,
                    got_w: w,
                    got_h: h,
                });
            }
        }
        Ok((w, h))
    }

    /// The size a frame file says it has: a PNG's or JPEG's header, or for raw YUYV the
    /// manifest's, checked against the file's length.
    fn header_size(&self, path: &Path, name: &str) -> Result<(u32, u32), FrameSetError> {
        let bad = |detail: String| FrameSetError::Image {
            path: path.to_path_buf(),
            detail,
        };
        match file_format(name) {
            PixelFormat::Yuyv => {
                let m = &self.manifest;
                let (Some(w), Some(h)) = (m.width_px, m.height_px) else {
                    return Err(bad(
                        "a raw YUYV frame needs the manifest's width_px and height_px".into(),
                    ));
                };
                let len = fs::metadata(path).map_err(io_err(path))?.len();
                let want = 2 * u64::from(w) * u64::from(h);
                if len != want {
                    return Err(bad(format!("{len} bytes, a {w}×{h} YUYV frame has {want}")));
                }
                Ok((w, h))
            }
            PixelFormat::Mjpeg => jpeg_size(&fs::read(path).map_err(io_err(path))?, path),
            _ => {
                let reader = image::ImageReader::open(path)
                    .map_err(io_err(path))?
                    .with_guessed_format()
                    .map_err(io_err(path))?;
                if reader.format() != Some(image::ImageFormat::Png) {
                    return Err(bad("not a PNG file".into()));
                }
                reader.into_dimensions().map_err(|e| bad(e.to_string()))
            }
        }
    }

    /// The set's directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Frame size, pixels (every frame has the reference's size).
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// How the set's frames hold their images (the first frame's, or the reference's in a
    /// set without frames): PNG ([`PixelFormat::Rgb8`]), JPEG or raw YUYV.
    pub fn frame_format(&self) -> PixelFormat {
        let name = self
            .manifest
            .frames
            .first()
            .map_or(&self.manifest.reference, |f| &f.file);
        file_format(name)
    }

    /// Number of frames (not counting the reference).
    pub fn len(&self) -> usize {
        self.manifest.frames.len()
    }

    /// Whether the set has no frames besides the reference.
    pub fn is_empty(&self) -> bool {
        self.manifest.frames.is_empty()
    }

    /// Path of a file of the set.
    pub fn path_of(&self, name: &str) -> PathBuf {
        self.dir.join(name)
    }

    /// Decodes the reference frame to RGB.
    pub fn load_reference(&self) -> Result<RgbImage, FrameSetError> {
        self.rgb(&self.manifest.reference)
    }

    /// Decodes frame `index` to RGB.
    ///
    /// # Panics
    /// If `index >= self.len()`.
    pub fn load_frame(&self, index: usize) -> Result<RgbImage, FrameSetError> {
        self.rgb(&self.manifest.frames[index].file)
    }

    /// The reference as the camera sent it (a PNG's pixels as RGB), sequence number 0.
    pub fn reference_frame(&self) -> Result<Frame, FrameSetError> {
        self.camera_frame(&self.manifest.reference, Duration::ZERO, 0)
    }

    /// Frame `index` as the camera sent it (a PNG's pixels as RGB), at its recorded time
    /// (or 30 frames/s without one), sequence number `index`.
    ///
    /// # Panics
    /// If `index >= self.len()`.
    pub fn frame(&self, index: usize) -> Result<Frame, FrameSetError> {
        let e = &self.manifest.frames[index];
        self.camera_frame(&e.file, self.t_of(index), index as u64)
    }

    /// Capture time of frame `index`: its `t_ms`, or 30 frames/s without one.
    pub fn t_of(&self, index: usize) -> Duration {
        let ms = self.manifest.frames[index]
            .t_ms
            .unwrap_or(index as f64 * 1000.0 / 30.0);
        Duration::from_secs_f64(ms.max(0.0) / 1000.0)
    }

    fn camera_frame(&self, name: &str, t: Duration, seq: u64) -> Result<Frame, FrameSetError> {
        let path = self.dir.join(name);
        let format = file_format(name);
        if format == PixelFormat::Rgb8 {
            return Ok(Frame::from_rgb(self.checked_png(name)?, t, seq));
        }
        let data = fs::read(&path).map_err(io_err(&path))?;
        Ok(Frame {
            width: self.width,
            height: self.height,
            format,
            data,
            timestamp: t,
            seq,
        })
    }

    /// The reference decoded at `1/scale` (see [`crate::decode`]).
    pub fn decoded_reference(&self, scale: u32) -> Result<Decoded, FrameSetError> {
        let mut out = Decoded::default();
        let f = self.reference_frame()?;
        self.decode(&self.manifest.reference, &f, scale, &mut out)?;
        Ok(out)
    }

    /// Frame `index` decoded at `1/scale` into `out` (its buffer reused).
    ///
    /// # Panics
    /// If `index >= self.len()`.
    pub fn decoded_frame(
        &self,
        index: usize,
        scale: u32,
        out: &mut Decoded,
    ) -> Result<(), FrameSetError> {
        let f = self.frame(index)?;
        self.decode(&self.manifest.frames[index].file, &f, scale, out)
    }

    fn decode(
        &self,
        name: &str,
        f: &Frame,
        scale: u32,
        out: &mut Decoded,
    ) -> Result<(), FrameSetError> {
        f.decode_into(scale, out).map_err(|e| FrameSetError::Image {
            path: self.dir.join(name),
            detail: e.to_string(),
        })
    }

    fn rgb(&self, name: &str) -> Result<RgbImage, FrameSetError> {
        if file_format(name) == PixelFormat::Rgb8 {
            return self.checked_png(name);
        }
        let path = self.dir.join(name);
        self.camera_frame(name, Duration::ZERO, 0)?
            .into_rgb()
            .map_err(|e| FrameSetError::Image {
                path,
                detail: e.to_string(),
            })
    }

    fn checked_png(&self, name: &str) -> Result<RgbImage, FrameSetError> {
        let path = self.dir.join(name);
        let img = load_png_rgb(&path)?;
        if img.dimensions() != (self.width, self.height) {
            return Err(FrameSetError::SizeMismatch {
                path,
                width: self.width,
                height: self.height,
                got_w: img.width(),
                got_h: img.height(),
            });
        }
        Ok(img)
    }
}

/// One frame file outside a set, as the camera sent it: a PNG (its pixels as RGB) or a
/// JPEG (its bytes). Raw YUYV does not say its size: it is read from a set, whose
/// manifest does.
pub fn frame_file(path: &Path) -> Result<Frame, FrameSetError> {
    let name = path.to_string_lossy();
    let bad = |detail: String| FrameSetError::Image {
        path: path.to_path_buf(),
        detail,
    };
    match file_format(&name) {
        PixelFormat::Mjpeg => {
            let data = fs::read(path).map_err(io_err(path))?;
            let (width, height) = jpeg_size(&data, path)?;
            Ok(Frame {
                width,
                height,
                format: PixelFormat::Mjpeg,
                data,
                timestamp: Duration::ZERO,
                seq: 0,
            })
        }
        PixelFormat::Yuyv => Err(bad(
            "a raw YUYV frame does not say its size: read it from a frame set".into(),
        )),
        _ => Ok(Frame::from_rgb(load_png_rgb(path)?, Duration::ZERO, 0)),
    }
}

/// A JPEG's size from its frame header (nothing else is decoded); `path` names it in
/// errors.
fn jpeg_size(bytes: &[u8], path: &Path) -> Result<(u32, u32), FrameSetError> {
    let bad = |detail: String| FrameSetError::Image {
        path: path.to_path_buf(),
        detail,
    };
    let mut dec = jpeg_decoder::Decoder::new(bytes);
    dec.read_info()
        .map_err(|e| bad(format!("not a JPEG frame: {e}")))?;
    let info = dec
        .info()
        .ok_or_else(|| bad("a JPEG without a frame header".into()))?;
    Ok((u32::from(info.width), u32::from(info.height)))
}

/// Decodes an 8-bit RGB, RGBA (alpha ignored) or grey PNG to RGB.
///
/// The header's size is checked first ([`crate::frame::MAX_FRAME_PX`]): nothing larger is
/// decoded.
pub fn load_png_rgb(path: &Path) -> Result<RgbImage, FrameSetError> {
    let image_err = |e: image::ImageError| FrameSetError::Image {
        path: path.to_path_buf(),
        detail: e.to_string(),
    };
    let reader = || -> Result<_, FrameSetError> {
        image::ImageReader::open(path)
            .map_err(io_err(path))?
            .with_guessed_format()
            .map_err(io_err(path))
    };
    let (w, h) = reader()?.into_dimensions().map_err(image_err)?;
    if !crate::frame::size_ok(w, h) {
        return Err(FrameSetError::Image {
            path: path.to_path_buf(),
            detail: crate::frame::size_refused(w, h),
        });
    }
    let img = reader()?.decode().map_err(image_err)?;
    use image::DynamicImage as D;
    match img {
        D::ImageRgb8(i) => Ok(i),
        D::ImageRgba8(_) | D::ImageLuma8(_) | D::ImageLumaA8(_) => Ok(img.to_rgb8()),
        other => Err(FrameSetError::Image {
            path: path.to_path_buf(),
            detail: format!(
                "pixel type {:?} not accepted (8-bit RGB, RGBA or grey only)",
                other.color()
            ),
        }),
    }
}

/// Encodes an RGB image as PNG bytes (deterministic: same pixels, same bytes).
pub fn png_bytes(img: &RgbImage) -> Result<Vec<u8>, image::ImageError> {
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png)?;
    Ok(out.into_inner())
}

/// Writes a frame set: reference first, frames as they come, manifest last (so a set whose
/// writer was killed has no manifest and is refused rather than read half-written).
///
/// Images are written in the writer's [`Encoding`] (PNG by default; [`Self::encoded`]);
/// camera frames ([`Self::create_from_frame`], [`Self::add_frame`]) byte for byte as the
/// camera sent them.
#[derive(Debug)]
pub struct FrameSetWriter {
    dir: PathBuf,
    manifest: Manifest,
    size: (u32, u32),
    encoding: Encoding,
}

/// The file extension of frames in `format`.
fn extension(format: PixelFormat) -> &'static str {
    match format {
        PixelFormat::Mjpeg => "jpg",
        PixelFormat::Yuyv => "yuyv",
        PixelFormat::Rgb8 | PixelFormat::Gray8 => "png",
    }
}

impl FrameSetWriter {
    /// Creates `dir` (if needed) and writes the reference frame as PNG.
    pub fn create(
        dir: &Path,
        grating_period_mm: f64,
        reference: &RgbImage,
    ) -> Result<FrameSetWriter, FrameSetError> {
        FrameSetWriter::encoded(dir, grating_period_mm, reference, Encoding::Rgb)
    }

    /// Creates `dir` (if needed) and writes the reference frame; every image is written
    /// as a camera would send it in `encoding`.
    pub fn encoded(
        dir: &Path,
        grating_period_mm: f64,
        reference: &RgbImage,
        encoding: Encoding,
    ) -> Result<FrameSetWriter, FrameSetError> {
        let (w, h) = reference.dimensions();
        let mut writer = FrameSetWriter::empty(dir, grating_period_mm, (w, h), encoding)?;
        let name = format!("reference.{}", extension(encoding.pixel_format()));
        writer.write_image(&name, reference)?;
        writer.manifest.reference = name;
        Ok(writer)
    }

    /// Creates `dir` (if needed) and writes `reference` as the camera sent it; later
    /// frames are expected in its format.
    pub fn create_from_frame(
        dir: &Path,
        grating_period_mm: f64,
        reference: &Frame,
    ) -> Result<FrameSetWriter, FrameSetError> {
        let encoding = match reference.format {
            PixelFormat::Yuyv => Encoding::Yuyv,
            // The quality is the camera's; it only matters for images encoded here.
            PixelFormat::Mjpeg => Encoding::Mjpeg(90),
            PixelFormat::Rgb8 | PixelFormat::Gray8 => Encoding::Rgb,
        };
        let size = (reference.width, reference.height);
        let mut writer = FrameSetWriter::empty(dir, grating_period_mm, size, encoding)?;
        let name = format!("reference.{}", extension(reference.format));
        writer.write_frame(&name, reference)?;
        writer.manifest.reference = name;
        Ok(writer)
    }

    fn empty(
        dir: &Path,
        grating_period_mm: f64,
        (w, h): (u32, u32),
        encoding: Encoding,
    ) -> Result<FrameSetWriter, FrameSetError> {
        fs::create_dir_all(dir).map_err(io_err(dir))?;
        let yuyv = encoding == Encoding::Yuyv;
        Ok(FrameSetWriter {
            dir: dir.to_path_buf(),
            manifest: Manifest {
                format: FORMAT.to_string(),
                grating_period_mm,
                reference: String::new(),
                frames: Vec::new(),
                width_px: yuyv.then_some(w),
                height_px: yuyv.then_some(h),
                extra: Map::new(),
            },
            size: (w, h),
            encoding,
        })
    }

    /// Writes a camera frame's bytes (a PNG for RGB or grey pixels).
    fn write_frame(&mut self, name: &str, f: &Frame) -> Result<(), FrameSetError> {
        let path = self.dir.join(name);
        if (f.width, f.height) != self.size {
            return Err(FrameSetError::SizeMismatch {
                path,
                width: self.size.0,
                height: self.size.1,
                got_w: f.width,
                got_h: f.height,
            });
        }
        let bytes = match f.format {
            PixelFormat::Mjpeg => f.data.clone(),
            PixelFormat::Yuyv => {
                self.manifest.width_px = Some(f.width);
                self.manifest.height_px = Some(f.height);
                f.data.clone()
            }
            PixelFormat::Rgb8 | PixelFormat::Gray8 => {
                let img = f.to_rgb().map_err(|e| FrameSetError::Image {
                    path: path.clone(),
                    detail: e.to_string(),
                })?;
                png_bytes(&img).map_err(|e| FrameSetError::Image {
                    path: path.clone(),
                    detail: e.to_string(),
                })?
            }
        };
        fs::write(&path, bytes).map_err(io_err(&path))
    }

    /// Top-level manifest keys beyond the format's (scene parameters, truth descriptions).
    pub fn extra_mut(&mut self) -> &mut Map<String, Value> {
        &mut self.manifest.extra
    }

    fn write_image(&self, name: &str, img: &RgbImage) -> Result<(), FrameSetError> {
        let path = self.dir.join(name);
        if img.dimensions() != self.size {
            return Err(FrameSetError::SizeMismatch {
                path,
                width: self.size.0,
                height: self.size.1,
                got_w: img.width(),
                got_h: img.height(),
            });
        }
        let bytes = match self.encoding {
            Encoding::Rgb => png_bytes(img).map_err(|e| e.to_string()),
            e => e.encode(img),
        }
        .map_err(|detail| FrameSetError::Image {
            path: path.clone(),
            detail,
        })?;
        fs::write(&path, bytes).map_err(io_err(&path))
    }

    /// Directory being written.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Name the next frame will get (`f0000.png`, `f0001.png`, ...; `.jpg` or `.yuyv`
    /// in those encodings).
    pub fn next_name(&self) -> String {
        self.name_for(self.encoding.pixel_format())
    }

    fn name_for(&self, format: PixelFormat) -> String {
        format!("f{:04}.{}", self.manifest.frames.len(), extension(format))
    }

    /// Appends a frame in the writer's encoding; `entry.file` is replaced by the next
    /// frame name.
    pub fn add(&mut self, img: &RgbImage, mut entry: FrameEntry) -> Result<(), FrameSetError> {
        entry.file = self.next_name();
        self.write_image(&entry.file, img)?;
        self.manifest.frames.push(entry);
        Ok(())
    }

    /// Appends a camera frame byte for byte; `entry.file` is replaced by the next frame
    /// name.
    pub fn add_frame(&mut self, f: &Frame, mut entry: FrameEntry) -> Result<(), FrameSetError> {
        entry.file = self.name_for(f.format);
        self.write_frame(&entry.file, f)?;
        self.manifest.frames.push(entry);
        Ok(())
    }

    /// Writes the manifest of the frames so far, leaving the set open for more: a set
    /// written over a long session stays readable if its writer is killed.
    pub fn flush(&self) -> Result<(), FrameSetError> {
        write_manifest(&self.dir, &self.manifest)
    }

    /// Frames written so far.
    pub fn len(&self) -> usize {
        self.manifest.frames.len()
    }

    /// Whether no frame has been written yet.
    pub fn is_empty(&self) -> bool {
        self.manifest.frames.is_empty()
    }

    /// Writes the manifest and returns the set, re-opened and validated.
    pub fn finish(self) -> Result<FrameSet, FrameSetError> {
        write_manifest(&self.dir, &self.manifest)?;
        FrameSet::open(&self.dir)
    }
}

/// Writes `manifest` as `dir/set.json` (pretty JSON, keys in a fixed order, newline at end).
pub fn write_manifest(dir: &Path, manifest: &Manifest) -> Result<(), FrameSetError> {
    let path = dir.join(MANIFEST);
    let mut text = serde_json::to_string_pretty(manifest).map_err(|e| FrameSetError::Manifest {
        path: path.clone(),
        line: 0,
        column: 0,
        detail: e.to_string(),
    })?;
    text.push('\n');
    fs::write(&path, text).map_err(io_err(&path))
}

/// Copies a set to `dst`: PNG images re-encoded, camera frames (JPEG, YUYV) byte for
/// byte, the manifest rewritten with its unknown keys kept.
pub fn copy_set(src: &FrameSet, dst: &Path) -> Result<FrameSet, FrameSetError> {
    let mut w = FrameSetWriter::create_from_frame(
        dst,
        src.manifest.grating_period_mm,
        &src.reference_frame()?,
    )?;
    w.manifest.extra = src.manifest.extra.clone();
    for (i, e) in src.manifest.frames.iter().enumerate() {
        w.add_frame(&src.frame(i)?, e.clone())?;
    }
    w.finish()
}
