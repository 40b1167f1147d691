//! The session: every step asked for and captured once its image settles, the kit fitted
//! on the device, its verdicts said, and the fit activated when the plan says so.

use std::time::{Duration, Instant};

use vistaf_protocol::{
    CalibrationFitted, CalibrationId, Hello, KitCaptured, KitQuantity, KitStep, KitVerdict,
};

use crate::guide::{Answer, Guide};
use crate::plan::{Activate, Plan};

/// What a session asks of the device: the host's client over a link, or the board's
/// service in the same process.
pub trait KitDevice {
    /// Stops the summaries for the session (they would only crowd the link).
    fn pause(&mut self) -> Result<(), KitError>;
    /// Streams summaries again.
    fn resume(&mut self) -> Result<(), KitError>;
    /// Sets the bench to `step` when software drives it, and captures its frame once the
    /// image has settled, waiting up to `timeout`.
    fn capture(&mut self, step: KitStep, timeout: Duration) -> Result<KitCaptured, KitError>;
    /// Fits the kit captured so far: the verdict per model, then the candidate.
    fn fit(&mut self, timeout: Duration) -> Result<(Vec<KitVerdict>, CalibrationFitted), KitError>;
    /// Puts the fitted candidate `calibration_id` in use; the device's identity after.
    fn activate(&mut self, calibration_id: u32, timeout: Duration) -> Result<Hello, KitError>;
}

/// Why the device did not do what a step asked.
#[derive(Debug, thiserror::Error)]
pub enum KitError {
    /// The image did not settle in the device's time: the step is asked for again.
    #[error("{0}")]
    NotSettled(String),
    /// Anything else (the link, the camera, the device's refusal): the session ends.
    #[error(transparent)]
    Failed(Box<dyn std::error::Error + Send + Sync>),
}

/// How a session ended.
#[derive(Debug, Clone, PartialEq)]
pub struct Outcome {
    /// Frames captured per quantity: reference, depth, force, temperature.
    pub captured: [usize; 4],
    /// The fitted models' verdicts.
    pub verdicts: Vec<KitVerdict>,
    /// The fitted candidate.
    pub fitted: Option<CalibrationFitted>,
    /// The device's identity after activation, when the fit was activated.
    pub activated: Option<Hello>,
}

/// What can end a session early.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// The link or the device.
    #[error(transparent)]
    Device(#[from] KitError),
    /// The person quit.
    #[error(
        "calibration ended at step {0} without a fit; the frames so far are kept on the device"
    )]
    Quit(usize),
    /// The heater command failed.
    #[error("heater command {command:?}: {detail}")]
    Heater {
        /// The command run.
        command: String,
        /// Why it failed.
        detail: String,
    },
}

/// Longest a fit may take on the device.
pub const FIT_TIMEOUT: Duration = Duration::from_secs(900);
/// How long one capture is waited for: the device's own limit on settling, and a margin
/// for the link.
pub const DEVICE_SETTLE: Duration =
    Duration::from_millis(vistaf_protocol::msg::KIT_SETTLE_TIMEOUT_MS as u64 + 2_000);
/// How long a command other than a capture or a fit is waited for.
pub const COMMAND_TIMEOUT: Duration = Duration::from_secs(5);

/// Runs a guided calibration on `device` by `plan`, asking `guide`.
pub fn run(
    device: &mut dyn KitDevice,
    plan: &Plan,
    guide: &mut dyn Guide,
) -> Result<Outcome, SessionError> {
    let steps = plan.steps();
    let mut out = Outcome {
        captured: [0; 4],
        verdicts: Vec::new(),
        fitted: None,
        activated: None,
    };
    device.pause()?;
    let result = capture_all(device, plan, guide, &steps, &mut out);
    let resumed = device.resume();
    result?;
    resumed?;
    guide.say("fitting the kit on the device…");
    let (verdicts, fitted) = device.fit(FIT_TIMEOUT)?;
    guide.say(&verdict_text(&verdicts, &fitted));
    out.verdicts = verdicts;
    out.fitted = Some(fitted);
    let activate = match plan.activate {
        Activate::Always => true,
        Activate::Pass => fitted.pass,
        Activate::Never => false,
    };
    if activate {
        let hello = device.activate(fitted.calibration_id, COMMAND_TIMEOUT)?;
        guide.say(&format!(
            "activated calibration {} on {} (the one it replaced is kept for a rollback)",
            CalibrationId(hello.calibration_id),
            hello.serial
        ));
        out.activated = Some(hello);
    } else {
        guide.say(&format!(
            "not activated (--activate {}); the candidate stays on the device",
            match plan.activate {
                Activate::Never => "never",
                _ => "pass: a model missed its target",
            }
        ));
    }
    Ok(out)
}

/// Asks for and captures every step.
fn capture_all(
    device: &mut dyn KitDevice,
    plan: &Plan,
    guide: &mut dyn Guide,
    steps: &[KitStep],
    out: &mut Outcome,
) -> Result<(), SessionError> {
    for (i, planned) in steps.iter().enumerate() {
        let mut step = *planned;
        match guide.ask(&step, i + 1, steps.len()) {
            Answer::Ready => {}
            Answer::Measured(v) => step.value_milli = (v * 1000.0).round() as i32,
            Answer::Skip => continue,
            Answer::Quit => return Err(SessionError::Quit(i + 1)),
        }
        if step.quantity == KitQuantity::Temperature {
            if let Some(cmd) = &plan.heater {
                heat(cmd, f64::from(step.value_milli) / 1000.0)?;
            }
        }
        let c = capture_settled(device, plan, step)?;
        let (name, unit, k) = step.quantity.si();
        guide.say(&format!(
            "  captured {name} {:.3} {unit} (settled in {:.1} s, change {:.2} DN)",
            f64::from(step.value_milli) * k,
            f64::from(c.settle_ms) / 1000.0,
            f64::from(c.change_centi_dn) / 100.0
        ));
        out.captured[step.quantity as usize] += 1;
    }
    Ok(())
}

/// Captures `step`, asking again while the image has not settled, up to the plan's
/// settling time.
fn capture_settled(
    device: &mut dyn KitDevice,
    plan: &Plan,
    step: KitStep,
) -> Result<KitCaptured, SessionError> {
    let deadline = Instant::now() + Duration::from_secs_f64(plan.settle_timeout_s.max(1.0));
    loop {
        match device.capture(step, DEVICE_SETTLE) {
            Ok(c) => return Ok(c),
            Err(KitError::NotSettled(_)) if Instant::now() < deadline => {}
            Err(e) => return Err(e.into()),
        }
    }
}

/// Runs the heater command for `temp_c`.
fn heat(cmd: &str, temp_c: f64) -> Result<(), SessionError> {
    let command = cmd.replace("{c}", &format!("{temp_c}"));
    let status = std::process::Command::new("sh")
        .arg("-c")
        .arg(&command)
        .status()
        .map_err(|e| SessionError::Heater {
            command: command.clone(),
            detail: e.to_string(),
        })?;
    if !status.success() {
        return Err(SessionError::Heater {
            command,
            detail: status.to_string(),
        });
    }
    Ok(())
}

/// The verdicts as a table, with the fitted id and the overall verdict.
pub fn verdict_text(verdicts: &[KitVerdict], fitted: &CalibrationFitted) -> String {
    let mut s = String::from("model         samples   held-out RMSE        target   verdict\n");
    for v in verdicts {
        let (name, unit, k) = v.quantity.si();
        s.push_str(&format!(
            "{name:<13} {:>7}   {:>9.4} {unit:<3}   ≤ {:>6.3} {unit:<3}   {}\n",
            v.samples,
            f64::from(v.error_milli) * k,
            f64::from(v.target_milli) * k,
            if v.pass { "pass" } else { "FAIL" }
        ));
    }
    s.push_str(&format!(
        "calibration {}: {}",
        CalibrationId(fitted.calibration_id),
        if fitted.pass {
            "every model meets its target"
        } else {
            "a model misses its target"
        }
    ));
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A device whose captures answer from a list, in order.
    struct Answers(Vec<Result<KitCaptured, KitError>>);

    impl KitDevice for Answers {
        fn pause(&mut self) -> Result<(), KitError> {
            Ok(())
        }
        fn resume(&mut self) -> Result<(), KitError> {
            Ok(())
        }
        fn capture(&mut self, _: KitStep, _: Duration) -> Result<KitCaptured, KitError> {
            self.0.remove(0)
        }
        fn fit(&mut self, _: Duration) -> Result<(Vec<KitVerdict>, CalibrationFitted), KitError> {
            Err(KitError::Failed("no fit here".into()))
        }
        fn activate(&mut self, _: u32, _: Duration) -> Result<Hello, KitError> {
            Err(KitError::Failed("no fit here".into()))
        }
    }

    /// A step whose image did not settle is asked for again, until it is captured; any
    /// other device error ends the session.
    #[test]
    fn a_step_that_did_not_settle_is_asked_for_again() {
        let step = KitStep {
            quantity: KitQuantity::Temperature,
            value_milli: 30_000,
        };
        let captured = || {
            Ok(KitCaptured {
                step,
                frames: 1,
                settle_ms: 31_000,
                change_centi_dn: 80,
            })
        };
        let not_settled = || Err(KitError::NotSettled("the image did not settle".into()));
        let plan = Plan::default();
        let mut d = Answers(vec![not_settled(), not_settled(), captured()]);
        let got = capture_settled(&mut d, &plan, step).unwrap();
        assert_eq!(got.settle_ms, 31_000);
        let mut d = Answers(vec![
            Err(KitError::Failed("camera lost".into())),
            captured(),
        ]);
        assert!(capture_settled(&mut d, &plan, step).is_err());
    }
}
