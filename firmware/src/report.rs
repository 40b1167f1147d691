//! Reports on what a skin runs with, as JSON for session and analysis files.

use serde_json::{json, Value};
use vistaf_pipeline::Calibration;

/// A calibration's identity, models and evidence: each model's equation, its
/// cross-validated and in-sample errors, and the frame sets it was fitted on.
pub fn calibration_json(c: &Calibration) -> Value {
    json!({
        "id": vistaf_protocol::CalibrationId(c.id()).to_string(),
        "phase_to_depth": { "equation": c.depth.equation, "model": c.depth.model, "cv_rmse_mm": c.depth.cv_rmse, "place_spread": c.depth_place_spread, "error_by_depth": c.depth_error, "in_sample_rmse_mm": c.depth.in_sample_rmse, "n": c.depth.n },
        "force": c.force.as_ref().map(|f| json!({ "equation": f.equation, "model": f.model, "cv_rmse_n": f.cv_rmse, "in_sample_rmse_n": f.in_sample_rmse, "n": f.n })),
        "temperature": c.temperature.as_ref().map(|t| json!({
            "coloured": { "equation": t.coloured.equation, "fit_range_c": t.coloured.fit_range_c, "cv_rmse_c": t.coloured.cv_rmse_c, "in_sample_rmse_c": t.coloured.in_sample_rmse_c },
            "black": { "equation": t.black.equation, "fit_range_c": t.black.fit_range_c, "cv_rmse_c": t.black.cv_rmse_c, "in_sample_rmse_c": t.black.in_sample_rmse_c },
            "fusion": "inverse-variance blend; each estimate's variance from its cross-validated scatter at that estimate",
            "range_c": t.range_c,
            "held_out_rmse_c": { "22_32": t.cv_rmse_transition_c, "all": t.cv_rmse_c },
            "blocks": t.n,
        })),
        "sets": c.sets,
    })
}
