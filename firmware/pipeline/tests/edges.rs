//! A press near the edge of the view is read at its place (near the edge the demodulator's
//! kernel averages padding, and the apex is not looked for there), and one whose contact
//! runs past the edge says so.
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

use vistaf_pipeline::calibration::Calibration;
use vistaf_pipeline::{Analyzer, AnalyzerOptions, Implementation, Measurement};
use vistaf_protocol::Flag;
use vistaf_sim::contact::{Contact, Indenter};
use vistaf_sim::scene::{ROOM_C, SPHERE_R_MM};
use vistaf_sim::{Renderer, SensorUnit, SkinState};

/// The centre tolerance of the accuracy battery (`vistaf_tests::accuracy`), mm.
const CENTRE_TOLERANCE_MM: f32 = 1.5;

/// One press at the edge as a path read it.
struct Read {
    imp: Implementation,
    center_mm: (f32, f32),
    m: Measurement,
    /// The measured centre's distance from the true one, mm (`None` without a contact).
    centre_err_mm: Option<f32>,
}

/// A unit under the default calibration, on both paths.
struct Edges {
    unit: SensorUnit,
    r: Renderer,
    paths: Vec<(Implementation, Analyzer)>,
}

impl Edges {
    fn new(unit: SensorUnit) -> Edges {
        let r = Renderer::new(unit.clone());
        let (reference, _) = r.render(&SkinState::idle(ROOM_C), 1);
        let opts = AnalyzerOptions {
            force_calibration: true,
            ..Default::default()
        };
        let paths = [Implementation::Fixed, Implementation::Float]
            .into_iter()
            .map(|imp| {
                let a = Analyzer::new(&reference, Calibration::default_sim(), imp, opts);
                (imp, a.unwrap())
            })
            .collect();
        Edges { unit, r, paths }
    }

    /// The calibrated sphere pressed `depth_mm`, its centre `off_mm` from each edge in
    /// turn (halfway along it), read by both paths.
    fn press_each_edge(&self, depth_mm: f32, off_mm: f32) -> Vec<Read> {
        let sphere = Indenter::Sphere { r_mm: SPHERE_R_MM };
        self.press_each_edge_with(sphere, depth_mm, off_mm)
    }

    /// `indenter` pressed `depth_mm`, its centre `off_mm` from each edge in turn (halfway
    /// along it), read by both paths.
    fn press_each_edge_with(&self, indenter: Indenter, depth_mm: f32, off_mm: f32) -> Vec<Read> {
        let mmpp = self.unit.mm_per_px();
        let (w, h) = self.unit.view_mm();
        let centres = [
            (w - off_mm, h / 2.0),
            (off_mm, h / 2.0),
            (w / 2.0, h - off_mm),
            (w / 2.0, off_mm),
        ];
        let mut out = Vec::new();
        for center_mm in centres {
            let mut s = SkinState::idle(ROOM_C);
            s.contacts.push(Contact {
                indenter: indenter.clone(),
                center_mm,
                depth_mm,
            });
            let (img, truth) = self.r.render(&s, 9);
            let t = truth.contact_px.unwrap();
            for (imp, a) in &self.paths {
                let m = a.analyze(&img).unwrap();
                let centre_err_mm = m.centroid_px.map(|c| (c.0 - t.0).hypot(c.1 - t.1) * mmpp);
                out.push(Read {
                    imp: *imp,
                    center_mm,
                    m,
                    centre_err_mm,
                });
            }
        }
        out
    }
}

/// The calibrated sphere pressed with its contact's rim 0 and 6 pixels inside each edge
/// (within a grating period, 16 pixels on this unit): on both paths the contact is found
/// and its centre lies within the tolerance. Were the apex looked for up to the edge, a
/// spurious peak there would take it and move the centre past the tolerance.
#[test]
fn a_press_reaching_the_edge_is_read_at_its_place() {
    let e = Edges::new(SensorUnit::reference_sized(320, 240));
    let mmpp = e.unit.mm_per_px();
    for depth_mm in [0.8f32, 1.4] {
        let contact_r_mm = (SPHERE_R_MM * depth_mm).sqrt();
        for gap_px in [0.0f32, 6.0] {
            for p in e.press_each_edge(depth_mm, contact_r_mm + gap_px * mmpp) {
                let err_mm = p.centre_err_mm.unwrap();
                assert!(
                    err_mm < CENTRE_TOLERANCE_MM,
                    "{:?}: {depth_mm} mm at {:?} mm read {err_mm:.2} mm away: {:?}",
                    p.imp,
                    p.center_mm,
                    p.m
                );
            }
        }
    }
}

/// A press deep enough for its phase to wrap, centred a grating period from the edge, inside
/// the band along it where no phase is trusted: its deep part lies there, and must not seed
/// the unwrapping as background, which would unwrap the press a turn low until it read as
/// no contact. The unit's phase response is steep enough for the press to wrap well inside
/// the depths it is calibrated for; the default calibration reads its depth wrong, so only
/// the contact's place is asserted.
#[test]
fn a_deep_press_centred_near_the_edge_is_reported_at_its_place() {
    let e = Edges::new(SensorUnit::wide(61));
    let depth_mm = 1.85f32;
    assert!(depth_mm * e.unit.phase_gain_rad_per_mm > std::f32::consts::PI);
    for p in e.press_each_edge(depth_mm, e.unit.period_px * e.unit.mm_per_px()) {
        assert!(
            p.m.contact && p.centre_err_mm.is_some_and(|e| e < CENTRE_TOLERANCE_MM),
            "{:?}: {depth_mm} mm at {:?} mm: {:?} mm away: {:?}",
            p.imp,
            p.center_mm,
            p.centre_err_mm,
            p.m
        );
    }
}

/// A press whose contact runs past the edge of the view is flagged `contact_at_edge` (what
/// lies beyond is not seen: its force reads low), on both paths and at every edge; the same
/// press with its rim 3 mm inside the view is not.
#[test]
fn a_contact_running_past_the_edge_is_flagged() {
    let e = Edges::new(SensorUnit::reference_sized(320, 240));
    let depth_mm = 1.0f32;
    let contact_r_mm = (SPHERE_R_MM * depth_mm).sqrt();
    for (rim_inside_mm, flagged) in [(-1.0f32, true), (3.0, false)] {
        for p in e.press_each_edge(depth_mm, contact_r_mm + rim_inside_mm) {
            assert!(
                p.m.contact,
                "{:?}: no contact at {:?} mm",
                p.imp, p.center_mm
            );
            assert_eq!(
                p.m.flags.contains(Flag::ContactAtEdge),
                flagged,
                "{:?}: rim {rim_inside_mm} mm inside at {:?} mm: {:?}",
                p.imp,
                p.center_mm,
                p.m
            );
        }
    }
}

/// A 5 mm sphere pressed 0.5 mm, centred three quarters of a grating period and a period
/// from the edge, on a unit of a short period: a contact's phase is trusted from one
/// period in, where the demodulator's kernel lies wholly in the image, and the press is
/// found there, reported at its place and flagged `contact_at_edge`, on both paths and at
/// every edge. Were no phase trusted within a period and a half of the edge, too little of
/// the press would remain to be a contact on this unit, and it would read as none, with no
/// flag.
#[test]
fn a_press_centred_within_a_period_of_the_edge_is_found() {
    let e = Edges::new(SensorUnit::wide(55));
    let period_mm = e.unit.period_px * e.unit.mm_per_px();
    let (r_mm, depth_mm) = (5.0f32, 0.5f32);
    for periods in [0.75f32, 1.0] {
        let off_mm = periods * period_mm;
        for p in e.press_each_edge_with(Indenter::Sphere { r_mm }, depth_mm, off_mm) {
            assert!(
                p.m.contact
                    && p.m.flags.contains(Flag::ContactAtEdge)
                    && p.centre_err_mm.is_some_and(|e| e < CENTRE_TOLERANCE_MM),
                "{:?}: {depth_mm} mm at {:?} mm: {:?} mm away: {:?}",
                p.imp,
                p.center_mm,
                p.centre_err_mm,
                p.m
            );
        }
    }
}
