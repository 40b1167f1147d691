//! The accuracy battery on three units drawn wide (`vistaf-accuracy` runs it on many and
//! writes `docs/accuracy.md`). What must already hold on every unit: it calibrates on its own
//! kit (one of the three has a grating fine enough that its deepest kit presses are flagged,
//! and the phase sign must not hang on them), no press of 0.2 mm or more goes unreported,
//! no press of the calibration sphere is reported elsewhere without a flag, and no heat
//! without a press reads a contact whose place or force is unflagged. (Silent
//! depth, force and temperature errors remain on such units: the battery's report lists
//! them.)
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

use vistaf_calibrate::{calibrate, Quiet};
use vistaf_hardware::decode::Decoded;
use vistaf_hardware::frameset::FrameSet;
use vistaf_pipeline::{Analyzer, AnalyzerOptions, Implementation};
use vistaf_protocol::Reading;
use vistaf_sim::sets::write_calibration_kit;
use vistaf_sim::SensorUnit;
use vistaf_tests::accuracy::{failure, kit_options, run_units, write_scenes, Camera, Kind, Scored};

#[test]
fn wide_units_calibrate_and_report_every_press_where_it_is() {
    for f in units_frames(&[2, 5, 11], "accuracy-test") {
        assert!(!f.missed, "unit {}: {:?} missed", f.unit, f);
        if f.kind == Kind::CalibrationSphere && f.flags.is_empty() {
            assert!(!f.phantom, "unit {}: {:?}", f.unit, f);
        }
        // A warm object's heat with nothing pressed may read as a contact where its colour
        // pulls the phase as a shallow press does; never with its place or force unflagged.
        if f.kind == Kind::HeatPrint {
            for r in [Reading::Contact, Reading::Force] {
                assert!(!f.silent_in(r), "unit {}: {:?}", f.unit, f);
            }
        }
    }
}

/// On these units an untouched skin's phase stood out by its noise where the reference's
/// fringes are faint (a dim corner, a glare spot, the border), beyond the threshold the
/// whole view's noise sets, and was reported as a contact. A contact must stand out
/// against the noise its own fringes carry; every press is still reported, where it is.
#[test]
fn faint_fringes_report_no_contact_on_an_untouched_skin() {
    let frames = units_frames(&[92, 97], "faint-fringes");
    // Their untouched skins were read (at least six), and like every frame report nothing.
    uniform_skins(&frames);
    for f in &frames {
        assert!(!f.phantom && !f.missed, "unit {}: {:?}", f.unit, f);
    }
}

/// On this unit the pigment darkens so far inside its transition that the grating's
/// contrast is flagged low there; the colour → temperature fit must still see those kit
/// frames (their colours are the skin's), or the skin reads low in that span with no flag.
#[test]
fn a_pigment_dark_enough_to_lower_contrast_is_still_calibrated() {
    let frames = unit_frames(7, "dark-pigment");
    skins_read_within_a_degree(&frames);
}

/// On this unit the skin's phase shows a contact near a glare spot on every warm kit frame
/// (flagged). Those frames must stay in the colour → temperature fit, their stripes placed as
/// they lie at rest: left out whole, the model ended below the warm setpoints and read a warm
/// skin or a heated object many degrees cold, with no flag.
#[test]
fn a_phantom_on_a_warm_kit_frame_keeps_its_temperature_in_the_fit() {
    let frames = unit_frames(16, "warm-phantom");
    skins_read_within_a_degree(&frames);
    let heated: Vec<f32> = frames
        .iter()
        .filter(|f| f.kind == Kind::Heated)
        .filter_map(|f| f.contact_temp_err_c)
        .collect();
    assert!(!heated.is_empty());
    for e in heated {
        assert!(e.abs() <= 5.0, "heated contact {e:+.2} °C off");
    }
}

/// On this unit (a coarse grating) the phase of the cool kit frames shows a contact at the
/// image's edge whose window spans most of the view. Those frames' colours must stay in the
/// fit: with the blocks of that window left out, the coloured stripes' model loses the
/// setpoints those frames hold and uniform skins read low, some without a flag
/// (`docs/temperature.md`).
#[test]
fn a_phantom_whose_window_spans_the_view_keeps_its_frame_in_the_fit() {
    let frames = unit_frames(72, "wide-phantom");
    skins_read_within_a_degree(&frames);
}

/// On these units a block's colours hardly move in the low thirties (the coloured stripes'
/// model has ended, the black stripes' path doubles back), and the mean of the blocks'
/// readings there, each within its variance, read a uniform skin off by more than the
/// bound below with no flag (`docs/temperature.md`, *The skin's mean*). The skin's mean is
/// turned back through what the kit's own uniform frames read
/// (`TemperatureModel::mean_read`), and every uniform skin reads within 0.4 °C. The units'
/// lenses put their colours apart: each colour is turned onto one grating and placed by
/// its own stripes (`docs/temperature.md`, *Lateral chromatic aberration*).
#[test]
fn a_warm_skin_reads_its_mean_where_the_colours_hardly_move() {
    let frames = units_frames(&[44, 53], "warm-mean");
    for f in uniform_skins(&frames) {
        let e = f.mean_temp_err_c.unwrap();
        assert!(
            e.abs() <= 0.4,
            "unit {}: uniform skin {e:+.2} °C off",
            f.unit
        );
    }
}

/// On these units a uniform skin's readings wander together over many blocks (where the
/// colours hardly move, with the light across the view), and a neighbourhood can depart
/// from the skin by more than independent noise allows for. A place stands out only when
/// it departs further than the kit's own uniform frames showed places departing
/// (`TemperatureModel::stand_out`), so every uniform skin's coldest and hottest places
/// read within 1 °C of it, their lenses' aberration drawn as in the test above.
#[test]
fn a_uniform_skin_shows_no_place_its_kit_did_not() {
    let frames = units_frames(&[52, 74], "uniform-places");
    for f in uniform_skins(&frames) {
        let (cold, hot) = (f.min_temp_deficit_c.unwrap(), f.max_temp_excess_c.unwrap());
        assert!(
            cold <= 1.0 && hot <= 1.0,
            "unit {} at {:.1} °C: coldest place {cold:.2} °C below, hottest {hot:.2} °C above",
            f.unit,
            f.skin_temp_c.unwrap_or(f32::NAN)
        );
    }
}

/// Temperatures a unit's own calibration says it cannot read are flagged, never reported
/// as if they could: unit 99's camera clips every warm kit frame (the cleared pigment and
/// the lamps' reflections reach full scale), so a hot contact reads as the warmest skin
/// the camera saw; unit 112's black-stripe model misses its own held-out setpoints by
/// degrees, and a uniform skin reads degrees off.
#[test]
fn temperatures_a_calibration_cannot_read_are_flagged() {
    let mut checked = 0;
    for f in units_frames(&[99, 112], "blind-kit") {
        let temperature = f
            .failures
            .iter()
            .any(|q| [failure::CONTACT_TEMPERATURE, failure::MEAN_TEMPERATURE].contains(q));
        if temperature {
            checked += 1;
            let flagged = f.flags.iter().any(|n| n.starts_with("temperature_"));
            assert!(flagged, "unit {}: {:?} not flagged", f.unit, f);
        }
    }
    assert!(
        checked >= 4,
        "{checked} frames misread: the units no longer show it"
    );
}

/// These units' cameras compress their frames to JPEG, which halves the chroma across the
/// stripes and quantises it per 8 × 8 block. A press squeezes the stripes and moves the
/// contact's chromaticity further than the calibration's flat frames show, and at the top
/// of the coloured transition, where the chromaticity hardly changes with temperature,
/// each unit has a heated contact that the shift carries degrees off
/// (`docs/temperature.md`). The calibration measures how far its own kit's presses move a
/// contact's chromaticity (`TemperatureModel::contact_chroma_spread`), and a contact's σ
/// carries that: every contact temperature off by more than 1 °C carries
/// `temperature_uncertain`.
#[test]
fn a_jpeg_cameras_misread_contact_temperature_is_flagged() {
    let mut checked = 0;
    for f in units_frames(&[159, 185], "jpeg-contact") {
        if f.failures.contains(&failure::CONTACT_TEMPERATURE) {
            checked += 1;
            let flagged = f.flags.contains(&"temperature_uncertain");
            assert!(flagged, "unit {}: {:?} not flagged", f.unit, f);
        }
    }
    assert!(
        checked >= 2,
        "{checked} contacts misread: the units no longer show it"
    );
}

/// On these units the skin is a thin layer whose surface returns to rest quickly beside a
/// contact: beside a letter's strokes it lies nearer rest than a half-space's, so a load
/// weighed over a disc enclosing the letter reads its force short. Weighed over the
/// letter's own half-depth footprint (`measure::load`), every letter reads within 15 %.
#[test]
fn letters_read_their_force_over_their_own_footprint() {
    let letters: Vec<Scored> = units_frames(&[51, 75], "letters")
        .into_iter()
        .filter(|f| f.kind == Kind::Letter)
        .collect();
    assert_eq!(letters.len(), 4, "two letters per unit");
    for f in &letters {
        let (err, force) = f.force_err_n.unwrap();
        assert!(
            err.abs() <= 0.15 * force,
            "unit {}: letter of {force:.2} N read {err:+.2} N off",
            f.unit
        );
    }
}

/// A unit's kit and scenes as `vistaf-accuracy --write-kit DIR --write-scenes` writes them,
/// calibrated and analysed from the files as `vistaf-skin calibrate` and `analyze` read
/// them, give the battery's readings frame by frame: a failure the battery lists can be
/// looked at closer with the shipped tools, on the very frame that failed.
#[test]
fn the_written_kit_and_scenes_read_as_the_battery_scored_them() {
    let seed = 3;
    let scored = unit_frames(seed, "written-scenes");
    let dir = std::env::temp_dir().join(format!("vistaf-written-scenes-{}", std::process::id()));
    let unit = Camera::default().unit(SensorUnit::wide(seed));
    let opts = kit_options(seed, Camera::default(), false);
    write_calibration_kit(&dir, &unit, &opts, |_, _, _| {}).unwrap();
    write_scenes(&dir.join("scenes"), seed, &unit, &[], &opts).unwrap();
    let kit: Vec<FrameSet> = ["depth", "force", "temperature"]
        .iter()
        .map(|s| FrameSet::open(&dir.join(s)).unwrap())
        .collect();
    let calib = calibrate(&kit, Implementation::Fixed, &mut Quiet).unwrap();
    let scenes = FrameSet::open(&dir.join("scenes")).unwrap();
    let reference = scenes.reference_frame().unwrap();
    let scale = calib.unit.scale_for(reference.width, reference.height);
    let reference = reference.into_decoded(scale, Decoded::default()).unwrap();
    let opts = AnalyzerOptions::default();
    let a = Analyzer::new(&reference, calib, Implementation::Fixed, opts).unwrap();
    assert_eq!(scenes.manifest.frames.len(), scored.len());
    for (i, f) in scored.iter().enumerate() {
        let frame = scenes.frame(i).unwrap();
        let m = a
            .analyze(&frame.into_decoded(scale, Decoded::default()).unwrap())
            .unwrap();
        let flags: Vec<&str> = m.flags.iter().map(|f| f.name()).collect();
        assert_eq!(flags, f.flags, "frame {i}: {f:?}");
        if let Some(err) = f.depth_err_mm {
            let read = f.depth_mm + err;
            assert!(
                (m.peak_depth_mm - read).abs() < 1e-5,
                "frame {i}: {m:?}, {f:?}"
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// On this unit glare spots and dim corners raise tile groups of both signs across the
/// view, and weighed whole their opposite-signed phase outweighs a 0.17 mm press of the
/// 5 mm sphere standing clear of them, as if the press were a thermal dipole. With the phase of
/// faint fringes set aside where the press's phase stands out, every press of the unit is
/// reported, and none away from its place.
#[test]
fn a_press_beside_faint_fringes_noise_is_reported_at_its_place() {
    for f in unit_frames(43, "faint-noise") {
        assert!(!f.phantom && !f.missed, "{f:?}");
        if f.depth_mm > 0.0 {
            assert!(f.centre_err_mm.is_some(), "no contact: {f:?}");
        }
    }
}

/// On the first unit (a coarse grating) a small sphere pressed at the edge of the view is
/// centred half a period from it, where the demodulator's kernel averages padding: its peak
/// lies there, and a period in only the band's ringing around it stands above the
/// threshold, with no peak of its own. Read only a period in, it would be no contact, with
/// no flag. A region with no peak a period in, standing well above the background off
/// recoloured ground, is read up to the edge: every press of the unit is reported, and the
/// presses at the edge say so. On the second unit a warm print's rim crosses the edge, and
/// read there it would stand as deep as such a press: it stays no contact (`docs/pipeline.md`,
/// *A press centred nearer the edge than the kernel reaches*).
#[test]
fn a_press_centred_nearer_the_edge_than_the_kernel_reaches_is_reported() {
    let frames = units_frames(&[900_253, 900_204], "edge-peak");
    for f in &frames {
        assert!(!f.missed, "{f:?}");
        if f.kind == Kind::HeatPrint {
            assert!(!f.phantom, "{f:?}");
        }
    }
    let at_edge: Vec<&Scored> = (frames.iter())
        .filter(|f| f.unit == 900_253 && f.kind == Kind::AtEdge)
        .collect();
    assert_eq!(at_edge.len(), 2, "two presses at the edge");
    for f in at_edge {
        assert!(f.flags.contains(&"contact_at_edge"), "{f:?}");
    }
}

/// On both units a skin away from the reference's temperature pulls the phase at a lamp's
/// reflection as far as a shallow press moves it, and weighed whole the two made a dipole.
/// On the first the colour's field was taken out and missed the reflection's pull; on the
/// second no field was, and the reflection stands where the stripes' contrast changed
/// against the reference. The part standing clear of both is the press
/// (`docs/pipeline.md`, *A press beside a reflection the colour pulls*): every press of
/// either unit is reported, none away from its place.
#[test]
fn a_press_beside_a_reflection_the_colour_pulls_is_reported() {
    let frames = units_frames(&[900_324, 900_391], "reflection-pull");
    for f in &frames {
        assert!(!f.missed, "{f:?}");
        if f.depth_mm > 0.0 {
            assert!(!f.phantom, "{f:?}");
        }
    }
    shallow_presses_at_their_places(&frames, Kind::SkinWarm, 0.6, 2);
}

/// On this unit the shallowest press of the calibrated sphere peaks barely past the contact
/// threshold where the fringes are bright, and a dim corner's noise floods nearly as high.
/// Weighed by their fringes, as a sample's phase is against the threshold, the press
/// stands out of the noise (`docs/pipeline.md`, *A faint press beside a dim corner's
/// noise*): it is reported at its place, and not silently.
#[test]
fn a_faint_press_beside_a_dim_corners_noise_is_reported() {
    let frames = unit_frames(900_300, "dim-corner");
    for f in shallow_presses_at_their_places(&frames, Kind::CalibrationSphere, 0.2, 1) {
        assert!(!f.silent_in(Reading::PeakDepth), "{f:?}");
    }
    for f in &frames {
        assert!(!f.missed && !f.phantom, "{f:?}");
    }
}

/// On these units the depth model's held-out misses lie in its floor, with no share of the
/// depth, while the kit's presses of one depth read apart from place to place by a share of
/// it. Neither alone is twice a mid-depth press's tolerance, both together are: a
/// calibration sphere's press read off where the kit never pressed would be silent on
/// either alone (`docs/pipeline.md`, *The floor and the places together*). No depth of
/// either unit is off unflagged.
#[test]
fn a_depth_off_where_the_kit_never_pressed_is_flagged_on_a_unit_whose_places_read_apart() {
    for f in units_frames(&[900_137, 900_140], "places-apart") {
        assert!(!f.silent_in(Reading::PeakDepth), "{f:?}");
    }
}

/// This unit's colour models compress the span above the coloured transition: its
/// held-out test read three setpoints there more than the tolerance warm, near where a
/// warmer uniform skin reads, while looked up by the skin's temperature the test missed
/// little there (`docs/temperature.md`, *A reading where the calibration read a setpoint
/// wrong*). Such a reading may be a skin of those setpoints', and is doubted: no
/// temperature of the unit is off unflagged.
#[test]
fn a_reading_near_where_the_calibration_read_a_setpoint_wrong_is_doubted() {
    for f in unit_frames(900_121, "failed-setpoint") {
        for r in [Reading::Temperature, Reading::ContactTemperature] {
            assert!(!f.silent_in(r), "{r:?}: {f:?}");
        }
    }
}

/// A heated sphere pressed deep into this unit warms a neighbourhood of blocks on the
/// press itself, which read the skin the press tilts above the object; the contact's own
/// reading takes that tilt out. The hottest place on a contact is the contact's reading
/// (`docs/temperature.md`, *Light that does not move, and the map's extremes*): no heated
/// press reads its hottest place beyond the tolerance, and none is off unflagged.
#[test]
fn a_hottest_place_on_a_heated_contact_reads_as_the_contact() {
    let frames = unit_frames(900_284, "hottest-on-contact");
    let heated: Vec<&Scored> = frames.iter().filter(|f| f.kind == Kind::Heated).collect();
    assert!(heated.len() >= 3, "{} heated presses read", heated.len());
    for f in heated {
        assert!(!f.failures.contains(&failure::HOTTEST_BLOCK), "{f:?}");
        assert!(!f.silent_in(Reading::Temperature), "{f:?}");
    }
}

/// The presses of `kind` shallower than `below_mm` among `frames`, `n` of them, each
/// reported within the centre tolerance (1.5 mm) of its place.
fn shallow_presses_at_their_places(
    frames: &[Scored],
    kind: Kind,
    below_mm: f32,
    n: usize,
) -> Vec<&Scored> {
    let shallow: Vec<&Scored> = (frames.iter())
        .filter(|f| f.kind == kind && f.depth_mm > 0.0 && f.depth_mm < below_mm)
        .collect();
    assert_eq!(shallow.len(), n, "{kind:?} presses under {below_mm} mm");
    for f in &shallow {
        assert!(f.centre_err_mm.is_some_and(|e| e <= 1.5), "{f:?}");
    }
    shallow
}

/// The battery's frames of unit `seed`, calibrated on its own kit.
fn unit_frames(seed: u64, name: &str) -> Vec<Scored> {
    units_frames(&[seed], name)
}

/// The battery's frames of the units `seeds` (two at a time), each calibrated on its own
/// kit; a unit that refuses calibration fails the test.
fn units_frames(seeds: &[u64], name: &str) -> Vec<Scored> {
    let work = std::env::temp_dir().join(format!("vistaf-{name}-{}", std::process::id()));
    let results = run_units(seeds, &work, 2, &[], Default::default(), |_| {});
    let _ = std::fs::remove_dir_all(&work);
    results
        .into_iter()
        .flat_map(|r| r.unwrap_or_else(|e| panic!("unit {}: {}", e.unit, e.why)))
        .collect()
}

/// The uniform skins among `frames`, at least six of them (two units' worth).
fn uniform_skins(frames: &[Scored]) -> Vec<&Scored> {
    let uniform: Vec<&Scored> = frames.iter().filter(|f| f.kind == Kind::Uniform).collect();
    assert!(uniform.len() >= 6, "{} uniform skins read", uniform.len());
    uniform
}

/// Every skin of one temperature throughout reads within 1 °C on average.
fn skins_read_within_a_degree(frames: &[Scored]) {
    let read: Vec<f32> = frames.iter().filter_map(|f| f.mean_temp_err_c).collect();
    assert!(read.len() >= 10, "{} skins read", read.len());
    for e in read {
        assert!(e.abs() <= 1.0, "mean temperature {e:+.2} °C off");
    }
}
