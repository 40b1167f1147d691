//! Conversions between SI floats and the integer sub-units of the wire.
//!
//! Rounding is to nearest; values beyond a field's range saturate and NaN becomes 0
//! (Rust's float-to-int `as` casts), so a wild estimate can never wrap around into a
//! plausible-looking number. The pipeline flags such estimates; the wire only carries them.

use crate::msg::{CentroidDeciMm, Summary};

/// Rounds a non-negative quantity `x × scale` to an unsigned field (negative → 0).
pub fn to_u32(x: f32, scale: f32) -> u32 {
    let v = x * scale;
    if v > 0.0 {
        (v + 0.5) as u32
    } else {
        0
    }
}

/// Rounds a signed quantity `x × scale` to an `i16` field, saturating.
pub fn to_i16(x: f32, scale: f32) -> i16 {
    let v = x * scale;
    if v >= 0.0 {
        (v + 0.5) as i16
    } else {
        (v - 0.5) as i16
    }
}

/// Temperature in °C → 0.01 °C, rounded to nearest and saturating within the field's
/// range; a reading that is not a number (NaN, ±∞) is [`TEMP_NOT_MEASURED`], and no
/// reading can become that value by saturating.
///
/// [`TEMP_NOT_MEASURED`]: crate::msg::TEMP_NOT_MEASURED
pub fn centi_c(temp_c: f32) -> i16 {
    if !temp_c.is_finite() {
        return crate::msg::TEMP_NOT_MEASURED;
    }
    let v = (temp_c * 100.0).clamp(f32::from(i16::MIN + 1), f32::from(i16::MAX));
    // Half away from zero, as `f32::round` (not in `core`): the fraction is exact here.
    let whole = v as i32;
    let frac = v - whole as f32;
    let rounded = if frac >= 0.5 {
        whole + 1
    } else if frac <= -0.5 {
        whole - 1
    } else {
        whole
    };
    rounded as i16
}

/// [`centi_c`] of a temperature that may not have been measured (`None`).
pub fn centi_c_or_not_measured(temp_c: Option<f32>) -> i16 {
    temp_c.map_or(crate::msg::TEMP_NOT_MEASURED, centi_c)
}

/// Position in mm → 0.1 mm.
pub fn deci_mm(pos_mm: f32) -> i16 {
    to_i16(pos_mm, 10.0)
}

/// 0.01 °C → °C; [`crate::msg::TEMP_NOT_MEASURED`] → NaN.
fn temp_c(v: i16) -> f32 {
    if v == crate::msg::TEMP_NOT_MEASURED {
        f32::NAN
    } else {
        f32::from(v) / 100.0
    }
}

/// A [`Summary`] in SI units, for display and recording. Temperatures that were not
/// measured are NaN.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SummarySi {
    /// Normal force, N.
    pub force_n: f32,
    /// Peak depth, mm.
    pub peak_depth_mm: f32,
    /// Contact area, mm².
    pub contact_area_mm2: f32,
    /// Measurement volume, mm³.
    pub volume_mm3: f32,
    /// Contact centre (x, y), mm.
    pub centroid_mm: Option<(f32, f32)>,
    /// Lowest temperature, °C.
    pub temp_min_c: f32,
    /// Mean temperature, °C.
    pub temp_mean_c: f32,
    /// Highest temperature, °C.
    pub temp_max_c: f32,
    /// Contact temperature, °C.
    pub contact_temp_c: Option<f32>,
}

impl Summary {
    /// The summary's quantities in SI units.
    pub fn si(&self) -> SummarySi {
        SummarySi {
            force_n: self.force_mn as f32 / 1000.0,
            peak_depth_mm: self.peak_depth_um as f32 / 1000.0,
            contact_area_mm2: self.contact_area_centi_mm2 as f32 / 100.0,
            volume_mm3: self.volume_milli_mm3 as f32 / 1000.0,
            centroid_mm: self
                .centroid
                .map(|c| (c.x as f32 / 10.0, c.y as f32 / 10.0)),
            temp_min_c: temp_c(self.temp_min_centi_c),
            temp_mean_c: temp_c(self.temp_mean_centi_c),
            temp_max_c: temp_c(self.temp_max_centi_c),
            contact_temp_c: self.contact_temp_centi_c.map(|t| t as f32 / 100.0),
        }
    }
}

impl CentroidDeciMm {
    /// A centre given in mm.
    pub fn from_mm(x_mm: f32, y_mm: f32) -> Self {
        CentroidDeciMm {
            x: deci_mm(x_mm),
            y: deci_mm(y_mm),
        }
    }
}

/// A calibration id as every output prints it: eight lowercase hexadecimal digits
/// (`Hello::calibration_id`, a fit's id, the calibration file's `id`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct CalibrationId(pub u32);

impl core::fmt::Display for CalibrationId {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{:08x}", self.0)
    }
}

impl crate::msg::KitQuantity {
    /// The quantity's name, its SI unit, and the factor from its wire milli-units to it.
    pub const fn si(self) -> (&'static str, &'static str, f64) {
        use crate::msg::KitQuantity;
        match self {
            KitQuantity::Reference => ("reference", "°C", 1e-3),
            KitQuantity::Depth => ("depth", "mm", 1e-3),
            KitQuantity::Force => ("force", "N", 1e-3),
            KitQuantity::Temperature => ("temperature", "°C", 1e-3),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounding_and_saturation() {
        assert_eq!(to_u32(1.2344, 1000.0), 1234);
        assert_eq!(to_u32(1.2346, 1000.0), 1235);
        assert_eq!(to_u32(-3.0, 1000.0), 0);
        assert_eq!(to_u32(f32::NAN, 1000.0), 0);
        assert_eq!(to_u32(1e30, 1000.0), u32::MAX);
        assert_eq!(centi_c(25.004), 2500);
        assert_eq!(centi_c(-5.006), -501);
        assert_eq!(centi_c(1e9), i16::MAX);
        // Saturation never reaches the "not measured" code; not a number does.
        assert_eq!(centi_c(-1e9), i16::MIN + 1);
        assert_eq!(centi_c(f32::NAN), crate::msg::TEMP_NOT_MEASURED);
        assert_eq!(centi_c(f32::INFINITY), crate::msg::TEMP_NOT_MEASURED);
        assert_eq!(centi_c_or_not_measured(None), crate::msg::TEMP_NOT_MEASURED);
        assert_eq!(centi_c_or_not_measured(Some(-0.004)), 0);
        assert_eq!(centi_c(0.125), 13);
        assert_eq!(centi_c(-0.125), -13);
        // The same as rounding with std's `f32::round` then saturating, for every
        // hundredth and half-hundredth across the range and beyond.
        for k in -700_000..700_000 {
            let t = k as f32 / 200.0;
            let expect = (t * 100.0).round().clamp(-32_767.0, 32_767.0) as i16;
            assert_eq!(centi_c(t), expect, "{t}");
        }
        assert_eq!(deci_mm(12.34), 123);
    }

    #[test]
    fn si_view_inverts_the_units() {
        let s = Summary {
            force_mn: 12_345,
            peak_depth_um: 2_000,
            contact_area_centi_mm2: 5_025,
            volume_milli_mm3: 117_000,
            centroid: Some(CentroidDeciMm::from_mm(20.0, -3.5)),
            temp_mean_centi_c: 3_150,
            contact_temp_centi_c: Some(4_000),
            ..Default::default()
        };
        let si = s.si();
        assert!((si.force_n - 12.345).abs() < 1e-6);
        assert!((si.peak_depth_mm - 2.0).abs() < 1e-6);
        assert!((si.contact_area_mm2 - 50.25).abs() < 1e-4);
        assert!((si.volume_mm3 - 117.0).abs() < 1e-4);
        assert_eq!(si.centroid_mm, Some((20.0, -3.5)));
        assert!((si.temp_mean_c - 31.5).abs() < 1e-6);
        assert_eq!(si.contact_temp_c, Some(40.0));
        let unmeasured = Summary {
            temp_min_centi_c: crate::msg::TEMP_NOT_MEASURED,
            ..s
        };
        assert!(unmeasured.si().temp_min_c.is_nan());
    }
}
