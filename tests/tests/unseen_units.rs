//! Units the pipeline was not tuned on: each is calibrated on its own kit (rendered,
//! written as frame sets, read back, fitted) and then measured on presses with other noise
//! seeds at a position the kit never used. The accuracy targets of the force-and-shape
//! pipeline must hold: peak depth within 3 % + 0.02 mm over 0.1–2.5 mm, contact centre
//! within 0.5 mm, force RMSE within 8 % of full scale over 0.5–30 N; and those of the
//! temperature pipeline: ≤ 0.3 °C within 22–32 °C and ≤ 1.0 °C over 15–45 °C at setpoints
//! the kit never used, a heated contact within 0.8 °C. The calibration's remarks name each
//! frame it left out once, however many of its stages left it out.
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

use vistaf_calibrate::{calibrate, Notes};
use vistaf_hardware::frameset::FrameSet;
use vistaf_pipeline::calibration::Calibration;
use vistaf_pipeline::{Analyzer, AnalyzerOptions, Implementation};
use vistaf_protocol::Flag;
use vistaf_sim::contact::{Contact, Indenter};
use vistaf_sim::scene::{center_mm, ROOM_C, SPHERE_R_MM};
use vistaf_sim::sets::{kit_states, write_states, SetOptions};
use vistaf_sim::thermal::HeatSource;
use vistaf_sim::{Renderer, SensorUnit, SkinState};
use vistaf_tests::accuracy::{unit_scenes, Kind};

/// Renders `unit`'s calibration kit (as frame sets, read back) and calibrates it: the
/// calibration and its remarks.
fn calibrate_kit(unit: &SensorUnit, seed: u64, name: &str) -> (Calibration, Notes) {
    let dir = std::env::temp_dir().join(format!("vistaf-{name}-{seed}-{}", std::process::id()));
    let [depth, force, temps] = kit_states(unit);
    let opts = SetOptions {
        truth_maps: false,
        seed: 5,
        unit_seed: seed,
        encoding: Default::default(),
    };
    let sets: Vec<FrameSet> = [
        ("depth", &depth),
        ("force", &force),
        ("temperature", &temps),
    ]
    .iter()
    .map(|(name, states)| {
        write_states(&dir.join(name), name, unit, states, &opts, |_, _| {}).unwrap()
    })
    .collect();
    let mut notes = Notes::default();
    let calib = calibrate(&sets, Implementation::Fixed, &mut notes);
    std::fs::remove_dir_all(&dir).unwrap();
    (calib.unwrap(), notes)
}

/// The device path with `calib`, on a reference of the skin at rest that `r` renders with
/// its own noise draw.
fn analyzer(r: &Renderer, calib: Calibration) -> Analyzer {
    let (reference, _) = r.render(&SkinState::idle(ROOM_C), 77);
    Analyzer::new(
        &reference,
        calib,
        Implementation::Fixed,
        AnalyzerOptions::default(),
    )
    .unwrap()
}

fn check_unit(seed: u64) {
    let unit = SensorUnit::from_seed(seed);
    let (calib, notes) = calibrate_kit(&unit, seed, "unseen");
    // A frame left out of several stages, for one reason or several, is reported once.
    let left_out: Vec<&str> = notes
        .0
        .iter()
        .filter_map(|n| n.split_once(" left out of ").map(|(frame, _)| frame))
        .collect();
    for (k, frame) in left_out.iter().enumerate() {
        assert!(
            !left_out[..k].contains(frame),
            "unit {seed}: {frame} reported left out twice: {:?}",
            notes.0
        );
    }

    let r = Renderer::new(unit.clone());
    let a = analyzer(&r, calib);
    let c = center_mm(&unit);
    let fov = unit.height_px as f32 * unit.mm_per_px();
    let at = (c.0 + 0.05 * fov, c.1 - 0.15 * fov); // not a kit position
    let sphere = Indenter::Sphere { r_mm: SPHERE_R_MM };
    let press = |depth_mm: f32| {
        let mut s = SkinState::idle(ROOM_C);
        s.contacts.push(Contact {
            indenter: sphere.clone(),
            center_mm: at,
            depth_mm,
        });
        s
    };
    let label = format!(
        "unit {seed} ({}×{}, {:.1} px period, {:+.1}°)",
        unit.width_px, unit.height_px, unit.period_px, unit.tilt_deg
    );
    for (k, depth) in [0.1f32, 0.3, 0.6, 1.0, 1.5, 2.0, 2.5]
        .into_iter()
        .enumerate()
    {
        let (img, truth) = r.render(&press(depth), 1000 + k as u64);
        let d = a.analyze(&img).unwrap();
        let tol = 0.03 * depth + 0.02;
        // A press whose contact is narrower than the band resolves (a radius √(R·d) under
        // about 1.6 mm: about 0.26 mm deep for this 10 mm sphere; the bound below leaves
        // room for the unit's own blur) may read low, and then says so, and a shallow one
        // may carry `depth_uncertain` where its tolerance is narrower than the calibration's
        // own held-out error allows for, or where its profile is not yet clearly a dome's
        // and a narrow flat punch a little shallower would leave the same map; from 1.5 mm,
        // wider, it meets the tolerance and carries no flag.
        let unresolved = d.flags.contains(Flag::DepthUnresolved);
        assert!(
            (d.peak_depth_mm - depth).abs() <= tol || unresolved,
            "{label}: {} mm for {depth} mm",
            d.peak_depth_mm
        );
        let (tx, ty) = truth.contact_px.unwrap();
        let (cx, cy) = d.centroid_px.unwrap();
        let err_mm = (cx - tx).hypot(cy - ty) * unit.mm_per_px();
        assert!(
            err_mm <= 0.5,
            "{label}: centre off by {err_mm} mm at {depth} mm"
        );
        assert!(
            d.flags
                .iter()
                .all(|f| matches!(f, Flag::DepthUnresolved | Flag::DepthUncertain))
                && (depth < 1.5 || d.flags.is_empty()),
            "{label}: {depth} mm flagged {:?}",
            d.flags
        );
    }
    let forces = [0.5f32, 1.0, 3.0, 6.0, 10.0, 15.0, 20.0, 25.0, 30.0];
    let mut sq = 0.0f32;
    for (k, f) in forces.iter().enumerate() {
        let (img, _) = r.render(
            &press(sphere.depth_for_force_mm(*f, unit.modulus_mpa)),
            2000 + k as u64,
        );
        let d = a.analyze(&img).unwrap();
        sq += (d.force_n - f).powi(2);
    }
    let rmse = (sq / forces.len() as f32).sqrt();
    println!(
        "{label}: force RMSE {rmse:.3} N ({:.2} % of 30 N)",
        100.0 * rmse / 30.0
    );
    assert!(rmse <= 0.08 * 30.0, "{label}: force RMSE {rmse} N");

    // Temperature: uniform skins at setpoints the kit never used (per-setpoint means of the
    // skin's mean), and a heated contact (its footprint's mean).
    let mut report = Vec::new();
    for (k, t) in [16.5f32, 21.5, 23.5, 26.5, 29.5, 31.5, 36.0, 43.0]
        .into_iter()
        .enumerate()
    {
        let (img, _) = r.render(&SkinState::idle(t), 3000 + k as u64);
        let d = a.analyze(&img).unwrap();
        let m = d.temperature.unwrap().mean_c;
        let tol = if (22.0..=32.0).contains(&t) { 0.3 } else { 1.0 };
        assert!((m - t).abs() <= tol, "{label}: {m:.3} °C at {t} °C");
        report.push(format!("{t}: {:+.3}", m - t));
    }
    let mut s = press(1.0);
    let heat = HeatSource::under(&s.contacts[0], 38.0, 2.0);
    s.temperature.sources.push(heat);
    let (img, truth) = r.render(&s, 3100);
    let got = a
        .analyze(&img)
        .unwrap()
        .temperature
        .unwrap()
        .contact_c
        .unwrap();
    let want = truth.contact_temp_c.unwrap();
    println!(
        "{label}: temperature error per setpoint {}; heated contact {got:.2} °C for {want:.2} °C",
        report.join(", ")
    );
    assert!(
        (got - want).abs() <= 0.8,
        "{label}: contact {got} °C, truth {want} °C"
    );
}

#[test]
fn unit_8_meets_the_targets_on_its_own_calibration() {
    check_unit(8);
}

#[test]
fn unit_9_meets_the_targets_on_its_own_calibration() {
    check_unit(9);
}

/// A pale unit whose black stripes' features bend sharply inside the coloured transition:
/// it read 19.6 °C at 16.5 °C while the fusion's variance tables were indexed by each
/// population's own estimate, and a 38 °C contact 0.95 °C high while the black model was
/// judged over every setpoint.
#[test]
fn unit_52_meets_the_targets_on_its_own_calibration() {
    check_unit(52);
}

/// Large stripes on a small camera (20 px period at 320×240, 6.7 working pixels per
/// period): read at the reference carrier with the flat skin's band, the stripes squeezed
/// by the press blurred into each other and a 38 °C contact read 0.87 °C high.
#[test]
fn unit_54_meets_the_targets_on_its_own_calibration() {
    check_unit(54);
}

/// A small view that a 2.5 mm press nearly fills: registered on the few background samples
/// left around the contact, the skirt of the indentation took 0.12 mm off its depth.
#[test]
fn unit_55_meets_the_targets_on_its_own_calibration() {
    check_unit(55);
}

/// A unit whose fine stripes are too faint for its noisy sensor in every frame: each kit
/// frame carries `low_contrast`. That is the unit's condition, not a frame's: its
/// calibration takes the frames and says so (leaving them out would refuse the unit, and
/// leave the robot no reading at all), and every frame measured with it, a press reported
/// at its place or the skin at rest, carries the flag as the kit's did.
#[test]
fn a_unit_noisy_throughout_calibrates_and_flags_every_frame() {
    let unit = SensorUnit {
        period_px: 7.5,
        blur_px: 1.7,
        noise_dn: 3.5,
        ..SensorUnit::reference()
    };
    let (calib, notes) = calibrate_kit(&unit, 0, "noisy");
    assert!(
        notes
            .0
            .iter()
            .any(|n| n.contains("depth frames carry low_contrast")),
        "{:?}",
        notes.0
    );
    let r = Renderer::new(unit.clone());
    let a = analyzer(&r, calib);
    let c = center_mm(&unit);
    let mut pressed = SkinState::idle(ROOM_C);
    pressed.contacts.push(Contact {
        indenter: Indenter::Sphere { r_mm: SPHERE_R_MM },
        center_mm: (c.0 + 1.5, c.1 - 2.0),
        depth_mm: 1.2,
    });
    for (k, state) in [SkinState::idle(ROOM_C), pressed].iter().enumerate() {
        let (img, truth) = r.render(state, 4000 + k as u64);
        let d = a.analyze(&img).unwrap();
        assert!(d.flags.contains(Flag::LowContrast), "{k}: {:?}", d.flags);
        assert_eq!(d.contact, truth.contact_px.is_some(), "{k}: {d:?}");
        if let (Some((tx, ty)), Some((cx, cy))) = (truth.contact_px, d.centroid_px) {
            let err_mm = (cx - tx).hypot(cy - ty) * unit.mm_per_px();
            assert!(err_mm <= 1.5, "press read {err_mm} mm from its place");
        }
    }
}

/// Any units: `VISTAF_UNITS=21,22 cargo test --release -p vistaf-tests --test unseen_units
/// -- --ignored --nocapture` checks the same targets on the seeds given (for units no one
/// has looked at yet).
#[test]
#[ignore = "checks the units named in VISTAF_UNITS"]
fn units_from_the_environment_meet_the_targets() {
    let seeds = std::env::var("VISTAF_UNITS").unwrap_or_default();
    for s in seeds.split(',').filter(|s| !s.trim().is_empty()) {
        check_unit(s.trim().parse().unwrap());
    }
}

/// A unit of the accuracy battery whose lamp reflections pull the fringe's phase as the
/// pigment changes colour, so its uniform skins far from the reference's temperature show
/// raised and sunk spots. Its calibration records the colour's field at each setpoint and
/// the device path takes it out: the battery's uniform skins of that unit read no contact,
/// where the same frames read with the record dropped from the calibration show one.
#[test]
fn unit_71_s_warm_uniform_skins_are_no_contact() {
    let seed = 71;
    let unit = SensorUnit::wide(seed);
    let (calib, _) = calibrate_kit(&unit, seed, "colour-phase");
    assert!(calib.colour_phase.is_some());
    let r = Renderer::new(unit.clone());
    let with = analyzer(&r, calib.clone());
    let without = analyzer(
        &r,
        Calibration {
            colour_phase: None,
            ..calib
        },
    );
    let mut phantoms_without = 0;
    for (k, (kind, state)) in unit_scenes(seed, &unit, &[]).into_iter().enumerate() {
        if kind != Kind::Uniform {
            continue;
        }
        let t = state.temperature.base_c;
        let (img, _) = r.render(&state, seed * 1000 + k as u64);
        let d = with.analyze(&img).unwrap();
        assert!(!d.contact, "{t} °C: a contact of {} mm", d.peak_depth_mm);
        phantoms_without += usize::from(without.analyze(&img).unwrap().contact);
    }
    assert!(
        phantoms_without > 0,
        "no spot read as a contact without the record"
    );
}

/// A thick skin: drawn as a half-space, its surface sinks as `1/r` around a press over the
/// whole view, and no background is at rest to register on. Registered on the background's
/// mean, the view's far side would stand raised above it and the press read as a thermal
/// dipole, dropped without a flag. Registered on the level beyond the press's far field,
/// every press is reported at its place, its depth within tolerance or flagged.
#[test]
fn a_half_space_s_presses_are_reported_at_their_place() {
    let unit = SensorUnit {
        layer_decay_mm: f32::INFINITY,
        ..SensorUnit::from_seed(8)
    };
    let (calib, _) = calibrate_kit(&unit, 8, "half-space");
    let r = Renderer::new(unit.clone());
    let a = analyzer(&r, calib);
    let c = center_mm(&unit);
    let fov = unit.height_px as f32 * unit.mm_per_px();
    let at = (c.0 - 0.1 * fov, c.1 + 0.1 * fov); // not a kit position
    for (k, depth) in [0.3f32, 0.6, 1.0, 1.5, 2.0, 2.5].into_iter().enumerate() {
        let mut s = SkinState::idle(ROOM_C);
        s.contacts.push(Contact {
            indenter: Indenter::Sphere { r_mm: SPHERE_R_MM },
            center_mm: at,
            depth_mm: depth,
        });
        let (img, truth) = r.render(&s, 5000 + k as u64);
        let d = a.analyze(&img).unwrap();
        assert!(d.contact, "{depth} mm: no contact, flags {:?}", d.flags);
        let (tx, ty) = truth.contact_px.unwrap();
        let (cx, cy) = d.centroid_px.unwrap();
        let err_mm = (cx - tx).hypot(cy - ty) * unit.mm_per_px();
        assert!(err_mm <= 1.5, "{depth} mm: read {err_mm} mm from its place");
        assert!(
            (d.peak_depth_mm - depth).abs() <= 0.03 * depth + 0.02 || !d.flags.is_empty(),
            "{depth} mm: read {} mm, unflagged",
            d.peak_depth_mm
        );
    }
}
