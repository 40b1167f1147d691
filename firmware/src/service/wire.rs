//! A measurement in the wire's units: the per-frame summary (its maps: [`super::maps`]).

use vistaf_pipeline::Measurement;
use vistaf_protocol::units::{centi_c, centi_c_or_not_measured, to_u32};
use vistaf_protocol::{CentroidDeciMm, Summary};

/// A summary of one analysed frame.
pub fn summary_of(
    d: &Measurement,
    seq: u32,
    capture_us: u64,
    latency_us: u32,
    mm_per_px: f32,
) -> Summary {
    Summary {
        seq,
        capture_us,
        latency_us,
        force_mn: to_u32(d.force_n, 1000.0),
        peak_depth_um: to_u32(d.peak_depth_mm, 1000.0),
        contact_area_centi_mm2: to_u32(d.contact_area_mm2, 100.0),
        volume_milli_mm3: to_u32(d.volume_mm3, 1000.0),
        centroid: d
            .centroid_px
            .map(|(x, y)| CentroidDeciMm::from_mm(x * mm_per_px, y * mm_per_px)),
        temp_min_centi_c: centi_c_or_not_measured(d.temperature.as_ref().map(|t| t.min_c)),
        temp_mean_centi_c: centi_c_or_not_measured(d.temperature.as_ref().map(|t| t.mean_c)),
        temp_max_centi_c: centi_c_or_not_measured(d.temperature.as_ref().map(|t| t.max_c)),
        contact_temp_centi_c: d
            .temperature
            .as_ref()
            .and_then(|t| t.contact_c)
            .map(centi_c),
        flags: d.flags,
    }
}
