//! `vistaf-skin calibrate`: fit phase → depth, deformation → force and colour → temperature
//! from labelled frame sets, choose each model by grouped cross-validation and parsimony, print the evidence.
//! With `--guided`, the kit is captured first, step by step, on this board's camera
//! ([`super::guided`]).

use std::path::PathBuf;

use anyhow::{anyhow, Context, Result};
use vistaf_calibrate::{calibrate, Observer};
use vistaf_hardware::frameset::FrameSet;
use vistaf_pipeline::calibration::{CandidateScore, Fitted};
use vistaf_pipeline::Implementation;

use super::progress;

/// What to calibrate from.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Labelled frame sets (depth_mm, force_n, temperature_c labels); repeat for several.
    #[arg(long = "set", required_unless_present_any = ["table", "guided"])]
    pub sets: Vec<PathBuf>,
    /// Output calibration file.
    #[arg(long, required_unless_present_any = ["table", "guided"])]
    pub out: Option<PathBuf>,
    /// Pipeline the calibration is made with (use the one that will run).
    #[arg(long, default_value = "fixed")]
    pub pipeline: Implementation,
    /// Reproduce the paper's Table II from its per-image results CSV instead.
    #[arg(long, value_name = "CSV", conflicts_with = "guided")]
    pub table: Option<PathBuf>,
    /// Capture the kit on this board's camera in a guided session, fit it, and activate it
    /// in the calibration file (the running service must be stopped first).
    #[arg(long, conflicts_with_all = ["sets", "out"])]
    pub guided: bool,
    /// The guided session's options.
    #[command(flatten)]
    pub session: super::guided::GuidedArgs,
}

/// A progress bar that also prints notes above itself.
struct Bar(indicatif::ProgressBar);

impl Observer for Bar {
    fn progress(&mut self, stage: &str, done: usize, total: usize) {
        self.0.set_message(stage.to_string());
        self.0.set_length(total as u64);
        self.0.set_position(done as u64);
    }
    fn note(&mut self, text: String) {
        // Printed with the bar out of the way; a hidden bar's own `println` prints nothing.
        self.0.suspend(|| println!("  {text}"));
    }
}

/// Prints a candidate table with the chosen model marked.
pub fn print_table<M>(title: &str, unit: &str, fitted: &Fitted<M>) {
    print_candidates(
        title,
        unit,
        &fitted.candidates,
        fitted.cv_rmse,
        fitted.in_sample_rmse,
        &fitted.equation,
    );
}

/// Prints candidates; the one scoring `chosen_cv` / `chosen_in` is marked.
fn print_candidates(
    title: &str,
    unit: &str,
    candidates: &[CandidateScore],
    chosen_cv: f64,
    chosen_in: f64,
    equation: &str,
) {
    println!("\n{title}");
    println!(
        "  {:<24} {:>6} {:>12} {:>10} {:>16}",
        "candidate", "params", "CV RMSE", "± SE", "in-sample RMSE"
    );
    let mut marked = false;
    for s in candidates {
        let CandidateScore {
            name,
            params,
            cv_rmse,
            cv_se,
            in_sample_rmse,
            refused,
        } = s;
        let mark = if let Some(why) = refused {
            format!("  refused: {why}")
        } else if !marked && *cv_rmse == chosen_cv && *in_sample_rmse == chosen_in {
            marked = true;
            "  ← chosen".to_string()
        } else {
            String::new()
        };
        println!("  {name:<24} {params:>6} {cv_rmse:>9.4} {unit} {cv_se:>10.4} {in_sample_rmse:>13.4} {unit}{mark}");
    }
    println!("  chosen: {equation}");
}

/// Runs the command.
pub fn run(a: &Args) -> Result<()> {
    if a.guided {
        return super::guided::run(&a.session, a.pipeline);
    }
    if a.session.given() {
        return Err(anyhow!(
            "the guided session's options (--source, --plan, --config, …) need --guided"
        ));
    }
    if let Some(csv) = &a.table {
        print!("{}", vistaf_calibrate::paper::table(csv)?);
        return Ok(());
    }
    let out = a.out.as_ref().ok_or_else(|| anyhow!("--out is required"))?;
    let sets: Vec<FrameSet> = a
        .sets
        .iter()
        .map(|d| FrameSet::open(d).with_context(|| format!("opening {}", d.display())))
        .collect::<Result<_>>()?;
    let mut bar = Bar(progress(0, "calibrating"));
    let calib = calibrate(&sets, a.pipeline, &mut bar)?;
    bar.0.finish_and_clear();
    let u = &calib.unit;
    println!(
        "unit: {}×{} px, grating period {:.3} px ({:.4} mm/px), carrier at {:.2}°, phase sign {:+}",
        u.width_px,
        u.height_px,
        u.period_px,
        u.grating_period_mm / u.period_px,
        u.angle_deg,
        calib.phase_sign
    );
    print_table(
        &format!(
            "phase → depth ({} frames, leave-one-depth-out CV)",
            calib.depth.n
        ),
        "mm",
        &calib.depth,
    );
    match &calib.force {
        Some(f) => print_table(
            &format!(
                "deformation → force ({} frames, leave-one-force-level-out CV)",
                f.n
            ),
            "N",
            f,
        ),
        None => println!("\nno force model (no force labels)"),
    }
    match &calib.temperature {
        Some(t) => {
            for (name, p) in [("coloured", &t.coloured), ("black", &t.black)] {
                print_candidates(
                    &format!(
                        "colour → temperature, {name} stripes ({:.1}–{:.1} °C, \
                         leave-one-setpoint-out CV of per-setpoint means)",
                        p.fit_range_c[0], p.fit_range_c[1]
                    ),
                    "°C",
                    &p.candidates,
                    p.cv_rmse_c,
                    p.in_sample_rmse_c,
                    &p.equation,
                );
            }
            println!(
                "\nfused (inverse-variance), held-out setpoints: RMSE {:.3} °C within 22–32 °C, \
                 {:.3} °C over {:.1}–{:.1} °C ({} blocks)",
                t.cv_rmse_transition_c, t.cv_rmse_c, t.range_c[0], t.range_c[1], t.n
            );
        }
        None => println!("\nno temperature model (no no-contact frames labelled temperature_c)"),
    }
    let (verdicts, pass) =
        vistaf_calibrate::verdict::report(&vistaf_calibrate::verdict::verdicts(&calib));
    println!("\nverdict (held-out error against the product's targets):\n{verdicts}");
    calib.save(out)?;
    println!(
        "wrote {}: calibration {}, {}",
        out.display(),
        vistaf_protocol::CalibrationId(calib.id()),
        if pass {
            "every model meets its target"
        } else {
            "A MODEL MISSES ITS TARGET (see FAIL above): add setpoints or frames, or check the kit"
        }
    );
    Ok(())
}
