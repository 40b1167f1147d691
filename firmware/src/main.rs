//! `vistaf-skin`: the vistaf skin's device program.

use anyhow::Result;
use clap::{Parser, Subcommand};

mod cmd;

#[derive(Parser, Debug)]
#[command(
    name = "vistaf-skin",
    version,
    about = "Vision-based tactile and thermal skin: device program"
)]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Subcommand, Debug)]
enum Cmd {
    /// Render simulated frame sets, calibration kits, fixtures, or the montage.
    Simulate(cmd::simulate::Args),
    /// Record frames from a source into a frame set.
    Record(cmd::record::Args),
    /// Analyse frames against a reference: depth, area, volume, centre, force, flags.
    Analyze(cmd::analyze::Args),
    /// Fit a calibration from labelled frame sets, or capture the kit on this board in a
    /// guided session first (`--guided`).
    Calibrate(cmd::calibrate::Args),
    /// Run the service: source → pipeline → summaries on a serial link.
    Run(cmd::run::Args),
    /// List this machine's V4L2 nodes: path, driver name, USB serial (what
    /// `--source camera:PATH|camera-serial:S|camera-name:N` picks from).
    ListCameras,
}

/// Prints the machine's V4L2 nodes, one per line.
fn list_cameras() -> Result<()> {
    #[cfg(feature = "v4l")]
    {
        let nodes = vistaf_hardware::camera::list_nodes();
        if nodes.is_empty() {
            println!("no V4L2 nodes on this machine (/sys/class/video4linux is empty)");
        }
        for n in &nodes {
            println!("{}", vistaf_hardware::camera::describe(n));
        }
        Ok(())
    }
    #[cfg(not(feature = "v4l"))]
    anyhow::bail!("this vistaf-skin was built without V4L2 (feature v4l)")
}

fn main() {
    exit_on_any_panic();
    let cli = Cli::parse();
    let result: Result<()> = match &cli.command {
        Cmd::Simulate(a) => cmd::simulate::run(a),
        Cmd::Record(a) => cmd::record::run(a),
        Cmd::Analyze(a) => cmd::analyze::run(a),
        Cmd::Calibrate(a) => cmd::calibrate::run(a),
        Cmd::Run(a) => cmd::run::run(a),
        Cmd::ListCameras => list_cameras(),
    };
    if let Err(e) = result {
        // Every error says its cause once (in its message or as its source, never both),
        // so the chain reads as one sentence.
        eprintln!("vistaf-skin: {e:#}");
        std::process::exit(1);
    }
}

/// A panic in any thread (the capture or the link reader) ends the service with a non-zero
/// status, after the usual message, so systemd restarts it instead of leaving it running
/// without that thread.
fn exit_on_any_panic() {
    let report = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        report(info);
        std::process::exit(101);
    }));
}
