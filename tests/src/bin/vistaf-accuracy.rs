//! The accuracy battery on units drawn wide, each calibrated on its own kit and measured
//! blind (see `vistaf_tests::accuracy`), written to `docs/accuracy.md`:
//!
//! ```sh
//! cargo run --release -p vistaf-tests --bin vistaf-accuracy -- --units 40
//! ```
//!
//! Seeds from [`HELD_OUT`] on are held out: no method is tuned on them. Development runs
//! use `--first 1` (or any seed below it).

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Parser;
use vistaf_sim::sets::write_calibration_kit;
use vistaf_sim::SensorUnit;
use vistaf_tests::accuracy::{
    frames_csv, kit_options, layer_decay, report, run_units, without, write_scenes, Camera, EFFECTS,
};

/// First held-out unit seed.
const HELD_OUT: u64 = 900_000;

#[derive(Parser, Debug)]
#[command(about = "Accuracy and silent failures on units drawn wide, calibrated on their own kits")]
struct Args {
    /// How many units.
    #[arg(long, default_value_t = 40)]
    units: u64,
    /// First unit seed (held-out seeds start at 900000).
    #[arg(long, default_value_t = HELD_OUT)]
    first: u64,
    /// Where the report goes (`-` for standard output only).
    #[arg(long, default_value = "docs/accuracy.md")]
    out: PathBuf,
    /// Effects to switch off, comma-separated (to find which one a failure needs): oblique,
    /// glare, vignetting, white-balance, mottle, wobble, distortion, phase-shape, jpeg,
    /// chromatic (the lens's lateral chromatic aberration), drift, shading, stripe-edges
    /// (the stripes made nearly sinusoidal), layer (the skin a half-space: its surface does
    /// not return to rest faster than `1/r` around a contact).
    #[arg(long, value_delimiter = ',')]
    without: Vec<String>,
    /// Every unit's layer drawn with this decay instead, mm (`inf`: a half-space, as
    /// `--without layer`): how far from a contact the skin's surface returns to rest.
    #[arg(long)]
    layer_decay_mm: Option<f32>,
    /// Write the calibration kit of the first unit here and stop (to calibrate it with
    /// `vistaf-skin calibrate` and look closer).
    #[arg(long)]
    write_kit: Option<PathBuf>,
    /// With `--write-kit`: also write the first unit's scored scenes there, as the frame set
    /// `scenes`: the battery's frames, reference and noise as it renders them, in its order.
    /// `vistaf-skin analyze` with the kit's calibration reads each as the battery scored it.
    #[arg(long, requires = "write_kit")]
    write_scenes: bool,
    /// Also write every scored frame here as CSV (indenter, truth, errors, flags).
    #[arg(long)]
    frames: Option<PathBuf>,
    /// Worker threads.
    #[arg(long, default_value_t = 2)]
    jobs: usize,
    /// The camera every unit sends from: ENCODING or ENCODING@WxH, e.g.
    /// `mjpeg:90@1280x720` (the unit's optics, another sensor size and format). Default:
    /// lossless, the unit's size.
    #[arg(long, default_value = "rgb")]
    camera: Camera,
}

fn main() -> Result<()> {
    let mut args = Args::parse();
    if let Some(bad) = args.without.iter().find(|e| !EFFECTS.contains(&e.as_str())) {
        anyhow::bail!(
            "--without: no effect named {bad:?} (known: {})",
            EFFECTS.join(", ")
        );
    }
    if let Some(decay_mm) = args.layer_decay_mm {
        if decay_mm.is_nan() || decay_mm <= 0.0 {
            anyhow::bail!("--layer-decay-mm: {decay_mm} is not a length above 0 mm");
        }
        args.without.push(layer_decay(decay_mm));
    }
    if let Some(dir) = &args.write_kit {
        let unit = args
            .camera
            .unit(without(SensorUnit::wide(args.first), &args.without));
        let opts = kit_options(args.first, args.camera, true);
        write_calibration_kit(dir, &unit, &opts, |_, _, _| {})
            .with_context(|| format!("writing the kit into {}", dir.display()))?;
        if args.write_scenes {
            let scenes = dir.join("scenes");
            write_scenes(&scenes, args.first, &unit, &args.without, &opts)
                .with_context(|| format!("writing the scenes into {}", scenes.display()))?;
        }
        println!("{unit:#?}");
        return Ok(());
    }
    let seeds: Vec<u64> = (args.first..args.first.saturating_add(args.units)).collect();
    let work = std::env::temp_dir().join(format!("vistaf-accuracy-{}", std::process::id()));
    let bar = indicatif::ProgressBar::new(seeds.len() as u64);
    let results = run_units(&seeds, &work, args.jobs, &args.without, args.camera, |_| {
        bar.inc(1)
    });
    bar.finish_and_clear();
    let _ = std::fs::remove_dir_all(&work);
    if let Some(path) = &args.frames {
        std::fs::write(path, frames_csv(&results))
            .with_context(|| format!("writing {}", path.display()))?;
    }
    let body = report(&results);
    let held = if args.first >= HELD_OUT {
        "held-out"
    } else {
        "development"
    };
    // The command as given: the effects switched off and the layer drawn otherwise too.
    let mut options = String::new();
    if args.camera != Camera::default() {
        options += &format!(" --camera {}", args.camera);
    }
    let off: Vec<&str> = args
        .without
        .iter()
        .map(String::as_str)
        .filter(|e| EFFECTS.contains(e))
        .collect();
    if !off.is_empty() {
        options += &format!(" --without {}", off.join(","));
    }
    if let Some(decay_mm) = args.layer_decay_mm {
        options += &format!(" --layer-decay-mm {decay_mm}");
    }
    let doc = format!(
        "# Accuracy on units drawn wide\n\n\
         Regenerated by `cargo run --release -p vistaf-tests --bin vistaf-accuracy -- --units {} --first {}{options}` \
         ({held} seeds {}–{}). Each unit is drawn by `SensorUnit::wide` (every imperfection of \
         `vistaf_sim::imperfections`), calibrated on its own kit and measured blind; tolerances \
         and definitions are those of `vistaf_tests::accuracy`.\n\n{body}",
        args.units,
        args.first,
        args.first,
        args.first + args.units.saturating_sub(1),
    );
    print!("{doc}");
    if args.out.as_os_str() != "-" {
        std::fs::write(&args.out, &doc)
            .with_context(|| format!("writing {}", args.out.display()))?;
    }
    Ok(())
}
