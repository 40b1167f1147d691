//! Colour → temperature models as a calibration file stores them, and their fusion.
//!
//! One polynomial per stripe population, on standardised features (see [`super::lab`]):
//! the coloured stripes' model is precise inside its transition and says nothing outside
//! it; the black stripes' model is wide and coarse. Each carries a table of how far the
//! truth scatters around its estimate, *given the estimate* (measured by cross-validation
//! on the calibration frames): where the colour hardly changes with temperature, or where a
//! model is out of its depth, that scatter is large. The two estimates are blended by the
//! inverse of those variances — the derivative of colour with temperature and the residual
//! noise are both in it — instead of by fixed thresholds.

use serde::{Deserialize, Serialize};

use super::extremes::STAND_OUT_SIGMAS;
use super::lab::Invariants;

/// Largest magnitude of a colour feature or an invariant a model may hold (CIELAB runs
/// to about ±130).
pub const FEATURE_LIMIT: f64 = 1e3;
/// Largest magnitude of a polynomial coefficient, °C.
pub const COEF_LIMIT_C: f64 = 1e4;
/// Largest magnitude of a temperature a model may hold, °C.
pub const TEMPERATURE_LIMIT_C: f64 = 250.0;

/// Whether `v` is finite and within ±`limit`.
fn within(v: f64, limit: f64) -> bool {
    v.is_finite() && v.abs() <= limit
}

/// Whether `s` can be a feature's scale (its block-to-block noise or spread): positive,
/// finite, and neither vanishing nor larger than any feature.
fn plausible_scale(s: f64) -> bool {
    s.is_finite() && (1e-4..=FEATURE_LIMIT).contains(&s)
}

/// Exponents of every monomial of total degree ≤ `degree` in `n` variables, by degree and
/// then lexicographically (the constant first).
pub fn monomials(n: usize, degree: u32) -> Vec<Vec<u32>> {
    let mut out = vec![vec![0; n]];
    for d in 1..=degree {
        let mut cur = vec![0u32; n];
        gen(&mut out, &mut cur, 0, d);
    }
    out
}

fn gen(out: &mut Vec<Vec<u32>>, cur: &mut Vec<u32>, k: usize, left: u32) {
    if k + 1 == cur.len() {
        cur[k] = left;
        out.push(cur.clone());
        cur[k] = 0;
        return;
    }
    for e in (0..=left).rev() {
        cur[k] = e;
        gen(out, cur, k + 1, left - e);
    }
    cur[k] = 0;
}

/// Values of [`monomials`] at standardised features `z`.
pub fn terms(z: &[f64], exps: &[Vec<u32>]) -> Vec<f64> {
    exps.iter()
        .map(|e| z.iter().zip(e).map(|(v, &p)| v.powi(p as i32)).product())
        .collect()
}

/// A polynomial in standardised features.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Polynomial {
    /// Feature names, in order.
    pub features: Vec<String>,
    /// Feature means of the training samples.
    pub mean: Vec<f64>,
    /// Feature standard deviations of the training samples.
    pub std: Vec<f64>,
    /// Total degree.
    pub degree: u32,
    /// Coefficients, one per monomial of [`monomials`], °C.
    pub coef: Vec<f64>,
}

impl Polynomial {
    /// Standardised features.
    pub fn standardise(&self, x: &[f64]) -> Vec<f64> {
        x.iter()
            .zip(self.mean.iter().zip(&self.std))
            .map(|(v, (m, s))| (v - m) / s)
            .collect()
    }

    /// The polynomial at raw features `x`, °C.
    pub fn eval(&self, x: &[f64]) -> f64 {
        let z = self.standardise(x);
        terms(&z, &monomials(z.len(), self.degree))
            .iter()
            .zip(&self.coef)
            .map(|(t, c)| t * c)
            .sum()
    }

    /// Whether the stored shapes agree with each other and every number is one a colour
    /// model can have (features in CIELAB units, coefficients in °C).
    pub fn is_consistent(&self) -> bool {
        let n = self.features.len();
        n > 0
            && self.mean.len() == n
            && self.std.len() == n
            && self.std.iter().all(|s| plausible_scale(*s))
            && self.degree <= 4
            && self.coef.len() == monomials(n, self.degree).len()
            && self.mean.iter().all(|v| within(*v, FEATURE_LIMIT))
            && self.coef.iter().all(|v| within(*v, COEF_LIMIT_C))
    }

    /// The equation as text, in the standardised features `z_name = (name − μ)/σ`.
    pub fn equation(&self) -> String {
        let exps = monomials(self.features.len(), self.degree);
        let mut s = String::from("T_c =");
        for (c, e) in self.coef.iter().zip(&exps) {
            let mut term = format!(" {} {:.6}", if *c < 0.0 { '-' } else { '+' }, c.abs());
            for (name, &p) in self.features.iter().zip(e) {
                match p {
                    0 => {}
                    1 => term.push_str(&format!("·z_{name}")),
                    p => term.push_str(&format!("·z_{name}^{p}")),
                }
            }
            s.push_str(&term);
        }
        let scalers: Vec<String> = self
            .features
            .iter()
            .zip(self.mean.iter().zip(&self.std))
            .map(|(n, (m, sd))| format!("z_{n} = ({n} − {m:.6})/{sd:.6}"))
            .collect();
        format!("{s}; {}", scalers.join(", "))
    }
}

/// The calibration curve: the per-setpoint mean features as knots, joined by straight
/// segments. A block reads the temperature of the nearest point on the curve (distance in
/// units of each feature's block-to-block noise; the segments searched are those at the
/// two nearest knots and the two end segments), linear beyond the end segments. The end
/// segments are always searched: a colour beyond the calibrated range lies past an end,
/// and its nearest knots may belong to the other end of a curve that bends back towards
/// its start. It has as many parameters as knots × features, so the parsimony rule only
/// takes it when the polynomials cannot follow the colour's path.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Curve {
    /// Feature names, in order.
    pub features: Vec<String>,
    /// Block-to-block noise of each feature (the distance scale).
    pub scale: Vec<f64>,
    /// Setpoints of the knots, °C, increasing.
    pub t_c: Vec<f64>,
    /// Mean features at each setpoint.
    pub knots: Vec<Vec<f64>>,
}

impl Curve {
    /// Temperature of the nearest point on the end segments and on those that meet at the
    /// two nearest knots (on a curve sampled as finely as a calibration's, the nearest point
    /// of all), °C.
    pub fn eval(&self, x: &[f64]) -> f64 {
        let n = self.t_c.len();
        if n < 2 {
            return self.t_c.first().copied().unwrap_or(f64::NAN);
        }
        let dist2 = |k: usize| -> f64 {
            x.iter()
                .zip(&self.knots[k])
                .zip(&self.scale)
                .map(|((v, c), s)| ((v - c) / s).powi(2))
                .sum()
        };
        // The two nearest knots, the segments meeting at either, and the end segments.
        let (mut k1, mut k2) = ((f64::INFINITY, 0usize), (f64::INFINITY, 0usize));
        for k in 0..n {
            let d = dist2(k);
            if d < k1.0 {
                k2 = k1;
                k1 = (d, k);
            } else if d < k2.0 {
                k2 = (d, k);
            }
        }
        let mut segments: Vec<usize> = [k1.1, k2.1]
            .iter()
            .flat_map(|&k| [k.saturating_sub(1), k.min(n - 2)])
            .chain([0, n - 2])
            .collect();
        segments.sort_unstable();
        segments.dedup();
        // Each searched segment's nearest point, then their likelihood-weighted mean
        // (weight e^{−Δd/2} for a squared distance Δd in σ² beyond the nearest): where a
        // block sits on the inner side of a bend, two segments are about equally near and
        // the reading moves smoothly between them instead of jumping.
        let mut found: Vec<(f64, f64)> = Vec::with_capacity(4);
        for k in segments {
            let (a, b) = (&self.knots[k], &self.knots[k + 1]);
            let (mut ab, mut ax, mut bb) = (0.0, 0.0, 0.0);
            for j in 0..x.len() {
                let s = self.scale[j];
                let (d, e) = ((b[j] - a[j]) / s, (x[j] - a[j]) / s);
                ab += d * e;
                bb += d * d;
                ax += e * e;
            }
            let mut u = if bb > 0.0 { ab / bb } else { 0.0 };
            let lo = if k == 0 { f64::NEG_INFINITY } else { 0.0 };
            let hi = if k == n - 2 { f64::INFINITY } else { 1.0 };
            u = u.clamp(lo, hi);
            let dist = ax - 2.0 * u * ab + u * u * bb;
            found.push((dist, self.t_c[k] + u * (self.t_c[k + 1] - self.t_c[k])));
        }
        let best = found.iter().map(|f| f.0).fold(f64::INFINITY, f64::min);
        let (mut sw, mut st) = (0.0, 0.0);
        for (d, t) in found {
            let w = softmin_weight(d - best);
            sw += w;
            st += w * t;
        }
        if sw > 0.0 {
            st / sw
        } else {
            f64::NAN
        }
    }

    /// Whether the stored shapes agree with each other and every number is one a colour
    /// curve can have.
    pub fn is_consistent(&self) -> bool {
        let n = self.features.len();
        n > 0
            && self.scale.len() == n
            && self.scale.iter().all(|s| plausible_scale(*s))
            && self.t_c.len() >= 2
            && self.t_c.windows(2).all(|w| w[1] > w[0])
            && self.t_c.iter().all(|t| within(*t, TEMPERATURE_LIMIT_C))
            && self.knots.len() == self.t_c.len()
            && self
                .knots
                .iter()
                .all(|k| k.len() == n && k.iter().all(|v| within(*v, FEATURE_LIMIT)))
    }

    /// The model as text.
    pub fn equation(&self) -> String {
        let knots: Vec<String> = self
            .t_c
            .iter()
            .zip(&self.knots)
            .map(|(t, k)| {
                let f: Vec<String> = k.iter().map(|v| format!("{v:.4}")).collect();
                format!("{t}: ({})", f.join(", "))
            })
            .collect();
        let scale: Vec<String> = self
            .features
            .iter()
            .zip(&self.scale)
            .map(|(n, s)| format!("σ_{n} = {s:.5}"))
            .collect();
        format!(
            "T_c = temperature of the nearest point on the piecewise-linear curve through \
             ({}) at each setpoint, distances scaled by {}; knots {}",
            self.features.join(", "),
            scale.join(", "),
            knots.join("; ")
        )
    }
}

/// Squared distances (σ²) beyond the nearest at which a segment's weight is cut to zero.
pub const SOFTMIN_CUT: f64 = 32.0;

/// Weight of a segment `delta` σ² farther than the nearest: `e^{−delta/2}`, zero beyond
/// [`SOFTMIN_CUT`] (the device tabulates it over that span).
pub fn softmin_weight(delta: f64) -> f64 {
    if (0.0..SOFTMIN_CUT).contains(&delta) {
        (-delta / 2.0).exp()
    } else if delta < 0.0 {
        1.0
    } else {
        0.0
    }
}

/// A population's colour → temperature model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum ColourModel {
    /// A polynomial in standardised features.
    Polynomial(Polynomial),
    /// The calibration curve.
    Curve(Curve),
}

impl ColourModel {
    /// Temperature at raw features `x`, °C.
    pub fn eval(&self, x: &[f64]) -> f64 {
        match self {
            ColourModel::Polynomial(p) => p.eval(x),
            ColourModel::Curve(c) => c.eval(x),
        }
    }

    /// Feature names.
    pub fn features(&self) -> &[String] {
        match self {
            ColourModel::Polynomial(p) => &p.features,
            ColourModel::Curve(c) => &c.features,
        }
    }

    /// Whether the stored shapes agree with each other.
    pub fn is_consistent(&self) -> bool {
        match self {
            ColourModel::Polynomial(p) => p.is_consistent(),
            ColourModel::Curve(c) => c.is_consistent(),
        }
    }

    /// The model as text.
    pub fn equation(&self) -> String {
        match self {
            ColourModel::Polynomial(p) => p.equation(),
            ColourModel::Curve(c) => c.equation(),
        }
    }
}

/// A population's mean squared error per block as a function of the temperature: bins of
/// `step_c` from `t0_c`; outside the table, [`VarianceTable::UNKNOWN_C2`].
///
/// It is indexed by the true temperature (in calibration, the setpoint) and read at the
/// black stripes' estimate, the only one valid over the whole range: a coloured stripe
/// below or above its transition shows the same colour whatever the temperature, so its
/// own estimate sits at the transition's edge, where its error says nothing about how far
/// outside the truth is.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VarianceTable {
    /// Centre of the first bin, °C.
    pub t0_c: f64,
    /// Bin width, °C.
    pub step_c: f64,
    /// Mean squared error of the estimate per bin, °C².
    pub var_c2: Vec<f64>,
}

impl VarianceTable {
    /// Variance outside the table: the estimate says nothing (a 1000 °C deviation, so its
    /// weight in a fusion vanishes).
    pub const UNKNOWN_C2: f64 = 1e6;

    /// Variance of a bin with (almost) no samples: a 10 °C deviation.
    pub const SPARSE_C2: f64 = 100.0;

    /// Variance at temperature `t`, linear between bin centres. Over the outer half of the
    /// end bins the weight (1/variance) falls linearly to zero, so an estimate crossing the
    /// table's edge loses its say gradually and the fusion stays continuous.
    pub fn at(&self, t: f64) -> f64 {
        let n = self.var_c2.len();
        if n == 0 || !t.is_finite() {
            return Self::UNKNOWN_C2;
        }
        let x = (t - self.t0_c) / self.step_c;
        let last = (n - 1) as f64;
        let beyond = if x < 0.0 {
            -x
        } else if x > last {
            x - last
        } else {
            0.0
        };
        if beyond >= 0.5 {
            return Self::UNKNOWN_C2;
        }
        let x = x.clamp(0.0, last);
        let k = (x.floor() as usize).min(n - 1);
        let f = x - k as f64;
        let next = self.var_c2[(k + 1).min(n - 1)];
        let v = self.var_c2[k] * (1.0 - f) + next * f;
        (v / (1.0 - 2.0 * beyond)).min(Self::UNKNOWN_C2)
    }

    /// Whether the table is usable.
    pub fn is_consistent(&self) -> bool {
        self.step_c >= 1e-3
            && self.step_c <= 100.0
            && within(self.t0_c, TEMPERATURE_LIMIT_C)
            && self.var_c2.len() <= 100_000
            && self
                .var_c2
                .iter()
                .all(|v| v.is_finite() && *v > 0.0 && *v <= Self::UNKNOWN_C2)
    }
}

/// One stripe population's model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PopulationModel {
    /// The chosen model.
    pub model: ColourModel,
    /// The model as text.
    pub equation: String,
    /// Setpoints the model was fitted on, °C (lowest, highest).
    pub fit_range_c: [f64; 2],
    /// Scatter of the truth around the estimate.
    pub variance: VarianceTable,
    /// Leave-one-setpoint-out RMSE of per-setpoint means inside `fit_range_c`, °C.
    pub cv_rmse_c: f64,
    /// In-sample RMSE of per-setpoint means inside `fit_range_c`, °C.
    pub in_sample_rmse_c: f64,
    /// Every candidate tried.
    pub candidates: Vec<crate::evidence::CandidateScore>,
}

/// Where the invariants of the calibration frames lay: the device's look-up table covers
/// this box.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Domain {
    /// Invariant r, the coloured-over-black chromaticity (lowest, highest).
    pub r: [f64; 2],
    /// Invariant g.
    pub g: [f64; 2],
    /// Invariant q, the black over the coloured.
    pub q: [f64; 2],
}

impl Domain {
    /// Whether `v` lies in the box.
    pub fn contains(&self, v: &Invariants) -> bool {
        let inr = |x: f64, r: [f64; 2]| x >= r[0] && x <= r[1];
        inr(v.r, self.r) && inr(v.g, self.g) && inr(v.q, self.q)
    }
}

/// Held-out error of the fused estimate at one setpoint.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SetpointError {
    /// Setpoint, °C.
    pub setpoint_c: f64,
    /// Mean fused estimate with this setpoint left out of both fits, °C.
    pub estimate_c: f64,
}

/// What the skin's mean read at one setpoint of the kit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MeanRead {
    /// Setpoint, °C.
    pub setpoint_c: f64,
    /// The mean over the skin's blocks of their fused readings, averaged over the
    /// setpoint's frames, °C.
    pub read_c: f64,
}

impl MeanRead {
    /// The skin temperature a mean `read_c` stands for on the line through `a` and `b`, °C.
    pub fn setpoint_at(a: &MeanRead, b: &MeanRead, read_c: f64) -> f64 {
        a.setpoint_c + (b.setpoint_c - a.setpoint_c) * (read_c - a.read_c) / (b.read_c - a.read_c)
    }
}

/// Colour → temperature: both populations, fused.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TemperatureModel {
    /// Coloured stripes (features a*, b*).
    pub coloured: PopulationModel,
    /// Black stripes (features L* against the coloured white, a*, b*).
    pub black: PopulationModel,
    /// Calibrated setpoints, °C (lowest, highest): estimates outside are flagged.
    pub range_c: [f64; 2],
    /// The warmest setpoint the camera could see, °C, when the kit went warmer and the
    /// camera clipped every frame there: the cleared pigment and the lamps' reflections
    /// reached full scale. A skin warmer than this reads near it, whatever its temperature,
    /// so a reading that reaches it (within two standard deviations and half a degree) is
    /// flagged as out of range. `None` when the camera saw the whole kit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub blind_above_c: Option<f64>,
    /// Invariants seen in calibration, widened by half their span on each side (the
    /// stripes of a steep indentation mix a little more than any calibration frame's).
    pub domain: Domain,
    /// Per-setpoint means of the fused estimate, leave-one-setpoint-out.
    pub held_out: Vec<SetpointError>,
    /// RMSE of `held_out` inside 22–32 °C and over the whole range, °C.
    pub cv_rmse_transition_c: f64,
    /// See `cv_rmse_transition_c`.
    pub cv_rmse_c: f64,
    /// Calibration blocks used.
    pub n: usize,
    /// The skin's mean as the service reads it at each setpoint, in order, each rising
    /// from the one before by at least [`MEAN_READ_MIN_SLOPE`] per °C
    /// ([`TemperatureModel::skin_mean_c`]). Empty in files written before it.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub mean_read: Vec<MeanRead>,
    /// How far a place departed from the skin on the kit's uniform frames at each
    /// setpoint, in order ([`TemperatureModel::stand_out_sigmas`]). Empty in files written
    /// before it.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub stand_out: Vec<StandOut>,
    /// How far the skin's mean, read on the kit's uniform frames, moved at each setpoint
    /// when another of those frames served as the reference, in order
    /// ([`TemperatureModel::reference_shift_c`]). Empty in files written before it.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub reference_shift: Vec<ReferenceShift>,
    /// How far a press moves the contact's chromaticity (`r`, `g`) from the skin's,
    /// relative: the RMS over the kit's trusted presses, whose skin is at one temperature
    /// throughout, so that the press alone moves it. The camera's blur and its chroma
    /// compression act on stripes that a press squeezes, which flat frames never show. A
    /// contact's reading carries this scatter in its variance
    /// ([`super::Temperatures::read_contact`]). Zero where it was not measured (files
    /// written before it, or a kit with fewer than [`CHROMA_SPREAD_MIN_PRESSES`] presses).
    #[serde(default, skip_serializing_if = "is_zero_pair")]
    pub contact_chroma_spread: [f64; 2],
}

/// Fewest trusted presses of the kit that measure [`TemperatureModel::contact_chroma_spread`].
pub const CHROMA_SPREAD_MIN_PRESSES: usize = 3;

/// Largest [`TemperatureModel::contact_chroma_spread`] a calibration file may hold: a
/// chromaticity moved by half of itself is no colour the models read.
pub const CHROMA_SPREAD_LIMIT: f64 = 0.5;

fn is_zero_pair(v: &[f64; 2]) -> bool {
    *v == [0.0; 2]
}

/// The largest departure of a place from the skin on the kit's uniform frames at one
/// setpoint ([`super::extremes::departures_sigmas`], either way, over the
/// setpoint's frames).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StandOut {
    /// Setpoint, °C.
    pub setpoint_c: f64,
    /// The departure, in standard deviations of a place at the skin's temperature.
    pub sigmas: f64,
}

/// How far the skin's mean, read on the kit's uniform frames at one setpoint, moved when
/// another of the kit's uniform frames served as the reference (the largest move over the
/// references tried).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ReferenceShift {
    /// Setpoint, °C.
    pub setpoint_c: f64,
    /// The move, °C (not negative).
    pub shift_c: f64,
}

/// The largest move a calibration file may hold in [`TemperatureModel::reference_shift`],
/// °C: beyond any range a pigment covers.
pub const REFERENCE_SHIFT_LIMIT_C: f64 = 100.0;

/// The largest departure a calibration file may hold in [`TemperatureModel::stand_out`],
/// standard deviations: far beyond any kit's, short of overflowing what it multiplies.
pub const STAND_OUT_LIMIT: f64 = 1e3;

/// Whether a table of [`StandOut`] holds finite setpoints in increasing order, each with a
/// departure within 0…[`STAND_OUT_LIMIT`].
pub fn stand_out_ordered(table: &[StandOut]) -> bool {
    ordered(table, |p| (p.setpoint_c, p.sigmas), STAND_OUT_LIMIT)
}

/// Whether a table of [`ReferenceShift`] holds finite setpoints in increasing order, each
/// with a move within 0…[`REFERENCE_SHIFT_LIMIT_C`].
pub fn reference_shift_ordered(table: &[ReferenceShift]) -> bool {
    ordered(
        table,
        |p| (p.setpoint_c, p.shift_c),
        REFERENCE_SHIFT_LIMIT_C,
    )
}

/// Whether `table`'s (setpoint, value) pairs (`read`) hold finite setpoints in increasing
/// order, each with a value within 0…`limit`.
fn ordered<P>(table: &[P], read: impl Fn(&P) -> (f64, f64), limit: f64) -> bool {
    let pairs: Vec<(f64, f64)> = table.iter().map(read).collect();
    pairs
        .iter()
        .all(|&(s, v)| s.is_finite() && (0.0..=limit).contains(&v))
        && pairs.windows(2).all(|w| w[0].0 < w[1].0)
}

/// How far beyond the largest departure its kit's uniform frames showed a place must
/// depart to stand out on a unit's skin, as a factor: a frame in use drifts in exposure
/// and white balance, which the kit's frames at one setpoint share, and the kit holds only
/// a few frames per setpoint.
pub const STAND_OUT_MARGIN: f64 = 1.25;

/// Least rise of the skin's mean read per °C of setpoint for [`TemperatureModel::mean_read`]
/// to stand: where it rises less, turning it back would magnify the mean's noise by more
/// than four.
pub const MEAN_READ_MIN_SLOPE: f64 = 0.25;

/// One block's reading.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// Fused temperature, °C.
    pub t_c: f64,
    /// Its variance, °C².
    pub var_c2: f64,
    /// The coloured stripes' estimate, °C.
    pub coloured_c: f64,
    /// The black stripes' estimate, °C.
    pub black_c: f64,
}

/// The blend of a coloured (`tc`) and a black (`tb`) estimate, °C and °C²: each
/// population's variance ([`VarianceTable`], indexed by temperature) is read at `guess` (a
/// black estimate: the block's own, or its neighbourhood's), the two are fused by inverse
/// variance, and the variances are read again at that result and fused once more. The
/// second pass lets a coloured stripe inside its transition have its say when the black
/// stripes, coarse and sometimes biased there by a degree, put the guess at the
/// transition's edge; outside the transition the coloured table has no entry and the
/// result stays the black estimate.
pub fn blend(
    coloured: &VarianceTable,
    black: &VarianceTable,
    tc: f64,
    tb: f64,
    guess: f64,
) -> (f64, f64) {
    let (t, _) = fuse(tc, coloured.at(guess), tb, black.at(guess));
    fuse(tc, coloured.at(t), tb, black.at(t))
}

/// Whether `m` holds finite temperatures, each point rising from the one before by at least
/// [`MEAN_READ_MIN_SLOPE`] per °C.
pub fn mean_read_rises(m: &[MeanRead]) -> bool {
    m.iter()
        .all(|p| within(p.setpoint_c, TEMPERATURE_LIMIT_C) && within(p.read_c, TEMPERATURE_LIMIT_C))
        && m.windows(2).all(|w| {
            let step = w[1].setpoint_c - w[0].setpoint_c;
            step > 0.0 && w[1].read_c - w[0].read_c >= MEAN_READ_MIN_SLOPE * step
        })
}

/// The value at `t` (°C) of `points` in setpoint order, each read as (setpoint, value) by
/// `read`: linear between setpoints, the nearest end's beyond them (the later of two at one
/// setpoint); `None` without points or for a `t` that is not a number.
fn along_setpoints<P>(points: &[P], read: impl Fn(&P) -> (f64, f64), t: f64) -> Option<f64> {
    if t.is_nan() {
        return None;
    }
    let k = points.partition_point(|p| read(p).0 < t);
    let last = points.len().checked_sub(1)?;
    let (s1, v1) = read(&points[k.min(last)]);
    if k == 0 || k > last {
        return Some(v1);
    }
    let (s0, v0) = read(&points[k - 1]);
    if s1 <= s0 {
        return Some(v1);
    }
    Some(v0 + (v1 - v0) * (t - s0) / (s1 - s0))
}

/// Inverse-variance blend of two estimates.
pub fn fuse(a: f64, va: f64, b: f64, vb: f64) -> (f64, f64) {
    let (wa, wb) = (1.0 / va.max(1e-6), 1.0 / vb.max(1e-6));
    ((a * wa + b * wb) / (wa + wb), 1.0 / (wa + wb))
}

/// Largest standard deviation the range check allows a reading, °C.
pub const OUT_OF_RANGE_SIGMA_C: f64 = 1.0;

/// Which stripe population.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Population {
    /// Coloured stripes: read per block.
    Coloured,
    /// Black stripes: read over a block's neighbourhood (see [`super::BLACK_POOL`]).
    Black,
}

impl TemperatureModel {
    /// One population's estimate (°C) from a block's invariants.
    pub fn population(&self, p: Population, v: &Invariants) -> f64 {
        match p {
            Population::Coloured => self.coloured.model.eval(&v.coloured_features()),
            Population::Black => self.black.model.eval(&v.black_features()),
        }
    }

    /// See [`blend`].
    pub fn blend(&self, tc: f64, tb: f64, guess: f64) -> (f64, f64) {
        blend(&self.coloured.variance, &self.black.variance, tc, tb, guess)
    }

    /// The float reference: exact CIELAB features, both models, fused. `own` are the
    /// block's invariants, `pooled` those of its neighbourhood.
    pub fn estimate(&self, own: &Invariants, pooled: &Invariants) -> Estimate {
        let tc = self.population(Population::Coloured, own);
        let tb = self.population(Population::Black, pooled);
        let (t, var) = self.blend(tc, tb, tb);
        Estimate {
            t_c: t,
            var_c2: var,
            coloured_c: tc,
            black_c: tb,
        }
    }

    /// Whether `t` (variance `var`) lies confidently outside the calibrated range: more
    /// than two standard deviations beyond it, with half a degree of slack. The deviation
    /// is capped at [`OUT_OF_RANGE_SIGMA_C`]: beyond the calibration no sample says how
    /// wide it is, and a wide guess must not hide a reading far outside.
    ///
    /// Below [`TemperatureModel::blind_above_c`] the reverse holds as well: a reading that
    /// reaches within half a degree of it may stand for any warmer skin.
    pub fn out_of_range(&self, t: f64, var: f64) -> bool {
        let two_sigma = 2.0 * var.max(0.0).sqrt().min(OUT_OF_RANGE_SIGMA_C);
        !t.is_finite()
            || t - two_sigma > self.range_c[1] + 0.5
            || t + two_sigma < self.range_c[0] - 0.5
            || self.blind_above_c.is_some_and(|b| t + two_sigma >= b - 0.5)
    }

    /// The skin temperature a mean of the map's blocks `read_c` stands for (°C), through
    /// [`TemperatureModel::mean_read`]: linear between its setpoints; beyond them shifted
    /// by the nearest end's offset, faded out over the end step's width; `read_c` itself
    /// without a table.
    ///
    /// A block's reading is unbiased block by block only in the colours' own noise: where
    /// a population's colour hardly moves (the coloured stripes past their transition, the
    /// black stripes where their path doubles back), a block's noise moves its estimate
    /// along the temperature more one way than the other, and the blend leans on the
    /// coloured stripes wherever a block's black estimate falls inside their transition.
    /// Each block's error is within its variance, but a mean over hundreds of blocks keeps
    /// what they share. The kit's uniform frames show it at each setpoint, as read.
    pub fn skin_mean_c(&self, read_c: f64) -> f64 {
        let m = &self.mean_read;
        let (Some(first), Some(last)) = (m.first(), m.last()) else {
            return read_c;
        };
        let k = m.partition_point(|p| p.read_c <= read_c);
        if k == 0 || k == m.len() {
            // Beyond the table the mean did not rise (or the kit ended): its end's offset
            // fades out over the end step's width, and the mean is reported as read.
            let (end, inner) = if k == 0 {
                (first, m.get(1))
            } else {
                (last, m.len().checked_sub(2).and_then(|i| m.get(i)))
            };
            let width = inner.map_or(1.0, |p| (p.setpoint_c - end.setpoint_c).abs());
            let fade = (1.0 - (read_c - end.read_c).abs() / width.max(1e-9)).max(0.0);
            return read_c + fade * (end.setpoint_c - end.read_c);
        }
        MeanRead::setpoint_at(&m[k - 1], &m[k], read_c)
    }

    /// By how many standard deviations of its noise a place must depart from a skin at
    /// `skin_c` (°C) to be its coldest or hottest place: [`STAND_OUT_SIGMAS`], or
    /// [`STAND_OUT_MARGIN`] times the largest departure the kit's uniform frames showed
    /// there ([`TemperatureModel::stand_out`], linear between setpoints, the end's
    /// beyond), where that is more.
    ///
    /// The noise of a neighbourhood's median assumes its blocks' errors independent beyond
    /// the cells that share a black-stripe estimate. Where the colours hardly move (above
    /// the coloured stripes' transition), a uniform skin's readings wander together over
    /// many blocks, with the light across the view: its places depart further than
    /// independent noise would take them, and its own kit shows how far.
    pub fn stand_out_sigmas(&self, skin_c: f64) -> f32 {
        let kit = along_setpoints(&self.stand_out, |p| (p.setpoint_c, p.sigmas), skin_c);
        (STAND_OUT_MARGIN * kit.unwrap_or(0.0)).max(f64::from(STAND_OUT_SIGMAS)) as f32
    }

    /// How far the calibration's own held-out test missed near `t` (°C): the absolute
    /// error of the per-setpoint means with that setpoint left out of both fits
    /// ([`TemperatureModel::held_out`]), linear between setpoints and the end setpoint's
    /// beyond them; 0 without any. A systematic miss no block's scatter shows: a colour
    /// path the models could not follow there, a setpoint the kit's frames misread.
    pub fn held_out_error_c(&self, t: f64) -> f64 {
        let miss = |e: &SetpointError| (e.setpoint_c, (e.estimate_c - e.setpoint_c).abs());
        along_setpoints(&self.held_out, miss, t).unwrap_or(0.0)
    }

    /// The most the held-out test missed a setpoint by among those it read within
    /// `window_c` of `reading_c` (°C); 0 where it read none there. [`Self::held_out_error_c`]
    /// looks a miss up by the skin's temperature, which a reading stands for only where
    /// the reading is right: a colour path the models compress carries skins of several
    /// degrees to one reading, away from their own setpoints. A reading near where a
    /// missed setpoint read may be that skin's (`thermal::HELD_OUT_FAILED_C`).
    pub fn held_out_miss_read_near_c(&self, reading_c: f64, window_c: f64) -> f64 {
        (self.held_out.iter())
            .filter(|e| (e.estimate_c - reading_c).abs() <= window_c)
            .map(|e| (e.estimate_c - e.setpoint_c).abs())
            .fold(0.0, f64::max)
    }

    /// How far the skin's mean moved near `t` (°C) when the kit's frames were read against
    /// another of its uniform frames as the reference ([`TemperatureModel::reference_shift`],
    /// linear between setpoints and the end setpoint's beyond them); 0 without any. The
    /// reference a unit is used with is taken at whatever temperature the skin rests at,
    /// rarely the kit reference's: where the light's pattern in the stripes' ratio
    /// ([`super::ratio_field`]) changes with the pigment's colour, the reading follows the
    /// reference's temperature by as much.
    pub fn reference_shift_c(&self, t: f64) -> f64 {
        let shift = |p: &ReferenceShift| (p.setpoint_c, p.shift_c);
        along_setpoints(&self.reference_shift, shift, t).unwrap_or(0.0)
    }

    /// Whether the stored shapes agree with each other.
    pub fn is_consistent(&self) -> bool {
        let pop = |p: &PopulationModel| p.model.is_consistent() && p.variance.is_consistent();
        pop(&self.coloured)
            && pop(&self.black)
            && self.coloured.model.features().len() == 3
            && self.black.model.features().len() == 3
            && self.range_c[0] < self.range_c[1]
            && self.blind_above_c.is_none_or(|b| b.is_finite())
            && [self.domain.r, self.domain.g, self.domain.q]
                .iter()
                .all(|r| within(r[0], FEATURE_LIMIT) && within(r[1], FEATURE_LIMIT) && r[0] < r[1])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shipped calibration's temperature model.
    fn default_model() -> TemperatureModel {
        crate::calibration::Calibration::default_sim()
            .temperature
            .unwrap_or_else(|| unreachable!("the default calibration has a temperature model"))
    }

    /// What the kit's mean read (`read`) at setpoint `t`.
    fn mean_at(t: f64, read: f64) -> MeanRead {
        MeanRead {
            setpoint_c: t,
            read_c: read,
        }
    }

    /// The held-out miss between and beyond the setpoints.
    #[test]
    fn the_held_out_miss_is_read_between_setpoints() {
        let mut m = default_model();
        let at = |t: f64, e: f64| SetpointError {
            setpoint_c: t,
            estimate_c: t + e,
        };
        m.held_out = vec![at(20.0, 0.2), at(30.0, -2.2), at(40.0, 0.5)];
        let close = |a: f64, b: f64| (a - b).abs() < 1e-9;
        assert!(close(m.held_out_error_c(10.0), 0.2));
        assert!(close(m.held_out_error_c(25.0), 1.2));
        assert!(close(m.held_out_error_c(30.0), 2.2));
        assert!(close(m.held_out_error_c(38.0), 0.84));
        assert!(close(m.held_out_error_c(50.0), 0.5));
        m.held_out.clear();
        assert_eq!(m.held_out_error_c(30.0), 0.0);
    }

    /// The skin's mean is turned back through what the kit's uniform frames read: between
    /// setpoints linearly, beyond them by the nearest end's offset fading out over the end
    /// step, as read without a table.
    #[test]
    fn the_skins_mean_is_read_back_through_the_kits_means() {
        let mut m = default_model();
        // A warm skin read low where a population's colour hardly moves.
        m.mean_read = vec![
            mean_at(30.0, 30.1),
            mean_at(35.0, 34.0),
            mean_at(40.0, 39.6),
        ];
        let close = |a: f64, b: f64| (a - b).abs() < 1e-9;
        assert!(close(m.skin_mean_c(34.0), 35.0));
        assert!(close(m.skin_mean_c(32.05), 32.5));
        assert!(close(m.skin_mean_c(30.1), 30.0));
        assert!(
            close(m.skin_mean_c(29.6), 29.51),
            "below: the first offset…"
        );
        assert!(
            close(m.skin_mean_c(27.6), 27.55),
            "…fading out over the end step…"
        );
        assert!(close(m.skin_mean_c(25.0), 25.0), "…to the mean as read");
        assert!(close(m.skin_mean_c(42.1), 42.3), "above, the same");
        assert!(close(m.skin_mean_c(46.0), 46.0));
        m.mean_read.clear();
        assert!(close(m.skin_mean_c(34.0), 34.0));
    }

    /// A table of the mean stands only where the mean rises steadily with the setpoint:
    /// turned back, a flat step would magnify the mean's noise without bound.
    #[test]
    fn a_mean_that_does_not_rise_makes_no_table() {
        assert!(mean_read_rises(&[]));
        assert!(mean_read_rises(&[mean_at(20.0, 20.3), mean_at(22.0, 21.0)]));
        assert!(!mean_read_rises(&[
            mean_at(20.0, 20.3),
            mean_at(22.0, 20.4)
        ]));
        assert!(!mean_read_rises(&[
            mean_at(20.0, 20.3),
            mean_at(20.0, 21.0)
        ]));
        assert!(!mean_read_rises(&[mean_at(20.0, f64::NAN)]));
    }

    /// Out of range: beyond the calibrated setpoints by two (capped) deviations and half a
    /// degree, or, on a camera blind above some setpoint, reaching it.
    #[test]
    fn a_reading_that_reaches_what_the_camera_could_not_see_is_out_of_range() {
        let mut m = default_model();
        m.range_c = [15.0, 47.5];
        assert!(!m.out_of_range(30.0, 0.04) && !m.out_of_range(48.0, 0.04));
        assert!(m.out_of_range(48.5, 0.04) && m.out_of_range(14.0, 0.04));
        m.blind_above_c = Some(31.0);
        // 30 °C ± 0.2: 30.4 stays below 30.5; ± 0.3 reaches it.
        assert!(!m.out_of_range(30.0, 0.04));
        assert!(m.out_of_range(30.0, 0.09));
        assert!(m.out_of_range(30.6, 0.0) && m.out_of_range(40.0, 0.0));
        assert!(
            !m.out_of_range(20.0, 25.0),
            "the deviation is capped at 1 °C"
        );
    }

    #[test]
    fn monomials_count_and_order() {
        assert_eq!(monomials(2, 1), vec![vec![0, 0], vec![1, 0], vec![0, 1]]);
        assert_eq!(monomials(2, 3).len(), 10);
        assert_eq!(monomials(3, 3).len(), 20);
        assert_eq!(monomials(4, 3).len(), 35);
    }

    #[test]
    fn curve_reads_the_nearest_segment_and_extrapolates_at_the_ends() {
        // Noise far below the segments' length: the nearest segment alone decides.
        let c = Curve {
            features: vec!["x".into(), "y".into()],
            scale: vec![0.01, 0.01],
            t_c: vec![10.0, 20.0, 30.0],
            knots: vec![vec![0.0, 0.0], vec![1.0, 0.0], vec![1.0, 1.0]],
        };
        assert!(c.is_consistent());
        assert!((c.eval(&[0.5, 0.1]) - 15.0).abs() < 1e-9);
        assert!((c.eval(&[1.1, 0.5]) - 25.0).abs() < 1e-9);
        assert!((c.eval(&[1.0, 2.0]) - 40.0).abs() < 1e-9);
        assert!((c.eval(&[-1.0, 0.0]) - 0.0).abs() < 1e-9);
        // Noise as large as the segments: near the bend both segments count.
        let wide = Curve {
            scale: vec![1.0, 1.0],
            ..c
        };
        let t = wide.eval(&[0.9, 0.1]);
        assert!(t > 19.0 && t < 21.0, "{t}");
    }

    #[test]
    fn a_coloured_stripe_outside_its_transition_has_no_say() {
        // Coloured: precise in 22–33 °C, its colour frozen (a large error) outside; black:
        // coarse everywhere.
        let coloured = VarianceTable {
            t0_c: 15.0,
            step_c: 1.0,
            var_c2: (15..=47)
                .map(|t| if (22..=33).contains(&t) { 0.05 } else { 150.0 })
                .collect(),
        };
        let black = VarianceTable {
            t0_c: 0.0,
            step_c: 1.0,
            var_c2: vec![4.0; 63],
        };
        // A cold skin: the coloured estimate stuck at its transition's edge.
        let (t, _) = blend(&coloured, &black, 23.8, 16.5, 16.5);
        assert!((t - 16.5).abs() < 0.3, "cold skin read {t}");
        // A hot one: the same at the other edge.
        let (t, _) = blend(&coloured, &black, 32.9, 43.0, 43.0);
        assert!((t - 43.0).abs() < 0.3, "hot skin read {t}");
        // Inside the transition the coloured stripes decide, even when the black guess
        // falls just outside it (the second pass reads the tables inside).
        let (first, _) = fuse(23.5, coloured.at(21.8), 21.8, black.at(21.8));
        assert!(first < 22.5, "one pass: {first}");
        let (t, var) = blend(&coloured, &black, 23.5, 21.8, 21.8);
        assert!((t - 23.5).abs() < 0.1 && var < 0.1, "{t} ± {var}");
    }

    #[test]
    fn variance_table_interpolates_and_is_unknown_outside() {
        let t = VarianceTable {
            t0_c: 20.0,
            step_c: 1.0,
            var_c2: vec![1.0, 3.0],
        };
        assert_eq!(t.at(20.0), 1.0);
        assert_eq!(t.at(20.5), 2.0);
        assert_eq!(t.at(21.0), 3.0);
        assert_eq!(
            t.at(21.25),
            6.0,
            "half the weight half-way out of the end bin"
        );
        assert_eq!(t.at(25.0), VarianceTable::UNKNOWN_C2);
        assert_eq!(t.at(f64::NAN), VarianceTable::UNKNOWN_C2);
    }

    #[test]
    fn fusion_leans_on_the_surer_estimate() {
        let (t, v) = fuse(30.0, 0.01, 40.0, 1.0);
        assert!((t - 30.099).abs() < 0.01, "{t}");
        assert!(v < 0.01);
        assert_eq!(fuse(10.0, 1.0, 20.0, 1.0).0, 15.0);
    }

    /// The threshold is the least one without a table, and where the kit's places departed
    /// less than it allows for; beyond that, the margin times the kit's departure, linear
    /// between setpoints and the end's beyond them.
    #[test]
    fn a_place_must_depart_further_where_the_kit_showed_places_departing() {
        let least = f64::from(STAND_OUT_SIGMAS);
        let mut m = default_model();
        m.stand_out.clear();
        assert_eq!(f64::from(m.stand_out_sigmas(40.0)), least);
        m.stand_out = vec![
            StandOut {
                setpoint_c: 30.0,
                sigmas: 2.0,
            },
            StandOut {
                setpoint_c: 40.0,
                sigmas: 6.0,
            },
        ];
        assert!(stand_out_ordered(&m.stand_out));
        let at = |t: f64| f64::from(m.stand_out_sigmas(t));
        for (t, want) in [
            (20.0, least),
            (30.0, least),
            (37.5, STAND_OUT_MARGIN * 5.0),
            (40.0, STAND_OUT_MARGIN * 6.0),
            (47.5, STAND_OUT_MARGIN * 6.0),
            (f64::NAN, least),
        ] {
            assert!(
                (at(t) - want).abs() < 1e-5,
                "{t} °C: {} σ, {want} σ expected",
                at(t)
            );
        }
        m.stand_out.swap(0, 1);
        assert!(!stand_out_ordered(&m.stand_out));
    }
}
