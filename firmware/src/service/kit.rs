//! A calibration kit captured on the device, step by step, as a guided calibration asks
//! (`HostMsg::KitCapture`), then fitted (`HostMsg::KitFit`) on a thread of its own so
//! frames keep flowing.
//!
//! * **Settled, measured:** a step's frame is taken once the image has stopped changing:
//!   the mean absolute change of 8 × 8-pixel block means, in every colour channel (a
//!   temperature step changes colour more than brightness), stays below `stable_dn` over
//!   [`SETTLED_RUN`] consecutive frame pairs. The frame in flight when the step was asked
//!   for is never used. A step that does not settle within [`SETTLE_TIMEOUT`] fails.
//! * **Kept for traceability:** each kit is a folder of three `vistaf-frames/1` sets
//!   (`depth/`, `force/`, `temperature/`), the frames byte for byte as the camera sent
//!   them, the manifest rewritten after every frame; a new kit never overwrites an old one.

use std::path::{Path, PathBuf};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use vistaf_calibrate::{calibrate, Observer};
use vistaf_hardware::decode::Decoded;
use vistaf_hardware::frame::Frame;
use vistaf_hardware::frameset::{FrameEntry, FrameSet, FrameSetWriter};
use vistaf_pipeline::input::Pixels;
use vistaf_pipeline::{Calibration, Implementation};
use vistaf_protocol::{KitCaptured, KitQuantity, KitStep};

use super::reference::mean_abs_diff;

/// How long a step may take to settle.
pub const SETTLE_TIMEOUT: Duration =
    Duration::from_millis(vistaf_protocol::msg::KIT_SETTLE_TIMEOUT_MS as u64);
/// Consecutive calm frame pairs that make a settled image.
pub const SETTLED_RUN: u32 = 2;
/// Side of the blocks whose means are compared, pixels.
const BLOCK_PX: usize = 8;

/// A step waiting for a settled image.
#[derive(Debug)]
struct Pending {
    step: KitStep,
    since: Instant,
    last: Option<Vec<u16>>,
    calm: u32,
}

/// The kit being captured.
#[derive(Debug)]
struct Session {
    dir: PathBuf,
    reference: Frame,
    grating_period_mm: f64,
    /// Depth, force and temperature sets, made at their first frame.
    sets: [Option<FrameSetWriter>; 3],
}

/// What a frame did to a waiting step.
#[derive(Debug)]
pub enum Offered {
    /// Nothing waits, or the image has not settled yet.
    Waiting,
    /// The step's frame is stored.
    Captured(KitCaptured),
    /// The step failed; why.
    Failed(String),
}

/// Kits, the step waiting, and the fit in progress.
#[derive(Debug)]
pub struct Kit {
    root: PathBuf,
    session: Option<Session>,
    pending: Option<Pending>,
    fit: Option<JoinHandle<Result<Calibration, String>>>,
}

impl Kit {
    /// Kits go into folders under `root`.
    pub fn new(root: PathBuf) -> Kit {
        Kit {
            root,
            session: None,
            pending: None,
            fit: None,
        }
    }

    /// Whether a step waits for a frame (the camera's bytes are kept for it).
    pub fn wants_frames(&self) -> bool {
        self.pending.is_some()
    }

    /// Starts waiting for `step`'s frame from `now` on.
    pub fn start(&mut self, step: KitStep, now: Instant) -> Result<(), String> {
        if self.pending.is_some() {
            return Err("a kit capture is already waiting for a settled image".into());
        }
        if self.fit.is_some() {
            return Err("the kit is being fitted".into());
        }
        if step.quantity != KitQuantity::Reference && self.session.is_none() {
            return Err("no kit begun: capture a Reference step first".into());
        }
        self.pending = Some(Pending {
            step,
            since: now,
            last: None,
            calm: 0,
        });
        Ok(())
    }

    /// A frame from the camera (`raw`, its bytes; `img`, decoded), whose decoding began
    /// at `started`; `stable_dn` is the largest mean change of a settled image.
    pub fn offer(
        &mut self,
        raw: Option<&Frame>,
        img: &Decoded,
        started: Instant,
        stable_dn: f32,
        grating_period_mm: f64,
    ) -> Offered {
        let Some(p) = self.pending.as_mut() else {
            return Offered::Waiting;
        };
        if started <= p.since {
            return Offered::Waiting;
        }
        let means = block_means(img);
        let change = p.last.as_ref().map(|l| mean_abs_diff(l, &means));
        p.last = Some(means);
        match change {
            Some(c) if c < stable_dn => p.calm += 1,
            _ => p.calm = 0,
        }
        // A frame whose bytes were not kept (decoded as the step was asked for) cannot be
        // stored: the next settled one is.
        let Some(raw) = raw.filter(|_| p.calm >= SETTLED_RUN) else {
            return Offered::Waiting;
        };
        let (step, since) = (p.step, p.since);
        self.pending = None;
        match self.store(step, raw, grating_period_mm) {
            Ok(frames) => Offered::Captured(KitCaptured {
                step,
                frames,
                settle_ms: u32::try_from(started.saturating_duration_since(since).as_millis())
                    .unwrap_or(u32::MAX),
                change_centi_dn: (change.unwrap_or(0.0) * 100.0).round().min(65535.0) as u16,
            }),
            Err(e) => Offered::Failed(e),
        }
    }

    /// The waiting step, failed if it has waited longer than [`SETTLE_TIMEOUT`] at `now`.
    pub fn timed_out(&mut self, now: Instant) -> Option<String> {
        let p = self.pending.as_ref()?;
        if now.saturating_duration_since(p.since) < SETTLE_TIMEOUT {
            return None;
        }
        self.pending = None;
        Some(format!(
            "the image did not settle within {} s (mean change stayed ≥ reference.stable_dn)",
            SETTLE_TIMEOUT.as_secs()
        ))
    }

    /// Stores a settled frame; the number of frames of its quantity in the kit.
    fn store(&mut self, step: KitStep, raw: &Frame, grating_period_mm: f64) -> Result<u16, String> {
        if step.quantity == KitQuantity::Reference {
            let dir = new_kit_dir(&self.root)?;
            self.session = Some(Session {
                dir,
                reference: raw.clone(),
                grating_period_mm,
                sets: [None, None, None],
            });
            return Ok(1);
        }
        let s = self
            .session
            .as_mut()
            .ok_or_else(|| "no kit begun".to_string())?;
        let (slot, name) = match step.quantity {
            KitQuantity::Depth => (0, "depth"),
            KitQuantity::Force => (1, "force"),
            _ => (2, "temperature"),
        };
        let writer = match &mut s.sets[slot] {
            Some(w) => w,
            empty => empty.insert(
                FrameSetWriter::create_from_frame(
                    &s.dir.join(name),
                    s.grating_period_mm,
                    &s.reference,
                )
                .map_err(|e| e.to_string())?,
            ),
        };
        let v = f64::from(step.value_milli) / 1000.0;
        let entry = match step.quantity {
            KitQuantity::Depth => FrameEntry {
                depth_mm: Some(v),
                ..FrameEntry::default()
            },
            KitQuantity::Force => FrameEntry {
                force_n: Some(v),
                ..FrameEntry::default()
            },
            _ => FrameEntry {
                temperature_c: Some(v),
                ..FrameEntry::default()
            },
        };
        writer.add_frame(raw, entry).map_err(|e| e.to_string())?;
        writer.flush().map_err(|e| e.to_string())?;
        Ok(u16::try_from(writer.len()).unwrap_or(u16::MAX))
    }

    /// Starts fitting the kit with `pipeline` on a thread of its own.
    pub fn fit(&mut self, pipeline: Implementation) -> Result<(), String> {
        if self.fit.is_some() {
            return Err("the kit is already being fitted".into());
        }
        if self.pending.is_some() {
            return Err("a kit capture is still waiting".into());
        }
        let s = self
            .session
            .as_ref()
            .ok_or_else(|| "no kit captured".to_string())?;
        let dirs: Vec<PathBuf> = s
            .sets
            .iter()
            .flatten()
            .map(|w| w.dir().to_path_buf())
            .collect();
        if dirs.is_empty() {
            return Err("the kit has no labelled frames".into());
        }
        self.fit = Some(std::thread::spawn(move || fit_sets(&dirs, pipeline)));
        Ok(())
    }

    /// The fit's outcome once it is done.
    pub fn fitted(&mut self) -> Option<Result<Calibration, String>> {
        if !self.fit.as_ref()?.is_finished() {
            return None;
        }
        let handle = self.fit.take()?;
        Some(
            handle
                .join()
                .unwrap_or_else(|_| Err("the fit panicked".into())),
        )
    }

    /// The folder of the kit being captured.
    pub fn dir(&self) -> Option<&Path> {
        self.session.as_ref().map(|s| s.dir.as_path())
    }
}

/// Opens the kit's sets and fits them.
fn fit_sets(dirs: &[PathBuf], pipeline: Implementation) -> Result<Calibration, String> {
    let sets: Vec<FrameSet> = dirs
        .iter()
        .map(|d| FrameSet::open(d).map_err(|e| e.to_string()))
        .collect::<Result<_, _>>()?;
    calibrate(&sets, pipeline, &mut Log).map_err(|e| e.to_string())
}

/// The fit's remarks (a frame left out, a spot masked, kit temperatures the model never
/// saw) on standard error: the service's log, or the terminal of a guided session run on
/// the board. Its progress is not: the fit takes seconds.
struct Log;

impl Observer for Log {
    fn progress(&mut self, _: &str, _: usize, _: usize) {}
    fn note(&mut self, text: String) {
        eprintln!("vistaf-skin: calibration: {text}");
    }
}

/// A new folder under `root`, named for the time (and a count, when two kits begin in
/// the same second).
fn new_kit_dir(root: &Path) -> Result<PathBuf, String> {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    for n in 0..1000 {
        let dir = root.join(format!("kit-{secs}-{n}"));
        match std::fs::create_dir_all(root).and_then(|()| std::fs::create_dir(&dir)) {
            Ok(()) => return Ok(dir),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(format!("kit folder {}: {e}", dir.display())),
        }
    }
    Err(format!("{}: no free kit folder name", root.display()))
}

/// Means of every channel over [`BLOCK_PX`]-pixel blocks (whole blocks only), 8.8 fixed
/// point.
fn block_means(img: &Decoded) -> Vec<u16> {
    let (w, h) = (img.width as usize, img.height as usize);
    Pixels::from(img).box_means_q8(BLOCK_PX, w / BLOCK_PX, h / BLOCK_PX)
}

#[cfg(test)]
mod tests {
    use super::*;
    use vistaf_hardware::decode::Colour;

    fn flat(v: u8) -> Decoded {
        Decoded {
            width: 32,
            height: 16,
            data: vec![v; 32 * 16 * 3],
            colour: Colour::Rgb,
        }
    }

    fn rgb_frame() -> Frame {
        Frame {
            width: 32,
            height: 16,
            format: vistaf_hardware::PixelFormat::Rgb8,
            data: vec![100; 32 * 16 * 3],
            timestamp: Duration::ZERO,
            seq: 0,
        }
    }

    #[test]
    fn a_step_waits_for_a_settled_image_and_never_takes_the_frame_in_flight() {
        let root = std::env::temp_dir().join(format!("vistaf-kit-test-{}", std::process::id()));
        let mut kit = Kit::new(root.clone());
        let t0 = Instant::now();
        let step = KitStep {
            quantity: KitQuantity::Reference,
            value_milli: 25_000,
        };
        assert!(kit
            .start(
                KitStep {
                    quantity: KitQuantity::Depth,
                    value_milli: 500
                },
                t0
            )
            .is_err());
        kit.start(step, t0).unwrap();
        let raw = rgb_frame();
        let at = |ms| t0 + Duration::from_millis(ms);
        // The frame in flight (decoded before the step) is ignored.
        assert!(matches!(
            kit.offer(Some(&raw), &flat(90), t0, 1.5, 2.0),
            Offered::Waiting
        ));
        // Changing: no capture.
        for (i, v) in [10u8, 60, 120].into_iter().enumerate() {
            let o = kit.offer(Some(&raw), &flat(v), at(10 + i as u64), 1.5, 2.0);
            assert!(matches!(o, Offered::Waiting), "{o:?}");
        }
        // Calm for two pairs: captured on the second.
        assert!(matches!(
            kit.offer(Some(&raw), &flat(121), at(20), 1.5, 2.0),
            Offered::Waiting
        ));
        match kit.offer(Some(&raw), &flat(121), at(30), 1.5, 2.0) {
            Offered::Captured(c) => {
                assert_eq!(c.step, step);
                assert_eq!(c.settle_ms, 30);
            }
            other => panic!("{other:?}"),
        }
        assert!(kit.dir().is_some_and(Path::is_dir));
        // A labelled step goes into its set, whose manifest is on disk at once.
        let depth = KitStep {
            quantity: KitQuantity::Depth,
            value_milli: 500,
        };
        kit.start(depth, at(40)).unwrap();
        assert!(kit.start(depth, at(40)).is_err(), "one step at a time");
        for ms in [50, 60] {
            let _ = kit.offer(Some(&raw), &flat(121), at(ms), 1.5, 2.0);
        }
        // Settled, but its bytes were not kept: the next settled frame is stored instead.
        let o = kit.offer(None, &flat(121), at(70), 1.5, 2.0);
        assert!(matches!(o, Offered::Waiting), "{o:?}");
        let o = kit.offer(Some(&raw), &flat(121), at(80), 1.5, 2.0);
        assert!(matches!(o, Offered::Captured(_)), "{o:?}");
        let set = FrameSet::open(&kit.dir().unwrap().join("depth")).unwrap();
        assert_eq!(set.len(), 1);
        assert_eq!(set.manifest.frames[0].depth_mm, Some(0.5));
        // Never settles: fails after the timeout.
        kit.start(depth, at(100)).unwrap();
        assert_eq!(kit.timed_out(at(200)), None);
        assert!(kit.timed_out(at(100) + SETTLE_TIMEOUT).is_some());
        assert!(!kit.wants_frames());
        let _ = std::fs::remove_dir_all(root);
    }
}
