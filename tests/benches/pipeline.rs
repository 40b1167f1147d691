//! Per-frame cost of each pipeline stage, float reference beside the device path, on a
//! simulated 640×480 frame (reference unit: 16 px period → 320×240 working resolution).
//! Setup (reference-side work) is outside the timed loop.
#![allow(clippy::unwrap_used)] // a bench that cannot set up is a broken bench

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use vistaf_pipeline::calibration::Calibration;
use vistaf_pipeline::ftp::fixed::{FixedFtp, Scratch as FixedScratch};
use vistaf_pipeline::image_ops::{gray_down_f32, gray_down_q8};
use vistaf_pipeline::measure::apex::BlurLoss;
use vistaf_pipeline::measure::profile::Shapes;
use vistaf_pipeline::measure::{measure, Context};
use vistaf_pipeline::{Analyzer, AnalyzerOptions, Implementation, Scratch};
use vistaf_sim::{scene, Renderer, SensorUnit, SkinState};

fn pipeline(c: &mut Criterion) {
    let unit = SensorUnit::reference();
    let r = Renderer::new(unit.clone());
    let (reference, _) = r.render(&SkinState::idle(scene::ROOM_C), 1);
    let press = &scene::states("sweep-depth", &unit, 5).unwrap()[3];
    let (frame, _) = r.render(press, 2);
    let (idle, _) = r.render(&SkinState::idle(scene::ROOM_C), 3);
    let mut g = c.benchmark_group("pipeline_640x480");
    g.sample_size(30);
    g.bench_function("luma_downsample_q8", |b| {
        b.iter(|| gray_down_q8(black_box(&frame), 2))
    });
    g.bench_function("luma_downsample_f32", |b| {
        b.iter(|| gray_down_f32(black_box(&frame), 2))
    });
    // Device path by stage: demodulation and phase, then the measurement.
    let calib = Calibration::default_sim();
    let working = vistaf_pipeline::ftp::carrier::working(&reference, None).unwrap();
    let fixed = FixedFtp::new(&reference, &working, &calib);
    let mut scratch = FixedScratch::default();
    g.bench_function("Fixed_stage_demodulate_and_phase", |b| {
        b.iter(|| {
            fixed.phase(black_box(&frame), &mut scratch);
        })
    });
    let field = fixed.phase(&frame, &mut scratch);
    let (_, _, factor) = fixed.geometry();
    let blur_loss = BlurLoss::new(fixed.blur_box_lengths(), 0.125 * factor as f32);
    let shapes = Shapes::new(fixed.blur_box_lengths(), 0.125 * factor as f32);
    let ctx = Context {
        calib: &calib,
        blur_loss: &blur_loss,
        shapes: &shapes,
        mm_per_px: 0.125,
        ref_saturated_fraction: 0.0,
        unwrap: Default::default(),
        colour_phase: None,
    };
    let carrier = fixed.carrier();
    g.bench_function("Fixed_stage_measure", |b| {
        b.iter(|| measure(black_box(&field), factor, carrier, &ctx))
    });
    for imp in [Implementation::Fixed, Implementation::Float] {
        let a = Analyzer::new(
            &reference,
            Calibration::default_sim(),
            imp,
            AnalyzerOptions::default(),
        )
        .unwrap();
        let mut scratch = Scratch::default();
        g.bench_function(format!("{imp:?}_press_1.9mm"), |b| {
            b.iter(|| a.analyze_with(black_box(&frame), &mut scratch).unwrap())
        });
        g.bench_function(format!("{imp:?}_no_contact"), |b| {
            b.iter(|| a.analyze_with(black_box(&idle), &mut scratch).unwrap())
        });
        // The temperature stage alone: the same frame without the temperature model.
        let mut bare = Calibration::default_sim();
        bare.temperature = None;
        let a = Analyzer::new(&reference, bare, imp, AnalyzerOptions::default()).unwrap();
        g.bench_function(format!("{imp:?}_press_1.9mm_without_temperature"), |b| {
            b.iter(|| a.analyze_with(black_box(&frame), &mut scratch).unwrap())
        });
    }
    g.finish();
}

criterion_group!(benches, pipeline);
criterion_main!(benches);
