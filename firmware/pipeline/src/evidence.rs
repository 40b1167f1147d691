//! The evidence a fitted model carries: every candidate's cross-validated and in-sample
//! errors, and the chosen one's, so a calibration file shows why it chose what it chose.

use serde::{Deserialize, Serialize};

/// One candidate model's scores, for the report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CandidateScore {
    /// Name (form, and feature for force).
    pub name: String,
    /// Free parameters.
    pub params: usize,
    /// Cross-validated RMSE.
    pub cv_rmse: f64,
    /// Standard error of the CV RMSE over folds.
    pub cv_se: f64,
    /// In-sample RMSE.
    pub in_sample_rmse: f64,
    /// Why the candidate could not be chosen whatever its errors (a depth curve that
    /// falls within the phases it will meet); absent for an eligible one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refused: Option<String>,
}

/// A fitted model with its evidence.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Fitted<M> {
    /// The chosen model.
    pub model: M,
    /// Its equation.
    pub equation: String,
    /// Cross-validated RMSE of the chosen model (leave-one-level-out).
    pub cv_rmse: f64,
    /// In-sample RMSE.
    pub in_sample_rmse: f64,
    /// Samples fitted.
    pub n: usize,
    /// Every candidate's scores.
    pub candidates: Vec<CandidateScore>,
    /// The inputs and labels the model was fitted on (absent in files written before it
    /// was recorded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub range: Option<FitRange>,
}

/// The span of a fit's inputs and labels: what the model has seen.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FitRange {
    /// Smallest and largest input (phase, rad; or the force model's feature).
    pub input: [f64; 2],
    /// Smallest and largest label (depth, mm; or force, N).
    pub output: [f64; 2],
}

impl FitRange {
    /// The span of `(input, label)` pairs; `None` for none.
    pub fn of(pairs: impl Iterator<Item = (f64, f64)>) -> Option<FitRange> {
        let mut r: Option<FitRange> = None;
        for (u, y) in pairs {
            let g = r.get_or_insert(FitRange {
                input: [u, u],
                output: [y, y],
            });
            g.input = [g.input[0].min(u), g.input[1].max(u)];
            g.output = [g.output[0].min(y), g.output[1].max(y)];
        }
        r
    }
}
