//! Where the bytes come from and go to: a serial port, a captured file, or stdin.
//!
//! A link is named by a short spec string, the same in the CLI and the library:
//!
//! | spec | meaning |
//! |---|---|
//! | `/dev/ttyACM0`, `serial:/dev/ttyGS0@921600` | serial port (default 921 600 baud) |
//! | `file:capture.bin`, `capture.bin` (an existing regular file) | a captured byte stream, read-only |
//! | `-` | standard input, read-only |

use std::fmt;
use std::io::{self, Read, Write};
use std::path::PathBuf;
use std::time::Duration;

use crate::error::HostError;

/// Default baud rate of the skin's serial port.
pub const DEFAULT_BAUD: u32 = 921_600;

/// How long one read waits for bytes before the caller gets control back.
pub const READ_POLL: Duration = Duration::from_millis(50);

/// A parsed link spec.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LinkSpec {
    /// A serial port at a baud rate.
    Serial {
        /// Device path, e.g. `/dev/ttyACM0`.
        path: String,
        /// Baud rate.
        baud: u32,
    },
    /// A captured byte stream.
    File(PathBuf),
    /// Standard input.
    Stdin,
}

impl fmt::Display for LinkSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LinkSpec::Serial { path, baud } => write!(f, "serial:{path}@{baud}"),
            LinkSpec::File(p) => write!(f, "file:{}", p.display()),
            LinkSpec::Stdin => f.write_str("stdin"),
        }
    }
}

impl std::str::FromStr for LinkSpec {
    type Err = HostError;

    fn from_str(s: &str) -> Result<Self, HostError> {
        let bad = |why: &str| HostError::BadLinkSpec {
            spec: s.to_string(),
            why: why.to_string(),
        };
        if s == "-" {
            return Ok(LinkSpec::Stdin);
        }
        if let Some(path) = s.strip_prefix("file:") {
            if path.is_empty() {
                return Err(bad("missing file path after 'file:'"));
            }
            return Ok(LinkSpec::File(PathBuf::from(path)));
        }
        let serial = s.strip_prefix("serial:");
        let body = serial.unwrap_or(s);
        if body.is_empty() {
            return Err(bad("empty port name"));
        }
        let (path, baud) = match body.rsplit_once('@') {
            Some((p, b)) => {
                let baud = b
                    .parse::<u32>()
                    .map_err(|_| bad("baud rate after '@' is not a number"))?;
                if baud == 0 {
                    return Err(bad("baud rate must be positive"));
                }
                (p, baud)
            }
            None => (body, DEFAULT_BAUD),
        };
        if serial.is_none() && std::path::Path::new(path).is_file() {
            return Ok(LinkSpec::File(PathBuf::from(path)));
        }
        Ok(LinkSpec::Serial {
            path: path.to_string(),
            baud,
        })
    }
}

/// An open link: a byte reader, an optional writer, and a name for messages.
pub struct Link {
    name: String,
    reader: Box<dyn Read + Send>,
    writer: Option<Box<dyn Write + Send>>,
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
        let name = spec.to_string();
        match spec {
            LinkSpec::Serial { path, baud } => {
                let port = serialport::new(path, *baud)
                    .timeout(READ_POLL)
                    .open_native()
                    .map_err(|e| HostError::Open {
                        link: name.clone(),
                        source: e.into(),
                    })?;
                Link::from_serial(name, port)
            }
            LinkSpec::File(path) => {
                let file = std::fs::File::open(path).map_err(|e| HostError::Open {
                    link: name.clone(),
                    source: e,
                })?;
                Ok(Link::read_only(name, file))
            }
            LinkSpec::Stdin => Ok(Link::read_only(name, io::stdin())),
        }
    }

    /// Wraps an open serial port (for example one end of a pseudo-terminal pair).
    pub fn from_serial(name: String, port: serialport::TTYPort) -> Result<Link, HostError> {
        let writer = port.try_clone_native().map_err(|e| HostError::Open {
            link: name.clone(),
            source: e.into(),
        })?;
        Ok(Link {
            name,
            reader: Box::new(TimeoutIsEmpty(port)),
            writer: Some(Box::new(writer)),
        })
    }

    /// A link that can only be read (a file, stdin, a pipe).
    pub fn read_only(name: String, reader: impl Read + Send + 'static) -> Link {
        Link {
            name,
            reader: Box::new(reader),
            writer: None,
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
        }
    }

    /// The link's name, as used in messages.
    pub fn name(&self) -> &str {
        &self.name
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
                        source: e,
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
                source: e,
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
    fn specs_parse() {
        assert_eq!("-".parse::<LinkSpec>().unwrap(), LinkSpec::Stdin);
        assert_eq!(
            "/dev/ttyACM0".parse::<LinkSpec>().unwrap(),
            LinkSpec::Serial {
                path: "/dev/ttyACM0".into(),
                baud: DEFAULT_BAUD
            }
        );
        assert_eq!(
            "serial:/dev/ttyGS0@115200".parse::<LinkSpec>().unwrap(),
            LinkSpec::Serial {
                path: "/dev/ttyGS0".into(),
                baud: 115_200
            }
        );
        assert_eq!(
            "file:cap.bin".parse::<LinkSpec>().unwrap(),
            LinkSpec::File(PathBuf::from("cap.bin"))
        );
    }

    #[test]
    fn bad_specs_name_the_problem() {
        for (spec, why) in [
            ("serial:/dev/ttyS0@fast", "not a number"),
            ("serial:/dev/ttyS0@0", "positive"),
            ("file:", "missing file path"),
            ("serial:", "empty"),
        ] {
            let err = spec.parse::<LinkSpec>().unwrap_err().to_string();
            assert!(err.contains(spec) && err.contains(why), "{spec}: {err}");
        }
    }

    #[test]
    fn missing_port_is_a_clear_error() {
        let spec: LinkSpec = "serial:/dev/does-not-exist-vistaf".parse().unwrap();
        let err = Link::open(&spec).unwrap_err().to_string();
        assert!(err.contains("/dev/does-not-exist-vistaf"), "{err}");
    }
}
