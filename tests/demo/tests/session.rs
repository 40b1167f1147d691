//! The demo as its user runs it: a short session of the scripted scene, recorded, with the
//! figure of its strongest press.
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

use std::process::Command;

#[test]
fn a_short_demo_records_the_press_and_draws_its_figure() {
    let out = std::env::temp_dir().join(format!("vistaf-demo-test-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let run = Command::new(env!("CARGO_BIN_EXE_vistaf-demo"))
        .args(["--frames", "90", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let lines = std::fs::read_to_string(out.join("summaries.jsonl")).unwrap();
    let forces: Vec<f64> = lines
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .filter(|m| m["type"] == "summary")
        .map(|m| m["force_n"].as_f64().unwrap())
        .collect();
    assert!(forces.len() >= 10, "{} summaries", forces.len());
    assert_eq!(forces[0], 0.0, "the scene starts untouched");
    let peak = forces.iter().copied().fold(0.0, f64::max);
    assert!(peak > 5.0, "the sphere's press reads {peak} N at most");
    assert!(std::fs::metadata(out.join("peak.png")).unwrap().len() > 10_000);
    assert!(std::fs::read_to_string(out.join("peak.svg"))
        .unwrap()
        .contains("<svg"));
    let _ = std::fs::remove_dir_all(&out);
}
