//! The real camera: a V4L2 capture device (USB UVC cameras, the Pi camera through libcamera's
//! V4L2 compatibility, the kernel's `vivid` test driver).
//!
//! * **Which node.** A UVC camera creates two `/dev/video*` nodes: frames and metadata. A
//!   camera is opened by path, by the name the driver reports, or by its USB serial; the
//!   metadata node (no `VIDEO_CAPTURE` capability) is never chosen. For a stable path
//!   across reboots use the udev rule in `firmware/deploy/` (`/dev/vistaf-camera`).
//! * **What format.** [`negotiate`] picks the preferred pixel format (YUYV, then MJPEG) at
//!   the offered size closest to the request; the driver may still adjust it, and the
//!   format it reports back is the one used ([`FrameSource::format`]).
//! * **Newest frame.** Every [`FrameSource::next_frame`] drains the driver's queue and
//!   returns the newest filled buffer; older ones are counted as stale. A slow consumer
//!   therefore never reads frames tens of milliseconds old.
//! * **Light held.** [`CaptureRequest::hold_after`] after it starts streaming (the image
//!   settled under the LED ring), the camera's automatic exposure, gain, white balance and
//!   focus are switched off at the values they settled to ([`crate::light_hold`]);
//!   [`FrameSource::take_note`] says once what was held and what the camera refused.
//! * **Unplugged.** A vanished device surfaces as [`SourceError::Gone`]; wrap the camera in
//!   [`crate::source::Reconnect`] to reopen it with back-off.
//!
//! Troubleshooting: `Permission denied` → add the user to group `video`; `Device or
//! resource busy` → another program holds the camera; `no capture node` → `v4l2-ctl
//! --list-devices` shows what the kernel sees.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use v4l::buffer::Type;
use v4l::io::mmap::Stream;
use v4l::io::traits::CaptureStream;
use v4l::video::Capture;
use v4l::{Device, FourCC};

use crate::frame::{Frame, PixelFormat};
use crate::light_hold::{self, Controls};
use crate::source::{FrameSource, SourceError, SourceFormat};

/// How to find the camera.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Selector {
    /// A device node, e.g. `/dev/video0` or a udev symlink.
    Path(PathBuf),
    /// The USB serial number of the camera (udev `ID_SERIAL_SHORT`).
    Serial(String),
    /// A substring of the name the driver reports (`card`), e.g. `USB Camera` or `vivid`.
    Name(String),
}

/// What to ask the camera for.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CaptureRequest {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Frames per second.
    pub fps: u32,
    /// Pixel formats in order of preference.
    pub formats: Vec<PixelFormat>,
    /// How long after streaming starts the automatic light settings are held
    /// ([`crate::light_hold`]); `None` leaves them automatic.
    pub hold_after: Option<Duration>,
}

impl Default for CaptureRequest {
    fn default() -> Self {
        CaptureRequest {
            width: 640,
            height: 480,
            fps: 30,
            formats: vec![PixelFormat::Yuyv, PixelFormat::Mjpeg],
            hold_after: Some(light_hold::HOLD_AFTER),
        }
    }
}

/// A format a device offers, with its frame sizes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Offer {
    /// Pixel format.
    pub format: PixelFormat,
    /// Offered sizes (stepwise ranges already expanded to their candidates).
    pub sizes: Vec<(u32, u32)>,
}

/// The V4L2 four-character code of a pixel format.
pub fn fourcc(f: PixelFormat) -> [u8; 4] {
    match f {
        PixelFormat::Yuyv => *b"YUYV",
        PixelFormat::Mjpeg => *b"MJPG",
        PixelFormat::Rgb8 => *b"RGB3",
        PixelFormat::Gray8 => *b"GREY",
    }
}

/// The pixel format of a V4L2 four-character code, if we can use it.
pub fn from_fourcc(code: [u8; 4]) -> Option<PixelFormat> {
    match &code {
        b"YUYV" => Some(PixelFormat::Yuyv),
        b"MJPG" => Some(PixelFormat::Mjpeg),
        b"RGB3" => Some(PixelFormat::Rgb8),
        b"GREY" => Some(PixelFormat::Gray8),
        _ => None,
    }
}

/// Chooses format and size: the first preferred format that is offered, at its offered
/// size closest to the request (by pixel-count ratio, then aspect). Pure, so it is tested
/// without a device.
pub fn negotiate(
    offers: &[Offer],
    req: &CaptureRequest,
) -> Result<(PixelFormat, u32, u32), String> {
    let want_px = f64::from(req.width) * f64::from(req.height);
    let want_aspect = f64::from(req.width) / f64::from(req.height.max(1));
    for pref in &req.formats {
        let Some(offer) = offers.iter().find(|o| o.format == *pref) else {
            continue;
        };
        let best = offer
            .sizes
            .iter()
            .copied()
            .filter(|&(w, h)| w > 0 && h > 0)
            .min_by(|a, b| {
                let cost = |(w, h): (u32, u32)| {
                    let px = f64::from(w) * f64::from(h);
                    let aspect = f64::from(w) / f64::from(h);
                    ((px / want_px).ln().abs(), (aspect / want_aspect).ln().abs())
                };
                cost(*a)
                    .partial_cmp(&cost(*b))
                    .unwrap_or(std::cmp::Ordering::Equal)
            });
        if let Some((w, h)) = best {
            return Ok((*pref, w, h));
        }
    }
    let offered: Vec<String> = offers.iter().map(|o| format!("{:?}", o.format)).collect();
    let wanted: Vec<String> = req.formats.iter().map(|f| format!("{f:?}")).collect();
    Err(format!(
        "offers [{}], none of the wanted [{}]",
        offered.join(", "),
        wanted.join(", ")
    ))
}

/// One `/dev/video*` node as seen in sysfs and by the driver.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Node {
    /// Device path.
    pub path: PathBuf,
    /// Name the driver reports.
    pub name: String,
    /// USB serial of the device, if any.
    pub serial: Option<String>,
    /// Whether the node captures video (metadata nodes do not).
    pub captures_video: bool,
}

/// Picks the node a selector means. Pure, so it is tested without devices.
pub fn resolve(nodes: &[Node], sel: &Selector) -> Result<PathBuf, String> {
    let video: Vec<&Node> = nodes.iter().filter(|n| n.captures_video).collect();
    let pick = |found: Vec<&&Node>, what: String| match found.as_slice() {
        [one] => Ok(one.path.clone()),
        [] => Err(format!("no video capture node with {what}")),
        many => Err(format!(
            "{} capture nodes with {what}: {}",
            many.len(),
            many.iter()
                .map(|n| n.path.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        )),
    };
    match sel {
        Selector::Path(p) => match nodes.iter().find(|n| &n.path == p) {
            Some(n) if !n.captures_video => Err(format!(
                "{} is not a video capture node (metadata?)",
                p.display()
            )),
            _ => Ok(p.clone()),
        },
        Selector::Serial(s) => pick(
            video
                .iter()
                .filter(|n| n.serial.as_deref() == Some(s.as_str()))
                .collect(),
            format!("serial {s:?}"),
        ),
        Selector::Name(s) => pick(
            video
                .iter()
                .filter(|n| n.name.contains(s.as_str()))
                .collect(),
            format!("name {s:?}"),
        ),
    }
}

/// One node as `list-cameras` prints it: path, the driver's name, the USB serial, and
/// what it is when it is not a camera.
pub fn describe(n: &Node) -> String {
    let mut line = format!("{}  {:?}", n.path.display(), n.name);
    if let Some(s) = &n.serial {
        line.push_str(&format!("  serial {s:?}"));
    }
    if !n.captures_video {
        line.push_str("  (not a capture node)");
    }
    line
}

/// What a "camera not found" error adds: the capture nodes this machine has, or that it
/// has none.
pub fn available(nodes: &[Node]) -> String {
    let cams: Vec<String> = nodes
        .iter()
        .filter(|n| n.captures_video)
        .map(describe)
        .collect();
    if cams.is_empty() {
        "no camera on this machine (vistaf-skin list-cameras)".into()
    } else {
        format!("cameras here: {}", cams.join("; "))
    }
}

fn read_trim(p: &Path) -> Option<String> {
    std::fs::read_to_string(p)
        .ok()
        .map(|s| s.trim().to_string())
}

/// Lists the machine's V4L2 nodes from `/sys/class/video4linux`.
pub fn list_nodes() -> Vec<Node> {
    let mut nodes = Vec::new();
    let Ok(entries) = std::fs::read_dir("/sys/class/video4linux") else {
        return nodes;
    };
    for e in entries.flatten() {
        let sys = e.path();
        let Some(dev_name) = sys.file_name().and_then(|n| n.to_str()).map(str::to_string) else {
            continue;
        };
        let path = PathBuf::from("/dev").join(&dev_name);
        let name = read_trim(&sys.join("name")).unwrap_or_default();
        // device → USB interface; its parent is the USB device, which has the serial.
        let serial = read_trim(&sys.join("device/../serial"));
        // Touch sensors (V4L2_CAP_TOUCH) report VIDEO_CAPTURE too; they are not cameras.
        let captures_video = Device::with_path(&path)
            .ok()
            .and_then(|d| query_caps(&d).ok())
            .is_some_and(|f| {
                f.contains(v4l::capability::Flags::VIDEO_CAPTURE)
                    && !f.contains(v4l::capability::Flags::TOUCH)
            });
        nodes.push(Node {
            path,
            name,
            serial,
            captures_video,
        });
    }
    nodes.sort_by(|a, b| a.path.cmp(&b.path));
    nodes
}

/// The device's controls, for [`light_hold`]: integer, menu and boolean values.
impl Controls for Device {
    fn get(&self, id: u32) -> Option<i64> {
        match self.control(id).ok()?.value {
            v4l::control::Value::Integer(v) => Some(v),
            v4l::control::Value::Boolean(b) => Some(i64::from(b)),
            _ => None,
        }
    }

    fn set(&mut self, id: u32, value: i64) -> std::io::Result<()> {
        let value = v4l::control::Value::Integer(value);
        self.set_control(v4l::control::Control { id, value })
    }
}

/// `VIDIOC_QUERYCAP`. The v4l crate panics on a driver name that is not UTF-8; a driver's
/// bytes must never crash the service, so that panic is caught and reported.
fn query_caps(dev: &Device) -> std::io::Result<v4l::capability::Flags> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| dev.query_caps()))
        .map_err(|_| std::io::Error::other("driver reported a non-UTF-8 name"))?
        .map(|c| c.capabilities)
}

/// An open, streaming V4L2 camera.
pub struct Camera {
    path: PathBuf,
    /// Bytes per line the driver uses (may exceed width × bytes per pixel).
    stride: usize,
    format: SourceFormat,
    stream: Stream<'static>,
    dev: Device,
    /// When the automatics are to be held; `None` once done, or never.
    hold_at: Option<Instant>,
    /// What the hold did, until [`FrameSource::take_note`] takes it.
    note: Option<String>,
    last_seq: Option<u32>,
    /// Frames the driver dropped (sequence gaps) since opening.
    pub driver_dropped: u64,
    /// Filled buffers skipped because a newer one was ready.
    pub stale_skipped: u64,
    seq: u64,
}

impl std::fmt::Debug for Camera {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Camera")
            .field("path", &self.path)
            .field("format", &self.format)
            .finish()
    }
}

fn gone(path: &Path, e: &std::io::Error) -> SourceError {
    SourceError::Gone {
        device: path.display().to_string(),
        detail: e.to_string(),
    }
}

impl Camera {
    /// Frames the driver dropped (gaps in its sequence numbers).
    pub fn driver_dropped(&self) -> u64 {
        self.driver_dropped
    }

    /// Filled buffers skipped because a newer one was already waiting (newest wins).
    pub fn stale_skipped(&self) -> u64 {
        self.stale_skipped
    }

    /// A V4L2 control's current value (`light_hold`'s ids); `None` where the camera has
    /// no such control.
    pub fn control(&self, id: u32) -> Option<i64> {
        self.dev.get(id)
    }

    /// Finds, opens and starts the camera.
    pub fn open(sel: &Selector, req: &CaptureRequest) -> Result<Camera, SourceError> {
        let not_found = |device: String, detail: String| SourceError::Gone {
            device,
            detail: format!("{detail}; {}", available(&list_nodes())),
        };
        let path = match sel {
            Selector::Path(p) => p.clone(),
            other => resolve(&list_nodes(), other)
                .map_err(|detail| not_found(format!("{other:?}"), detail))?,
        };
        let dev = Device::with_path(&path).map_err(|e| match e.kind() {
            std::io::ErrorKind::NotFound => not_found(path.display().to_string(), e.to_string()),
            _ => gone(&path, &e),
        })?;
        let caps = query_caps(&dev).map_err(|e| gone(&path, &e))?;
        let unsupported = |detail: String| SourceError::Unsupported {
            device: path.display().to_string(),
            detail,
        };
        if !caps.contains(v4l::capability::Flags::VIDEO_CAPTURE) {
            return Err(unsupported(
                "not a video capture node (a metadata node?)".into(),
            ));
        }
        let mut offers = Vec::new();
        for d in dev.enum_formats().map_err(|e| gone(&path, &e))? {
            let Some(format) = from_fourcc(d.fourcc.repr) else {
                continue;
            };
            let mut sizes = Vec::new();
            for fs in dev.enum_framesizes(d.fourcc).unwrap_or_default() {
                match fs.size {
                    v4l::framesize::FrameSizeEnum::Discrete(s) => sizes.push((s.width, s.height)),
                    v4l::framesize::FrameSizeEnum::Stepwise(s) => {
                        let clamp = |v: u32, lo: u32, hi: u32| v.clamp(lo, hi.max(lo));
                        sizes.push((
                            clamp(req.width, s.min_width, s.max_width),
                            clamp(req.height, s.min_height, s.max_height),
                        ));
                    }
                }
            }
            offers.push(Offer { format, sizes });
        }
        let (pixel, w, h) = negotiate(&offers, req).map_err(unsupported)?;
        let mut fmt = dev.format().map_err(|e| gone(&path, &e))?;
        fmt.width = w;
        fmt.height = h;
        fmt.fourcc = FourCC::new(&fourcc(pixel));
        let got = dev.set_format(&fmt).map_err(|e| gone(&path, &e))?;
        let pixel = from_fourcc(got.fourcc.repr).ok_or_else(|| {
            unsupported(format!("driver switched to unusable format {}", got.fourcc))
        })?;
        let params = dev
            .set_params(&v4l::video::capture::Parameters::with_fps(req.fps.max(1)))
            .map_err(|e| gone(&path, &e))?;
        let interval = Some((params.interval.numerator, params.interval.denominator));
        // Two buffers: one being filled while we process the other. More only adds latency.
        let mut stream =
            Stream::with_buffers(&dev, Type::VideoCapture, 2).map_err(|e| gone(&path, &e))?;
        stream.set_timeout(Duration::from_secs(2));
        Ok(Camera {
            path,
            stride: got.stride as usize,
            format: SourceFormat {
                width: got.width,
                height: got.height,
                pixel,
                interval,
            },
            stream,
            dev,
            hold_at: req.hold_after.and_then(|d| Instant::now().checked_add(d)),
            note: None,
            last_seq: None,
            driver_dropped: 0,
            stale_skipped: 0,
            seq: 0,
        })
    }
}

impl FrameSource for Camera {
    fn format(&self) -> SourceFormat {
        self.format
    }

    fn name(&self) -> String {
        self.path.display().to_string()
    }

    fn take_note(&mut self) -> Option<String> {
        self.note.take()
    }

    fn next_frame(&mut self) -> Result<Option<Frame>, SourceError> {
        let handle = self.stream.handle();
        let (data, seq) = loop {
            let (buf, meta) = self.stream.next().map_err(|e| gone(&self.path, &e))?;
            let used = (meta.bytesused as usize).min(buf.len());
            let seq = meta.sequence;
            // Another buffer already filled? Then this one is stale: skip to the newest.
            if handle.poll(libc_pollin(), 0).unwrap_or(0) > 0 {
                self.stale_skipped += 1;
                continue;
            }
            break (unpad(&buf[..used], &self.format, self.stride), seq);
        };
        if let Some(last) = self.last_seq {
            self.driver_dropped += u64::from(seq.wrapping_sub(last).saturating_sub(1));
        }
        self.last_seq = Some(seq);
        self.seq += 1;
        if self.hold_at.is_some_and(|at| Instant::now() >= at) {
            self.hold_at = None;
            let held = light_hold::hold(&mut self.dev);
            self.note = Some(format!("camera light {}", light_hold::describe(&held)));
        }
        Ok(Some(Frame {
            width: self.format.width,
            height: self.format.height,
            format: self.format.pixel,
            data,
            timestamp: crate::clock::now(),
            seq: self.seq - 1,
        }))
    }
}

/// A frame's bytes without the driver's line padding: packed formats whose lines are
/// longer than their pixels (`bytesperline` > width × bytes per pixel) are repacked.
pub fn unpad(data: &[u8], f: &SourceFormat, stride: usize) -> Vec<u8> {
    let bpp = match f.pixel {
        PixelFormat::Rgb8 => 3,
        PixelFormat::Gray8 => 1,
        PixelFormat::Yuyv => 2,
        _ => return data.to_vec(),
    };
    let line = f.width as usize * bpp;
    if stride <= line || data.len() < stride * (f.height as usize).saturating_sub(1) + line {
        return data.to_vec();
    }
    data.chunks(stride)
        .take(f.height as usize)
        .flat_map(|row| &row[..line.min(row.len())])
        .copied()
        .collect()
}

/// `POLLIN` without a libc dependency of our own.
const fn libc_pollin() -> i16 {
    0x001
}

#[cfg(test)]
mod tests {
    use super::*;

    fn offers() -> Vec<Offer> {
        vec![
            Offer {
                format: PixelFormat::Mjpeg,
                sizes: vec![(1920, 1080), (1280, 720), (640, 480)],
            },
            Offer {
                format: PixelFormat::Yuyv,
                sizes: vec![(640, 480), (320, 240), (1280, 720)],
            },
        ]
    }

    #[test]
    fn padded_lines_are_repacked() {
        let f = SourceFormat {
            width: 2,
            height: 2,
            pixel: PixelFormat::Yuyv,
            interval: None,
        };
        // 4 bytes of pixels and 4 of padding per line.
        let data = [1, 2, 3, 4, 0, 0, 0, 0, 5, 6, 7, 8, 0, 0, 0, 0];
        assert_eq!(unpad(&data, &f, 8), vec![1, 2, 3, 4, 5, 6, 7, 8]);
        assert_eq!(unpad(&data[..8], &f, 4), data[..8].to_vec());
    }

    #[test]
    fn prefers_yuyv_at_the_closest_size() {
        let req = CaptureRequest {
            width: 320,
            height: 240,
            ..Default::default()
        };
        assert_eq!(
            negotiate(&offers(), &req),
            Ok((PixelFormat::Yuyv, 320, 240))
        );
        let req = CaptureRequest {
            width: 800,
            height: 600,
            ..Default::default()
        };
        assert_eq!(
            negotiate(&offers(), &req),
            Ok((PixelFormat::Yuyv, 640, 480))
        );
    }

    #[test]
    fn falls_back_to_mjpeg_and_reports_what_is_missing() {
        let req = CaptureRequest {
            width: 1280,
            height: 720,
            formats: vec![PixelFormat::Mjpeg],
            ..Default::default()
        };
        assert_eq!(
            negotiate(&offers(), &req),
            Ok((PixelFormat::Mjpeg, 1280, 720))
        );
        let only_grey = [Offer {
            format: PixelFormat::Gray8,
            sizes: vec![(640, 480)],
        }];
        let err = negotiate(&only_grey, &CaptureRequest::default()).unwrap_err();
        assert!(err.contains("Gray8") && err.contains("Yuyv"), "{err}");
        let no_sizes = [Offer {
            format: PixelFormat::Yuyv,
            sizes: vec![],
        }];
        assert!(negotiate(&no_sizes, &CaptureRequest::default()).is_err());
    }

    fn nodes() -> Vec<Node> {
        let n = |i: u32, name: &str, serial: Option<&str>, video: bool| Node {
            path: PathBuf::from(format!("/dev/video{i}")),
            name: name.into(),
            serial: serial.map(Into::into),
            captures_video: video,
        };
        vec![
            n(0, "USB Camera: USB Camera", Some("SN123"), true),
            n(1, "USB Camera: USB Camera", Some("SN123"), false),
            n(2, "vivid-000-vid-cap", None, true),
        ]
    }

    #[test]
    fn serial_and_name_never_pick_the_metadata_node() {
        assert_eq!(
            resolve(&nodes(), &Selector::Serial("SN123".into())),
            Ok("/dev/video0".into())
        );
        assert_eq!(
            resolve(&nodes(), &Selector::Name("USB Camera".into())),
            Ok("/dev/video0".into())
        );
        assert_eq!(
            resolve(&nodes(), &Selector::Name("vivid".into())),
            Ok("/dev/video2".into())
        );
        let err = resolve(&nodes(), &Selector::Path("/dev/video1".into())).unwrap_err();
        assert!(err.contains("not a video capture node"), "{err}");
        let err = resolve(&nodes(), &Selector::Serial("nope".into())).unwrap_err();
        assert!(err.contains("no video capture node"), "{err}");
        let mut two = nodes();
        two[2].name = "USB Camera 2".into();
        let err = resolve(&two, &Selector::Name("USB Camera".into())).unwrap_err();
        assert!(err.contains("2 capture nodes"), "{err}");
    }

    #[test]
    fn opening_a_missing_device_is_a_clear_error() {
        let err = Camera::open(
            &Selector::Path("/dev/video-missing".into()),
            &CaptureRequest::default(),
        )
        .unwrap_err();
        assert!(err.is_transient());
        assert!(err.to_string().contains("/dev/video-missing"), "{err}");
    }
}
