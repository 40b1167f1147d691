//! The calibration bench: what presses and heats the skin during a guided calibration.
//!
//! On a real unit a person (or a motorised stage, a heater driven by a script on the host)
//! sets each step, and the device is told what was set; the device then only waits for
//! the image to settle. A bench that software drives, such as the simulated skin's,
//! implements [`Bench`], and the device applies each step to it before it waits, so the
//! same guided session runs end to end without hands.

use std::sync::{Arc, Mutex};

/// What the skin should show for one step of a calibration kit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Stimulus {
    /// Nothing touching it, at a uniform temperature, °C.
    Untouched {
        /// Skin temperature, °C.
        temp_c: f32,
    },
    /// The calibration sphere pressed to a known depth, mm.
    SphereDepth {
        /// Indentation, mm.
        depth_mm: f32,
    },
    /// The calibration sphere pressed with a known force, N.
    SphereForce {
        /// Normal force, N.
        force_n: f32,
    },
}

/// A bench the device can drive.
pub trait Bench: Send + std::fmt::Debug {
    /// Sets the skin to show `s` from the next frames on; the reason when it cannot.
    fn apply(&mut self, s: Stimulus) -> Result<(), String>;
}

/// A bench shared between whoever drives it and the source that films it.
pub type SharedBench = Arc<Mutex<dyn Bench>>;
