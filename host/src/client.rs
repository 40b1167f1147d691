//! One skin on one link: decode what it sends, with receive times; send commands and wait
//! for their answers. Every wait has a timeout.

use std::collections::VecDeque;
use std::io;
use std::time::{Duration, Instant, SystemTime};

use vistaf_protocol::frame::HOST_FRAME_MAX;
use vistaf_protocol::{
    encode, schema, Command, DeviceDecoder, DeviceMsg, DropCounts, FrameError, Hello, HostMsg, Map,
    MapKind, SetLed,
};

use crate::error::HostError;
use crate::link::Link;

/// Default wait for a command's answer.
pub const DEFAULT_TIMEOUT: Duration = Duration::from_secs(2);

/// A decoded message and when it was received.
#[derive(Debug, Clone, PartialEq)]
pub struct Received {
    /// The message.
    pub msg: DeviceMsg,
    /// Wall-clock receive time (when its last byte was read).
    pub at: SystemTime,
}

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
        let at = SystemTime::now();
        let (queue, mismatch) = (&mut self.queue, &mut self.mismatch);
        // Nothing after a mismatching Hello is trusted: what follows it in the same read is
        // dropped, so the messages handed out are exactly those before it.
        self.decoder.push(&buf[..n], |r| match r {
            Ok(_) if mismatch.is_some() => {}
            Ok(msg) => queue.push_back(Received { msg, at }),
            Err(FrameError::ProtocolMismatch {
                protocol_version,
                schema_hash,
            }) => {
                mismatch.get_or_insert((protocol_version, schema_hash));
            }
            Err(_) => {}
        });
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
    /// for [`Client::next`]. A device error ends the wait.
    fn wait_for<T>(
        &mut self,
        waiting_for: &'static str,
        timeout: Duration,
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
                        break Err(HostError::Device {
                            link: self.name().to_string(),
                            error: error.clone(),
                        });
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
        held.append(&mut self.queue);
        self.queue = held;
        result
    }

    /// Asks for the device's `Hello` and checks that it speaks this protocol.
    pub fn handshake(&mut self, timeout: Duration) -> Result<Hello, HostError> {
        self.send(&HostMsg::GetInfo)?;
        let hello = self.wait_for("Hello", timeout, |m| match m {
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

    /// Requests one map and waits for it.
    pub fn request_map(&mut self, kind: MapKind, timeout: Duration) -> Result<Map, HostError> {
        self.send(&HostMsg::RequestMap(kind))?;
        self.wait_for("Map", timeout, |m| match m {
            DeviceMsg::Map(map) if map.kind == kind => Some(map.clone()),
            _ => None,
        })
    }
}
