//! `vistaf-host`: monitor, record and command vistaf skins from the robot computer.

use std::io::Write;
use std::path::PathBuf;
use std::time::Duration;

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use vistaf_host::bridge::{mcap::McapSink, serve::Serve, Bridge, Stamps};
use vistaf_host::client::{describe, Client, Next, DEFAULT_TIMEOUT};
use vistaf_host::link::{Link, LinkSpec};
use vistaf_host::maps::WholeMap;
use vistaf_host::monitor::Monitor;
use vistaf_host::multi::Reopen;
use vistaf_host::record::{message_json, Recorder};
use vistaf_host::stream::{Limits, Readout};
use vistaf_host::HostError;
use vistaf_protocol::{schema, DeviceMsg, MapKind};

#[derive(Parser, Debug)]
#[command(
    name = "vistaf-host",
    version,
    about = "Read and command vistaf tactile-thermal skins"
)]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Subcommand, Debug)]
enum Cmd {
    /// Live readout of one or more skins: force, depth, temperature, flags, rate, losses.
    Monitor {
        /// Links: /dev/ttyACM0, serial:PATH@BAUD, file:CAPTURE, or - for stdin.
        #[arg(required = true)]
        ports: Vec<String>,
        /// Draw each skin's latest map under its line: depth or temperature (asked for
        /// `--maps-hz` times a second).
        #[arg(long, value_parser = map_kind)]
        map: Option<MapKind>,
        /// The map's colour bar, LO,HI in its unit (mm or °C), fixed for the session
        /// [default: depth 0,1; temperature 20,40].
        #[arg(long, value_parser = range_pair)]
        map_range: Option<(f64, f64)>,
        /// How often maps are asked for, Hz.
        #[arg(long, default_value_t = 2.0, value_parser = rate_hz)]
        maps_hz: f64,
        #[command(flatten)]
        run: RunArgs,
    },
    /// Record summaries to a .csv or .jsonl file, flushed line by line.
    Record {
        /// Links to record from.
        #[arg(required = true)]
        ports: Vec<String>,
        /// Output file (.csv keeps summaries; .jsonl keeps every message; - is JSON lines
        /// on standard output).
        #[arg(long)]
        out: PathBuf,
        #[command(flatten)]
        run: RunArgs,
    },
    /// Own the links and publish every skin to every consumer at once: an MCAP file
    /// (Foxglove, ROS 2 bag), JSON lines. A `file:` link replays a capture and ends there.
    Bridge {
        /// Links to bridge.
        #[arg(required = true)]
        ports: Vec<String>,
        /// Publish on ROS 2 (DDS): WrenchStamped, PointStamped, Temperature, Image,
        /// DiagnosticArray per skin (needs a build with the `ros2` feature).
        #[arg(long)]
        ros2: bool,
        /// Write an MCAP recording (ROS 2 messages in CDR, plus each summary as JSON).
        #[arg(long)]
        mcap: Option<PathBuf>,
        /// Write every message as JSON lines to this file, or - for standard output.
        #[arg(long)]
        jsonl: Option<PathBuf>,
        /// Serve each skin's stream again on TCP (skin i on PORT+i; port 0: any free
        /// port, printed), for `vistaf-host monitor tcp:HOST:PORT` to attach to.
        #[arg(long)]
        serve: Option<String>,
        /// The frame of every skin's messages (default vistaf_<serial>).
        #[arg(long)]
        frame_id: Option<String>,
        /// Ask live skins for maps (depth, temperature, or both: depth,temperature),
        /// published as 32FC1 images.
        #[arg(long, value_delimiter = ',', value_parser = map_kind)]
        maps: Vec<MapKind>,
        /// How often maps are asked for, Hz.
        #[arg(long, default_value_t = 2.0, value_parser = rate_hz)]
        maps_hz: f64,
        #[command(flatten)]
        run: RunArgs,
    },
    /// Decode a captured byte stream: JSON lines on stdout, drop counts on stderr.
    Decode {
        /// Captured stream (a file, or - for stdin).
        file: String,
        /// Accepted for old scripts: JSON lines are the only output.
        #[arg(long, hide = true)]
        json: bool,
    },
    /// Print the device's identity and protocol version.
    Info {
        /// Serial link.
        port: String,
        /// Answer timeout, ms.
        #[arg(long, default_value_t = 2000)]
        timeout_ms: u64,
    },
    /// Ask the device to capture a new no-contact reference.
    Reference {
        /// Serial link.
        port: String,
        /// Answer timeout, ms (the device waits for a stable image first).
        #[arg(long, default_value_t = 10_000)]
        timeout_ms: u64,
    },
    /// The demo is its own program now: `cargo run --release -p vistaf-demo`.
    #[command(hide = true)]
    Demo {
        /// Ignored.
        #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
        rest: Vec<String>,
    },
    /// Limit the summary rate (0: every frame).
    Rate {
        /// Serial link.
        port: String,
        /// Summaries per second at most; 0 sends every frame's.
        hz: u16,
    },
    /// Set the LED ring.
    Led {
        /// Serial link.
        port: String,
        /// Colour, R,G,B (0–255 each).
        #[arg(long, value_parser = rgb, default_value = "255,255,255")]
        rgb: vistaf_protocol::Rgb,
        /// Brightness, 0–255 (the reference build uses 30).
        #[arg(long, default_value_t = 30)]
        brightness: u8,
        /// Which LEDs are lit: bit i lights LED i (the reference build: 0xAAAAAA).
        #[arg(long, value_parser = hex_mask, default_value = "0xAAAAAA")]
        mask: u32,
    },
    /// Resume streaming summaries.
    Start {
        /// Serial link.
        port: String,
    },
    /// Pause streaming summaries (the device keeps processing, so its reference stays fresh).
    Stop {
        /// Serial link.
        port: String,
    },
    /// Ask for one map of the next frame and print it as JSON, in mm or °C (the camera's
    /// cells as [r, g, b]).
    Map {
        /// Serial link.
        port: String,
        /// depth, temperature, or camera (whole only: with --full).
        #[arg(value_parser = any_map_kind)]
        kind: MapKind,
        /// The map at the working resolution (every working pixel), sent in pieces,
        /// instead of the coarse one of at most 768 cells.
        #[arg(long)]
        full: bool,
        /// Answer timeout, ms (a full map over a slow serial line takes seconds).
        #[arg(long, default_value_t = 30_000)]
        timeout_ms: u64,
    },
    /// Draw the next frame as a figure: camera image, depth map with mm axes and a numbered
    /// colour bar, shaded 3-D surface, temperature map with its extremes marked; force,
    /// depth, contact temperature and flags in the title. Writes OUT (PNG) and its SVG twin.
    Snapshot {
        /// Serial link.
        port: String,
        /// The figure, PNG; the SVG twin is written beside it.
        #[arg(long)]
        out: PathBuf,
        /// Also write the indented surface as a PLY mesh (mm).
        #[arg(long)]
        ply: Option<PathBuf>,
        /// Depth colour bar, LO,HI mm [default: 0 to the frame's deepest, rounded up,
        /// at least 0.5].
        #[arg(long, value_parser = range_pair)]
        depth_range_mm: Option<(f64, f64)>,
        /// Temperature colour bar, LO,HI °C [default: around the frame's coldest and
        /// hottest, rounded, at least 2 wide].
        #[arg(long, value_parser = range_pair)]
        temperature_range_c: Option<(f64, f64)>,
        /// Answer timeout, ms (full maps over a slow serial line take seconds).
        #[arg(long, default_value_t = 30_000)]
        timeout_ms: u64,
    },
    /// Calibrate a skin in one guided session: each press and temperature asked for,
    /// captured on the device once the image settles, fitted, judged against the targets,
    /// and activated (the previous calibration kept for `rollback`).
    Calibrate {
        /// Serial link.
        port: String,
        /// The plan, when to activate, the scale.
        #[command(flatten)]
        session: vistaf_session::SessionArgs,
    },
    /// Put back the calibration the last activation replaced.
    Rollback {
        /// Serial link.
        port: String,
    },
    /// List the serial ports of this machine (USB vendor, product, serial).
    ListPorts,
    /// Measure the round-trip time to the device.
    Ping {
        /// Serial link.
        port: String,
        /// Pings to send.
        #[arg(long, default_value_t = 5)]
        count: u32,
    },
}

#[derive(clap::Args, Debug)]
struct RunArgs {
    /// Stop after this many summaries in all (a rate limit sends fewer summaries than the
    /// camera takes frames; `--frames` is the old name).
    #[arg(long, alias = "frames")]
    summaries: Option<u64>,
    /// Stop after this many seconds.
    #[arg(long, value_parser = seconds)]
    duration_s: Option<f64>,
    /// Skip the Hello handshake on serial links (for devices that do not answer GetInfo).
    #[arg(long)]
    no_handshake: bool,
    /// When a serial link goes away (a cable pulled, the board's USB gadget
    /// re-enumerating), keep trying to open it again for this many seconds before giving up
    /// with an error (0: give up at once).
    #[arg(long, default_value_t = 30.0, value_parser = seconds)]
    reconnect_s: f64,
}

/// How often a streaming skin's clock is read, to map capture times onto the host's.
const CLOCK_PERIOD: Duration = Duration::from_secs(1);

/// A map kind for `--maps` (coarse maps: depth or temperature).
fn map_kind(s: &str) -> Result<MapKind, String> {
    match s {
        "depth" => Ok(MapKind::Depth),
        "temperature" => Ok(MapKind::Temperature),
        other => Err(format!("{other:?}: depth or temperature")),
    }
}

/// A map kind for `map`: depth, temperature or camera.
fn any_map_kind(s: &str) -> Result<MapKind, String> {
    match s {
        "camera" => Ok(MapKind::Camera),
        other => map_kind(other).map_err(|_| format!("{other:?}: depth, temperature or camera")),
    }
}

/// A colour bar's `LO,HI`, finite and increasing.
fn range_pair(s: &str) -> Result<(f64, f64), String> {
    let bad = || format!("{s:?}: LO,HI with LO < HI, like 0,1.5");
    let (lo, hi) = s.split_once(',').ok_or_else(bad)?;
    let (lo, hi): (f64, f64) = (
        lo.trim().parse().map_err(|_| bad())?,
        hi.trim().parse().map_err(|_| bad())?,
    );
    if lo.is_finite() && hi.is_finite() && lo < hi {
        Ok((lo, hi))
    } else {
        Err(bad())
    }
}

/// A rate for `--maps-hz`: above zero, at most 60.
fn rate_hz(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("{s:?} is not a number"))?;
    if v.is_finite() && v > 0.0 && v <= 60.0 {
        Ok(v)
    } else {
        Err(format!("{v}: a rate above 0 and at most 60 Hz"))
    }
}

/// A duration for `--duration-s`: finite, not negative, at most a year.
fn seconds(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("{s:?} is not a number"))?;
    if v.is_finite() && (0.0..=3.2e7).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{v}: seconds from 0 to a year (3.2e7)"))
    }
}

fn main() {
    let cli = Cli::parse();
    if let Err(e) = run(cli) {
        // Every error says its cause once (in its message or as its source, never both),
        // so the chain reads as one sentence.
        eprintln!("vistaf-host: {e:#}");
        std::process::exit(1);
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Cmd::Monitor {
            ports,
            map,
            map_range,
            maps_hz,
            run,
        } => {
            let mut monitor = Monitor::new(ports.len(), true);
            let mut maps = Maps::none();
            if let Some(kind) = map {
                let d = vistaf_figure::Ranges::default();
                let range = map_range.unwrap_or(match kind {
                    MapKind::Temperature => d.temperature_c,
                    _ => d.depth_mm,
                });
                monitor = monitor.with_maps(range);
                maps = Maps {
                    kinds: vec![kind],
                    every: Duration::from_secs_f64(1.0 / maps_hz),
                };
            }
            stream(&ports, &run, None, monitor, &maps)
        }
        Cmd::Record { ports, out, run } => {
            let rec = Recorder::create(&out)?;
            let monitor = Monitor::new(ports.len(), false);
            stream(&ports, &run, Some(rec), monitor, &Maps::none())
        }
        Cmd::Bridge {
            ports,
            ros2,
            mcap,
            jsonl,
            serve,
            frame_id,
            maps,
            maps_hz,
            run,
        } => {
            let maps = Maps {
                kinds: maps,
                every: Duration::from_secs_f64(1.0 / maps_hz),
            };
            let sinks = Outputs {
                ros2,
                mcap: mcap.as_deref(),
                jsonl: jsonl.as_deref(),
                serve: serve.as_deref(),
            };
            bridge(&ports, &run, &sinks, frame_id, &maps)
        }
        Cmd::Decode { file, json: _ } => decode(&file),
        Cmd::Info { port, timeout_ms } => {
            let mut c = open_client(&port)?;
            let hello = c.handshake(Duration::from_millis(timeout_ms))?;
            let fw = hello.firmware;
            println!("link:         {}", c.name());
            println!("serial:       {}", hello.serial);
            println!("firmware:     {}.{}.{}", fw.major, fw.minor, fw.patch);
            println!(
                "protocol:     v{} (schema {:#018x})",
                hello.protocol_version, hello.schema_hash
            );
            println!(
                "frame size:   {}×{} px",
                hello.frame_width_px, hello.frame_height_px
            );
            println!("calibration:  {}", vistaf_protocol::CalibrationId(hello.calibration_id));
            Ok(())
        }
        Cmd::Reference { port, timeout_ms } => command(&port, "new reference captured", |c| {
            c.capture_reference(Duration::from_millis(timeout_ms))
        }),
        Cmd::Demo { .. } => bail!(
            "the demo is its own program: cargo run --release -p vistaf-demo (or vistaf-demo --help)"
        ),
        Cmd::Rate { port, hz } => command(&port, "rate set", |c| c.set_rate(hz, DEFAULT_TIMEOUT)),
        Cmd::Led {
            port,
            rgb,
            brightness,
            mask,
        } => command(&port, "LED ring set", |c| {
            c.set_led(
                vistaf_protocol::SetLed {
                    rgb,
                    brightness,
                    lit_mask: mask,
                },
                DEFAULT_TIMEOUT,
            )
        }),
        Cmd::Start { port } => command(&port, "streaming", |c| c.start(DEFAULT_TIMEOUT)),
        Cmd::Stop { port } => command(&port, "stopped", |c| c.stop(DEFAULT_TIMEOUT)),
        Cmd::Map {
            port,
            kind,
            full,
            timeout_ms,
        } => {
            let mut c = open_client(&port)?;
            c.handshake(DEFAULT_TIMEOUT)?;
            let timeout = Duration::from_millis(timeout_ms);
            let json = if full {
                let shot = c.request_full_maps(&[kind], timeout)?;
                shot.maps.first().map(|m| m.to_json())
            } else {
                let map = c.request_map(kind, timeout)?;
                WholeMap::from_coarse(&map).map(|m| m.to_json())
            };
            println!("{}", json.context("the device sent no usable map")?);
            Ok(())
        }
        Cmd::Snapshot {
            port,
            out,
            ply,
            depth_range_mm,
            temperature_range_c,
            timeout_ms,
        } => {
            let bars = vistaf_figure::range::Bars {
                depth_mm: depth_range_mm,
                temperature_c: temperature_range_c,
            };
            snapshot(&port, &out, ply.as_deref(), bars, timeout_ms)
        }
        Cmd::Calibrate { port, session } => calibrate(&port, &session),
        Cmd::Rollback { port } => {
            let mut c = open_client(&port)?;
            c.handshake(DEFAULT_TIMEOUT)?;
            let hello = c.roll_back_calibration(DEFAULT_TIMEOUT)?;
            println!(
                "{}: calibration {} in use again",
                hello.serial,
                vistaf_protocol::CalibrationId(hello.calibration_id)
            );
            Ok(())
        }
        Cmd::ListPorts => {
            for line in vistaf_host::link::port_list() {
                println!("{line}");
            }
            Ok(())
        }
        Cmd::Ping { port, count } => {
            let mut c = open_client(&port)?;
            for nonce in 0..count {
                let rtt = c.ping(nonce, DEFAULT_TIMEOUT)?;
                println!(
                    "{}: pong {nonce} in {:.2} ms",
                    c.name(),
                    rtt.as_secs_f64() * 1e3
                );
            }
            Ok(())
        }
    }
}

/// The next frame of the skin on `port` as a figure (and its surface as PLY).
fn snapshot(
    port: &str,
    out: &std::path::Path,
    ply: Option<&std::path::Path>,
    bars: vistaf_figure::range::Bars,
    timeout_ms: u64,
) -> Result<()> {
    use vistaf_host::snapshot;
    let mut c = open_client(port)?;
    c.handshake(DEFAULT_TIMEOUT)?;
    let timeout = Duration::from_millis(timeout_ms);
    let shot = match c.request_full_maps(&snapshot::FIGURE_MAPS, timeout) {
        // A calibration without thermometry: the figure without its temperature panel.
        Err(HostError::Device { error, .. })
            if error.code == vistaf_protocol::ErrorCode::UnsupportedCommand =>
        {
            eprintln!("{}: {}; no temperature panel", c.name(), error.detail);
            c.request_full_maps(&[MapKind::Camera, MapKind::Depth], timeout)?
        }
        other => other?,
    };
    let frame = snapshot::frame(&shot);
    let ranges = bars.or(vistaf_figure::Ranges::covering([&frame]));
    let written = vistaf_figure::write(&frame, &ranges, out)?;
    println!(
        "{}: {} wrote {} and {}",
        c.name(),
        frame.readout.label,
        written.png.display(),
        written.svg.display()
    );
    if let Some(p) = ply {
        snapshot::write_ply(&frame, p)?;
        println!("{}: surface in {}", c.name(), p.display());
    }
    Ok(())
}

/// Greets the skin on `port`, sends it one command, and says `done` when it is acknowledged.
fn command(
    port: &str,
    done: &str,
    send: impl FnOnce(&mut Client) -> Result<(), HostError>,
) -> Result<()> {
    let mut c = open_client(port)?;
    c.handshake(DEFAULT_TIMEOUT)?;
    send(&mut c)?;
    println!("{}: {done}", c.name());
    Ok(())
}

/// An `R,G,B` colour for `--rgb`.
fn rgb(s: &str) -> Result<vistaf_protocol::Rgb, String> {
    let v: Vec<u8> = s
        .split(',')
        .map(|p| p.trim().parse::<u8>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("{s:?}: R,G,B with each 0–255"))?;
    match v[..] {
        [r, g, b] => Ok(vistaf_protocol::Rgb { r, g, b }),
        _ => Err(format!("{s:?}: R,G,B with each 0–255")),
    }
}

/// A bit mask for `--mask`, hexadecimal with `0x` or decimal.
fn hex_mask(s: &str) -> Result<u32, String> {
    match s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        Some(h) => u32::from_str_radix(h, 16),
        None => s.parse(),
    }
    .map_err(|_| format!("{s:?}: a 32-bit mask, like 0xAAAAAA"))
}

/// A guided calibration of the skin on `port`.
fn calibrate(port: &str, session: &vistaf_session::SessionArgs) -> Result<()> {
    let (plan, mut guide) = session.open().map_err(anyhow::Error::msg)?;
    let mut client = open_client(port)?;
    let hello = client.handshake(DEFAULT_TIMEOUT)?;
    println!(
        "{}; calibration {} in use; {} steps",
        describe(&hello),
        vistaf_protocol::CalibrationId(hello.calibration_id),
        plan.steps().len()
    );
    let outcome = vistaf_session::run(&mut client, &plan, guide.as_mut())?;
    if outcome.activated.is_some() {
        println!("`vistaf-host rollback {port}` puts the one it replaced back");
    }
    if outcome.fitted.is_some_and(|f| !f.pass) {
        bail!("the calibration misses a target (see the table above)");
    }
    Ok(())
}

fn open_client(port: &str) -> Result<Client> {
    let spec: LinkSpec = port.parse()?;
    Ok(Client::new(Link::open(&spec)?))
}

fn decode(file: &str) -> Result<()> {
    let spec = if file == "-" {
        LinkSpec::Stdio
    } else {
        LinkSpec::File(PathBuf::from(file))
    };
    let mut client = Client::new(Link::open(&spec)?);
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    let name = client.name().to_string();
    let mut messages = 0u64;
    let mut failure = None;
    loop {
        match client.next(None) {
            Ok(Next::Message(r)) => {
                if let DeviceMsg::Hello(h) = &r.msg {
                    if !schema::is_compatible(h.protocol_version, h.schema_hash) {
                        eprintln!(
                            "{}",
                            HostError::incompatible(&name, h.protocol_version, h.schema_hash)
                        );
                    }
                }
                writeln!(out, "{}", message_json(&name, &r)).context("writing stdout")?;
                messages += 1;
            }
            Ok(Next::End | Next::Timeout) => break,
            Err(e) => {
                failure = Some(e);
                break;
            }
        }
    }
    out.flush().context("writing stdout")?;
    let d = client.drops();
    eprintln!(
        "{name}: {messages} frames decoded, {} dropped (crc {}, cobs {}, too short {}, \
         overflow {}, not a message {})",
        d.total(),
        d.crc,
        d.cobs,
        d.too_short,
        d.overflow,
        d.decode
    );
    match failure {
        Some(e) => Err(e.into()),
        None => Ok(()),
    }
}

/// Reads the links until `run` says stop, recording to `rec`, with `monitor`'s readout,
/// asking live skins for `maps`.
///
/// A serial link that goes away is opened again (and greeted) for `--reconnect-s`; one
/// that does not come back, or ends with reconnecting off, is an error.
fn stream(
    ports: &[String],
    run: &RunArgs,
    rec: Option<Recorder>,
    monitor: Monitor,
    maps: &Maps,
) -> Result<()> {
    let links = open_links(ports, run, maps)?;
    let mut readout = Readout {
        recorder: rec,
        monitor,
    };
    let outcome = vistaf_host::stream::stream_with(links, &limits(run), &mut readout)?;
    readout.finish(&outcome);
    match outcome.failure {
        Some(e) => Err(e.into()),
        None => Ok(()),
    }
}

/// The maps asked of live skins while streaming, and how often.
#[derive(Debug, Clone)]
struct Maps {
    kinds: Vec<MapKind>,
    every: Duration,
}

impl Maps {
    fn none() -> Maps {
        Maps {
            kinds: Vec::new(),
            every: Duration::from_secs(1),
        }
    }
}

/// Opens every link, asking for `maps`; serial ones are greeted, read with their clock
/// kept, and opened again (asking for the same maps) when they go away.
fn open_links(
    ports: &[String],
    run: &RunArgs,
    maps: &Maps,
) -> Result<Vec<(Client, Option<Reopen>)>> {
    let mut links = Vec::new();
    for p in ports {
        let serial = matches!(p.parse::<LinkSpec>()?, LinkSpec::Serial { .. });
        let mut c = open_client(p)?;
        if serial && !run.no_handshake {
            greet(&mut c, p)?;
            c.keep_clock(CLOCK_PERIOD);
        }
        c.keep_maps(&maps.kinds, maps.every);
        let reopen = serial.then(|| reopen(p, run, maps.clone()));
        links.push((c, reopen));
    }
    Ok(links)
}

fn limits(run: &RunArgs) -> Limits {
    Limits {
        summaries: run.summaries,
        duration: run.duration_s.map(Duration::from_secs_f64),
    }
}

/// Where `bridge` publishes.
struct Outputs<'a> {
    ros2: bool,
    mcap: Option<&'a std::path::Path>,
    jsonl: Option<&'a std::path::Path>,
    serve: Option<&'a str>,
}

#[cfg(feature = "ros2")]
fn ros2_sink() -> Result<Box<dyn vistaf_host::bridge::Sink>> {
    Ok(Box::new(vistaf_host::bridge::dds::DdsSink::new()?))
}

#[cfg(not(feature = "ros2"))]
fn ros2_sink() -> Result<Box<dyn vistaf_host::bridge::Sink>> {
    bail!(
        "this vistaf-host was built without ROS 2; build it with \
         `cargo build --release -p vistaf-host --features ros2`"
    )
}

/// `bridge`: every skin to every consumer, until the limits or the end of every link.
fn bridge(
    ports: &[String],
    run: &RunArgs,
    out: &Outputs<'_>,
    frame_id: Option<String>,
    maps: &Maps,
) -> Result<()> {
    if !out.ros2 && out.mcap.is_none() && out.jsonl.is_none() && out.serve.is_none() {
        bail!("nothing to bridge to: give --ros2, --mcap FILE, --jsonl FILE|- and/or --serve ADDR");
    }
    let replay = ports
        .iter()
        .map(|p| p.parse::<LinkSpec>())
        .collect::<Result<Vec<_>, _>>()?
        .iter()
        .all(|s| !matches!(s, LinkSpec::Serial { .. }));
    let links = open_links(ports, run, maps)?;
    let stamps = if replay { Stamps::Device } else { Stamps::Host };
    let mut b = Bridge::new(links.len(), stamps, frame_id);
    if out.ros2 {
        b = b.sink(ros2_sink()?);
    }
    if let Some(path) = out.mcap {
        b = b.sink(Box::new(McapSink::create(path)?));
    }
    if let Some(path) = out.jsonl {
        b = b.jsonl(Recorder::create(path)?);
    }
    if let Some(addr) = out.serve {
        let serve = Serve::bind(addr, links.len())?;
        for (i, (c, _)) in links.iter().enumerate() {
            if let Some(at) = serve.local_addr(i) {
                eprintln!("{}: served on tcp:{at}", c.name());
            }
        }
        b = b.serve(serve);
    }
    let outcome = vistaf_host::stream::stream_with(links, &limits(run), &mut b);
    let finished = b.finish();
    let outcome = outcome?;
    finished?;
    for s in &outcome.stats {
        eprintln!(
            "{}: {} summaries, {} missing (sequence gaps), {} frames dropped",
            s.name,
            s.seq.received,
            s.seq.missing,
            s.drops.total()
        );
    }
    eprintln!("published {} messages", b.published());
    match outcome.failure {
        Some(e) => Err(e.into()),
        None => Ok(()),
    }
}

/// How a serial link `port` is opened again after it went away: greeted and asked for
/// `maps` as at the start.
fn reopen(port: &str, run: &RunArgs, maps: Maps) -> Reopen {
    let (port, handshake) = (port.to_string(), !run.no_handshake);
    Reopen {
        open: Box::new(move || {
            let mut c = Client::new(Link::open(&port.parse::<LinkSpec>()?)?);
            if handshake {
                c.handshake(DEFAULT_TIMEOUT)?;
                c.keep_clock(CLOCK_PERIOD);
            }
            c.keep_maps(&maps.kinds, maps.every);
            Ok(c)
        }),
        give_up_after: Duration::from_secs_f64(run.reconnect_s),
        min_backoff: Duration::from_millis(250),
        max_backoff: Duration::from_secs(4),
    }
}

/// Shakes hands with a skin and prints who it is.
fn greet(c: &mut Client, port: &str) -> Result<()> {
    let hello = c.handshake(DEFAULT_TIMEOUT).map_err(|e| match e {
        HostError::Timeout { .. } => {
            anyhow::anyhow!("{e}: is a vistaf skin on {port}? (--no-handshake skips this check)")
        }
        other => other.into(),
    })?;
    eprintln!("{}: {}", c.name(), describe(&hello));
    let d = c.discarded();
    if d.bytes + d.messages > 0 {
        eprintln!(
            "{}: discarded what the skin sent before the host listened: {} bytes waiting \
             in the port, {} message(s) before its Hello",
            c.name(),
            d.bytes,
            d.messages
        );
    }
    Ok(())
}
