//! The service over time: a reference that drifts is renewed after a quiet spell, or its
//! summaries say `stale_reference` when renewing is off; a camera that goes away is
//! reported once, retried, and counted when it comes back; a frame of the wrong size is
//! counted and skipped.
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};

use vistaf_firmware::calibration::Calibration;
use vistaf_firmware::pipeline::Implementation;
use vistaf_firmware::service::{run, Counters, ReferencePolicy, Settings};
use vistaf_hardware::frame::Frame;
use vistaf_hardware::led::{LedConfig, MemoryLedRing};
use vistaf_hardware::sim::scene::{states, ROOM_C};
use vistaf_hardware::sim::{SensorUnit, SimSource, SkinState};
use vistaf_hardware::source::{FrameSource, SourceError, SourceFormat};
use vistaf_protocol::{DeviceDecoder, DeviceMsg, ErrorCode, Flag, RunState};

/// A link that keeps what the service wrote.
#[derive(Clone, Default)]
struct Capture(Arc<Mutex<Vec<u8>>>);

impl std::io::Write for Capture {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        self.0.lock().unwrap().extend_from_slice(b);
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Capture {
    fn messages(&self) -> Vec<DeviceMsg> {
        let mut out = Vec::new();
        let mut dec = DeviceDecoder::new();
        dec.push(&self.0.lock().unwrap(), |r| out.push(r.unwrap()));
        out
    }
}

fn unit() -> SensorUnit {
    SensorUnit {
        width_px: 320,
        height_px: 240,
        ..SensorUnit::reference()
    }
}

fn serve(source: Box<dyn FrameSource>, reference: ReferencePolicy) -> (Counters, Vec<DeviceMsg>) {
    let link = Capture::default();
    let settings = Settings {
        serial: "VSK-TEST".into(),
        calibration: Calibration::default_sim(),
        force_calibration: true,
        pipeline: Implementation::Fixed,
        frames: None,
        max_rate_hz: 0,
        led: LedConfig::default(),
        reference,
    };
    let mut led = MemoryLedRing::default();
    let stop = Arc::new(AtomicBool::new(false));
    let c = run(source, link.clone(), None, &mut led, &settings, stop).unwrap();
    (c, link.messages())
}

/// Idle frames for the reference, then the skin creeps and the light fades.
fn creeping() -> Box<dyn FrameSource> {
    let u = unit();
    let mut s = vec![SkinState::idle(ROOM_C); 4];
    s.extend(states("creep", &u, 40).unwrap());
    Box::new(SimSource::new("creep", u, s, None, 3))
}

#[test]
fn a_drifting_reference_is_flagged_stale_when_renewing_is_off() {
    let (c, msgs) = serve(
        creeping(),
        ReferencePolicy {
            auto_after_s: 0.0,
            ..Default::default()
        },
    );
    assert_eq!(c.references, 1);
    let flags: Vec<bool> = msgs
        .iter()
        .filter_map(|m| match m {
            DeviceMsg::Summary(s) => Some(s.flags.contains(Flag::StaleReference)),
            _ => None,
        })
        .collect();
    // Early frames are fresh; once the creep passes the limit every frame says so.
    assert!(!flags[0] && !flags[3], "{flags:?}");
    let first = flags.iter().position(|f| *f).unwrap();
    assert!(flags[first..].iter().all(|f| *f), "{flags:?}");
    assert!(first < flags.len() - 5, "{flags:?}");
    assert_eq!(c.stale as usize, flags.len() - first);
}

/// A skin warming from room temperature to 37 °C changes the stripes' colours, and with
/// them the image's brightness: that is the reading, not a drifting reference.
#[test]
fn a_warming_skin_is_not_a_drifting_reference() {
    let u = unit();
    let mut s = vec![SkinState::idle(ROOM_C); 4];
    s.extend((0..24).map(|i| SkinState::idle(ROOM_C + 12.0 * i as f32 / 23.0)));
    let (c, msgs) = serve(
        Box::new(SimSource::new("warming", u, s, None, 3)),
        ReferencePolicy {
            auto_after_s: 0.0,
            ..Default::default()
        },
    );
    let summaries: Vec<_> = msgs
        .iter()
        .filter_map(|m| match m {
            DeviceMsg::Summary(s) => Some(s),
            _ => None,
        })
        .collect();
    let last = summaries.last().unwrap();
    assert!(
        (f32::from(last.temp_mean_centi_c) / 100.0 - (ROOM_C + 12.0)).abs() < 1.0,
        "the warming is read: {last:?}"
    );
    assert!(
        summaries
            .iter()
            .all(|s| !s.flags.contains(Flag::StaleReference)),
        "{summaries:?}"
    );
    assert_eq!(c.stale, 0);
}

#[test]
fn a_drifting_reference_is_renewed_after_a_quiet_spell() {
    let (c, msgs) = serve(
        creeping(),
        ReferencePolicy {
            auto_after_s: 1e-3,
            ..Default::default()
        },
    );
    assert!(c.references >= 2, "{c:?}");
    assert_eq!(c.stale, 0, "renewed instead of flagged");
    let renewals = msgs
        .iter()
        .filter(|m| matches!(m, DeviceMsg::Status(s) if s.state == RunState::Referencing))
        .count();
    assert!(renewals >= 1);
}

/// Frames, then the camera goes away for a few reads, then frames again; one frame of the
/// wrong size in between.
struct Flaky {
    frames: Vec<Frame>,
    next: usize,
    gone_at: usize,
    gone_for: usize,
    format: SourceFormat,
}

impl FrameSource for Flaky {
    fn format(&self) -> SourceFormat {
        self.format
    }
    fn name(&self) -> String {
        "flaky".into()
    }
    fn next_frame(&mut self) -> Result<Option<Frame>, SourceError> {
        // Paced like a camera, so the service processes every frame.
        std::thread::sleep(std::time::Duration::from_millis(40));
        if self.gone_for > 0 && self.next == self.gone_at {
            self.gone_for -= 1;
            return Err(SourceError::Gone {
                device: "/dev/video9".into(),
                detail: "unplugged".into(),
            });
        }
        let f = self.frames.get(self.next).cloned();
        self.next += 1;
        Ok(f)
    }
}

#[test]
fn a_lost_camera_is_reported_once_and_counted_when_it_returns() {
    let mut sim = SimSource::new("idle", unit(), vec![SkinState::idle(ROOM_C); 12], None, 5);
    let format = sim.format();
    let mut frames: Vec<Frame> = std::iter::from_fn(|| sim.next_frame().unwrap()).collect();
    // A frame of another size: counted as bad, skipped.
    let mut small = frames[0].clone();
    small.width /= 2;
    small.height /= 2;
    small.data.truncate(small.data.len() / 4);
    frames.insert(8, small);
    let source = Flaky {
        frames,
        next: 0,
        gone_at: 6,
        gone_for: 5,
        format,
    };
    let (c, msgs) = serve(Box::new(source), ReferencePolicy::default());
    assert_eq!(c.camera_restarts, 1, "{c:?}");
    assert_eq!(c.bad, 1, "{c:?}");
    let lost: Vec<&DeviceMsg> = msgs
        .iter()
        .filter(|m| matches!(m, DeviceMsg::Error(e) if e.code == ErrorCode::CameraLost))
        .collect();
    assert_eq!(lost.len(), 1, "one report per outage: {lost:?}");
    if let DeviceMsg::Error(e) = lost[0] {
        assert!(e.detail.contains("unplugged"), "{}", e.detail);
    }
    let last = msgs.iter().rev().find_map(|m| match m {
        DeviceMsg::Status(s) => Some(*s),
        _ => None,
    });
    assert_eq!(last.unwrap().camera_restarts, 1);
}
