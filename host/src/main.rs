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
use vistaf_protocol::{schema, DeviceMsg, Summary};

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
        eprintln!("vistaf-host: {e:#}");
        std::process::exit(1);
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Cmd::Monitor { ports, run } => stream(&ports, &run, None, true),
        Cmd::Record { ports, out, run } => {
            let rec = Recorder::create(&out)?;
            stream(&ports, &run, Some(rec), false)
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
    let result = stream(&[format!("serial:{port}")], &args, Some(rec), true);
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
            "phase_to_depth": { "equation": calibration.depth.equation, "cv_rmse_mm": calibration.depth.cv_rmse, "in_sample_rmse_mm": calibration.depth.in_sample_rmse },
            "force": calibration.force.as_ref().map(|f| serde_json::json!({ "equation": f.equation, "cv_rmse_n": f.cv_rmse, "in_sample_rmse_n": f.in_sample_rmse })),
        },
        "summaries": "summaries.jsonl",
    });
    std::fs::write(
        out.join("session.json"),
        serde_json::to_string_pretty(&session)? + "\n",
    )
    .with_context(|| format!("writing {}", out.join("session.json").display()))?;
    eprintln!("session: {}", out.display());
    result
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

fn stream(ports: &[String], run: &RunArgs, mut rec: Option<Recorder>, live: bool) -> Result<()> {
    let mut clients = Vec::new();
    for p in ports {
        let mut c = open_client(p)?;
        if !run.no_handshake && matches!(p.parse::<LinkSpec>()?, LinkSpec::Serial { .. }) {
            let hello = c.handshake(DEFAULT_TIMEOUT).map_err(|e| match e {
                HostError::Timeout { .. } => anyhow::anyhow!(
                    "{e}: is a vistaf skin on {p}? (--no-handshake skips this check)"
                ),
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
        }
        clients.push(c);
    }
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
