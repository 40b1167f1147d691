//! Link specs: how a user names the byte stream between a skin and its host, the same on
//! both sides (`std` feature).
//!
//! | spec | device (`vistaf-skin run --link`) | host (`vistaf-host …`) |
//! |---|---|---|
//! | `/dev/ttyACM0`, `serial:/dev/ttyGS0@921600` | serial port (default [`DEFAULT_BAUD`]) | serial port |
//! | `file:capture.bin`, or a path to an existing regular file | frames written to the file | a captured stream, read |
//! | `-` (the device also takes `stdout`) | frames on standard output | a stream on standard input |
//! | `tcp:HOST:PORT` | refused (the host's only) | a running bridge's re-served stream (`bridge --serve`) |
//!
//! Parsing checks the form only (and whether a bare path is an existing regular file);
//! opening is each side's business.

use std::fmt;
use std::path::PathBuf;
use std::string::{String, ToString};

/// Default baud rate of the skin's serial port.
pub const DEFAULT_BAUD: u32 = 921_600;

/// A parsed link spec.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LinkSpec {
    /// A serial port at a baud rate.
    Serial {
        /// Device path, e.g. `/dev/ttyACM0`.
        path: String,
        /// Baud rate, bits per second (positive).
        baud: u32,
    },
    /// A file: a captured stream on the host, the stream's destination on the device.
    File(PathBuf),
    /// Standard input (host) or standard output (device).
    Stdio,
    /// A TCP address, `HOST:PORT`: a running bridge serving a skin's stream (host only).
    Tcp(String),
}

/// Why a link spec was refused.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LinkSpecError {
    /// The spec as given.
    pub spec: String,
    /// What is wrong with it.
    pub why: &'static str,
}

impl fmt::Display for LinkSpecError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "bad link '{}': {} (expected /dev/ttyX, serial:PATH[@BAUD], file:PATH, tcp:HOST:PORT or -)",
            self.spec, self.why
        )
    }
}

impl std::error::Error for LinkSpecError {}

impl fmt::Display for LinkSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LinkSpec::Serial { path, baud } => write!(f, "serial:{path}@{baud}"),
            LinkSpec::File(p) => write!(f, "file:{}", p.display()),
            LinkSpec::Stdio => f.write_str("-"),
            LinkSpec::Tcp(addr) => write!(f, "tcp:{addr}"),
        }
    }
}

impl core::str::FromStr for LinkSpec {
    type Err = LinkSpecError;

    fn from_str(s: &str) -> Result<Self, LinkSpecError> {
        let bad = |why: &'static str| LinkSpecError {
            spec: s.to_string(),
            why,
        };
        if s == "-" || s == "stdout" {
            return Ok(LinkSpec::Stdio);
        }
        if let Some(path) = s.strip_prefix("file:") {
            if path.is_empty() {
                return Err(bad("missing file path after 'file:'"));
            }
            return Ok(LinkSpec::File(PathBuf::from(path)));
        }
        if let Some(addr) = s.strip_prefix("tcp:") {
            let port = addr.rsplit_once(':').map(|(h, p)| (h, p.parse::<u16>()));
            return match port {
                Some((host, Ok(_))) if !host.is_empty() => Ok(LinkSpec::Tcp(addr.to_string())),
                _ => Err(bad("expected tcp:HOST:PORT with a port from 0 to 65535")),
            };
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
        if path.is_empty() {
            return Err(bad("empty port name"));
        }
        // A regular file is never a serial port: a bare path to one names a capture.
        if serial.is_none() && std::path::Path::new(path).is_file() {
            return Ok(LinkSpec::File(PathBuf::from(path)));
        }
        Ok(LinkSpec::Serial {
            path: path.to_string(),
            baud,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specs_parse() {
        assert_eq!("-".parse::<LinkSpec>().unwrap(), LinkSpec::Stdio);
        assert_eq!("stdout".parse::<LinkSpec>().unwrap(), LinkSpec::Stdio);
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
        // An existing regular file, named bare, is a capture.
        let manifest = concat!(env!("CARGO_MANIFEST_DIR"), "/Cargo.toml");
        assert_eq!(
            manifest.parse::<LinkSpec>().unwrap(),
            LinkSpec::File(PathBuf::from(manifest))
        );
        assert_eq!(
            "tcp:127.0.0.1:7000".parse::<LinkSpec>().unwrap(),
            LinkSpec::Tcp("127.0.0.1:7000".into())
        );
        for s in [
            "-",
            "serial:/dev/ttyGS0@115200",
            "file:cap.bin",
            "tcp:[::1]:7000",
        ] {
            let spec: LinkSpec = s.parse().unwrap();
            assert_eq!(spec.to_string().parse::<LinkSpec>().unwrap(), spec, "{s}");
        }
    }

    #[test]
    fn bad_specs_name_the_problem() {
        for (spec, why) in [
            ("serial:/dev/ttyS0@fast", "not a number"),
            ("serial:/dev/ttyS0@0", "positive"),
            ("serial:/dev/ttyS0@", "not a number"),
            ("serial:@9600", "empty port"),
            ("file:", "missing file path"),
            ("serial:", "empty"),
            ("tcp:localhost", "tcp:HOST:PORT"),
            ("tcp::7000", "tcp:HOST:PORT"),
            ("tcp:localhost:99999", "tcp:HOST:PORT"),
            ("", "empty"),
        ] {
            let err = spec.parse::<LinkSpec>().unwrap_err().to_string();
            assert!(err.contains(spec) && err.contains(why), "{spec}: {err}");
        }
    }
}
