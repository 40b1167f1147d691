//! The bridge's own stream, served again: each skin on a TCP port of its own, in the wire's
//! framing, so a monitor (or any reader of the stream) attaches to a running bridge with
//! `tcp:HOST:PORT` while the bridge keeps the serial port.
//!
//! Readers are written to without blocking: one that falls behind loses whole frames (the
//! decoder counts them as dropped), never the bridge's time; one that hangs up is dropped.
//! A reader that connects is first sent the skin's last `Hello`, so it knows whose stream it
//! reads.

use std::io::{self, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};

use vistaf_protocol::frame::DEVICE_FRAME_MAX;
use vistaf_protocol::{encode, DeviceMsg};

use crate::error::HostError;

/// One skin's listener and its readers.
#[derive(Debug)]
struct SkinServer {
    listener: TcpListener,
    readers: Vec<TcpStream>,
    hello: Option<Vec<u8>>,
}

/// Every skin's stream, each on its own port.
#[derive(Debug)]
pub struct Serve {
    skins: Vec<SkinServer>,
}

fn serve_error(addr: &str, cause: io::Error) -> HostError {
    HostError::Open {
        link: format!("tcp:{addr}"),
        cause,
    }
}

impl Serve {
    /// Listens for `devices` skins: on `host:port`, `host:port+1`, … (port 0: each on a port
    /// the system picks).
    pub fn bind(addr: &str, devices: usize) -> Result<Serve, HostError> {
        let base: SocketAddr = addr
            .parse()
            .map_err(|e| serve_error(addr, io::Error::new(io::ErrorKind::InvalidInput, e)))?;
        let mut skins = Vec::new();
        for i in 0..devices {
            let mut at = base;
            if base.port() != 0 {
                let port = u16::try_from(usize::from(base.port()) + i).map_err(|_| {
                    serve_error(
                        addr,
                        io::Error::other("port beyond 65535 for this many skins"),
                    )
                })?;
                at.set_port(port);
            }
            let listener = TcpListener::bind(at).map_err(|e| serve_error(&at.to_string(), e))?;
            listener
                .set_nonblocking(true)
                .map_err(|e| serve_error(&at.to_string(), e))?;
            skins.push(SkinServer {
                listener,
                readers: Vec::new(),
                hello: None,
            });
        }
        Ok(Serve { skins })
    }

    /// Where skin `device` is served.
    pub fn local_addr(&self, device: usize) -> Option<SocketAddr> {
        self.skins.get(device)?.listener.local_addr().ok()
    }

    /// Takes the readers that connected since the last call.
    pub fn accept(&mut self) {
        for skin in &mut self.skins {
            while let Ok((mut stream, _)) = skin.listener.accept() {
                let ready = stream.set_nonblocking(true).is_ok()
                    && skin
                        .hello
                        .as_ref()
                        .is_none_or(|h| stream.write_all(h).is_ok());
                if ready {
                    skin.readers.push(stream);
                }
            }
        }
    }

    /// Sends `msg` of skin `device` to its readers.
    pub fn send(&mut self, device: usize, msg: &DeviceMsg) {
        let Some(skin) = self.skins.get_mut(device) else {
            return;
        };
        let hello = matches!(msg, DeviceMsg::Hello(_));
        if skin.readers.is_empty() && !hello {
            return;
        }
        let mut buf = [0u8; DEVICE_FRAME_MAX];
        let Ok(n) = encode(msg, &mut buf) else {
            return;
        };
        let frame = &buf[..n];
        if hello {
            skin.hello = Some(frame.to_vec());
        }
        // A partial write leaves a cut frame, which the reader's decoder drops and counts
        // at the next delimiter; a reader that is gone is dropped.
        skin.readers.retain_mut(|r| match r.write(frame) {
            Ok(_) => true,
            Err(e) => e.kind() == io::ErrorKind::WouldBlock,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::client::{Client, Next};
    use crate::link::{Link, LinkSpec};
    use std::time::{Duration, Instant};
    use vistaf_protocol::Summary;

    #[test]
    fn a_reader_that_connects_gets_the_hello_then_the_stream() {
        let mut serve = Serve::bind("127.0.0.1:0", 1).unwrap();
        let addr = serve.local_addr(0).unwrap();
        let hello = DeviceMsg::Hello(vistaf_protocol::Hello {
            protocol_version: vistaf_protocol::PROTOCOL_VERSION,
            schema_hash: vistaf_protocol::schema_hash(),
            firmware: vistaf_protocol::FirmwareVersion {
                major: 0,
                minor: 1,
                patch: 0,
            },
            serial: heapless::String::from("VSK-TCP"),
            frame_width_px: 640,
            frame_height_px: 480,
            calibration_id: 0,
        });
        serve.send(0, &hello);
        // Before anyone listens: not kept (only the Hello is).
        serve.send(0, &DeviceMsg::Summary(Summary::default()));
        let spec: LinkSpec = format!("tcp:{addr}").parse().unwrap();
        let mut client = Client::new(Link::open(&spec).unwrap());
        let deadline = Instant::now() + Duration::from_secs(5);
        while serve.skins[0].readers.is_empty() && Instant::now() < deadline {
            serve.accept();
        }
        for seq in 1..=3 {
            serve.send(
                0,
                &DeviceMsg::Summary(Summary {
                    seq,
                    ..Default::default()
                }),
            );
        }
        let mut got = Vec::new();
        while got.len() < 4 {
            match client.next(Some(deadline)).unwrap() {
                Next::Message(r) => got.push(r.msg),
                other => panic!("{other:?} after {got:?}"),
            }
        }
        assert_eq!(got[0], hello);
        let seqs: Vec<u32> = got[1..]
            .iter()
            .map(|m| match m {
                DeviceMsg::Summary(s) => s.seq,
                other => panic!("{other:?}"),
            })
            .collect();
        assert_eq!(seqs, [1, 2, 3]);
    }
}
