//! `vistaf-host`: monitor, record and command vistaf skins from the robot computer.

use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use vistaf_host::client::{Client, Next, DEFAULT_TIMEOUT};
use vistaf_host::link::{Link, LinkSpec};
use vistaf_host::multi::{DeviceStats, Event, MultiReader};
use vistaf_host::record::{message_json, Recorder};
use vistaf_host::HostError;
use vistaf_protocol::{schema, DeviceMsg, HostMsg, MapKind, Summary};

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
        #[command(flatten)]
        run: RunArgs,
    },
    /// Record summaries to a .csv or .jsonl file, flushed line by line.
    Record {
        /// Links to record from.
        #[arg(required = true)]
        ports: Vec<String>,
        /// Output file (.csv keeps summaries; .jsonl keeps every message).
        #[arg(long)]
        out: PathBuf,
        #[command(flatten)]
        run: RunArgs,
    },
    /// Decode a captured byte stream: JSON lines on stdout, drop counts on stderr.
    Decode {
        /// Captured stream (a file, or - for stdin).
        file: String,
        /// Emit JSON lines (the default and only output format today).
        #[arg(long, default_value_t = true)]
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
    /// The whole chain on a simulated skin: the device service on a scripted scene (idle,
    /// heated sphere pressed and slid, released, letter E, heated bar) writing to a real
    /// pseudo-terminal, this host reading it with a live readout, a recording in --out.
    Demo {
        /// Frames of the scripted scene (30 per second).
        #[arg(long, default_value_t = 300)]
        frames: usize,
        /// Session folder (summaries.jsonl, session.json).
        #[arg(long, default_value = "vistaf-demo")]
        out: PathBuf,
    },
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
    /// Stop after this many summaries in all.
    #[arg(long)]
    frames: Option<u64>,
    /// Stop after this many seconds.
    #[arg(long)]
    duration_s: Option<f64>,
    /// Skip the Hello handshake on serial links (for devices that do not answer GetInfo).
    #[arg(long)]
    no_handshake: bool,
}

fn main() {
    let cli = Cli::parse();
    if let Err(e) = run(cli) {
        eprintln!("vistaf-host: {}", causes(&e));
        std::process::exit(1);
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Cmd::Monitor { ports, run } => stream(&ports, &run, None, true, &mut |_, _| {}),
        Cmd::Record { ports, out, run } => {
            let rec = Recorder::create(&out)?;
            stream(&ports, &run, Some(rec), false, &mut |_, _| {})
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
            println!("calibration:  {:#010x}", hello.calibration_id);
            Ok(())
        }
        Cmd::Reference { port, timeout_ms } => {
            let mut c = open_client(&port)?;
            c.handshake(DEFAULT_TIMEOUT)?;
            c.capture_reference(Duration::from_millis(timeout_ms))?;
            println!("{}: new reference captured", c.name());
            Ok(())
        }
        Cmd::Demo { frames, out } => demo(frames, &out),
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

fn demo(frames: usize, out: &std::path::Path) -> Result<()> {
    use std::sync::atomic::AtomicBool;
    use std::sync::Arc;
    use vistaf_firmware::calibration::Calibration;
    use vistaf_firmware::service::{run as serve, Settings};
    use vistaf_firmware::source_spec::{open, OpenOptions, SourceSpec};
    use vistaf_hardware::led::{LedConfig, MemoryLedRing};

    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let (master, slave) = serialport::TTYPort::pair().context("creating a pseudo-terminal pair")?;
    let port = serialport::SerialPort::name(&slave).context("pseudo-terminal has no name")?;
    let calibration = Calibration::default_sim();
    let settings = Settings {
        serial: "VSK-SIM-DEMO".into(),
        calibration: calibration.clone(),
        force_calibration: false,
        pipeline: vistaf_firmware::pipeline::Implementation::Fixed,
        frames: Some(frames as u64),
        max_rate_hz: 0,
        led: LedConfig::default(),
        reference: Default::default(),
    };
    let source = open(
        &SourceSpec::Sim("demo".into()),
        &OpenOptions {
            sim_frames: frames + 2,
            fps: Some(30.0),
            ..OpenOptions::default()
        },
    )?;
    let reader = master.try_clone_native().context("pseudo-terminal")?;
    let stop = Arc::new(AtomicBool::new(false));
    let device_stop = stop.clone();
    let device = std::thread::spawn(move || {
        let mut led = MemoryLedRing::default();
        serve(
            source,
            master,
            Some(Box::new(reader)),
            &mut led,
            &settings,
            device_stop,
        )
    });
    eprintln!("device: simulated skin on {port}; host: reading it");
    let rec = Recorder::create(&out.join("summaries.jsonl"))?;
    let args = RunArgs {
        frames: Some(frames as u64),
        duration_s: Some(frames as f64 / 30.0 + 20.0),
        no_handshake: false,
    };
    // Maps at peak contact: whenever the force passes its maximum so far by 10 %, ask for
    // both maps (they come from the next frame); keep the last pair.
    let host_end = serialport::new(&port, 921_600)
        .timeout(Duration::from_millis(100))
        .open_native()
        .context("opening the pseudo-terminal")?;
    let commands = host_end
        .try_clone_native()
        .context("opening the pseudo-terminal for commands")?;
    let name = format!("serial:{port}");
    let mut client = Client::new(Link::from_serial(name.clone(), host_end)?);
    greet(&mut client, &name)?;
    let mut commander = Client::new(Link::new(name, std::io::empty(), commands));
    let mut peak_mn = 500u32;
    let mut peak = PeakMaps::default();
    let mut frames_json = Vec::new();
    let mut hook = |_: usize, r: &vistaf_host::client::Received| match &r.msg {
        DeviceMsg::Summary(s) => {
            frames_json.push(summary_brief(s));
            if s.force_mn > peak_mn + peak_mn / 10 {
                peak_mn = s.force_mn;
                peak.force_mn = s.force_mn;
                for kind in [MapKind::Depth, MapKind::Temperature] {
                    if let Err(e) = commander.send(&HostMsg::RequestMap(kind)) {
                        eprintln!("requesting a map: {e}");
                    }
                }
            }
        }
        DeviceMsg::Map(m) => match m.kind {
            MapKind::Depth => peak.depth = Some(m.clone()),
            MapKind::Temperature => peak.temperature = Some(m.clone()),
        },
        _ => {}
    };
    let result = stream_clients(vec![client], &args, Some(rec), true, &mut hook);
    for (name, map) in [
        ("depth_at_peak.png", &peak.depth),
        ("temperature_at_peak.png", &peak.temperature),
    ] {
        if let Some(m) = map {
            vistaf_firmware::maps::wire_map_png(m, &out.join(name))?;
        }
    }
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    let counters = device
        .join()
        .map_err(|_| anyhow::anyhow!("device thread panicked"))??;
    let session = serde_json::json!({
        "scene": "demo",
        "link": port,
        "device": {
            "frames_captured": counters.captured, "frames_processed": counters.processed,
            "frames_dropped": counters.dropped, "summaries_sent": counters.sent,
        },
        "calibration": {
            "id": format!("{:08x}", calibration.id()),
            "phase_to_depth": { "equation": calibration.depth.equation, "model": calibration.depth.model, "cv_rmse_mm": calibration.depth.cv_rmse, "in_sample_rmse_mm": calibration.depth.in_sample_rmse },
            "force": calibration.force.as_ref().map(|f| serde_json::json!({ "equation": f.equation, "model": f.model, "cv_rmse_n": f.cv_rmse, "in_sample_rmse_n": f.in_sample_rmse })),
            "temperature": calibration.temperature.as_ref().map(|t| serde_json::json!({
                "coloured": { "equation": t.coloured.equation, "cv_rmse_c": t.coloured.cv_rmse_c, "in_sample_rmse_c": t.coloured.in_sample_rmse_c, "fit_range_c": t.coloured.fit_range_c },
                "black": { "equation": t.black.equation, "cv_rmse_c": t.black.cv_rmse_c, "in_sample_rmse_c": t.black.in_sample_rmse_c, "fit_range_c": t.black.fit_range_c },
                "held_out_rmse_c": { "22_32": t.cv_rmse_transition_c, "all": t.cv_rmse_c },
                "range_c": t.range_c,
            })),
        },
        "peak_contact": {
            "force_n": f64::from(peak.force_mn) / 1000.0,
            "depth_map": peak.depth.as_ref().map(|_| "depth_at_peak.png"),
            "temperature_map": peak.temperature.as_ref().map(|_| "temperature_at_peak.png"),
        },
        "summaries": "summaries.jsonl",
        "frames": frames_json,
    });
    std::fs::write(
        out.join("session.json"),
        serde_json::to_string_pretty(&session)? + "\n",
    )
    .with_context(|| format!("writing {}", out.join("session.json").display()))?;
    eprintln!("session: {}", out.display());
    result
}

/// The maps the demo kept from its strongest press.
#[derive(Default)]
struct PeakMaps {
    force_mn: u32,
    depth: Option<vistaf_protocol::Map>,
    temperature: Option<vistaf_protocol::Map>,
}

/// A summary's physical values for the session file.
fn summary_brief(s: &Summary) -> serde_json::Value {
    let si = s.si();
    let finite = |v: f32| v.is_finite().then_some(v);
    serde_json::json!({
        "seq": s.seq,
        "force_n": si.force_n,
        "depth_mm": si.peak_depth_mm,
        "contact_area_mm2": si.contact_area_mm2,
        "temp_mean_c": finite(si.temp_mean_c),
        "contact_temp_c": si.contact_temp_c,
        "flags": s.flags.iter().map(|f| f.name()).collect::<Vec<_>>(),
    })
}

fn open_client(port: &str) -> Result<Client> {
    let spec: LinkSpec = port.parse()?;
    Ok(Client::new(Link::open(&spec)?))
}

fn decode(file: &str) -> Result<()> {
    let spec = if file == "-" {
        LinkSpec::Stdin
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

/// Reads the links until `run` says stop, recording to `rec`, with a live readout when
/// `live`; `hook` sees every message (device index, message).
fn stream(
    ports: &[String],
    run: &RunArgs,
    rec: Option<Recorder>,
    live: bool,
    hook: &mut dyn FnMut(usize, &vistaf_host::client::Received),
) -> Result<()> {
    let mut clients = Vec::new();
    for p in ports {
        let mut c = open_client(p)?;
        if !run.no_handshake && matches!(p.parse::<LinkSpec>()?, LinkSpec::Serial { .. }) {
            greet(&mut c, p)?;
        }
        clients.push(c);
    }
    stream_clients(clients, run, rec, live, hook)
}

/// Shakes hands with a skin and prints who it is.
fn greet(c: &mut Client, port: &str) -> Result<()> {
    let hello = c.handshake(DEFAULT_TIMEOUT).map_err(|e| match e {
        HostError::Timeout { .. } => {
            anyhow::anyhow!("{e}: is a vistaf skin on {port}? (--no-handshake skips this check)")
        }
        other => other.into(),
    })?;
    eprintln!(
        "{}: skin {} firmware {}.{}.{}, {}×{} px",
        c.name(),
        hello.serial,
        hello.firmware.major,
        hello.firmware.minor,
        hello.firmware.patch,
        hello.frame_width_px,
        hello.frame_height_px
    );
    Ok(())
}

/// [`stream`] over links already open.
fn stream_clients(
    clients: Vec<Client>,
    run: &RunArgs,
    mut rec: Option<Recorder>,
    live: bool,
    hook: &mut dyn FnMut(usize, &vistaf_host::client::Received),
) -> Result<()> {
    let mut reader = MultiReader::spawn(clients);
    let mut view = Monitor::new(reader.stats().len(), live);
    let started = Instant::now();
    let deadline = run
        .duration_s
        .map(|s| started + Duration::from_secs_f64(s.max(0.0)));
    let mut summaries = 0u64;
    let mut failures = Vec::new();
    loop {
        if run.frames.is_some_and(|n| summaries >= n)
            || deadline.is_some_and(|d| Instant::now() >= d)
        {
            break;
        }
        let Some(event) = reader.recv(Duration::from_millis(100)) else {
            if reader.all_finished() {
                break;
            }
            view.draw(reader.stats(), false);
            continue;
        };
        match event {
            Event::Message { device, received } => {
                hook(device, &received);
                if let Some(rec) = rec.as_mut() {
                    let name = reader.stats()[device].name.clone();
                    rec.record(&name, &received)?;
                }
                match &received.msg {
                    DeviceMsg::Summary(s) => {
                        summaries += 1;
                        view.summary(device, s);
                    }
                    DeviceMsg::Error(e) => {
                        eprintln!(
                            "{}: device error {:?}: {}",
                            reader.stats()[device].name,
                            e.code,
                            e.detail
                        )
                    }
                    _ => {}
                }
            }
            Event::Ended { device } => eprintln!("{}: stream ended", reader.stats()[device].name),
            Event::Failed { device, error } => {
                eprintln!("{}: {error}", reader.stats()[device].name);
                failures.push(error);
            }
        }
        view.draw(reader.stats(), false);
    }
    view.draw(reader.stats(), true);
    if let Some(rec) = &rec {
        eprintln!("recorded {} lines", rec.lines());
    }
    for s in reader.stats() {
        eprintln!(
            "{}: {} summaries, {} missing (sequence gaps), {} out of order, {} frames dropped",
            s.name,
            s.seq.received,
            s.seq.missing,
            s.seq.out_of_order,
            s.drops.total()
        );
    }
    if let Some(e) = failures.into_iter().next() {
        bail!(e);
    }
    Ok(())
}

/// The live readout: one line per skin, redrawn at most 5 times a second.
struct Monitor {
    last: Vec<Option<Summary>>,
    rate: Vec<(Instant, u64, f64)>,
    drawn: Option<Instant>,
    live: bool,
    tty: bool,
    lines_drawn: usize,
}

impl Monitor {
    fn new(devices: usize, live: bool) -> Monitor {
        Monitor {
            last: vec![None; devices],
            rate: vec![(Instant::now(), 0, 0.0); devices],
            drawn: None,
            live,
            tty: std::io::stdout().is_terminal(),
            lines_drawn: 0,
        }
    }

    fn summary(&mut self, device: usize, s: &Summary) {
        if let Some(slot) = self.last.get_mut(device) {
            *slot = Some(*s);
        }
        if let Some((since, n, hz)) = self.rate.get_mut(device) {
            *n += 1;
            let dt = since.elapsed().as_secs_f64();
            if dt >= 1.0 {
                *hz = *n as f64 / dt;
                *since = Instant::now();
                *n = 0;
            }
        }
    }

    fn draw(&mut self, stats: &[DeviceStats], force: bool) {
        if !self.live {
            return;
        }
        let now = Instant::now();
        if !force
            && self
                .drawn
                .is_some_and(|t| now.duration_since(t) < Duration::from_millis(200))
        {
            return;
        }
        self.drawn = Some(now);
        let mut text = String::new();
        if self.tty && self.lines_drawn > 0 {
            text.push_str(&format!("\x1b[{}A", self.lines_drawn));
        }
        for (i, st) in stats.iter().enumerate() {
            let hz = self.rate.get(i).map_or(0.0, |r| r.2);
            let body = match self.last.get(i).copied().flatten() {
                Some(s) => {
                    let si = s.si();
                    let flags: Vec<&str> = s.flags.iter().map(|f| f.name()).collect();
                    format!(
                        "#{:<7} F {:7.3} N  d {:6.3} mm  A {:7.2} mm²  T {}{}  \
                         {:5.1} Hz  lost {}  dropped {}  {}",
                        s.seq,
                        si.force_n,
                        si.peak_depth_mm,
                        si.contact_area_mm2,
                        if si.temp_mean_c.is_nan() {
                            "— (not measured)".to_string()
                        } else {
                            format!(
                                "{:5.2} °C [{:5.2}…{:5.2}]",
                                si.temp_mean_c, si.temp_min_c, si.temp_max_c
                            )
                        },
                        si.contact_temp_c
                            .map(|t| format!(" contact {t:5.2} °C"))
                            .unwrap_or_default(),
                        hz,
                        st.seq.missing,
                        st.drops.total(),
                        if flags.is_empty() {
                            "ok".to_string()
                        } else {
                            flags.join(",")
                        }
                    )
                }
                None => "waiting for summaries…".to_string(),
            };
            text.push_str(&format!("{}: {body}", st.name));
            text.push_str(if self.tty { "\x1b[K\n" } else { "\n" });
        }
        self.lines_drawn = stats.len();
        let mut out = std::io::stdout().lock();
        let _ = out.write_all(text.as_bytes());
        let _ = out.flush();
    }
}

/// The error and its causes, each once: a cause whose text the message already carries (an
/// error that prints its source) is not repeated.
fn causes(e: &anyhow::Error) -> String {
    let mut msg = String::new();
    for c in e.chain() {
        let t = c.to_string();
        if !msg.contains(&t) {
            if !msg.is_empty() {
                msg.push_str(": ");
            }
            msg.push_str(&t);
        }
    }
    msg
}
