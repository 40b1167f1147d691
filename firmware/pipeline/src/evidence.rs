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
}
