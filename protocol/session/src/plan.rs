//! A calibration session's steps and settings (`plan.toml`): the kit of
//! `docs/calibration.md` by default, every key optional.

use std::path::Path;

use serde::Deserialize;
use vistaf_protocol::{KitQuantity, KitStep};

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
        let doc = include_str!("../../../docs/calibration.md");
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
}
