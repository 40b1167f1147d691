//! A press near the edge of the view is read at its place: near the edge the demodulator's
//! kernel averages padding, and the apex is not looked for there.
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

use vistaf_pipeline::calibration::Calibration;
use vistaf_pipeline::{Analyzer, AnalyzerOptions, Implementation};
use vistaf_sim::contact::{Contact, Indenter};
use vistaf_sim::scene::{ROOM_C, SPHERE_R_MM};
use vistaf_sim::{Renderer, SensorUnit, SkinState};

/// The centre tolerance of the accuracy battery (`vistaf_tests::accuracy`), mm.
const CENTRE_TOLERANCE_MM: f32 = 1.5;

/// The calibrated sphere pressed with its contact's rim 0 and 6 pixels inside each edge
/// (within a grating period, 16 pixels on this unit): on both paths the contact is found
/// and its centre lies within the tolerance. Were the apex looked for up to the edge, a
/// spurious peak there would take it and move the centre past the tolerance.
#[test]
fn a_press_reaching_the_edge_is_read_at_its_place() {
    let unit = SensorUnit::reference_sized(320, 240);
    let r = Renderer::new(unit.clone());
    let (reference, _) = r.render(&SkinState::idle(ROOM_C), 1);
    let opts = AnalyzerOptions {
        force_calibration: true,
        ..Default::default()
    };
    let mmpp = unit.mm_per_px();
    let (w, h) = (unit.width_px as f32 * mmpp, unit.height_px as f32 * mmpp);
    for imp in [Implementation::Fixed, Implementation::Float] {
        let a = Analyzer::new(&reference, Calibration::default_sim(), imp, opts).unwrap();
        for depth_mm in [0.8f32, 1.4] {
            let contact_r_mm = (SPHERE_R_MM * depth_mm).sqrt();
            for gap_px in [0.0f32, 6.0] {
                let off = contact_r_mm + gap_px * mmpp;
                for center_mm in [
                    (w - off, h / 2.0),
                    (off, h / 2.0),
                    (w / 2.0, h - off),
                    (w / 2.0, off),
                ] {
                    let mut s = SkinState::idle(ROOM_C);
                    s.contacts.push(Contact {
                        indenter: Indenter::Sphere { r_mm: SPHERE_R_MM },
                        center_mm,
                        depth_mm,
                    });
                    let (img, truth) = r.render(&s, 9);
                    let m = a.analyze(&img).unwrap();
                    let (c, t) = (m.centroid_px.unwrap(), truth.contact_px.unwrap());
                    let err_mm = (c.0 - t.0).hypot(c.1 - t.1) * mmpp;
                    assert!(
                        err_mm < CENTRE_TOLERANCE_MM,
                        "{imp:?}: {depth_mm} mm at {center_mm:?} mm read {err_mm:.2} mm away: {m:?}"
                    );
                }
            }
        }
    }
}
