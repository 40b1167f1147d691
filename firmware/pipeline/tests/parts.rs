//! A press is judged apart from tile groups elsewhere in the view: phase of the other sign
//! far from it (faint fringes' noise, a glare's edge) does not make it a dipole.
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

use vistaf_pipeline::calibration::Calibration;
use vistaf_pipeline::{Analyzer, AnalyzerOptions, Implementation, Measurement};
use vistaf_sim::contact::{Contact, Indenter};
use vistaf_sim::scene::ROOM_C;
use vistaf_sim::{Renderer, SensorUnit, SkinState};

/// Phase of the patches pasted from a shifted grating, rad.
const PATCH_RAD: f32 = 0.6;
/// Side of a patch, grating periods.
const PATCH_PERIODS: f32 = 4.0;

fn unit() -> SensorUnit {
    SensorUnit::reference_sized(640, 480)
}

/// A shallow press of the calibrated sphere at `at_mm`.
fn press(at_mm: (f32, f32), depth_mm: f32) -> SkinState {
    let mut s = SkinState::idle(ROOM_C);
    s.contacts.push(Contact {
        indenter: Indenter::Sphere { r_mm: 5.0 },
        center_mm: at_mm,
        depth_mm,
    });
    s
}

/// `img` with squares `PATCH_PERIODS` periods wide centred at `centres` (px) taken from
/// `from`: there the grating stands shifted as `from`'s does.
fn pasted(
    img: &image::RgbImage,
    from: &image::RgbImage,
    centres: &[(u32, u32)],
) -> image::RgbImage {
    let half = (PATCH_PERIODS * unit().period_px / 2.0) as u32;
    let mut out = img.clone();
    for &(cx, cy) in centres {
        for y in cy - half..cy + half {
            for x in cx - half..cx + half {
                out.put_pixel(x, y, *from.get_pixel(x, y));
            }
        }
    }
    out
}

fn analyzers(reference: &image::RgbImage) -> Vec<Analyzer> {
    [Implementation::Fixed, Implementation::Float]
        .into_iter()
        .map(|imp| {
            let opts = AnalyzerOptions {
                force_calibration: true,
                ..Default::default()
            };
            Analyzer::new(reference, Calibration::default_sim(), imp, opts).unwrap()
        })
        .collect()
}

fn centre_px(m: &Measurement) -> (f32, f32) {
    m.centroid_px.unwrap()
}

/// The reference unit's renderer, its reference at rest, and a frame of the calibrated
/// sphere pressed `depth_mm` at (180, 300) px with the truth's contact centre, px.
fn pressed_scene(depth_mm: f32) -> (Renderer, image::RgbImage, image::RgbImage, (f32, f32)) {
    let u = unit();
    let r = Renderer::new(u.clone());
    let (reference, _) = r.render(&SkinState::idle(ROOM_C), 1);
    let mmpp = u.mm_per_px();
    let (frame, truth) = r.render(&press((180.0 * mmpp, 300.0 * mmpp), depth_mm), 9);
    (r, reference, frame, truth.contact_px.unwrap())
}

/// Every analyzer reports a contact in `img` within 1.5 mm of `truth_px`.
fn assert_found_at(analyzers: &[Analyzer], img: &image::RgbImage, truth_px: (f32, f32)) {
    for a in analyzers {
        let m = a.analyze(img).unwrap();
        assert!(m.contact, "no contact: {m:?}");
        let (x, y) = centre_px(&m);
        let off_mm = (x - truth_px.0).hypot(y - truth_px.1) * unit().mm_per_px();
        assert!(off_mm < 1.5, "centre {off_mm:.2} mm off: {m:?}");
    }
}

/// Two patches whose grating stands shifted against the indentation's sign, each larger
/// than the press, lie far from a 0.3 mm press: weighed with them as one region, its
/// opposite-signed phase outweighs the press. Judged apart, the press is reported at its
/// place on both paths, and the patches alone (of either sign) are read as they are: of
/// the indentation's sign a contact, of the other none.
#[test]
fn a_press_is_not_weighed_with_phase_of_the_other_sign_far_from_it() {
    let (r, reference, frame, truth_px) = pressed_scene(0.3);
    let patches = [(460, 120), (470, 360)];
    let shift_px = PATCH_RAD / std::f32::consts::TAU * unit().period_px;
    let shifted = |sign: f32| {
        let mut s = SkinState::idle(ROOM_C);
        s.shift_px = (sign * shift_px, 0.0);
        r.render(&s, 5).0
    };
    let analyzers = analyzers(&reference);
    // Which shift reads as indentation: its patches alone are a contact, the other's not.
    let reads: Vec<(f32, Vec<bool>)> = [1.0, -1.0]
        .into_iter()
        .map(|sign| {
            let only = pasted(&reference, &shifted(sign), &patches);
            (
                sign,
                analyzers
                    .iter()
                    .map(|a| a.analyze(&only).unwrap().contact)
                    .collect(),
            )
        })
        .collect();
    assert!(
        reads.iter().any(|(_, c)| c.iter().all(|&c| c))
            && reads.iter().any(|(_, c)| c.iter().all(|&c| !c)),
        "{reads:?}"
    );
    let opposite = reads.iter().find(|(_, c)| !c[0]).unwrap().0;
    let img = pasted(&frame, &shifted(opposite), &patches);
    assert_found_at(&analyzers, &img, truth_px);
}

/// `img` with each square of `patches` (centre px, phase rad) taken from the reference
/// rendered with its grating shifted by that phase.
fn with_patches(
    r: &Renderer,
    img: &image::RgbImage,
    patches: &[((u32, u32), f32)],
) -> image::RgbImage {
    let period_px = unit().period_px;
    patches.iter().fold(img.clone(), |out, &(at, rad)| {
        let mut s = SkinState::idle(ROOM_C);
        s.shift_px = (rad / std::f32::consts::TAU * period_px, 0.0);
        pasted(&out, &r.render(&s, 5).0, &[at])
    })
}

/// The sign of a grating shift that reads as indentation: a patch shifted by it alone is
/// a contact.
fn indentation_sign(r: &Renderer, reference: &image::RgbImage, a: &Analyzer) -> f32 {
    let only = with_patches(r, reference, &[((460, 120), PATCH_RAD)]);
    if a.analyze(&only).unwrap().contact {
        1.0
    } else {
        -1.0
    }
}

/// Several groups stand alone beside a press, as the phase of a skin away from the
/// reference's temperature does in many places: two shallow patches of the indentation's
/// sign and, between them, two of the other sign that make the whole region a dipole. The
/// press, its phase standing more than twice as far out as theirs, is still reported at
/// its place on both paths.
#[test]
fn a_press_standing_out_of_several_groups_is_reported() {
    let (r, reference, frame, truth_px) = pressed_scene(0.6);
    let analyzers = analyzers(&reference);
    let sign = indentation_sign(&r, &reference, &analyzers[0]);
    let shallow = 0.12 * sign;
    let img = with_patches(
        &r,
        &frame,
        &[
            ((470, 90), shallow),
            ((470, 400), shallow),
            ((420, 200), -3.0 * shallow),
            ((520, 300), -3.0 * shallow),
        ],
    );
    assert_found_at(&analyzers, &img, truth_px);
}
