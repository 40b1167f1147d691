//! The calibration file: which models map phase to depth and deformation to force (and,
//! later, colour to temperature), with their coefficients, metrics and provenance.
//!
//! Versioned JSON (`format: "vistaf-calibration/2"`). A file of another version, or a
//! malformed one, is refused with a message naming the problem. A calibration records the
//! unit geometry it was made on (carrier period, orientation, image size); [`Calibration::check_fits`]
//! refuses a reference that does not match unless the caller overrides it.

use std::path::Path;

use serde::{Deserialize, Serialize};

pub mod colour_phase;

pub use crate::evidence::{CandidateScore, FitRange, Fitted};

mod validate;
pub use validate::{check_depth, Invalid, MAX_DEPTH_MM, MAX_FORCE_N, MODEL_REACH};

/// The format tag of calibration files.
pub const FORMAT: &str = "vistaf-calibration/2";

/// The calibration shipped for the simulated reference unit (`vistaf-skin simulate
/// --calibration-kit` then `vistaf-skin calibrate`; see `docs/calibration.md`).
pub const DEFAULT_JSON: &str = include_str!("../../calibration/default.json");

/// Phase → depth, applied per pixel to `x = phase_sign · Δφ` (rad, ≥ 0 under indentation).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum DepthModel {
    /// `d = k·x`.
    Linear {
        /// Slope, mm/rad.
        k_mm_per_rad: f64,
    },
    /// The paper's saturating hinge: `d = H·(1 − e^(−k·x))`.
    Hinge {
        /// Saturation depth, mm.
        h_mm: f64,
        /// Rate, 1/rad.
        k_per_rad: f64,
    },
    /// `d = a·(e^(b·x) − 1)`: a response that steepens (phase saturating with depth).
    Growth {
        /// Scale, mm.
        a_mm: f64,
        /// Rate, 1/rad.
        b_per_rad: f64,
    },
    /// `d = c₁·x + c₂·x² + …` through the origin: a smooth curve of either bend, or of a
    /// bend that changes along the range, for a phase response no two-parameter form
    /// follows (the calibration admits it only where it rises over twice the phases it
    /// was fitted on).
    Polynomial {
        /// `c₁, c₂, …`: mm/rad, mm/rad², ….
        c_mm: Vec<f64>,
    },
    /// Monotone piecewise-linear through `(x, d)` knots starting at (0, 0); beyond the last
    /// knot it continues with the last segment's slope.
    Monotone {
        /// Knot phases, rad, increasing.
        x_rad: Vec<f64>,
        /// Depth at each knot, mm, non-decreasing.
        d_mm: Vec<f64>,
    },
}

impl DepthModel {
    /// Depth at phase `x` (rad), mm. Negative `x` (bulging) maps to 0.
    pub fn depth_mm(&self, x: f64) -> f64 {
        let x = x.max(0.0);
        match self {
            DepthModel::Linear { k_mm_per_rad } => k_mm_per_rad * x,
            DepthModel::Hinge { h_mm, k_per_rad } => h_mm * (1.0 - (-k_per_rad * x).exp()),
            DepthModel::Growth { a_mm, b_per_rad } => {
                a_mm * ((b_per_rad * x).min(50.0).exp() - 1.0)
            }
            DepthModel::Polynomial { c_mm } => c_mm.iter().rev().fold(0.0, |acc, c| (acc + c) * x),
            DepthModel::Monotone { x_rad, d_mm } => {
                let (mut x0, mut d0) = (0.0, 0.0);
                for (&x1, &d1) in x_rad.iter().zip(d_mm) {
                    if x <= x1 {
                        return if x1 > x0 {
                            d0 + (d1 - d0) * (x - x0) / (x1 - x0)
                        } else {
                            d1
                        };
                    }
                    (x0, d0) = (x1, d1);
                }
                // Beyond the last knot: extend the last segment.
                let n = x_rad.len();
                if n >= 2 && x_rad[n - 1] > x_rad[n - 2] {
                    let s = (d_mm[n - 1] - d_mm[n - 2]) / (x_rad[n - 1] - x_rad[n - 2]);
                    d0 + s * (x - x0)
                } else {
                    d0
                }
            }
        }
    }

    /// The model as an equation.
    pub fn equation(&self) -> String {
        match self {
            DepthModel::Linear { k_mm_per_rad } => format!("d_mm = {k_mm_per_rad:.6}·x"),
            DepthModel::Hinge { h_mm, k_per_rad } => {
                format!("d_mm = {h_mm:.6}·(1 − exp(−{k_per_rad:.6}·x))")
            }
            DepthModel::Growth { a_mm, b_per_rad } => {
                format!("d_mm = {a_mm:.6}·(exp({b_per_rad:.6}·x) − 1)")
            }
            DepthModel::Polynomial { c_mm } => {
                let mut eq = String::from("d_mm =");
                for (k, c) in c_mm.iter().enumerate() {
                    let sign = match (k, c.is_sign_negative()) {
                        (0, false) => " ",
                        (0, true) => " −",
                        (_, false) => " + ",
                        (_, true) => " − ",
                    };
                    let power = if k == 0 {
                        String::new()
                    } else {
                        format!("^{}", k + 1)
                    };
                    eq += &format!("{sign}{:.6}·x{power}", c.abs());
                }
                eq
            }
            DepthModel::Monotone { x_rad, d_mm } => {
                let pts: Vec<String> = x_rad
                    .iter()
                    .zip(d_mm)
                    .map(|(x, d)| format!("({x:.4}, {d:.4})"))
                    .collect();
                format!("d_mm = piecewise-linear through (0, 0), {}", pts.join(", "))
            }
        }
    }
}

/// Which deformation feature predicts force.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ForceFeature {
    /// Measurement volume, mm³.
    Volume,
    /// Phase integrated over the deformed area, rad·mm².
    IntegratedPhase,
    /// Contact area, mm².
    ContactArea,
    /// Peak depth, mm.
    PeakDepth,
    /// Elastic load `√(A/π)·d`, mm²: the half-peak contact radius times the peak depth. In
    /// an elastic half-space the force is proportional to it for a sphere of any radius
    /// (Hertz: `F = (4/3)·E*·a·d`, and the depth falls to half its peak exactly at the
    /// contact radius `a`) and within 6 % for a flat punch of any size (Boussinesq:
    /// `F = 2·E*·a·d`, its depth at half the plateau at `√2·a`); the reciprocal load below
    /// is exact for any shape and is the one the calibration keeps when it fits.
    ElasticLoad,
    /// Reciprocal load `L`, mm²: the depth map weighted by the pressure of a flat punch the
    /// shape of the contact's half-depth region (`crate::measure::load`). By Betti's
    /// reciprocal theorem the force on an elastic half-space is `E*·L` for any indenter
    /// shape, so the calibration on one sphere only finds the skin's modulus.
    ReciprocalLoad,
}

/// What a contact offers the force model: one value per [`ForceFeature`].
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ForceInputs {
    /// Half-peak contact area, mm².
    pub area_mm2: f32,
    /// Peak depth, mm.
    pub peak_mm: f32,
    /// Volume, mm³.
    pub volume_mm3: f32,
    /// Phase integrated over the deformed area, rad·mm².
    pub integrated_phase_rad_mm2: f32,
    /// Reciprocal load, mm².
    pub reciprocal_load_mm2: f32,
}

impl ForceFeature {
    /// Every feature.
    pub const ALL: [ForceFeature; 6] = [
        ForceFeature::Volume,
        ForceFeature::IntegratedPhase,
        ForceFeature::ContactArea,
        ForceFeature::PeakDepth,
        ForceFeature::ElasticLoad,
        ForceFeature::ReciprocalLoad,
    ];

    /// The feature's value for a contact.
    pub fn of(self, x: &ForceInputs) -> f32 {
        match self {
            ForceFeature::Volume => x.volume_mm3,
            ForceFeature::IntegratedPhase => x.integrated_phase_rad_mm2,
            ForceFeature::ContactArea => x.area_mm2,
            ForceFeature::PeakDepth => x.peak_mm,
            ForceFeature::ElasticLoad => {
                (x.area_mm2.max(0.0) / std::f32::consts::PI).sqrt() * x.peak_mm
            }
            ForceFeature::ReciprocalLoad => x.reciprocal_load_mm2,
        }
    }

    /// Symbol used in equations.
    pub fn symbol(self) -> &'static str {
        match self {
            ForceFeature::Volume => "V_mm3",
            ForceFeature::IntegratedPhase => "Φ_rad_mm2",
            ForceFeature::ContactArea => "A_mm2",
            ForceFeature::PeakDepth => "d_mm",
            ForceFeature::ElasticLoad => "ad_mm2",
            ForceFeature::ReciprocalLoad => "L_mm2",
        }
    }
}

/// The functional form of the force model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum ForceForm {
    /// `F = a·u`.
    Linear {
        /// Slope.
        a: f64,
    },
    /// `F = a·u^b`.
    PowerLaw {
        /// Scale.
        a: f64,
        /// Exponent.
        b: f64,
    },
    /// The paper's exponential growth `F = a·(e^(b·u) − 1)`.
    Exponential {
        /// Scale.
        a: f64,
        /// Rate.
        b: f64,
    },
    /// Hertz-like `F = c·u^1.5`.
    Hertz {
        /// Scale.
        c: f64,
    },
}

/// Measurement → force.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ForceModel {
    /// Input feature.
    pub feature: ForceFeature,
    /// Form and coefficients.
    pub form: ForceForm,
}

impl ForceModel {
    /// Force for a feature value `u`, N (never negative).
    pub fn force_n(&self, u: f64) -> f64 {
        let u = u.max(0.0);
        let f = match self.form {
            ForceForm::Linear { a } => a * u,
            ForceForm::PowerLaw { a, b } => a * u.powf(b),
            ForceForm::Exponential { a, b } => a * ((b * u).min(50.0).exp() - 1.0),
            ForceForm::Hertz { c } => c * u.powf(1.5),
        };
        f.max(0.0)
    }

    /// Force for a feature value `u` when the calibration's largest input was `top`, N.
    /// Within `top` it is [`ForceModel::force_n`]. Beyond it the elastic laws (linear in a
    /// load, Hertz's power in depth) are the skin's physics and carry on as they are; the
    /// growth forms' curvature was fitted over the kit alone, so they go on along their
    /// tangent at `top` instead of compounding it.
    pub fn extrapolated_force_n(&self, u: f64, top: f64) -> f64 {
        if !(u > top && top > 0.0) {
            return self.force_n(u);
        }
        let slope = match self.form {
            ForceForm::Linear { .. } | ForceForm::Hertz { .. } => return self.force_n(u),
            ForceForm::PowerLaw { a, b } => a * b * top.powf(b - 1.0),
            ForceForm::Exponential { a, b } => a * b * (b * top).min(50.0).exp(),
        };
        (self.force_n(top) + slope.max(0.0) * (u - top)).max(0.0)
    }

    /// The model as an equation.
    pub fn equation(&self) -> String {
        let u = self.feature.symbol();
        match self.form {
            ForceForm::Linear { a } => format!("F_N = {a:.6}·{u}"),
            ForceForm::PowerLaw { a, b } => format!("F_N = {a:.6}·{u}^{b:.4}"),
            ForceForm::Exponential { a, b } => format!("F_N = {a:.6}·(exp({b:.6}·{u}) − 1)"),
            ForceForm::Hertz { c } => format!("F_N = {c:.6}·{u}^1.5"),
        }
    }
}

/// The unit geometry a calibration was made on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UnitGeometry {
    /// Image width, pixels: the pipeline's input, the camera's width over
    /// [`UnitGeometry::decode_scale`].
    pub width_px: u32,
    /// Image height, pixels.
    pub height_px: u32,
    /// Grating period in the image, pixels.
    pub period_px: f64,
    /// Carrier direction, degrees.
    pub angle_deg: f64,
    /// Physical grating period, mm.
    pub grating_period_mm: f64,
    /// How many times smaller than the camera's image its frames are decoded, each way (1,
    /// 2, 4 or 8; see [`crate::input::decode_scale`]). Pixel sizes above are at that scale.
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub decode_scale: u32,
}

fn one() -> u32 {
    1
}

fn is_one(s: &u32) -> bool {
    *s == 1
}

impl UnitGeometry {
    /// The camera's image size, pixels.
    pub fn camera_size(&self) -> (u32, u32) {
        let s = self.decode_scale.max(1);
        (self.width_px * s, self.height_px * s)
    }

    /// The scale to decode a `width_px × height_px` camera frame at: the calibration's,
    /// when the frame is the camera's size; else 1 (the frame is read as it is, and a
    /// size that does not fit is refused by [`Calibration::check_fits`]).
    pub fn scale_for(&self, width_px: u32, height_px: u32) -> u32 {
        if (width_px, height_px) == self.camera_size() {
            self.decode_scale.max(1)
        } else {
            1
        }
    }
}

/// How the calibrated indenter looks: its contact area (depth ≥ half the peak) at each
/// measured depth, and the load its map carries there. The calibration is exact for
/// contacts of this shape; a contact much sharper or blunter than it is flagged.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShapeSignature {
    /// Measured peak depths, mm, increasing.
    pub depth_mm: Vec<f64>,
    /// Contact area at each, mm².
    pub area_mm2: Vec<f64>,
    /// The reciprocal load at each measured depth (absent from files written before it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load: Option<LoadSignature>,
}

/// The calibrated indenter's reciprocal load (`measure::load`, mm²) against its measured
/// peak depth: how much the skin pushes back for that depth. An indenter of another shape
/// pressed to the same depth carries another load (a flat punch more, a sharper sphere
/// less), and so does a contact whose depth was misread.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LoadSignature {
    /// Measured peak depths, mm, increasing.
    pub depth_mm: Vec<f64>,
    /// Reciprocal load at each, mm².
    pub load_mm2: Vec<f64>,
}

impl LoadSignature {
    /// The load at `depth_mm` (linear between knots), mm²; `None` outside the knots, where
    /// the kit says nothing.
    pub fn load_mm2_at(&self, depth_mm: f64) -> Option<f64> {
        let (d, l) = (&self.depth_mm, &self.load_mm2);
        if d.first().is_some_and(|&d0| depth_mm < d0) {
            return None;
        }
        let k = d.iter().position(|&x| x >= depth_mm)?;
        Some(between_knots(d, l, k, depth_mm))
    }
}

impl ShapeSignature {
    /// Area at `depth_mm` (linear between knots, constant beyond), mm².
    pub fn area_mm2_at(&self, depth_mm: f64) -> f64 {
        let (d, a) = (&self.depth_mm, &self.area_mm2);
        match d.iter().position(|&x| x >= depth_mm) {
            None => a.last().copied().unwrap_or(0.0),
            Some(k) => between_knots(d, a, k, depth_mm),
        }
    }
}

/// `y` at `x`, linear between knots `k − 1` and `k` (the first knot at or beyond `x`; knot
/// `k`'s value when `k` is 0). Knots the validation would refuse (unequal lengths) give the
/// last value, or 0, instead of a panic.
fn between_knots(xs: &[f64], ys: &[f64], k: usize, x: f64) -> f64 {
    let (Some(&x1), Some(&y1)) = (xs.get(k), ys.get(k)) else {
        return ys.last().copied().unwrap_or(0.0);
    };
    let before = k
        .checked_sub(1)
        .and_then(|j| Some((*xs.get(j)?, *ys.get(j)?)));
    match before {
        None => y1,
        Some((x0, y0)) => y0 + (y1 - y0) * (x - x0) / (x1 - x0).max(1e-12),
    }
}

/// A frame set used for the calibration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SetRecord {
    /// Directory as given.
    pub path: String,
    /// SHA-256 of the manifest and every image, in manifest order.
    pub sha256: String,
    /// Frames used.
    pub frames: usize,
}

/// How far the depth model reads a press held out of its fit, as a standard deviation at
/// depth `d`: `√(floor² + (share · d)²)`, mm. A unit whose phase gain varies across the
/// view reads deep presses off by a share of their depth while its shallow presses hold
/// their floor; one figure for every depth (the whole held-out RMSE) would lend the deep
/// presses' error to the shallow ones and doubt them all. Fitted on the kit's presses, each
/// read by the model fitted without its depth (`vistaf_calibrate::fit::error_by_depth`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DepthError {
    /// The error's part that does not grow with the depth, mm.
    pub floor_mm: f64,
    /// The error's part that grows with the depth, a share of it.
    pub share: f64,
}

impl DepthError {
    /// The error at `depth_mm` (a standard deviation), mm.
    pub fn at_mm(&self, depth_mm: f64) -> f64 {
        self.floor_mm.hypot(self.share * depth_mm)
    }

    /// This error with its share of the depth raised to how far presses of one depth read
    /// apart from place to place ([`Calibration::depth_place_spread`]) where that is larger:
    /// the error a reading at a place the kit never pressed may carry.
    pub fn with_place_spread(self, place_spread: Option<f64>) -> DepthError {
        DepthError {
            share: place_spread.map_or(self.share, |p| self.share.max(p)),
            ..self
        }
    }
}

/// A calibration file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Calibration {
    /// Must be [`FORMAT`].
    pub format: String,
    /// Unit geometry at calibration.
    pub unit: UnitGeometry,
    /// Sign that makes indentation phase positive.
    pub phase_sign: f64,
    /// Phase → depth.
    pub depth: Fitted<DepthModel>,
    /// How far a press at a place the kit never pressed may read from the depth model, as a
    /// share of the depth (a standard deviation): the kit's presses of one depth read apart
    /// from place to place (pooled over the depths where the depth tolerance's share
    /// outweighs its floor), widened for the model being fitted between those places
    /// (`vistaf_calibrate::fit::place_spread`). A unit whose phase gain varies across the
    /// view reads a deep press wrong by a share of its depth there. Absent when too few
    /// such depths were pressed at two places or more, and in files written before it was
    /// recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub depth_place_spread: Option<f64>,
    /// How far the depth model read the kit's presses held out of its fit, by depth
    /// ([`DepthError`]). Absent in files written before it was recorded, where the depth
    /// model's whole held-out error (`depth.cv_rmse`) stands for it at every depth.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub depth_error: Option<DepthError>,
    /// Measurement → force, if the kit had force labels.
    pub force: Option<Fitted<ForceModel>>,
    /// The calibrated indenter's contact area by depth (for the sharpness check).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shape: Option<ShapeSignature>,
    /// Colour → temperature, if the kit had no-contact frames labelled with temperatures.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub temperature: Option<crate::thermal::model::TemperatureModel>,
    /// The grating phase the pigment's colour moves at each of the temperature kit's
    /// setpoints ([`colour_phase`]), if the kit had uniform frames.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub colour_phase: Option<colour_phase::ColourPhase>,
    /// Frame sets the fit used.
    pub sets: Vec<SetRecord>,
}

/// A calibration that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum CalibrationError {
    /// Unreadable file.
    #[error("{path}: {cause}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        cause: std::io::Error,
    },
    /// Not valid calibration JSON.
    #[error("{path}: not a valid calibration file: {detail}")]
    Malformed {
        /// The file.
        path: String,
        /// The parser's message.
        detail: String,
    },
    /// A value that breaks a rule a usable calibration keeps.
    #[error("{path}: key `{key}`: {why}")]
    Invalid {
        /// The file.
        path: String,
        /// The key's JSON path.
        key: String,
        /// What is wrong.
        why: String,
    },
    /// Another format version.
    #[error("{path}: calibration format {found:?}, this build reads {FORMAT:?}; recalibrate with this version")]
    Version {
        /// The file.
        path: String,
        /// What it says.
        found: String,
    },
    /// Made for another unit geometry.
    #[error("calibration was made for {want}, but this sensor shows {got}; recalibrate, or pass --force-calibration to use it anyway")]
    Mismatch {
        /// What the calibration expects.
        want: String,
        /// What the reference shows.
        got: String,
    },
}

impl Calibration {
    /// Parses calibration JSON; `path` names it in errors.
    pub fn from_json(text: &str, path: &str) -> Result<Calibration, CalibrationError> {
        let v: serde_json::Value =
            serde_json::from_str(text).map_err(|e| CalibrationError::Malformed {
                path: path.into(),
                detail: e.to_string(),
            })?;
        match v.get("format").and_then(|f| f.as_str()) {
            Some(FORMAT) => {}
            Some(other) => {
                return Err(CalibrationError::Version {
                    path: path.into(),
                    found: other.into(),
                })
            }
            None => {
                return Err(CalibrationError::Malformed {
                    path: path.into(),
                    detail: "missing \"format\"".into(),
                })
            }
        }
        let c: Calibration =
            serde_json::from_value(v).map_err(|e| CalibrationError::Malformed {
                path: path.into(),
                detail: e.to_string(),
            })?;
        c.check().map_err(|e| CalibrationError::Invalid {
            path: path.into(),
            key: e.key,
            why: e.why,
        })?;
        Ok(c)
    }

    /// Checks every rule a usable calibration keeps (see the `validate` module); the
    /// first one broken names its key.
    pub fn check(&self) -> Result<(), Invalid> {
        validate::check(self)
    }

    /// The deepest indentation the calibration saw, mm (from the indenter's shape
    /// signature, else the depth fit's labels, else the monotone depth model's last knot).
    pub fn calibrated_depth_mm(&self) -> Option<f64> {
        if let Some(d) = self.shape.as_ref().and_then(|s| s.depth_mm.last()) {
            return Some(*d);
        }
        if let Some(r) = &self.depth.range {
            return Some(r.output[1]);
        }
        match &self.depth.model {
            DepthModel::Monotone { d_mm, .. } => d_mm.last().copied(),
            _ => None,
        }
    }

    /// Reads a calibration file.
    pub fn load(path: &Path) -> Result<Calibration, CalibrationError> {
        let p = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|cause| CalibrationError::Io {
            path: p.clone(),
            cause,
        })?;
        Calibration::from_json(&text, &p)
    }

    /// The shipped default for the simulated reference unit.
    pub fn default_sim() -> Calibration {
        // The embedded file is checked by a test, so this cannot fail in a release.
        Calibration::from_json(DEFAULT_JSON, "default calibration")
            .unwrap_or_else(|e| panic!("{e}"))
    }

    /// A short identifier: the first 4 bytes of the SHA-256 of the JSON.
    pub fn id(&self) -> u32 {
        use sha2::{Digest, Sha256};
        let text = serde_json::to_string(self).unwrap_or_default();
        let d = Sha256::digest(text.as_bytes());
        u32::from_be_bytes([d[0], d[1], d[2], d[3]])
    }

    /// Refuses a sensor whose geometry differs from the calibration's: another image size,
    /// or a carrier period more than 3 % off.
    pub fn check_fits(
        &self,
        width_px: u32,
        height_px: u32,
        period_px: f64,
    ) -> Result<(), CalibrationError> {
        let u = &self.unit;
        let rel = (period_px - u.period_px).abs() / u.period_px;
        if width_px != u.width_px || height_px != u.height_px || rel > 0.03 {
            let (cw, ch) = u.camera_size();
            let scaled = if u.decode_scale > 1 {
                format!(" (a {cw}×{ch} camera read at 1/{})", u.decode_scale)
            } else {
                String::new()
            };
            return Err(CalibrationError::Mismatch {
                want: format!(
                    "{}×{} px{scaled} with a {:.2} px grating period",
                    u.width_px, u.height_px, u.period_px
                ),
                got: format!("{width_px}×{height_px} px with a {period_px:.2} px period"),
            });
        }
        Ok(())
    }

    /// Writes the calibration as pretty JSON.
    ///
    /// A calibration that breaks a rule is refused, not written; the file appears whole or
    /// not at all (written beside it, then renamed over it).
    pub fn save(&self, path: &Path) -> Result<(), CalibrationError> {
        let p = path.display().to_string();
        self.check().map_err(|e| CalibrationError::Invalid {
            path: p.clone(),
            key: e.key,
            why: e.why,
        })?;
        let text = serde_json::to_string_pretty(self).map_err(|e| CalibrationError::Malformed {
            path: p.clone(),
            detail: e.to_string(),
        })?;
        let mut part = path.as_os_str().to_owned();
        part.push(".part");
        let part = std::path::PathBuf::from(part);
        std::fs::write(&part, text + "\n")
            .and_then(|()| std::fs::rename(&part, path))
            .map_err(|cause| {
                let _ = std::fs::remove_file(&part);
                CalibrationError::Io { path: p, cause }
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Beyond the kit the elastic laws read on as they are, and the growth forms along
    /// their tangent at the kit's largest input; within it every form is itself.
    #[test]
    fn force_models_extrapolate_by_their_physics() {
        let model = |form| ForceModel {
            feature: ForceFeature::ReciprocalLoad,
            form,
        };
        let linear = model(ForceForm::Linear { a: 1.6 });
        let hertz = model(ForceForm::Hertz { c: 2.0 });
        let power = model(ForceForm::PowerLaw { a: 2.0, b: 1.5 });
        let growth = model(ForceForm::Exponential { a: 1.0, b: 2.0 });
        for m in [&linear, &hertz, &power, &growth] {
            for u in [0.0, 0.5, 2.0] {
                assert_eq!(m.extrapolated_force_n(u, 2.0), m.force_n(u), "{m:?} at {u}");
            }
        }
        assert_eq!(linear.extrapolated_force_n(5.0, 2.0), linear.force_n(5.0));
        assert_eq!(hertz.extrapolated_force_n(5.0, 2.0), hertz.force_n(5.0));
        // The power law that Hertz's is, past u = 2: 2·2^1.5 + 3·√2·3.
        let tangent = 2.0 * 2f64.powf(1.5) + 3.0 * 2f64.sqrt() * 3.0;
        assert!((power.extrapolated_force_n(5.0, 2.0) - tangent).abs() < 1e-9);
        assert!(power.extrapolated_force_n(5.0, 2.0) < power.force_n(5.0));
        // e^4 − 1 at the kit's edge, rising at 2·e^4 beyond it.
        let e4 = 4f64.exp();
        let got = growth.extrapolated_force_n(3.0, 2.0);
        assert!((got - (e4 - 1.0 + 2.0 * e4)).abs() < 1e-9, "{got}");
    }

    #[test]
    fn depth_models_are_monotone() {
        let models = [
            DepthModel::Linear { k_mm_per_rad: 0.6 },
            DepthModel::Hinge {
                h_mm: 2.08,
                k_per_rad: 4.2,
            },
            DepthModel::Growth {
                a_mm: 3.0,
                b_per_rad: 0.2,
            },
            DepthModel::Monotone {
                x_rad: vec![0.5, 1.0, 2.0],
                d_mm: vec![0.3, 0.7, 1.6],
            },
            DepthModel::Polynomial {
                c_mm: vec![0.5, -0.02, 0.01],
            },
        ];
        for m in &models {
            let mut last = -1.0;
            for i in 0..200 {
                let d = m.depth_mm(i as f64 * 0.02);
                assert!(d >= last, "{m:?} at {i}");
                last = d;
            }
            assert_eq!(m.depth_mm(-1.0), 0.0);
        }
        // The paper's curve: x = 0.1 → 0.715 mm (reference-pipeline §11.6).
        let paper = DepthModel::Hinge {
            h_mm: 2.0826494996246554,
            k_per_rad: 4.20441143052732,
        };
        assert!((paper.depth_mm(0.1) - 0.715).abs() < 1e-3);
        // Monotone: interpolates and extends the last slope.
        let m = &models[3];
        assert!((m.depth_mm(0.75) - 0.5).abs() < 1e-12);
        assert!((m.depth_mm(3.0) - 2.5).abs() < 1e-12);
        // Polynomial: 0.5·2 − 0.02·4 + 0.01·8.
        assert!((models[4].depth_mm(2.0) - 1.0).abs() < 1e-12);
        assert_eq!(
            models[4].equation(),
            "d_mm = 0.500000·x − 0.020000·x^2 + 0.010000·x^3"
        );
    }

    /// The load signature answers between its knots only, linearly; a file written
    /// before it (no `load`) still loads, without one.
    #[test]
    fn the_load_signature_speaks_only_within_its_knots() {
        let l = LoadSignature {
            depth_mm: vec![0.5, 1.0, 2.0],
            load_mm2: vec![1.0, 3.0, 8.0],
        };
        assert_eq!(l.load_mm2_at(0.4), None);
        assert_eq!(l.load_mm2_at(0.5), Some(1.0));
        assert!((l.load_mm2_at(0.75).unwrap() - 2.0).abs() < 1e-12);
        assert_eq!(l.load_mm2_at(2.0), Some(8.0));
        assert_eq!(l.load_mm2_at(2.1), None);
        let mut v: serde_json::Value = serde_json::from_str(DEFAULT_JSON).unwrap();
        assert!(
            v["shape"]["load"].is_object(),
            "the default calibration has one"
        );
        v["shape"].as_object_mut().unwrap().remove("load");
        let c = Calibration::from_json(&v.to_string(), "old.json").unwrap();
        assert_eq!(c.shape.unwrap().load, None);
    }

    /// Files that would crash the service or make it lie are refused, naming the key.
    #[test]
    fn hostile_values_are_refused_naming_the_key() {
        let refusal = |edit: &dyn Fn(&mut serde_json::Value)| {
            let mut v: serde_json::Value = serde_json::from_str(DEFAULT_JSON).unwrap();
            edit(&mut v);
            Calibration::from_json(&v.to_string(), "c.json")
                .unwrap_err()
                .to_string()
        };
        type Edit<'a> = &'a dyn Fn(&mut serde_json::Value);
        let colour = |setpoints: serde_json::Value| serde_json::json!({"step": 2, "nodes": [4, 3], "setpoints": setpoints});
        let cases: [(&str, Edit<'_>); 26] = [
            ("`depth_error`", &|v| {
                v["depth_error"] = serde_json::json!({"floor_mm": -0.01, "share": 0.02})
            }),
            ("`depth_error`", &|v| {
                v["depth_error"] = serde_json::json!({"floor_mm": 0.01, "share": 2.0})
            }),
            ("`depth_place_spread`", &|v| {
                v["depth_place_spread"] = serde_json::json!(-0.01)
            }),
            ("`shape`", &|v| {
                v["shape"]["area_mm2"] = serde_json::json!([1.0])
            }),
            (
                "`shape.load`",
                &|v| {
                    v["shape"]["load"] =
                        serde_json::json!({"depth_mm": [0.5, 0.4], "load_mm2": [1.0, 2.0]})
                },
            ),
            (
                "`force.model.form.",
                &|v| {
                    v["force"]["model"]["form"] =
                        serde_json::json!({"kind": "power_law", "a": 1e308, "b": 1e308})
                },
            ),
            ("`force.model`", &|v| {
                v["force"]["model"]["form"] = serde_json::json!({"kind": "hertz", "c": 1e6})
            }),
            (
                "`depth.model.k_mm_per_rad`",
                &|v| {
                    v["depth"]["model"] =
                        serde_json::json!({"kind": "linear", "k_mm_per_rad": -5.0})
                },
            ),
            (
                "`depth.model`",
                &|v| {
                    v["depth"]["model"] =
                        serde_json::json!({"kind": "linear", "k_mm_per_rad": 1e308})
                },
            ),
            (
                "`depth.model`",
                &|v| {
                    v["depth"]["model"] =
                        serde_json::json!({"kind": "monotone", "x_rad": [], "d_mm": []})
                },
            ),
            ("`depth.model.c_mm`", &|v| {
                v["depth"]["model"] = serde_json::json!({"kind": "polynomial", "c_mm": []})
            }),
            (
                "`depth.model.c_mm`",
                &|v| {
                    v["depth"]["model"] =
                        serde_json::json!({"kind": "polynomial", "c_mm": [0.5, 0.0, 0.0, 0.0, 0.1]})
                },
            ),
            // Turns down within the phases it will meet.
            (
                "`depth.model`",
                &|v| {
                    v["depth"]["model"] =
                        serde_json::json!({"kind": "polynomial", "c_mm": [0.8, -0.2]})
                },
            ),
            ("`unit.grating_period_mm`", &|v| {
                v["unit"]["grating_period_mm"] = 1e300.into()
            }),
            ("`force.range.output`", &|v| {
                v["force"]["range"]["output"] = serde_json::json!([5.0, 1.0])
            }),
            ("`temperature`", &|v| {
                v["temperature"]["black"]["variance"]["var_c2"][0] = 1e300.into()
            }),
            // A mean that falls as the skin warms cannot be turned back.
            ("`temperature.mean_read`", &|v| {
                v["temperature"]["mean_read"] = serde_json::json!([
                    {"setpoint_c": 20.0, "read_c": 21.0},
                    {"setpoint_c": 22.0, "read_c": 20.5}
                ])
            }),
            ("`temperature.stand_out`", &|v| {
                v["temperature"]["stand_out"] = serde_json::json!([
                    {"setpoint_c": 20.0, "sigmas": 4.0},
                    {"setpoint_c": 22.0, "sigmas": -1.0}
                ])
            }),
            ("`temperature.stand_out`", &|v| {
                v["temperature"]["stand_out"] = serde_json::json!([
                    {"setpoint_c": 22.0, "sigmas": 4.0},
                    {"setpoint_c": 20.0, "sigmas": 5.0}
                ])
            }),
            ("`temperature.reference_shift`", &|v| {
                v["temperature"]["reference_shift"] = serde_json::json!([
                    {"setpoint_c": 20.0, "shift_c": 0.2},
                    {"setpoint_c": 22.0, "shift_c": 1e6}
                ])
            }),
            ("`temperature.reference_shift`", &|v| {
                v["temperature"]["reference_shift"] = serde_json::json!([
                    {"setpoint_c": 22.0, "shift_c": 0.2},
                    {"setpoint_c": 20.0, "shift_c": 0.3}
                ])
            }),
            ("`temperature.contact_chroma_spread`", &|v| {
                v["temperature"]["contact_chroma_spread"] = serde_json::json!([0.01, -0.01])
            }),
            ("`temperature.contact_chroma_spread`", &|v| {
                v["temperature"]["contact_chroma_spread"] = serde_json::json!([0.01, 3.0])
            }),
            // A spot beyond the 12 nodes.
            ("`colour_phase`", &|v| {
                v["colour_phase"] = colour(serde_json::json!([{"t_c": 30.0, "spots": "12:50"}]))
            }),
            ("`colour_phase`", &|v| {
                v["colour_phase"] = colour(serde_json::json!([
                    {"t_c": 30.0, "spots": ""}, {"t_c": 25.0, "spots": ""}
                ]))
            }),
            ("spot \"3:x\"", &|v| {
                v["colour_phase"] = colour(serde_json::json!([{"t_c": 30.0, "spots": "3:x"}]))
            }),
        ];
        for (key, edit) in cases {
            let e = refusal(edit);
            assert!(e.contains("c.json") && e.contains(key), "{key}: {e}");
        }
    }

    /// Writing refuses what loading would refuse, and leaves no file behind.
    #[test]
    fn an_unusable_calibration_is_not_written() {
        let mut c = Calibration::default_sim();
        c.unit.grating_period_mm = 1e300;
        let path = std::env::temp_dir().join(format!("vistaf-cal-{}.json", std::process::id()));
        let e = c.save(&path).unwrap_err().to_string();
        assert!(e.contains("unit.grating_period_mm"), "{e}");
        assert!(!path.exists());
        Calibration::default_sim().save(&path).unwrap();
        assert_eq!(
            Calibration::load(&path).unwrap(),
            Calibration::default_sim()
        );
        std::fs::remove_file(&path).unwrap();
    }

    #[test]
    fn bad_files_are_refused_with_the_reason() {
        let e = Calibration::from_json("{", "c.json")
            .unwrap_err()
            .to_string();
        assert!(e.contains("c.json") && e.contains("not a valid"), "{e}");
        let e = Calibration::from_json(r#"{"format": "vistaf-calibration/0"}"#, "c.json")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("vistaf-calibration/0") && e.contains("recalibrate"),
            "{e}"
        );
        let mut v: serde_json::Value = serde_json::from_str(DEFAULT_JSON).unwrap();
        v["phase_sign"] = 0.5.into();
        let e = Calibration::from_json(&v.to_string(), "c.json")
            .unwrap_err()
            .to_string();
        assert!(e.contains("phase_sign"), "{e}");
        v["phase_sign"] = 1.0.into();
        v.as_object_mut().unwrap().remove("depth");
        let e = Calibration::from_json(&v.to_string(), "c.json")
            .unwrap_err()
            .to_string();
        assert!(e.contains("depth"), "{e}");
    }

    #[test]
    fn the_default_loads_and_checks_geometry() {
        let c = Calibration::default_sim();
        let u = c.unit.clone();
        assert!(c
            .check_fits(u.width_px, u.height_px, u.period_px * 1.01)
            .is_ok());
        let e = c.check_fits(320, 240, u.period_px).unwrap_err().to_string();
        assert!(e.contains("--force-calibration"), "{e}");
        assert!(c
            .check_fits(u.width_px, u.height_px, u.period_px * 1.2)
            .is_err());
    }
}
