//! Simulated-skin rendering cost per frame at 640×480 (renderer setup excluded).
#![allow(clippy::unwrap_used)]

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use vistaf_sim::{scene, Renderer, SensorUnit};

fn render(c: &mut Criterion) {
    let unit = SensorUnit::reference();
    let r = Renderer::new(unit.clone());
    let mut g = c.benchmark_group("render_640x480");
    g.sample_size(20);
    for name in ["idle", "press-sphere", "letter-e", "heated-nut"] {
        let states = scene::states(name, &unit, 10).unwrap();
        let s = &states[states.len() / 2];
        g.bench_function(name, |b| b.iter(|| r.render(black_box(s), 7)));
    }
    g.finish();
}

criterion_group!(benches, render);
criterion_main!(benches);
