//! Runs the pipeline on N frames, for instruction counting under callgrind:
//!
//! ```sh
//! valgrind --tool=callgrind target/release/pipeline-frames fixed 1 640 480
//! valgrind --tool=callgrind target/release/pipeline-frames fixed 11 640 480
//! ```
//!
//! The difference of the two totals divided by 10 is the per-frame cost without setup
//! (`scripts/instructions.sh` does exactly that). Arguments: `float|fixed`, frame count,
//! input width and height (the reference unit's 16 px period is kept), optionally `idle`
//! to analyse no-contact frames, optionally `no-temperature` to leave the calibration's
//! temperature model out (the difference is what temperature costs; `with-temperature`
//! keeps it), then the downsampling factor (`auto` or a number), the float path's band
//! window (`matched` or `hann`), when to unwrap (`when-needed`, `always`, `never`), the
//! device path's filter (`2d` or `rows`) and the lens (`chromatic`: the unit's red and
//! blue images at the simulator's largest lateral chromatic aberration, which the pipeline
//! turns out per colour, `vistaf_pipeline::ftp::lateral`; anything else: none).

use vistaf_pipeline::calibration::Calibration;
use vistaf_pipeline::{Analyzer, AnalyzerOptions, Implementation};
use vistaf_sim::{scene, Renderer, SensorUnit, SkinState};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let imp: Implementation = args.get(1).map_or("fixed", String::as_str).parse()?;
    let n: usize = args.get(2).map_or(Ok(1), |s| s.parse())?;
    let w: u32 = args.get(3).map_or(Ok(640), |s| s.parse())?;
    let h: u32 = args.get(4).map_or(Ok(480), |s| s.parse())?;
    let idle = args.get(5).is_some_and(|s| s == "idle");
    let no_temperature = args.get(6).is_some_and(|s| s == "no-temperature");
    let factor: Option<usize> = match args.get(7).map(String::as_str) {
        None | Some("auto") => None,
        Some(f) => Some(f.parse()?),
    };
    let band = if args.get(8).is_some_and(|s| s == "hann") {
        vistaf_pipeline::ftp::band::BandWindow::Hann
    } else {
        vistaf_pipeline::ftp::band::BandWindow::Matched
    };
    let mut unit = SensorUnit::reference_sized(w, h);
    if args.get(11).is_some_and(|s| s == "chromatic") {
        let chi = vistaf_sim::imperfections::CHROMATIC_MAX as f32;
        unit.imperfections.chromatic = [chi, -chi];
    }
    let r = Renderer::new(unit.clone());
    let (reference, _) = r.render(&SkinState::idle(scene::ROOM_C), 1);
    let state = if idle {
        SkinState::idle(scene::ROOM_C)
    } else {
        scene::states("sweep-depth", &unit, 5).ok_or("scene")?[3].clone()
    };
    let (frame, _) = r.render(&state, 2);
    let unwrap = match args.get(9).map(String::as_str) {
        Some("always") => vistaf_pipeline::measure::Unwrap::Always,
        Some("never") => vistaf_pipeline::measure::Unwrap::Never,
        _ => vistaf_pipeline::measure::Unwrap::WhenNeeded,
    };
    let opts = AnalyzerOptions {
        force_calibration: true,
        factor,
        band,
        unwrap,
        rows_only: args.get(10).is_some_and(|s| s == "rows"),
    };
    let mut calib = Calibration::default_sim();
    if no_temperature {
        calib.temperature = None;
    }
    let a = Analyzer::new(&reference, calib, imp, opts)?;
    // As the service runs it: one scratch for the stream of frames.
    let mut scratch = vistaf_pipeline::Scratch::default();
    let mut peak = 0.0;
    for _ in 0..n {
        peak += a.analyze_with(&frame, &mut scratch)?.peak_depth_mm;
    }
    println!("{imp:?}: {n} frames, mean peak {:.3} mm", peak / n as f32);
    Ok(())
}
