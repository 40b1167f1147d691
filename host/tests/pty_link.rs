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

/// A monitor attaches to a running bridge: the bridge holds the skin's port and serves
/// its stream on TCP; `record tcp:…` reads the same summaries, the skin's Hello first.
#[test]
fn a_reader_attaches_to_a_running_bridge() {
    use std::io::{BufRead, BufReader};
    use std::process::{Command, Stdio};

    let (mut master, slave) = TTYPort::pair().unwrap();
    let path = slave.name().unwrap();
    let mut bridge = Command::new(env!("CARGO_BIN_EXE_vistaf-host"))
        .args(["bridge", &format!("serial:{path}"), "--no-handshake"])
        .args(["--serve", "127.0.0.1:0", "--duration-s", "20"])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = BufReader::new(bridge.stderr.take().unwrap()).lines();
    let served = err
        .by_ref()
        .map_while(Result::ok)
        .find_map(|l| l.split("served on ").nth(1).map(str::to_string))
        .expect("the bridge says where it serves");
    // The skin: its Hello, then a summary every 20 ms until the reader has enough.
    let device = std::thread::spawn(move || {
        master
            .write_all(&common::frame(&common::hello("VSK-ATTACH", 3)))
            .unwrap();
        for seq in 0..400 {
            let frame = common::frame(&DeviceMsg::Summary(common::summary(seq)));
            if master.write_all(&frame).is_err() {
                break;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    });
    let stdout = common::host_ok(&["record", &served, "--out", "-", "--summaries", "30"]);
    let lines: Vec<serde_json::Value> = stdout
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines[0]["type"], "hello");
    assert_eq!(lines[0]["body"]["serial"], "VSK-ATTACH");
    let seqs: Vec<u64> = lines
        .iter()
        .filter(|l| l["type"] == "summary")
        .map(|l| l["seq"].as_u64().unwrap())
        .collect();
    assert_eq!(seqs.len(), 30);
    assert!(seqs.windows(2).all(|w| w[1] == w[0] + 1), "{seqs:?}");
    let _ = bridge.kill();
    let _ = bridge.wait();
    drop(slave);
    device.join().unwrap();
}

/// A device on a pseudo-terminal that answers each command with `answer`'s messages until
/// the host hangs up.
fn device_answering(
    mut master: TTYPort,
    answer: impl Fn(vistaf_protocol::HostMsg) -> Vec<DeviceMsg> + Send + 'static,
) -> std::thread::JoinHandle<()> {
    std::thread::spawn(move || {
        use std::io::Read;
        let mut dec = vistaf_protocol::HostDecoder::new();
        let mut buf = [0u8; 256];
        master.set_timeout(Duration::from_millis(50)).unwrap();
        let deadline = Instant::now() + Duration::from_secs(30);
        while Instant::now() < deadline {
            let n = match master.read(&mut buf) {
                Ok(n) => n,
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => continue,
                Err(_) => return,
            };
            let mut out = Vec::new();
            dec.push(&buf[..n], |m| {
                if let Ok(m) = m {
                    out.extend(answer(m));
                }
            });
            for m in out {
                if master.write_all(&common::frame(&m)).is_err() {
                    return;
                }
            }
        }
    })
}

/// `rate`, `stop`, `start`, `led` and `map` as one-shot subcommands: each greets the skin,
/// sends its command, and reports the answer; the map comes in SI units.
#[test]
fn control_subcommands_command_the_skin() {
    use vistaf_protocol::{Command as Cmd, HostMsg, Map, MapKind};
    let (master, slave) = TTYPort::pair().unwrap();
    let path = slave.name().unwrap();
    let seen = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let log = seen.clone();
    let device = device_answering(master, move |m| {
        log.lock().unwrap().push(m);
        match m {
            HostMsg::GetInfo => vec![common::hello("VSK-CTL", 1)],
            HostMsg::SetRate { .. } => vec![DeviceMsg::Ack(Cmd::SetRate)],
            HostMsg::Stop => vec![DeviceMsg::Ack(Cmd::Stop)],
            HostMsg::Start => vec![DeviceMsg::Ack(Cmd::Start)],
            HostMsg::SetLed(_) => vec![DeviceMsg::Ack(Cmd::SetLed)],
            HostMsg::RequestMap(kind) => vec![
                DeviceMsg::Ack(Cmd::RequestMap),
                DeviceMsg::Map(Map {
                    seq: 5,
                    kind,
                    width: 2,
                    height: 1,
                    cell_pitch_centi_mm: 125,
                    cells: heapless::Vec::from_slice(&[1500, vistaf_protocol::msg::MAP_NO_DATA])
                        .unwrap(),
                }),
            ],
            _ => Vec::new(),
        }
    });
    let link = format!("serial:{path}");
    assert!(common::host_ok(&["rate", &link, "10"]).contains("rate set"));
    assert!(common::host_ok(&["stop", &link]).contains("stopped"));
    assert!(common::host_ok(&["start", &link]).contains("streaming"));
    common::host_ok(&["led", &link, "--rgb", "210,245,125", "--mask", "0xAAAAAA"]);
    let map: serde_json::Value =
        serde_json::from_str(common::host_ok(&["map", &link, "depth"]).trim()).unwrap();
    assert_eq!(map["unit"], "mm");
    assert_eq!(map["cells"], serde_json::json!([1.5, null]));
    assert_eq!(map["cell_pitch_mm"], 1.25);
    let got = seen.lock().unwrap().clone();
    assert!(got.contains(&HostMsg::SetRate { max_rate_hz: 10 }));
    assert!(got.contains(&HostMsg::RequestMap(MapKind::Depth)));
    assert!(got.iter().any(|m| matches!(
        m,
        HostMsg::SetLed(l) if l.rgb.g == 245 && l.lit_mask == 0x00AA_AAAA && l.brightness == 30
    )));
    drop(slave);
    drop(device);
}

/// The pieces of a `w × h` map whose cell `i` is `cell(i)`.
fn pieces(
    kind: vistaf_protocol::MapKind,
    (w, h): (u16, u16),
    cell: impl Fn(usize) -> i16,
) -> Vec<DeviceMsg> {
    let cells: Vec<i16> = (0..usize::from(w) * usize::from(h)).map(cell).collect();
    cells
        .chunks(vistaf_protocol::msg::MAP_MAX_CELLS)
        .enumerate()
        .map(|(i, part)| {
            DeviceMsg::MapChunk(vistaf_protocol::MapChunk {
                seq: 10,
                kind,
                width: w,
                height: h,
                cell_pitch_nm: if kind == vistaf_protocol::MapKind::Temperature {
                    2_000_000
                } else {
                    250_000
                },
                first_cell: (i * vistaf_protocol::msg::MAP_MAX_CELLS) as u32,
                cells: heapless::Vec::from_slice(part).unwrap(),
            })
        })
        .collect()
}

/// `snapshot` draws the next frame's full maps as a figure with its SVG twin and PLY
/// surface; `map --full` prints a full map in SI units.
#[test]
fn snapshot_and_full_maps_from_the_skin() {
    use vistaf_protocol::{Command as Cmd, HostMsg, MapKind};
    let (master, slave) = TTYPort::pair().unwrap();
    let path = slave.name().unwrap();
    // A 2 mm deep dimple at cell (30, 12) of a 48 × 36 working grid.
    let depth_um = |i: usize| {
        let (x, y) = ((i % 48) as f64 - 30.0, (i / 48) as f64 - 12.0);
        (2000.0 * (1.0 - (x * x + y * y) / 64.0)).max(0.0) as i16
    };
    let device = device_answering(master, move |m| match m {
        HostMsg::GetInfo => vec![common::hello("VSK-FIG", 7)],
        HostMsg::RequestFullMap(kind) => {
            let mut out = vec![DeviceMsg::Ack(Cmd::RequestFullMap)];
            if kind == MapKind::Camera {
                out.push(DeviceMsg::Summary(vistaf_protocol::Summary {
                    force_mn: 12_360,
                    peak_depth_um: 2_000,
                    ..common::summary(10)
                }));
            }
            out.extend(match kind {
                MapKind::Camera => pieces(kind, (48, 36), |i| if i % 4 < 2 { 0x7bef } else { 0 }),
                MapKind::Depth => pieces(kind, (48, 36), depth_um),
                MapKind::Temperature => pieces(kind, (6, 4), |i| 2_500 + 100 * i as i16),
            });
            out
        }
        _ => Vec::new(),
    });
    let link = format!("serial:{path}");
    let dir = std::env::temp_dir().join(format!("vistaf-host-snap-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (png, ply) = (dir.join("fig.png"), dir.join("surface.ply"));
    let said = common::host_ok(&[
        "snapshot",
        &link,
        "--out",
        png.to_str().unwrap(),
        "--ply",
        ply.to_str().unwrap(),
        "--depth-range-mm",
        "0,2.5",
    ]);
    assert!(said.contains("frame 10"), "{said}");
    assert_eq!(&std::fs::read(&png).unwrap()[1..4], b"PNG");
    let svg = std::fs::read_to_string(dir.join("fig.svg")).unwrap();
    for want in [
        ">2.5 mm<",
        ">0.0 mm<",
        "force 12.36 N",
        "depth 2.000 mm",
        "max 48.0 °C",
        "min 25.0 °C",
    ] {
        assert!(
            svg.replace('\n', "").contains(want),
            "no {want} in the figure's SVG"
        );
    }
    let mesh = std::fs::read_to_string(&ply).unwrap();
    assert!(mesh.contains(&format!("element vertex {}\n", 48 * 36)));
    assert!(
        mesh.contains("7.5000 3.0000 -2.0000\n"),
        "the dimple's bottom at (30, 12) × 0.25 mm"
    );

    let full: serde_json::Value =
        serde_json::from_str(common::host_ok(&["map", &link, "depth", "--full"]).trim()).unwrap();
    assert_eq!(
        (full["width"].as_u64(), full["height"].as_u64()),
        (Some(48), Some(36))
    );
    assert_eq!(full["unit"], "mm");
    assert_eq!(full["cell_pitch_mm"], 0.25);
    assert_eq!(full["cells"][12 * 48 + 30], 2.0);
    drop(slave);
    drop(device);
    std::fs::remove_dir_all(&dir).ok();
}
