//! The on-device service: camera → pipeline → serial.
//!
//! ```text
//!  capture thread ──(bounded 1, newest wins)──▶ process loop ──▶ link (postcard frames)
//!                                                   ▲
//!  link reader thread ──(HostMsg)───────────────────┘  commands between frames
//! ```
//!
//! * The capture thread reads the source as fast as it delivers. The channel to the process
//!   loop holds one frame; a newer frame evicts the waiting one, and every eviction is
//!   counted (`Status.frames_dropped`), so the pipeline always works on the newest image.
//! * The reference is taken once the image is stable: the mean absolute luminance change
//!   between consecutive frames must fall below `reference.stable_dn` (measured, not a
//!   sleep). It drifts as the skin creeps and the light ages: a frame without contact whose
//!   registration offset or mean brightness has moved beyond the policy's limits counts as
//!   drifted (brightness only while the skin's mean temperature is that of the reference:
//!   [`TEMPERATURE_EXPLAINS_C`]). After `reference.auto_after_s` without contact a drifted reference is renewed;
//!   with auto re-referencing off, summaries carry `stale_reference` until the host sends
//!   `CaptureReference`.
//! * Camera lost (a transient source error): one `Error(CameraLost)` and `RunState::CameraLost`
//!   in `Status` while the source retries with back-off; frames resuming count in
//!   `Status.camera_restarts`.
//! * Host commands are decoded on their own thread and handled between frames: `Ping`,
//!   `GetInfo`, `CaptureReference`, `SetRate`, `SetLed`, `RequestMap`, `Start`, `Stop`.
//! * A `Hello` goes out at start and on request; a `Status` every second.
//! * A bad frame (wrong size, undecodable) is counted and skipped; a failing link write is
//!   counted and the service keeps running (the host may come back).
//!

use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use crossbeam_channel::{bounded, TrySendError};
use image::RgbImage;
use vistaf_hardware::frame::Frame;
use vistaf_hardware::led::{LedConfig, LedRing};
use vistaf_hardware::source::FrameSource;
use vistaf_protocol::frame::DEVICE_FRAME_MAX;
use vistaf_protocol::msg::{MAP_MAX_CELLS, MAP_NO_DATA, TEMP_NOT_MEASURED};
use vistaf_protocol::units::to_u32;
use vistaf_protocol::{
    encode, schema_hash, CentroidDeciMm, Command, DeviceMsg, FirmwareVersion, Hello, HostDecoder,
    HostMsg, Map, MapKind, RunState, Status, Summary, PROTOCOL_VERSION,
};

use crate::calibration::Calibration;
pub use crate::config::ReferencePolicy;
use crate::pipeline::image_ops::gray_down_q8;
use crate::pipeline::{Analyzer, AnalyzerOptions, Deformation, Implementation};

/// Service settings.
#[derive(Debug, Clone)]
pub struct Settings {
    /// Device serial sent in `Hello`.
    pub serial: String,
    /// Calibration.
    pub calibration: Calibration,
    /// Use the calibration even for another geometry.
    pub force_calibration: bool,
    /// Pipeline implementation.
    pub pipeline: Implementation,
    /// Stop after this many processed frames.
    pub frames: Option<u64>,
    /// Summary rate limit, Hz (0 = every frame).
    pub max_rate_hz: u16,
    /// LED ring at start.
    pub led: LedConfig,
    /// When the reference is taken and renewed.
    pub reference: ReferencePolicy,
}

/// Counters at the end of a run.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counters {
    /// Frames delivered by the source.
    pub captured: u32,
    /// Frames processed.
    pub processed: u32,
    /// Frames evicted by a newer one.
    pub dropped: u32,
    /// Malformed frames skipped.
    pub bad: u32,
    /// Summaries written.
    pub sent: u32,
    /// Link writes that failed.
    pub link_errors: u32,
    /// References taken (the first one included).
    pub references: u32,
    /// Times frames resumed after the camera was lost.
    pub camera_restarts: u32,
    /// Summaries flagged `stale_reference`.
    pub stale: u32,
}

fn firmware_version() -> FirmwareVersion {
    let v = |s: &str| s.parse::<u8>().unwrap_or(0);
    FirmwareVersion {
        major: v(env!("CARGO_PKG_VERSION_MAJOR")),
        minor: v(env!("CARGO_PKG_VERSION_MINOR")),
        patch: v(env!("CARGO_PKG_VERSION_PATCH")),
    }
}

/// Writes framed messages to the link, counting failures instead of stopping.
struct Tx<W: Write> {
    out: W,
    buf: Box<[u8; DEVICE_FRAME_MAX]>,
    errors: u32,
}

impl<W: Write> Tx<W> {
    fn send(&mut self, msg: &DeviceMsg) -> bool {
        let ok = match encode(msg, &mut self.buf[..]) {
            Ok(n) => self
                .out
                .write_all(&self.buf[..n])
                .and_then(|()| self.out.flush())
                .is_ok(),
            Err(_) => false,
        };
        if !ok {
            self.errors += 1;
        }
        ok
    }
}

/// A summary of one analysed frame.
pub fn summary_of(
    d: &Deformation,
    seq: u32,
    capture_us: u64,
    latency_us: u32,
    mm_per_px: f32,
) -> Summary {
    Summary {
        seq,
        capture_us,
        latency_us,
        force_mn: to_u32(d.force_n, 1000.0),
        peak_depth_um: to_u32(d.peak_depth_mm, 1000.0),
        contact_area_centi_mm2: to_u32(d.contact_area_mm2, 100.0),
        volume_milli_mm3: to_u32(d.volume_mm3, 1000.0),
        centroid: d
            .centroid_px
            .map(|(x, y)| CentroidDeciMm::from_mm(x * mm_per_px, y * mm_per_px)),
        temp_min_centi_c: centi_c(d.temperature.as_ref().map(|t| t.min_c)),
        temp_mean_centi_c: centi_c(d.temperature.as_ref().map(|t| t.mean_c)),
        temp_max_centi_c: centi_c(d.temperature.as_ref().map(|t| t.max_c)),
        contact_temp_centi_c: d
            .temperature
            .as_ref()
            .and_then(|t| t.contact_c)
            .map(|c| centi_c(Some(c))),
        flags: d.flags,
    }
}

/// °C → 0.01 °C on the wire, saturating; [`TEMP_NOT_MEASURED`] for nothing or NaN.
fn centi_c(t: Option<f32>) -> i16 {
    match t {
        Some(v) if v.is_finite() => (v * 100.0)
            .round()
            .clamp(f32::from(i16::MIN + 1), f32::from(i16::MAX))
            as i16,
        _ => TEMP_NOT_MEASURED,
    }
}

/// A temperature map tile of at most [`MAP_MAX_CELLS`] cells (means of the measured blocks),
/// or `None` without a temperature model.
pub fn temperature_tile(d: &Deformation, seq: u32) -> Option<Map> {
    let t = d.temperature.as_ref()?;
    let step = ((t.bw * t.bh) as f32 / MAP_MAX_CELLS as f32)
        .sqrt()
        .ceil()
        .max(1.0) as usize;
    let (tw, th) = (t.bw.div_ceil(step).min(255), t.bh.div_ceil(step).min(255));
    let mut cells = heapless::Vec::new();
    'rows: for ty in 0..th {
        for tx in 0..tw {
            let (mut sum, mut n) = (0.0f32, 0u32);
            for y in ty * step..((ty + 1) * step).min(t.bh) {
                for x in tx * step..((tx + 1) * step).min(t.bw) {
                    let v = t.map_c[y * t.bw + x];
                    if v.is_finite() {
                        sum += v;
                        n += 1;
                    }
                }
            }
            let v = if n > 0 {
                centi_c(Some(sum / n as f32))
            } else {
                MAP_NO_DATA
            };
            if cells.push(v).is_err() {
                break 'rows;
            }
        }
    }
    Some(Map {
        seq,
        kind: MapKind::Temperature,
        width: tw as u8,
        height: th as u8,
        cell_pitch_centi_mm: to_u32(t.block_mm * step as f32, 100.0).min(u32::from(u16::MAX))
            as u16,
        cells,
    })
}

/// A depth map tile of at most [`MAP_MAX_CELLS`] cells (block maxima of the working map).
pub fn depth_tile(d: &Deformation, seq: u32, mm_per_px: f32) -> Map {
    let step = ((d.w * d.h) as f32 / MAP_MAX_CELLS as f32)
        .sqrt()
        .ceil()
        .max(1.0) as usize;
    let (tw, th) = (d.w.div_ceil(step).min(255), d.h.div_ceil(step).min(255));
    let mut cells = heapless::Vec::new();
    'rows: for ty in 0..th {
        for tx in 0..tw {
            let mut m = i32::MIN;
            let mut any = false;
            for y in ty * step..((ty + 1) * step).min(d.h) {
                for x in tx * step..((tx + 1) * step).min(d.w) {
                    let i = y * d.w + x;
                    any |= d.reliable[i];
                    m = m.max(d.depth_um[i]);
                }
            }
            let v = if any {
                m.clamp(0, i32::from(i16::MAX)) as i16
            } else {
                MAP_NO_DATA
            };
            if cells.push(v).is_err() {
                break 'rows;
            }
        }
    }
    Map {
        seq,
        kind: MapKind::Depth,
        width: tw as u8,
        height: th as u8,
        cell_pitch_centi_mm: to_u32(mm_per_px * (d.factor * step) as f32, 100.0)
            .min(u32::from(u16::MAX)) as u16,
        cells,
    }
}

/// Mean of a sparse sample of the image's channels (every 31st byte), 0–255: enough to
/// see the light change.
fn brightness(img: &RgbImage) -> f32 {
    let raw: &[u8] = img.as_raw();
    let (sum, n) = raw
        .iter()
        .step_by(31)
        .fold((0u64, 0u64), |(s, n), &v| (s + u64::from(v), n + 1));
    sum as f32 / n.max(1) as f32
}

fn mean_abs_diff(a: &[u16], b: &[u16]) -> f32 {
    let s: u64 = a
        .iter()
        .zip(b)
        .map(|(x, y)| u64::from(x.abs_diff(*y)))
        .sum();
    s as f32 / 256.0 / a.len().max(1) as f32
}

/// A change of the skin's mean temperature (°C) since the reference that explains a change
/// of brightness: thermochromic stripes change colour, so the image's brightness follows
/// the temperature the service is there to report.
pub const TEMPERATURE_EXPLAINS_C: f32 = 0.5;

/// Runs the service until the source ends, `frames` have been processed, or `stop` is set.
///
/// `commands` is the link's read side (None for a write-only link such as stdout).
pub fn run(
    mut source: Box<dyn FrameSource>,
    link: impl Write,
    commands: Option<Box<dyn Read + Send>>,
    led: &mut dyn LedRing,
    settings: &Settings,
    stop: Arc<AtomicBool>,
) -> anyhow::Result<Counters> {
    let started = Instant::now();
    let format = source.format();
    let mut tx = Tx {
        out: link,
        buf: Box::new([0u8; DEVICE_FRAME_MAX]),
        errors: 0,
    };
    let hello = || {
        DeviceMsg::Hello(Hello {
            protocol_version: PROTOCOL_VERSION,
            schema_hash: schema_hash(),
            firmware: firmware_version(),
            serial: settings
                .serial
                .chars()
                .take(vistaf_protocol::msg::SERIAL_MAX_LEN)
                .collect(),
            frame_width_px: u16::try_from(format.width).unwrap_or(u16::MAX),
            frame_height_px: u16::try_from(format.height).unwrap_or(u16::MAX),
            calibration_id: settings.calibration.id(),
        })
    };
    tx.send(&hello());
    if let Err(e) = led.show(&settings.led) {
        eprintln!("vistaf-skin: {e}");
    }

    // Capture: newest frame wins.
    let (frame_tx, frame_rx) = bounded::<Frame>(1);
    let evict = frame_rx.clone();
    let captured = Arc::new(AtomicU32::new(0));
    let dropped = Arc::new(AtomicU32::new(0));
    let restarts = Arc::new(AtomicU32::new(0));
    // Camera lost / back: reported once per outage.
    let (lost_tx, lost_rx) = bounded::<Option<String>>(16);
    let (cap_stop, cap_n, cap_drop, cap_restarts) = (
        stop.clone(),
        captured.clone(),
        dropped.clone(),
        restarts.clone(),
    );
    let capture = std::thread::spawn(move || -> Option<String> {
        let mut lost = false;
        while !cap_stop.load(Ordering::Relaxed) {
            let frame = match source.next_frame() {
                Ok(Some(f)) => f,
                Ok(None) => return None,
                Err(e) if e.is_transient() => {
                    if !lost {
                        lost = true;
                        let _ = lost_tx.try_send(Some(e.to_string()));
                    }
                    // A source without its own back-off must not spin.
                    std::thread::sleep(Duration::from_millis(20));
                    continue;
                }
                Err(e) => return Some(e.to_string()),
            };
            if lost {
                lost = false;
                cap_restarts.fetch_add(1, Ordering::Relaxed);
                let _ = lost_tx.try_send(None);
            }
            cap_n.fetch_add(1, Ordering::Relaxed);
            match frame_tx.try_send(frame) {
                Ok(()) => {}
                Err(TrySendError::Full(f)) => {
                    if evict.try_recv().is_ok() {
                        cap_drop.fetch_add(1, Ordering::Relaxed);
                    }
                    let _ = frame_tx.try_send(f);
                }
                Err(TrySendError::Disconnected(_)) => return None,
            }
        }
        None
    });

    // Commands from the host.
    let (cmd_tx, cmd_rx) = bounded::<HostMsg>(64);
    let link_dropped = Arc::new(AtomicU32::new(0));
    if let Some(mut rd) = commands {
        let (ld, rd_stop) = (link_dropped.clone(), stop.clone());
        std::thread::spawn(move || {
            let mut dec = HostDecoder::new();
            let mut buf = [0u8; 256];
            while !rd_stop.load(Ordering::Relaxed) {
                match rd.read(&mut buf) {
                    Ok(0) => std::thread::sleep(Duration::from_millis(20)),
                    Ok(n) => dec.push(&buf[..n], |r| match r {
                        Ok(m) => {
                            let _ = cmd_tx.try_send(m);
                        }
                        Err(_) => {
                            ld.fetch_add(1, Ordering::Relaxed);
                        }
                    }),
                    Err(e)
                        if matches!(
                            e.kind(),
                            std::io::ErrorKind::WouldBlock
                                | std::io::ErrorKind::TimedOut
                                | std::io::ErrorKind::Interrupted
                        ) => {}
                    Err(_) => std::thread::sleep(Duration::from_millis(100)),
                }
            }
        });
    }

    let mut c = Counters::default();
    let mut analyzer: Option<Analyzer> = None;
    let mut last_gray: Option<Vec<u16>> = None;
    let mut settle = 0u32;
    let mut streaming = true;
    let mut max_rate_hz = settings.max_rate_hz;
    let mut last_sent: Option<Instant> = None;
    // Maps asked for, sent with the next analysed frame: [depth, temperature].
    let mut maps_requested = [false; 2];
    let mut last_status = Instant::now();
    let mut reference_at = Instant::now();
    let mut seq = 0u32;
    let policy = settings.reference;
    // Reference brightness (mean of a sparse sample), and when contact was last seen.
    let mut ref_brightness = 0.0f32;
    // The skin's mean temperature when the reference was taken: a brightness change that
    // the skin's own temperature explains is the reading, not drift.
    let mut ref_temp_c: Option<f32> = None;
    let mut calm_since = Instant::now();
    let mut camera_lost = false;
    // Whether the last frame without contact found the reference drifted; contact frames
    // cannot tell, so they keep the verdict.
    let mut drifted = false;
    let opts = AnalyzerOptions {
        force_calibration: settings.force_calibration,
        ..Default::default()
    };
    let status = |c: &Counters, state: RunState, rate: u16, ref_at: Instant| {
        DeviceMsg::Status(Status {
            uptime_ms: started.elapsed().as_millis() as u64,
            state,
            max_rate_hz: rate,
            frames_captured: captured.load(Ordering::Relaxed),
            frames_processed: c.processed,
            frames_dropped: dropped.load(Ordering::Relaxed),
            bad_frames: c.bad,
            link_frames_dropped: link_dropped.load(Ordering::Relaxed),
            reference_age_ms: ref_at.elapsed().as_millis().min(u128::from(u32::MAX)) as u32,
            camera_restarts: u16::try_from(restarts.load(Ordering::Relaxed)).unwrap_or(u16::MAX),
        })
    };
    loop {
        if stop.load(Ordering::Relaxed)
            || settings.frames.is_some_and(|n| u64::from(c.processed) >= n)
        {
            break;
        }
        // Commands first: they never wait for a frame.
        while let Ok(cmd) = cmd_rx.try_recv() {
            let reply = match cmd {
                HostMsg::Ping { nonce } => DeviceMsg::Pong { nonce },
                HostMsg::GetInfo => hello(),
                HostMsg::CaptureReference => {
                    analyzer = None;
                    last_gray = None;
                    settle = 0;
                    DeviceMsg::Ack(Command::CaptureReference)
                }
                HostMsg::SetRate { max_rate_hz: r } => {
                    max_rate_hz = r;
                    DeviceMsg::Ack(Command::SetRate)
                }
                HostMsg::SetLed(l) => {
                    let cfg = LedConfig {
                        rgb: smart_leds_rgb(l.rgb),
                        brightness: l.brightness,
                        lit_mask: l.lit_mask,
                        ..settings.led
                    };
                    match led.show(&cfg) {
                        Ok(()) => DeviceMsg::Ack(Command::SetLed),
                        Err(e) => DeviceMsg::Error(vistaf_protocol::DeviceError {
                            code: vistaf_protocol::ErrorCode::LedFault,
                            detail: e
                                .to_string()
                                .chars()
                                .take(vistaf_protocol::msg::ERROR_DETAIL_MAX_LEN)
                                .collect(),
                        }),
                    }
                }
                HostMsg::RequestMap(MapKind::Temperature)
                    if analyzer
                        .as_ref()
                        .is_some_and(|a| a.calibration().temperature.is_none()) =>
                {
                    DeviceMsg::Error(vistaf_protocol::DeviceError {
                        code: vistaf_protocol::ErrorCode::UnsupportedCommand,
                        detail: "the calibration has no temperature model".into(),
                    })
                }
                HostMsg::RequestMap(kind) => {
                    maps_requested[usize::from(kind == MapKind::Temperature)] = true;
                    DeviceMsg::Ack(Command::RequestMap)
                }
                HostMsg::Start => {
                    streaming = true;
                    DeviceMsg::Ack(Command::Start)
                }
                HostMsg::Stop => {
                    streaming = false;
                    DeviceMsg::Ack(Command::Stop)
                }
            };
            tx.send(&reply);
        }
        while let Ok(event) = lost_rx.try_recv() {
            camera_lost = event.is_some();
            if let Some(detail) = event {
                tx.send(&DeviceMsg::Error(vistaf_protocol::DeviceError {
                    code: vistaf_protocol::ErrorCode::CameraLost,
                    detail: detail
                        .chars()
                        .take(vistaf_protocol::msg::ERROR_DETAIL_MAX_LEN)
                        .collect(),
                }));
            }
            last_status = Instant::now() - Duration::from_secs(2); // report the state now
        }
        if last_status.elapsed() >= Duration::from_secs(1) {
            let state = if camera_lost {
                RunState::CameraLost
            } else if analyzer.is_none() {
                RunState::Referencing
            } else if streaming {
                RunState::Streaming
            } else {
                RunState::Stopped
            };
            tx.send(&status(&c, state, max_rate_hz, reference_at));
            last_status = Instant::now();
        }
        let frame = match frame_rx.recv_timeout(Duration::from_millis(50)) {
            Ok(f) => f,
            Err(crossbeam_channel::RecvTimeoutError::Timeout) => {
                if capture.is_finished() && frame_rx.is_empty() {
                    break;
                }
                continue;
            }
            Err(crossbeam_channel::RecvTimeoutError::Disconnected) => break,
        };
        let capture_us = u64::try_from(frame.timestamp.as_micros()).unwrap_or(u64::MAX);
        let img: RgbImage = match frame.into_rgb() {
            Ok(i) if i.dimensions() == (format.width, format.height) => i,
            _ => {
                c.bad += 1;
                continue;
            }
        };
        let Some(a) = analyzer.as_ref() else {
            // Reference: wait until the image is stable.
            let (g, _, _, _) = gray_down_q8(&img, 4);
            let stable = last_gray
                .as_ref()
                .is_some_and(|p| p.len() == g.len() && mean_abs_diff(p, &g) < policy.stable_dn);
            settle += 1;
            last_gray = Some(g);
            if stable || settle >= policy.max_wait_frames {
                analyzer = Some(Analyzer::new(
                    &img,
                    settings.calibration.clone(),
                    settings.pipeline,
                    opts,
                )?);
                c.references += 1;
                drifted = false;
                ref_brightness = brightness(&img);
                ref_temp_c = analyzer
                    .as_ref()
                    .and_then(|a| a.analyze(&img).ok())
                    .and_then(|d| d.temperature)
                    .map(|t| t.mean_c)
                    .filter(|t| t.is_finite());
                reference_at = Instant::now();
                calm_since = Instant::now();
                tx.send(&status(&c, RunState::Streaming, max_rate_hz, reference_at));
            }
            continue;
        };
        let t0 = Instant::now();
        let mut d = match a.analyze(&img) {
            Ok(d) => d,
            Err(_) => {
                c.bad += 1;
                continue;
            }
        };
        c.processed += 1;
        // Reference drift, judged on frames without contact.
        let mut renew = false;
        if d.contact {
            calm_since = Instant::now();
        } else {
            let b = brightness(&img);
            let warmed = match (ref_temp_c, d.temperature.as_ref()) {
                (Some(r), Some(t)) if t.mean_c.is_finite() => {
                    (t.mean_c - r).abs() > TEMPERATURE_EXPLAINS_C
                }
                _ => false,
            };
            drifted = d.offset_rad.abs() > policy.drift_rad
                || (!warmed
                    && (b / ref_brightness.max(1e-3) - 1.0).abs() > policy.drift_brightness);
        }
        if drifted {
            let auto = policy.auto_after_s > 0.0;
            if auto && !d.contact && calm_since.elapsed().as_secs_f32() >= policy.auto_after_s {
                renew = true;
            } else {
                d.flags.insert(vistaf_protocol::Flag::StaleReference);
                c.stale += 1;
            }
        }
        let latency_us = u32::try_from(t0.elapsed().as_micros()).unwrap_or(u32::MAX);
        let due = max_rate_hz == 0
            || last_sent.is_none_or(|t| {
                t.elapsed() >= Duration::from_secs_f32(1.0 / f32::from(max_rate_hz))
            });
        if streaming && due {
            let s = summary_of(&d, seq, capture_us, latency_us, a.mm_per_px());
            seq = seq.wrapping_add(1);
            if tx.send(&DeviceMsg::Summary(s)) {
                c.sent += 1;
            }
            last_sent = Some(Instant::now());
        }
        if std::mem::take(&mut maps_requested[0]) {
            tx.send(&DeviceMsg::Map(depth_tile(
                &d,
                seq.wrapping_sub(1),
                a.mm_per_px(),
            )));
        }
        if std::mem::take(&mut maps_requested[1]) {
            if let Some(m) = temperature_tile(&d, seq.wrapping_sub(1)) {
                tx.send(&DeviceMsg::Map(m));
            }
        }
        if renew {
            // The next stable frames become the new reference.
            analyzer = None;
            last_gray = None;
            settle = 0;
            tx.send(&status(
                &c,
                RunState::Referencing,
                max_rate_hz,
                reference_at,
            ));
        }
    }
    stop.store(true, Ordering::Relaxed);
    let _ = led.off();
    drop(frame_rx);
    let failure = capture.join().ok().flatten();
    c.captured = captured.load(Ordering::Relaxed);
    c.dropped = dropped.load(Ordering::Relaxed);
    c.link_errors = tx.errors;
    c.camera_restarts = restarts.load(Ordering::Relaxed);
    tx.send(&status(&c, RunState::Stopped, max_rate_hz, reference_at));
    if let Some(e) = failure {
        anyhow::bail!("source failed: {e}");
    }
    Ok(c)
}

fn smart_leds_rgb(c: vistaf_protocol::Rgb) -> smart_leds::RGB8 {
    smart_leds::RGB8 {
        r: c.r,
        g: c.g,
        b: c.b,
    }
}
