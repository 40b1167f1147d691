//! End to end over real pseudo-terminals: two writer threads stream thousands of framed
//! summaries with injected garbage and corruption at full speed; the multi-skin reader
//! opens each slave by path, exactly as it opens a USB serial port, and must decode every
//! intact summary in order with exact drop and sequence-gap accounting.
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

mod common;

use std::io::Write;
use std::time::{Duration, Instant};

use serialport::{SerialPort, TTYPort};
use vistaf_host::client::Client;
use vistaf_host::link::{Link, LinkSpec};
use vistaf_host::multi::{Event, MultiReader};
use vistaf_protocol::DeviceMsg;

const COUNT: u32 = 5_000;

#[test]
fn two_skins_over_ptys_with_garbage() {
    let streams = [
        common::noisy_stream(COUNT, 0xabcdef),
        common::noisy_stream(COUNT, 0x123456),
    ];
    let mut clients = Vec::new();
    let mut writers = Vec::new();
    for s in &streams {
        let (mut master, slave) = TTYPort::pair().expect("pseudo-terminal pair");
        let path = slave.name().expect("slave has a name");
        let spec: LinkSpec = format!("serial:{path}@921600").parse().unwrap();
        clients.push(Client::new(Link::open(&spec).unwrap()));
        let bytes = s.bytes.clone();
        writers.push(std::thread::spawn(move || {
            // Odd-sized writes at full speed; the pty applies back-pressure.
            for chunk in bytes.chunks(997) {
                master.write_all(chunk).unwrap();
            }
            master.flush().unwrap();
            // Keep both ends open until the reader has drained everything.
            std::thread::sleep(Duration::from_millis(1500));
            drop(slave);
        }));
    }

    let mut reader = MultiReader::spawn(clients);
    let mut got: [Vec<u32>; 2] = [Vec::new(), Vec::new()];
    let deadline = Instant::now() + Duration::from_secs(60);
    while got
        .iter()
        .zip(&streams)
        .any(|(g, s)| g.len() < s.intact.len())
    {
        assert!(
            Instant::now() < deadline,
            "timed out: got {} and {}",
            got[0].len(),
            got[1].len()
        );
        match reader.recv(Duration::from_millis(200)) {
            Some(Event::Message { device, received }) => {
                if let DeviceMsg::Summary(s) = received.msg {
                    assert_eq!(s, common::summary(s.seq), "decoded values differ from sent");
                    got[device].push(s.seq);
                }
            }
            Some(Event::Failed { error, .. }) => panic!("link failed: {error}"),
            Some(Event::Lost { why, .. }) => panic!("link lost: {why}"),
            Some(Event::Ended { .. } | Event::Reconnected { .. }) | None => {}
        }
    }
    for (i, s) in streams.iter().enumerate() {
        assert_eq!(got[i], s.intact, "device {i}: intact summaries, in order");
        let st = &reader.stats()[i];
        assert_eq!(
            st.seq.missing, s.damaged,
            "device {i}: sequence gaps = corrupted frames"
        );
        assert_eq!(st.seq.out_of_order, 0);
        assert_eq!(
            st.drops.total(),
            s.expected_drops,
            "device {i}: dropped fragments"
        );
        assert!(st.drops.crc > 0 && st.drops.total() > s.damaged);
    }
    for w in writers {
        w.join().unwrap();
    }
}

#[test]
fn a_silent_port_times_out_with_a_clear_error() {
    let (_master, slave) = TTYPort::pair().unwrap();
    let path = slave.name().unwrap();
    let mut c = Client::new(Link::open(&format!("serial:{path}").parse().unwrap()).unwrap());
    let err = c
        .handshake(Duration::from_millis(300))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("no Hello within") && err.contains(&path),
        "{err}"
    );
}
