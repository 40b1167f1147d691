//! Where the bytes come from and go to: a serial port, a captured file, or stdin.
//!
//! A link is named by a [`LinkSpec`], the grammar the device's CLI shares:
//!
//! | spec | meaning on the host |
//! |---|---|
//! | `/dev/ttyACM0`, `serial:/dev/ttyGS0@921600` | serial port (default 921 600 baud) |
//! | `file:capture.bin`, `capture.bin` (an existing regular file) | a captured byte stream, read-only |
//! | `-` | standard input, read-only |
//! | `tcp:HOST:PORT` | a running bridge's re-served stream of one skin, read-only |

use std::fmt;
use std::io::{self, Read, Write};
use std::time::Duration;

use crate::error::HostError;

pub use vistaf_session::port::port_list;
use vistaf_session::port::{drain, with_ports_named};

pub use vistaf_protocol::link::{LinkSpec, LinkSpecError, DEFAULT_BAUD};

/// How long one read waits for bytes before the caller gets control back.
pub const READ_POLL: Duration = Duration::from_millis(50);

/// An open link: a byte reader, an optional writer, and a name for messages.
pub struct Link {
    name: String,
    reader: Box<dyn Read + Send>,
    writer: Option<Box<dyn Write + Send>>,
    discarded_bytes: u64,
}

impl fmt::Debug for Link {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Link")
            .field("name", &self.name)
            .finish_non_exhaustive()
    }
}

impl Link {
    /// Opens the link a spec names.
    pub fn open(spec: &LinkSpec) -> Result<Link, HostError> {
        let name = match spec {
            LinkSpec::Stdio => "stdin".to_string(),
            other => other.to_string(),
        };
        match spec {
            LinkSpec::Serial { path, baud } => {
                let port = serialport::new(path, *baud)
                    .timeout(READ_POLL)
                    .open_native()
                    .map_err(|e| HostError::Open {
                        link: name.clone(),
                        cause: with_ports_named(e.into()),
                    })?;
                Link::from_serial(name, port)
            }
            LinkSpec::File(path) => {
                let file = std::fs::File::open(path).map_err(|e| HostError::Open {
                    link: name.clone(),
                    cause: e,
                })?;
                Ok(Link::read_only(name, file))
            }
            LinkSpec::Stdio => Ok(Link::read_only(name, io::stdin())),
            LinkSpec::Tcp(addr) => {
                let open_error = |cause: io::Error| HostError::Open {
                    link: name.clone(),
                    cause,
                };
                let stream = std::net::TcpStream::connect(addr).map_err(open_error)?;
                stream
                    .set_read_timeout(Some(READ_POLL))
                    .map_err(open_error)?;
                Ok(Link::read_only(name, stream))
            }
        }
    }

    /// Wraps an open serial port (for example one end of a pseudo-terminal pair).
    ///
    /// What waits in the port's input buffer was sent before anyone listened (a device
    /// that streamed while the port was closed): it is thrown away, and counted
    /// ([`Link::discarded_bytes`]), so the first summaries read are fresh ones.
    pub fn from_serial(name: String, mut port: serialport::TTYPort) -> Result<Link, HostError> {
        let open_error = |e: serialport::Error| HostError::Open {
            link: name.clone(),
            cause: e.into(),
        };
        let discarded_bytes = drain(&mut port).map_err(open_error)?;
        let writer = port.try_clone_native().map_err(open_error)?;
        Ok(Link {
            name,
            reader: Box::new(TimeoutIsEmpty(port)),
            writer: Some(Box::new(writer)),
            discarded_bytes,
        })
    }

    /// A link that can only be read (a file, stdin, a pipe).
    pub fn read_only(name: String, reader: impl Read + Send + 'static) -> Link {
        Link {
            name,
            reader: Box::new(reader),
            writer: None,
            discarded_bytes: 0,
        }
    }

    /// A link over any reader and writer (in-process tests, sockets).
    pub fn new(
        name: String,
        reader: impl Read + Send + 'static,
        writer: impl Write + Send + 'static,
    ) -> Link {
        Link {
            name,
            reader: Box::new(reader),
            writer: Some(Box::new(writer)),
            discarded_bytes: 0,
        }
    }

    /// The link's name, as used in messages.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Whether commands can be sent (a serial port; not a file or stdin).
    pub fn is_writable(&self) -> bool {
        self.writer.is_some()
    }

    /// Bytes thrown away on opening, sent before anyone listened.
    pub fn discarded_bytes(&self) -> u64 {
        self.discarded_bytes
    }

    /// Reads some bytes. `Ok(0)` means end of stream, including the other end going away
    /// (a closed pseudo-terminal or a pulled USB cable reads as EIO or a broken pipe); a
    /// poll timeout is reported as [`io::ErrorKind::WouldBlock`].
    pub fn read(&mut self, buf: &mut [u8]) -> Result<usize, HostError> {
        const EIO: i32 = 5;
        loop {
            match self.reader.read(buf) {
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e)
                    if e.kind() == io::ErrorKind::BrokenPipe || e.raw_os_error() == Some(EIO) =>
                {
                    return Ok(0)
                }
                Err(e) => {
                    return Err(HostError::Io {
                        link: self.name.clone(),
                        cause: e,
                    })
                }
                Ok(n) => return Ok(n),
            }
        }
    }

    /// Writes one whole frame.
    pub fn send(&mut self, frame: &[u8]) -> Result<(), HostError> {
        let writer = self.writer.as_mut().ok_or_else(|| HostError::ReadOnly {
            link: self.name.clone(),
        })?;
        writer
            .write_all(frame)
            .and_then(|()| writer.flush())
            .map_err(|e| HostError::Io {
                link: self.name.clone(),
                cause: e,
            })
    }
}

/// Serial reads time out every [`READ_POLL`]; that is "no bytes yet", not an error.
struct TimeoutIsEmpty<R>(R);

impl<R: Read> Read for TimeoutIsEmpty<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        match self.0.read(buf) {
            Err(e) if e.kind() == io::ErrorKind::TimedOut => Err(io::Error::new(
                io::ErrorKind::WouldBlock,
                "no bytes within the poll time",
            )),
            other => other,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn missing_port_is_a_clear_error() {
        let spec: LinkSpec = "serial:/dev/does-not-exist-vistaf".parse().unwrap();
        let err = Link::open(&spec).unwrap_err().to_string();
        assert!(err.contains("/dev/does-not-exist-vistaf"), "{err}");
    }
}
