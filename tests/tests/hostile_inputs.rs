//! Files a user (or an attacker) hands the skin, mutated at random: a calibration, a frame
//! set's manifest, a service configuration. Each is refused with an error or accepted;
//! nothing panics, and an accepted calibration never makes the pipeline report an absurd
//! number (a non-finite value, a force beyond any skin's).
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

use std::path::{Path, PathBuf};

use proptest::prelude::*;
use serde_json::Value;
use vistaf_firmware::config::Config;
use vistaf_hardware::frameset::FrameSet;
use vistaf_hardware::source::{FrameSource, Pacing, SetReplay};
use vistaf_pipeline::calibration::{Calibration, DEFAULT_JSON, MAX_DEPTH_MM, MAX_FORCE_N};
use vistaf_pipeline::{Analyzer, AnalyzerOptions, Implementation};
use vistaf_sim::contact::{Contact, Indenter};
use vistaf_sim::scene::{center_mm, ROOM_C, SPHERE_R_MM};
use vistaf_sim::{Renderer, SensorUnit, SkinState};

/// Cases per property: `PROPTEST_CASES` when set (a long run), else a CI-sized 64.
fn cases() -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(64)
}

/// Every path to a leaf (or an array) of a JSON value.
fn paths(v: &Value, at: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
    match v {
        Value::Object(m) => {
            for (k, c) in m {
                at.push(k.clone());
                paths(c, at, out);
                at.pop();
            }
        }
        Value::Array(a) => {
            out.push(at.clone());
            for (i, c) in a.iter().enumerate() {
                at.push(i.to_string());
                paths(c, at, out);
                at.pop();
            }
        }
        _ => out.push(at.clone()),
    }
}

fn at_mut<'a>(v: &'a mut Value, path: &[String]) -> Option<&'a mut Value> {
    path.iter().try_fold(v, |v, k| match v {
        Value::Object(m) => m.get_mut(k),
        Value::Array(a) => a.get_mut(k.parse::<usize>().ok()?),
        _ => None,
    })
}

/// Values that break things: extremes, wrong types, short and empty arrays.
fn hostile(k: usize) -> Value {
    let values = [
        serde_json::json!(0),
        serde_json::json!(-1),
        serde_json::json!(-5.0),
        serde_json::json!(1e308),
        serde_json::json!(-1e308),
        serde_json::json!(1e-300),
        serde_json::json!(1e300),
        serde_json::json!(u64::MAX),
        serde_json::json!("x"),
        Value::Null,
        serde_json::json!([]),
        serde_json::json!([1.0]),
        serde_json::json!({}),
        serde_json::json!(true),
    ];
    values[k % values.len()].clone()
}

/// `json` with `changes` (path index, value index) applied.
fn mutated(json: &str, changes: &[(usize, usize)]) -> String {
    let mut v: Value = serde_json::from_str(json).unwrap();
    let mut all = Vec::new();
    paths(&v, &mut Vec::new(), &mut all);
    for &(p, k) in changes {
        let path = &all[p % all.len()];
        if let Some(slot) = at_mut(&mut v, path) {
            *slot = hostile(k);
        }
    }
    v.to_string()
}

fn unit() -> SensorUnit {
    SensorUnit::reference_sized(320, 240)
}

struct Frames {
    reference: image::RgbImage,
    press: image::RgbImage,
}

fn frames() -> &'static Frames {
    static F: std::sync::OnceLock<Frames> = std::sync::OnceLock::new();
    F.get_or_init(|| {
        let r = Renderer::new(unit());
        let mut press = SkinState::idle(ROOM_C);
        press.contacts.push(Contact {
            indenter: Indenter::Sphere { r_mm: SPHERE_R_MM },
            center_mm: center_mm(&unit()),
            depth_mm: 1.5,
        });
        Frames {
            reference: r.render(&SkinState::idle(ROOM_C), 1).0,
            press: r.render(&press, 2).0,
        }
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(cases()))]

    #[test]
    fn a_mutated_calibration_is_refused_or_measures_plausibly(
        changes in proptest::collection::vec((0usize..10_000, 0usize..100), 1..4)
    ) {
        let text = mutated(DEFAULT_JSON, &changes);
        let Ok(calib) = Calibration::from_json(&text, "mutated.json") else {
            return Ok(());
        };
        let f = frames();
        let opts = AnalyzerOptions { force_calibration: true, ..Default::default() };
        for imp in [Implementation::Fixed, Implementation::Float] {
            let Ok(a) = Analyzer::new(&f.reference, calib.clone(), imp, opts) else {
                continue;
            };
            let d = a.analyze(&f.press).unwrap();
            prop_assert!(d.peak_depth_mm.is_finite() && f64::from(d.peak_depth_mm) <= MAX_DEPTH_MM);
            prop_assert!(d.force_n.is_finite() && f64::from(d.force_n) <= MAX_FORCE_N);
            prop_assert!(d.force_n >= 0.0 && d.volume_mm3.is_finite());
            if let Some(t) = &d.temperature {
                prop_assert!(t.map_c.iter().all(|v| v.is_nan() || v.is_finite()));
            }
        }
    }
}

/// A small frame set written once for the manifest test.
fn sample_set() -> PathBuf {
    static DIR: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("vistaf-hostile-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let u = SensorUnit::reference_sized(64, 48);
        let states = vistaf_sim::scene::states("press-sphere", &u, 3).unwrap();
        let opts = vistaf_sim::sets::SetOptions {
            truth_maps: false,
            seed: 1,
            unit_seed: 0,
            encoding: Default::default(),
        };
        vistaf_sim::sets::write_states(&dir, "press-sphere", &u, &states, &opts, |_, _| {})
            .unwrap();
        dir
    })
    .clone()
}

fn copy_set(from: &Path, to: &Path) {
    let _ = std::fs::remove_dir_all(to);
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let p = e.unwrap().path();
        if p.is_file() {
            std::fs::copy(&p, to.join(p.file_name().unwrap())).unwrap();
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(cases()))]

    #[test]
    fn a_mutated_manifest_is_refused_or_replays(
        changes in proptest::collection::vec((0usize..10_000, 0usize..100), 1..4),
        case in 0u32..1_000_000,
    ) {
        let src = sample_set();
        let dir = std::env::temp_dir()
            .join(format!("vistaf-hostile-{}-{case}", std::process::id()));
        copy_set(&src, &dir);
        let text = std::fs::read_to_string(dir.join("set.json")).unwrap();
        std::fs::write(dir.join("set.json"), mutated(&text, &changes)).unwrap();
        if let Ok(set) = FrameSet::open(&dir) {
            let _ = set.load_reference();
            // Replayed as recorded: the pacing of any accepted manifest is bounded.
            let mut replay = SetReplay::new(set, Pacing::AsFastAsPossible, false);
            while let Ok(Some(_)) = replay.next_frame() {}
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_mutated_configuration_is_refused_or_parses(
        key in 0usize..14,
        value in prop_oneof![
            Just("0".to_string()), Just("-1".to_string()), Just("nan".to_string()),
            Just("inf".to_string()), Just("1e309".to_string()), Just("\"x\"".to_string()),
            Just("[]".to_string()), Just("99999999999999999999".to_string()),
            Just("\"serial:/dev/ttyGS0@0\"".to_string()), Just("\"\"".to_string()),
        ],
    ) {
        let keys = [
            "source", "link", "serial", "calibration", "pipeline", "frames", "fps",
            "max_rate_hz", "led.count", "led.brightness", "led.lit_mask",
            "reference.stable_dn", "reference.auto_after_s", "reference.max_wait_frames",
        ];
        let k = keys[key];
        let text = match k.split_once('.') {
            Some((section, name)) => format!("[{section}]\n{name} = {value}\n"),
            None => format!("{k} = {value}\n"),
        };
        if let Ok(c) = Config::parse(&text, "skin.toml") {
            if let Some(f) = c.fps {
                prop_assert!(f.is_finite() && f > 0.0);
            }
            prop_assert!(c.reference.auto_after_s.is_finite());
        }
    }
}
