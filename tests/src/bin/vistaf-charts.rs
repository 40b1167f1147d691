//! Regenerates every speed-against-accuracy and stability chart and `docs/performance.md`:
//!
//! ```sh
//! cargo run --release -p vistaf-tests --bin vistaf-charts            # writes into docs/
//! cargo run --release -p vistaf-tests --bin vistaf-charts -- --instructions
//! ```
//!
//! `--instructions` adds instructions per frame under callgrind for each configuration
//! (valgrind must be installed; a few minutes more).

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Parser;
use vistaf_tests::charts::{plot, stability, tradeoff};

#[derive(Parser, Debug)]
#[command(about = "Speed against accuracy, and stability where methods fail")]
struct Args {
    /// Where the charts, CSV files and performance.md go.
    #[arg(long, default_value = "docs")]
    out: PathBuf,
    /// Also count instructions per frame with callgrind.
    #[arg(long)]
    instructions: bool,
}

fn bar(len: u64, msg: &str) -> indicatif::ProgressBar {
    let b = indicatif::ProgressBar::new(len);
    if let Ok(style) =
        indicatif::ProgressStyle::with_template("{msg:>12} [{bar:40}] {pos}/{len} {elapsed}")
    {
        b.set_style(style.progress_chars("=> "));
    }
    b.set_message(msg.to_string());
    b
}

fn machine() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|c| {
            c.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|s| s.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    format!("{cpu}, {cores} cores, {}", std::env::consts::ARCH)
}

fn main() -> Result<()> {
    let a = Args::parse();
    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;

    let b = bar(8, "stability");
    let sweeps = stability::sweeps(|d, _| b.set_position(d as u64));
    b.finish_and_clear();
    let mut checks = String::new();
    for s in &sweeps {
        plot::stability_chart(&a.out, s)?;
        let mut csv = String::from("x,error_over_tolerance,flagged\n");
        for p in &s.points {
            let _ = writeln!(csv, "{},{},{}", p.x, p.error, u8::from(p.flagged));
        }
        let path = a.out.join(format!("stability-{}.csv", s.name));
        std::fs::write(&path, csv).with_context(|| format!("writing {}", path.display()))?;
        let c = s.check();
        let _ = writeln!(
            checks,
            "| [{}](stability-{}.png) | {}–{} | {} | {} / {} ({:.0} %) | {} / {} ({:.1} %) | {} |",
            s.axis,
            s.name,
            s.envelope.0,
            s.envelope.1,
            s.error,
            c.out_flagged,
            c.out,
            100.0 * c.recall(),
            c.inside_flagged,
            c.inside,
            100.0 * c.false_rate(),
            if c.holds() { "holds" } else { "**fails**" }
        );
    }

    let b = bar(tradeoff::configs().len() as u64, "trade-off");
    let mut rows = tradeoff::measure(|d, _| b.set_position(d as u64));
    b.finish_and_clear();
    if a.instructions {
        count_instructions(&mut rows)?;
    }
    let use_instr = a.instructions
        && rows
            .iter()
            .all(|r| r.refused.is_some() || r.instructions.is_some());
    let front = tradeoff::pareto(&rows, |r| {
        if use_instr {
            r.instructions.map_or(f64::NAN, |i| i as f64)
        } else {
            r.ms
        }
    });
    plot::tradeoff_chart(&a.out, &rows, &front, use_instr)?;
    let mut csv = String::from(
        "config,ms_per_frame,instructions_per_frame,depth_error_over_tolerance,force_rmse_n,temperature_error_c,pareto,refused\n",
    );
    let mut table = String::new();
    for (i, r) in rows.iter().enumerate() {
        let on = front.contains(&i);
        let _ = writeln!(
            csv,
            "\"{}\",{:.3},{},{:.4},{:.4},{},{},{}",
            r.config.name.replace('"', "'"),
            r.ms,
            r.instructions.map_or(String::new(), |v| v.to_string()),
            r.depth_error,
            r.force_rmse_n,
            r.temperature_error_c
                .map_or(String::new(), |v| format!("{v:.4}")),
            u8::from(on),
            r.refused.clone().unwrap_or_default().replace(',', ";")
        );
        let _ = match &r.refused {
            Some(why) => writeln!(table, "| {} | refused: {why} | | | | | |", r.config.name),
            None => writeln!(
                table,
                "| {} | {:.2} | {} | {:.3} | {:.3} | {} | {} |",
                r.config.name,
                r.ms,
                r.instructions
                    .map_or("–".into(), |v| format!("{:.1} M", v as f64 / 1e6)),
                r.depth_error,
                r.force_rmse_n,
                r.temperature_error_c
                    .map_or("–".into(), |v| format!("{v:.3}")),
                if on { "yes" } else { "" }
            ),
        };
    }
    let path = a.out.join("tradeoff.csv");
    std::fs::write(&path, csv).with_context(|| format!("writing {}", path.display()))?;

    let doc = format!(
        include_str!("../charts/performance.md.in"),
        machine = machine(),
        tradeoff_table = table,
        checks_table = checks,
        seeds = stability::SEEDS,
        tradeoff_seeds = tradeoff::SEEDS,
    );
    let path = a.out.join("performance.md");
    std::fs::write(&path, doc).with_context(|| format!("writing {}", path.display()))?;
    eprintln!("wrote {} (charts, CSV, performance.md)", a.out.display());
    Ok(())
}

/// Builds the programs callgrind runs, beside this one and in its profile: a build of this
/// program alone (`cargo run --bin vistaf-charts`) leaves them missing or older than the
/// code they count (cargo does nothing when they are up to date).
fn build_siblings(exes: &[&std::path::Path]) -> Result<()> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut build = std::process::Command::new(cargo);
    build.args(["build", "-q", "-p", "vistaf-tests"]);
    if !cfg!(debug_assertions) {
        build.arg("--release");
    }
    for e in exes {
        if let Some(name) = e.file_name() {
            build.arg("--bin").arg(name);
        }
    }
    let status = build
        .status()
        .context("running cargo to build the counted programs")?;
    anyhow::ensure!(status.success(), "building the counted programs: {status}");
    Ok(())
}

/// Instructions per frame of each configuration: callgrind over `pipeline-frames` (or, for
/// a camera format, `camera-frames`: the device from the camera's bytes) with 1 and 11
/// frames, the difference over 10.
fn count_instructions(rows: &mut [tradeoff::Row]) -> Result<()> {
    let pipeline = std::env::current_exe()?.with_file_name("pipeline-frames");
    let camera = std::env::current_exe()?.with_file_name("camera-frames");
    build_siblings(&[&pipeline, &camera])?;
    let b = bar(rows.len() as u64, "callgrind");
    for (k, r) in rows.iter_mut().enumerate() {
        b.set_position(k as u64);
        if r.refused.is_some() {
            continue;
        }
        let c = &r.config;
        let args = |n: usize| -> Vec<String> {
            if c.encoding != vistaf_hardware::encode::Encoding::Rgb {
                return [
                    c.encoding.to_string(),
                    "640".into(),
                    "480".into(),
                    n.to_string(),
                ]
                .into();
            }
            [
                if c.imp == vistaf_pipeline::Implementation::Float {
                    "float"
                } else {
                    "fixed"
                },
                &n.to_string(),
                "640",
                "480",
                "press",
                if c.temperature {
                    "with-temperature"
                } else {
                    "no-temperature"
                },
                &c.factor.map_or("auto".into(), |f| f.to_string()),
                if c.band == vistaf_pipeline::ftp::band::BandWindow::Hann {
                    "hann"
                } else {
                    "matched"
                },
                match c.unwrap {
                    vistaf_pipeline::measure::Unwrap::Always => "always",
                    vistaf_pipeline::measure::Unwrap::Never => "never",
                    vistaf_pipeline::measure::Unwrap::WhenNeeded => "when-needed",
                },
                if c.rows_only { "rows" } else { "2d" },
            ]
            .map(String::from)
            .into()
        };
        let exe = if c.encoding == vistaf_hardware::encode::Encoding::Rgb {
            &pipeline
        } else {
            &camera
        };
        let ir = |n: usize| -> Result<u64> {
            let out = std::process::Command::new("valgrind")
                .args(["--tool=callgrind", "--callgrind-out-file=/dev/null"])
                .arg(exe)
                .args(args(n))
                .output()
                .context("running valgrind (is it installed?)")?;
            let text = String::from_utf8_lossy(&out.stderr);
            text.lines()
                .find_map(|l| l.split("Collected : ").nth(1))
                .and_then(|v| v.trim().parse().ok())
                .ok_or_else(|| anyhow::anyhow!("callgrind printed no count for {}", c.name))
        };
        r.instructions = Some((ir(11)?.saturating_sub(ir(1)?)) / 10);
    }
    b.finish_and_clear();
    Ok(())
}
