//! Stability sweeps: along each axis where a method can fail, error against flag rate.

use vistaf_pipeline::calibration::Calibration;
use vistaf_pipeline::{Analyzer, AnalyzerOptions, Implementation, Measurement};
use vistaf_protocol::Flag;
use vistaf_sim::scene::{ROOM_C, SPHERE_R_MM};
use vistaf_sim::{Renderer, SensorUnit, SkinState};

use super::{depth_tolerance_mm, press, temperature_tolerance_c};

/// One frame of a sweep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    /// The axis value.
    pub x: f32,
    /// Error in units of its tolerance (≤ 1: within tolerance).
    pub error: f32,
    /// Whether the frame carried a relevant flag (or was refused with an error).
    pub flagged: bool,
}

/// A sweep along one axis.
#[derive(Debug, Clone)]
pub struct Sweep {
    /// Short name (file names).
    pub name: &'static str,
    /// What the axis is, with its unit.
    pub axis: &'static str,
    /// What the error measures.
    pub error: &'static str,
    /// The specified envelope along the axis: outside it a flag is expected even where the
    /// reading happens to be right (a temperature beyond the calibration, say).
    pub envelope: (f32, f32),
    /// Frames.
    pub points: Vec<Point>,
}

/// The flag rule's outcome on a sweep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Check {
    /// Frames out of tolerance.
    pub out: usize,
    /// Of those, flagged.
    pub out_flagged: usize,
    /// Frames within tolerance and inside the envelope.
    pub inside: usize,
    /// Of those, flagged.
    pub inside_flagged: usize,
}

impl Check {
    /// Flag rate out of tolerance (1 when there is nothing out of tolerance).
    pub fn recall(&self) -> f32 {
        if self.out == 0 {
            1.0
        } else {
            self.out_flagged as f32 / self.out as f32
        }
    }

    /// False-flag rate within tolerance.
    pub fn false_rate(&self) -> f32 {
        if self.inside == 0 {
            0.0
        } else {
            self.inside_flagged as f32 / self.inside as f32
        }
    }

    /// Whether the rule holds: ≥ 95 % flagged out of tolerance, ≤ 2 % falsely flagged.
    pub fn holds(&self) -> bool {
        self.recall() >= 0.95 && self.false_rate() <= 0.02
    }
}

impl Sweep {
    /// The rule's outcome.
    pub fn check(&self) -> Check {
        let mut c = Check {
            out: 0,
            out_flagged: 0,
            inside: 0,
            inside_flagged: 0,
        };
        for p in &self.points {
            if p.error > 1.0 {
                c.out += 1;
                c.out_flagged += usize::from(p.flagged);
            } else if p.x >= self.envelope.0 && p.x <= self.envelope.1 {
                c.inside += 1;
                c.inside_flagged += usize::from(p.flagged);
            }
        }
        c
    }
}

/// The sweep bench: the reference build cropped to 320×240 (its 16 px period kept), the
/// shipped calibration, the device path.
struct Bench {
    unit: SensorUnit,
    r: Renderer,
    a: Analyzer,
}

impl Bench {
    fn new(unit: SensorUnit) -> Option<Bench> {
        let r = Renderer::new(unit.clone());
        let (reference, _) = r.render(&SkinState::idle(ROOM_C), 11);
        let a = Analyzer::new(
            &reference,
            Calibration::default_sim(),
            Implementation::Fixed,
            AnalyzerOptions {
                force_calibration: true,
                ..Default::default()
            },
        )
        .ok()?;
        Some(Bench { unit, r, a })
    }

    fn run(&self, s: &SkinState, seed: u64) -> (Option<Measurement>, vistaf_sim::Truth) {
        let (img, truth) = self.r.render(s, seed);
        (self.a.analyze(&img).ok(), truth)
    }
}

fn small_unit() -> SensorUnit {
    SensorUnit::reference_sized(320, 240)
}

/// Force-and-shape flags: everything but the temperature's own (out of range, uncertain),
/// which a depth axis does not judge (a washed-out grating reads as heat and says so).
fn shape_flagged(d: &Measurement) -> bool {
    d.flags
        .iter()
        .any(|f| !matches!(f, Flag::TemperatureOutOfRange | Flag::TemperatureUncertain))
}

/// A depth sweep point: peak depth error over its tolerance.
fn depth_point(b: &Bench, x: f32, s: &SkinState, seed: u64) -> Point {
    let (d, truth) = b.run(s, seed);
    match d {
        Some(d) => Point {
            x,
            error: (d.peak_depth_mm - truth.peak_depth_mm).abs()
                / depth_tolerance_mm(truth.peak_depth_mm),
            flagged: shape_flagged(&d),
        },
        None => refused(x),
    }
}

/// Frames per axis value.
pub const SEEDS: u64 = 3;

/// The seeds of axis value `k`: [`SEEDS`] of them, disjoint across values.
fn seeds(k: usize) -> impl Iterator<Item = u64> {
    (0..SEEDS).map(move |i| 1000 * k as u64 + i)
}

/// A frame that could not be analysed at all: an error, not a number.
fn refused(x: f32) -> Point {
    Point {
        x,
        error: f32::INFINITY,
        flagged: true,
    }
}

/// Every sweep; `progress(done, total)` after each axis.
pub fn sweeps(mut progress: impl FnMut(usize, usize)) -> Vec<Sweep> {
    let Some(b) = Bench::new(small_unit()) else {
        return Vec::new();
    };
    let axes: [&dyn Fn() -> Vec<Sweep>; 6] = [
        &|| vec![depth_sweep(&b)],
        &|| vec![steepness_sweep(&b)],
        &|| optics_sweeps(&b),
        &|| vec![misregistration_sweep(&b)],
        &|| vec![temperature_sweep(&b)],
        &|| vec![period_sweep()],
    ];
    let total = 8;
    let mut out = Vec::new();
    for axis in axes {
        for s in axis() {
            out.push(s);
            progress(out.len(), total);
        }
    }
    out
}

/// Indentation depth, past the carrier band.
fn depth_sweep(b: &Bench) -> Sweep {
    let depths = [
        0.1f32, 0.3, 0.6, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0,
    ];
    let mut pts = Vec::new();
    for (k, &d) in depths.iter().enumerate() {
        for seed in seeds(k) {
            pts.push(depth_point(b, d, &press(&b.unit, SPHERE_R_MM, d), seed));
        }
    }
    Sweep {
        name: "depth",
        envelope: (0.1, 2.5),
        axis: "indentation depth, 10 mm sphere (mm)",
        error: "peak depth error / (3 % + 0.02 mm)",
        points: pts,
    }
}

/// Steepness: sharper spheres at 1 mm.
fn steepness_sweep(b: &Bench) -> Sweep {
    let radii = [10.0f32, 6.0, 4.0, 3.0, 2.0, 1.5, 1.0, 0.7, 0.5];
    let mut pts = Vec::new();
    for (k, &r) in radii.iter().enumerate() {
        for seed in seeds(k + 20) {
            pts.push(depth_point(b, 1.0 / r, &press(&b.unit, r, 1.0), seed));
        }
    }
    Sweep {
        name: "steepness",
        envelope: (0.0, 0.2),
        axis: "curvature of a sphere pressed 1 mm (1/radius, 1/mm)",
        error: "peak depth error / (3 % + 0.02 mm)",
        points: pts,
    }
}

/// Sensor noise, fringe contrast and over-exposure: a 1 mm press each.
fn optics_sweeps(b: &Bench) -> Vec<Sweep> {
    /// Name, axis label, envelope, values, and how a value sets the frame's optics.
    type Axis = (
        &'static str,
        &'static str,
        (f32, f32),
        Vec<f32>,
        fn(&mut SkinState, f32),
    );
    let axes: [Axis; 3] = [
        (
            "noise",
            "sensor noise (× the unit's)",
            (1.0, 8.0),
            vec![1.0, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0, 16.0],
            |s, v| s.noise_scale = v,
        ),
        (
            "contrast",
            "fringe contrast (× the unit's)",
            (0.35, 1.0),
            vec![1.0, 0.7, 0.5, 0.35, 0.25, 0.15, 0.1, 0.05],
            |s, v| s.contrast_scale = v,
        ),
        (
            "exposure",
            "exposure (× the unit's)",
            (1.0, 1.6),
            vec![1.0, 1.2, 1.4, 1.6, 1.8, 2.0, 2.5, 3.0],
            |s, v| s.exposure_scale = v,
        ),
    ];
    let mut out = Vec::new();
    for (k, (name, axis, envelope, values, set)) in axes.into_iter().enumerate() {
        let mut pts = Vec::new();
        for (j, &v) in values.iter().enumerate() {
            for seed in seeds(100 * (k + 3) + j) {
                let mut s = press(&b.unit, SPHERE_R_MM, 1.0);
                set(&mut s, v);
                pts.push(depth_point(b, v, &s, seed));
            }
        }
        out.push(Sweep {
            name,
            envelope,
            axis,
            error: "peak depth error / (3 % + 0.02 mm)",
            points: pts,
        });
    }
    out
}

/// Misregistration: the skin shifted against the camera, no contact.
fn misregistration_sweep(b: &Bench) -> Sweep {
    let shifts = [0.0f32, 0.5, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0];
    let mut pts = Vec::new();
    for (k, &sh) in shifts.iter().enumerate() {
        for seed in seeds(700 + k) {
            let mut s = SkinState::idle(ROOM_C);
            s.shift_px = (sh, 0.3 * sh);
            let (d, _) = b.run(&s, seed);
            pts.push(match d {
                Some(d) => Point {
                    x: sh,
                    error: (d.peak_depth_mm / 0.02).max(d.force_n / 0.05),
                    flagged: shape_flagged(&d),
                },
                None => refused(sh),
            });
        }
    }
    Sweep {
        name: "misregistration",
        envelope: (0.0, 6.4),
        axis: "skin shift against the camera, no contact (px; period 16 px)",
        error: "max(depth / 0.02 mm, force / 0.05 N)",
        points: pts,
    }
}

/// Temperature beyond the calibrated range (15–47.5 °C).
fn temperature_sweep(b: &Bench) -> Sweep {
    let temps = [
        5.0f32, 10.0, 13.0, 15.0, 20.0, 27.0, 35.0, 45.0, 50.0, 55.0, 60.0, 65.0,
    ];
    let mut pts = Vec::new();
    for (k, &t) in temps.iter().enumerate() {
        for seed in seeds(800 + k) {
            let (d, _) = b.run(&SkinState::idle(t), seed);
            let read = d
                .as_ref()
                .and_then(|d| d.temperature.as_ref().map(|x| (d, x)));
            pts.push(match read {
                Some((d, temp)) => Point {
                    x: t,
                    error: (temp.mean_c - t).abs() / temperature_tolerance_c(t),
                    flagged: d.flags.contains(Flag::TemperatureOutOfRange),
                },
                None => refused(t),
            });
        }
    }
    Sweep {
        name: "temperature",
        envelope: (15.0, 47.5),
        axis: "uniform skin temperature (°C; calibrated 15–47.5)",
        error: "mean temperature error / tolerance (0.3 °C in 22–32, else 1 °C)",
        points: pts,
    }
}

/// Grating period down to Nyquist: units of ever finer stripes, each with its own
/// reference and the shipped calibration forced onto it.
fn period_sweep() -> Sweep {
    let periods = [16.0f32, 12.0, 9.0, 7.0, 6.0, 5.0, 4.0, 3.0, 2.5];
    let mut pts = Vec::new();
    for (k, &p) in periods.iter().enumerate() {
        let u = SensorUnit {
            period_px: p,
            ..small_unit()
        };
        let bench = Bench::new(u);
        for seed in seeds(900 + k) {
            pts.push(match &bench {
                Some(bb) => depth_point(bb, p, &press(&bb.unit, SPHERE_R_MM, 1.0), seed),
                None => refused(p),
            });
        }
    }
    Sweep {
        name: "period",
        envelope: (5.0, 30.0),
        axis: "grating period in the image (px)",
        error: "peak depth error / (3 % + 0.02 mm), 1 mm press",
        points: pts,
    }
}
