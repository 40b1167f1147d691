//! The state of the skin in one frame: what touches it, its temperature, and how the
//! camera sees it (shift, exposure, contrast, noise, white balance).

use crate::contact::Contact;
use crate::thermal::TempField;

/// Everything that changes from frame to frame.
#[derive(Debug, Clone, PartialEq)]
pub struct SkinState {
    /// Indenters pressing on the skin.
    pub contacts: Vec<Contact>,
    /// Temperature of the skin.
    pub temperature: TempField,
    /// Global shift of the skin relative to the camera, pixels (misregistration).
    pub shift_px: (f32, f32),
    /// Exposure relative to the unit's (> 1 over-exposes).
    pub exposure_scale: f32,
    /// Fringe contrast relative to the unit's (1 = as built, 0 = no stripes).
    pub contrast_scale: f32,
    /// Sensor noise relative to the unit's.
    pub noise_scale: f32,
    /// White balance relative to the unit's, linear R, G, B (an auto white balance drifting).
    pub white_balance: [f32; 3],
}

impl SkinState {
    /// No contact, uniform temperature, nominal optics.
    pub fn idle(t_c: f32) -> SkinState {
        SkinState {
            contacts: Vec::new(),
            temperature: TempField::uniform(t_c),
            shift_px: (0.0, 0.0),
            exposure_scale: 1.0,
            contrast_scale: 1.0,
            noise_scale: 1.0,
            white_balance: [1.0; 3],
        }
    }
}
