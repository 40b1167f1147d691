//! Time a robot can trust, over a real pseudo-terminal: a skin that streamed before the
//! host listened leaves nothing stale behind, and summaries come stamped with their capture
//! time on the host's clock, within the stated uncertainty.
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

mod common;

use std::io::{Read, Write};
use std::time::{Duration, Instant, SystemTime};

use serialport::{SerialPort, TTYPort};
use vistaf_host::client::{Client, Next};
use vistaf_host::clock::unix_s;
use vistaf_host::link::{Link, LinkSpec};
use vistaf_protocol::*;

/// A device clock 200 ppm fast, its epoch an hour before the test.
fn device_us(base: Instant, at: Instant) -> u64 {
    let s = 3600.0 + at.duration_since(base).as_secs_f64() * (1.0 + 200e-6);
    (s * 1e6) as u64
}

/// Answers the host until it hangs up: a backlog of three summaries and then `Hello` to
/// `GetInfo`; to each clock request its reading and then a summary captured at once.
fn device(mut master: TTYPort, base: Instant) {
    let mut dec = HostDecoder::new();
    let mut buf = [0u8; 256];
    let mut seq = 1000;
    master.set_timeout(Duration::from_millis(50)).unwrap();
    let deadline = Instant::now() + Duration::from_secs(30);
    while Instant::now() < deadline {
        let n = match master.read(&mut buf) {
            Ok(0) => return,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::TimedOut => continue,
            Err(_) => return,
        };
        let received = Instant::now();
        let mut out = Vec::new();
        dec.push(&buf[..n], |m| match m {
            Ok(HostMsg::GetInfo) => {
                for s in 0..3 {
                    out.push(DeviceMsg::Summary(common::summary(s)));
                }
                out.push(common::hello("VSK-CLOCK", 1));
            }
            Ok(HostMsg::Clock { nonce }) => {
                out.push(DeviceMsg::Clock(ClockReading {
                    nonce,
                    received_us: device_us(base, received),
                    sent_us: device_us(base, Instant::now()),
                }));
                seq += 1;
                out.push(DeviceMsg::Summary(Summary {
                    seq,
                    capture_us: device_us(base, Instant::now()),
                    ..Default::default()
                }));
            }
            _ => {}
        });
        for m in out {
            if master.write_all(&common::frame(&m)).is_err() {
                return;
            }
        }
    }
}

#[test]
fn a_backlog_is_discarded_and_summaries_carry_host_capture_times() {
    let (mut master, slave) = TTYPort::pair().unwrap();
    let path = slave.name().unwrap();
    // What the skin sent while nobody listened.
    let mut backlog = Vec::new();
    for s in 0..40 {
        backlog.extend(common::frame(&DeviceMsg::Summary(common::summary(s))));
    }
    master.write_all(&backlog).unwrap();
    master.flush().unwrap();

    let spec: LinkSpec = format!("serial:{path}").parse().unwrap();
    let mut client = Client::new(Link::open(&spec).unwrap());
    assert_eq!(client.discarded().bytes, backlog.len() as u64);

    let base = Instant::now();
    let dev = std::thread::spawn(move || device(master, base));
    let hello = client.handshake(Duration::from_secs(5)).unwrap();
    assert_eq!(hello.serial.as_str(), "VSK-CLOCK");
    assert_eq!(
        client.discarded().messages,
        3,
        "the summaries before the Hello"
    );

    let map = client.sync_clock(12, Duration::from_secs(10)).unwrap();
    assert!(map.uncertainty_s < 0.05, "{map:?}");
    // Every summary after the first exchange is stamped; its capture time is just before
    // it was received, within the uncertainty.
    let mut stamped = 0;
    while let Next::Message(r) = client.next(Some(Instant::now())).unwrap() {
        let DeviceMsg::Summary(s) = r.msg else {
            continue;
        };
        assert!(s.seq > 1000, "a stale summary got through: {s:?}");
        let Some(c) = r.captured else {
            assert_eq!(
                s.seq, 1001,
                "only the first summary precedes every exchange"
            );
            continue;
        };
        let received = unix_s(r.at);
        assert!(
            c.host_s <= received + c.uncertainty_s && received - c.host_s < 0.05 + c.uncertainty_s,
            "captured {} s, received {received} s, ± {} s",
            c.host_s,
            c.uncertainty_s
        );
        stamped += 1;
    }
    assert!(stamped >= 10, "{stamped} stamped summaries");
    assert!(unix_s(SystemTime::now()) - map.host_at_s < 60.0);
    drop(client);
    drop(slave);
    dev.join().unwrap();
}
