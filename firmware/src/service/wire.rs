//! A measurement in the wire's units: the per-frame summary and the coarse maps.

use vistaf_pipeline::Measurement;
use vistaf_protocol::msg::{MAP_MAX_CELLS, MAP_NO_DATA};
use vistaf_protocol::units::{centi_c, centi_c_or_not_measured, to_u32};
use vistaf_protocol::{CentroidDeciMm, Map, MapKind, Summary};

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

/// A temperature map tile of at most [`MAP_MAX_CELLS`] cells (means of the measured blocks),
/// or `None` without a temperature model.
pub fn temperature_tile(d: &Measurement, seq: u32) -> Option<Map> {
    let t = d.temperature.as_ref()?;
    let step = ((t.bw * t.bh) as f32 / MAP_MAX_CELLS as f32)
        .sqrt()
        .ceil()
        .max(1.0) as usize;
    let (tw, th) = (t.bw.div_ceil(step).min(255), t.bh.div_ceil(step).min(255));
    let mut cells = heapless::Vec::new();
    'rows: for ty in 0..th {
        for tx in 0..tw {
            let (mut sum, mut n) = (0.0f32, 0u32);
            for y in ty * step..((ty + 1) * step).min(t.bh) {
                for x in tx * step..((tx + 1) * step).min(t.bw) {
                    let v = t.map_c[y * t.bw + x];
                    if v.is_finite() {
                        sum += v;
                        n += 1;
                    }
                }
            }
            let v = if n > 0 {
                centi_c(sum / n as f32)
            } else {
                MAP_NO_DATA
            };
            if cells.push(v).is_err() {
                break 'rows;
            }
        }
    }
    Some(Map {
        seq,
        kind: MapKind::Temperature,
        width: tw as u8,
        height: th as u8,
        cell_pitch_centi_mm: to_u32(t.block_mm * step as f32, 100.0).min(u32::from(u16::MAX))
            as u16,
        cells,
    })
}

/// A depth map tile of at most [`MAP_MAX_CELLS`] cells (block maxima of the working map).
pub fn depth_tile(d: &Measurement, seq: u32, mm_per_px: f32) -> Map {
    let step = ((d.width_px * d.height_px) as f32 / MAP_MAX_CELLS as f32)
        .sqrt()
        .ceil()
        .max(1.0) as usize;
    let (tw, th) = (
        d.width_px.div_ceil(step).min(255),
        d.height_px.div_ceil(step).min(255),
    );
    let mut cells = heapless::Vec::new();
    'rows: for ty in 0..th {
        for tx in 0..tw {
            let mut m = i32::MIN;
            let mut any = false;
            for y in ty * step..((ty + 1) * step).min(d.height_px) {
                for x in tx * step..((tx + 1) * step).min(d.width_px) {
                    let i = y * d.width_px + x;
                    any |= d.reliable[i];
                    m = m.max(d.depth_um[i]);
                }
            }
            let v = if any {
                m.clamp(0, i32::from(i16::MAX)) as i16
            } else {
                MAP_NO_DATA
            };
            if cells.push(v).is_err() {
                break 'rows;
            }
        }
    }
    Map {
        seq,
        kind: MapKind::Depth,
        width: tw as u8,
        height: th as u8,
        cell_pitch_centi_mm: to_u32(mm_per_px * (d.factor * step) as f32, 100.0)
            .min(u32::from(u16::MAX)) as u16,
        cells,
    }
}
