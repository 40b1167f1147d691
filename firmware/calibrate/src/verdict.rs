//! Whether a fitted calibration is good enough: each model's held-out error against the
//! product's target, so a calibration that misses one says so instead of passing silently.
//!
//! The targets are the product's accuracy targets on the calibrated sphere: peak depth
//! RMSE 0.02 mm, force RMSE 0.3 N, and skin temperature RMSE 0.3 °C within 22–32 °C, where
//! the thermochromic transition gives the most colour per degree. The errors are the fits'
//! cross-validated ones (leave one setpoint out), the best estimate of what a new press
//! will show.

use vistaf_pipeline::calibration::{Calibration, DepthError};
use vistaf_pipeline::measure::{
    depth_error, depths_doubted_mm, DEPTH_CONFIDENCE_SIGMAS, DEPTH_TOLERANCE_SHARE,
    DEPTH_TOLERANCE_UM,
};

/// Depth target, mm.
pub const DEPTH_TARGET_MM: f64 = 0.02;
/// Force target, N.
pub const FORCE_TARGET_N: f64 = 0.3;
/// Temperature target within 22–32 °C, °C.
pub const TEMPERATURE_TARGET_C: f64 = 0.3;

/// Which fitted model a verdict is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Model {
    /// Phase → depth, mm.
    Depth,
    /// Deformation → force, N.
    Force,
    /// Colour → temperature, °C.
    Temperature,
}

impl Model {
    /// The model's name and its unit.
    pub fn name_unit(self) -> (&'static str, &'static str) {
        match self {
            Model::Depth => ("depth", "mm"),
            Model::Force => ("force", "N"),
            Model::Temperature => ("temperature (22–32 °C)", "°C"),
        }
    }
}

/// One model's held-out error against its target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Verdict {
    /// The model.
    pub model: Model,
    /// Samples fitted.
    pub n: usize,
    /// Cross-validated RMSE, in the model's unit.
    pub error: f64,
    /// The target, same unit.
    pub target: f64,
    /// For depth: how far a press where the kit never pressed may read off, a share of the
    /// depth ([`Calibration::depth_place_spread`]).
    pub place_spread: Option<f64>,
    /// For depth: the held-out error by depth ([`Calibration::depth_error`]).
    pub depth_error: Option<DepthError>,
}

impl Verdict {
    /// Whether the error is within the target.
    pub fn pass(&self) -> bool {
        self.error <= self.target
    }
}

/// A verdict per model the calibration has.
pub fn verdicts(c: &Calibration) -> Vec<Verdict> {
    let mut v = vec![Verdict {
        model: Model::Depth,
        n: c.depth.n,
        error: c.depth.cv_rmse,
        target: DEPTH_TARGET_MM,
        place_spread: c.depth_place_spread,
        depth_error: Some(depth_error(c)),
    }];
    if let Some(f) = &c.force {
        v.push(Verdict {
            model: Model::Force,
            n: f.n,
            error: f.cv_rmse,
            target: FORCE_TARGET_N,
            place_spread: None,
            depth_error: None,
        });
    }
    if let Some(t) = &c.temperature {
        v.push(Verdict {
            model: Model::Temperature,
            n: t.n,
            error: t.cv_rmse_transition_c,
            target: TEMPERATURE_TARGET_C,
            place_spread: None,
            depth_error: None,
        });
    }
    v
}

/// The verdicts as lines a person reads, and whether all passed.
pub fn report(verdicts: &[Verdict]) -> (String, bool) {
    let mut text = String::new();
    for v in verdicts {
        let (name, unit) = v.model.name_unit();
        let mark = if v.pass() { "pass" } else { "FAIL" };
        text.push_str(&format!(
            "  {name:<24} held-out RMSE {:>8.4} {unit}  target ≤ {} {unit}  {mark}\n",
            v.error, v.target
        ));
        if let Some(e) = v.depth_error {
            text.push_str(&depth_error_lines(e, v.place_spread));
        }
    }
    (text, verdicts.iter().all(Verdict::pass))
}

/// The depth model's held-out error by depth, how far the kit's places read apart where
/// that changes which depths are flagged, and the depths the two flag, as lines (the error
/// [`vistaf_pipeline::measure::reading_error`] expects of a reading).
fn depth_error_lines(held_out: DepthError, place_spread: Option<f64>) -> String {
    let mut text = format!(
        "  {:<24} held-out error by depth √({:.4}² + ({:.2} % · depth)²) mm\n",
        "",
        held_out.floor_mm,
        100.0 * held_out.share
    );
    let expected = held_out.with_place_spread(place_spread);
    let doubted = depths_doubted_mm(expected);
    if doubted != depths_doubted_mm(held_out) {
        text.push_str(&format!(
            "  {:<24} a press where the kit never pressed may read {:.1} % off (standard \
             deviation, from how far the kit's places read apart): a reading's error takes \
             that share of its depth, √({:.4}² + ({:.1} % · depth)²) mm\n",
            "",
            100.0 * expected.share,
            expected.floor_mm,
            100.0 * expected.share,
        ));
    }
    let range = match doubted {
        (u, _) if u.is_infinite() => Some("every peak depth".to_string()),
        (u, Some(o)) if u > 0.0 => Some(format!("peak depths under {u:.2} mm and over {o:.2} mm")),
        (u, None) if u > 0.0 => Some(format!("peak depths under {u:.2} mm")),
        (_, Some(o)) => Some(format!("peak depths over {o:.2} mm")),
        _ => None,
    };
    if let Some(range) = range {
        text.push_str(&format!(
            "  {:<24} {range} will carry depth_uncertain: the depth tolerance ({} % + {} mm) \
             is less than {DEPTH_CONFIDENCE_SIGMAS} times this error there\n",
            "",
            100.0 * DEPTH_TOLERANCE_SHARE,
            DEPTH_TOLERANCE_UM / 1000.0,
        ));
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_model_over_its_target_fails_and_the_report_says_so() {
        let mut c = Calibration::default_sim();
        let all = verdicts(&c);
        assert_eq!(
            all.len(),
            3,
            "the reference calibration has all three models"
        );
        if let Some(t) = c.temperature.as_mut() {
            t.cv_rmse_transition_c = 0.338;
        }
        let v = verdicts(&c);
        let t = v.iter().find(|v| v.model == Model::Temperature).unwrap();
        assert!(!t.pass());
        let (text, pass) = report(&v);
        assert!(
            !pass && text.contains("FAIL") && text.contains("0.3380"),
            "{text}"
        );
    }

    /// A depth model that missed its kit's presses by 0.03 mm, in a file without the error
    /// by depth, says from which depth down its readings will be flagged: where 3 % of the
    /// depth + 0.02 mm is under 0.06 mm.
    #[test]
    fn a_depth_model_over_its_target_says_which_depths_it_cannot_hold() {
        let mut c = Calibration::default_sim();
        let (text, _) = report(&verdicts(&c));
        assert!(!text.contains("depth_uncertain"), "{text}");
        (c.depth_error, c.depth_place_spread) = (None, None);
        c.depth.cv_rmse = 0.03;
        let (text, pass) = report(&verdicts(&c));
        assert!(
            !pass && text.contains("under 1.33 mm will carry depth_uncertain"),
            "{text}"
        );
    }

    /// A held-out error by depth names the depths it doubts: deep ones where it grows with
    /// the depth (a floor of 0.004 mm and 2.2 %: `2·√(0.004² + (0.022·d)²)` passes
    /// `0.02 + 0.03·d` at 1.39 mm), both ends where its floor is high too (0.012 mm and
    /// 2 %: under 0.16 mm and over 1.55 mm).
    #[test]
    fn a_depth_error_by_depth_says_which_depths_it_cannot_hold() {
        let mut c = Calibration::default_sim();
        for ((floor_mm, share), said) in [
            ((0.004, 0.022), "peak depths over 1.39 mm"),
            ((0.012, 0.02), "peak depths under 0.16 mm and over 1.55 mm"),
        ] {
            c.depth_error = Some(DepthError { floor_mm, share });
            let (text, _) = report(&verdicts(&c));
            assert!(
                text.contains(&format!("{said} will carry depth_uncertain")),
                "{text}"
            );
        }
    }

    /// A press where the kit never pressed reading 2 % off, on the reference unit's depth
    /// model (a held-out floor of 0.002 mm): `2·√(0.002² + (0.02·d)²)` passes
    /// `0.02 + 0.03·d` at 1.99 mm, and the report says so; at 1 % off no depth is flagged.
    /// A held-out floor of 0.012 mm alone flags presses under 0.13 mm; with the places 2 %
    /// apart, those under 0.16 mm and over 1.55 mm.
    #[test]
    fn places_reading_apart_say_from_which_depth_up_readings_are_flagged() {
        let mut c = Calibration::default_sim();
        c.depth_place_spread = Some(0.02);
        let (text, _) = report(&verdicts(&c));
        assert!(
            text.contains("over 1.99 mm will carry depth_uncertain") && text.contains("2.0 % off"),
            "{text}"
        );
        c.depth_place_spread = Some(0.01);
        let (text, _) = report(&verdicts(&c));
        assert!(!text.contains("depth_uncertain"), "{text}");
        c.depth_error = Some(DepthError {
            floor_mm: 0.012,
            share: 0.0,
        });
        for (spread, said) in [
            (None, "peak depths under 0.13 mm will"),
            (
                Some(0.02),
                "peak depths under 0.16 mm and over 1.55 mm will",
            ),
        ] {
            c.depth_place_spread = spread;
            let (text, _) = report(&verdicts(&c));
            assert!(text.contains(said), "{spread:?}: {text}");
        }
    }
}
