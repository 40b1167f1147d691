//! Every command of the README and the docs runs as written.
//!
//! The commands are the lines of the fenced `sh` blocks of `README.md`, `docs/*.md` and
//! `firmware/deploy/*.md` (a `\` at a line's end continues it; `# …` after a command is
//! its comment). Each runs under `bash -o pipefail -c`, in a folder of its own document
//! (so a block's later commands see what its earlier ones wrote), with `vistaf-skin`,
//! `vistaf-host` and `vistaf-demo` on the `PATH` as built for this run, and must succeed;
//! `cargo run [--release] -p PACKAGE [--bin BINARY] -- ARGS` runs that binary as built for
//! this run (the command without a second build).
//!
//! The hardware a command names is the simulated skin's ([`Bench::substitute`]):
//! `/dev/ttyACM0` and `/dev/ttyACM1` are pseudo-terminals with a simulated skin on their
//! other end, `/dev/ttyGS0` (the board's gadget serial) a pseudo-terminal this test reads,
//! `camera:/dev/video0` a simulated scene, `/tmp/` and `/etc/vistaf/` the document's folder,
//! and the TCP port `7000` a free one.
//! Files a command takes as already there (a captured stream, the paper's results table,
//! a recorded kit) are put there first ([`prepare`]).
//!
//! A command that runs until stopped (a monitor, a service, a live recording) must show
//! what it is for ([`UNTIL_STOPPED`]) and is then stopped; one that asks at a terminal is
//! answered ([`ANSWERED`]). A command that cannot run here says why in [`NOT_RUN`], and
//! what can be checked is: its script exists and parses (`bash -n`), its binary's
//! arguments parse (`--help` after them). An entry of any table that no document has any
//! more fails the test, so the tables cannot go stale.
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

use std::collections::BTreeSet;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use serialport::{SerialPort, TTYPort};
use vistaf_firmware::service::{pty, Settings};
use vistaf_firmware::source_spec::{open_with_bench, OpenOptions};
use vistaf_pipeline::calibration::Calibration;

/// Commands that cannot run in a test, each with why; what is checked instead is in
/// [`check_not_run`].
const NOT_RUN: &[(&str, &str)] = &[
    (
        "bash scripts/install-deps.sh && cargo test --workspace --features vistaf-host/ros2",
        "the command that runs this test",
    ),
    (
        "bash scripts/install-deps.sh",
        "runs before the tests (.ci/run)",
    ),
    (
        "cargo run --release -p vistaf-tests --bin vistaf-charts -- --instructions",
        "minutes of callgrind",
    ),
    (
        "cargo run --release -p vistaf-tests --bin vistaf-charts",
        "minutes of sweeps (the charts' code is tested in vistaf-tests)",
    ),
    (
        "cargo run --release -p vistaf-tests --bin vistaf-accuracy -- --units 40",
        "minutes of units (tests/accuracy.rs runs the battery on 3)",
    ),
    (
        "bash scripts/package.sh aarch64-unknown-linux-gnu",
        "a cross build of the board's package",
    ),
    (
        "bash scripts/bridge-demo.sh",
        "a release build of its own; the bridge to DDS and MCAP read back by their own \
         readers are host/tests/ros2_interop.rs and python_interop.rs",
    ),
    (
        "scp target/debian/vistaf-skin_*_arm64.deb pi@skin.local:",
        "a board on the network",
    ),
    (
        "sudo apt install ./vistaf-skin_*_arm64.deb",
        "on the board, as root",
    ),
    ("sudo systemctl stop vistaf-skin", "on the board, as root"),
    (
        "sudo -u vistaf vistaf-skin calibrate --guided --config /etc/vistaf/skin.toml \
         --calibration /var/lib/vistaf/calibration.json",
        "on the board, as its service's user (the same session on sim:bench is in \
         docs/calibration.md)",
    ),
    ("sudo systemctl start vistaf-skin", "on the board, as root"),
];

/// What a command that runs until stopped must have shown before it is stopped.
#[derive(Debug, Clone, Copy)]
enum Shows {
    /// Its standard output or its standard error has this.
    Says(&'static str),
    /// This file (in the document's folder) has at least this many lines.
    Lines(&'static str, usize),
    /// Bytes arrived on the board's gadget serial.
    Gadget,
}

/// Commands that run until stopped, and what each must show first.
const UNTIL_STOPPED: &[(&str, Shows)] = &[
    (
        "vistaf-host monitor /dev/ttyACM0 /dev/ttyACM1",
        Shows::Says("VSK-DOC1"),
    ),
    ("vistaf-host monitor /dev/ttyACM0", Shows::Says("VSK-DOC0")),
    (
        "vistaf-host monitor /dev/ttyACM0 --map temperature",
        Shows::Says("temperature 20 to 40 °C, frame"),
    ),
    (
        "vistaf-host monitor tcp:127.0.0.1:7000",
        Shows::Says("VSK-DOC0"),
    ),
    (
        "vistaf-host record /dev/ttyACM0 --out run.csv",
        Shows::Lines("run.csv", 5),
    ),
    (
        "vistaf-host bridge /dev/ttyACM0 --mcap run.mcap --jsonl -",
        Shows::Says("\"summary\""),
    ),
    (
        "vistaf-host bridge /dev/ttyACM0 /dev/ttyACM1 --ros2 --mcap run.mcap --jsonl -",
        Shows::Says("\"summary\""),
    ),
    (
        "vistaf-host bridge /dev/ttyACM0 --ros2 --serve 127.0.0.1:7000 &",
        Shows::Says("served on tcp:127.0.0.1:7000"),
    ),
    (
        "vistaf-skin run --config /etc/vistaf/skin.toml",
        Shows::Gadget,
    ),
    (
        "vistaf-skin run --source sim:demo --link serial:/dev/ttyGS0 --fps 30",
        Shows::Gadget,
    ),
];

/// Commands that ask at a terminal: what is typed, and what they must have said.
const ANSWERED: &[(&str, &str, &str)] = &[
    (
        "vistaf-host calibrate /dev/ttyACM0",
        "q\n",
        "[1/93] leave the skin untouched",
    ),
    (
        "vistaf-skin calibrate --guided --source sim:bench --unit-seed 3 \
         --calibration calibration.json",
        "q\n",
        "[1/93] leave the skin untouched",
    ),
    (
        "vistaf-skin calibrate --guided --source sim:bench --calibration guided.json",
        "\nq\n",
        "captured reference 25.000 °C",
    ),
];

/// How long one command may take.
const TIMEOUT: Duration = Duration::from_secs(300);

/// How long a command that runs until stopped may take to show what it is for.
const SHOWN_WITHIN: Duration = Duration::from_secs(60);

/// A document's runnable blocks, each a list of commands.
fn blocks(text: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    let mut block: Option<Vec<String>> = None;
    let mut pending = String::new();
    for line in text.lines() {
        let fence = line.trim_start().starts_with("```");
        match (&mut block, fence) {
            (None, true) if line.trim() == "```sh" => block = Some(Vec::new()),
            (Some(_), true) => out.push(block.take().unwrap_or_default()),
            (Some(b), false) => {
                let code = strip_comment(line);
                if let Some(head) = code.trim_end().strip_suffix('\\') {
                    pending.push_str(head.trim());
                    pending.push(' ');
                    continue;
                }
                pending.push_str(code.trim());
                let cmd = std::mem::take(&mut pending).trim().to_string();
                if !cmd.is_empty() {
                    b.push(cmd);
                }
            }
            _ => {}
        }
    }
    out
}

/// `line` without a `# comment` (a `#` after a blank, outside quotes).
fn strip_comment(line: &str) -> &str {
    let (mut single, mut double, mut prev_blank) = (false, false, true);
    for (i, c) in line.char_indices() {
        match c {
            '\'' if !double => single = !single,
            '"' if !single => double = !double,
            '#' if !single && !double && prev_blank => return &line[..i],
            _ => {}
        }
        prev_blank = c.is_whitespace();
    }
    line
}

/// The documents whose commands are run, relative to the workspace.
fn documents(root: &Path) -> Vec<PathBuf> {
    let mut docs = vec![root.join("README.md")];
    for dir in ["docs", "firmware/deploy"] {
        let mut md: Vec<PathBuf> = std::fs::read_dir(root.join(dir))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "md"))
            .collect();
        md.sort();
        docs.extend(md);
    }
    docs
}

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

/// The folder of this run's binaries, built if a test run did not build them (a test run
/// of the workspace builds every binary a package's tests run).
fn binaries() -> PathBuf {
    let dir = std::env::current_exe()
        .unwrap()
        .parent()
        .and_then(Path::parent)
        .unwrap()
        .to_path_buf();
    let names = ["vistaf-skin", "vistaf-host", "vistaf-demo"];
    if names.iter().any(|n| !dir.join(n).exists()) {
        let status = Command::new(env!("CARGO"))
            .current_dir(workspace())
            .args(["build", "--bins", "-p", "vistaf-firmware"])
            .args(["-p", "vistaf-host", "-p", "vistaf-demo"])
            .status()
            .unwrap();
        assert!(status.success(), "building the binaries: {status}");
    }
    dir
}

/// The simulated hardware the commands' device paths stand for.
struct Bench {
    skins: Vec<(String, Arc<AtomicBool>)>,
    gadget: TTYPort,
    gadget_path: String,
    /// A free port of this machine, for the documents' `127.0.0.1:7000`.
    tcp_port: u16,
}

impl Bench {
    fn new() -> Bench {
        let skins = (0..2)
            .map(|i| {
                let opts = OpenOptions {
                    fps: Some(10.0),
                    looping: true,
                    sim_frames: 90,
                    unit_seed: 0,
                    ..OpenOptions::default()
                };
                let (source, _) = open_with_bench(&"sim:demo".parse().unwrap(), &opts).unwrap();
                let settings = Settings {
                    serial: format!("VSK-DOC{i}"),
                    ..Settings::new(Calibration::default_sim())
                };
                let on = pty::spawn(source, settings).unwrap();
                (on.port, on.stop)
            })
            .collect();
        let (gadget, slave) = TTYPort::pair().unwrap();
        let gadget_path = slave.name().unwrap();
        // The slave stays open here, so the master reads nothing but what a command sends.
        std::mem::forget(slave);
        let tcp_port = std::net::TcpListener::bind("127.0.0.1:0")
            .and_then(|l| l.local_addr())
            .map(|a| a.port())
            .unwrap();
        Bench {
            skins,
            gadget,
            gadget_path,
            tcp_port,
        }
    }

    /// `text` with the hardware's paths replaced by the simulated skin's, the system's
    /// folders by `folder`'s, and the documents' TCP port by a free one.
    fn substitute(&self, text: &str, folder: &Path) -> String {
        let f = folder.display();
        text.replace("/dev/ttyACM0", &self.skins[0].0)
            .replace("/dev/ttyACM1", &self.skins[1].0)
            .replace("/dev/ttyGS0", &self.gadget_path)
            .replace("camera:/dev/video0", "sim:demo")
            .replace("127.0.0.1:7000", &format!("127.0.0.1:{}", self.tcp_port))
            .replace("/tmp/", &format!("{f}/tmp/"))
            .replace("/etc/vistaf/", &format!("{f}/etc/"))
    }

    /// Throws away what earlier commands sent on the gadget serial.
    fn drain_gadget(&mut self) {
        while self.gadget_hears(Duration::from_millis(100)) {}
    }

    /// Whether bytes arrive on the gadget serial within `wait`.
    fn gadget_hears(&mut self, wait: Duration) -> bool {
        let _ = self.gadget.set_timeout(wait);
        let mut buf = [0u8; 256];
        matches!(self.gadget.read(&mut buf), Ok(n) if n > 0)
    }
}

impl Drop for Bench {
    fn drop(&mut self) {
        for (_, stop) in &self.skins {
            stop.store(true, Ordering::Relaxed);
        }
    }
}

/// Puts in `folder` what `commands` take as already there: the service's configuration, a
/// captured stream, the paper's per-image results, a recorded kit.
fn prepare(folder: &Path, commands: &[String], bench: &Bench, bin: &Path) {
    let any = |s: &str| commands.iter().any(|c| c.contains(s));
    std::fs::create_dir_all(folder.join("tmp")).unwrap();
    std::fs::create_dir_all(folder.join("etc")).unwrap();
    let root = workspace();
    let config = std::fs::read_to_string(root.join("firmware/deploy/skin.toml")).unwrap();
    std::fs::write(
        folder.join("etc/skin.toml"),
        bench.substitute(&config, folder),
    )
    .unwrap();
    if any("per_image_results.csv") {
        std::fs::copy(
            root.join(
                "../shared/reference-data/vistaf/Force/Height_to_force/calibration_out/\
             per_image_results.csv",
            ),
            folder.join("per_image_results.csv"),
        )
        .unwrap();
    }
    if any("capture.bin") {
        let cmd =
            "vistaf-skin run --source sim:press-sphere --sim-frames 30 --link file:capture.bin";
        run_ok(bin, folder, cmd);
    }
    if any("--set depth ") {
        run_ok(
            bin,
            folder,
            "vistaf-skin simulate --calibration-kit --out .",
        );
    }
}

/// A shell running `cmd` in `folder` with this run's binaries first on the path.
fn shell(bin: &Path, folder: &Path, cmd: &str) -> Command {
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let mut c = Command::new("bash");
    c.args(["-o", "pipefail", "-c", cmd])
        .current_dir(folder)
        .env("PATH", path)
        .env("NO_COLOR", "1");
    c
}

/// Runs `cmd` to its end, checking it succeeded in time.
fn run_ok(bin: &Path, folder: &Path, cmd: &str) {
    let child = shell(bin, folder, cmd)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let (ok, stdout, stderr) = finish(child, TIMEOUT);
    assert!(ok, "`{cmd}` in {}:\n{stdout}\n{stderr}", folder.display());
}

/// Waits for `child` up to `limit`: whether it succeeded, its output and its errors.
fn finish(mut child: Child, limit: Duration) -> (bool, String, String) {
    let mut out = child.stdout.take().unwrap();
    let mut err = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = out.read_to_string(&mut s);
        s
    });
    let errors = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = err.read_to_string(&mut s);
        s
    });
    let end = Instant::now() + limit;
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break Some(s);
        }
        if Instant::now() > end {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let (stdout, stderr) = (reader.join().unwrap(), errors.join().unwrap());
    (status.is_some_and(|s| s.success()), stdout, stderr)
}

/// Whether this host was built with ROS 2 (`--features vistaf-host/ros2`, as CI builds it).
fn host_has_ros2(out: &str) -> bool {
    !out.contains("built without ROS 2")
}

/// Sends SIGINT to `child` (as Ctrl-C would), then kills it if it has not ended.
fn interrupt(child: &mut Child) {
    if let Ok(Some(_)) = child.try_wait() {
        return;
    }
    let _ = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .stderr(Stdio::null())
        .status();
    let end = Instant::now() + Duration::from_secs(5);
    while Instant::now() < end {
        if let Ok(Some(_)) = child.try_wait() {
            return;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let _ = child.kill();
    let _ = child.wait();
}

/// A command running until stopped, its output gathered as it comes.
struct Running {
    child: Child,
    stdout: Arc<std::sync::Mutex<String>>,
    stderr: Arc<std::sync::Mutex<String>>,
}

impl Running {
    fn start(bin: &Path, folder: &Path, cmd: &str) -> Running {
        let mut child = shell(bin, folder, &format!("exec {cmd}"))
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let gather = |mut r: Box<dyn Read + Send>| {
            let buf = Arc::new(std::sync::Mutex::new(String::new()));
            let into = buf.clone();
            std::thread::spawn(move || {
                let mut chunk = [0u8; 4096];
                while let Ok(n) = r.read(&mut chunk) {
                    if n == 0 {
                        break;
                    }
                    into.lock()
                        .unwrap()
                        .push_str(&String::from_utf8_lossy(&chunk[..n]));
                }
            });
            buf
        };
        let stdout = gather(Box::new(child.stdout.take().unwrap()));
        let stderr = gather(Box::new(child.stderr.take().unwrap()));
        Running {
            child,
            stdout,
            stderr,
        }
    }

    /// Waits until `shows` holds; an error naming what it said if it ends first or does
    /// not show it in time.
    fn wait_for(&mut self, shows: Shows, folder: &Path, bench: &mut Bench) -> Result<(), String> {
        let end = Instant::now() + SHOWN_WITHIN;
        loop {
            let shown = match shows {
                Shows::Says(s) => {
                    let s = bench.substitute(s, folder);
                    self.stdout.lock().unwrap().contains(&s)
                        || self.stderr.lock().unwrap().contains(&s)
                }
                Shows::Lines(f, n) => {
                    std::fs::read_to_string(folder.join(f)).is_ok_and(|t| t.lines().count() >= n)
                }
                Shows::Gadget => bench.gadget_hears(Duration::from_millis(200)),
            };
            if shown {
                return Ok(());
            }
            let ended = self.child.try_wait().unwrap();
            if ended.is_some() || Instant::now() > end {
                return Err(format!(
                    "{} before showing {shows:?}:\n{}\n{}",
                    ended.map_or("timed out".to_string(), |s| format!("ended ({s})")),
                    self.stdout.lock().unwrap(),
                    self.stderr.lock().unwrap()
                ));
            }
            std::thread::sleep(Duration::from_millis(100));
        }
    }
}

impl Drop for Running {
    /// Stops the command, as Ctrl-C would, whether the test goes on or failed.
    fn drop(&mut self) {
        interrupt(&mut self.child);
    }
}

/// `cargo run [--release] -p PACKAGE [--bin BINARY] [-- ARGS]` as the binary it runs and
/// its arguments (the binary as this test run built it, so nothing is compiled again).
fn cargo_run(cmd: &str) -> Option<(String, String)> {
    let rest = cmd.strip_prefix("cargo run ")?;
    let (opts, args) = rest.split_once(" -- ").unwrap_or((rest, ""));
    let words: Vec<&str> = opts.split_whitespace().collect();
    let after = |flag: &str| {
        let i = words.iter().position(|w| *w == flag)?;
        words.get(i + 1).map(|w| w.to_string())
    };
    Some((after("--bin").or_else(|| after("-p"))?, args.to_string()))
}

/// What `check_not_run` verifies of a command that cannot run: a script exists and
/// parses; a binary's arguments parse (run through cargo, or as another user).
fn check_not_run(bin: &Path, root: &Path, cmd: &str) {
    for part in cmd.split("&&").map(str::trim) {
        let words: Vec<&str> = part.split_whitespace().collect();
        match words.as_slice() {
            ["bash", script, ..] => {
                let status = Command::new("bash")
                    .args(["-n", script])
                    .current_dir(root)
                    .status()
                    .unwrap();
                assert!(status.success(), "`{part}`: {script} does not parse");
            }
            ["sudo", "-u", _, program, args @ ..] if bin.join(program).exists() => {
                parses(&bin.join(program), &args.join(" "), part);
            }
            ["cargo", "run", ..] => {
                let (name, args) = cargo_run(part).unwrap();
                parses(&bin.join(&name), &args, part);
            }
            _ => {}
        }
    }
}

/// Asserts `exe` accepts `args` (asked for its help with them), for the command `part`.
fn parses(exe: &Path, args: &str, part: &str) {
    let out = Command::new(exe)
        .args(args.split_whitespace())
        .arg("--help")
        .output()
        .unwrap_or_else(|e| panic!("`{part}`: {}: {e}", exe.display()));
    assert!(
        out.status.success(),
        "`{part}`: its arguments do not parse: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// How a command went (a failure panics, naming the command).
enum Ran {
    /// It did what it is for.
    Done,
    /// It runs on in the background (`… &`) until its document's commands are done.
    Background(Running),
    /// It needs ROS 2 and this host was built without (the rest of its block depends on it).
    NoRos2,
}

/// Runs `cmd` of a document (`at` names both) in `folder`.
fn run_command(at: &str, cmd: &str, bin: &Path, folder: &Path, bench: &mut Bench) -> Ran {
    if NOT_RUN.iter().any(|(c, _)| *c == cmd) {
        check_not_run(bin, &workspace(), cmd);
        return Ran::Done;
    }
    let real = match cargo_run(cmd) {
        Some((name, args)) => format!("{name} {args}"),
        None => bench.substitute(cmd, folder),
    };
    if let Some((_, shows)) = UNTIL_STOPPED.iter().find(|(c, _)| *c == cmd) {
        if matches!(shows, Shows::Gadget) {
            bench.drain_gadget();
        }
        let mut r = Running::start(bin, folder, real.trim_end_matches('&').trim());
        match r.wait_for(*shows, folder, bench) {
            Ok(()) if cmd.ends_with('&') => return Ran::Background(r),
            Ok(()) => return Ran::Done,
            Err(e) if !host_has_ros2(&e) => return Ran::NoRos2,
            Err(e) => panic!("{at}: {e}"),
        }
    }
    if let Some((_, typed, said)) = ANSWERED.iter().find(|(c, _, _)| *c == cmd) {
        let mut child = shell(bin, folder, &real)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        use std::io::Write;
        let mut stdin = child.stdin.take().unwrap();
        stdin.write_all(typed.as_bytes()).unwrap();
        drop(stdin);
        let (_, stdout, stderr) = finish(child, TIMEOUT);
        assert!(stdout.contains(said), "{at}: said\n{stdout}\n{stderr}");
        return Ran::Done;
    }
    run_ok(bin, folder, &real);
    Ran::Done
}

/// Runs one document's commands, block by block, in a folder of its own; the commands
/// go into `seen`, for the tables' check.
fn run_document(doc: &Path, bin: &Path, bench: &mut Bench, seen: &mut BTreeSet<String>) {
    let text = std::fs::read_to_string(doc).unwrap();
    let blocks = blocks(&text);
    let commands: Vec<String> = blocks.iter().flatten().cloned().collect();
    if commands.is_empty() {
        return;
    }
    let name = doc.file_stem().unwrap().to_string_lossy().to_string();
    let folder = std::env::temp_dir().join(format!("vistaf-docs-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&folder);
    std::fs::create_dir_all(&folder).unwrap();
    prepare(&folder, &commands, bench, bin);
    let mut background = Vec::new();
    for block in &blocks {
        let mut skipping = false;
        for cmd in block {
            seen.insert(cmd.clone());
            let at = format!("{}: `{cmd}`", doc.display());
            if skipping {
                eprintln!("{at}: skipped (this vistaf-host has no ROS 2)");
                continue;
            }
            eprintln!("{at}");
            match run_command(&at, cmd, bin, &folder, bench) {
                Ran::Done => {}
                Ran::Background(r) => background.push(r),
                Ran::NoRos2 => skipping = true,
            }
        }
    }
    drop(background);
    let _ = std::fs::remove_dir_all(&folder);
}

#[test]
fn every_command_of_the_readme_and_the_docs_runs_as_written() {
    let bin = binaries();
    let mut bench = Bench::new();
    let mut seen = BTreeSet::new();
    for doc in documents(&workspace()) {
        run_document(&doc, &bin, &mut bench, &mut seen);
    }
    let stale: Vec<&str> = NOT_RUN
        .iter()
        .map(|(c, _)| *c)
        .chain(UNTIL_STOPPED.iter().map(|(c, _)| *c))
        .chain(ANSWERED.iter().map(|(c, _, _)| *c))
        .filter(|c| !seen.contains(*c))
        .collect();
    assert!(
        stale.is_empty(),
        "no document has these commands any more: {stale:?}"
    );
}

#[test]
fn commands_are_read_with_their_continuations_and_without_comments() {
    let text = "x\n```sh\na --b \\\n  c   # what it does\n\necho '# kept' # gone\n```\n```text\nnot run\n```\n";
    assert_eq!(
        blocks(text),
        [vec!["a --b c".to_string(), "echo '# kept'".to_string()]]
    );
}
