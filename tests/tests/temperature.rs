//! Temperature on the simulated reference unit with the shipped calibration, against the
//! renderer's ground truth: uniform skins at setpoints the calibration kit never used,
//! indentation shading (cross-talk), heated contacts, temperatures beyond the calibrated
//! range, and the device path against the float reference.
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

use vistaf_pipeline::calibration::Calibration;
use vistaf_pipeline::thermal::stripes::pool;
use vistaf_pipeline::thermal::{BLACK_POOL, CONTACT_SIGMA_LIMIT_C};
use vistaf_pipeline::{Analyzer, AnalyzerOptions, Implementation, Measurement};
use vistaf_protocol::Flag;
use vistaf_sim::contact::{Contact, Footprint, Indenter};
use vistaf_sim::render::lamp_reflections_px;
use vistaf_sim::scene::{center_mm, ROOM_C, SPHERE_R_MM};
use vistaf_sim::thermal::HeatSource;
use vistaf_sim::{Renderer, SensorUnit, SkinState, Truth};

struct Bench {
    r: Renderer,
    fixed: Analyzer,
    float: Analyzer,
}

fn bench() -> Bench {
    bench_of(SensorUnit::reference())
}

fn bench_of(unit: SensorUnit) -> Bench {
    bench_calibrated(unit, Calibration::default_sim())
}

fn bench_calibrated(unit: SensorUnit, calib: Calibration) -> Bench {
    let r = Renderer::new(unit);
    let (reference, _) = r.render(&SkinState::idle(ROOM_C), 4242);
    let an =
        |imp| Analyzer::new(&reference, calib.clone(), imp, AnalyzerOptions::default()).unwrap();
    Bench {
        fixed: an(Implementation::Fixed),
        float: an(Implementation::Float),
        r,
    }
}

impl Bench {
    fn run(&self, s: &SkinState, seed: u64) -> (Measurement, Measurement, Truth) {
        let (img, truth) = self.r.render(s, seed);
        (
            self.fixed.analyze(&img).unwrap(),
            self.float.analyze(&img).unwrap(),
            truth,
        )
    }
}

fn press(depth_mm: f32, t_c: f32) -> SkinState {
    let mut s = SkinState::idle(t_c);
    s.contacts.push(Contact {
        indenter: Indenter::Sphere { r_mm: SPHERE_R_MM },
        center_mm: center_mm(&SensorUnit::reference()),
        depth_mm,
    });
    s
}

/// Per-setpoint means of the skin's mean temperature at setpoints between the kit's,
/// two frames each: ≤ 0.3 °C within 22–32 °C, ≤ 1.0 °C over 15–45 °C, on both paths.
#[test]
fn uniform_skin_reads_held_out_setpoints() {
    let b = bench();
    let setpoints = [
        16.0f32, 21.0, 22.5, 24.5, 26.5, 28.5, 30.5, 31.5, 36.0, 41.0, 44.0,
    ];
    let mut report = Vec::new();
    for (k, &t) in setpoints.iter().enumerate() {
        let mut mean = [0.0f32; 2];
        for rep in 0..2u64 {
            let (fx, fl, _) = b.run(&SkinState::idle(t), 500 + 10 * k as u64 + rep);
            for (m, d) in mean.iter_mut().zip([&fx, &fl]) {
                let temp = d.temperature.as_ref().unwrap();
                assert!(temp.measured > 100, "{t} °C: {} blocks", temp.measured);
                assert!(
                    !d.flags.contains(Flag::TemperatureOutOfRange),
                    "{t} °C flagged out of range ({:.2}–{:.2})",
                    temp.min_c,
                    temp.max_c
                );
                *m += temp.mean_c / 2.0;
            }
        }
        let tol = if (22.0..=32.0).contains(&t) { 0.3 } else { 1.0 };
        for (path, m) in ["fixed", "float"].iter().zip(mean) {
            assert!(
                (m - t).abs() <= tol,
                "{path}: {m:.3} °C at a {t} °C setpoint (tolerance {tol})"
            );
        }
        report.push(format!("{t}: {:+.3}", mean[0] - t));
    }
    println!(
        "uniform skin, device path error per setpoint: {}",
        report.join(", ")
    );
}

/// A 2 mm indentation shades the skin; the contact temperature must not move by more than
/// 0.5 °C, inside the coloured transition and outside it.
#[test]
fn indentation_shading_does_not_move_temperature() {
    let b = bench();
    for (k, t) in [24.0f32, 28.0, 31.0, 40.0].into_iter().enumerate() {
        let (fx, fl, _) = b.run(&press(2.0, t), 900 + k as u64);
        for d in [&fx, &fl] {
            assert!(d.contact && d.peak_depth_mm > 1.9, "{d:?}");
            let temp = d.temperature.as_ref().unwrap();
            let c = temp.contact_c.unwrap();
            assert!(
                (c - t).abs() <= 0.5,
                "contact reads {c:.3} °C on a {t} °C skin"
            );
            assert!(
                (temp.mean_c - t).abs() <= 0.5,
                "mean {:.3} at {t}",
                temp.mean_c
            );
            // Nothing on a uniform skin stands out of its noise, the contact included.
            assert_eq!(temp.hottest_px, None, "{t} °C: hottest {:.3}", temp.max_c);
            assert!(
                (temp.max_c - t).abs() <= 0.5,
                "hottest {:.3} at {t}",
                temp.max_c
            );
        }
    }
}

/// A camera's white balance and exposure drift after the reference (±4 % per channel, ±6 %
/// exposure): the mean temperature of a uniform skin moves by at most 0.1 °C, in the
/// coloured transition and on both sides of it, on both paths.
#[test]
fn a_drifting_white_balance_does_not_move_temperature() {
    let b = bench();
    for (k, t) in [20.0f32, 24.5, 27.5, 30.5, 36.0].into_iter().enumerate() {
        let seed = 1300 + k as u64;
        let mean_c = |m: &Measurement| m.temperature.as_ref().unwrap().mean_c;
        let (fx, fl, _) = b.run(&SkinState::idle(t), seed);
        let steady = [mean_c(&fx), mean_c(&fl)];
        for (wb, exposure) in [([1.04, 1.0, 0.96], 0.94), ([0.96, 1.0, 1.04], 1.06)] {
            let mut s = SkinState::idle(t);
            s.white_balance = wb;
            s.exposure_scale = exposure;
            let (fx, fl, _) = b.run(&s, seed);
            for (d, steady_c) in [&fx, &fl].into_iter().zip(steady) {
                let got = mean_c(d);
                assert!(
                    (got - steady_c).abs() <= 0.1,
                    "{t} °C skin: white balance {wb:?} reads {got:.3} °C, {steady_c:.3} without"
                );
            }
        }
    }
}

/// Beyond the coloured transition only the black stripes' slow brightening speaks, and a
/// pattern of a few per cent in their ratio to the coloured stripes reads as degrees. A
/// strong, off-centre vignetting puts such a pattern on every block (the two populations'
/// samples see the fall-off at different places); the reference shows it and the
/// thermometer takes it out ([`vistaf_pipeline::thermal::ratio_field`]), so a uniform hot
/// skin reads flat on both paths: block-to-block spread within 0.5 °C, hottest place within
/// 1 °C of the truth.
#[test]
fn a_vignetted_unit_reads_a_hot_skin_flat() {
    let mut unit = SensorUnit::reference();
    unit.vignetting = 0.55;
    unit.imperfections.vignetting_offset = (0.12, -0.08);
    let b = bench_of(unit);
    for (k, t) in [38.0f32, 42.0].into_iter().enumerate() {
        let (fx, fl, _) = b.run(&SkinState::idle(t), 1400 + k as u64);
        for (path, m) in [("device", &fx), ("float", &fl)] {
            let temp = m.temperature.as_ref().unwrap();
            let v: Vec<f32> = temp
                .map_c
                .iter()
                .copied()
                .filter(|v| v.is_finite())
                .collect();
            let mean = v.iter().sum::<f32>() / v.len() as f32;
            let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f32>() / v.len() as f32).sqrt();
            assert!(
                sd <= 0.5 && temp.max_c - t <= 1.0,
                "{path}: {t} °C skin reads {mean:.2} ± {sd:.2} °C, hottest {:.2} °C",
                temp.max_c
            );
        }
    }
}

/// A heated sphere's contact temperature within 0.8 °C of the truth (the mean over its
/// footprint), at several depths and temperatures; and the heat does not move the force.
#[test]
fn heated_contact_reads_its_temperature_and_not_its_force() {
    let b = bench();
    let c = center_mm(&SensorUnit::reference());
    for (k, (depth, hot)) in [(0.5f32, 40.0f32), (1.0, 36.0), (1.5, 45.0), (1.0, 30.0)]
        .into_iter()
        .enumerate()
    {
        let s = heated_press(c, depth, hot);
        let seed = 1300 + k as u64;
        let (fx, fl, truth) = b.run(&s, seed);
        let want = truth.contact_temp_c.unwrap();
        for d in [&fx, &fl] {
            let temp = d.temperature.as_ref().unwrap();
            let got = temp.contact_c.unwrap();
            assert!(
                (got - want).abs() <= 0.8,
                "{depth} mm at {hot} °C: contact reads {got:.3}, truth {want:.3}"
            );
            // A heated contact stands out of the skin: it is the hottest place.
            assert_eq!(temp.max_c, got, "{depth} mm at {hot} °C");
            assert!(temp.hottest_px.is_some(), "{depth} mm at {hot} °C");
        }
        let (cold, _, _) = b.run(&press(depth, ROOM_C), seed);
        assert!(
            (fx.force_n - cold.force_n).abs() <= 0.05 * cold.force_n.max(1.0),
            "heat moved the force: {} N heated, {} N at room temperature",
            fx.force_n,
            cold.force_n
        );
    }
}

/// Above the coloured transition a contact reads through its black stripes alone, whose
/// change with temperature is faint, and a small contact's black/coloured ratio is less
/// sure than flat skin's: around the LED ring the light changes within a stripe period.
/// The contact's standard deviation says so. Heated contacts just inside each lamp's
/// reflection read within 2.5 of their σ, with errors of RMS within one σ, on both paths;
/// a σ above [`CONTACT_SIGMA_LIMIT_C`] is flagged `temperature_uncertain`. Inside the
/// transition the coloured stripes read the contact: σ stays small.
#[test]
fn a_contact_temperature_says_how_sure_it_is() {
    let b = bench();
    let u = SensorUnit::reference();
    let (mut z2, mut worst, mut n) = (0.0f32, 0.0f32, 0);
    let mut check = |s: &SkinState, seed: u64| -> [f32; 2] {
        let (fx, fl, truth) = b.run(s, seed);
        let want = truth.contact_temp_c.unwrap();
        [&fx, &fl].map(|d| {
            let t = d.temperature.as_ref().unwrap();
            let (got, sd) = (t.contact_c.unwrap(), t.contact_sigma_c.unwrap());
            let flagged = d.flags.contains(Flag::TemperatureUncertain);
            assert_eq!(
                flagged,
                sd > CONTACT_SIGMA_LIMIT_C,
                "σ {sd:.2} and the flag disagree"
            );
            let z = (got - want) / sd;
            assert!(
                z.abs() <= 2.5,
                "reads {got:.2} (σ {sd:.2}), truth {want:.2}"
            );
            z2 += z * z;
            worst = worst.max(z.abs());
            n += 1;
            sd
        })
    };
    for (k, px) in (0u64..).zip(lamp_reflections_px(&u, 15.0)) {
        let c = (px.0 * u.mm_per_px(), px.1 * u.mm_per_px());
        for (depth, hot) in [(0.45f32, 40.0f32), (0.8, 44.0)] {
            check(&heated_press(c, depth, hot), 1400 + k);
        }
    }
    let inside = check(&heated_press(center_mm(&u), 1.0, 28.0), 1450);
    let rms = (z2 / n as f32).sqrt();
    println!("contact errors over σ: RMS {rms:.2}, worst {worst:.2}, over {n} readings");
    assert!(rms <= 1.0, "errors over σ: RMS {rms:.2} over {n} readings");
    assert!(
        inside.iter().all(|&sd| sd < 0.5),
        "inside the transition σ {inside:?}"
    );
}

/// A press moves the contact's chromaticity by what the camera's blur and chroma
/// compression do to squeezed stripes; the calibration measures the scatter on its own
/// kit's presses (`TemperatureModel::contact_chroma_spread`), and a contact's σ carries it.
/// Inside the coloured transition the colour moves fast with temperature, and σ grows by
/// hundredths of a degree. At its top (33.5–34.5 °C) the colour slows, the coloured
/// stripes still hold the blend, and the same scatter adds a tenth or more. Above it the black
/// stripes' ratio already dominates σ. On both paths alike.
#[test]
fn a_contacts_sigma_carries_what_a_press_does_to_its_colour() {
    let u = SensorUnit::reference();
    let with = |spread: f64| {
        let mut calib = Calibration::default_sim();
        calib.temperature.as_mut().unwrap().contact_chroma_spread = [spread; 2];
        bench_calibrated(u.clone(), calib)
    };
    let (plain, spread) = (with(0.0), with(0.005));
    let c = center_mm(&u);
    for (k, hot) in [28.0f32, 31.0, 33.5, 34.0, 34.5].into_iter().enumerate() {
        let s = heated_press(c, 1.0, hot);
        let sigma = |b: &Bench| {
            let (fx, fl, _) = b.run(&s, 1600 + k as u64);
            [fx, fl].map(|d| d.temperature.unwrap().contact_sigma_c.unwrap())
        };
        let (was, now) = (sigma(&plain), sigma(&spread));
        let grew = [now[0] - was[0], now[1] - was[1]];
        let want = if hot < 33.0 { 0.0..0.05 } else { 0.1..1.0 };
        assert!(
            grew.iter().all(|g| want.contains(g)),
            "{hot} °C: σ {was:?} without the spread, {now:?} with it"
        );
        assert!((now[0] - now[1]).abs() <= 0.05, "{hot} °C: paths {now:?}");
    }
}

/// An LED ring lighting the skin obliquely brightens the side of a dimple facing it and
/// darkens the other, to first order in the slope: across a sphere's contact the light is
/// a plane. The contact's coloured and black stripes lie at different places, and above the
/// coloured transition a per cent of their ratio is degrees. Heated contacts at 40 °C under
/// a strong oblique light from four directions, at five depths from 0.5 to 1.3 mm (the
/// stripes slide under the contact with depth), read within 0.5 °C of the truth on both paths
/// ([`vistaf_pipeline::thermal::trend`]).
#[test]
fn an_oblique_light_across_a_contact_does_not_read_as_heat() {
    let (mut worst, mut n) = (0.0f32, 0);
    for (k, dir) in [0.3f32, 1.9, 3.5, 5.0].into_iter().enumerate() {
        let mut u = SensorUnit::reference();
        u.imperfections.oblique_gain = 1.0;
        u.imperfections.oblique_dir_rad = dir;
        let c = center_mm(&u);
        let b = bench_of(u);
        for (j, depth) in [0.5f32, 0.7, 0.9, 1.1, 1.3].into_iter().enumerate() {
            let (fx, fl, truth) = b.run(
                &heated_press(c, depth, 40.0),
                1500 + 10 * k as u64 + j as u64,
            );
            let want = truth.contact_temp_c.unwrap();
            for d in [&fx, &fl] {
                let got = d.temperature.as_ref().unwrap().contact_c.unwrap();
                worst = worst.max((got - want).abs());
                n += 1;
            }
        }
    }
    println!("worst {worst:.2} over {n} readings");
    assert!(
        worst <= 0.5,
        "worst contact error {worst:.2} °C over {n} readings"
    );
}

/// A sphere pressed `depth_mm` at `c` (mm), the skin under it at `hot_c`.
fn heated_press(c: (f32, f32), depth_mm: f32, hot_c: f32) -> SkinState {
    let mut s = SkinState::idle(ROOM_C);
    let press = Contact {
        indenter: Indenter::Sphere { r_mm: SPHERE_R_MM },
        center_mm: c,
        depth_mm,
    };
    s.temperature
        .sources
        .push(HeatSource::under(&press, hot_c, 2.0));
    s.contacts.push(press);
    s
}

/// Beyond the calibrated range the reading is flagged, not clamped.
#[test]
fn temperatures_beyond_the_calibration_are_flagged() {
    let b = bench();
    for (k, t) in [5.0f32, 60.0].into_iter().enumerate() {
        let (fx, fl, _) = b.run(&SkinState::idle(t), 1700 + k as u64);
        for d in [&fx, &fl] {
            assert!(
                d.flags.contains(Flag::TemperatureOutOfRange),
                "{t} °C not flagged: {:?}",
                d.temperature
            );
        }
        let m = fx.temperature.as_ref().unwrap().mean_c;
        assert!(
            if t > 30.0 { m > 48.0 } else { m < 14.5 },
            "{t} °C reads {m:.2}: an out-of-range reading is reported, not clamped"
        );
    }
    // A hot spot beyond the range flags the frame and reads beyond the kit's hottest
    // setpoint (47.5 °C), not clamped to it; the skin around it still reads true.
    let c = center_mm(&SensorUnit::reference());
    let mut s = SkinState::idle(ROOM_C);
    s.temperature.sources.push(HeatSource::Spot {
        center_mm: c,
        footprint: Footprint::Disc { r_mm: 5.0 },
        temp_c: 65.0,
        spread_mm: 2.0,
    });
    let (fx, _, _) = b.run(&s, 1750);
    assert!(fx.flags.contains(Flag::TemperatureOutOfRange));
    let t = fx.temperature.unwrap();
    assert!(t.max_c > 47.5 && t.min_c < ROOM_C + 1.0, "{t:?}");
}

/// The device path's integer evaluation (Q16 invariants, tabulated cube root, integer
/// models and blend) agrees with the float models (exact CIELAB) within 0.05 °C on the
/// same blocks; and the two whole pipelines (different FTPs placing the stripes) agree, on
/// the contact's σ too.
#[test]
fn device_arithmetic_agrees_with_the_float_models() {
    let b = bench();
    let th = b.fixed.thermometer();
    let g = th.geometry().clone();
    let (mut worst_block, mut worst_path, mut blocks) = (0.0f32, 0.0f32, 0usize);
    for (k, t) in [18.0f32, 23.3, 25.1, 27.7, 29.2, 31.6, 33.0, 38.0, 46.0]
        .into_iter()
        .enumerate()
    {
        let (img, _) = b.r.render(&press(1.0, t), 2000 + k as u64);
        let (_, sums) = b.fixed.colour_sums(&img).unwrap();
        let pooled = pool(&sums, g.bw, g.bh, BLACK_POOL);
        for (own, p) in sums.iter().zip(&pooled) {
            if let (Some(dev), Some(ora)) = (th.read(own, p), th.read_exact(own, p)) {
                worst_block = worst_block.max((dev.t_c - ora.t_c).abs());
                blocks += 1;
            }
        }
        let fx = b.fixed.analyze(&img).unwrap().temperature.unwrap();
        let fl = b.float.analyze(&img).unwrap().temperature.unwrap();
        for (a, c) in [
            (fx.mean_c, fl.mean_c),
            (fx.contact_c.unwrap(), fl.contact_c.unwrap()),
            (fx.contact_sigma_c.unwrap(), fl.contact_sigma_c.unwrap()),
        ] {
            worst_path = worst_path.max((a - c).abs());
        }
    }
    println!(
        "device vs float models: worst {worst_block:.4} °C over {blocks} blocks; \
         whole paths: worst {worst_path:.4} °C"
    );
    assert!(blocks > 1000);
    assert!(
        worst_block <= 0.05,
        "device differs from the models by {worst_block} °C"
    );
    assert!(
        worst_path <= 0.1,
        "the two pipelines differ by {worst_path} °C"
    );
}
