//! `vistaf-skin analyze`: run the pipeline on a reference and frames; JSON lines out.
//!
//! `temperature_c` is the contact temperature when there is contact, else the skin's mean;
//! `temp_min_c`, `temp_mean_c`, `temp_max_c` are the skin's coldest place, mean and hottest
//! place (`vistaf_pipeline::thermal::Temperature`). All are `null` when the calibration has
//! no temperature model.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use serde_json::json;
use vistaf_hardware::decode::Decoded;
use vistaf_hardware::frame::Frame;
use vistaf_hardware::frameset::{frame_file, FrameSet};
use vistaf_pipeline::{Analyzer, AnalyzerOptions, Measurement};

/// What to analyse.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Reference (no-contact) frame, PNG or JPEG.
    #[arg(long, requires = "frame", conflicts_with = "set")]
    pub reference: Option<PathBuf>,
    /// Frame to analyse, PNG or JPEG.
    #[arg(long)]
    pub frame: Option<PathBuf>,
    /// A frame set (its reference and every frame).
    #[arg(long, required_unless_present = "reference")]
    pub set: Option<PathBuf>,
    #[command(flatten)]
    pub pipe: super::common::PipelineArgs,
    /// Override the working-resolution downsampling factor.
    #[arg(long)]
    pub downsample: Option<usize>,
    /// Accepted for old scripts: JSON lines on stdout are the only output.
    #[arg(long, hide = true)]
    pub json: bool,
    /// Also write a figure per frame here (`<frame>.png` and its `.svg` twin: camera,
    /// depth, 3-D surface, temperature, with one set of colour ranges for the whole run)
    /// and a summary JSON.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// One result as a JSON object; positions in the camera's pixels (the pipeline's, times
/// `scale`, the scale the frame was decoded at).
pub fn result_json(file: &str, d: &Measurement, latency_us: u128, scale: u32) -> serde_json::Value {
    // NaN is not JSON: an unmeasured temperature is null.
    let t = d.temperature.as_ref();
    let finite = |v: f32| v.is_finite().then_some(v);
    let px = |v: f32| v * scale as f32;
    json!({
        "file": file,
        "depth_mm": d.peak_depth_mm,
        "force_n": d.force_n,
        "contact_area_mm2": d.contact_area_mm2,
        "volume_mm3": d.volume_mm3,
        "contact_x_px": d.centroid_px.map(|c| px(c.0)),
        "contact_y_px": d.centroid_px.map(|c| px(c.1)),
        "integrated_phase_rad_mm2": d.integrated_phase_rad_mm2,
        "reciprocal_load_mm2": d.reciprocal_load_mm2,
        "shape": d.contact.then(|| d.shape.name()),
        "temperature_c": t.and_then(|t| t.contact_c.or(finite(t.mean_c))),
        "temp_mean_c": t.and_then(|t| finite(t.mean_c)),
        "temp_min_c": t.and_then(|t| finite(t.min_c)),
        "temp_max_c": t.and_then(|t| finite(t.max_c)),
        "contact_temp_c": t.and_then(|t| t.contact_c),
        "hottest_x_px": t.and_then(|t| t.hottest_px.map(|p| px(p.0))),
        "hottest_y_px": t.and_then(|t| t.hottest_px.map(|p| px(p.1))),
        "flags": d.flags.iter().map(|f| f.name()).collect::<Vec<_>>(),
        "noise_rad": d.noise_rad,
        "offset_rad": d.offset_rad,
        "latency_us": latency_us,
    })
}

/// Where the frames come from: a set, or two files.
enum Frames {
    Set(FrameSet),
    Files { reference: PathBuf, frame: PathBuf },
}

impl Frames {
    fn open(a: &Args) -> Result<Frames> {
        Ok(match (&a.set, &a.reference, &a.frame) {
            (Some(dir), _, _) => Frames::Set(FrameSet::open(dir)?),
            (None, Some(r), Some(f)) => Frames::Files {
                reference: r.clone(),
                frame: f.clone(),
            },
            _ => bail!("give --set DIR, or --reference REF.png --frame F.png"),
        })
    }

    fn reference(&self) -> Result<Frame> {
        Ok(match self {
            Frames::Set(set) => set.reference_frame()?,
            Frames::Files { reference, .. } => frame_file(reference)?,
        })
    }

    /// The frames' names, in order.
    fn names(&self) -> Vec<String> {
        match self {
            Frames::Set(set) => set.manifest.frames.iter().map(|f| f.file.clone()).collect(),
            Frames::Files { frame, .. } => vec![frame.file_name().map_or_else(
                || frame.display().to_string(),
                |n| n.to_string_lossy().into(),
            )],
        }
    }

    /// Frame `i` as the camera sent it.
    fn frame(&self, i: usize) -> Result<Frame> {
        Ok(match self {
            Frames::Set(set) => set.frame(i)?,
            Frames::Files { frame, .. } => frame_file(frame)?,
        })
    }

    fn path(&self, i: usize) -> PathBuf {
        match self {
            Frames::Set(set) => set.path_of(&set.manifest.frames[i].file),
            Frames::Files { frame, .. } => frame.clone(),
        }
    }
}

/// Runs the command. Each frame is read from its file first; `latency_us` then counts
/// from its bytes as the camera sent them: decoding (at the calibration's scale) and the
/// pipeline.
pub fn run(a: &Args) -> Result<()> {
    let calib = a.pipe.calibration()?;
    let frames = Frames::open(a)?;
    let reference = frames.reference()?;
    let scale = calib.unit.scale_for(reference.width, reference.height);
    let decode = |f: Frame, buf: Decoded, what: &Path| {
        f.into_decoded(scale, buf)
            .with_context(|| what.display().to_string())
    };
    let mut img = decode(reference, Decoded::default(), Path::new("reference"))?;
    let opts = AnalyzerOptions {
        factor: a.downsample,
        force_calibration: a.pipe.force_calibration,
        ..Default::default()
    };
    let analyzer =
        Analyzer::new(&img, calib, a.pipe.pipeline, opts).context("preparing the reference")?;
    let mut out = Lines::new(std::io::stdout().lock());
    let (mut results, mut figures) = (Vec::new(), Vec::new());
    let mut scratch = vistaf_pipeline::Scratch::default();
    for (i, name) in frames.names().into_iter().enumerate() {
        let path = frames.path(i);
        let frame = frames.frame(i)?;
        let t = Instant::now();
        img = decode(frame, std::mem::take(&mut img), &path)?;
        let d = analyzer
            .analyze_with(&img, &mut scratch)
            .with_context(|| format!("{}", path.display()))?;
        let latency = t.elapsed().as_micros();
        let j = result_json(&name, &d, latency, scale);
        out.line(&j)?;
        if a.out.is_some() {
            let mm_per_px = analyzer.mm_per_px();
            figures.push(vistaf_firmware::figure::frame(
                &d,
                (&img).into(),
                mm_per_px,
                &name,
            ));
        }
        results.push(j);
    }
    if let Some(dir) = &a.out {
        write_outputs(dir, &analyzer, &results, &figures)?;
    }
    Ok(())
}

/// JSON lines on standard output, for as long as someone reads them: a reader that hangs
/// up (`| head -2`) ends the printing, not the analysis, and `--out` is still written.
struct Lines<W: Write> {
    out: Option<W>,
}

impl<W: Write> Lines<W> {
    fn new(out: W) -> Lines<W> {
        Lines { out: Some(out) }
    }

    fn line(&mut self, j: &serde_json::Value) -> Result<()> {
        let Some(out) = self.out.as_mut() else {
            return Ok(());
        };
        match writeln!(out, "{j}") {
            Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {
                self.out = None;
                Ok(())
            }
            other => other.context("writing stdout"),
        }
    }
}

fn write_outputs(
    dir: &Path,
    analyzer: &Analyzer,
    results: &[serde_json::Value],
    figures: &[vistaf_figure::Frame],
) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let ranges = vistaf_figure::Ranges::covering(figures);
    for f in figures {
        let name = &f.readout.label;
        let stem = Path::new(name)
            .file_stem()
            .map_or_else(|| name.clone(), |s| s.to_string_lossy().into_owned());
        vistaf_figure::write(f, &ranges, &dir.join(format!("{stem}.png")))?;
    }
    let summary = json!({
        "scale_mm_per_px": analyzer.mm_per_px(),
        "grating_period_px": analyzer.period_px(),
        "calibration": vistaf_firmware::report::calibration_json(analyzer.calibration()),
        "figure_ranges": {
            "depth_mm": [ranges.depth_mm.0, ranges.depth_mm.1],
            "temperature_c": [ranges.temperature_c.0, ranges.temperature_c.1],
        },
        "frames": results,
    });
    let p = dir.join("summary.json");
    std::fs::write(&p, serde_json::to_string_pretty(&summary)? + "\n")
        .with_context(|| format!("writing {}", p.display()))?;
    Ok(())
}
