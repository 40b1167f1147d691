//! Pipeline configurations against a fixed benchmark set: cost beside accuracy. The
//! camera's format is an axis too: the same frames sent as YUYV or JPEG at a quality,
//! decoded as the device decodes them, cost counted from the camera's bytes.

use std::time::Instant;

use vistaf_hardware::decode::Decoded;
use vistaf_hardware::encode::Encoding;
use vistaf_pipeline::calibration::Calibration;
use vistaf_pipeline::ftp::band::BandWindow;
use vistaf_pipeline::measure::Unwrap;
use vistaf_pipeline::{Analyzer, AnalyzerOptions, Implementation};
use vistaf_sim::scene::{ROOM_C, SPHERE_R_MM};
use vistaf_sim::thermal::HeatSource;
use vistaf_sim::{Renderer, SensorUnit, SkinState};

use super::{depth_tolerance_mm, press};

/// One pipeline configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct Config {
    /// Label.
    pub name: String,
    /// Float reference or device path.
    pub imp: Implementation,
    /// Downsampling factor (None: chosen from the carrier, 2 here).
    pub factor: Option<usize>,
    /// Band-pass window of the float path.
    pub band: BandWindow,
    /// Whether temperature is measured.
    pub temperature: bool,
    /// When the phase is unwrapped.
    pub unwrap: Unwrap,
    /// Device path: 1-D band-pass along rows instead of 2-D.
    pub rows_only: bool,
    /// How the camera sends the frames.
    pub encoding: Encoding,
}

/// The configurations compared.
pub fn configs() -> Vec<Config> {
    let c = |name: &str, imp, factor, band, temperature| Config {
        name: name.into(),
        imp,
        factor,
        band,
        temperature,
        unwrap: Unwrap::WhenNeeded,
        rows_only: false,
        encoding: Encoding::Rgb,
    };
    use BandWindow::{Hann, Matched};
    let sent = |name: &str, encoding| Config {
        encoding,
        ..c(name, Fixed, None, Matched, true)
    };
    use Implementation::{Fixed, Float};
    let rows = Config {
        rows_only: true,
        ..c("fixed ÷2, 1-D rows", Fixed, None, Matched, true)
    };
    let always = Config {
        unwrap: Unwrap::Always,
        ..c("fixed ÷2, always unwrap", Fixed, None, Matched, true)
    };
    let never = Config {
        unwrap: Unwrap::Never,
        ..c("fixed ÷2, never unwrap", Fixed, None, Matched, true)
    };
    vec![
        c("fixed ÷2 (default)", Fixed, None, Matched, true),
        sent("fixed ÷2, YUYV", Encoding::Yuyv),
        sent("fixed ÷2, MJPEG q90", Encoding::Mjpeg(90)),
        sent("fixed ÷2, MJPEG q75", Encoding::Mjpeg(75)),
        rows,
        always,
        never,
        c("fixed ÷1", Fixed, Some(1), Matched, true),
        c("fixed ÷4", Fixed, Some(4), Matched, true),
        c("fixed ÷8", Fixed, Some(8), Matched, true),
        c("fixed ÷2, no temperature", Fixed, None, Matched, false),
        c("float ÷2 matched", Float, None, Matched, true),
        c("float ÷2 Hann", Float, None, Hann, true),
        c("float ÷1 matched", Float, Some(1), Matched, true),
        c("float ÷4 matched", Float, Some(4), Matched, true),
    ]
}

/// A configuration's measured cost and accuracy.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// The configuration.
    pub config: Config,
    /// Median time per frame, ms (this machine, release build).
    pub ms: f64,
    /// Instructions per frame under callgrind (when measured).
    pub instructions: Option<u64>,
    /// Mean peak-depth error over its tolerance, presses of the calibrated sphere.
    pub depth_error: f64,
    /// Force RMSE, N.
    pub force_rmse_n: f64,
    /// Mean absolute temperature error (uniform skins and a heated contact), °C.
    pub temperature_error_c: Option<f64>,
    /// Why the configuration could not run, if it could not.
    pub refused: Option<String>,
}

/// The benchmark set: (state, what to score).
enum Case {
    Press { depth_mm: f32, force_n: f32 },
    Uniform(f32),
    Heated,
}

fn bench_set(unit: &SensorUnit) -> Vec<(SkinState, Case)> {
    let sphere = vistaf_sim::contact::Indenter::Sphere { r_mm: SPHERE_R_MM };
    let mut v = Vec::new();
    for d in [0.3f32, 1.0, 2.0, 2.5] {
        v.push((
            press(unit, SPHERE_R_MM, d),
            Case::Press {
                depth_mm: d,
                force_n: sphere.force_n(d, unit.modulus_mpa),
            },
        ));
    }
    for t in [20.0f32, 27.0, 40.0] {
        v.push((SkinState::idle(t), Case::Uniform(t)));
    }
    let mut s = press(unit, SPHERE_R_MM, 1.0);
    let heat = HeatSource::under(&s.contacts[0], 38.0, 2.0);
    s.temperature.sources.push(heat);
    v.push((s, Case::Heated));
    v
}

/// Noise seeds per benchmark state.
pub const SEEDS: u64 = 2;

/// Measures every configuration on the reference build (640×480, 16 px period);
/// `progress(done, total)` after each.
pub fn measure(mut progress: impl FnMut(usize, usize)) -> Vec<Row> {
    let unit = SensorUnit::reference();
    let r = Renderer::new(unit.clone());
    let (reference, _) = r.render(&SkinState::idle(ROOM_C), 5);
    let frames: Vec<_> = bench_set(&unit)
        .into_iter()
        .flat_map(|(s, case)| {
            let imgs: Vec<_> = (0..SEEDS).map(|k| r.render(&s, 70 + k)).collect();
            imgs.into_iter()
                .map(move |(img, truth)| (img, truth, matches_case(&case)))
        })
        .collect();
    let all = configs();
    let mut rows = Vec::new();
    for (k, c) in all.iter().enumerate() {
        let mut calib = Calibration::default_sim();
        if !c.temperature {
            calib.temperature = None;
        }
        let opts = AnalyzerOptions {
            factor: c.factor,
            band: c.band,
            unwrap: c.unwrap,
            rows_only: c.rows_only,
            ..Default::default()
        };
        let sent = |img: &image::RgbImage| sent_as(img, c.encoding);
        let prepared = sent(&reference)
            .and_then(|r| Analyzer::new(&r, calib, c.imp, opts).map_err(|e| e.to_string()));
        let row = match prepared {
            Err(e) => Row {
                config: c.clone(),
                ms: f64::NAN,
                instructions: None,
                depth_error: f64::NAN,
                force_rmse_n: f64::NAN,
                temperature_error_c: None,
                refused: Some(e),
            },
            Ok(a) => score(c, &a, &frames),
        };
        rows.push(row);
        progress(k + 1, all.len());
    }
    rows
}

/// What a frame is scored on (a copy of its case).
#[derive(Clone, Copy)]
enum Scored {
    Press { depth_mm: f32, force_n: f32 },
    Uniform(f32),
    Heated,
}

fn matches_case(c: &Case) -> Scored {
    match *c {
        Case::Press { depth_mm, force_n } => Scored::Press { depth_mm, force_n },
        Case::Uniform(t) => Scored::Uniform(t),
        Case::Heated => Scored::Heated,
    }
}

/// `img` as the camera of `encoding` sends it, decoded as the device decodes it (whole:
/// the benchmark camera is 640 × 480).
fn sent_as(img: &image::RgbImage, encoding: Encoding) -> Result<Decoded, String> {
    encoding.frame(img)?.decode(1).map_err(|e| e.to_string())
}

fn score(c: &Config, a: &Analyzer, frames: &[(image::RgbImage, vistaf_sim::Truth, Scored)]) -> Row {
    let mut times = Vec::new();
    let mut decoded = Decoded::default();
    let (mut depth, mut nd, mut force_sq, mut nf) = (0.0f64, 0usize, 0.0f64, 0usize);
    let (mut temp, mut nt) = (0.0f64, 0usize);
    for (img, truth, case) in frames {
        let Ok(frame) = c.encoding.frame(img) else {
            continue;
        };
        let mut result = None;
        for _ in 0..3 {
            // From the camera's bytes: decoding is part of the cost.
            let t0 = Instant::now();
            let d = frame
                .decode_into(1, &mut decoded)
                .ok()
                .and_then(|()| a.analyze(&decoded).ok());
            times.push(t0.elapsed().as_secs_f64() * 1e3);
            result = d;
        }
        let Some(d) = result else { continue };
        match *case {
            Scored::Press { depth_mm, force_n } => {
                depth += f64::from(
                    (d.peak_depth_mm - truth.peak_depth_mm).abs() / depth_tolerance_mm(depth_mm),
                );
                nd += 1;
                force_sq += f64::from(d.force_n - force_n).powi(2);
                nf += 1;
            }
            Scored::Uniform(t) => {
                if let Some(x) = &d.temperature {
                    temp += f64::from((x.mean_c - t).abs());
                    nt += 1;
                }
            }
            Scored::Heated => {
                if let (Some(x), Some(want)) = (
                    d.temperature.as_ref().and_then(|x| x.contact_c),
                    truth.contact_temp_c,
                ) {
                    temp += f64::from((x - want).abs());
                    nt += 1;
                }
            }
        }
    }
    times.sort_by(f64::total_cmp);
    Row {
        config: c.clone(),
        ms: times.get(times.len() / 2).copied().unwrap_or(f64::NAN),
        instructions: None,
        depth_error: depth / nd.max(1) as f64,
        force_rmse_n: (force_sq / nf.max(1) as f64).sqrt(),
        temperature_error_c: (nt > 0).then(|| temp / nt as f64),
        refused: None,
    }
}

/// Indices of the rows on the Pareto front of (cost, depth error): no other row is both
/// cheaper and more accurate. `cost` picks instructions when every row has them.
pub fn pareto(rows: &[Row], cost: impl Fn(&Row) -> f64) -> Vec<usize> {
    let ok: Vec<usize> = (0..rows.len())
        .filter(|&i| rows[i].refused.is_none() && cost(&rows[i]).is_finite())
        .collect();
    ok.iter()
        .copied()
        .filter(|&i| {
            !ok.iter().any(|&j| {
                j != i
                    && cost(&rows[j]) <= cost(&rows[i])
                    && rows[j].depth_error <= rows[i].depth_error
                    && (cost(&rows[j]) < cost(&rows[i])
                        || rows[j].depth_error < rows[i].depth_error)
            })
        })
        .collect()
}
