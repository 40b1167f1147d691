//! A lens's lateral chromatic aberration on both paths: each colour's stripes magnified
//! about the centre by its own scale, and a frame whose colours' fringe amplitudes differ
//! from the reference's (another temperature, another white balance). Read through the
//! luminance alone, the view shows a phase field where nothing pressed; with each colour
//! turned onto one grating first it shows none, and a press reads the same whatever the
//! colours' weights.
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

use image::RgbImage;
use std::f64::consts::TAU;
use vistaf_pipeline::calibration::Calibration;
use vistaf_pipeline::ftp::band::BandWindow;
use vistaf_pipeline::ftp::carrier;
use vistaf_pipeline::ftp::fixed::{FixedFtp, Scratch};
use vistaf_pipeline::ftp::float::FloatFtp;
use vistaf_pipeline::input::{luma, Colour};
use vistaf_pipeline::phase::{PhaseMap, GRID};

const W: u32 = 320;
const H: u32 = 240;
/// Each colour's magnification minus one: red outward, green as is, blue inward (a strong
/// lens, so that the luminance's field stands well above the test's bound).
const CHI: [f64; 3] = [0.004, 0.0, -0.004];

/// Stripes of a 12 px period, slightly tilted, each colour `k` of fringe amplitude
/// `amps[k]` about 120 and magnified by `1 + CHI[k]` about the centre; `bump_rad` of phase
/// at the centre of a Gaussian press at [`PRESS`], near a corner.
fn stripes(amps: [f64; 3], bump_rad: f64) -> RgbImage {
    let (cx, cy) = (f64::from(W) / 2.0, f64::from(H) / 2.0);
    RgbImage::from_fn(W, H, |x, y| {
        let (x, y) = (f64::from(x), f64::from(y));
        let (dx, dy) = (x - PRESS.0 as f64, y - PRESS.1 as f64);
        let bump = bump_rad * (-(dx * dx + dy * dy) / 300.0).exp();
        image::Rgb(std::array::from_fn(|k| {
            let (u, v) = (
                cx + (x - cx) / (1.0 + CHI[k]),
                cy + (y - cy) / (1.0 + CHI[k]),
            );
            let theta = TAU * (u + 0.1 * v) / 12.0 + bump;
            (120.0 + amps[k] * theta.cos()).round() as u8
        }))
    })
}

/// The image with every pixel's colour replaced by its luminance: the same luminance,
/// no colour to read apart.
fn grey(img: &RgbImage) -> RgbImage {
    RgbImage::from_fn(img.width(), img.height(), |x, y| {
        let l = (luma(Colour::Rgb).weighted(&img.get_pixel(x, y).0) + 128) >> 8;
        image::Rgb([l as u8; 3])
    })
}

/// Where the press is, input pixels.
const PRESS: (usize, usize) = (264, 52);

const REFERENCE: [f64; 3] = [50.0, 50.0, 50.0];
/// The colours' amplitudes of a warmer skin under another white balance.
const SHIFTED: [f64; 3] = [15.0, 50.0, 90.0];
/// Coarse samples this far (working pixels) from the border are read.
const MARGIN: usize = 16;

/// The wrapped phase difference of `frame` at every coarse sample clear of the border, rad,
/// on the device path.
fn fixed_phases(reference: &RgbImage, frame: &RgbImage) -> Vec<(usize, usize, f64)> {
    let working = carrier::working(reference, None).unwrap();
    let ftp = FixedFtp::new(reference, &working, &Calibration::default_sim());
    let mut scratch = Scratch::default();
    let field = ftp.phase(frame, &mut scratch);
    let (w, h) = field.size();
    let cw = w.div_ceil(GRID);
    let f = working.factor;
    field
        .wrapped_all()
        .into_iter()
        .enumerate()
        .map(|(k, p)| {
            (
                (k % cw) * GRID,
                (k / cw) * GRID,
                f64::from(p) * TAU / 65_536.0,
            )
        })
        .filter(|&(x, y, _)| x >= MARGIN && y >= MARGIN && x + MARGIN < w && y + MARGIN < h)
        .map(|(x, y, p)| (x * f, y * f, p))
        .collect()
}

/// As [`fixed_phases`], on the float reference, at the same coarse samples.
fn float_phases(reference: &RgbImage, frame: &RgbImage) -> Vec<(usize, usize, f64)> {
    let working = carrier::working(reference, None).unwrap();
    let ftp = FloatFtp::new(reference, &working, BandWindow::Matched);
    let field = ftp.phase(frame);
    let (w, h, f) = (field.w, field.h, working.factor);
    (MARGIN..h - MARGIN)
        .step_by(GRID)
        .flat_map(|y| (MARGIN..w - MARGIN).step_by(GRID).map(move |x| (x, y)))
        .map(|(x, y)| (x * f, y * f, f64::from(field.wrapped[y * w + x])))
        .collect()
}

type Reader = fn(&RgbImage, &RgbImage) -> Vec<(usize, usize, f64)>;

/// The largest |phase| over the view, rad.
fn largest(phases: &[(usize, usize, f64)]) -> f64 {
    phases.iter().map(|p| p.2.abs()).fold(0.0, f64::max)
}

#[test]
fn colours_that_change_their_weights_show_no_field_where_nothing_pressed() {
    let (reference, frame) = (stripes(REFERENCE, 0.0), stripes(SHIFTED, 0.0));
    for (path, read) in [("fixed", fixed_phases as Reader), ("float", float_phases)] {
        let luminance_alone = largest(&read(&grey(&reference), &grey(&frame)));
        let turned = largest(&read(&reference, &frame));
        println!("{path}: largest phase {luminance_alone:.3} rad through the luminance alone, {turned:.3} rad per colour");
        assert!(
            luminance_alone > 0.06,
            "{path}: the lens draws a field ({luminance_alone} rad)"
        );
        assert!(turned < 0.012, "{path}: {turned} rad where nothing pressed");
    }
}

#[test]
fn a_press_reads_the_same_whatever_the_colours_weights() {
    let reference = stripes(REFERENCE, 0.0);
    let at_press = |read: Reader, reference: &RgbImage, frame: &RgbImage| {
        let phases = read(reference, frame);
        let near =
            |p: &&(usize, usize, f64)| p.0.abs_diff(PRESS.0) <= 4 && p.1.abs_diff(PRESS.1) <= 4;
        let (n, sum) = phases
            .iter()
            .filter(near)
            .fold((0, 0.0), |(n, s), p| (n + 1, s + p.2));
        assert!(n > 0, "no sample at the press");
        sum / f64::from(n)
    };
    for (path, read) in [("fixed", fixed_phases as Reader), ("float", float_phases)] {
        let frames = [stripes(REFERENCE, -1.0), stripes(SHIFTED, -1.0)];
        let [a, b] = frames
            .each_ref()
            .map(|f| at_press(read, &grey(&reference), &grey(f)));
        let [c, d] = frames.each_ref().map(|f| at_press(read, &reference, f));
        println!("{path}: the press reads {a:.4} and {b:.4} rad through the luminance alone, {c:.4} and {d:.4} rad per colour");
        assert!(
            (a - b).abs() > 0.03,
            "{path}: the lens moves the press's phase ({a} vs {b} rad)"
        );
        assert!(c < -0.5, "{path}: the press is seen ({c} rad)");
        assert!((c - d).abs() < 0.01, "{path}: {c} vs {d} rad");
    }
}
