//! The committed fixtures, replayed through `FrameSource` exactly as a camera delivers
//! them, analysed by both pipelines and scored against their ground truth.
//!
//! The fixtures are a 320×240 crop of the simulated reference unit: same grating period
//! as the default calibration, smaller image, hence `force_calibration`.
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

use vistaf_hardware::source::{FrameSource, Pacing, SetReplay};
use vistaf_pipeline::calibration::Calibration;
use vistaf_pipeline::{Analyzer, AnalyzerOptions, Implementation, Measurement};
use vistaf_protocol::Flag;
use vistaf_tests::{fixture, truth_depth_mm};

const IMPLS: [Implementation; 2] = [Implementation::Fixed, Implementation::Float];

/// Scale of the fixtures (reference unit: 2 mm over 16 px).
const MM_PER_PX: f32 = 2.0 / 16.0;

/// Every frame of a fixture through the pipeline, with its manifest entry index.
fn replay(name: &str, imp: Implementation) -> Vec<Measurement> {
    let set = fixture(name);
    let reference = set.load_reference().unwrap();
    let opts = AnalyzerOptions {
        force_calibration: true,
        ..Default::default()
    };
    let a = Analyzer::new(&reference, Calibration::default_sim(), imp, opts).unwrap();
    let mut src = SetReplay::new(set, Pacing::AsFastAsPossible, false);
    let mut out = Vec::new();
    while let Some(frame) = src.next_frame().unwrap() {
        out.push(a.analyze(&frame.into_rgb().unwrap()).unwrap());
    }
    out
}

#[test]
fn idle_frames_have_no_contact_no_force_no_flags() {
    for imp in IMPLS {
        let r = replay("idle", imp);
        assert_eq!(r.len(), fixture("idle").len());
        for d in &r {
            assert!(
                d.peak_depth_mm < 0.02 && d.force_n == 0.0 && !d.contact,
                "{imp:?}: {d:?}"
            );
        }
    }
}

#[test]
fn sphere_presses_meet_the_depth_and_centre_tolerances() {
    let set = fixture("press-sphere");
    for imp in IMPLS {
        for (d, f) in replay("press-sphere", imp).iter().zip(&set.manifest.frames) {
            let want = f.depth_mm.unwrap() as f32;
            let tol = 0.03 * want + 0.02;
            // The 0.1 mm press touches 1 mm of radius, narrower than the band resolves:
            // it may read low, and says so. The others meet the tolerance; the 0.9 mm one,
            // whose profile is not yet clearly a dome's, is also the map a 2 mm punch
            // would leave a tenth shallower, and says its depth is open to that. The
            // deeper ones are unflagged.
            let narrow = want < 0.5;
            let expected = if narrow {
                vec![Flag::DepthUnresolved]
            } else if want < 1.0 {
                vec![Flag::DepthUncertain]
            } else {
                vec![]
            };
            let flags: Vec<Flag> = d.flags.iter().collect();
            assert_eq!(flags, expected, "{imp:?}: {want} mm");
            assert!(
                (d.peak_depth_mm - want).abs() <= tol || narrow,
                "{imp:?}: {} vs {want} mm",
                d.peak_depth_mm
            );
            let (cx, cy) = d.centroid_px.unwrap();
            let err_mm = (cx - f.contact_x_px.unwrap() as f32)
                .hypot(cy - f.contact_y_px.unwrap() as f32)
                * MM_PER_PX;
            assert!(err_mm <= 0.5, "{imp:?}: centre off by {err_mm} mm");
            let force = f.force_n.unwrap() as f32;
            assert!(
                (d.force_n - force).abs() <= 0.08 * 30.0,
                "{imp:?}: {} vs {force} N",
                d.force_n
            );
        }
    }
}

#[test]
fn depth_map_follows_the_truth_map_where_it_is_deep() {
    // Inside the contact (truth ≥ half the peak) the reported map stays within 10 % of the
    // peak of the truth, after the demodulator's one-period smoothing.
    let set = fixture("press-sphere");
    let last = set.len() - 1;
    let truth = truth_depth_mm(&set, last).unwrap();
    let d = &replay("press-sphere", Implementation::Fixed)[last];
    let (w, f) = (d.width_px, d.factor);
    let full_w = set.size().0 as usize;
    let peak = truth.iter().copied().fold(0.0f32, f32::max);
    let mut worst = 0.0f32;
    for (i, &um) in d.depth_um.iter().enumerate() {
        let (x, y) = ((i % w) * f + f / 2, (i / w) * f + f / 2);
        let t = truth[y * full_w + x];
        if t >= 0.5 * peak {
            worst = worst.max((um as f32 / 1000.0 - t).abs());
        }
    }
    assert!(worst <= 0.1 * peak, "worst {worst} mm of a {peak} mm peak");
}

#[test]
fn letter_and_nut_contacts_are_found_and_centred() {
    for name in ["letter-e", "heated-nut"] {
        let set = fixture(name);
        for (d, f) in replay(name, Implementation::Fixed)
            .iter()
            .zip(&set.manifest.frames)
        {
            assert!(d.contact && d.force_n > 0.0, "{name}: {d:?}");
            let (cx, cy) = d.centroid_px.unwrap();
            let err_mm = (cx - f.contact_x_px.unwrap() as f32)
                .hypot(cy - f.contact_y_px.unwrap() as f32)
                * MM_PER_PX;
            assert!(err_mm <= 0.5, "{name}: centre off by {err_mm} mm");
            // Flat punches read deeper than they are: the calibration maps the smoothed
            // peak phase of a sphere, and a flat punch's phase is not smoothed down the
            // same way (`measure::apex`). Beyond the depth tolerance the phase-slope flag
            // says so; the only other flag is a hot contact's temperature_uncertain.
            let want = f.depth_mm.unwrap() as f32;
            let err = (d.peak_depth_mm - want).abs();
            assert!(err <= 0.1, "{name}: {} vs {want}", d.peak_depth_mm);
            assert!(
                d.flags
                    .iter()
                    .all(|f| f == Flag::PhaseSlope || f == Flag::TemperatureUncertain),
                "{name}: {:?}",
                d.flags
            );
            // The contact reads the object's temperature within a degree, or says it may not.
            let want_c = f.temperature_c.unwrap() as f32;
            let got_c = d.temperature.as_ref().and_then(|t| t.contact_c).unwrap();
            assert!(
                (got_c - want_c).abs() <= 1.0 || d.flags.contains(Flag::TemperatureUncertain),
                "{name}: contact {got_c} °C vs {want_c} °C without a flag"
            );
            assert!(
                err <= 0.03 * want + 0.02 || d.flags.contains(Flag::PhaseSlope),
                "{name}: {} vs {want} without a flag",
                d.peak_depth_mm
            );
        }
    }
}

#[test]
fn sub_period_misregistration_is_compensated_without_flags() {
    let r = replay("misregistered", Implementation::Fixed);
    let offsets: Vec<f32> = r.iter().map(|d| d.offset_rad).collect();
    assert!(
        offsets.windows(2).all(|w| w[1] > w[0]),
        "offset grows with the shift: {offsets:?}"
    );
    for d in &r {
        assert!(!d.contact && d.flags.is_empty(), "{d:?}");
    }
}
