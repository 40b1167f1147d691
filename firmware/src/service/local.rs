//! The service driven in this process, without a link: a guided calibration on the board
//! (`vistaf-skin calibrate --guided`) runs the same session as the host's
//! `vistaf-host calibrate`, with the service's own state machine as its device.
//!
//! Each request is the command the host would send, handed to [`Service`]; its answer
//! comes back at once or after frames: a capture waits for the image to settle, a fit for
//! its thread. Frames are read from the source only while an answer is awaited, so the
//! camera is this command's for the session (the running service must be stopped first).

use std::time::{Duration, Instant};

use vistaf_hardware::source::FrameSource;
use vistaf_protocol::{
    CalibrationFitted, DeviceMsg, ErrorCode, Hello, HostMsg, KitCaptured, KitStep, KitVerdict,
};
use vistaf_session::{answer, KitDevice, KitError};

use super::{Service, SystemClock};

/// How often a fit in progress is looked at when no frame comes.
const FIT_POLL: Duration = Duration::from_millis(20);

/// A service and its camera, answering a session's requests.
pub struct Local<'a> {
    service: Service<'a, SystemClock>,
    source: Box<dyn FrameSource>,
    /// Kinds of report already said (each is said once).
    reported: Vec<ErrorCode>,
}

impl std::fmt::Debug for Local<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Local")
            .field("source", &self.source.name())
            .finish_non_exhaustive()
    }
}

impl<'a> Local<'a> {
    /// Drives `service` with frames from `source`; the service's first messages (its
    /// `Hello`, the LED ring lit) are its identity.
    pub fn new(mut service: Service<'a, SystemClock>, source: Box<dyn FrameSource>) -> Local<'a> {
        let _ = service.start();
        Local {
            service,
            source,
            reported: Vec::new(),
        }
    }

    /// Says a report of the device's state on stderr, the first of its kind only.
    fn report(&mut self, code: ErrorCode, detail: &str) {
        if !self.reported.contains(&code) {
            self.reported.push(code);
            eprintln!("vistaf-skin: {code:?}: {detail} (the session goes on)");
        }
    }

    /// Sends `cmd` and feeds frames (or waits, when `frames` is false) until `want` takes a
    /// message, a device error comes, or `timeout` passes.
    fn ask<T>(
        &mut self,
        cmd: HostMsg,
        timeout: Duration,
        frames: bool,
        mut want: impl FnMut(&DeviceMsg) -> Option<T>,
    ) -> Result<T, KitError> {
        let deadline = Instant::now() + timeout;
        let mut pending = vec![self.service.on_command(cmd)];
        loop {
            for msg in pending.drain(..) {
                match &msg {
                    // The device's own state (a new unit's reference that the calibration
                    // in use cannot take): said, not an answer.
                    DeviceMsg::Error(e) if e.code.is_report() => {
                        self.report(e.code, &e.detail);
                        continue;
                    }
                    DeviceMsg::Error(e) => return Err(e.into()),
                    _ => {}
                }
                if let Some(t) = want(&msg) {
                    return Ok(t);
                }
            }
            if Instant::now() >= deadline {
                return Err(KitError::Failed(
                    format!("no answer from the service within {timeout:?}").into(),
                ));
            }
            pending.extend(self.service.on_background());
            if frames {
                pending.extend(self.next_frame()?);
            } else {
                std::thread::sleep(FIT_POLL);
            }
        }
    }

    /// The service's messages for the source's next frame.
    fn next_frame(&mut self) -> Result<Vec<DeviceMsg>, KitError> {
        match self.source.next_frame() {
            Ok(Some(frame)) => Ok(self.service.on_frame(frame)),
            Ok(None) => Err(KitError::Failed(
                format!("{}: the source ended", self.source.name()).into(),
            )),
            Err(e) => Err(KitError::Failed(
                format!("{}: {e}", self.source.name()).into(),
            )),
        }
    }
}

impl Drop for Local<'_> {
    /// The ring goes dark, as when the service stops.
    fn drop(&mut self) {
        let _ = self.service.finish();
    }
}

impl KitDevice for Local<'_> {
    fn pause(&mut self) -> Result<(), KitError> {
        self.ask(HostMsg::Stop, Duration::ZERO, false, |m| {
            matches!(m, DeviceMsg::Ack(_)).then_some(())
        })
    }

    fn resume(&mut self) -> Result<(), KitError> {
        self.ask(HostMsg::Start, Duration::ZERO, false, |m| {
            matches!(m, DeviceMsg::Ack(_)).then_some(())
        })
    }

    fn capture(&mut self, step: KitStep, timeout: Duration) -> Result<KitCaptured, KitError> {
        self.ask(
            HostMsg::KitCapture(step),
            timeout,
            true,
            answer::captured(step),
        )
    }

    fn fit(&mut self, timeout: Duration) -> Result<(Vec<KitVerdict>, CalibrationFitted), KitError> {
        let mut verdicts = Vec::new();
        let fitted = self.ask(
            HostMsg::KitFit,
            timeout,
            false,
            answer::fitted(&mut verdicts),
        )?;
        Ok((verdicts, fitted))
    }

    fn activate(&mut self, calibration_id: u32, timeout: Duration) -> Result<Hello, KitError> {
        self.ask(
            HostMsg::CalibrationActivate { calibration_id },
            timeout,
            false,
            answer::activated(calibration_id),
        )
    }
}
