//! What a calibration must hold before the pipeline trusts it, on load and on write: every
//! array as long as its partner, every coefficient finite, every model that must be
//! monotone monotone, and every model's output plausible over the inputs it will meet.
//! A file that breaks a rule is refused with the key's path named, so a broken or hostile
//! file can neither crash the service nor make it report absurd numbers.

use super::{Calibration, DepthModel, FitRange, ForceForm, ForceModel, ShapeSignature};
use crate::thermal::model::{
    mean_read_rises, reference_shift_ordered, stand_out_ordered, CHROMA_SPREAD_LIMIT,
    MEAN_READ_MIN_SLOPE, REFERENCE_SHIFT_LIMIT_C, STAND_OUT_LIMIT,
};

/// A broken rule: the key's path and why.
#[derive(Debug, Clone, PartialEq)]
pub struct Invalid {
    /// Where, as a JSON path (`force.model.form.a`).
    pub key: String,
    /// What is wrong.
    pub why: String,
}

type Check = Result<(), Invalid>;

/// A number as a message shows it: compact for the very large and very small.
fn num(v: f64) -> String {
    if v != 0.0 && !(1e-4..1e6).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

fn bad(key: &str, why: impl Into<String>) -> Invalid {
    Invalid {
        key: key.to_string(),
        why: why.into(),
    }
}

/// Deepest indentation any skin can show, mm: a depth model past it over the phases it will
/// meet is not a skin's.
pub const MAX_DEPTH_MM: f64 = 100.0;
/// Largest force any skin can carry, N.
pub const MAX_FORCE_N: f64 = 10_000.0;
/// A model may miss its own calibration's largest label by this fraction (plus
/// [`OUTPUT_SLACK_ABS`]) at its largest input: more, and the file does not hold what was
/// fitted.
pub const OUTPUT_SLACK: f64 = 0.5;
/// See [`OUTPUT_SLACK`]: in the label's unit (mm or N).
pub const OUTPUT_SLACK_ABS: f64 = 1.0;
/// Most coefficients a polynomial depth model may carry.
const MAX_POLYNOMIAL_DEGREE: usize = 4;
/// How far beyond its calibration's largest input a model is checked (and so may be read),
/// as a multiple of that input.
pub const MODEL_REACH: f64 = 2.0;
/// Points a model is evaluated at to check it is finite and monotone.
const PROBES: usize = 256;
/// Phases a depth model is checked over without a recorded range, rad (two turns: a
/// calibrated sphere's deepest press stays within one).
const DEFAULT_PHASE_RAD: f64 = 4.0 * std::f64::consts::PI;

/// Checks every rule; the first one broken is returned.
pub fn check(c: &Calibration) -> Check {
    if !(c.phase_sign == 1.0 || c.phase_sign == -1.0) {
        return Err(bad(
            "phase_sign",
            format!("{}: must be 1 or -1", num(c.phase_sign)),
        ));
    }
    check_unit(c)?;
    check_depth(&c.depth.model, c.depth.range.as_ref())?;
    check_range("depth.range", c.depth.range.as_ref())?;
    if let Some(spread) = c.depth_place_spread {
        if !(0.0..=1.0).contains(&spread) {
            return Err(bad(
                "depth_place_spread",
                format!("{}: must be a share of the depth, 0…1", num(spread)),
            ));
        }
    }
    if let Some(e) = c.depth_error {
        let valid = |v: f64, max: f64| (0.0..=max).contains(&v);
        if !(valid(e.floor_mm, MAX_DEPTH_MM) && valid(e.share, 1.0)) {
            return Err(bad(
                "depth_error",
                format!(
                    "floor_mm {}, share {}: must be 0…{MAX_DEPTH_MM} mm and a share of the \
                     depth, 0…1",
                    num(e.floor_mm),
                    num(e.share)
                ),
            ));
        }
    }
    if let Some(f) = &c.force {
        check_range("force.range", f.range.as_ref())?;
        check_force(&f.model, f.range.as_ref())?;
    }
    if let Some(s) = &c.shape {
        check_shape(s)?;
    }
    if let Some(why) = c.colour_phase.as_ref().and_then(|p| p.invalid()) {
        return Err(bad("colour_phase", why));
    }
    if let Some(t) = &c.temperature {
        let r = t.range_c;
        if !mean_read_rises(&t.mean_read) {
            return Err(bad(
                "temperature.mean_read",
                format!(
                    "must hold finite temperatures in setpoint order, each mean read at least \
                     {MEAN_READ_MIN_SLOPE} °C per °C above the one before"
                ),
            ));
        }
        if !stand_out_ordered(&t.stand_out) {
            return Err(bad(
                "temperature.stand_out",
                format!(
                    "must hold finite setpoints in increasing order, each with a departure of \
                     0…{STAND_OUT_LIMIT} standard deviations"
                ),
            ));
        }
        if !reference_shift_ordered(&t.reference_shift) {
            return Err(bad(
                "temperature.reference_shift",
                format!(
                    "must hold finite setpoints in increasing order, each with a move of \
                     0…{REFERENCE_SHIFT_LIMIT_C} °C"
                ),
            ));
        }
        if !t
            .contact_chroma_spread
            .iter()
            .all(|s| (0.0..=CHROMA_SPREAD_LIMIT).contains(s))
        {
            return Err(bad(
                "temperature.contact_chroma_spread",
                format!("must be two relative spreads of 0…{CHROMA_SPREAD_LIMIT}"),
            ));
        }
        if !t.is_consistent() {
            return Err(bad(
                "temperature",
                "models must have 2 (coloured) and 3 (black) finite standardised features, \
                 matching coefficient counts, positive variances and a non-empty range and \
                 domain",
            ));
        }
        if !(r[0].is_finite() && r[1].is_finite() && -50.0 <= r[0] && r[0] < r[1] && r[1] <= 150.0)
        {
            return Err(bad(
                "temperature.range_c",
                format!("{r:?}: must be an increasing range within -50…150 °C"),
            ));
        }
    }
    Ok(())
}

fn check_unit(c: &Calibration) -> Check {
    let u = &c.unit;
    for (key, v) in [
        ("unit.width_px", u.width_px),
        ("unit.height_px", u.height_px),
    ] {
        if !(1..=16_384).contains(&v) {
            return Err(bad(key, format!("{v}: an image side of 1 to 16 384 px")));
        }
    }
    if !vistaf_hardware::decode::SCALES.contains(&u.decode_scale) {
        return Err(bad(
            "unit.decode_scale",
            format!("{}: a decoding scale of 1, 2, 4 or 8", u.decode_scale),
        ));
    }
    let within = |key: &str, v: f64, lo: f64, hi: f64, what: &str| {
        if v.is_finite() && v > lo && v <= hi {
            Ok(())
        } else {
            Err(bad(key, format!("{}: {what}", num(v))))
        }
    };
    within(
        "unit.period_px",
        u.period_px,
        2.0,
        4096.0,
        "a grating period of more than 2 px",
    )?;
    within(
        "unit.grating_period_mm",
        u.grating_period_mm,
        0.0,
        100.0,
        "a grating period of up to 100 mm",
    )?;
    if !u.angle_deg.is_finite() {
        return Err(bad(
            "unit.angle_deg",
            format!("{}: not a number", num(u.angle_deg)),
        ));
    }
    Ok(())
}

/// A recorded fit range: finite and ordered.
fn check_range(key: &str, r: Option<&FitRange>) -> Check {
    let Some(r) = r else { return Ok(()) };
    for (k, [lo, hi]) in [("input", r.input), ("output", r.output)] {
        if !(lo.is_finite() && hi.is_finite() && 0.0 <= lo && lo <= hi) {
            return Err(bad(
                &format!("{key}.{k}"),
                format!(
                    "[{}, {}]: must be finite, non-negative and ordered",
                    num(lo),
                    num(hi)
                ),
            ));
        }
    }
    Ok(())
}

/// A model `f` over `[0, to]`: finite, non-negative, non-decreasing, at most `max`; and at
/// its calibration's largest input within the slack of its largest label.
fn check_curve(
    key: &str,
    f: impl Fn(f64) -> f64,
    to: f64,
    max: f64,
    range: Option<&FitRange>,
) -> Check {
    let mut last = 0.0f64;
    for k in 0..=PROBES {
        let x = to * k as f64 / PROBES as f64;
        let y = f(x);
        if !y.is_finite() || y < 0.0 || y > max {
            return Err(bad(
                key,
                format!(
                    "reads {} at {x:.4}: outside 0…{max} over the inputs it will meet",
                    num(y)
                ),
            ));
        }
        if y < last - 1e-9 * last.abs() {
            return Err(bad(
                key,
                format!(
                    "falls from {} to {} at {x:.4}: must not decrease",
                    num(last),
                    num(y)
                ),
            ));
        }
        last = y;
    }
    if let Some(r) = range {
        let (got, want) = (f(r.input[1]), r.output[1]);
        if (got - want).abs() > OUTPUT_SLACK * want + OUTPUT_SLACK_ABS {
            return Err(bad(
                key,
                format!(
                    "reads {} at its calibration's largest input, whose label was {}",
                    num(got),
                    num(want)
                ),
            ));
        }
    }
    Ok(())
}

/// `v` is a finite, positive coefficient, or an error naming `key`.
fn positive(key: &str, v: f64) -> Check {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(bad(key, format!("{}: must be positive", num(v))))
    }
}

/// Checks a depth model alone over the phases it will meet ([`MODEL_REACH`] times its fit's
/// largest, or two turns without a range): a calibration chooses only among models that
/// pass.
pub fn check_depth(m: &DepthModel, range: Option<&FitRange>) -> Check {
    let key = "depth.model";
    let positive = |k: &str, v: f64| positive(&format!("{key}.{k}"), v);
    match m {
        DepthModel::Linear { k_mm_per_rad } => positive("k_mm_per_rad", *k_mm_per_rad)?,
        DepthModel::Hinge { h_mm, k_per_rad } => {
            positive("h_mm", *h_mm)?;
            positive("k_per_rad", *k_per_rad)?;
        }
        DepthModel::Growth { a_mm, b_per_rad } => {
            positive("a_mm", *a_mm)?;
            positive("b_per_rad", *b_per_rad)?;
        }
        DepthModel::Polynomial { c_mm } => {
            if c_mm.is_empty() || c_mm.len() > MAX_POLYNOMIAL_DEGREE {
                return Err(bad(
                    &format!("{key}.c_mm"),
                    format!("needs 1 to {MAX_POLYNOMIAL_DEGREE} coefficients"),
                ));
            }
            if !c_mm.iter().all(|c| c.is_finite()) {
                return Err(bad(&format!("{key}.c_mm"), "coefficients must be finite"));
            }
        }
        DepthModel::Monotone { x_rad, d_mm } => {
            let ok = x_rad.len() == d_mm.len()
                && x_rad.len() >= 2
                && x_rad.first().is_some_and(|x| *x > 0.0)
                && x_rad.windows(2).all(|p| p[1] > p[0])
                && d_mm.windows(2).all(|p| p[1] >= p[0])
                && d_mm.last().is_some_and(|d| *d > 0.0)
                && x_rad.iter().chain(d_mm).all(|v| v.is_finite() && *v >= 0.0);
            if !ok {
                return Err(bad(
                    key,
                    "monotone knots must be two or more, equally many, finite, increasing \
                     from above 0, and reach a positive depth",
                ));
            }
        }
    }
    let to = range.map_or(DEFAULT_PHASE_RAD, |r| MODEL_REACH * r.input[1].max(1e-3));
    check_curve(key, |x| m.depth_mm(x), to, MAX_DEPTH_MM, range)?;
    // Some phase must read as depth: a model reading 0 for every press is a lie.
    if m.depth_mm(to) <= 0.0 {
        return Err(bad(key, "reads no depth at any phase"));
    }
    Ok(())
}

/// Inputs a force model is checked over without a recorded range, by feature.
fn default_input(m: &ForceModel) -> f64 {
    use super::ForceFeature as F;
    match m.feature {
        F::Volume => 400.0,
        F::IntegratedPhase => 400.0,
        F::ContactArea => 400.0,
        F::PeakDepth => 5.0,
        F::ElasticLoad | F::ReciprocalLoad => 50.0,
    }
}

fn check_force(m: &ForceModel, range: Option<&FitRange>) -> Check {
    let key = "force.model.form";
    let positive = |k: &str, v: f64| positive(&format!("{key}.{k}"), v);
    match m.form {
        ForceForm::Linear { a } => positive("a", a)?,
        ForceForm::PowerLaw { a, b } => {
            positive("a", a)?;
            positive("b", b)?;
            if b > 10.0 {
                return Err(bad(
                    &format!("{key}.b"),
                    format!("{}: an exponent of at most 10", num(b)),
                ));
            }
        }
        ForceForm::Exponential { a, b } => {
            positive("a", a)?;
            positive("b", b)?;
        }
        ForceForm::Hertz { c } => positive("c", c)?,
    }
    let to = range.map_or_else(|| default_input(m), |r| MODEL_REACH * r.input[1].max(1e-6));
    let top = range.map_or(f64::INFINITY, |r| r.input[1]);
    check_curve(
        "force.model",
        |u| m.extrapolated_force_n(u, top),
        to,
        MAX_FORCE_N,
        range,
    )
}

fn check_shape(s: &ShapeSignature) -> Check {
    if !knots_ok(&s.depth_mm, &s.area_mm2) {
        return Err(bad(
            "shape",
            "depth_mm and area_mm2 must be equally long (one or more), finite, non-negative, \
             with depths increasing",
        ));
    }
    match &s.load {
        Some(l) if !knots_ok(&l.depth_mm, &l.load_mm2) => Err(bad(
            "shape.load",
            "depth_mm and load_mm2 must be equally long (one or more), finite, non-negative, \
             with depths increasing",
        )),
        _ => Ok(()),
    }
}

/// Knots `(x, y)` of a signature: equally long, one or more, finite, non-negative, `x`
/// increasing.
fn knots_ok(x: &[f64], y: &[f64]) -> bool {
    x.len() == y.len()
        && !x.is_empty()
        && x.windows(2).all(|p| p[1] > p[0])
        && x.iter().chain(y).all(|v| v.is_finite() && *v >= 0.0)
}
