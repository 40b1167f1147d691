//! Sources: recording any source into a set, and reopening a source that went away.
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Duration;

use vistaf_hardware::frame::{Frame, PixelFormat};
use vistaf_hardware::source::{record, FrameSource, Reconnect, SourceError, SourceFormat};
use vistaf_sim::{SensorUnit, SimSource};

#[test]
fn recording_a_simulated_camera_gives_a_valid_set_with_times() {
    let unit = SensorUnit::reference_sized(96, 64);
    let mut src = SimSource::scene("press-sphere", unit, 5, None, 3).unwrap();
    let dir = std::env::temp_dir().join(format!("vistaf-rec-{}", std::process::id()));
    let set = record(&mut src, &dir, 3, 2.0).unwrap();
    assert_eq!(set.len(), 3);
    assert_eq!(set.size(), (96, 64));
    let t: Vec<f64> = set
        .manifest
        .frames
        .iter()
        .map(|f| f.t_ms.unwrap())
        .collect();
    assert!(t.windows(2).all(|w| w[1] >= w[0]), "{t:?}");
    assert_eq!(set.manifest.extra["recorded_from"], "sim:press-sphere");
    std::fs::remove_dir_all(dir).unwrap();
    // A source that ends before the reference is a clear error.
    let mut empty = SimSource::new("nothing", SensorUnit::reference(), vec![], None, 1);
    let e = record(&mut empty, &std::env::temp_dir().join("never"), 3, 2.0).unwrap_err();
    assert!(e.to_string().contains("reference"), "{e}");
}

/// A camera that delivers `good` frames, then vanishes.
struct Flaky {
    good: usize,
    left: usize,
}

impl FrameSource for Flaky {
    fn format(&self) -> SourceFormat {
        SourceFormat {
            width: 2,
            height: 1,
            pixel: PixelFormat::Gray8,
            interval: None,
        }
    }
    fn name(&self) -> String {
        "flaky".into()
    }
    fn take_note(&mut self) -> Option<String> {
        (self.left == 1).then(|| "one frame left".into())
    }
    fn next_frame(&mut self) -> Result<Option<Frame>, SourceError> {
        if self.left == 0 {
            return Err(SourceError::Gone {
                device: "flaky".into(),
                detail: "unplugged".into(),
            });
        }
        self.left -= 1;
        Ok(Some(Frame {
            width: 2,
            height: 1,
            format: PixelFormat::Gray8,
            data: vec![1, 2],
            timestamp: Duration::ZERO,
            seq: (self.good - self.left) as u64,
        }))
    }
}

#[test]
fn a_vanished_camera_is_reported_then_reopened_with_back_off() {
    let opens = Arc::new(AtomicUsize::new(0));
    let o = opens.clone();
    let open = move || {
        // The second open fails (device still gone); the others succeed.
        match o.fetch_add(1, Ordering::SeqCst) {
            1 => Err(SourceError::Gone {
                device: "flaky".into(),
                detail: "not there".into(),
            }),
            _ => Ok(Flaky { good: 2, left: 2 }),
        }
    };
    let mut cam = Reconnect::new(open).unwrap().with_sleep(|_| {});
    assert!(cam.next_frame().unwrap().is_some());
    // The open source's note passes through.
    assert_eq!(cam.take_note().as_deref(), Some("one frame left"));
    assert!(cam.next_frame().unwrap().is_some());
    let lost = cam.next_frame().unwrap_err();
    assert!(
        lost.is_transient() && lost.to_string().contains("unplugged"),
        "{lost}"
    );
    assert!(!cam.is_connected());
    assert!(cam.next_frame().is_err(), "first reopen fails");
    assert!(
        cam.next_frame().unwrap().is_some(),
        "second reopen delivers again"
    );
    assert_eq!(cam.reopened, 1);
    assert_eq!(opens.load(Ordering::SeqCst), 3);
}
