//! The camera seam: anything that yields timestamped frames.
//!
//! Implementations: the V4L2 camera ([`crate::camera`], feature `v4l`), frame-set replay
//! ([`SetReplay`]), and the simulated skin (`vistaf_sim::SimSource`). "Newest frame wins" is
//! the service's policy, not the source's: a source hands out every frame it has, in order,
//! with a sequence number whose gaps reveal frames it dropped.

use std::time::{Duration, Instant};

use crate::frame::{Frame, FrameError, PixelFormat};
use crate::frameset::{FrameEntry, FrameSet, FrameSetError, FrameSetWriter};

/// What a source delivers, as negotiated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SourceFormat {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Pixel layout.
    pub pixel: PixelFormat,
    /// Nominal frame interval as a fraction of a second (numerator, denominator);
    /// `None` when the source has no fixed rate.
    pub interval: Option<(u32, u32)>,
}

/// Why a source could not deliver.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SourceError {
    /// The device is not there (unplugged, wrong path, driver unbound).
    #[error("{device}: device not available: {detail}")]
    Gone {
        /// Device path or name.
        device: String,
        /// What the OS said.
        detail: String,
    },
    /// An I/O error talking to the device.
    #[error("{device}: {cause}")]
    Io {
        /// Device path or name.
        device: String,
        /// The cause.
        cause: std::io::Error,
    },
    /// The device cannot deliver what was asked.
    #[error("{device}: {detail}")]
    Unsupported {
        /// Device path or name.
        device: String,
        /// What is not supported.
        detail: String,
    },
    /// A frame set could not be read.
    #[error(transparent)]
    FrameSet(#[from] FrameSetError),
    /// A malformed frame.
    #[error(transparent)]
    Frame(#[from] FrameError),
}

impl SourceError {
    /// Whether retrying later may help (the device went away and may come back).
    pub fn is_transient(&self) -> bool {
        matches!(self, SourceError::Gone { .. } | SourceError::Io { .. })
    }
}

/// A source of frames.
pub trait FrameSource: Send {
    /// What the source delivers.
    fn format(&self) -> SourceFormat;
    /// A short name for messages (`/dev/video0`, `set:fixtures/idle`, `sim:press-sphere`).
    fn name(&self) -> String;
    /// The next frame, blocking until it is due; `Ok(None)` at the end of a finite source.
    fn next_frame(&mut self) -> Result<Option<Frame>, SourceError>;
    /// A remark worth one log line, given once (a camera's light settings held:
    /// [`crate::light_hold`]); none by default.
    fn take_note(&mut self) -> Option<String> {
        None
    }
}

/// How a replayed set is paced.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pacing {
    /// Deliver each frame at its recorded `t_ms` (frames without one: 30 frames/s).
    Recorded,
    /// Deliver frames as fast as they are asked for.
    AsFastAsPossible,
}

/// Replays a frame set as a camera would deliver it.
#[derive(Debug)]
pub struct SetReplay {
    set: FrameSet,
    pacing: Pacing,
    looping: bool,
    next: usize,
    seq: u64,
    started: Option<Instant>,
    loop_offset: Duration,
}

impl SetReplay {
    /// Replays `set`; with `looping`, starts over after the last frame.
    pub fn new(set: FrameSet, pacing: Pacing, looping: bool) -> SetReplay {
        SetReplay {
            set,
            pacing,
            looping,
            next: 0,
            seq: 0,
            started: None,
            loop_offset: Duration::ZERO,
        }
    }

    /// Opens the set in `dir` and replays it.
    pub fn open(
        dir: &std::path::Path,
        pacing: Pacing,
        looping: bool,
    ) -> Result<SetReplay, SourceError> {
        Ok(SetReplay::new(FrameSet::open(dir)?, pacing, looping))
    }

    /// The set being replayed.
    pub fn set(&self) -> &FrameSet {
        &self.set
    }

    fn t_of(&self, i: usize) -> Duration {
        self.set.t_of(i)
    }
}

impl FrameSource for SetReplay {
    fn format(&self) -> SourceFormat {
        let (width, height) = self.set.size();
        SourceFormat {
            width,
            height,
            pixel: self.set.frame_format(),
            interval: None,
        }
    }

    fn name(&self) -> String {
        format!("set:{}", self.set.dir().display())
    }

    fn next_frame(&mut self) -> Result<Option<Frame>, SourceError> {
        if self.next >= self.set.len() {
            if !self.looping || self.set.is_empty() {
                return Ok(None);
            }
            let last = self.t_of(self.set.len() - 1);
            self.loop_offset += last + Duration::from_millis(33);
            self.next = 0;
        }
        let i = self.next;
        let t = self.loop_offset + self.t_of(i);
        let started = *self.started.get_or_insert_with(Instant::now);
        if self.pacing == Pacing::Recorded {
            if let Some(wait) = t.checked_sub(started.elapsed()) {
                std::thread::sleep(wait);
            }
        }
        let mut frame = self.set.frame(i)?;
        frame.timestamp = t;
        frame.seq = self.seq;
        self.next += 1;
        self.seq += 1;
        Ok(Some(frame))
    }
}

/// Records `frames` frames from `source` into a new set in `dir`. The first frame delivered
/// becomes the reference (start recording with nothing touching the skin).
pub fn record(
    source: &mut dyn FrameSource,
    dir: &std::path::Path,
    frames: usize,
    grating_period_mm: f64,
) -> Result<FrameSet, SourceError> {
    let first = source
        .next_frame()?
        .ok_or_else(|| SourceError::Unsupported {
            device: source.name(),
            detail: "ended before delivering a reference frame".into(),
        })?;
    let t0 = first.timestamp;
    let mut w = FrameSetWriter::create_from_frame(dir, grating_period_mm, &first)?;
    w.extra_mut()
        .insert("recorded_from".into(), source.name().into());
    for _ in 0..frames {
        let Some(f) = source.next_frame()? else { break };
        let t_ms = f.timestamp.saturating_sub(t0).as_secs_f64() * 1000.0;
        w.add_frame(
            &f,
            FrameEntry {
                t_ms: Some(t_ms),
                ..Default::default()
            },
        )?;
    }
    Ok(w.finish()?)
}

/// Reopens a source that went away, with exponential back-off.
///
/// On a transient error ([`SourceError::is_transient`]) the error is returned (so the
/// caller can report "camera lost") and the source is dropped; every later call first
/// waits the current back-off (doubling from `min_backoff` up to `max_backoff`), then
/// tries to reopen. A successful reopen resets the back-off and counts in
/// [`Reconnect::reopened`].
pub struct Reconnect<S: FrameSource, F: FnMut() -> Result<S, SourceError> + Send> {
    open: F,
    current: Option<S>,
    last_format: SourceFormat,
    name: String,
    backoff: Duration,
    /// First wait after a loss.
    pub min_backoff: Duration,
    /// Longest wait between attempts.
    pub max_backoff: Duration,
    /// Successful reopens.
    pub reopened: u64,
    sleep: fn(Duration),
}

impl<S: FrameSource, F: FnMut() -> Result<S, SourceError> + Send> std::fmt::Debug
    for Reconnect<S, F>
{
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Reconnect")
            .field("name", &self.name)
            .field("reopened", &self.reopened)
            .finish()
    }
}

impl<S: FrameSource, F: FnMut() -> Result<S, SourceError> + Send> Reconnect<S, F> {
    /// Opens the source once (failing if it is not there at all) and keeps `open` for later.
    pub fn new(mut open: F) -> Result<Self, SourceError> {
        let first = open()?;
        Ok(Reconnect {
            last_format: first.format(),
            name: first.name(),
            open,
            current: Some(first),
            backoff: Duration::from_millis(100),
            min_backoff: Duration::from_millis(100),
            max_backoff: Duration::from_secs(5),
            reopened: 0,
            sleep: std::thread::sleep,
        })
    }

    /// Replaces the sleep function (tests).
    pub fn with_sleep(mut self, sleep: fn(Duration)) -> Self {
        self.sleep = sleep;
        self
    }

    /// Whether the source is currently open.
    pub fn is_connected(&self) -> bool {
        self.current.is_some()
    }
}

impl<S: FrameSource, F: FnMut() -> Result<S, SourceError> + Send> FrameSource for Reconnect<S, F> {
    fn format(&self) -> SourceFormat {
        self.current
            .as_ref()
            .map_or(self.last_format, |s| s.format())
    }

    fn name(&self) -> String {
        self.name.clone()
    }

    fn next_frame(&mut self) -> Result<Option<Frame>, SourceError> {
        if self.current.is_none() {
            (self.sleep)(self.backoff);
            match (self.open)() {
                Ok(s) => {
                    self.last_format = s.format();
                    self.current = Some(s);
                    self.backoff = self.min_backoff;
                    self.reopened += 1;
                }
                Err(e) => {
                    self.backoff = (self.backoff * 2).min(self.max_backoff);
                    return Err(e);
                }
            }
        }
        let Some(src) = self.current.as_mut() else {
            return Ok(None);
        };
        match src.next_frame() {
            Err(e) if e.is_transient() => {
                self.current = None;
                self.backoff = self.min_backoff;
                Err(e)
            }
            other => other,
        }
    }

    fn take_note(&mut self) -> Option<String> {
        self.current.as_mut().and_then(|s| s.take_note())
    }
}
