//! The simulated skin: synthetic sensor frames with ground truth.
//!
//! ```text
//!  SensorUnit (from a unit seed)      SkinState (contacts, temperature, shift, exposure)
//!          │                                   │
//!          └──────────── Renderer ─────────────┘──▶ RgbImage + Truth (depth, T, force)
//! ```
//!
//! * [`unit`](mod@unit): what differs between manufactured units (period in pixels, tilt,
//!   phase response, stiffness, optics, noise, pigment batch).
//! * [`imperfections`]: what a built skin shows beyond the ideal model (oblique light,
//!   glare, white balance, mottle, grating wobble and distortion, lateral chromatic
//!   aberration, JPEG).
//! * [`footprint`]: flat shapes on the skin (discs, letters, a hex nut).
//! * [`contact`]: indenters and the elastic half-space model (Hertz for spheres,
//!   Boussinesq for cylinders, [`elastic`]: any flat footprint solved numerically).
//! * [`state`]: what the skin shows in one frame (contacts, temperature, optics).
//! * [`thermal`]: temperature fields (heated contacts with lateral conduction, gradients).
//! * [`render`](mod@render): the image formation model ([`plane`]: blurs on the pixel grid).
//! * [`scene`]: named scripted scenes.
//! * [`sets`]: writing scenes and calibration kits as `vistaf-frames/1` sets with truth.
//! * [`bench`](mod@bench): a scripted indenter and heater a guided calibration drives
//!   ([`SimSource::on_bench`]).
//!
//! Deterministic: the same unit seed, scene and noise seed give the same bytes.

pub mod bench;
pub mod contact;
pub mod elastic;
pub mod footprint;
pub mod imperfections;
pub mod plane;
pub mod render;
pub mod rng;
pub mod scene;
pub mod sets;
pub mod state;
pub mod thermal;
pub mod unit;

pub use render::{render, Renderer, Truth};
pub use state::SkinState;
pub use unit::SensorUnit;

use std::time::{Duration, Instant};

use vistaf_hardware::frame::{Frame, PixelFormat};
use vistaf_hardware::source::{FrameSource, SourceError, SourceFormat};

/// A camera that films a scripted simulated skin.
#[derive(Debug)]
pub struct SimSource {
    renderer: Renderer,
    name: String,
    states: Vec<SkinState>,
    next: usize,
    looping: bool,
    fps: Option<f32>,
    seed: u64,
    started: Option<Instant>,
    delivered: u64,
    last_truth: Option<Truth>,
    /// Set by a bench: the state filmed, instead of `states`.
    live: Option<bench::LiveState>,
}

impl SimSource {
    /// Films `states` with `unit`; `fps` paces delivery (None = as fast as asked).
    pub fn new(
        name: &str,
        unit: SensorUnit,
        states: Vec<SkinState>,
        fps: Option<f32>,
        seed: u64,
    ) -> SimSource {
        SimSource {
            renderer: Renderer::new(unit),
            name: format!("sim:{name}"),
            states,
            next: 0,
            looping: false,
            fps,
            seed,
            started: None,
            delivered: 0,
            last_truth: None,
            live: None,
        }
    }

    /// Films `unit` on a calibration bench, for ever: the skin shows whatever the returned
    /// bench was last told (untouched at room temperature until then).
    pub fn on_bench(unit: SensorUnit, fps: Option<f32>, seed: u64) -> (SimSource, bench::SimBench) {
        let (bench, live) = bench::SimBench::new(unit.clone());
        let mut src = SimSource::new("bench", unit, Vec::new(), fps, seed);
        src.live = Some(live);
        (src, bench)
    }

    /// Films the named scene; `None` for an unknown name.
    pub fn scene(
        name: &str,
        unit: SensorUnit,
        frames: usize,
        fps: Option<f32>,
        seed: u64,
    ) -> Option<SimSource> {
        let states = scene::states(name, &unit, frames)?;
        Some(SimSource::new(name, unit, states, fps, seed))
    }

    /// Starts over after the last state.
    pub fn looping(mut self, on: bool) -> SimSource {
        self.looping = on;
        self
    }

    /// The no-contact frame of this unit at the scene's base temperature.
    pub fn reference_frame(&self) -> image::RgbImage {
        let base = self
            .states
            .first()
            .map_or(scene::ROOM_C, |s| s.temperature.base_c);
        self.renderer
            .render(&SkinState::idle(base), self.seed ^ 0xfeed)
            .0
    }

    /// Ground truth of the frame last delivered.
    pub fn last_truth(&self) -> Option<&Truth> {
        self.last_truth.as_ref()
    }

    /// The unit being filmed.
    pub fn unit(&self) -> &SensorUnit {
        self.renderer.unit()
    }
}

impl FrameSource for SimSource {
    fn format(&self) -> SourceFormat {
        let u = self.renderer.unit();
        SourceFormat {
            width: u.width_px,
            height: u.height_px,
            pixel: PixelFormat::Rgb8,
            interval: self.fps.map(|f| (1000, (f * 1000.0).round() as u32)),
        }
    }

    fn name(&self) -> String {
        self.name.clone()
    }

    fn next_frame(&mut self) -> Result<Option<Frame>, SourceError> {
        let live = self.live.as_ref().map(bench::LiveState::get);
        if live.is_none() && self.next >= self.states.len() {
            if !self.looping || self.states.is_empty() {
                return Ok(None);
            }
            self.next = 0;
        }
        let i = self.next;
        let started = *self.started.get_or_insert_with(Instant::now);
        let seq = self.delivered;
        let state = match &live {
            Some(s) => s,
            None => &self.states[i],
        };
        let (img, truth) = self.renderer.render(state, self.seed.wrapping_add(seq));
        let timestamp = match self.fps {
            Some(fps) => {
                let due = Duration::from_secs_f64(seq as f64 / f64::from(fps.max(0.1)));
                if let Some(wait) = due.checked_sub(started.elapsed()) {
                    std::thread::sleep(wait);
                }
                vistaf_hardware::clock::now()
            }
            None => vistaf_hardware::clock::now(),
        };
        self.next += 1;
        self.delivered += 1;
        self.last_truth = Some(truth);
        Ok(Some(Frame::from_rgb(img, timestamp, seq)))
    }
}
