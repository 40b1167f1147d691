//! Renders one frame of a scene to a PNG (quick look): `cargo run --example peek -- SCENE FRAME OUT.png [UNIT_SEED]`.
#![allow(clippy::unwrap_used)]
use vistaf_sim::{scene, Renderer, SensorUnit};
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let unit = SensorUnit::from_seed(a.get(4).map_or(0, |s| s.parse().unwrap()));
    let states = scene::states(&a[1], &unit, 20).unwrap();
    let r = Renderer::new(unit);
    let t = std::time::Instant::now();
    let (img, truth) = r.render(&states[a[2].parse::<usize>().unwrap()], 1);
    eprintln!(
        "{:?} peak {:.3} mm force {:.2} N contact {:?} T {:?}",
        t.elapsed(),
        truth.peak_depth_mm,
        truth.force_n,
        truth.contact_px,
        truth.contact_temp_c
    );
    img.save(&a[3]).unwrap();
}
