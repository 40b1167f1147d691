//! The whole service, threads and all, fed 10 000 frames of trouble: good frames mixed with
//! a camera that keeps going away, frames of the wrong size, frames that do not decode, a
//! link whose writes fail, and a stop (as SIGTERM sets it) at a point drawn per run. It
//! must neither panic nor hang, put no torn frame on the link, and account for every frame.
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use vistaf_firmware::service::{run, Settings};
use vistaf_hardware::frame::Frame;
use vistaf_hardware::led::MemoryLedRing;
use vistaf_hardware::source::{FrameSource, SourceError, SourceFormat};
use vistaf_hardware::PixelFormat;
use vistaf_pipeline::Calibration;
use vistaf_protocol::{DeviceDecoder, DeviceMsg};
use vistaf_sim::contact::{Contact, Indenter};
use vistaf_sim::scene::{center_mm, ROOM_C};
use vistaf_sim::{Renderer, SensorUnit, SkinState};

const FRAMES: u64 = 10_000;

/// A small xorshift, so each run's mix is fixed by its seed.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
}

fn unit() -> SensorUnit {
    SensorUnit {
        width_px: 160,
        height_px: 120,
        period_px: 8.0,
        ..SensorUnit::reference()
    }
}

/// What the source delivers, by kind.
#[derive(Debug, Default, Clone, Copy)]
struct Delivered {
    good: u64,
    wrong_size: u64,
    undecodable: u64,
    gone: u64,
}

/// A camera with every fault, and the stop that SIGTERM would set at frame `stop_at`.
struct Trouble {
    good: Vec<Frame>,
    rng: Rng,
    seq: u64,
    stop_at: u64,
    stop: Arc<AtomicBool>,
    delivered: Arc<Mutex<Delivered>>,
}

impl FrameSource for Trouble {
    fn format(&self) -> SourceFormat {
        SourceFormat {
            width: 160,
            height: 120,
            pixel: PixelFormat::Rgb8,
            interval: None,
        }
    }
    fn name(&self) -> String {
        "trouble".into()
    }
    fn next_frame(&mut self) -> Result<Option<Frame>, SourceError> {
        if self.seq >= FRAMES {
            return Ok(None);
        }
        if self.seq == self.stop_at {
            self.stop.store(true, Ordering::Relaxed);
        }
        self.seq += 1;
        let mut d = self.delivered.lock().unwrap();
        let mut f = self.good[(self.rng.next() % self.good.len() as u64) as usize].clone();
        f.seq = self.seq;
        f.timestamp = Duration::from_millis(self.seq * 33);
        // One read in 200 finds the camera gone (the service backs off a little each
        // time); one frame in 20 is of the wrong size, one in 20 does not decode.
        match self.rng.next() % 200 {
            0 => {
                d.gone += 1;
                return Err(SourceError::Gone {
                    device: "/dev/video0".into(),
                    detail: "unplugged".into(),
                });
            }
            1..=10 => {
                d.wrong_size += 1;
                f.width = 80;
                f.data.truncate(80 * 120 * 3);
            }
            11..=20 => {
                d.undecodable += 1;
                f.format = PixelFormat::Mjpeg;
                f.data.truncate(97);
            }
            _ => d.good += 1,
        }
        Ok(Some(f))
    }
}

/// A link whose writes fail now and then (each write whole or not at all), keeping what
/// got through.
#[derive(Clone)]
struct FlakyLink {
    bytes: Arc<Mutex<Vec<u8>>>,
    failed: Arc<Mutex<u64>>,
    rng: Arc<Mutex<Rng>>,
}

impl Write for FlakyLink {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        if self.rng.lock().unwrap().next().is_multiple_of(9) {
            *self.failed.lock().unwrap() += 1;
            return Err(std::io::Error::from(std::io::ErrorKind::BrokenPipe));
        }
        self.bytes.lock().unwrap().extend_from_slice(b);
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

fn good_frames() -> Vec<Frame> {
    let r = Renderer::new(unit());
    let mut frames = Vec::new();
    for (k, depth_mm) in [0.0f32, 0.0, 0.5, 1.0, 1.5].into_iter().enumerate() {
        let mut s = SkinState::idle(ROOM_C);
        if depth_mm > 0.0 {
            s.contacts.push(Contact {
                indenter: Indenter::Sphere { r_mm: 6.0 },
                center_mm: center_mm(&unit()),
                depth_mm,
            });
        }
        frames.push(Frame::from_rgb(r.render(&s, k as u64).0, Duration::ZERO, 0));
    }
    frames
}

#[test]
fn ten_thousand_frames_of_trouble() {
    let good = good_frames();
    for seed in [0x9e37_79b9_7f4a_7c15u64, 0x2545_f491_4f6c_dd1d] {
        let mut rng = Rng(seed);
        let stop = Arc::new(AtomicBool::new(false));
        let delivered = Arc::new(Mutex::new(Delivered::default()));
        let stop_at = FRAMES / 2 + rng.next() % (FRAMES / 2);
        let source = Trouble {
            good: good.clone(),
            rng: Rng(rng.next()),
            seq: 0,
            stop_at,
            stop: stop.clone(),
            delivered: delivered.clone(),
        };
        let link = FlakyLink {
            bytes: Arc::default(),
            failed: Arc::default(),
            rng: Arc::new(Mutex::new(Rng(rng.next()))),
        };
        let settings = Settings {
            force_calibration: true,
            ..Settings::new(Calibration::default_sim())
        };
        let mut led = MemoryLedRing::default();
        let c = run(
            Box::new(source),
            link.clone(),
            None,
            &mut led,
            &settings,
            stop,
        )
        .unwrap();
        let d = *delivered.lock().unwrap();

        // Every frame the camera delivered was processed, spent on the reference, counted
        // bad, or evicted by a newer one; at most one was still waiting when the stop came.
        assert_eq!(u64::from(c.captured), d.good + d.wrong_size + d.undecodable);
        let accounted = c.processed + c.referencing + c.bad + c.dropped;
        assert!(
            (c.captured - 1..=c.captured).contains(&accounted),
            "{c:?} {d:?}"
        );
        assert!(c.camera_restarts > 0 && u64::from(c.camera_restarts) <= d.gone);
        assert!(c.processed > 0, "{c:?}");

        // What reached the link decodes whole: no torn frame, every summary sent there.
        let bytes = link.bytes.lock().unwrap().clone();
        let mut dec = DeviceDecoder::new();
        let mut summaries = 0u32;
        dec.push(&bytes, |r| {
            if let DeviceMsg::Summary(_) = r.unwrap() {
                summaries += 1;
            }
        });
        assert_eq!(dec.drops().total(), 0);
        assert_eq!(summaries, c.sent);
        assert_eq!(u64::from(c.link_errors), *link.failed.lock().unwrap());
        assert!(!led.is_lit(), "the ring is off at the end");
    }
}
