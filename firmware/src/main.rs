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
    /// Fit a calibration from labelled frame sets.
    Calibrate(cmd::calibrate::Args),
    /// Run the service: source → pipeline → summaries on a serial link.
    Run(cmd::run::Args),
}

fn main() {
    let cli = Cli::parse();
    let result: Result<()> = match &cli.command {
        Cmd::Simulate(a) => cmd::simulate::run(a),
        Cmd::Record(a) => cmd::record::run(a),
        Cmd::Analyze(a) => cmd::analyze::run(a),
        Cmd::Calibrate(a) => cmd::calibrate::run(a),
        Cmd::Run(a) => cmd::run::run(a),
    };
    if let Err(e) = result {
        eprintln!("vistaf-skin: {}", causes(&e));
        std::process::exit(1);
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
