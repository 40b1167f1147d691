//! libFuzzer target: arbitrary bytes as a calibration file. Refused with an error or
//! accepted; an accepted one's models read finite, bounded values wherever they are read.
//! Run: `bash scripts/fuzz.sh` (or `cd firmware/pipeline/fuzz && cargo fuzz run -s none
//! calibration`). Seeds: `firmware/pipeline/calibration/`.
#![no_main]

use libfuzzer_sys::fuzz_target;
use vistaf_pipeline::calibration::{Calibration, MAX_DEPTH_MM, MAX_FORCE_N};

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let Ok(c) = Calibration::from_json(&text, "fuzz.json") else {
        return;
    };
    let to = c.depth.range.map_or(12.0, |r| 2.0 * r.input[1]);
    for k in 0..=16 {
        let x = to * f64::from(k) / 16.0;
        let d = c.depth.model.depth_mm(x);
        assert!(d.is_finite() && (0.0..=MAX_DEPTH_MM).contains(&d), "depth {d} at {x}");
    }
    if let Some(f) = &c.force {
        let to = f.range.map_or(5.0, |r| 2.0 * r.input[1]);
        for k in 0..=16 {
            let u = to * f64::from(k) / 16.0;
            let n = f.model.force_n(u);
            assert!(n.is_finite() && (0.0..=MAX_FORCE_N).contains(&n), "force {n} at {u}");
        }
    }
    let _ = c.calibrated_depth_mm();
    let _ = c.id();
});
