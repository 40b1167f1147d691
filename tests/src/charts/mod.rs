//! Speed against accuracy, and stability where methods fail: the measurements behind
//! `docs/performance.md` and its charts (`vistaf-charts`).
//!
//! * [`stability`] sweeps each axis along which a method can fail and records, per frame,
//!   the error in units of its tolerance and whether the frame was flagged, then checks the
//!   rule the flags must keep: out of tolerance ⇒ flagged in ≥ 95 % of frames, inside the
//!   envelope ⇒ falsely flagged in ≤ 2 %.
//! * [`tradeoff`] runs pipeline configurations over a fixed benchmark set and records cost
//!   (time, optionally instructions) beside accuracy.
//! * [`plot`] draws both (plotters, PNG and SVG).

pub mod plot;
pub mod stability;
pub mod tradeoff;

use vistaf_sim::contact::{Contact, Indenter};
use vistaf_sim::scene::{center_mm, ROOM_C};
use vistaf_sim::{SensorUnit, SkinState};

/// Depth tolerance of the force-and-shape pipeline: 3 % of depth + 0.02 mm.
pub fn depth_tolerance_mm(depth_mm: f32) -> f32 {
    0.03 * depth_mm + 0.02
}

/// Temperature tolerance: 0.3 °C within 22–32 °C, 1.0 °C elsewhere in 15–45 °C.
pub fn temperature_tolerance_c(t_c: f32) -> f32 {
    if (22.0..=32.0).contains(&t_c) {
        0.3
    } else {
        1.0
    }
}

/// A sphere of radius `r_mm` pressed `depth_mm` into the middle of the skin.
pub fn press(unit: &SensorUnit, r_mm: f32, depth_mm: f32) -> SkinState {
    let mut s = SkinState::idle(ROOM_C);
    if depth_mm > 0.0 {
        s.contacts.push(Contact {
            indenter: Indenter::Sphere { r_mm },
            center_mm: center_mm(unit),
            depth_mm,
        });
    }
    s
}
