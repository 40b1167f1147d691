//! `vistaf-skin` on the committed fixtures: JSON lines, traceable outputs, and refusals
//! that name the problem.
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

use std::path::PathBuf;
use std::process::{Command, Output};

fn skin(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_vistaf-skin"))
        .args(args)
        .output()
        .unwrap()
}

/// Asserts a run succeeded, showing its stderr if not.
fn ok(out: &Output) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn fixture(name: &str) -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/fixtures")
        .join(name)
        .display()
        .to_string()
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("vistaf-skin-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

#[test]
fn analyze_set_prints_one_json_object_per_frame() {
    let out = skin(&[
        "analyze",
        "--set",
        &fixture("press-sphere"),
        "--json",
        "--force-calibration",
    ]);
    ok(&out);
    let text = String::from_utf8(out.stdout).unwrap();
    let rows: Vec<serde_json::Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(rows.len(), 4);
    for key in [
        "file",
        "depth_mm",
        "force_n",
        "contact_area_mm2",
        "volume_mm3",
        "contact_x_px",
        "contact_y_px",
        "flags",
        "latency_us",
    ] {
        assert!(rows[0].get(key).is_some(), "missing {key}");
    }
    assert!(rows[3]["depth_mm"].as_f64().unwrap() > 2.4);
}

#[test]
fn analyze_out_writes_maps_and_a_traceable_summary() {
    let out_dir = tmp("out");
    let f = fixture("press-sphere");
    let out = skin(&[
        "analyze",
        "--reference",
        &format!("{f}/reference.png"),
        "--frame",
        &format!("{f}/f0003.png"),
        "--out",
        out_dir.to_str().unwrap(),
        "--force-calibration",
        "--pipeline",
        "float",
    ]);
    ok(&out);
    assert!(out_dir.join("f0003.png").exists());
    let svg = std::fs::read_to_string(out_dir.join("f0003.svg")).unwrap();
    assert!(
        svg.contains(">\ndepth\n<") || svg.contains(">depth<"),
        "the depth bar's title"
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("summary.json")).unwrap())
            .unwrap();
    assert!(summary["calibration"]["phase_to_depth"]["equation"]
        .as_str()
        .unwrap()
        .contains("d_mm"));
    assert!(summary["calibration"]["force"]["equation"]
        .as_str()
        .unwrap()
        .contains("F_N"));
    std::fs::remove_dir_all(out_dir).unwrap();
}

#[test]
fn a_calibration_for_another_geometry_is_refused_unless_forced() {
    // The fixtures are 320×240; the default calibration was made at 640×480.
    let out = skin(&["analyze", "--set", &fixture("idle")]);
    assert!(!out.status.success());
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(
        err.contains("640×480") && err.contains("320×240") && err.contains("--force-calibration"),
        "{err}"
    );
}

#[test]
fn bad_inputs_are_named() {
    let cal = tmp("bad.json");
    std::fs::write(&cal, "{\"format\": \"vistaf-calibration/7\"}").unwrap();
    let out = skin(&[
        "analyze",
        "--set",
        &fixture("idle"),
        "--calibration",
        cal.to_str().unwrap(),
    ]);
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(
        !out.status.success() && err.contains("vistaf-calibration/7"),
        "{err}"
    );
    std::fs::remove_file(cal).unwrap();

    let f = fixture("idle");
    // A frame of another size than the reference: the frame is named.
    let wrong = tmp("small.png");
    image::RgbImage::new(10, 10).save(&wrong).unwrap();
    let out = skin(&[
        "analyze",
        "--reference",
        &format!("{f}/reference.png"),
        "--frame",
        wrong.to_str().unwrap(),
        "--force-calibration",
    ]);
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(
        !out.status.success() && err.contains("small.png") && err.contains("10×10"),
        "{err}"
    );
    std::fs::remove_file(wrong).unwrap();

    let out = skin(&["simulate", "--scene", "no-such", "--out", "/tmp/x"]);
    assert!(String::from_utf8(out.stderr)
        .unwrap()
        .contains("press-sphere"));
}

#[test]
fn calibrate_fits_a_labelled_set_and_the_result_analyzes() {
    // The press-sphere fixture has four labelled depths: enough for a (small) calibration.
    let cal = tmp("fixture-cal.json");
    let out = skin(&[
        "calibrate",
        "--set",
        &fixture("press-sphere"),
        "--out",
        cal.to_str().unwrap(),
    ]);
    ok(&out);
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.contains("phase → depth") && text.contains("← chosen"),
        "{text}"
    );
    let out = skin(&[
        "analyze",
        "--set",
        &fixture("idle"),
        "--calibration",
        cal.to_str().unwrap(),
    ]);
    ok(&out);
    std::fs::remove_file(cal).unwrap();
}

/// `analyze … | head -1`: the reader hangs up after one line; the analysis goes on and its
/// summary is written.
#[test]
fn analyze_whose_reader_hangs_up_still_writes_its_summary() {
    use std::io::{BufRead, BufReader};
    let out_dir = tmp("hangup");
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_vistaf-skin"))
        .args([
            "analyze",
            "--set",
            &fixture("press-sphere"),
            "--force-calibration",
        ])
        .args(["--out", out_dir.to_str().unwrap()])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let first = BufReader::new(child.stdout.take().unwrap())
        .lines()
        .next()
        .unwrap()
        .unwrap();
    assert!(first.starts_with('{'), "{first}");
    let out = child.wait_with_output().unwrap();
    ok(&out);
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("summary.json")).unwrap())
            .unwrap();
    assert_eq!(summary["frames"].as_array().unwrap().len(), 4);
}

/// `calibrate --guided` on the board: the session runs against this process's own service
/// on a simulated unit that the default calibration does not fit (its bench set by each
/// step), keeps the kit, fits it, says the verdicts and writes the calibration file that
/// was not there before; the written file is the fit the session announced.
#[test]
fn a_guided_calibration_on_the_board_writes_the_fit_it_announces() {
    let dir = tmp("guided");
    std::fs::create_dir_all(&dir).unwrap();
    let plan = dir.join("plan.toml");
    std::fs::write(
        &plan,
        "depths_mm = [0.2, 0.5, 0.8, 1.1, 1.4, 1.7, 2.0, 2.3]\n\
         forces_n = [1.0, 2.0, 4.0, 6.0, 10.0, 15.0, 20.0, 30.0]\n\
         temperatures_c = [15.0, 20.0, 22.0, 24.0, 26.0, 28.0, 30.0, 32.0, 34.0, 38.0, 42.0, 46.0]\n\
         repeats = 1\n\
         activate = \"always\"\n",
    )
    .unwrap();
    let cal = dir.join("calibration.json");
    let (cal_s, plan_s) = (cal.display().to_string(), plan.display().to_string());
    let base = [
        "calibrate",
        "--guided",
        "--source",
        "sim:bench",
        "--unit-seed",
        "3",
        "--plan",
        &plan_s,
    ];
    // Without a file to activate into, the session does not start.
    let out = skin(&base);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--calibration PATH"));

    let out = skin(&[&base[..], &["--calibration", &cal_s]].concat());
    let text = String::from_utf8_lossy(&out.stdout);
    let err = String::from_utf8_lossy(&out.stderr);
    // A fit that misses a target is still activated (`always`), and the exit says so.
    assert!(
        out.status.success() || err.contains("misses a target"),
        "{text}\n{err}"
    );
    assert!(
        text.contains("[29/29] bring the untouched skin to 46.0 °C"),
        "{text}"
    );
    assert!(text.contains("held-out RMSE"), "{text}");
    let id = text
        .split("activated calibration ")
        .nth(1)
        .and_then(|t| t.split_whitespace().next())
        .unwrap_or_else(|| panic!("no activation in:\n{text}\n{err}"));
    let written = vistaf_pipeline::Calibration::load(&cal).unwrap().id();
    assert_eq!(format!("{written:08x}"), id, "{text}");
    assert!(text.contains(&format!("wrote {cal_s};")), "{text}");
    // The kit is kept: one folder, its depth set labelled as planned.
    let kit = std::fs::read_dir(dir.join("kit"))
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(kit.join("depth").join("set.json")).unwrap())
            .unwrap();
    assert_eq!(manifest["frames"].as_array().map(Vec::len), Some(8));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_guided_options_need_guided() {
    let out = skin(&[
        "calibrate",
        "--set",
        "x",
        "--out",
        "y",
        "--source",
        "sim:bench",
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("need --guided"));
}
