//! Fitting colour → temperature from uniform-temperature calibration frames.
//!
//! Samples are blocks (one stripe pair each) of no-contact frames, labelled with the frame's
//! setpoint. For each population, polynomial degrees 1–3 on standardised features are
//! scored by leave-one-setpoint-out cross-validation of per-setpoint means (the error a user
//! sees on a uniform skin), and the parsimony rule takes the lowest degree within one
//! standard error of the best. Least squares uses per-setpoint normal equations, so leaving
//! a setpoint out is a subtraction, not a refit over every sample.
//!
//! The coloured stripes' model is fitted only over the setpoints where their colour moves:
//! the span, around the fastest change, where the per-setpoint mean colour moves by at
//! least a tenth of its fastest rate (in units of its block-to-block noise). Outside that
//! span it has nothing to say, and its variance table shows it.

use crate::linear::solve;
use vistaf_pipeline::evidence::CandidateScore;
use vistaf_pipeline::thermal::lab::Invariants;
use vistaf_pipeline::thermal::model::{
    blend, monomials, terms, ColourModel, Curve, Domain, Polynomial, PopulationModel,
    SetpointError, TemperatureModel, VarianceTable,
};

/// One calibration block.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BlockSample {
    /// Its invariants (the coloured stripes' model reads these).
    pub v: Invariants,
    /// Its neighbourhood's invariants (the black stripes' model reads these; see
    /// [`vistaf_pipeline::thermal::BLACK_POOL`]).
    pub pooled: Invariants,
    /// Setpoint, °C.
    pub t_c: f64,
}

/// Highest polynomial degree tried.
pub const MAX_DEGREE: u32 = 3;

/// Fewest setpoints a model is fitted on.
pub const MIN_SETPOINTS: usize = 4;

/// Setpoints (sorted) and each sample's index into them.
fn groups(samples: &[BlockSample]) -> (Vec<f64>, Vec<usize>) {
    let key = |t: f64| (t * 1000.0).round() / 1000.0;
    let mut sp: Vec<f64> = samples.iter().map(|s| key(s.t_c)).collect();
    sp.sort_by(f64::total_cmp);
    sp.dedup();
    let idx = samples
        .iter()
        .map(|s| sp.partition_point(|&t| t < key(s.t_c)))
        .collect();
    (sp, idx)
}

/// A population's design: standardised polynomial terms (up to [`MAX_DEGREE`]) of every
/// sample, and per-setpoint normal equations for each degree.
struct Design {
    names: Vec<String>,
    mean: Vec<f64>,
    std: Vec<f64>,
    /// Raw features of every sample.
    f: Vec<Vec<f64>>,
    /// Terms of every sample (all samples, in or out of the fit span).
    x: Vec<Vec<f64>>,
    /// Whether each sample is in the fit span.
    used: Vec<bool>,
    /// Whether each sample's held-out error scores the candidates (a subset of `used`).
    scored: Vec<bool>,
}

fn design(
    samples: &[BlockSample],
    names: &[&str],
    features: impl Fn(&BlockSample) -> Vec<f64>,
    used: Vec<bool>,
) -> Design {
    let f: Vec<Vec<f64>> = samples.iter().map(features).collect();
    let n = names.len();
    let m = used.iter().filter(|u| **u).count().max(1) as f64;
    let mean: Vec<f64> = (0..n)
        .map(|k| {
            f.iter()
                .zip(&used)
                .filter(|x| *x.1)
                .map(|x| x.0[k])
                .sum::<f64>()
                / m
        })
        .collect();
    let std: Vec<f64> = (0..n)
        .map(|k| {
            let v = f
                .iter()
                .zip(&used)
                .filter(|x| *x.1)
                .map(|x| (x.0[k] - mean[k]).powi(2))
                .sum::<f64>()
                / m;
            v.sqrt().max(1e-9)
        })
        .collect();
    let exps = monomials(n, MAX_DEGREE);
    let x = f
        .iter()
        .map(|v| {
            let z: Vec<f64> = v
                .iter()
                .zip(mean.iter().zip(&std))
                .map(|(a, (m, s))| (a - m) / s)
                .collect();
            terms(&z, &exps)
        })
        .collect();
    Design {
        names: names.iter().map(|s| s.to_string()).collect(),
        mean,
        std,
        f,
        x,
        scored: used.clone(),
        used,
    }
}

/// Scores of one population at every degree, with its leave-one-setpoint-out predictions.
struct Scored {
    model: ColourModel,
    /// Per sample: held-out prediction (setpoint in the span) or the full model's.
    held_out: Vec<f64>,
    cv_rmse: f64,
    in_sample: f64,
    candidates: Vec<CandidateScore>,
}

/// Root mean square of `v` (0 when empty).
pub(crate) fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|e| e * e).sum::<f64>() / v.len().max(1) as f64).sqrt()
}

/// Per-setpoint mean of `pred` minus the setpoint, for setpoints where `keep`.
fn setpoint_errors(pred: &[f64], idx: &[usize], sp: &[f64], keep: &[bool]) -> Vec<f64> {
    let mut sum = vec![0.0; sp.len()];
    let mut n = vec![0usize; sp.len()];
    for ((p, &g), k) in pred.iter().zip(idx).zip(keep) {
        if *k {
            sum[g] += p;
            n[g] += 1;
        }
    }
    (0..sp.len())
        .filter(|&g| n[g] > 0)
        .map(|g| sum[g] / n[g] as f64 - sp[g])
        .collect()
}

/// The RMSE of per-setpoint errors and its standard error (delta method over setpoints).
fn cv_stats(errs: &[f64]) -> (f64, f64) {
    let cv = rms(errs);
    let sq: Vec<f64> = errs.iter().map(|e| e * e).collect();
    let mean_sq = sq.iter().sum::<f64>() / sq.len().max(1) as f64;
    let var_sq =
        sq.iter().map(|s| (s - mean_sq).powi(2)).sum::<f64>() / (sq.len().max(2) - 1) as f64;
    (
        cv,
        (var_sq / sq.len().max(1) as f64).sqrt() / (2.0 * cv.max(1e-9)),
    )
}

/// The calibration curve through the per-setpoint means of the used samples, leaving out
/// setpoint `skip`.
fn curve(d: &Design, idx: &[usize], sp: &[f64], scale: &[f64], skip: Option<usize>) -> Curve {
    let n = d.names.len();
    let mut sum = vec![vec![0.0; n]; sp.len()];
    let mut cnt = vec![0usize; sp.len()];
    for i in (0..idx.len()).filter(|&i| d.used[i] && Some(idx[i]) != skip) {
        for (acc, v) in sum[idx[i]].iter_mut().zip(&d.f[i]) {
            *acc += v;
        }
        cnt[idx[i]] += 1;
    }
    let (mut t_c, mut knots) = (Vec::new(), Vec::new());
    for g in (0..sp.len()).filter(|&g| cnt[g] > 0) {
        t_c.push(sp[g]);
        knots.push(sum[g].iter().map(|v| v / cnt[g] as f64).collect());
    }
    Curve {
        features: d.names.clone(),
        scale: scale.to_vec(),
        t_c,
        knots,
    }
}

/// Scores the calibration curve by leaving each setpoint out.
fn score_curve(
    d: &Design,
    sp: &[f64],
    idx: &[usize],
) -> Option<(ColourModel, Vec<f64>, CandidateScore)> {
    let n = d.names.len();
    // Pooled block-to-block noise per feature.
    let full0 = curve(d, idx, sp, &vec![1.0; n], None);
    let mut var = vec![0.0; n];
    let mut m = 0usize;
    for i in (0..idx.len()).filter(|&i| d.used[i]) {
        let k = full0.t_c.iter().position(|t| *t == sp[idx[i]])?;
        for ((acc, v), c) in var.iter_mut().zip(&d.f[i]).zip(&full0.knots[k]) {
            *acc += (v - c).powi(2);
        }
        m += 1;
    }
    let scale: Vec<f64> = var
        .iter()
        .map(|v| (v / m.max(1) as f64).sqrt().max(1e-6))
        .collect();
    let full = curve(d, idx, sp, &scale, None);
    if full.t_c.len() < MIN_SETPOINTS {
        return None;
    }
    let mut held_out: Vec<f64> = d.f.iter().map(|x| full.eval(x)).collect();
    let ins = rms(&setpoint_errors(&held_out, idx, sp, &d.scored));
    for g in 0..sp.len() {
        let members: Vec<usize> = (0..idx.len())
            .filter(|&i| d.used[i] && idx[i] == g)
            .collect();
        if members.is_empty() {
            continue;
        }
        let c = curve(d, idx, sp, &scale, Some(g));
        for i in members {
            held_out[i] = c.eval(&d.f[i]);
        }
    }
    let (cv, se) = cv_stats(&setpoint_errors(&held_out, idx, sp, &d.scored));
    let params = full.t_c.len() * n;
    Some((
        ColourModel::Curve(full),
        held_out,
        CandidateScore {
            name: "calibration curve".into(),
            params,
            cv_rmse: cv,
            cv_se: se,
            in_sample_rmse: ins,
            refused: None,
        },
    ))
}

fn score(d: &Design, samples: &[BlockSample], sp: &[f64], idx: &[usize]) -> Option<Scored> {
    let y: Vec<f64> = samples.iter().map(|s| s.t_c).collect();
    let mut fits = Vec::new();
    for degree in 1..=MAX_DEGREE {
        let m = monomials(d.names.len(), degree).len();
        // Per-setpoint normal equations.
        let mut a = vec![vec![0.0; m * m]; sp.len()];
        let mut b = vec![vec![0.0; m]; sp.len()];
        for i in (0..samples.len()).filter(|&i| d.used[i]) {
            let (x, g) = (&d.x[i][..m], idx[i]);
            for r in 0..m {
                b[g][r] += x[r] * y[i];
                for c in 0..m {
                    a[g][r * m + c] += x[r] * x[c];
                }
            }
        }
        let total_a: Vec<f64> = (0..m * m).map(|k| a.iter().map(|v| v[k]).sum()).collect();
        let total_b: Vec<f64> = (0..m).map(|k| b.iter().map(|v| v[k]).sum()).collect();
        let Some(full) = solve(total_a.clone(), total_b.clone()) else {
            continue;
        };
        let eval = |coef: &[f64], i: usize| -> f64 {
            d.x[i][..m].iter().zip(coef).map(|(t, c)| t * c).sum()
        };
        let in_group: Vec<bool> = (0..sp.len())
            .map(|g| (0..samples.len()).any(|i| d.used[i] && idx[i] == g))
            .collect();
        let mut held_out: Vec<f64> = (0..samples.len()).map(|i| eval(&full, i)).collect();
        let mut ok = true;
        for g in (0..sp.len()).filter(|&g| in_group[g]) {
            let aa: Vec<f64> = total_a.iter().zip(&a[g]).map(|(t, v)| t - v).collect();
            let bb: Vec<f64> = total_b.iter().zip(&b[g]).map(|(t, v)| t - v).collect();
            let Some(coef) = solve(aa, bb) else {
                ok = false;
                break;
            };
            for i in (0..samples.len()).filter(|&i| d.used[i] && idx[i] == g) {
                held_out[i] = eval(&coef, i);
            }
        }
        if !ok {
            continue;
        }
        let errs = setpoint_errors(&held_out, idx, sp, &d.scored);
        let full_pred: Vec<f64> = (0..samples.len()).map(|i| eval(&full, i)).collect();
        let ins = rms(&setpoint_errors(&full_pred, idx, sp, &d.scored));
        let (cv, se) = cv_stats(&errs);
        fits.push((
            ColourModel::Polynomial(Polynomial {
                features: d.names.clone(),
                mean: d.mean.clone(),
                std: d.std.clone(),
                degree,
                coef: full,
            }),
            held_out,
            CandidateScore {
                name: format!("degree {degree}"),
                params: m,
                cv_rmse: cv,
                cv_se: se,
                in_sample_rmse: ins,
                refused: None,
            },
        ));
    }
    fits.extend(score_curve(d, sp, idx));
    let best = fits
        .iter()
        .map(|f| &f.2)
        .filter(|s| s.cv_rmse.is_finite())
        .min_by(|a, b| a.cv_rmse.total_cmp(&b.cv_rmse))?
        .clone();
    let limit = best.cv_rmse + best.cv_se;
    let candidates: Vec<CandidateScore> = fits.iter().map(|f| f.2.clone()).collect();
    let (model, held_out, s) =
        fits.into_iter()
            .filter(|f| f.2.cv_rmse <= limit)
            .min_by(|a, b| {
                a.2.params
                    .cmp(&b.2.params)
                    .then(a.2.cv_rmse.total_cmp(&b.2.cv_rmse))
            })?;
    Some(Scored {
        model,
        held_out,
        cv_rmse: s.cv_rmse,
        in_sample: s.in_sample_rmse,
        candidates,
    })
}

/// A population's mean squared error per block at each setpoint (`pred` against `truth`,
/// `idx` the setpoint of each sample, at least `floor` there), in 1 °C bins over [lo, hi]:
/// linear between setpoints, the end setpoints' values beyond them (the black stripes'
/// table reaches past the calibration, where their estimate extrapolates and is flagged).
fn variance_table(
    pred: &[f64],
    truth: &[f64],
    (idx, sp): (&[usize], &[f64]),
    floor: &[f64],
    (lo, hi): (f64, f64),
) -> VarianceTable {
    let (mut s, mut c) = (vec![0.0; sp.len()], vec![0.0; sp.len()]);
    for ((p, t), &g) in pred.iter().zip(truth).zip(idx) {
        if p.is_finite() {
            s[g] += (p - t).powi(2);
            c[g] += 1.0;
        }
    }
    let known: Vec<(f64, f64)> = sp
        .iter()
        .zip(s.iter().zip(&c))
        .zip(floor)
        .filter(|((_, (_, c)), _)| **c > 0.0)
        .map(|((t, (s, c)), f)| (*t, (s / c).max(*f)))
        .collect();
    let mse_at = |t: f64| -> f64 {
        let Some(first) = known.first() else {
            return VarianceTable::SPARSE_C2;
        };
        let k = known.partition_point(|(x, _)| *x <= t);
        if k == 0 {
            return first.1;
        }
        if k == known.len() {
            return known[k - 1].1;
        }
        let ((t0, v0), (t1, v1)) = (known[k - 1], known[k]);
        v0 + (v1 - v0) * (t - t0) / (t1 - t0)
    };
    let (t0, step) = (lo.floor(), 1.0);
    let n = (hi.ceil() - t0) as usize + 1;
    VarianceTable {
        t0_c: t0,
        step_c: step,
        var_c2: (0..n)
            .map(|k| mse_at(t0 + k as f64 * step).max(1e-3))
            .collect(),
    }
}

/// The span of setpoints where the coloured stripes' colour moves (see the module doc),
/// and how fast it moves at each setpoint: the mean over the two intervals beside it of the
/// mean colour's change per °C, in units of its block-to-block noise.
fn coloured_span(samples: &[BlockSample], sp: &[f64], idx: &[usize]) -> (Vec<bool>, Vec<f64>) {
    let g = sp.len();
    let mut mean = vec![[0.0f64; 2]; g];
    let mut n = vec![0.0f64; g];
    let feats: Vec<[f64; 2]> = samples.iter().map(|s| s.v.chroma_ab()).collect();
    for (f, &k) in feats.iter().zip(idx) {
        mean[k][0] += f[0];
        mean[k][1] += f[1];
        n[k] += 1.0;
    }
    for (m, c) in mean.iter_mut().zip(&n) {
        m[0] /= c.max(1.0);
        m[1] /= c.max(1.0);
    }
    let mut noise = [0.0f64; 2];
    for (f, &k) in feats.iter().zip(idx) {
        noise[0] += (f[0] - mean[k][0]).powi(2);
        noise[1] += (f[1] - mean[k][1]).powi(2);
    }
    let noise = noise.map(|v| (v / samples.len().max(1) as f64).sqrt().max(1e-6));
    let speed: Vec<f64> = (0..g.saturating_sub(1))
        .map(|k| {
            let d = [
                (mean[k + 1][0] - mean[k][0]) / noise[0],
                (mean[k + 1][1] - mean[k][1]) / noise[1],
            ];
            d[0].hypot(d[1]) / (sp[k + 1] - sp[k]).max(1e-6)
        })
        .collect();
    // The speeds of the intervals either side of setpoint `k` (none beyond the ends).
    let beside = |k: usize| [k.checked_sub(1).map(|j| speed[j]), speed.get(k).copied()];
    // Whether the colour moves at `k`: the faster side.
    let at = |k: usize| beside(k).into_iter().flatten().fold(0.0, f64::max);
    // How fast: the mean of the sides there are.
    let rate: Vec<f64> = (0..g)
        .map(|k| {
            let s: Vec<f64> = beside(k).into_iter().flatten().collect();
            s.iter().sum::<f64>() / s.len().max(1) as f64
        })
        .collect();
    let Some(peak) = (0..g).max_by(|&a, &b| at(a).total_cmp(&at(b))) else {
        return (vec![true; samples.len()], rate);
    };
    let lim = 0.1 * at(peak);
    let (mut lo, mut hi) = (peak, peak);
    while lo > 0 && at(lo - 1) >= lim {
        lo -= 1;
    }
    while hi + 1 < g && at(hi + 1) >= lim {
        hi += 1;
    }
    if hi - lo + 1 < MIN_SETPOINTS {
        return (vec![true; samples.len()], rate);
    }
    (idx.iter().map(|&k| k >= lo && k <= hi).collect(), rate)
}

/// Why no temperature model could be fitted.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ThermalFitError {
    /// Too few setpoints.
    #[error("temperature needs trusted no-contact frames at {MIN_SETPOINTS} or more setpoints (found {0})")]
    TooFewSetpoints(usize),
    /// Least squares failed.
    #[error("the {0} stripes' colour does not determine temperature (singular fit)")]
    Singular(&'static str),
}

/// The calibration's samples grouped by setpoint.
struct Setpoints<'a> {
    samples: &'a [BlockSample],
    /// The setpoints, sorted, and each sample's index into them.
    sp: Vec<f64>,
    idx: Vec<usize>,
    /// Each sample's setpoint, °C.
    truth: Vec<f64>,
}

/// Fits both populations and their fusion.
pub fn fit_temperature(samples: &[BlockSample]) -> Result<TemperatureModel, ThermalFitError> {
    let (sp, idx) = groups(samples);
    if sp.len() < MIN_SETPOINTS {
        return Err(ThermalFitError::TooFewSetpoints(sp.len()));
    }
    let set = Setpoints {
        samples,
        truth: samples.iter().map(|s| s.t_c).collect(),
        sp,
        idx,
    };
    let (span, rate) = coloured_span(samples, &set.sp, &set.idx);
    let (dc, db) = designs(&set, &span);
    let c = score(&dc, samples, &set.sp, &set.idx).ok_or(ThermalFitError::Singular("coloured"))?;
    let k = score(&db, samples, &set.sp, &set.idx).ok_or(ThermalFitError::Singular("black"))?;
    let (lo, hi) = (set.sp[0], set.sp[set.sp.len() - 1]);
    let (hc, hk) = (c.held_out.clone(), k.held_out.clone());
    // The coloured stripes' table covers the whole calibration: outside their span their
    // error is large (their colour no longer moves), and at least what the colour's rate
    // of change allows (noise over sensitivity, squared): where the colour stops moving, a
    // model that happens to land near the truth has still not measured it. The black
    // stripes' reaches 15 °C past the calibration on either side (extrapolated, flagged as
    // out of range).
    let sensitivity: Vec<f64> = rate.iter().map(|r| 1.0 / (r * r).max(1e-9)).collect();
    let coloured = set.population(c, &dc, span_of(&set, &span), [lo, hi], &sensitivity);
    let black = set.population(
        k,
        &db,
        [lo, hi],
        [lo - 15.0, hi + 15.0],
        &vec![0.0; set.sp.len()],
    );
    let (errs, held_out) = set.fused_held_out(&db, (&hc, &hk), (&coloured, &black));
    let in_transition: Vec<f64> = held_out
        .iter()
        .filter(|h| (22.0..=32.0).contains(&h.setpoint_c))
        .map(|h| h.estimate_c - h.setpoint_c)
        .collect();
    Ok(TemperatureModel {
        domain: colour_domain(samples),
        coloured,
        black,
        range_c: [lo, hi],
        blind_above_c: None,
        cv_rmse_transition_c: rms(&in_transition),
        cv_rmse_c: rms(&errs),
        held_out,
        n: samples.len(),
        mean_read: Vec::new(),
        stand_out: Vec::new(),
        reference_shift: Vec::new(),
        contact_chroma_spread: [0.0; 2],
    })
}

/// The two populations' designs: the coloured stripes fitted over their `span`, the black
/// stripes fitted everywhere (inside the coloured span their estimate places the reading
/// on the variance tables) but judged where they are the ones that speak: outside the
/// coloured stripes' span, when it holds enough setpoints.
fn designs(set: &Setpoints<'_>, span: &[bool]) -> (Design, Design) {
    let samples = set.samples;
    let dc = design(
        samples,
        &["a", "b", "Lk"],
        |s| s.v.coloured_features(),
        span.to_vec(),
    );
    let mut db = design(
        samples,
        &["Lk", "a", "b"],
        |s| s.pooled.black_features(),
        vec![true; samples.len()],
    );
    let outside: Vec<bool> = span.iter().map(|s| !s).collect();
    // Distinct setpoints among them (samples need not come in setpoint order).
    let outside_setpoints = (0..set.sp.len())
        .filter(|&g| set.idx.iter().zip(&outside).any(|(&i, &o)| o && i == g))
        .count();
    if outside_setpoints >= MIN_SETPOINTS {
        db.scored = outside;
    }
    (dc, db)
}

/// The setpoints the coloured span covers, °C: lowest and highest.
fn span_of(set: &Setpoints<'_>, span: &[bool]) -> [f64; 2] {
    let ts: Vec<f64> = set
        .idx
        .iter()
        .zip(span)
        .filter(|x| *x.1)
        .map(|x| set.sp[*x.0])
        .collect();
    [
        ts.iter().copied().fold(f64::INFINITY, f64::min),
        ts.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    ]
}

impl Setpoints<'_> {
    /// A population's model with its error per setpoint, tabulated over `table` (outside
    /// it the estimate carries no weight): held out, except at the ends of the span the
    /// model was fitted on (`range`), where leaving a setpoint out makes the error an
    /// extrapolation the fitted model never does there.
    fn population(
        &self,
        s: Scored,
        d: &Design,
        range: [f64; 2],
        table: [f64; 2],
        floor: &[f64],
    ) -> PopulationModel {
        let pred: Vec<f64> = self
            .samples
            .iter()
            .zip(&s.held_out)
            .zip(&d.f)
            .map(|((x, h), f)| {
                if x.t_c == range[0] || x.t_c == range[1] {
                    s.model.eval(f)
                } else {
                    *h
                }
            })
            .collect();
        PopulationModel {
            equation: s.model.equation(),
            variance: variance_table(
                &pred,
                &self.truth,
                (&self.idx, &self.sp),
                floor,
                (table[0], table[1]),
            ),
            model: s.model,
            fit_range_c: range,
            cv_rmse_c: s.cv_rmse,
            in_sample_rmse_c: s.in_sample,
            candidates: s.candidates,
        }
    }

    /// The held-out fused estimate per block (both estimates held out, `held`), its error
    /// per setpoint, and the setpoints' estimates. The tables are read at the fitted black
    /// model's estimate (a reading reads them at its neighbourhood's median of that). Read
    /// at the held-out black estimate instead, a setpoint inside the coloured transition,
    /// left out of a black calibration curve, would put the tables 40 °C away.
    fn fused_held_out(
        &self,
        db: &Design,
        held: (&[f64], &[f64]),
        (coloured, black): (&PopulationModel, &PopulationModel),
    ) -> (Vec<f64>, Vec<SetpointError>) {
        let fused: Vec<f64> =
            db.f.iter()
                .zip(held.0.iter().zip(held.1))
                .map(|(f, (&a, &b))| {
                    let guess = black.model.eval(f);
                    blend(&coloured.variance, &black.variance, a, b, guess).0
                })
                .collect();
        let errs = setpoint_errors(&fused, &self.idx, &self.sp, &vec![true; self.samples.len()]);
        let held_out = self
            .sp
            .iter()
            .zip(&errs)
            .map(|(&t, e)| SetpointError {
                setpoint_c: t,
                estimate_c: t + e,
            })
            .collect();
        (errs, held_out)
    }
}

/// The calibrated colours: each invariant's range over the blocks and their
/// neighbourhoods, widened by half its span on either side.
fn colour_domain(samples: &[BlockSample]) -> Domain {
    let widen = |f: &dyn Fn(&Invariants) -> f64| {
        let all = || samples.iter().flat_map(|s| [f(&s.v), f(&s.pooled)]);
        let lo = all().fold(f64::INFINITY, f64::min);
        let hi = all().fold(f64::NEG_INFINITY, f64::max);
        let m = 0.5 * (hi - lo).max(1e-3);
        [lo - m, hi + m]
    };
    Domain {
        r: widen(&|v| v.r),
        g: widen(&|v| v.g),
        q: widen(&|v| v.q),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A synthetic pigment: chromaticity turns through the 24–32 °C transition, the black
    /// ratio rises everywhere. The fit must recover the temperature of held-out setpoints.
    fn synthetic(t: f64, wobble: f64) -> Invariants {
        let s = 1.0 / (1.0 + (-(t - 28.0) / 1.5).exp());
        Invariants {
            r: 0.30 + 0.12 * s + wobble,
            g: 0.36 - 0.05 * s - wobble,
            q: 0.10 + 0.004 * t + 0.05 * s,
        }
    }

    #[test]
    fn fits_recover_held_out_setpoints() {
        let mut samples = Vec::new();
        let sps = [
            15.0, 18.0, 20.0, 22.0, 24.0, 25.0, 26.0, 27.0, 28.0, 29.0, 30.0, 31.0, 32.0, 34.0,
            37.0, 40.0, 45.0,
        ];
        for &t in &sps {
            for k in 0..40 {
                let w = ((k * 37) % 11) as f64 / 11.0 - 0.5;
                let v = synthetic(t, 2e-4 * w);
                samples.push(BlockSample {
                    v,
                    pooled: v,
                    t_c: t,
                });
            }
        }
        let m = fit_temperature(&samples).unwrap();
        assert!(m.is_consistent());
        assert!(m.coloured.fit_range_c[0] >= 20.0 && m.coloured.fit_range_c[1] <= 37.0);
        assert!(m.cv_rmse_transition_c < 0.3, "{m:#?}");
        for t in [23.5, 28.5, 30.5] {
            let v = synthetic(t, 0.0);
            let e = m.estimate(&v, &v);
            assert!((e.t_c - t).abs() < 0.3, "{t}: {e:?}");
        }
        assert!(m.out_of_range(60.0, 1.0) && !m.out_of_range(30.0, 1.0));
        assert!(!m.out_of_range(46.0, 1.0), "within two sigma of the range");
        assert_eq!(
            fit_temperature(&samples[..80]),
            Err(ThermalFitError::TooFewSetpoints(2))
        );
    }
}
