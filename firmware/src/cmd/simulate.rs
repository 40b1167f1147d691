//! `vistaf-skin simulate`: simulated frame sets, calibration kits, fixtures and the montage.

use std::path::{Path, PathBuf};

use anyhow::{anyhow, Context, Result};
use image::RgbImage;
use vistaf_hardware::encode::Encoding;
use vistaf_sim::{scene, sets, Renderer, SensorUnit, SkinState};

use super::progress;

/// What to simulate.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Scene to render (see --list).
    #[arg(long, required_unless_present_any = ["calibration_kit", "fixtures", "montage", "list"])]
    pub scene: Option<String>,
    /// Output directory (a frame set, or the kit's parent directory).
    #[arg(long, required_unless_present_any = ["fixtures", "montage", "list"])]
    pub out: Option<PathBuf>,
    /// Frames to render.
    #[arg(long, default_value_t = 20)]
    pub frames: usize,
    /// Noise seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Sensor unit to draw (0 = the reference build).
    #[arg(long, default_value_t = 0)]
    pub unit_seed: u64,
    /// Override the unit's image width, pixels (keeps its period in pixels).
    #[arg(long)]
    pub width: Option<u32>,
    /// Override the unit's image height, pixels.
    #[arg(long)]
    pub height: Option<u32>,
    /// Override the unit's grating period in the image, pixels (a camera of more pixels
    /// behind the same optics sees a coarser grating).
    #[arg(long)]
    pub period_px: Option<f32>,
    /// How frames are written: rgb (PNG), yuyv (raw, as a UVC camera sends it at small
    /// sizes) or mjpeg:QUALITY (4:2:2 JPEG, as it sends larger ones).
    #[arg(long, default_value = "rgb", value_name = "rgb|yuyv|mjpeg:Q")]
    pub encode: Encoding,
    /// Do not write 16-bit truth maps.
    #[arg(long)]
    pub no_truth: bool,
    /// Write the three calibration sets (depth/, force/, temperature/) under --out.
    #[arg(long)]
    pub calibration_kit: bool,
    /// Regenerate the committed fixture corpus in this directory.
    #[arg(long, value_name = "DIR")]
    pub fixtures: Option<PathBuf>,
    /// Write a montage of representative frames to this PNG.
    #[arg(long, value_name = "PNG")]
    pub montage: Option<PathBuf>,
    /// List the scenes.
    #[arg(long)]
    pub list: bool,
}

fn unit_of(a: &Args) -> SensorUnit {
    let mut u = SensorUnit::from_seed(a.unit_seed);
    if let Some(w) = a.width {
        u.width_px = w;
    }
    if let Some(h) = a.height {
        u.height_px = h;
    }
    if let Some(p) = a.period_px {
        u.period_px = p;
    }
    u
}

/// Runs the command.
pub fn run(a: &Args) -> Result<()> {
    if a.list {
        for (name, what) in scene::SCENES {
            println!("{name:16} {what}");
        }
        return Ok(());
    }
    if let Some(dir) = &a.fixtures {
        return fixtures(dir);
    }
    if let Some(png) = &a.montage {
        return montage(png);
    }
    let out = a.out.as_ref().ok_or_else(|| anyhow!("--out is required"))?;
    let unit = unit_of(a);
    if unit.width_px < 64 || unit.height_px < 48 {
        anyhow::bail!(
            "image size {}×{} is too small (at least 64×48)",
            unit.width_px,
            unit.height_px
        );
    }
    let opts = sets::SetOptions {
        truth_maps: !a.no_truth,
        seed: a.seed,
        unit_seed: a.unit_seed,
        encoding: a.encode,
    };
    if a.calibration_kit {
        let pb = progress(0, "kit");
        let kit = sets::write_calibration_kit(out, &unit, &opts, |what, i, n| {
            pb.set_message(what.to_string());
            pb.set_length(n as u64);
            pb.set_position(i as u64);
        })?;
        pb.finish_and_clear();
        for s in &kit {
            println!("{}: {} frames", s.dir().display(), s.len());
        }
        return Ok(());
    }
    let name = a
        .scene
        .as_deref()
        .ok_or_else(|| anyhow!("--scene is required"))?;
    let states = scene::states(name, &unit, a.frames).ok_or_else(|| {
        let names: Vec<&str> = scene::SCENES.iter().map(|s| s.0).collect();
        anyhow!("unknown scene {name:?}; scenes: {}", names.join(", "))
    })?;
    let pb = progress(states.len() as u64, name);
    let set = sets::write_states(out, name, &unit, &states, &opts, |i, _| {
        pb.set_position(i as u64)
    })?;
    pb.finish_and_clear();
    println!(
        "{}: {} frames of {name}, {}×{} px",
        set.dir().display(),
        set.len(),
        unit.width_px,
        unit.height_px
    );
    Ok(())
}

/// The fixture corpus: small sets (320×240, reference unit) that end-to-end tests replay.
pub const FIXTURES: &[(&str, &str, usize)] = &[
    ("idle", "idle", 3),
    ("press-sphere", "sweep-depth", 4),
    ("letter-e", "letter-e", 2),
    ("heated-nut", "heated-nut", 2),
    ("misregistered", "misregistered", 3),
];

fn fixtures(dir: &Path) -> Result<()> {
    let unit = SensorUnit::reference_sized(320, 240);
    for (k, (name, scene_name, n)) in FIXTURES.iter().enumerate() {
        let states =
            scene::states(scene_name, &unit, *n).ok_or_else(|| anyhow!("scene {scene_name}"))?;
        let out = dir.join(name);
        if out.exists() {
            std::fs::remove_dir_all(&out).with_context(|| format!("clearing {}", out.display()))?;
        }
        let opts = sets::SetOptions {
            truth_maps: true,
            seed: 100 + k as u64,
            unit_seed: 0,
            encoding: Default::default(),
        };
        let set = sets::write_states(&out, scene_name, &unit, &states, &opts, |_, _| {})?;
        println!("{}: {} frames", set.dir().display(), set.len());
    }
    Ok(())
}

fn montage(png: &Path) -> Result<()> {
    let unit = SensorUnit::reference_sized(320, 240);
    let r = Renderer::new(unit.clone());
    let pick = |name: &str, frac: f32| -> Result<SkinState> {
        let s = scene::states(name, &unit, 11).ok_or_else(|| anyhow!("scene {name}"))?;
        Ok(s[((s.len() - 1) as f32 * frac) as usize].clone())
    };
    let mut deep = pick("sweep-depth", 1.0)?;
    deep.contacts[0].depth_mm = 2.5;
    let tiles = [
        SkinState::idle(scene::ROOM_C),
        deep,
        pick("letter-e", 1.0)?,
        pick("heated-nut", 1.0)?,
        pick("misregistered", 1.0)?,
        pick("heated-bar", 1.0)?,
    ];
    let (w, h) = (unit.width_px, unit.height_px);
    let gap = 4;
    let mut out = RgbImage::from_pixel(3 * w + 2 * gap, 2 * h + gap, image::Rgb([255, 255, 255]));
    for (i, s) in tiles.iter().enumerate() {
        let (img, _) = r.render(s, 42 + i as u64);
        let (x, y) = ((i as u32 % 3) * (w + gap), (i as u32 / 3) * (h + gap));
        image::imageops::replace(&mut out, &img, i64::from(x), i64::from(y));
    }
    if let Some(parent) = png.parent() {
        std::fs::create_dir_all(parent)
            .with_context(|| format!("creating {}", parent.display()))?;
    }
    out.save(png)
        .with_context(|| format!("writing {}", png.display()))?;
    println!(
        "{}: reference, sphere 2.5 mm, letter E, heated nut 45 °C, misregistered 3 px, heated bar",
        png.display()
    );
    Ok(())
}
