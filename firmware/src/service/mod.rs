//! The on-device service: camera → pipeline → serial.
//!
//! ```text
//!  capture thread ──(Newest: one slot, newest wins)──▶ ┐
//!  link reader thread ──(HostMsg)────────────────────▶ ├─ runner ─▶ Service ─▶ link
//!  camera lost / back ───────────────────────────────▶ ┘   (edge)   (decides)  (postcard frames)
//! ```
//!
//! * [`Service`] ([`machine`]) decides: every event (a frame, a host command, a camera
//!   outage, the passing of time) goes in, the messages to send come out. It owns the
//!   [`ReferenceKeeper`] ([`reference`](mod@reference): when the reference is taken,
//!   whether it drifted, when it is renewed) and reads the time from an injected
//!   [`Clock`], so its tests drive it frame by frame with a clock they move by hand.
//! * [`run`] ([`runner`]) is the edge: it starts the capture and link-reader threads, feeds
//!   their events to the service, and writes what comes out. The capture thread reads the
//!   source as fast as it delivers into a one-slot [`runner::Newest`] mailbox: a newer
//!   frame evicts the waiting one, and every eviction is counted
//!   (`Status.frames_dropped`), so the pipeline always works on the newest image.
//! * Camera lost (a transient source error): one `Error(CameraLost)` and
//!   `RunState::CameraLost` in `Status` while the source retries with back-off; frames
//!   resuming count in `Status.camera_restarts`.
//! * Host commands are handled between frames: `Ping`, `GetInfo`, `CaptureReference`,
//!   `SetRate`, `SetLed`, `RequestMap` and `RequestFullMap` ([`maps`]: the next frame's
//!   map, coarse in one message or whole in pieces), `Start`, `Stop`, `Clock`, and a guided
//!   calibration's `KitCapture`, `KitFit`, `CalibrationActivate`, `CalibrationRollback`
//!   ([`kit`]: the kit captured and fitted on the device; [`persist`]: the calibration
//!   file and the one it replaced). A `Clock` request is
//!   stamped when the link reader decodes it, so its answer tells the host how long it
//!   waited for the frame in progress.
//! * A `Hello` goes out at start and on request; a `Status` every second.
//! * A bad frame (wrong size, undecodable) is counted and skipped; a failing link write is
//!   counted and the service keeps running (the host may come back).

pub mod clock;
pub mod kit;
pub mod local;
pub mod machine;
pub mod maps;
pub mod persist;
pub mod pty;
pub mod reference;
pub mod runner;
pub mod systemd;
pub mod wire;

pub use clock::{Clock, ManualClock, SystemClock};
pub use machine::{CameraEvent, EdgeCounters, Service};
pub use reference::{ReferenceKeeper, Verdict, TEMPERATURE_EXPLAINS_C};
pub use runner::run;
pub use wire::summary_of;

pub use crate::config::ReferencePolicy;
use std::path::PathBuf;

use vistaf_hardware::bench::SharedBench;
use vistaf_hardware::led::LedConfig;
use vistaf_pipeline::{Calibration, Implementation};

/// Where kits go when neither the configuration nor the command line says.
pub const DEFAULT_KIT_DIR: &str = "vistaf-kit";

/// Service settings.
#[derive(Debug, Clone)]
pub struct Settings {
    /// Device serial sent in `Hello` (cut to the wire's 24 bytes).
    pub serial: String,
    /// Calibration.
    pub calibration: Calibration,
    /// Use the calibration even for another geometry.
    pub force_calibration: bool,
    /// Pipeline implementation.
    pub pipeline: Implementation,
    /// Stop after this many processed frames.
    pub frames: Option<u64>,
    /// Summary rate limit, Hz (0 = every frame).
    pub max_rate_hz: u16,
    /// LED ring at start.
    pub led: LedConfig,
    /// When the reference is taken and renewed.
    pub reference: ReferencePolicy,
    /// The file the calibration came from: an activated calibration is written there (the
    /// one it replaces kept beside it); `None` keeps activations in memory.
    pub calibration_path: Option<PathBuf>,
    /// The calibration the last activation replaced (kept beside the file as
    /// `<file>.previous`), for a rollback after a restart.
    pub previous: Option<Calibration>,
    /// Where calibration kits captured on the device are kept.
    pub kit_dir: PathBuf,
    /// The calibration bench, when software drives it (a simulated skin's).
    pub bench: Option<SharedBench>,
}

impl Settings {
    /// The reference build's settings with `calibration`: the device path, a summary per
    /// frame, no frame limit, the default LED ring and reference policy, serial `VSK-SIM`.
    pub fn new(calibration: Calibration) -> Settings {
        Settings {
            serial: "VSK-SIM".into(),
            calibration,
            force_calibration: false,
            pipeline: Implementation::Fixed,
            frames: None,
            max_rate_hz: 0,
            led: LedConfig::default(),
            reference: ReferencePolicy::default(),
            calibration_path: None,
            previous: None,
            kit_dir: PathBuf::from(DEFAULT_KIT_DIR),
            bench: None,
        }
    }
}

/// Counters at the end of a run.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counters {
    /// Frames delivered by the source.
    pub captured: u32,
    /// Frames processed.
    pub processed: u32,
    /// Frames evicted by a newer one.
    pub dropped: u32,
    /// Malformed frames skipped.
    pub bad: u32,
    /// Summaries written.
    pub sent: u32,
    /// Link writes that failed.
    pub link_errors: u32,
    /// References taken (the first one included).
    pub references: u32,
    /// Times frames resumed after the camera was lost.
    pub camera_restarts: u32,
    /// Summaries flagged `stale_reference`.
    pub stale: u32,
    /// Frames spent taking a reference (waiting for a stable image, or for the retry of
    /// one that could not be used).
    pub referencing: u32,
    /// References that could not be used (no grating in view, a calibration for another
    /// unit), each reported and retried.
    pub reference_failures: u32,
}
