//! One skin on one link: decode what it sends, with receive times; send commands and wait
//! for their answers. Every wait has a timeout.

use std::collections::VecDeque;
use std::io;
use std::time::{Duration, Instant, SystemTime};

use vistaf_protocol::frame::HOST_FRAME_MAX;
use vistaf_protocol::{
    encode, schema, CalibrationFitted, ClockReading, Command, DeviceDecoder, DeviceMsg, DropCounts,
    FrameError, Hello, HostMsg, KitCaptured, KitStep, KitVerdict, Map, MapKind, SetLed,
};
use vistaf_session::answer;

use crate::clock::{next_request, ClockEstimator, ClockMap, Exchange, HostTimeline, MappedTime};
use crate::error::HostError;
use crate::link::Link;
use crate::maps::{Collector, Snapshot};

/// Default wait for a command's answer.
pub const DEFAULT_TIMEOUT: Duration = Duration::from_secs(2);

/// A decoded message and when it was received.
#[derive(Debug, Clone, PartialEq)]
pub struct Received {
    /// The message.
    pub msg: DeviceMsg,
    /// Wall-clock receive time (when its last byte was read).
    pub at: SystemTime,
    /// A summary's capture time on the host's clock, with its uncertainty, once the
    /// device's clock has been read ([`Client::keep_clock`], [`Client::sync_clock`]).
    pub captured: Option<MappedTime>,
}

impl Received {
    /// A message received at `at`, with no capture time mapped.
    pub fn new(msg: DeviceMsg, at: SystemTime) -> Received {
        Received {
            msg,
            at,
            captured: None,
        }
    }
}

/// What was thrown away on connecting because the device sent it before the host was
/// listening: a backlog in the port's buffer, the messages before the handshake's answer.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Discarded {
    /// Bytes waiting in the port's input buffer when it was opened.
    pub bytes: u64,
    /// Messages decoded before the device's answer to the handshake.
    pub messages: u64,
}

/// The device's clock, as read by one client: the estimate, the request in flight, and
/// when the next goes out.
#[derive(Debug)]
struct ClockSync {
    timeline: HostTimeline,
    estimator: ClockEstimator,
    pending: Option<(u32, Instant)>,
    nonce: u32,
    every: Option<Duration>,
    next_at: Instant,
}

/// How long a clock request may go unanswered before another is sent.
const CLOCK_ANSWER_WAIT: Duration = Duration::from_secs(1);

/// A skin's identity in one line: serial, firmware, image size.
pub fn describe(hello: &Hello) -> String {
    let fw = hello.firmware;
    format!(
        "skin {} firmware {}.{}.{}, {}×{} px",
        hello.serial, fw.major, fw.minor, fw.patch, hello.frame_width_px, hello.frame_height_px
    )
}

/// What [`Client::next`] produced.
// Summaries are the common case and small; a rare Map makes the enum large. Boxing
// would cost an allocation per summary to save stack on the rare case.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, PartialEq)]
pub enum Next {
    /// A message.
    Message(Received),
    /// Nothing arrived before the deadline.
    Timeout,
    /// The stream ended (end of file, port closed).
    End,
}

/// A client of one skin.
#[derive(Debug)]
pub struct Client {
    link: Link,
    decoder: Box<DeviceDecoder>,
    queue: VecDeque<Received>,
    mismatch: Option<(u16, u64)>,
    ended: bool,
    clock: ClockSync,
    maps: Option<MapRequests>,
    discarded_messages: u64,
}

/// Maps asked for periodically ([`Client::keep_maps`]).
#[derive(Debug)]
struct MapRequests {
    kinds: Vec<MapKind>,
    every: Duration,
    next_at: Instant,
}

impl Client {
    /// A client over an open link.
    pub fn new(link: Link) -> Client {
        Client {
            link,
            decoder: Box::new(DeviceDecoder::new()),
            queue: VecDeque::new(),
            mismatch: None,
            ended: false,
            clock: ClockSync {
                timeline: HostTimeline::now(),
                estimator: ClockEstimator::new(),
                pending: None,
                nonce: 0,
                every: None,
                next_at: Instant::now(),
            },
            maps: None,
            discarded_messages: 0,
        }
    }

    /// Asks for maps of `kinds` every `period` while messages are read (each comes with
    /// the next processed frame, as a `Map` message). Nothing is sent on a read-only link.
    pub fn keep_maps(&mut self, kinds: &[MapKind], period: Duration) {
        self.maps = (!kinds.is_empty()).then(|| MapRequests {
            kinds: kinds.to_vec(),
            every: period,
            next_at: Instant::now(),
        });
    }

    /// Sends the map requests when they are due.
    fn request_maps_if_due(&mut self) -> Result<(), HostError> {
        let now = Instant::now();
        let Some(m) = self.maps.as_mut() else {
            return Ok(());
        };
        if !self.link.is_writable() || now < m.next_at {
            return Ok(());
        }
        m.next_at = now + m.every;
        let kinds = m.kinds.clone();
        for kind in kinds {
            self.send(&HostMsg::RequestMap(kind))?;
        }
        Ok(())
    }

    /// What was thrown away on connecting, sent before the host was listening.
    pub fn discarded(&self) -> Discarded {
        Discarded {
            bytes: self.link.discarded_bytes(),
            messages: self.discarded_messages,
        }
    }

    /// Reads the device's clock every `period` while messages are read (quickly at first,
    /// until a few exchanges are in), so every summary gets its capture time on the host's
    /// clock ([`Received::captured`]). Nothing is sent on a read-only link.
    pub fn keep_clock(&mut self, period: Duration) {
        self.clock.every = Some(period);
        self.clock.next_at = Instant::now();
    }

    /// The device's clock mapped onto the host's, once read.
    pub fn clock_map(&self) -> Option<&ClockMap> {
        self.clock.estimator.map()
    }

    /// Reads the device's clock `exchanges` times, one request after the other, and returns
    /// the map; messages arriving meanwhile stay queued for [`Client::next`].
    pub fn sync_clock(
        &mut self,
        exchanges: usize,
        timeout: Duration,
    ) -> Result<ClockMap, HostError> {
        let deadline = Instant::now() + timeout;
        for _ in 0..exchanges {
            self.request_clock()?;
            while self.clock.pending.is_some() {
                if self.ended || Instant::now() >= deadline {
                    return Err(HostError::Timeout {
                        link: self.name().to_string(),
                        waiting_for: "Clock",
                        timeout,
                    });
                }
                self.fill()?;
            }
        }
        self.clock_map().copied().ok_or_else(|| HostError::Timeout {
            link: self.name().to_string(),
            waiting_for: "Clock",
            timeout,
        })
    }

    fn request_clock(&mut self) -> Result<(), HostError> {
        let c = &mut self.clock;
        c.nonce = c.nonce.wrapping_add(1);
        let nonce = c.nonce;
        let sent = Instant::now();
        c.pending = Some((nonce, sent));
        c.next_at = sent + next_request(c.estimator.len(), c.every.unwrap_or(CLOCK_ANSWER_WAIT));
        self.send(&HostMsg::Clock { nonce })
    }

    /// Sends a clock request when one is due (and the last was answered or given up on).
    fn request_clock_if_due(&mut self) -> Result<(), HostError> {
        let now = Instant::now();
        let c = &self.clock;
        let due = c.every.is_some()
            && self.link.is_writable()
            && now >= c.next_at
            && c.pending
                .is_none_or(|(_, sent)| now.duration_since(sent) >= CLOCK_ANSWER_WAIT);
        if due {
            self.request_clock()?;
        }
        Ok(())
    }

    /// Takes a clock answer: one exchange, if it answers the request in flight.
    fn clock_answered(&mut self, reading: &ClockReading, at: Instant) {
        let c = &mut self.clock;
        if let Some((nonce, sent)) = c.pending {
            if nonce == reading.nonce {
                c.pending = None;
                c.estimator.add(Exchange {
                    host_sent_s: c.timeline.unix_s(sent),
                    device_received_us: reading.received_us,
                    device_sent_us: reading.sent_us,
                    host_received_s: c.timeline.unix_s(at),
                });
            }
        }
    }

    /// The link's name.
    pub fn name(&self) -> &str {
        self.link.name()
    }

    /// Frames dropped so far, by reason.
    pub fn drops(&self) -> DropCounts {
        self.decoder.drops()
    }

    /// Frames decoded so far.
    pub fn accepted(&self) -> u64 {
        self.decoder.accepted()
    }

    /// The next message, waiting until `deadline` (`None`: wait as long as it takes).
    ///
    /// A device that announces another protocol version ends the stream with
    /// [`HostError::Incompatible`]: nothing it sends afterwards could be trusted.
    pub fn next(&mut self, deadline: Option<Instant>) -> Result<Next, HostError> {
        loop {
            if let Some(r) = self.queue.pop_front() {
                return Ok(Next::Message(r));
            }
            if let Some((v, h)) = self.mismatch {
                return Err(HostError::incompatible(self.link.name(), v, h));
            }
            if self.ended {
                return Ok(Next::End);
            }
            if deadline.is_some_and(|d| Instant::now() >= d) {
                return Ok(Next::Timeout);
            }
            self.request_clock_if_due()?;
            self.request_maps_if_due()?;
            self.fill()?;
        }
    }

    /// Reads once from the link and decodes what arrived.
    fn fill(&mut self) -> Result<(), HostError> {
        let mut buf = [0u8; 4096];
        let n = match self.link.read(&mut buf) {
            Ok(0) => {
                self.ended = true;
                self.decoder.finish();
                return Ok(());
            }
            Ok(n) => n,
            Err(HostError::Io { cause, .. })
                if matches!(
                    cause.kind(),
                    io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                ) =>
            {
                return Ok(());
            }
            Err(e) => return Err(e),
        };
        let (at, now) = (SystemTime::now(), Instant::now());
        let mut decoded = Vec::new();
        let mismatch = &mut self.mismatch;
        // Nothing after a mismatching Hello is trusted: what follows it in the same read is
        // dropped, so the messages handed out are exactly those before it.
        self.decoder.push(&buf[..n], |r| match r {
            Ok(_) if mismatch.is_some() => {}
            Ok(msg) => decoded.push(msg),
            Err(FrameError::ProtocolMismatch {
                protocol_version,
                schema_hash,
            }) => {
                mismatch.get_or_insert((protocol_version, schema_hash));
            }
            Err(_) => {}
        });
        for msg in decoded {
            if let DeviceMsg::Clock(reading) = &msg {
                self.clock_answered(reading, now);
                continue;
            }
            let captured = match &msg {
                DeviceMsg::Summary(s) => self.clock_map().map(|m| m.host_time(s.capture_us)),
                _ => None,
            };
            self.queue.push_back(Received { msg, at, captured });
        }
        Ok(())
    }

    /// Sends one command.
    pub fn send(&mut self, msg: &HostMsg) -> Result<(), HostError> {
        let mut buf = [0u8; HOST_FRAME_MAX];
        let n = encode(msg, &mut buf).map_err(|e| HostError::Io {
            link: self.link.name().to_string(),
            cause: io::Error::other(e),
        })?;
        self.link.send(&buf[..n])
    }

    /// Waits for the first message `pick` accepts; other messages stay queued, in order,
    /// for [`Client::next`]. A device error ends the wait, unless it is a report of the
    /// device's state rather than an answer (see `is_report`).
    fn wait_for<T>(
        &mut self,
        waiting_for: &'static str,
        timeout: Duration,
        pick: impl FnMut(&DeviceMsg) -> Option<T>,
    ) -> Result<T, HostError> {
        self.wait_keeping(waiting_for, timeout, true, pick)
    }

    /// [`Client::wait_for`]; with `keep` off, the messages before the one picked are
    /// discarded (and counted) instead of queued: a calibration session's waits are long,
    /// and the summaries meanwhile are not what it reads.
    fn wait_keeping<T>(
        &mut self,
        waiting_for: &'static str,
        timeout: Duration,
        keep: bool,
        mut pick: impl FnMut(&DeviceMsg) -> Option<T>,
    ) -> Result<T, HostError> {
        let deadline = Instant::now() + timeout;
        let mut held = VecDeque::new();
        let result = loop {
            match self.next(Some(deadline)) {
                Ok(Next::Message(r)) => {
                    if let Some(v) = pick(&r.msg) {
                        break Ok(v);
                    }
                    if let DeviceMsg::Error(error) = &r.msg {
                        if !error.code.is_report() {
                            break Err(HostError::Device {
                                link: self.name().to_string(),
                                error: error.clone(),
                            });
                        }
                    }
                    held.push_back(r);
                }
                Ok(Next::Timeout) => {
                    break Err(HostError::Timeout {
                        link: self.name().to_string(),
                        waiting_for,
                        timeout,
                    })
                }
                Ok(Next::End) => {
                    break Err(HostError::Closed {
                        link: self.name().to_string(),
                        waiting_for,
                    })
                }
                Err(e) => break Err(e),
            }
        };
        if keep || result.is_err() {
            held.append(&mut self.queue);
            self.queue = held;
        } else {
            self.discarded_messages += held.len() as u64;
        }
        result
    }

    /// Asks for the device's `Hello` and checks that it speaks this protocol. Whatever the
    /// device sent before its answer (a backlog from before the host was listening) is
    /// discarded and counted ([`Client::discarded`]); the answer itself is the first message
    /// [`Client::next`] hands out.
    pub fn handshake(&mut self, timeout: Duration) -> Result<Hello, HostError> {
        self.send(&HostMsg::GetInfo)?;
        let hello = self.wait_keeping("Hello", timeout, false, |m| match m {
            DeviceMsg::Hello(h) => Some(h.clone()),
            _ => None,
        })?;
        if !schema::is_compatible(hello.protocol_version, hello.schema_hash) {
            return Err(HostError::incompatible(
                self.name(),
                hello.protocol_version,
                hello.schema_hash,
            ));
        }
        // The answer stays in the stream, first, so whoever reads on knows whose it is.
        self.queue.push_front(Received::new(
            DeviceMsg::Hello(hello.clone()),
            SystemTime::now(),
        ));
        Ok(hello)
    }

    /// Round-trip time of a ping.
    pub fn ping(&mut self, nonce: u32, timeout: Duration) -> Result<Duration, HostError> {
        let sent = Instant::now();
        self.send(&HostMsg::Ping { nonce })?;
        self.wait_for("Pong", timeout, |m| {
            matches!(m, DeviceMsg::Pong { nonce: n } if *n == nonce).then_some(())
        })?;
        Ok(sent.elapsed())
    }

    fn command(&mut self, msg: HostMsg, cmd: Command, timeout: Duration) -> Result<(), HostError> {
        self.send(&msg)?;
        self.wait_for("Ack", timeout, |m| {
            matches!(m, DeviceMsg::Ack(c) if *c == cmd).then_some(())
        })
    }

    /// Asks the device to take a new no-contact reference.
    pub fn capture_reference(&mut self, timeout: Duration) -> Result<(), HostError> {
        self.command(
            HostMsg::CaptureReference,
            Command::CaptureReference,
            timeout,
        )
    }

    /// Limits the summary rate (0 = every frame).
    pub fn set_rate(&mut self, max_rate_hz: u16, timeout: Duration) -> Result<(), HostError> {
        self.command(HostMsg::SetRate { max_rate_hz }, Command::SetRate, timeout)
    }

    /// Sets the LED ring.
    pub fn set_led(&mut self, led: SetLed, timeout: Duration) -> Result<(), HostError> {
        self.command(HostMsg::SetLed(led), Command::SetLed, timeout)
    }

    /// Resumes streaming.
    pub fn start(&mut self, timeout: Duration) -> Result<(), HostError> {
        self.command(HostMsg::Start, Command::Start, timeout)
    }

    /// Pauses streaming.
    pub fn stop(&mut self, timeout: Duration) -> Result<(), HostError> {
        self.command(HostMsg::Stop, Command::Stop, timeout)
    }

    /// Asks the device to capture one labelled calibration kit frame once the image has
    /// settled, and waits for it (up to `timeout`, which must allow for the settling).
    pub fn kit_capture(
        &mut self,
        step: KitStep,
        timeout: Duration,
    ) -> Result<KitCaptured, HostError> {
        self.send(&HostMsg::KitCapture(step))?;
        self.wait_keeping("KitCaptured", timeout, false, answer::captured(step))
    }

    /// Asks the device to fit a calibration to its kit, and waits for the verdicts and
    /// the fitted candidate (up to `timeout`: a fit takes seconds to minutes).
    pub fn kit_fit(
        &mut self,
        timeout: Duration,
    ) -> Result<(Vec<KitVerdict>, CalibrationFitted), HostError> {
        self.send(&HostMsg::KitFit)?;
        let mut verdicts = Vec::new();
        let fitted = self.wait_keeping(
            "CalibrationFitted",
            timeout,
            false,
            answer::fitted(&mut verdicts),
        )?;
        Ok((verdicts, fitted))
    }

    /// Puts the fitted calibration `calibration_id` in use on the device; its `Hello`
    /// after the change.
    pub fn activate_calibration(
        &mut self,
        calibration_id: u32,
        timeout: Duration,
    ) -> Result<Hello, HostError> {
        self.send(&HostMsg::CalibrationActivate { calibration_id })?;
        self.wait_keeping("Hello", timeout, false, answer::activated(calibration_id))
    }

    /// Puts the calibration the last activation replaced back in use; the device's
    /// `Hello` after the change.
    pub fn roll_back_calibration(&mut self, timeout: Duration) -> Result<Hello, HostError> {
        // The answer is a Hello: one already queued (the handshake's) is not it.
        self.queue.retain(|r| !matches!(r.msg, DeviceMsg::Hello(_)));
        self.send(&HostMsg::CalibrationRollback)?;
        self.wait_keeping("Hello", timeout, false, |m| match m {
            DeviceMsg::Hello(h) => Some(h.clone()),
            _ => None,
        })
    }

    /// Requests one map and waits for it.
    pub fn request_map(&mut self, kind: MapKind, timeout: Duration) -> Result<Map, HostError> {
        self.send(&HostMsg::RequestMap(kind))?;
        self.wait_for("Map", timeout, |m| match m {
            DeviceMsg::Map(map) if map.kind == kind => Some(map.clone()),
            _ => None,
        })
    }

    /// Requests the next processed frame's maps of `kinds` at the working resolution and
    /// waits until each has come whole; with them, that frame's summary when the device
    /// sent one (it is streaming). Other messages stay queued for [`Client::next`]; the
    /// pieces of these maps do not.
    pub fn request_full_maps(
        &mut self,
        kinds: &[MapKind],
        timeout: Duration,
    ) -> Result<Snapshot, HostError> {
        for &kind in kinds {
            self.send(&HostMsg::RequestFullMap(kind))?;
        }
        let mut collector = Collector::new(kinds);
        let shot = self.wait_for("full map", timeout, |m| collector.take(m))?;
        self.queue
            .retain(|r| !matches!(&r.msg, DeviceMsg::MapChunk(c) if kinds.contains(&c.kind)));
        Ok(shot)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::{Arc, Mutex};
    use vistaf_protocol::{ErrorCode, HostDecoder};

    /// A link that never has bytes to read.
    struct Quiet;

    impl io::Read for Quiet {
        fn read(&mut self, _: &mut [u8]) -> io::Result<usize> {
            Err(io::ErrorKind::WouldBlock.into())
        }
    }

    /// What was written, shared with the test.
    #[derive(Clone, Default)]
    struct Sent(Arc<Mutex<Vec<u8>>>);

    impl io::Write for Sent {
        fn write(&mut self, b: &[u8]) -> io::Result<usize> {
            self.0
                .lock()
                .map_err(|_| io::Error::other("poisoned"))?
                .extend(b);
            Ok(b.len())
        }
        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn maps_kept_are_asked_for_once_a_period() {
        let sent = Sent::default();
        let mut c = Client::new(Link::new("test".into(), Quiet, sent.clone()));
        c.keep_maps(
            &[MapKind::Depth, MapKind::Temperature],
            Duration::from_secs(60),
        );
        let deadline = Instant::now() + Duration::from_millis(20);
        assert_eq!(c.next(Some(deadline)).unwrap(), Next::Timeout);
        let bytes = sent.0.lock().unwrap().clone();
        let mut got = Vec::new();
        HostDecoder::new().push(&bytes, |m| got.push(m.unwrap()));
        assert_eq!(
            got,
            [
                HostMsg::RequestMap(MapKind::Depth),
                HostMsg::RequestMap(MapKind::Temperature)
            ],
            "asked once within the period, nothing else sent"
        );
    }

    fn framed(msgs: &[DeviceMsg]) -> Vec<u8> {
        let mut out = Vec::new();
        for m in msgs {
            let mut buf = [0u8; vistaf_protocol::frame::DEVICE_FRAME_MAX];
            let n = encode(m, &mut buf).unwrap();
            out.extend(&buf[..n]);
        }
        out
    }

    fn device_error(code: ErrorCode, detail: &str) -> DeviceMsg {
        DeviceMsg::Error(vistaf_protocol::DeviceError {
            code,
            detail: vistaf_protocol::msg::truncated(detail),
        })
    }

    /// A device retrying a reference its calibration cannot take reports an error every
    /// second: a command's wait goes through those to its answer (and keeps them in the
    /// stream), but an error that answers the command ends it.
    #[test]
    fn a_wait_goes_through_state_reports_and_ends_on_an_answer_error() {
        let stream = framed(&[
            device_error(ErrorCode::Reference, "calibration was made for 640×480"),
            device_error(ErrorCode::CameraLost, "/dev/video0 gone"),
            DeviceMsg::Ack(Command::SetRate),
        ]);
        let mut c = Client::new(Link::new(
            "test".into(),
            io::Cursor::new(stream),
            Sent::default(),
        ));
        c.set_rate(10, Duration::from_secs(1)).unwrap();
        let kept: Vec<_> = std::iter::from_fn(|| match c.next(None).unwrap() {
            Next::Message(r) => Some(r.msg),
            _ => None,
        })
        .collect();
        assert_eq!(kept.len(), 2, "the reports stay in the stream: {kept:?}");

        let stream = framed(&[
            device_error(ErrorCode::Reference, "no grating in view"),
            device_error(
                ErrorCode::Calibration,
                "no earlier calibration to roll back to",
            ),
        ]);
        let mut c = Client::new(Link::new(
            "test".into(),
            io::Cursor::new(stream),
            Sent::default(),
        ));
        let e = c.roll_back_calibration(Duration::from_secs(1)).unwrap_err();
        assert!(e.to_string().contains("no earlier calibration"), "{e}");
    }
}
