//! Which device message answers a session's command, the same over a link (the host's
//! client) and in process (the board's service): each is a picker for the caller's wait.

use vistaf_protocol::{CalibrationFitted, DeviceMsg, Hello, KitCaptured, KitStep, KitVerdict};

use crate::session::KitError;

/// The capture of `step` (`HostMsg::KitCapture`).
pub fn captured(step: KitStep) -> impl FnMut(&DeviceMsg) -> Option<KitCaptured> {
    move |m| match m {
        DeviceMsg::KitCaptured(c) if c.step == step => Some(*c),
        _ => None,
    }
}

/// The fitted candidate (`HostMsg::KitFit`); the verdicts before it go into `verdicts`.
pub fn fitted(
    verdicts: &mut Vec<KitVerdict>,
) -> impl FnMut(&DeviceMsg) -> Option<CalibrationFitted> + '_ {
    move |m| match m {
        DeviceMsg::KitVerdict(v) => {
            verdicts.push(*v);
            None
        }
        DeviceMsg::CalibrationFitted(f) => Some(*f),
        _ => None,
    }
}

/// The device's identity once `calibration_id` is in use (`HostMsg::CalibrationActivate`).
pub fn activated(calibration_id: u32) -> impl FnMut(&DeviceMsg) -> Option<Hello> {
    move |m| match m {
        DeviceMsg::Hello(h) if h.calibration_id == calibration_id => Some(h.clone()),
        _ => None,
    }
}

impl From<&vistaf_protocol::DeviceError> for KitError {
    /// A device's refusal: "not settled" is the session's cue to ask again.
    fn from(e: &vistaf_protocol::DeviceError) -> KitError {
        if e.code == vistaf_protocol::ErrorCode::NotSettled {
            KitError::NotSettled(e.detail.to_string())
        } else {
            KitError::Failed(format!("{:?}: {}", e.code, e.detail).into())
        }
    }
}
