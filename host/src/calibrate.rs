//! A guided calibration over a link: the session of [`vistaf_session`] with this crate's
//! [`Client`] as its device (the board runs the same session on its own service).

use std::time::Duration;

use vistaf_protocol::{CalibrationFitted, ErrorCode, Hello, KitCaptured, KitStep, KitVerdict};
pub use vistaf_session::plan::{DEFAULT_DEPTHS_MM, DEFAULT_FORCES_N, DEFAULT_TEMPERATURES_C};
pub use vistaf_session::{
    instruction, run, verdict_text, Activate, Answer, Guide, KitDevice, KitError, Outcome, Plan,
    Scripted, SessionError, Terminal, WithScale,
};

use crate::client::{Client, DEFAULT_TIMEOUT};
use crate::error::HostError;

impl From<HostError> for KitError {
    fn from(e: HostError) -> KitError {
        match e {
            HostError::Device { error, .. } if error.code == ErrorCode::NotSettled => {
                KitError::from(&error)
            }
            other => KitError::Failed(Box::new(other)),
        }
    }
}

impl KitDevice for Client {
    fn pause(&mut self) -> Result<(), KitError> {
        Ok(self.stop(DEFAULT_TIMEOUT)?)
    }

    fn resume(&mut self) -> Result<(), KitError> {
        Ok(self.start(DEFAULT_TIMEOUT)?)
    }

    fn capture(&mut self, step: KitStep, timeout: Duration) -> Result<KitCaptured, KitError> {
        Ok(self.kit_capture(step, timeout)?)
    }

    fn fit(&mut self, timeout: Duration) -> Result<(Vec<KitVerdict>, CalibrationFitted), KitError> {
        Ok(self.kit_fit(timeout)?)
    }

    fn activate(&mut self, calibration_id: u32, timeout: Duration) -> Result<Hello, KitError> {
        Ok(self.activate_calibration(calibration_id, timeout)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use vistaf_protocol::{DeviceError, DeviceMsg, KitQuantity};

    /// A client reading `msgs` from its link.
    fn client(msgs: &[DeviceMsg]) -> Client {
        let mut bytes = Vec::new();
        for m in msgs {
            let mut buf = [0u8; vistaf_protocol::frame::DEVICE_FRAME_MAX];
            let n = vistaf_protocol::encode(m, &mut buf).unwrap();
            bytes.extend(&buf[..n]);
        }
        Client::new(crate::link::Link::new(
            "test".into(),
            std::io::Cursor::new(bytes),
            Vec::new(),
        ))
    }

    /// The device's "not settled" is the session's cue to ask again; any other error
    /// ends it, and the capture the device sends is the one returned.
    #[test]
    fn a_device_that_did_not_settle_says_so_to_the_session() {
        let step = KitStep {
            quantity: KitQuantity::Temperature,
            value_milli: 30_000,
        };
        let error = |code| {
            DeviceMsg::Error(DeviceError {
                code,
                detail: vistaf_protocol::msg::truncated("the image did not settle"),
            })
        };
        let captured = KitCaptured {
            step,
            frames: 1,
            settle_ms: 31_000,
            change_centi_dn: 80,
        };
        let mut c = client(&[
            error(ErrorCode::NotSettled),
            DeviceMsg::KitCaptured(captured),
        ]);
        let t = Duration::from_secs(1);
        assert!(matches!(
            c.capture(step, t),
            Err(KitError::NotSettled(d)) if d.contains("did not settle")
        ));
        assert_eq!(c.capture(step, t).unwrap(), captured);
        let mut c = client(&[error(ErrorCode::Calibration)]);
        assert!(matches!(c.capture(step, t), Err(KitError::Failed(_))));
    }
}
