//! libFuzzer target: arbitrary bytes as a frame set's `set.json`. Refused with an error
//! naming the file, or accepted with every value inside its documented range.
//! Run: `bash scripts/fuzz.sh` (or `cd hardware/fuzz && cargo fuzz run -s none manifest`).
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use vistaf_hardware::frameset::{Manifest, MAX_DEPTH_MM, MAX_FORCE_N, MAX_T_MS};

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    match Manifest::parse(&text, Path::new("set.json")) {
        Ok(m) => {
            assert!(m.grating_period_mm.is_finite() && m.grating_period_mm > 0.0);
            for f in &m.frames {
                assert!(f.t_ms.is_none_or(|t| (0.0..=MAX_T_MS).contains(&t)));
                assert!(f.depth_mm.is_none_or(|d| (0.0..=MAX_DEPTH_MM).contains(&d)));
                assert!(f.force_n.is_none_or(|n| (0.0..=MAX_FORCE_N).contains(&n)));
            }
        }
        Err(e) => assert!(e.to_string().contains("set.json"), "{e}"),
    }
});
