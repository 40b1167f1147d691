//! Where the method fails, it says so: each failure mode sets its flag, and clean frames
//! carry none. (The stability sweeps that chart error and flag rate against each axis are
//! a benchmark; these are the pass/fail edges.)
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

use vistaf_pipeline::calibration::{Calibration, DepthError};
use vistaf_pipeline::{Analyzer, AnalyzerOptions, Implementation, Measurement};
use vistaf_protocol::Flag;
use vistaf_sim::contact::{Contact, Footprint, Indenter};
use vistaf_sim::scene::{center_mm, ROOM_C, SPHERE_R_MM};
use vistaf_sim::{Renderer, SensorUnit, SkinState};

fn unit() -> SensorUnit {
    SensorUnit::reference_sized(320, 240)
}

fn analyze(state: &SkinState, imp: Implementation) -> Measurement {
    analyze_on(unit(), state, imp)
}

fn analyze_on(unit: SensorUnit, state: &SkinState, imp: Implementation) -> Measurement {
    let r = Renderer::new(unit);
    let (reference, _) = r.render(&SkinState::idle(ROOM_C), 1);
    let opts = AnalyzerOptions {
        force_calibration: true,
        ..Default::default()
    };
    let a = Analyzer::new(&reference, Calibration::default_sim(), imp, opts).unwrap();
    let (img, _) = r.render(state, 9);
    a.analyze(&img).unwrap()
}

fn sphere(r_mm: f32, depth_mm: f32) -> SkinState {
    let mut s = SkinState::idle(ROOM_C);
    s.contacts.push(Contact {
        indenter: Indenter::Sphere { r_mm },
        center_mm: center_mm(&unit()),
        depth_mm,
    });
    s
}

fn both(state: &SkinState, flag: Flag, want: bool) {
    for imp in [Implementation::Fixed, Implementation::Float] {
        let d = analyze(state, imp);
        assert_eq!(
            d.flags.contains(flag),
            want,
            "{imp:?}: {flag:?} expected {want}: {d:?}"
        );
    }
}

#[test]
fn washed_out_fringes_flag_low_contrast() {
    let mut s = SkinState::idle(ROOM_C);
    s.contrast_scale = 0.15;
    both(&s, Flag::LowContrast, true);
    both(&SkinState::idle(ROOM_C), Flag::LowContrast, false);
}

#[test]
fn saturation_flags_over_exposure() {
    let mut s = SkinState::idle(ROOM_C);
    s.exposure_scale = 4.0;
    both(&s, Flag::OverExposure, true);
}

#[test]
fn a_shift_near_half_a_period_flags_misregistration() {
    let mut s = SkinState::idle(ROOM_C);
    s.shift_px = (7.5, 0.0); // 7.5 px of a 16 px period: 2.9 rad, nearly ambiguous
    both(&s, Flag::Misregistration, true);
    s.shift_px = (5.0, 1.0); // compensated exactly
    both(&s, Flag::Misregistration, false);
}

/// Flat punches keep the depth the band takes from the calibrated sphere's apex, so they
/// read deep: wherever a punch of more area than the blunt margin allows
/// (`BLUNTNESS_RATIO`) leaves the tolerance, the phase-slope flag is set. The 3 mm disc
/// at 0.8 mm reads just past the tolerance with less than twice the sphere's area, so only
/// a narrow margin flags it. (A punch too narrow to show its plateau is the next test's.)
#[test]
fn out_of_tolerance_blunt_contacts_are_flagged() {
    let mut flagged_any = false;
    for (r, d) in [
        (2.0, 1.4),
        (3.0, 0.5),
        (3.0, 0.8),
        (4.0, 0.4),
        (4.0, 0.9),
        (6.0, 0.6),
        (6.0, 0.9),
    ] {
        let mut s = SkinState::idle(ROOM_C);
        s.contacts.push(Contact {
            indenter: Indenter::Punch(Footprint::Disc { r_mm: r }),
            center_mm: center_mm(&unit()),
            depth_mm: d,
        });
        for imp in [Implementation::Fixed, Implementation::Float] {
            let x = analyze(&s, imp);
            let err = (x.peak_depth_mm - d).abs();
            let flagged = x.flags.contains(Flag::PhaseSlope);
            flagged_any |= flagged;
            assert!(
                flagged || err <= 0.03 * d + 0.02,
                "{imp:?} disc r {r} d {d}: error {err} mm without a flag: {x:?}"
            );
        }
    }
    assert!(
        flagged_any,
        "no disc was flagged: the test no longer reaches the flag"
    );
}

/// A 2 mm disc is too narrow for its profile to show a plateau, and its blurred map is the
/// calibrated sphere's a little deeper: its area and load pass it for the sphere, and it
/// reads deep. Wherever it reads beyond the tolerance it carries a flag, `depth_uncertain`
/// where nothing else speaks (a punch of its sharpness would read that far off); the
/// calibrated sphere, wide enough to be told from a punch, reads clean.
#[test]
fn a_punch_too_narrow_to_show_its_plateau_is_flagged_where_it_reads_deep() {
    let mut uncertain = 0;
    for d in [0.3, 0.45, 0.6, 0.8] {
        let mut s = SkinState::idle(ROOM_C);
        s.contacts.push(Contact {
            indenter: Indenter::Punch(Footprint::Disc { r_mm: 2.0 }),
            center_mm: center_mm(&unit()),
            depth_mm: d,
        });
        for imp in [Implementation::Fixed, Implementation::Float] {
            let x = analyze(&s, imp);
            let err = (x.peak_depth_mm - d).abs();
            uncertain += usize::from(x.flags.contains(Flag::DepthUncertain));
            assert!(
                err <= 0.03 * d + 0.02 || !x.flags.is_empty(),
                "{imp:?} disc r 2 d {d}: error {err} mm without a flag: {x:?}"
            );
        }
    }
    assert!(uncertain > 0, "no disc carried depth_uncertain");
    both(&sphere(SPHERE_R_MM, 1.5), Flag::DepthUncertain, false);
}

/// A flat punch wider than half the view sinks most of it evenly; registered on its
/// plateau, it read as no contact at all. It is reported, where it is, at a depth within
/// tolerance or flagged.
#[test]
fn a_punch_filling_most_of_the_view_is_reported() {
    let u = unit();
    let (mmpp, height_mm) = (u.mm_per_px(), u.height_px as f32 * u.mm_per_px());
    let c = center_mm(&u);
    let at = (c.0 + 0.1 * height_mm, c.1);
    let d = 0.9;
    for r_mm in [0.45 * height_mm, 0.55 * height_mm] {
        let mut s = SkinState::idle(ROOM_C);
        s.contacts.push(Contact {
            indenter: Indenter::Punch(Footprint::Disc { r_mm }),
            center_mm: at,
            depth_mm: d,
        });
        for imp in [Implementation::Fixed, Implementation::Float] {
            let x = analyze(&s, imp);
            assert!(
                x.contact,
                "{imp:?}: disc r {r_mm:.1} mm not reported: {x:?}"
            );
            let (cx, cy) = x.centroid_px.unwrap();
            let off_mm = (cx - at.0 / mmpp).hypot(cy - at.1 / mmpp) * mmpp;
            assert!(
                off_mm < 1.5,
                "{imp:?}: disc r {r_mm:.1} mm, centre {off_mm:.2} mm off"
            );
            let err = (x.peak_depth_mm - d).abs();
            assert!(
                x.flags.contains(Flag::PhaseSlope) || err <= 0.03 * d + 0.02,
                "{imp:?}: disc r {r_mm:.1} mm, error {err} mm without a flag: {x:?}"
            );
        }
    }
}

/// Spheres sharper than the calibrated 10 mm indenter are smoothed by the band more than
/// the calibration knows: wherever the depth error leaves the tolerance, the phase-slope
/// flag is set (or, for a contact narrower than the band resolves, `depth_unresolved`), and
/// the calibrated indenter itself is never taken for another shape.
#[test]
fn out_of_tolerance_sharp_contacts_are_flagged_and_the_calibrated_indenter_is_not() {
    for (r, d) in [
        (10.0, 0.1),
        (10.0, 1.0),
        (10.0, 2.5),
        (5.0, 1.0),
        (5.0, 2.0),
        (3.0, 0.5),
        (3.0, 2.0),
        (1.5, 0.5),
        (1.5, 2.0),
    ] {
        for imp in [Implementation::Fixed, Implementation::Float] {
            let x = analyze(&sphere(r, d), imp);
            let err = (x.peak_depth_mm - d).abs();
            let flagged = x.flags.contains(Flag::PhaseSlope);
            let unresolved = x.flags.contains(Flag::DepthUnresolved);
            if r == 10.0 {
                assert!(
                    !flagged && (err <= 0.03 * d + 0.02 || unresolved),
                    "{imp:?} R {r} d {d}: {x:?}"
                );
            } else if err > 0.03 * d + 0.02 {
                assert!(
                    flagged || unresolved,
                    "{imp:?} R {r} d {d}: error {err} mm without a flag: {x:?}"
                );
            }
        }
    }
}

/// Spheres of another radius than the calibrated one and flat punches wide enough for their
/// profile to tell are read as what they are, within tolerance; the spheres without the
/// phase-slope flag that an unknown shape of their area earns.
#[test]
fn wide_spheres_and_punches_are_read_as_what_they_are() {
    use vistaf_pipeline::measure::profile::Shape;
    let disc = |r_mm, depth_mm| {
        let mut s = SkinState::idle(ROOM_C);
        s.contacts.push(Contact {
            indenter: Indenter::Punch(Footprint::Disc { r_mm }),
            center_mm: center_mm(&unit()),
            depth_mm,
        });
        s
    };
    for (state, d, shape) in [
        (sphere(15.0, 2.0), 2.0, Shape::Sphere),
        (sphere(20.0, 1.6), 1.6, Shape::Sphere),
        (disc(5.0, 0.6), 0.6, Shape::Flat),
        (disc(5.0, 0.9), 0.9, Shape::Flat),
        (disc(7.0, 0.9), 0.9, Shape::Flat),
    ] {
        for imp in [Implementation::Fixed, Implementation::Float] {
            let x = analyze(&state, imp);
            let err = (x.peak_depth_mm - d).abs();
            assert_eq!(x.shape, shape, "{imp:?} d {d}: {x:?}");
            assert!(
                err <= 0.03 * d + 0.02,
                "{imp:?} d {d}: error {err} mm: {x:?}"
            );
            if shape == Shape::Sphere {
                assert!(!x.flags.contains(Flag::PhaseSlope), "{imp:?} d {d}: {x:?}");
            }
        }
    }
}

/// A flat punch whose skirt cannot have sunk the frame's registration is read at its
/// plateau's level and spared the calibrated indenter's area and load tests: on a view
/// wide enough, punches from 3 to 6 mm in radius read within tolerance without the
/// phase-slope flag. (On the small view, a 6 mm punch's skirt covers the background, and
/// it keeps the tests: `out_of_tolerance_blunt_contacts_are_flagged`.)
#[test]
fn a_plateau_whose_skirt_spared_the_registration_reads_unflagged() {
    use vistaf_pipeline::measure::profile::Shape;
    let wide = SensorUnit::reference();
    for (r_mm, d) in [(3.0, 0.5), (4.0, 0.8), (6.0, 0.4), (6.0, 0.9)] {
        let mut s = SkinState::idle(ROOM_C);
        s.contacts.push(Contact {
            indenter: Indenter::Punch(Footprint::Disc { r_mm }),
            center_mm: center_mm(&wide),
            depth_mm: d,
        });
        for imp in [Implementation::Fixed, Implementation::Float] {
            let x = analyze_on(wide.clone(), &s, imp);
            let err = (x.peak_depth_mm - d).abs();
            assert_eq!(x.shape, Shape::Flat, "{imp:?} disc r {r_mm} d {d}: {x:?}");
            assert!(
                err <= 0.03 * d + 0.02,
                "{imp:?} disc r {r_mm} d {d}: error {err} mm: {x:?}"
            );
            assert!(
                !x.flags.contains(Flag::PhaseSlope),
                "{imp:?} disc r {r_mm} d {d}: {x:?}"
            );
        }
    }
}

/// `img` with its stripes averaged away over the square of side `side_px` centred at
/// `(x, y)`: each pixel takes the square's mean colour, as where the camera loses the
/// fringe (a dark crescent at a punch's rim, a clipped glint).
fn blot(img: &image::RgbImage, (x, y): (f32, f32), side_px: u32) -> image::RgbImage {
    let mut out = img.clone();
    let x0 = (x - side_px as f32 / 2.0).round().max(0.0) as u32;
    let y0 = (y - side_px as f32 / 2.0).round().max(0.0) as u32;
    let (x1, y1) = (
        (x0 + side_px).min(img.width()),
        (y0 + side_px).min(img.height()),
    );
    let mut sum = [0u64; 3];
    for py in y0..y1 {
        for px in x0..x1 {
            for (s, v) in sum.iter_mut().zip(img.get_pixel(px, py).0) {
                *s += u64::from(v);
            }
        }
    }
    let n = u64::from((x1 - x0) * (y1 - y0)).max(1);
    let mean = image::Rgb(sum.map(|s| (s / n) as u8));
    for py in y0..y1 {
        for px in x0..x1 {
            out.put_pixel(px, py, mean);
        }
    }
    out
}

/// The calibrated sphere pressed 1.5 mm at the view's centre: the reference, the frame and
/// the contact's centre, px.
fn deep_sphere() -> (image::RgbImage, image::RgbImage, (f32, f32)) {
    let r = Renderer::new(unit());
    let (reference, _) = r.render(&SkinState::idle(ROOM_C), 1);
    let (img, truth) = r.render(&sphere(SPHERE_R_MM, 1.5), 9);
    (reference, img, truth.contact_px.unwrap())
}

/// On both paths, each case's frame against its reference reports the press, and carries
/// `phase_slope` as the case wants.
fn phase_slope_as(cases: &[(&str, &image::RgbImage, image::RgbImage, bool)]) {
    let opts = AnalyzerOptions {
        force_calibration: true,
        ..Default::default()
    };
    for imp in [Implementation::Fixed, Implementation::Float] {
        for &(what, reference, ref frame, want) in cases {
            let a = Analyzer::new(reference, Calibration::default_sim(), imp, opts).unwrap();
            let d = a.analyze(frame).unwrap();
            assert!(d.contact, "{imp:?}, {what}: {d:?}");
            assert_eq!(
                d.flags.contains(Flag::PhaseSlope),
                want,
                "{imp:?}, {what}: {d:?}"
            );
        }
    }
}

/// The apex is read from the map blurred over the demodulator's kernel: where the fringe
/// was lost within its reach, it averages a phase nobody read, and the press is flagged.
/// The calibrated sphere reads clean; with the fringe lost over a square of one period at
/// its apex (too few samples for the band-loss count of the whole contact) it carries
/// `phase_slope`; with the same square lost away from the contact, it does not.
#[test]
fn an_apex_beside_a_lost_fringe_is_flagged() {
    let (reference, img, at) = deep_sphere();
    let side = unit().period_px.round() as u32;
    let far = (
        at.0 + 0.3 * unit().width_px as f32,
        at.1 + 0.25 * unit().height_px as f32,
    );
    phase_slope_as(&[
        ("clean", &reference, img.clone(), false),
        ("lost at the apex", &reference, blot(&img, at, side), true),
        (
            "lost away from the contact",
            &reference,
            blot(&img, far, side),
            false,
        ),
    ]);
}

/// The band is lost where a press took the fringe away, not where the skin never showed
/// one: a square of two periods on the calibrated sphere's flank (beyond the apex reading's
/// reach) whose fringe is gone in the frame alone carries `phase_slope`; the same square
/// gone in the reference too (a pale patch of pigment, a glare spot) is a part of the skin
/// no frame can read, and leaves the press unflagged, as the clean frame is.
#[test]
fn a_fringe_the_reference_never_had_is_not_a_lost_band() {
    let (reference, img, at) = deep_sphere();
    let period = unit().period_px;
    let flank = (at.0 + 2.5 * period, at.1);
    let side = (2.0 * period).round() as u32;
    let pale_reference = blot(&reference, flank, side);
    phase_slope_as(&[
        ("clean", &reference, img.clone(), false),
        (
            "lost in the frame",
            &reference,
            blot(&img, flank, side),
            true,
        ),
        (
            "never there",
            &pale_reference,
            blot(&img, flank, side),
            false,
        ),
    ]);
}

/// A shallow press standing little above a noisy unit's contact threshold cannot show its
/// width: the noise is a share of its region and of both blurred readings at its apex, and
/// a contact narrower than the band can pass for a resolved one at a fraction of its depth.
/// On a fine-pitched, noisy unit, shallow presses of the calibrated sphere at ten places
/// are reported with their depth within tolerance or with a flag (or not at all: they are
/// lighter than the 0.2 mm from which every press must be reported).
#[test]
fn a_press_near_the_noise_floor_is_within_tolerance_or_flagged() {
    let mut unit = SensorUnit::reference_sized(320, 240);
    (unit.period_px, unit.tilt_deg, unit.noise_dn) = (8.0, -6.75, 3.0);
    let r = Renderer::new(unit.clone());
    let (reference, _) = r.render(&SkinState::idle(ROOM_C), 1);
    let opts = AnalyzerOptions {
        force_calibration: true,
        ..Default::default()
    };
    let depth_mm = 0.15;
    for imp in [Implementation::Fixed, Implementation::Float] {
        let a = Analyzer::new(&reference, Calibration::default_sim(), imp, opts).unwrap();
        for seed in 2..12u64 {
            let c = center_mm(&unit);
            let mut s = SkinState::idle(ROOM_C);
            s.contacts.push(Contact {
                indenter: Indenter::Sphere { r_mm: SPHERE_R_MM },
                center_mm: (c.0 + 0.37 * seed as f32, c.1 - 0.23 * seed as f32),
                depth_mm,
            });
            let (img, _) = r.render(&s, seed);
            let m = a.analyze(&img).unwrap();
            let err = (m.peak_depth_mm - depth_mm).abs();
            assert!(
                m.peak_depth_mm == 0.0 || err <= 0.03 * depth_mm + 0.02 || !m.flags.is_empty(),
                "{imp:?} place {seed}: {:.3} mm read for {depth_mm} mm without a flag: {m:?}",
                m.peak_depth_mm
            );
        }
    }
}

/// A unit whose calibration could not hold its own kit's presses (its depth model's
/// held-out error, `depth.cv_rmse`, in a file without the error by depth) cannot hold the
/// depth tolerance either where that is under twice the error: a 1 mm press is flagged
/// `depth_uncertain` there, a deep one (whose tolerance, 3 % of the depth + 20 µm, is
/// wider) is not, and on a calibration that held its kit neither is. (Shallower, the
/// sphere's map would also be a narrow punch's, which carries the flag on any
/// calibration: the test above.)
#[test]
fn a_depth_model_that_missed_its_kit_flags_the_depths_it_cannot_hold() {
    let held = Calibration::default_sim();
    let mut missed = held.clone();
    missed.depth_error = None;
    missed.depth.cv_rmse = 0.03;
    for (depth_mm, uncertain) in [(1.0, true), (1.8, false)] {
        depth_uncertain_as(depth_mm, &[(&held, false), (&missed, uncertain)]);
    }
}

/// The same held-out error of 0.03 mm over a kit whose deep presses missed by a share of
/// their depth (a floor of 0.004 mm and a share of 2.2 %, `depth_error`) doubts its deep
/// presses and not its shallow ones: a 1 mm press (tolerance 0.05 mm against twice
/// 0.022 mm) carries no `depth_uncertain`, a 2.2 mm one (0.086 mm against twice 0.049 mm)
/// does. The whole held-out error would have doubted the shallow press and trusted the
/// deep one.
#[test]
fn a_depth_model_that_missed_its_deep_presses_flags_those_alone() {
    let mut missed = Calibration::default_sim();
    missed.depth.cv_rmse = 0.03;
    missed.depth_error = Some(DepthError {
        floor_mm: 0.004,
        share: 0.022,
    });
    for (depth_mm, uncertain) in [(1.0, false), (2.2, true)] {
        depth_uncertain_as(depth_mm, &[(&missed, uncertain)]);
    }
}

/// A unit where a press the kit never pressed may read off by a share of the depth
/// (`depth_place_spread`) cannot hold the tolerance's share at depths its floor no
/// longer covers: with a spread of 2.2 %, a 1.8 mm press (over 0.02 mm / (4.4 % − 3 %) =
/// 1.43 mm) is flagged `depth_uncertain` and a 1 mm one is not; with a spread of 1 %, or
/// none recorded, neither is.
#[test]
fn presses_that_read_apart_from_place_to_place_flag_the_deep_presses() {
    let held = Calibration::default_sim();
    let spread = |s: f64| Calibration {
        depth_place_spread: Some(s),
        ..held.clone()
    };
    let (narrow, wide) = (spread(0.01), spread(0.022));
    for (depth_mm, uncertain) in [(1.0, false), (1.8, true)] {
        depth_uncertain_as(
            depth_mm,
            &[(&held, false), (&narrow, false), (&wide, uncertain)],
        );
    }
}

/// A depth model whose held-out misses all lie in its floor (0.012 mm, no share) on a unit
/// whose presses of one depth read 2 % apart from place to place: a reading's error is
/// both, and a 1.8 mm press, whose tolerance (0.074 mm) is more than twice either alone
/// (0.024 and 0.036 mm) but less than twice `√(0.012² + 0.036²)`, is flagged
/// `depth_uncertain`; a 1 mm press, within it, is not.
#[test]
fn a_held_out_floor_and_places_reading_apart_flag_together_what_neither_flags_alone() {
    let held = Calibration::default_sim();
    let floor = Calibration {
        depth_error: Some(DepthError {
            floor_mm: 0.012,
            share: 0.0,
        }),
        ..held.clone()
    };
    let apart = Calibration {
        depth_place_spread: Some(0.02),
        ..held.clone()
    };
    let both = Calibration {
        depth_place_spread: Some(0.02),
        ..floor.clone()
    };
    for (depth_mm, uncertain) in [(1.0, false), (1.8, true)] {
        depth_uncertain_as(
            depth_mm,
            &[(&floor, false), (&apart, false), (&both, uncertain)],
        );
    }
}

/// Asserts on both paths that a press of the calibrated sphere `depth_mm` deep is read, and
/// carries `depth_uncertain` under each calibration of `cases` as its flag says.
fn depth_uncertain_as(depth_mm: f32, cases: &[(&Calibration, bool)]) {
    let r = Renderer::new(unit());
    let (reference, _) = r.render(&SkinState::idle(ROOM_C), 1);
    let (img, _) = r.render(&sphere(SPHERE_R_MM, depth_mm), 9);
    let opts = AnalyzerOptions {
        force_calibration: true,
        ..Default::default()
    };
    for imp in [Implementation::Fixed, Implementation::Float] {
        for &(calib, want) in cases {
            let a = Analyzer::new(&reference, calib.clone(), imp, opts).unwrap();
            let m = a.analyze(&img).unwrap();
            assert!(m.peak_depth_mm > 0.0, "{imp:?} {depth_mm} mm: {m:?}");
            assert_eq!(
                m.flags.contains(Flag::DepthUncertain),
                want,
                "{imp:?} {depth_mm} mm, depth model's held-out error {} mm, places {:?} \
                 apart, by depth {:?}: {m:?}",
                calib.depth.cv_rmse,
                calib.depth_place_spread,
                calib.depth_error
            );
        }
    }
}

/// On a noisy unit a narrow press's peak stands barely above the noise, over fewer samples
/// than a disc a period across: from 0.2 mm on it is still reported at its place, and
/// where it was found by its shape alone it says so (`faint_contact`, which doubts its
/// force too). The untouched skin stays untouched.
#[test]
fn a_faint_narrow_press_is_reported_at_its_place_and_said_to_be_faint() {
    let mut noisy = unit();
    noisy.noise_dn = 4.0;
    let idle = analyze_on(
        noisy.clone(),
        &SkinState::idle(ROOM_C),
        Implementation::Fixed,
    );
    assert!(!idle.contact, "{idle:?}");
    let (cx, cy) = center_mm(&noisy);
    let mut faint = 0;
    for step in 0..=20 {
        let depth_mm = 0.05 + 0.0125 * step as f32;
        let m = analyze_on(noisy.clone(), &sphere(2.5, depth_mm), Implementation::Fixed);
        if m.contact {
            let (x, y) = m.centroid_px.unwrap();
            let mmpp = noisy.mm_per_px();
            let off_mm = (x * mmpp - cx).hypot(y * mmpp - cy);
            assert!(off_mm < 1.5, "{depth_mm} mm: {off_mm} mm off");
        } else {
            assert!(depth_mm < 0.2, "{depth_mm} mm missed: {m:?}");
        }
        if m.flags.contains(Flag::FaintContact) {
            faint += 1;
            assert!(m.flags.contains(Flag::DepthUnresolved), "{m:?}");
        }
    }
    assert!(faint > 0, "no press was found by its shape alone");
}
