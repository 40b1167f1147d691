//! Colour ranges with round ends, fixed across the frames of a session so a colour means
//! the same depth or temperature in every figure.

use crate::{Frame, Grid};

/// The colour bars' ranges.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ranges {
    /// Depth bar, mm (from 0).
    pub depth_mm: (f64, f64),
    /// Temperature bar, °C.
    pub temperature_c: (f64, f64),
}

/// The narrowest depth bar, mm: an untouched skin is drawn as flat, not as noise blown
/// up to fill the bar.
pub const MIN_DEPTH_SPAN_MM: f64 = 0.5;

/// The narrowest temperature bar, °C.
pub const MIN_TEMPERATURE_SPAN_C: f64 = 2.0;

impl Default for Ranges {
    /// 0–1 mm deep (a firm press of the calibration sphere) and 20–40 °C (room to skin).
    fn default() -> Ranges {
        Ranges {
            depth_mm: (0.0, 1.0),
            temperature_c: (20.0, 40.0),
        }
    }
}

impl Ranges {
    /// Bars that hold every value of `frames`, with round ends: depth from 0 to the
    /// deepest value, temperature around the coldest and hottest, each at least its
    /// minimum span wide. Frames without a map leave that bar at its default.
    pub fn covering<'a>(frames: impl IntoIterator<Item = &'a Frame>) -> Ranges {
        let (mut depth, mut temp) = (None::<(f32, f32)>, None::<(f32, f32)>);
        let widen =
            |acc: Option<(f32, f32)>, g: &Option<Grid>| match g.as_ref().and_then(Grid::extremes) {
                Some((lo, hi)) => Some(acc.map_or((lo.value, hi.value), |(a, b)| {
                    (a.min(lo.value), b.max(hi.value))
                })),
                None => acc,
            };
        for f in frames {
            depth = widen(depth, &f.depth_mm);
            temp = widen(temp, &f.temperature_c);
        }
        let d = Ranges::default();
        Ranges {
            depth_mm: depth.map_or(d.depth_mm, |(_, hi)| {
                (0.0, round_up(f64::from(hi).max(MIN_DEPTH_SPAN_MM)))
            }),
            temperature_c: temp.map_or(d.temperature_c, |(lo, hi)| {
                around(f64::from(lo), f64::from(hi), MIN_TEMPERATURE_SPAN_C)
            }),
        }
    }
}

/// Colour bars asked for, each `None` to take another's ([`Bars::or`]): what a user
/// gives on a command line.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Bars {
    /// Depth bar, mm.
    pub depth_mm: Option<(f64, f64)>,
    /// Temperature bar, °C.
    pub temperature_c: Option<(f64, f64)>,
}

impl Bars {
    /// These bars where given, `fallback`'s elsewhere.
    pub fn or(self, fallback: Ranges) -> Ranges {
        Ranges {
            depth_mm: self.depth_mm.unwrap_or(fallback.depth_mm),
            temperature_c: self.temperature_c.unwrap_or(fallback.temperature_c),
        }
    }
}

/// The round step (1, 2 or 5 times a power of ten) that cuts `span` into about five.
pub fn step(span: f64) -> f64 {
    let raw = (span / 5.0).max(1e-9);
    let p = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * p)
        .find(|s| *s >= raw * 0.999)
        .unwrap_or(10.0 * p)
}

/// `v` rounded up to its step.
fn round_up(v: f64) -> f64 {
    let s = step(v);
    (v / s).ceil() * s
}

/// A range around `lo..hi` at least `min_span` wide, its ends on the step.
fn around(lo: f64, hi: f64, min_span: f64) -> (f64, f64) {
    let mid = (lo + hi) / 2.0;
    let half = ((hi - lo) / 2.0).max(min_span / 2.0);
    let s = step(2.0 * half);
    (
        ((mid - half) / s).floor() * s,
        ((mid + half) / s).ceil() * s,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(depth: &[f32], temp: &[f32]) -> Frame {
        let g = |v: &[f32]| Grid {
            width: v.len(),
            height: 1,
            pitch_mm: 0.1,
            values: v.to_vec(),
        };
        Frame {
            depth_mm: Some(g(depth)),
            temperature_c: Some(g(temp)),
            ..Frame::default()
        }
    }

    #[test]
    fn the_bars_hold_every_frame_with_round_ends() {
        let a = frame(&[0.0, 1.23, f32::NAN], &[24.2, 25.0]);
        let b = frame(&[0.0, 0.4], &[29.7, 31.1]);
        let r = Ranges::covering([&a, &b]);
        assert_eq!(r.depth_mm, (0.0, 1.5));
        assert!(r.temperature_c.0 <= 24.2 && r.temperature_c.1 >= 31.1);
        assert_eq!(r.temperature_c, (24.0, 32.0));
    }

    #[test]
    fn a_flat_frame_keeps_a_minimum_span() {
        let r = Ranges::covering([&frame(&[0.0, 0.01], &[25.0, 25.1])]);
        assert_eq!(r.depth_mm, (0.0, 0.5));
        assert!(r.temperature_c.1 - r.temperature_c.0 >= MIN_TEMPERATURE_SPAN_C);
        assert_eq!(Ranges::covering([]), Ranges::default());
    }

    #[test]
    fn steps_are_round() {
        assert_eq!(step(1.4), 0.5);
        assert_eq!(step(8.0), 2.0);
        assert_eq!(step(20.0), 5.0);
    }
}
