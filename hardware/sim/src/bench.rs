//! A scripted indenter and heater: the simulated skin on a calibration bench.
//!
//! A guided calibration tells the device each step (the sphere to a depth, to a force, the
//! skin to a temperature); on a simulated unit the device applies it here, and the
//! [`crate::SimSource`] made by [`crate::SimSource::on_bench`] films it from the next frame
//! on. Presses alternate between the calibration kit's two positions, as a person moving
//! the indenter between presses would; a force becomes the depth the unit's stiffness
//! gives it (Hertz), so force labels carry the unit's own mechanics.

use std::sync::{Arc, Mutex, PoisonError};

use vistaf_hardware::bench::{Bench, Stimulus};

use crate::contact::Indenter;
use crate::scene::{self, SPHERE_R_MM};
use crate::sets::press;
use crate::state::SkinState;
use crate::unit::SensorUnit;

/// The state the bench last set, shared with the source that films it.
#[derive(Debug, Clone)]
pub struct LiveState(Arc<Mutex<SkinState>>);

impl LiveState {
    /// The state to film now.
    pub fn get(&self) -> SkinState {
        self.0
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone()
    }
}

/// The simulated bench of one unit.
#[derive(Debug)]
pub struct SimBench {
    unit: SensorUnit,
    live: LiveState,
    presses: usize,
}

impl SimBench {
    /// A bench for `unit`, the skin untouched at room temperature; and what it sets.
    pub fn new(unit: SensorUnit) -> (SimBench, LiveState) {
        let live = LiveState(Arc::new(Mutex::new(SkinState::idle(scene::ROOM_C))));
        let bench = SimBench {
            unit,
            live: live.clone(),
            presses: 0,
        };
        (bench, live)
    }

    fn press(&mut self, depth_mm: f32) -> SkinState {
        self.presses += 1;
        press(&self.unit, self.presses, depth_mm)
    }
}

impl Bench for SimBench {
    fn apply(&mut self, s: Stimulus) -> Result<(), String> {
        let state = match s {
            Stimulus::Untouched { temp_c } if (-20.0..=80.0).contains(&temp_c) => {
                scene::uniform(temp_c)
            }
            Stimulus::SphereDepth { depth_mm } if (0.0..=4.0).contains(&depth_mm) => {
                self.press(depth_mm)
            }
            Stimulus::SphereForce { force_n } if (0.0..=60.0).contains(&force_n) => {
                let sphere = Indenter::Sphere { r_mm: SPHERE_R_MM };
                let d = sphere.depth_for_force_mm(force_n, self.unit.modulus_mpa);
                self.press(d)
            }
            other => return Err(format!("the simulated bench cannot set {other:?}")),
        };
        *self.live.0.lock().unwrap_or_else(PoisonError::into_inner) = state;
        Ok(())
    }
}
