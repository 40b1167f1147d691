//! Colour maps: perceptually ordered, so equal steps of the value look like equal steps
//! of colour and print in grey as a ramp.

/// A colour map: anchors at equal spacing, linear between them.
#[derive(Debug, Clone, Copy)]
pub struct ColourMap(&'static [[f32; 3]]);

/// Viridis (depth): dark blue for none, yellow for the deepest.
pub const VIRIDIS: ColourMap = ColourMap(&[
    [68.0, 1.0, 84.0],
    [59.0, 82.0, 139.0],
    [33.0, 145.0, 140.0],
    [94.0, 201.0, 98.0],
    [253.0, 231.0, 37.0],
]);

/// Inferno (temperature): black-purple for the coldest, pale yellow for the hottest.
pub const INFERNO: ColourMap = ColourMap(&[
    [0.0, 0.0, 4.0],
    [87.0, 16.0, 110.0],
    [188.0, 55.0, 84.0],
    [249.0, 142.0, 9.0],
    [252.0, 255.0, 164.0],
]);

/// Cells without a trusted value.
pub const NO_DATA: [u8; 3] = [170, 170, 170];

impl ColourMap {
    /// The colour at `t` in 0…1 (clamped; NaN gives [`NO_DATA`]).
    pub fn at(self, t: f32) -> [u8; 3] {
        if t.is_nan() {
            return NO_DATA;
        }
        let a = self.0;
        let last = a.len() - 1;
        let t = t.clamp(0.0, 1.0) * last as f32;
        let i = (t.floor() as usize).min(last - 1);
        let f = t - i as f32;
        [0, 1, 2].map(|k| (a[i][k] + (a[i + 1][k] - a[i][k]) * f).round() as u8)
    }

    /// The colour of `v` on a bar from `lo` to `hi`.
    pub fn of(self, v: f32, (lo, hi): (f64, f64)) -> [u8; 3] {
        let span = (hi - lo).max(1e-9);
        self.at(((f64::from(v) - lo) / span) as f32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ends_are_the_anchors_and_nan_is_grey() {
        assert_eq!(VIRIDIS.at(0.0), [68, 1, 84]);
        assert_eq!(VIRIDIS.at(1.0), [253, 231, 37]);
        assert_eq!(VIRIDIS.at(7.0), [253, 231, 37]);
        assert_eq!(INFERNO.at(f32::NAN), NO_DATA);
        assert_eq!(INFERNO.of(30.0, (20.0, 40.0)), INFERNO.at(0.5));
    }

    #[test]
    fn viridis_brightens_steadily() {
        let luma =
            |c: [u8; 3]| 0.3 * f32::from(c[0]) + 0.59 * f32::from(c[1]) + 0.11 * f32::from(c[2]);
        let l: Vec<f32> = (0..=20)
            .map(|i| luma(VIRIDIS.at(i as f32 / 20.0)))
            .collect();
        assert!(l.windows(2).all(|w| w[1] > w[0]));
    }
}
