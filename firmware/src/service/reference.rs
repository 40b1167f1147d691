//! The reference keeper: when the no-contact reference is taken, whether it has drifted,
//! and when it is renewed.
//!
//! * **Taken once the image is stable**: the mean absolute luminance change between
//!   consecutive frames (at a quarter of the resolution) must fall below
//!   `reference.stable_dn` (measured, not a sleep), or `max_wait_frames` pass.
//! * **Drift** is judged on frames without contact: a registration offset beyond
//!   `drift_rad`, or a mean brightness change beyond `drift_brightness` that the skin's own
//!   temperature does not explain ([`TEMPERATURE_EXPLAINS_C`]). Contact frames cannot
//!   tell, so they keep the last verdict.
//! * **Renewed** after `auto_after_s` without contact when drifted; with renewal off (0),
//!   the frames carry `stale_reference` until the host asks for a new reference.

use std::time::{Duration, Instant};

use vistaf_pipeline::image_ops::gray_down_q8;
use vistaf_pipeline::input::{luma, Pixels};
use vistaf_pipeline::{Analyzer, Measurement, PipelineError};

use crate::config::ReferencePolicy;

/// A change of the skin's mean temperature (°C) since the reference that explains a change
/// of brightness: thermochromic stripes change colour, so the image's brightness follows
/// the temperature the service is there to report.
pub const TEMPERATURE_EXPLAINS_C: f32 = 0.5;

/// Downsampling of the stability test's luminance images.
const STABILITY_FACTOR: usize = 4;

/// A reference in use, with what drift is judged against.
#[derive(Debug)]
struct Reference {
    analyzer: Analyzer,
    /// Mean of a sparse sample of the reference's bytes, 0–255.
    brightness: f32,
    /// The skin's mean temperature when it was taken, °C.
    temp_c: Option<f32>,
    /// When contact was last seen (or the reference taken).
    calm_since: Instant,
    /// Whether the last frame without contact found it drifted.
    drifted: bool,
}

/// Waiting for a stable image.
#[derive(Debug, Default)]
struct Settling {
    last_gray: Option<Vec<u16>>,
    frames: u32,
}

/// What a measured frame says about the reference.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// Still good.
    Fresh,
    /// Drifted: the frame's numbers may be off (`stale_reference`).
    Stale,
    /// Drifted, and calm long enough: take a new one (from the next stable frames).
    Renew,
}

/// Takes, judges and renews the reference.
#[derive(Debug)]
pub struct ReferenceKeeper {
    policy: ReferencePolicy,
    current: Option<Reference>,
    settling: Settling,
    /// When the reference in use (or, before the first, the keeper) was made.
    taken_at: Instant,
    /// References taken so far.
    taken: u32,
}

impl ReferenceKeeper {
    /// A keeper waiting for its first stable image.
    pub fn new(policy: ReferencePolicy, now: Instant) -> ReferenceKeeper {
        ReferenceKeeper {
            policy,
            current: None,
            settling: Settling::default(),
            taken_at: now,
            taken: 0,
        }
    }

    /// The pipeline prepared for the current reference, if there is one.
    pub fn analyzer(&self) -> Option<&Analyzer> {
        self.current.as_ref().map(|r| &r.analyzer)
    }

    /// References taken so far.
    pub fn taken(&self) -> u32 {
        self.taken
    }

    /// How old the current reference is (before the first: how long the keeper has run).
    pub fn age(&self, now: Instant) -> Duration {
        now.saturating_duration_since(self.taken_at)
    }

    /// Offers a frame while there is no reference; `make` prepares the pipeline for it once
    /// the image has settled. `Ok(true)` when a reference was taken.
    pub fn offer(
        &mut self,
        img: Pixels<'_>,
        now: Instant,
        make: impl FnOnce(Pixels<'_>) -> Result<Analyzer, PipelineError>,
    ) -> Result<bool, PipelineError> {
        let (g, _, _, _) = gray_down_q8(img, STABILITY_FACTOR);
        let s = &mut self.settling;
        let stable = s
            .last_gray
            .as_ref()
            .is_some_and(|p| mean_abs_diff(p, &g) < self.policy.stable_dn);
        s.frames += 1;
        s.last_gray = Some(g);
        if !(stable || s.frames >= self.policy.max_wait_frames) {
            return Ok(false);
        }
        let analyzer = make(img)?;
        let temp_c = analyzer
            .analyze(img)
            .ok()
            .and_then(|d| d.temperature)
            .map(|t| t.mean_c)
            .filter(|t| t.is_finite());
        self.current = Some(Reference {
            analyzer,
            brightness: brightness(img),
            temp_c,
            calm_since: now,
            drifted: false,
        });
        self.settling = Settling::default();
        self.taken += 1;
        self.taken_at = now;
        Ok(true)
    }

    /// Judges the reference on a measured frame `d` of image `img`.
    pub fn judge(&mut self, d: &Measurement, img: Pixels<'_>, now: Instant) -> Verdict {
        let policy = self.policy;
        let Some(r) = self.current.as_mut() else {
            return Verdict::Fresh;
        };
        if d.contact {
            r.calm_since = now;
        } else {
            let warmed = match (r.temp_c, d.temperature.as_ref()) {
                (Some(t0), Some(t)) if t.mean_c.is_finite() => {
                    (t.mean_c - t0).abs() > TEMPERATURE_EXPLAINS_C
                }
                _ => false,
            };
            let light = brightness(img) / r.brightness.max(1e-3) - 1.0;
            r.drifted = d.offset_rad.abs() > policy.drift_rad
                || (!warmed && light.abs() > policy.drift_brightness);
        }
        if !r.drifted {
            return Verdict::Fresh;
        }
        let calm_s = now.saturating_duration_since(r.calm_since).as_secs_f32();
        if policy.auto_after_s > 0.0 && !d.contact && calm_s >= policy.auto_after_s {
            Verdict::Renew
        } else {
            Verdict::Stale
        }
    }

    /// Drops the reference: the next stable frames make a new one.
    pub fn renew(&mut self) {
        self.current = None;
        self.settling = Settling::default();
    }
}

/// Mean luminance of a sparse sample of the image's pixels (every 11th), 0–255 in 8.8
/// steps: enough to see the light change, in any colour encoding.
fn brightness(img: Pixels<'_>) -> f32 {
    let l = luma(img.colour());
    let (sum, n) = img
        .raw()
        .as_chunks::<3>()
        .0
        .iter()
        .step_by(11)
        .fold((0u64, 0u64), |(s, n), p| {
            (s + u64::from(l.weighted(p)), n + 1)
        });
    l.mean_q8(sum, n) as f32 / 256.0
}

/// Mean absolute difference of two Q8 images (luminance, or block means), 8-bit steps;
/// infinite for images of different sizes or none (nothing shows they agree).
pub(super) fn mean_abs_diff(a: &[u16], b: &[u16]) -> f32 {
    if a.len() != b.len() || a.is_empty() {
        return f32::INFINITY;
    }
    let s: u64 = a
        .iter()
        .zip(b)
        .map(|(x, y)| u64::from(x.abs_diff(*y)))
        .sum();
    s as f32 / 256.0 / a.len() as f32
}
