//! `vistaf-skin calibrate`: fit phase → depth and deformation → force from labelled frame
//! sets, choose each model by grouped cross-validation and parsimony, print the evidence.

use std::path::PathBuf;

use anyhow::{anyhow, bail, Context, Result};
use sha2::{Digest, Sha256};
use vistaf_firmware::calibration::{
    Calibration, CandidateScore, DepthModel, Fitted, ForceFeature, SetRecord, UnitGeometry, FORMAT,
};
use vistaf_firmware::fit::{fit_depth, fit_force, Sample};
use vistaf_firmware::pipeline::carrier;
use vistaf_firmware::pipeline::image_ops::gray_down_f32;
use vistaf_firmware::pipeline::{Analyzer, AnalyzerOptions, Deformation, Implementation};
use vistaf_hardware::frameset::FrameSet;

use super::progress;

/// What to calibrate from.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Labelled frame sets (depth_mm, force_n labels); repeat for several.
    #[arg(long = "set", required_unless_present = "table")]
    pub sets: Vec<PathBuf>,
    /// Output calibration file.
    #[arg(long, required_unless_present = "table")]
    pub out: Option<PathBuf>,
    /// Pipeline the calibration is made with (use the one that will run).
    #[arg(long, default_value = "fixed")]
    pub pipeline: Implementation,
    /// Reproduce the paper's Table II from its per-image results CSV instead.
    #[arg(long, value_name = "CSV")]
    pub table: Option<PathBuf>,
}

fn sha_of(set: &FrameSet) -> Result<String> {
    let mut h = Sha256::new();
    let files = std::iter::once("set.json".to_string())
        .chain(std::iter::once(set.manifest.reference.clone()))
        .chain(set.manifest.frames.iter().map(|f| f.file.clone()));
    for f in files {
        let p = set.path_of(&f);
        h.update(std::fs::read(&p).with_context(|| format!("hashing {}", p.display()))?);
    }
    Ok(h.finalize().iter().map(|b| format!("{b:02x}")).collect())
}

fn print_table(title: &str, unit: &str, scores: &[CandidateScore], chosen: &CandidateScore) {
    println!("\n{title}");
    println!(
        "  {:<24} {:>6} {:>12} {:>10} {:>14}",
        "candidate", "params", "CV RMSE", "± SE", "in-sample RMSE"
    );
    for s in scores {
        let mark = if s.name == chosen.name {
            "  ← chosen"
        } else {
            ""
        };
        println!(
            "  {:<24} {:>6} {:>9.4} {unit} {:>10.4} {:>11.4} {unit}{mark}",
            s.name, s.params, s.cv_rmse, s.cv_se, s.in_sample_rmse
        );
    }
}

/// Runs the command.
pub fn run(a: &Args) -> Result<()> {
    if let Some(csv) = &a.table {
        return super::paper::table(csv);
    }
    let out = a.out.as_ref().ok_or_else(|| anyhow!("--out is required"))?;
    let sets: Vec<FrameSet> = a
        .sets
        .iter()
        .map(|d| FrameSet::open(d).with_context(|| format!("opening {}", d.display())))
        .collect::<Result<_>>()?;
    let first = sets
        .first()
        .ok_or_else(|| anyhow!("give at least one --set"))?;
    let reference = first.load_reference()?;
    let (g, gw, gh) = gray_down_f32(&reference, 1);
    let c = carrier::estimate(&g, gw, gh)
        .with_context(|| format!("{}: reference", first.dir().display()))?;
    for s in &sets {
        if s.size() != first.size() {
            bail!(
                "{}: {}×{} px, but {} is {}×{} px; calibrate one unit at a time",
                s.dir().display(),
                s.size().0,
                s.size().1,
                first.dir().display(),
                first.size().0,
                first.size().1
            );
        }
    }
    let unit = UnitGeometry {
        width_px: reference.width(),
        height_px: reference.height(),
        period_px: f64::from(c.period_px()),
        angle_deg: f64::from(c.angle_deg()),
        grating_period_mm: first.manifest.grating_period_mm,
    };
    println!(
        "unit: {}×{} px, grating period {:.3} px ({:.4} mm/px), carrier at {:.2}°",
        unit.width_px,
        unit.height_px,
        unit.period_px,
        unit.grating_period_mm / unit.period_px,
        unit.angle_deg
    );
    // A calibration whose depth model is the identity: "depth" in mm reads as phase in rad.
    let identity = |sign: f64| Calibration {
        format: FORMAT.into(),
        unit: unit.clone(),
        phase_sign: sign,
        depth: Fitted {
            model: DepthModel::Linear { k_mm_per_rad: 1.0 },
            equation: String::new(),
            cv_rmse: 0.0,
            in_sample_rmse: 0.0,
            n: 0,
            candidates: vec![],
        },
        force: None,
        sets: vec![],
    };
    let opts = AnalyzerOptions {
        force_calibration: true,
        ..Default::default()
    };
    let analyze_all =
        |calib: &Calibration, label: &str, what: &str| -> Result<Vec<(f64, Deformation)>> {
            let mut out = Vec::new();
            let total: usize = sets.iter().map(|s| s.len()).sum();
            let pb = progress(total as u64, what);
            for s in &sets {
                let an = Analyzer::new(&s.load_reference()?, calib.clone(), a.pipeline, opts)?;
                for (i, f) in s.manifest.frames.iter().enumerate() {
                    pb.inc(1);
                    let y = match label {
                        "depth" => f.depth_mm,
                        _ => f.force_n,
                    };
                    let Some(y) = y.filter(|v| *v > 0.0) else {
                        continue;
                    };
                    let d = an
                        .analyze(&s.load_frame(i)?)
                        .with_context(|| format!("{}: {}", s.dir().display(), f.file))?;
                    if d.flags.is_empty() {
                        out.push((y, d));
                    } else {
                        let names: Vec<&str> = d.flags.iter().map(|f| f.name()).collect();
                        pb.println(format!(
                            "  {}: {} left out of the fit ({})",
                            s.dir().display(),
                            f.file,
                            names.join(", ")
                        ));
                    }
                }
            }
            pb.finish_and_clear();
            Ok(out)
        };

    // Phase sign: the one under which the deepest labelled frame shows an indentation.
    let plus = analyze_all(&identity(1.0), "depth", "phase sign")?;
    if plus.is_empty() {
        bail!("no frame is labelled with depth_mm > 0: phase → depth needs a depth set");
    }
    let minus_peak = {
        let deepest = plus.iter().map(|p| p.0).fold(0.0, f64::max);
        let mut m = 0.0f32;
        for s in &sets {
            let an = Analyzer::new(&s.load_reference()?, identity(-1.0), a.pipeline, opts)?;
            for (i, f) in s.manifest.frames.iter().enumerate() {
                if f.depth_mm == Some(deepest) {
                    m = m.max(an.analyze(&s.load_frame(i)?)?.peak_depth_mm);
                }
            }
        }
        m
    };
    let plus_peak = plus
        .iter()
        .filter(|p| p.0 >= plus.iter().map(|q| q.0).fold(0.0, f64::max))
        .map(|p| p.1.peak_depth_mm)
        .fold(0.0, f32::max);
    let sign = if minus_peak > plus_peak { -1.0 } else { 1.0 };
    let depth_frames = if sign > 0.0 {
        plus
    } else {
        analyze_all(&identity(-1.0), "depth", "phase → depth")?
    };
    let samples: Vec<Sample> = depth_frames
        .iter()
        .filter(|(_, d)| d.contact)
        .map(|(y, d)| Sample {
            u: f64::from(d.peak_depth_mm),
            y: *y,
            group: *y,
        })
        .collect();
    let (model, chosen, scores) = fit_depth(&samples, |_, _| {})
        .ok_or_else(|| anyhow!("phase → depth needs frames at three or more depths"))?;
    print_table(
        &format!(
            "phase → depth ({} frames, leave-one-depth-out CV)",
            samples.len()
        ),
        "mm",
        &scores,
        &chosen,
    );
    let mut calib = identity(sign);
    calib.depth = Fitted {
        equation: model.equation(),
        model,
        cv_rmse: chosen.cv_rmse,
        in_sample_rmse: chosen.in_sample_rmse,
        n: samples.len(),
        candidates: scores,
    };

    let force_frames = analyze_all(&calib, "force", "deformation → force")?;
    if force_frames.len() >= 3 {
        let feats: Vec<(ForceFeature, Vec<Sample>)> = ForceFeature::ALL
            .iter()
            .map(|&f| {
                let s = force_frames
                    .iter()
                    .map(|(y, d)| Sample {
                        u: f64::from(match f {
                            ForceFeature::Volume => d.volume_mm3,
                            ForceFeature::IntegratedPhase => d.integrated_phase_rad_mm2,
                            ForceFeature::ContactArea => d.contact_area_mm2,
                            ForceFeature::PeakDepth => d.peak_depth_mm,
                        }),
                        y: *y,
                        group: *y,
                    })
                    .collect();
                (f, s)
            })
            .collect();
        if let Some((m, chosen, scores)) = fit_force(&feats, |_, _| {}) {
            let full_scale = force_frames.iter().map(|f| f.0).fold(0.0, f64::max);
            print_table(
                &format!(
                    "deformation → force ({} frames, leave-one-force-level-out CV; full scale {full_scale:.1} N)",
                    force_frames.len()
                ),
                "N",
                &scores,
                &chosen,
            );
            calib.force = Some(Fitted {
                equation: m.equation(),
                model: m,
                cv_rmse: chosen.cv_rmse,
                in_sample_rmse: chosen.in_sample_rmse,
                n: force_frames.len(),
                candidates: scores,
            });
        }
    } else {
        println!("\nno force labels: force model left empty (force reads 0)");
    }
    calib.sets = sets
        .iter()
        .map(|s| {
            Ok(SetRecord {
                path: s.dir().display().to_string(),
                sha256: sha_of(s)?,
                frames: s.len(),
            })
        })
        .collect::<Result<_>>()?;
    calib.save(out)?;
    println!("\n{}: depth {}", out.display(), calib.depth.equation);
    if let Some(f) = &calib.force {
        println!("{}: force {}", out.display(), f.equation);
    }
    Ok(())
}
