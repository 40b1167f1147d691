//! A guided calibration: the host walks a person (or a script) through the kit, and the
//! device captures, keeps, fits and activates it.
//!
//! ```text
//!  plan ─▶ for each step: say what to set (or run the heater command) ─▶ KitCapture
//!            device: bench set if software drives it, image settles, frame kept
//!        ─▶ KitFit ─▶ verdict per model against its target ─▶ CalibrationActivate
//! ```
//!
//! The [`Plan`] lists the setpoints (the defaults are the kit of `docs/calibration.md`);
//! a [`Guide`] asks a person at a terminal ([`Terminal`]) or answers by itself
//! ([`Scripted`], the `--plan` mode). A press step's value can be corrected by typing the
//! reading of a load cell or depth gauge, or read from the load cell's indicator over a
//! serial port ([`WithScale`], `scale` in the plan); a temperature step can run a heater
//! command and waits for the colour to settle on the device, retrying while it has not.

use std::io::{BufRead, Write};
use std::path::Path;
use std::time::Duration;

use serde::Deserialize;
use vistaf_protocol::{CalibrationFitted, Hello, KitQuantity, KitStep, KitVerdict};

use crate::client::Client;
use crate::error::HostError;
use crate::record::{calibration_id_text, kit_quantity_si};

/// Depths of the default kit, mm.
pub const DEFAULT_DEPTHS_MM: [f64; 12] = [
    0.1, 0.2, 0.35, 0.5, 0.75, 1.0, 1.25, 1.5, 1.75, 2.0, 2.25, 2.5,
];
/// Forces of the default kit, N.
pub const DEFAULT_FORCES_N: [f64; 12] = [
    0.5, 1.0, 2.0, 3.0, 4.0, 6.0, 8.0, 10.0, 15.0, 20.0, 25.0, 30.0,
];
/// Temperatures of the default kit, °C: dense in the pigment's colour transition.
pub const DEFAULT_TEMPERATURES_C: [f64; 22] = [
    15.0, 17.5, 20.0, 22.0, 23.0, 24.0, 25.0, 26.0, 27.0, 28.0, 29.0, 30.0, 31.0, 32.0, 33.0, 34.0,
    35.0, 37.5, 40.0, 42.5, 45.0, 47.5,
];

/// When the fitted calibration is put in use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Activate {
    /// When every model meets its target.
    Pass,
    /// Whatever the verdicts.
    Always,
    /// Never (the candidate stays on the device until the next fit).
    Never,
}

/// A calibration session's steps and settings (`plan.toml`). Every key is optional.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Plan {
    /// Temperature of the untouched skin at the start, °C.
    pub reference_temperature_c: f64,
    /// Depths the sphere is pressed to, mm.
    pub depths_mm: Vec<f64>,
    /// Forces the sphere is pressed with, N.
    pub forces_n: Vec<f64>,
    /// Uniform skin temperatures, °C.
    pub temperatures_c: Vec<f64>,
    /// Frames per setpoint (presses alternate between two places on the skin).
    pub repeats: u32,
    /// A command run before each temperature step, `{c}` replaced by the setpoint in °C
    /// (for example a script that sets a heater and returns once it holds).
    pub heater: Option<String>,
    /// How long a step may take to settle, s: the device gives up on one attempt after
    /// `KIT_SETTLE_TIMEOUT_MS`, and the step is asked for again until this has passed.
    pub settle_timeout_s: f64,
    /// When to activate the fit.
    pub activate: Activate,
    /// The load cell's indicator, streaming readings on a serial port (`serial:PATH@BAUD`,
    /// or a path at 9600 baud): each force step's value is its reading once the step is set.
    pub scale: Option<String>,
}

impl Default for Plan {
    fn default() -> Plan {
        Plan {
            reference_temperature_c: 25.0,
            depths_mm: DEFAULT_DEPTHS_MM.to_vec(),
            forces_n: DEFAULT_FORCES_N.to_vec(),
            temperatures_c: DEFAULT_TEMPERATURES_C.to_vec(),
            repeats: 2,
            heater: None,
            settle_timeout_s: 120.0,
            activate: Activate::Pass,
            scale: None,
        }
    }
}

impl Plan {
    /// Reads a plan file; errors name the file and the key.
    pub fn load(path: &Path) -> Result<Plan, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let plan: Plan = toml::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
        plan.check()
            .map_err(|e| format!("{}: {e}", path.display()))?;
        Ok(plan)
    }

    /// Refuses setpoints no kit can have.
    pub fn check(&self) -> Result<(), String> {
        let within = |key: &str, v: &[f64], lo: f64, hi: f64| match v
            .iter()
            .find(|x| !(x.is_finite() && (lo..=hi).contains(*x)))
        {
            Some(x) => Err(format!("key `{key}`: {x} is outside {lo}…{hi}")),
            None => Ok(()),
        };
        within("depths_mm", &self.depths_mm, 0.01, 10.0)?;
        within("forces_n", &self.forces_n, 0.01, 500.0)?;
        within("temperatures_c", &self.temperatures_c, -20.0, 80.0)?;
        within(
            "reference_temperature_c",
            &[self.reference_temperature_c],
            -20.0,
            80.0,
        )?;
        if self.repeats == 0 {
            return Err("key `repeats`: at least 1".into());
        }
        if self.depths_mm.is_empty() {
            return Err("key `depths_mm`: phase → depth needs depth presses".into());
        }
        Ok(())
    }

    /// Every step, in order: the reference, then depths, forces and temperatures.
    pub fn steps(&self) -> Vec<KitStep> {
        let milli = |v: f64| (v * 1000.0).round() as i32;
        let step = |quantity, v| KitStep {
            quantity,
            value_milli: milli(v),
        };
        let r = self.repeats as usize;
        let mut out = vec![step(KitQuantity::Reference, self.reference_temperature_c)];
        for (q, values) in [
            (KitQuantity::Depth, &self.depths_mm),
            (KitQuantity::Force, &self.forces_n),
            (KitQuantity::Temperature, &self.temperatures_c),
        ] {
            out.extend(
                values
                    .iter()
                    .flat_map(|&v| std::iter::repeat_n(step(q, v), r)),
            );
        }
        out
    }
}

/// What a person answers to a step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Answer {
    /// Set as asked: capture with the planned value.
    Ready,
    /// Set, but the reading differs: capture with this value (mm, N or °C).
    Measured(f64),
    /// Leave this step out.
    Skip,
    /// End the session without fitting.
    Quit,
}

/// Who sets each step and is told how it went.
pub trait Guide {
    /// Asks for `step` (`n` of `total`); the answer.
    fn ask(&mut self, step: &KitStep, n: usize, total: usize) -> Answer;
    /// Tells something.
    fn say(&mut self, text: &str);
}

impl<G: Guide + ?Sized> Guide for Box<G> {
    fn ask(&mut self, step: &KitStep, n: usize, total: usize) -> Answer {
        (**self).ask(step, n, total)
    }

    fn say(&mut self, text: &str) {
        (**self).say(text);
    }
}

/// A person at a terminal: each step asked for, Enter to capture.
#[derive(Debug)]
pub struct Terminal<R: BufRead, W: Write> {
    input: R,
    out: W,
}

impl<R: BufRead, W: Write> Terminal<R, W> {
    /// Reads answers from `input`, writes prompts to `out`.
    pub fn new(input: R, out: W) -> Terminal<R, W> {
        Terminal { input, out }
    }
}

/// What to do for a step, in words.
pub fn instruction(step: &KitStep) -> String {
    let v = f64::from(step.value_milli) / 1000.0;
    match step.quantity {
        KitQuantity::Reference => {
            format!("leave the skin untouched at {v:.1} °C (the kit's reference)")
        }
        KitQuantity::Depth => format!("press the 10 mm sphere to {v:.2} mm"),
        KitQuantity::Force => format!("press the 10 mm sphere until the load cell reads {v:.1} N"),
        KitQuantity::Temperature => {
            format!("bring the untouched skin to {v:.1} °C and let it settle")
        }
    }
}

impl<R: BufRead, W: Write> Guide for Terminal<R, W> {
    fn ask(&mut self, step: &KitStep, n: usize, total: usize) -> Answer {
        let (_, unit, _) = kit_quantity_si(step.quantity);
        loop {
            let _ = write!(
                self.out,
                "[{n}/{total}] {}, then Enter (or type the reading in {unit}; s skips, q quits): ",
                instruction(step)
            );
            let _ = self.out.flush();
            let mut line = String::new();
            match self.input.read_line(&mut line) {
                Ok(0) | Err(_) => return Answer::Quit,
                Ok(_) => {}
            }
            match line.trim() {
                "" => return Answer::Ready,
                "s" => return Answer::Skip,
                "q" => return Answer::Quit,
                t => match t.parse::<f64>() {
                    Ok(v) if v.is_finite() => return Answer::Measured(v),
                    _ => {
                        let _ = writeln!(self.out, "  {t:?}: a number in {unit}, s or q");
                    }
                },
            }
        }
    }

    fn say(&mut self, text: &str) {
        let _ = writeln!(self.out, "{text}");
    }
}

/// The `--plan` mode: every step taken as planned (the bench is driven by the device or
/// the heater command), progress written to `out`.
#[derive(Debug)]
pub struct Scripted<W: Write> {
    out: W,
}

impl<W: Write> Scripted<W> {
    /// Writes progress to `out`.
    pub fn new(out: W) -> Scripted<W> {
        Scripted { out }
    }
}

impl<W: Write> Guide for Scripted<W> {
    fn ask(&mut self, step: &KitStep, n: usize, total: usize) -> Answer {
        let _ = writeln!(self.out, "[{n}/{total}] {}", instruction(step));
        Answer::Ready
    }

    fn say(&mut self, text: &str) {
        let _ = writeln!(self.out, "{text}");
    }
}

/// A guide whose force steps take their value from a scale: when the step is set as asked,
/// the scale is read and its reading is the step's value (a reading typed in still wins).
pub struct WithScale<G: Guide> {
    inner: G,
    scale: Box<dyn crate::scale::Scale>,
}

impl<G: Guide> std::fmt::Debug for WithScale<G> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WithScale").finish_non_exhaustive()
    }
}

impl<G: Guide> WithScale<G> {
    /// Asks through `inner`, reading `scale` for force steps.
    pub fn new(inner: G, scale: Box<dyn crate::scale::Scale>) -> WithScale<G> {
        WithScale { inner, scale }
    }
}

/// Attempts at reading the scale before a session ends.
const SCALE_ATTEMPTS: usize = 3;

impl<G: Guide> Guide for WithScale<G> {
    fn ask(&mut self, step: &KitStep, n: usize, total: usize) -> Answer {
        for _ in 0..SCALE_ATTEMPTS {
            let answer = self.inner.ask(step, n, total);
            if step.quantity != KitQuantity::Force || answer != Answer::Ready {
                return answer;
            }
            match self.scale.read_n() {
                Ok(force_n) => {
                    self.inner.say(&format!("  the scale reads {force_n:.3} N"));
                    return Answer::Measured(force_n);
                }
                Err(e) => self.inner.say(&format!("  {e}")),
            }
        }
        self.inner
            .say("the scale gave no reading: ending the session (the frames so far are kept)");
        Answer::Quit
    }

    fn say(&mut self, text: &str) {
        self.inner.say(text);
    }
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
    Host(#[from] HostError),
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
const DEVICE_SETTLE: Duration =
    Duration::from_millis(vistaf_protocol::msg::KIT_SETTLE_TIMEOUT_MS as u64 + 2_000);

/// Runs a guided calibration on `client` by `plan`, asking `guide`.
pub fn run(
    client: &mut Client,
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
    // Summaries would only crowd the link: paused for the session, resumed at its end.
    client.stop(crate::client::DEFAULT_TIMEOUT)?;
    let result = capture_all(client, plan, guide, &steps, &mut out);
    let resumed = client.start(crate::client::DEFAULT_TIMEOUT);
    result?;
    resumed?;
    guide.say("fitting the kit on the device…");
    let (verdicts, fitted) = client.kit_fit(FIT_TIMEOUT)?;
    guide.say(&verdict_text(&verdicts, &fitted));
    out.verdicts = verdicts;
    out.fitted = Some(fitted);
    let activate = match plan.activate {
        Activate::Always => true,
        Activate::Pass => fitted.pass,
        Activate::Never => false,
    };
    if activate {
        let hello =
            client.activate_calibration(fitted.calibration_id, crate::client::DEFAULT_TIMEOUT)?;
        guide.say(&format!(
            "activated calibration {} on {} (the previous one is kept: `vistaf-host rollback`)",
            calibration_id_text(hello.calibration_id),
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
    client: &mut Client,
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
        let c = capture_settled(client, plan, step)?;
        let (name, unit, k) = kit_quantity_si(step.quantity);
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
    client: &mut Client,
    plan: &Plan,
    step: KitStep,
) -> Result<vistaf_protocol::KitCaptured, SessionError> {
    let deadline =
        std::time::Instant::now() + Duration::from_secs_f64(plan.settle_timeout_s.max(1.0));
    loop {
        match client.kit_capture(step, DEVICE_SETTLE) {
            Ok(c) => return Ok(c),
            Err(HostError::Device { error, .. })
                if error.code == vistaf_protocol::ErrorCode::NotSettled
                    && std::time::Instant::now() < deadline => {}
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
        let (name, unit, k) = kit_quantity_si(v.quantity);
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
        calibration_id_text(fitted.calibration_id),
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

    #[test]
    fn the_default_plan_is_the_documented_kit() {
        let p = Plan::default();
        p.check().unwrap();
        let steps = p.steps();
        assert_eq!(steps.len(), 1 + 2 * (12 + 12 + 22));
        assert_eq!(steps[0].quantity, KitQuantity::Reference);
        assert_eq!(steps[1].value_milli, 100);
        assert_eq!(steps[2].value_milli, 100);
    }

    /// The plan `docs/calibration.md` shows, with every key, is one this code reads.
    #[test]
    fn the_documented_plan_reads() {
        let doc = include_str!("../../docs/calibration.md");
        let toml = doc
            .split("```toml\n")
            .nth(1)
            .and_then(|b| b.split("```").next())
            .unwrap();
        let plan: Plan = toml::from_str(toml).unwrap();
        plan.check().unwrap();
        assert_eq!(
            plan,
            Plan {
                heater: plan.heater.clone(),
                scale: plan.scale.clone(),
                ..Plan::default()
            },
            "the other keys are the defaults"
        );
        assert_eq!(plan.scale.as_deref(), Some("serial:/dev/ttyUSB0@9600"));
    }

    #[test]
    fn a_plan_file_with_a_bad_key_or_value_is_refused_by_name() {
        let bad: Result<Plan, _> = toml::from_str("depth_mm = [1.0]");
        assert!(bad.unwrap_err().to_string().contains("depth_mm"));
        let p: Plan = toml::from_str("forces_n = [1.0, -2.0]").unwrap();
        let e = p.check().unwrap_err();
        assert!(e.contains("forces_n") && e.contains("-2"), "{e}");
    }

    /// A step whose image did not settle is asked for again, until it is captured; any
    /// other device error ends the session.
    #[test]
    fn a_step_that_did_not_settle_is_asked_for_again() {
        use vistaf_protocol::{DeviceError, DeviceMsg, ErrorCode, KitCaptured};
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
        let captured = DeviceMsg::KitCaptured(KitCaptured {
            step,
            frames: 1,
            settle_ms: 31_000,
            change_centi_dn: 80,
        });
        let client = |msgs: &[DeviceMsg]| {
            let mut bytes = Vec::new();
            for m in msgs {
                let mut buf = [0u8; vistaf_protocol::frame::DEVICE_FRAME_MAX];
                let n = vistaf_protocol::encode(m, &mut buf).unwrap();
                bytes.extend(&buf[..n]);
            }
            let link =
                crate::link::Link::new("test".into(), std::io::Cursor::new(bytes), Vec::new());
            Client::new(link)
        };
        let plan = Plan::default();
        let mut c = client(&[error(ErrorCode::NotSettled), captured.clone()]);
        let got = capture_settled(&mut c, &plan, step).unwrap();
        assert_eq!(got.settle_ms, 31_000);
        let mut c = client(&[error(ErrorCode::Calibration), captured]);
        assert!(capture_settled(&mut c, &plan, step).is_err());
    }

    /// A scale that reads what it is given, then fails.
    struct Readings(Vec<f64>);

    impl crate::scale::Scale for Readings {
        fn read_n(&mut self) -> Result<f64, String> {
            self.0
                .pop()
                .ok_or_else(|| "scale /dev/null: 0 readings".to_string())
        }
    }

    #[test]
    fn a_force_step_takes_the_scale_reading_and_other_steps_do_not() {
        let step = |quantity, value_milli| KitStep {
            quantity,
            value_milli,
        };
        let mut out = Vec::new();
        let mut g = WithScale::new(Scripted::new(&mut out), Box::new(Readings(vec![6.02])));
        let depth = step(KitQuantity::Depth, 500);
        let force = step(KitQuantity::Force, 6_000);
        assert_eq!(g.ask(&depth, 1, 3), Answer::Ready);
        assert_eq!(g.ask(&force, 2, 3), Answer::Measured(6.02));
        assert_eq!(g.ask(&force, 3, 3), Answer::Quit, "no reading, three times");
        let text = String::from_utf8(out).unwrap();
        assert!(text.contains("the scale reads 6.020 N"), "{text}");
        assert_eq!(text.matches("0 readings").count(), SCALE_ATTEMPTS);
        // A typed reading wins over the scale.
        let mut g = WithScale::new(
            Terminal::new(&b"5.9\n"[..], Vec::new()),
            Box::new(Readings(vec![6.02])),
        );
        assert_eq!(g.ask(&force, 1, 1), Answer::Measured(5.9));
    }

    #[test]
    fn a_terminal_takes_enter_a_reading_skip_and_quit() {
        let input = b"\n0.52\nnope\ns\nq\n";
        let mut out = Vec::new();
        let mut t = Terminal::new(&input[..], &mut out);
        let step = KitStep {
            quantity: KitQuantity::Depth,
            value_milli: 500,
        };
        assert_eq!(t.ask(&step, 1, 3), Answer::Ready);
        assert_eq!(t.ask(&step, 2, 3), Answer::Measured(0.52));
        assert_eq!(t.ask(&step, 3, 3), Answer::Skip);
        assert_eq!(t.ask(&step, 3, 3), Answer::Quit);
        assert_eq!(t.ask(&step, 3, 3), Answer::Quit, "end of input quits");
        let text = String::from_utf8(out).unwrap();
        assert!(text.contains("press the 10 mm sphere to 0.50 mm") && text.contains("\"nope\""));
    }
}
