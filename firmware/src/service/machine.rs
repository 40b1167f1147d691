//! The service's decisions, without threads or I/O: each event (a frame, a host command, a
//! camera outage, the passing of time) goes in, the messages to send come out. The time
//! comes from an injected [`Clock`], so a test drives the service frame by frame with a
//! clock it moves by hand.

use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use vistaf_hardware::bench::Stimulus;
use vistaf_hardware::clock::micros;
use vistaf_hardware::decode::Decoded;
use vistaf_hardware::frame::Frame;
use vistaf_hardware::led::{LedConfig, LedRing};
use vistaf_hardware::source::SourceFormat;
use vistaf_pipeline::input::Pixels;
use vistaf_pipeline::{Analyzer, AnalyzerOptions, Calibration, Scratch};
use vistaf_protocol::msg::truncated;
use vistaf_protocol::{
    schema_hash, CalibrationFitted, CalibrationId, ClockReading, Command, DeviceError, DeviceMsg,
    ErrorCode, FirmwareVersion, Flag, Hello, HostMsg, KitQuantity, KitStep, KitVerdict, MapKind,
    RunState, Status, PROTOCOL_VERSION,
};

use super::clock::Clock;
use super::kit::{Kit, Offered};
use super::maps::{self, Size};
use super::reference::{ReferenceKeeper, Verdict};
use super::wire::summary_of;
use super::{Counters, Settings};

/// How often a `Status` goes out.
pub const STATUS_INTERVAL: Duration = Duration::from_secs(1);
/// How long after a reference that could not be used the next attempt is made.
pub const REFERENCE_RETRY: Duration = Duration::from_secs(1);

/// What the threads at the edge (capture, link reader) and the service share: the
/// counts the edge keeps, read into `Status`, and how the service wants frames decoded.
#[derive(Debug, Default)]
pub struct EdgeCounters {
    /// Frames delivered by the source.
    pub captured: AtomicU32,
    /// Frames evicted by a newer one before the pipeline took them.
    pub dropped: AtomicU32,
    /// Times frames resumed after the camera was lost.
    pub camera_restarts: AtomicU32,
    /// Host frames the link reader could not decode.
    pub link_frames_dropped: AtomicU32,
    /// Set by the service while a calibration kit step waits: the capture thread keeps
    /// each frame's bytes as the camera sent them.
    pub keep_raw: AtomicBool,
    /// The scale the capture thread decodes at (the calibration in use chooses it).
    pub decode_scale: AtomicU32,
}

impl EdgeCounters {
    fn get(counter: &AtomicU32) -> u32 {
        counter.load(Ordering::Relaxed)
    }
}

/// The camera went away, or came back.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CameraEvent {
    /// Lost, with the reason.
    Lost(String),
    /// Frames again.
    Back,
}

/// A camera frame decoded for the pipeline (on the capture thread, while the pipeline
/// works on the frame before), with what the service keeps of the camera's frame.
#[derive(Debug, Clone)]
pub struct DecodedFrame {
    /// The camera's capture time, µs on the device's clock.
    pub capture_us: u64,
    /// The source's sequence number.
    pub seq: u64,
    /// The camera's image size, pixels.
    pub size: (u32, u32),
    /// When decoding began: a summary's latency counts from here.
    pub started: Instant,
    /// The pixels, or why the bytes did not decode.
    pub pixels: Result<Decoded, vistaf_hardware::frame::FrameError>,
    /// The camera's bytes, when they were asked for (a calibration kit keeps them).
    pub raw: Option<Frame>,
    /// The scale the pixels were decoded at.
    pub scale: u32,
}

impl DecodedFrame {
    /// Decodes `frame` at `1/scale` into `buf` (a buffer handed back by
    /// [`Service::on_decoded`], or a new one; an RGB frame read whole keeps its own),
    /// decoding from `started`; with `keep_raw`, a copy of the camera's bytes is kept.
    pub fn decode(
        frame: Frame,
        scale: u32,
        started: Instant,
        buf: Decoded,
        keep_raw: bool,
    ) -> DecodedFrame {
        let raw = keep_raw.then(|| frame.clone());
        DecodedFrame {
            capture_us: u64::try_from(frame.timestamp.as_micros()).unwrap_or(u64::MAX),
            seq: frame.seq,
            size: (frame.width, frame.height),
            started,
            pixels: frame.into_decoded(scale, buf),
            raw,
            scale,
        }
    }
}

/// The scale a source's frames are decoded at under `calibration`.
pub fn decode_scale(calibration: &Calibration, format: &SourceFormat) -> u32 {
    calibration.unit.scale_for(format.width, format.height)
}

/// The service's state between events.
pub struct Service<'a, C: Clock> {
    settings: &'a Settings,
    clock: C,
    led: &'a mut dyn LedRing,
    edge: Arc<EdgeCounters>,
    format: SourceFormat,
    started: Instant,
    counters: Counters,
    keeper: ReferenceKeeper,
    streaming: bool,
    max_rate_hz: u16,
    /// When the next summary may go out under the rate limit (`None`: now).
    next_due: Option<Instant>,
    /// Maps asked for, sent with the next analysed frame (each once).
    maps_requested: Vec<(MapKind, Size)>,
    /// When the last `Status` went out (`None`: one is due now).
    last_status: Option<Instant>,
    camera_lost: bool,
    seq: u32,
    /// The pipeline's buffers, kept from frame to frame.
    scratch: Scratch,
    /// A decoded frame's buffer, kept from frame to frame.
    decoded: Decoded,
    /// Frames are decoded at `1/scale` (the calibration's, for this camera's size).
    scale: u32,
    /// Before this, no reference is attempted (the last attempt failed).
    reference_retry_at: Option<Instant>,
    /// Capture to link of the last summaries sent.
    latency: Latencies,
    /// The calibration in use (the settings' until one is activated).
    calibration: Calibration,
    /// The one the last activation replaced.
    previous: Option<Calibration>,
    /// A calibration kit being captured or fitted.
    kit: Kit,
    /// The last kit's fitted calibration, until activated.
    candidate: Option<Calibration>,
}

/// The last [`Latencies::KEPT`] capture-to-link latencies, µs, for the `Status`'s
/// percentiles.
#[derive(Debug, Clone, Default)]
struct Latencies {
    kept: Vec<u32>,
    next: usize,
}

impl Latencies {
    const KEPT: usize = 256;

    fn add(&mut self, us: u32) {
        if self.kept.len() < Self::KEPT {
            self.kept.push(us);
        } else {
            self.kept[self.next] = us;
        }
        self.next = (self.next + 1) % Self::KEPT;
    }

    /// The 50th and 99th percentiles (nearest rank), µs; 0 before any.
    fn p50_p99(&self) -> (u32, u32) {
        let mut v = self.kept.clone();
        v.sort_unstable();
        let rank = |p: usize| {
            v.get((v.len() * p).div_ceil(100).saturating_sub(1))
                .copied()
                .unwrap_or(0)
        };
        (rank(50), rank(99))
    }
}

impl<C: Clock> std::fmt::Debug for Service<'_, C> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Service")
            .field("counters", &self.counters)
            .field("streaming", &self.streaming)
            .field("seq", &self.seq)
            .finish_non_exhaustive()
    }
}

impl<'a, C: Clock> Service<'a, C> {
    /// A service for a source delivering `format`, reading its edge's counts from `edge`.
    pub fn new(
        settings: &'a Settings,
        format: SourceFormat,
        led: &'a mut dyn LedRing,
        edge: Arc<EdgeCounters>,
        clock: C,
    ) -> Service<'a, C> {
        let now = clock.now();
        Service {
            settings,
            clock,
            led,
            edge,
            started: now,
            counters: Counters::default(),
            keeper: ReferenceKeeper::new(settings.reference, now),
            streaming: true,
            max_rate_hz: settings.max_rate_hz,
            next_due: None,
            maps_requested: Vec::new(),
            last_status: Some(now),
            camera_lost: false,
            seq: 0,
            scratch: Scratch::default(),
            decoded: Decoded::default(),
            scale: decode_scale(&settings.calibration, &format),
            format,
            reference_retry_at: None,
            latency: Latencies::default(),
            calibration: settings.calibration.clone(),
            previous: settings.previous.clone(),
            kit: Kit::new(settings.kit_dir.clone()),
            candidate: None,
        }
    }

    /// A summary of the frame captured at `capture_us` (device clock, µs) has been written
    /// to the link, its last byte now: the latency the `Status` reports.
    pub fn on_sent(&mut self, capture_us: u64) {
        let now = micros(self.clock.now());
        let us = now.saturating_sub(capture_us);
        self.latency.add(u32::try_from(us).unwrap_or(u32::MAX));
    }

    /// What goes out first: `Hello`, and the LED ring lit (a failing ring is reported on
    /// stderr: the skin keeps reporting without it).
    pub fn start(&mut self) -> Vec<DeviceMsg> {
        if let Err(e) = self.led.show(&self.settings.led) {
            eprintln!("vistaf-skin: {e}");
        }
        vec![self.hello()]
    }

    /// Whether the frame limit of the settings is reached.
    pub fn done(&self) -> bool {
        self.settings
            .frames
            .is_some_and(|n| u64::from(self.counters.processed) >= n)
    }

    /// The counters so far (the edge's come from [`EdgeCounters`] and the link).
    pub fn counters(&self) -> Counters {
        Counters {
            references: self.keeper.taken(),
            ..self.counters
        }
    }

    /// The last `Status` (state `Stopped`), and the LED ring off.
    pub fn finish(&mut self) -> DeviceMsg {
        let _ = self.led.off();
        self.status(RunState::Stopped)
    }

    /// The device's identity.
    pub fn hello(&self) -> DeviceMsg {
        DeviceMsg::Hello(Hello {
            protocol_version: PROTOCOL_VERSION,
            schema_hash: schema_hash(),
            firmware: firmware_version(),
            serial: truncated(&self.settings.serial),
            frame_width_px: u16::try_from(self.format.width).unwrap_or(u16::MAX),
            frame_height_px: u16::try_from(self.format.height).unwrap_or(u16::MAX),
            calibration_id: self.calibration.id(),
        })
    }

    /// A host command and its answer, the command taken as received now.
    pub fn on_command(&mut self, cmd: HostMsg) -> DeviceMsg {
        let now = self.clock.now();
        self.on_command_received(cmd, now)
    }

    /// A host command decoded from the link at `received`, and its answer.
    pub fn on_command_received(&mut self, cmd: HostMsg, received: Instant) -> DeviceMsg {
        match cmd {
            HostMsg::Ping { nonce } => DeviceMsg::Pong { nonce },
            HostMsg::Clock { nonce } => DeviceMsg::Clock(ClockReading {
                nonce,
                received_us: micros(received),
                sent_us: micros(self.clock.now()),
            }),
            HostMsg::GetInfo => self.hello(),
            HostMsg::CaptureReference => {
                self.keeper.renew();
                DeviceMsg::Ack(Command::CaptureReference)
            }
            HostMsg::SetRate { max_rate_hz } => {
                self.max_rate_hz = max_rate_hz;
                self.next_due = None;
                DeviceMsg::Ack(Command::SetRate)
            }
            HostMsg::SetLed(l) => {
                let cfg = LedConfig {
                    rgb: smart_leds::RGB8 {
                        r: l.rgb.r,
                        g: l.rgb.g,
                        b: l.rgb.b,
                    },
                    brightness: l.brightness,
                    lit_mask: l.lit_mask,
                    ..self.settings.led
                };
                match self.led.show(&cfg) {
                    Ok(()) => DeviceMsg::Ack(Command::SetLed),
                    Err(e) => error(ErrorCode::LedFault, &e.to_string()),
                }
            }
            HostMsg::RequestMap(MapKind::Temperature)
            | HostMsg::RequestFullMap(MapKind::Temperature)
                if self.calibration.temperature.is_none() =>
            {
                error(
                    ErrorCode::UnsupportedCommand,
                    "the calibration has no temperature model",
                )
            }
            HostMsg::RequestMap(MapKind::Camera) => error(
                ErrorCode::UnsupportedCommand,
                "the camera image is sent whole only: RequestFullMap",
            ),
            HostMsg::RequestMap(kind) => self.request_map(kind, Size::Coarse),
            HostMsg::RequestFullMap(kind) => self.request_map(kind, Size::Full),
            HostMsg::Start => {
                self.streaming = true;
                DeviceMsg::Ack(Command::Start)
            }
            HostMsg::Stop => {
                self.streaming = false;
                DeviceMsg::Ack(Command::Stop)
            }
            HostMsg::KitCapture(step) => self.kit_capture(step),
            HostMsg::KitFit => match self.kit.fit(self.settings.pipeline) {
                Ok(()) => DeviceMsg::Ack(Command::KitFit),
                Err(e) => error(ErrorCode::Calibration, &e),
            },
            HostMsg::CalibrationActivate { calibration_id } => self.activate(calibration_id),
            HostMsg::CalibrationRollback => self.roll_back(),
        }
    }

    /// Notes a map to send with the next analysed frame (asked twice, sent once).
    fn request_map(&mut self, kind: MapKind, size: Size) -> DeviceMsg {
        if !self.maps_requested.contains(&(kind, size)) {
            self.maps_requested.push((kind, size));
        }
        DeviceMsg::Ack(match size {
            Size::Coarse => Command::RequestMap,
            Size::Full => Command::RequestFullMap,
        })
    }

    /// Sets the bench (when software drives it) to `step` and waits for its frame.
    fn kit_capture(&mut self, step: KitStep) -> DeviceMsg {
        let v = step.value_milli as f32 / 1000.0;
        let stimulus = match step.quantity {
            KitQuantity::Reference | KitQuantity::Temperature => Stimulus::Untouched { temp_c: v },
            KitQuantity::Depth => Stimulus::SphereDepth { depth_mm: v },
            KitQuantity::Force => Stimulus::SphereForce { force_n: v },
        };
        if let Some(bench) = &self.settings.bench {
            let applied = bench
                .lock()
                .map_err(|_| "the bench's lock is poisoned".to_string())
                .and_then(|mut b| b.apply(stimulus));
            if let Err(e) = applied {
                return error(ErrorCode::InvalidArgument, &e);
            }
        }
        match self.kit.start(step, self.clock.now()) {
            Ok(()) => {
                self.edge.keep_raw.store(true, Ordering::Relaxed);
                DeviceMsg::Ack(Command::KitCapture)
            }
            Err(e) => error(ErrorCode::Calibration, &e),
        }
    }

    /// Puts the fitted candidate in use, keeping the calibration it replaces.
    fn activate(&mut self, id: u32) -> DeviceMsg {
        let Some(new) = self.candidate.take_if(|c| c.id() == id) else {
            return match &self.candidate {
                Some(c) => error(
                    ErrorCode::InvalidArgument,
                    &format!(
                        "the fitted calibration is {}, not {}",
                        CalibrationId(c.id()),
                        CalibrationId(id)
                    ),
                ),
                None => error(ErrorCode::Calibration, "no fitted calibration to activate"),
            };
        };
        if let Some(path) = &self.settings.calibration_path {
            if let Err(e) = super::persist::activate(path, &new) {
                self.candidate = Some(new);
                return error(ErrorCode::Calibration, &e);
            }
        }
        self.use_calibration(new)
    }

    /// Goes back to the calibration the last activation replaced.
    fn roll_back(&mut self) -> DeviceMsg {
        let Some(old) = self.previous.take() else {
            return error(
                ErrorCode::Calibration,
                "no earlier calibration to roll back to",
            );
        };
        if let Some(path) = &self.settings.calibration_path {
            if let Err(e) = super::persist::roll_back(path) {
                self.previous = Some(old);
                return error(ErrorCode::Calibration, &e);
            }
        }
        self.use_calibration(old)
    }

    /// Puts `c` in use, keeping the one it replaces: frames decoded at its scale, a new
    /// reference; the device's `Hello` with its id.
    fn use_calibration(&mut self, c: Calibration) -> DeviceMsg {
        self.previous = Some(std::mem::replace(&mut self.calibration, c));
        self.scale = decode_scale(&self.calibration, &self.format);
        self.edge.decode_scale.store(self.scale, Ordering::Relaxed);
        self.keeper.renew();
        self.reference_retry_at = None;
        self.hello()
    }

    /// What happened in the background since the last call: a kit step that never
    /// settled, a fit that finished (its verdicts, then the candidate).
    pub fn on_background(&mut self) -> Vec<DeviceMsg> {
        let mut out = Vec::new();
        if let Some(e) = self.kit.timed_out(self.clock.now()) {
            self.edge.keep_raw.store(false, Ordering::Relaxed);
            out.push(error(ErrorCode::NotSettled, &e));
        }
        match self.kit.fitted() {
            None => {}
            Some(Err(e)) => out.push(error(ErrorCode::Calibration, &format!("kit fit: {e}"))),
            Some(Ok(c)) => {
                let verdicts = vistaf_calibrate::verdict::verdicts(&c);
                out.extend(
                    verdicts
                        .iter()
                        .map(|v| DeviceMsg::KitVerdict(wire_verdict(v))),
                );
                out.push(DeviceMsg::CalibrationFitted(CalibrationFitted {
                    calibration_id: c.id(),
                    pass: verdicts.iter().all(|v| v.pass()),
                }));
                self.candidate = Some(c);
            }
        }
        out
    }

    /// The camera went away or came back: a loss is reported (the capture side reports
    /// each outage once), and a `Status` with the new state is due at the next tick.
    pub fn on_camera(&mut self, event: CameraEvent) -> Option<DeviceMsg> {
        self.camera_lost = matches!(event, CameraEvent::Lost(_));
        self.last_status = None;
        match event {
            CameraEvent::Lost(detail) => Some(error(ErrorCode::CameraLost, &detail)),
            CameraEvent::Back => None,
        }
    }

    /// The `Status`, once a second.
    pub fn on_tick(&mut self) -> Option<DeviceMsg> {
        let now = self.clock.now();
        if self
            .last_status
            .is_some_and(|t| now.saturating_duration_since(t) < STATUS_INTERVAL)
        {
            return None;
        }
        self.last_status = Some(now);
        let state = if self.camera_lost {
            RunState::CameraLost
        } else if self.keeper.analyzer().is_none() {
            RunState::Referencing
        } else if self.streaming {
            RunState::Streaming
        } else {
            RunState::Stopped
        };
        Some(self.status(state))
    }

    /// A frame from the source, decoded here: see [`Service::on_decoded`].
    pub fn on_frame(&mut self, frame: Frame) -> Vec<DeviceMsg> {
        let buf = std::mem::take(&mut self.decoded);
        let keep = self.kit.wants_frames();
        let d = DecodedFrame::decode(frame, self.scale, self.clock.now(), buf, keep);
        self.on_decoded(d)
    }

    /// A decoded frame: a reference when the keeper needs one, else a summary (at the rate
    /// asked for) and the maps asked for. A frame of the wrong size or one that did not
    /// decode is counted and skipped. A summary's latency counts from the frame's bytes as
    /// the camera sent them: decoding is part of it.
    pub fn on_decoded(&mut self, frame: DecodedFrame) -> Vec<DeviceMsg> {
        let fits = frame.size == (self.format.width, self.format.height);
        let img = match frame.pixels {
            // A frame decoded at the scale of the calibration before an activation is
            // skipped, not measured at the wrong size.
            Ok(img) if fits && frame.scale == self.scale => img,
            Ok(img) if fits => {
                self.decoded = img;
                return Vec::new();
            }
            Ok(img) => {
                self.decoded = img;
                self.counters.bad += 1;
                return Vec::new();
            }
            Err(_) => {
                self.counters.bad += 1;
                return Vec::new();
            }
        };
        let mut out = self.offer_to_kit(frame.raw.as_ref(), &img, frame.started);
        out.extend(if self.keeper.analyzer().is_none() {
            self.counters.referencing += 1;
            self.take_reference(Pixels::from(&img))
        } else {
            self.measure(Pixels::from(&img), frame.capture_us, frame.started)
        });
        self.decoded = img;
        out
    }

    /// Offers a frame to the kit step waiting, if any.
    fn offer_to_kit(
        &mut self,
        raw: Option<&Frame>,
        img: &Decoded,
        started: Instant,
    ) -> Vec<DeviceMsg> {
        if !self.kit.wants_frames() {
            return Vec::new();
        }
        let stable_dn = self.settings.reference.stable_dn;
        let period_mm = self.calibration.unit.grating_period_mm;
        let msg = match self.kit.offer(raw, img, started, stable_dn, period_mm) {
            Offered::Waiting => return Vec::new(),
            Offered::Captured(c) => DeviceMsg::KitCaptured(c),
            Offered::Failed(e) => error(ErrorCode::Calibration, &e),
        };
        self.edge.keep_raw.store(false, Ordering::Relaxed);
        vec![msg]
    }

    /// The buffer of the last decoded frame, for the next decode (empty when there is
    /// none).
    pub fn take_buffer(&mut self) -> Decoded {
        std::mem::take(&mut self.decoded)
    }

    /// Offers the frame to the reference keeper; a reference taken is announced by a
    /// `Status`. A reference that cannot be used (no grating in view: a lens cap, the light
    /// off; a calibration for another unit) is reported, and tried again from the frames
    /// after [`REFERENCE_RETRY`]: the service waits for a usable image instead of exiting.
    fn take_reference(&mut self, img: Pixels<'_>) -> Vec<DeviceMsg> {
        let now = self.clock.now();
        if self.reference_retry_at.is_some_and(|t| now < t) {
            return Vec::new();
        }
        let opts = AnalyzerOptions {
            force_calibration: self.settings.force_calibration,
            ..Default::default()
        };
        let (calibration, pipeline) = (&self.calibration, self.settings.pipeline);
        let offered = self.keeper.offer(img, now, |r| {
            Analyzer::new(r, calibration.clone(), pipeline, opts)
        });
        match offered {
            Ok(true) => {
                self.reference_retry_at = None;
                vec![self.status(RunState::Streaming)]
            }
            Ok(false) => Vec::new(),
            Err(e) => {
                self.counters.reference_failures += 1;
                self.reference_retry_at = Some(now + REFERENCE_RETRY);
                vec![error(ErrorCode::Reference, &e.to_string())]
            }
        }
    }

    /// Measures a frame against the reference and says what it found; its latency counts
    /// from `t0`.
    fn measure(&mut self, img: Pixels<'_>, capture_us: u64, t0: Instant) -> Vec<DeviceMsg> {
        let mut out = Vec::new();
        let Some(analyzer) = self.keeper.analyzer() else {
            return out;
        };
        let mm_per_px = analyzer.mm_per_px();
        let Ok(mut d) = analyzer.analyze_with(img, &mut self.scratch) else {
            self.counters.bad += 1;
            return out;
        };
        self.counters.processed += 1;
        let verdict = self.keeper.judge(&d, img, self.clock.now());
        if verdict == Verdict::Stale {
            d.flags.insert(Flag::StaleReference);
            self.counters.stale += 1;
        }
        let now = self.clock.now();
        let latency_us =
            u32::try_from(now.saturating_duration_since(t0).as_micros()).unwrap_or(u32::MAX);
        if self.streaming && self.summary_due(now) {
            out.push(DeviceMsg::Summary(summary_of(
                &d, self.seq, capture_us, latency_us, mm_per_px,
            )));
            self.seq = self.seq.wrapping_add(1);
        }
        let last_seq = self.seq.wrapping_sub(1);
        for (kind, size) in std::mem::take(&mut self.maps_requested) {
            let Some(p) = maps::plane(kind, &d, img, mm_per_px) else {
                continue;
            };
            match size {
                Size::Coarse => out.push(DeviceMsg::Map(p.tile(last_seq))),
                Size::Full => out.extend(maps::chunks(&p, last_seq).map(DeviceMsg::MapChunk)),
            }
        }
        if verdict == Verdict::Renew {
            self.keeper.renew();
            out.push(self.status(RunState::Referencing));
        }
        out
    }

    /// Whether a summary may go out at `now` under the rate limit, and if so when the next
    /// may. Summaries are due on a fixed schedule, not a period after the last one: a
    /// 10 Hz limit on a 30 frames/s camera gives every third frame, not every fourth (a
    /// frame a nanosecond early would otherwise wait for the next). A schedule more than a
    /// period behind (the frames stopped) starts afresh.
    fn summary_due(&mut self, now: Instant) -> bool {
        if self.max_rate_hz == 0 {
            return true;
        }
        let period = Duration::from_secs_f64(1.0 / f64::from(self.max_rate_hz));
        if self.next_due.is_some_and(|t| now < t) {
            return false;
        }
        let slot = match self.next_due {
            Some(t) if t + period >= now => t,
            _ => now,
        };
        self.next_due = Some(slot + period);
        true
    }

    /// A `Status` in `state`.
    fn status(&self, state: RunState) -> DeviceMsg {
        let now = self.clock.now();
        let edge = &self.edge;
        let (p50, p99) = self.latency.p50_p99();
        DeviceMsg::Status(Status {
            uptime_ms: now.saturating_duration_since(self.started).as_millis() as u64,
            state,
            max_rate_hz: self.max_rate_hz,
            frames_captured: EdgeCounters::get(&edge.captured),
            frames_processed: self.counters.processed,
            frames_dropped: EdgeCounters::get(&edge.dropped),
            bad_frames: self.counters.bad,
            link_frames_dropped: EdgeCounters::get(&edge.link_frames_dropped),
            reference_age_ms: self.keeper.age(now).as_millis().min(u128::from(u32::MAX)) as u32,
            camera_restarts: u16::try_from(EdgeCounters::get(&edge.camera_restarts))
                .unwrap_or(u16::MAX),
            latency_p50_us: p50,
            latency_p99_us: p99,
        })
    }
}

/// A verdict as the wire carries it (milli-units, rounded).
fn wire_verdict(v: &vistaf_calibrate::verdict::Verdict) -> KitVerdict {
    use vistaf_calibrate::verdict::Model;
    let milli = |x: f64| (x * 1000.0).round().clamp(0.0, f64::from(u32::MAX)) as u32;
    KitVerdict {
        quantity: match v.model {
            Model::Depth => KitQuantity::Depth,
            Model::Force => KitQuantity::Force,
            Model::Temperature => KitQuantity::Temperature,
        },
        samples: u16::try_from(v.n).unwrap_or(u16::MAX),
        error_milli: milli(v.error),
        target_milli: milli(v.target),
        pass: v.pass(),
    }
}

/// A device error message, its detail cut to what the wire carries.
fn error(code: ErrorCode, detail: &str) -> DeviceMsg {
    DeviceMsg::Error(DeviceError {
        code,
        detail: truncated(detail),
    })
}

fn firmware_version() -> FirmwareVersion {
    let v = |s: &str| s.parse::<u8>().unwrap_or(0);
    FirmwareVersion {
        major: v(env!("CARGO_PKG_VERSION_MAJOR")),
        minor: v(env!("CARGO_PKG_VERSION_MINOR")),
        patch: v(env!("CARGO_PKG_VERSION_PATCH")),
    }
}
