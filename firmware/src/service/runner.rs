//! The service's edge: the threads that read the camera and the link, the loop that feeds
//! their events to the [`Service`], and the writer that frames what it says.

use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crossbeam_channel::{bounded, Receiver, RecvTimeoutError, Sender, TrySendError};
use vistaf_hardware::decode::Decoded;
use vistaf_hardware::led::LedRing;
use vistaf_hardware::source::FrameSource;
use vistaf_protocol::frame::DEVICE_FRAME_MAX;
use vistaf_protocol::{encode, DeviceMsg, HostDecoder, HostMsg};

use super::clock::SystemClock;
use super::machine::{decode_scale, CameraEvent, DecodedFrame, EdgeCounters, Service};
use super::systemd::Systemd;
use super::{Counters, Settings};

/// How long the loop waits for a frame before it looks at commands and time again.
const FRAME_WAIT: Duration = Duration::from_millis(50);
/// Pause of a source that reports a transient error without a back-off of its own.
const RETRY_PAUSE: Duration = Duration::from_millis(20);
/// Pause of the link reader when the link reads nothing or fails.
const LINK_IDLE: Duration = Duration::from_millis(20);
const LINK_ERROR_PAUSE: Duration = Duration::from_millis(100);

/// Writes framed messages to the link, counting failures (and summaries written) instead
/// of stopping.
struct Tx<W: Write> {
    out: W,
    buf: Box<[u8; DEVICE_FRAME_MAX]>,
    errors: u32,
    summaries: u32,
}

impl<W: Write> Tx<W> {
    fn send(&mut self, msg: &DeviceMsg) {
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
        } else if matches!(msg, DeviceMsg::Summary(_)) {
            self.summaries += 1;
        }
    }

    fn send_all(&mut self, msgs: impl IntoIterator<Item = DeviceMsg>) {
        for m in msgs {
            self.send(&m);
        }
    }
}

/// A one-slot mailbox where the newest item wins: putting into a full slot evicts the
/// waiting item (and says so), so the taker always gets the newest.
#[derive(Debug, Clone)]
pub struct Newest<T> {
    tx: Sender<T>,
    rx: Receiver<T>,
}

impl<T> Default for Newest<T> {
    fn default() -> Newest<T> {
        let (tx, rx) = bounded(1);
        Newest { tx, rx }
    }
}

impl<T> Newest<T> {
    /// Puts `item`, evicting a waiting one; `true` when one was evicted.
    pub fn put(&self, item: T) -> bool {
        match self.tx.try_send(item) {
            Ok(()) | Err(TrySendError::Disconnected(_)) => false,
            Err(TrySendError::Full(item)) => {
                let evicted = self.rx.try_recv().is_ok();
                let _ = self.tx.try_send(item);
                evicted
            }
        }
    }

    /// The waiting item, waiting up to `timeout` for one.
    pub fn take(&self, timeout: Duration) -> Result<T, RecvTimeoutError> {
        self.rx.recv_timeout(timeout)
    }

    /// Whether nothing is waiting.
    pub fn is_empty(&self) -> bool {
        self.rx.is_empty()
    }
}

/// What the capture thread needs besides its source: where decoded frames go and the
/// buffers the service hands back (the scale, and whether to keep the camera's bytes, it
/// reads from the [`EdgeCounters`] the service sets).
struct Decoding {
    frames: Newest<DecodedFrame>,
    spare: Receiver<Decoded>,
}

/// Reads the source as fast as it delivers and decodes each frame for the pipeline
/// (capture and decoding on this thread, the pipeline on the service's, so the two
/// overlap on a multi-core board), into `out.frames` where the newest wins, until the
/// source ends, fails for good, or `stop` is set; returns the failure, if any. A transient
/// error (the camera lost) is reported once per outage and retried after `retry_pause`.
fn capture(
    mut source: Box<dyn FrameSource>,
    out: Decoding,
    camera: Sender<CameraEvent>,
    edge: Arc<EdgeCounters>,
    stop: Arc<AtomicBool>,
    retry_pause: Duration,
) -> Option<String> {
    let mut lost = false;
    while !stop.load(Ordering::Relaxed) {
        let frame = match source.next_frame() {
            Ok(Some(f)) => f,
            Ok(None) => return None,
            Err(e) if e.is_transient() => {
                if !lost {
                    lost = true;
                    let _ = camera.try_send(CameraEvent::Lost(e.to_string()));
                }
                std::thread::sleep(retry_pause);
                continue;
            }
            Err(e) => return Some(e.to_string()),
        };
        if lost {
            lost = false;
            edge.camera_restarts.fetch_add(1, Ordering::Relaxed);
            let _ = camera.try_send(CameraEvent::Back);
        }
        if let Some(note) = source.take_note() {
            eprintln!("vistaf-skin: {}: {note}", source.name());
        }
        edge.captured.fetch_add(1, Ordering::Relaxed);
        let buf = out.spare.try_recv().unwrap_or_default();
        let scale = edge.decode_scale.load(Ordering::Relaxed);
        let keep_raw = edge.keep_raw.load(Ordering::Relaxed);
        let decoded = DecodedFrame::decode(frame, scale, Instant::now(), buf, keep_raw);
        if out.frames.put(decoded) {
            edge.dropped.fetch_add(1, Ordering::Relaxed);
        }
    }
    None
}

/// Decodes host commands from the link into `commands`, each with the instant it was
/// decoded (a clock request's answer tells it), until `stop` is set; frames that do not
/// decode are counted.
fn read_commands(
    mut link: Box<dyn Read + Send>,
    commands: Sender<(HostMsg, Instant)>,
    edge: Arc<EdgeCounters>,
    stop: Arc<AtomicBool>,
) {
    let mut dec = HostDecoder::new();
    let mut buf = [0u8; 256];
    while !stop.load(Ordering::Relaxed) {
        match link.read(&mut buf) {
            Ok(0) => std::thread::sleep(LINK_IDLE),
            Ok(n) => dec.push(&buf[..n], |r| match r {
                Ok(m) => {
                    let _ = commands.try_send((m, Instant::now()));
                }
                Err(_) => {
                    edge.link_frames_dropped.fetch_add(1, Ordering::Relaxed);
                }
            }),
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock
                        | std::io::ErrorKind::TimedOut
                        | std::io::ErrorKind::Interrupted
                ) => {}
            Err(_) => std::thread::sleep(LINK_ERROR_PAUSE),
        }
    }
}

/// The threads at the edge and the channels from them.
struct Edge {
    frames: Newest<DecodedFrame>,
    /// Buffers of frames the pipeline is done with, back to the capture thread.
    spare: Sender<Decoded>,
    commands: Receiver<(HostMsg, Instant)>,
    camera: Receiver<CameraEvent>,
    capture: JoinHandle<Option<String>>,
    counters: Arc<EdgeCounters>,
}

impl Edge {
    /// Starts the threads; frames are decoded at `1/scale`.
    fn start(
        source: Box<dyn FrameSource>,
        link_in: Option<Box<dyn Read + Send>>,
        stop: &Arc<AtomicBool>,
        scale: u32,
    ) -> Edge {
        let counters = Arc::new(EdgeCounters::default());
        counters.decode_scale.store(scale, Ordering::Relaxed);
        let frames = Newest::default();
        let (camera_tx, camera) = bounded(16);
        let (spare, spares) = bounded(1);
        let out = Decoding {
            frames: frames.clone(),
            spare: spares,
        };
        let (edge, cap_stop) = (counters.clone(), stop.clone());
        let capture = std::thread::spawn(move || {
            capture(source, out, camera_tx, edge, cap_stop, RETRY_PAUSE)
        });
        let (commands_tx, commands) = bounded(64);
        if let Some(rd) = link_in {
            let (edge, rd_stop) = (counters.clone(), stop.clone());
            std::thread::spawn(move || read_commands(rd, commands_tx, edge, rd_stop));
        }
        Edge {
            frames,
            spare,
            commands,
            camera,
            capture,
            counters,
        }
    }
}

/// Runs the service until the source ends, `frames` have been processed, or `stop` is set.
///
/// `commands` is the link's read side (None for a write-only link such as stdout).
pub fn run(
    source: Box<dyn FrameSource>,
    link: impl Write,
    commands: Option<Box<dyn Read + Send>>,
    led: &mut dyn LedRing,
    settings: &Settings,
    stop: Arc<AtomicBool>,
) -> anyhow::Result<Counters> {
    // The device's clock starts before anything is timed on it.
    vistaf_hardware::clock::epoch();
    let format = source.format();
    let mut tx = Tx {
        out: link,
        buf: Box::new([0u8; DEVICE_FRAME_MAX]),
        errors: 0,
        summaries: 0,
    };
    let scale = decode_scale(&settings.calibration, &format);
    let edge = Edge::start(source, commands, &stop, scale);
    let mut service = Service::new(settings, format, led, edge.counters.clone(), SystemClock);
    tx.send_all(service.start());
    let mut systemd = Systemd::from_env();
    systemd.ready();
    serve(&mut service, &edge, &mut tx, &stop, &mut systemd);
    systemd.stopping();
    stop.store(true, Ordering::Relaxed);
    let failure = stop_capture(edge.capture);
    tx.send(&service.finish());
    let counters = service.counters();
    if let Some(e) = failure {
        anyhow::bail!("source failed: {e}");
    }
    let e = &edge.counters;
    Ok(Counters {
        captured: e.captured.load(Ordering::Relaxed),
        dropped: e.dropped.load(Ordering::Relaxed),
        camera_restarts: e.camera_restarts.load(Ordering::Relaxed),
        sent: tx.summaries,
        link_errors: tx.errors,
        ..counters
    })
}

/// How long the capture thread has to stop after the service did: a source blocked in a
/// read (a camera that froze, a replay pacing a frame far in the future) is left behind.
const CAPTURE_STOP_GRACE: Duration = Duration::from_secs(2);

/// Waits for the capture thread to stop (up to [`CAPTURE_STOP_GRACE`]); its failure, if it
/// failed, and a panic counts as one.
fn stop_capture(capture: JoinHandle<Option<String>>) -> Option<String> {
    let deadline = std::time::Instant::now() + CAPTURE_STOP_GRACE;
    while !capture.is_finished() {
        if std::time::Instant::now() >= deadline {
            eprintln!(
                "vistaf-skin: the camera did not stop within {CAPTURE_STOP_GRACE:?}; leaving it"
            );
            return None;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    match capture.join() {
        Ok(failure) => failure,
        Err(_) => Some("the capture thread panicked".into()),
    }
}

/// The loop: commands first (they never wait for a frame), then camera events, the
/// `Status` when due, and the next frame.
///
/// Every turn tells systemd the loop is alive: one that hangs (in the pipeline, on the
/// link) stops the pets and is restarted.
fn serve<W: Write>(
    service: &mut Service<'_, SystemClock>,
    edge: &Edge,
    tx: &mut Tx<W>,
    stop: &AtomicBool,
    systemd: &mut Systemd,
) {
    while !stop.load(Ordering::Relaxed) && !service.done() {
        systemd.alive(std::time::Instant::now());
        for (cmd, received) in edge.commands.try_iter() {
            tx.send(&service.on_command_received(cmd, received));
        }
        for event in edge.camera.try_iter() {
            tx.send_all(service.on_camera(event));
        }
        tx.send_all(service.on_tick());
        tx.send_all(service.on_background());
        let frame = match edge.frames.take(FRAME_WAIT) {
            Ok(f) => f,
            Err(RecvTimeoutError::Timeout) => {
                if edge.capture.is_finished() && edge.frames.is_empty() {
                    break;
                }
                continue;
            }
            Err(RecvTimeoutError::Disconnected) => break,
        };
        let out = service.on_decoded(frame);
        let summaries: Vec<u64> = out
            .iter()
            .filter_map(|m| match m {
                DeviceMsg::Summary(s) => Some(s.capture_us),
                _ => None,
            })
            .collect();
        tx.send_all(out);
        for capture_us in summaries {
            service.on_sent(capture_us);
        }
        let _ = edge.spare.try_send(service.take_buffer());
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use vistaf_hardware::source::{SourceError, SourceFormat};
    use vistaf_hardware::{Frame, PixelFormat};

    #[test]
    fn the_newest_item_wins_and_evictions_are_told() {
        let slot = Newest::default();
        assert!(!slot.put(1));
        assert!(slot.put(2));
        assert!(slot.put(3));
        assert_eq!(slot.take(Duration::ZERO), Ok(3));
        assert!(slot.is_empty());
        assert_eq!(slot.take(Duration::ZERO), Err(RecvTimeoutError::Timeout));
    }

    /// Frames, then the camera gone for a few reads, then frames again.
    struct Flaky {
        next: u64,
        gone: std::ops::Range<u64>,
        frames: u64,
    }

    impl FrameSource for Flaky {
        fn format(&self) -> SourceFormat {
            SourceFormat {
                width: 2,
                height: 1,
                pixel: PixelFormat::Gray8,
                interval: None,
            }
        }
        fn name(&self) -> String {
            "flaky".into()
        }
        fn next_frame(&mut self) -> Result<Option<Frame>, SourceError> {
            self.next += 1;
            if self.gone.contains(&self.next) {
                return Err(SourceError::Gone {
                    device: "/dev/video9".into(),
                    detail: "unplugged".into(),
                });
            }
            Ok((self.next <= self.frames).then(|| Frame {
                width: 2,
                height: 1,
                format: PixelFormat::Gray8,
                data: vec![0, 0],
                timestamp: Duration::ZERO,
                seq: self.next,
            }))
        }
    }

    #[test]
    fn a_lost_camera_is_reported_once_and_counted_when_it_returns() {
        let source = Box::new(Flaky {
            next: 0,
            gone: 6..11,
            frames: 14,
        });
        let (frames, edge) = (Newest::default(), Arc::new(EdgeCounters::default()));
        let (events_tx, events) = bounded(16);
        let stop = Arc::new(AtomicBool::new(false));
        edge.decode_scale.store(1, Ordering::Relaxed);
        let out = Decoding {
            frames: frames.clone(),
            spare: bounded(1).1,
        };
        let failure = capture(source, out, events_tx, edge.clone(), stop, Duration::ZERO);
        assert_eq!(failure, None, "the source ended");
        let seen: Vec<CameraEvent> = events.try_iter().collect();
        assert_eq!(
            seen,
            [
                CameraEvent::Lost("/dev/video9: device not available: unplugged".into()),
                CameraEvent::Back
            ]
        );
        assert_eq!(edge.camera_restarts.load(Ordering::Relaxed), 1);
        assert_eq!(edge.captured.load(Ordering::Relaxed), 9);
        // Nobody took frames: all but the newest were evicted.
        assert_eq!(edge.dropped.load(Ordering::Relaxed), 8);
        assert_eq!(frames.take(Duration::ZERO).map(|f| f.seq), Ok(14));
    }
}
