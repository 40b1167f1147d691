//! Model fitting with honest numbers: least squares for each candidate form, grouped
//! cross-validation (leave one setpoint or force level out), and the parsimony rule: the
//! model with the fewest parameters whose CV error is within one standard error of the
//! best.
//!
//! Every two-parameter form here is `y = a·g(b·u)` (or `a·u^b`): for each `b` on a
//! logarithmic grid `a` has a closed form, and the best `b` is then refined by golden-section
//! search. No general nonlinear optimiser is needed, and the fit cannot diverge.

use crate::linear::solve;
use vistaf_pipeline::calibration::{
    check_depth, CandidateScore, DepthError, DepthModel, FitRange, ForceFeature, ForceForm,
    ForceModel,
};

/// A sample: input, target, and its group (setpoint) for cross-validation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Input (phase, feature).
    pub u: f64,
    /// Target (depth, force).
    pub y: f64,
    /// Group label (the setpoint it was recorded at).
    pub group: f64,
}

fn rmse(pairs: impl Iterator<Item = (f64, f64)>) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for (p, y) in pairs {
        s += (p - y).powi(2);
        n += 1;
    }
    if n == 0 {
        f64::NAN
    } else {
        (s / n as f64).sqrt()
    }
}

/// Best `a` for `y ≈ a·g` (least squares), and its SSE.
fn scale_fit(samples: &[Sample], g: impl Fn(f64) -> f64) -> (f64, f64) {
    let (mut sgy, mut sgg) = (0.0, 0.0);
    for s in samples {
        let v = g(s.u);
        sgy += v * s.y;
        sgg += v * v;
    }
    let a = if sgg > 0.0 { sgy / sgg } else { 0.0 };
    let sse = samples.iter().map(|s| (a * g(s.u) - s.y).powi(2)).sum();
    (a, sse)
}

/// Least-squares `y ≈ c₁·u + … + c_n·u^n` through the origin, from its normal equations;
/// zeros should they have no solution (a model that reads no depth, which the file's check
/// refuses).
fn polynomial_fit(samples: &[Sample], n: usize) -> Vec<f64> {
    let (mut ata, mut aty) = (vec![0.0; n * n], vec![0.0; n]);
    for s in samples {
        let powers: Vec<f64> = (1..=n as i32).map(|k| s.u.powi(k)).collect();
        for (i, pi) in powers.iter().enumerate() {
            for (j, pj) in powers.iter().enumerate() {
                ata[i * n + j] += pi * pj;
            }
            aty[i] += pi * s.y;
        }
    }
    solve(ata, aty).unwrap_or_else(|| vec![0.0; n])
}

/// Fits `y ≈ a·g(b, u)` over `b` in [lo, hi] (log grid, then golden section); returns (a, b).
pub fn fit_ab(samples: &[Sample], lo: f64, hi: f64, g: impl Fn(f64, f64) -> f64) -> (f64, f64) {
    let sse_of = |b: f64| scale_fit(samples, |u| g(b, u)).1;
    let steps = 60;
    let (mut best_b, mut best) = (lo, f64::INFINITY);
    for k in 0..=steps {
        let b = lo * (hi / lo).powf(k as f64 / steps as f64);
        let e = sse_of(b);
        if e < best {
            (best_b, best) = (b, e);
        }
    }
    let ratio = (hi / lo).powf(1.0 / steps as f64);
    let (mut a, mut c) = ((best_b / ratio).ln(), (best_b * ratio).ln());
    let phi = 0.618_033_988_75;
    for _ in 0..60 {
        let (x1, x2) = (c - phi * (c - a), a + phi * (c - a));
        if sse_of(x1.exp()) < sse_of(x2.exp()) {
            c = x2;
        } else {
            a = x1;
        }
    }
    let b = ((a + c) / 2.0).exp();
    (scale_fit(samples, |u| g(b, u)).0, b)
}

/// Pool-adjacent-violators on the setpoint means: the non-decreasing fit of `y` over `u`,
/// anchored at (0, 0), one knot per setpoint (averaging the frames of a setpoint first
/// keeps the knots stable). Beyond the last setpoint the model continues with the
/// least-squares slope of the last knots spanning a fifth of the range (stored as one extra
/// knot at twice the range): the slope between the last two knots alone can come from two
/// setpoints microns apart, and is no basis for extrapolation. Returns knots.
fn isotonic(samples: &[Sample]) -> (Vec<f64>, Vec<f64>) {
    let mut groups: Vec<(f64, f64, f64, f64)> = Vec::new(); // group, Σu, Σy, n
    for s in samples {
        match groups.iter_mut().find(|g| g.0 == s.group) {
            Some(g) => {
                g.1 += s.u;
                g.2 += s.y;
                g.3 += 1.0;
            }
            None => groups.push((s.group, s.u, s.y, 1.0)),
        }
    }
    let mut pts: Vec<(f64, f64)> = groups
        .iter()
        .map(|g| ((g.1 / g.3).max(0.0), (g.2 / g.3).max(0.0)))
        .collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    // Blocks: (sum u, sum y, count).
    let mut blocks: Vec<(f64, f64, f64)> = Vec::new();
    for (u, y) in pts {
        blocks.push((u, y, 1.0));
        while blocks.len() >= 2 {
            let n = blocks.len();
            let (a, b) = (blocks[n - 2], blocks[n - 1]);
            if a.1 / a.2 > b.1 / b.2 {
                blocks.truncate(n - 2);
                blocks.push((a.0 + b.0, a.1 + b.1, a.2 + b.2));
            } else {
                break;
            }
        }
    }
    let mut xs: Vec<f64> = Vec::new();
    let mut ds: Vec<f64> = Vec::new();
    for (su, sy, n) in blocks {
        let (x, d) = (su / n, (sy / n).max(ds.last().copied().unwrap_or(0.0)));
        if x > xs.last().copied().unwrap_or(0.0) {
            xs.push(x);
            ds.push(d);
        }
    }
    if let Some(&x_last) = xs.last() {
        // The last knots spanning at least a fifth of the range (with the origin as a
        // knot when needed).
        let mut all: Vec<(f64, f64)> = vec![(0.0, 0.0)];
        all.extend(xs.iter().copied().zip(ds.iter().copied()));
        let start = all
            .iter()
            .rposition(|p| x_last - p.0 >= 0.2 * x_last)
            .unwrap_or(0);
        let top = &all[start..];
        let slope = if top.len() >= 2 {
            let (mx, md) = (
                top.iter().map(|p| p.0).sum::<f64>() / top.len() as f64,
                top.iter().map(|p| p.1).sum::<f64>() / top.len() as f64,
            );
            let sxx: f64 = top.iter().map(|p| (p.0 - mx).powi(2)).sum();
            let sxd: f64 = top.iter().map(|p| (p.0 - mx) * (p.1 - md)).sum();
            if sxx > 0.0 {
                (sxd / sxx).max(0.0)
            } else {
                0.0
            }
        } else {
            0.0
        };
        let d_last = ds[ds.len() - 1];
        xs.push(2.0 * x_last);
        ds.push(d_last + slope * x_last);
    }
    (xs, ds)
}

/// Setpoint-mean knots of a non-decreasing relation (no extrapolation knot): for tables
/// such as the calibrated indenter's area by depth.
pub fn monotone_knots(samples: &[Sample]) -> (Vec<f64>, Vec<f64>) {
    let (mut x, mut y) = isotonic(samples);
    x.pop();
    y.pop();
    (x, y)
}

/// Fits a model to samples.
type Fitter<M> = Box<dyn Fn(&[Sample]) -> M>;

/// A candidate form: its name, parameter count, and how to fit it.
struct Candidate<M> {
    name: String,
    params: usize,
    fit: Fitter<M>,
}

/// Cross-validated scores of every candidate (groups left out one at a time), each with
/// its model fitted on all samples. `None` with fewer than three groups.
fn score_all<M>(
    samples: &[Sample],
    candidates: Vec<Candidate<M>>,
    predict: &impl Fn(&M, f64) -> f64,
) -> Option<Vec<(M, CandidateScore)>> {
    let groups = groups(samples);
    if groups.len() < 3 {
        return None;
    }
    let mut out = Vec::new();
    for c in candidates {
        let folds = held_out(samples, &groups, &c.fit, predict);
        let fold_rmse: Vec<f64> = folds.iter().map(|f| rmse(f.iter().copied())).collect();
        let cv = rmse(folds.into_iter().flatten());
        let mean = fold_rmse.iter().sum::<f64>() / fold_rmse.len() as f64;
        let var = fold_rmse.iter().map(|r| (r - mean).powi(2)).sum::<f64>()
            / (fold_rmse.len() - 1) as f64;
        let se = (var / fold_rmse.len() as f64).sqrt();
        let m = (c.fit)(samples);
        let ins = rmse(samples.iter().map(|s| (predict(&m, s.u), s.y)));
        out.push((
            m,
            CandidateScore {
                name: c.name,
                params: c.params,
                cv_rmse: cv,
                cv_se: se,
                in_sample_rmse: ins,
                refused: None,
            },
        ));
    }
    Some(out)
}

/// The samples' groups, ascending, each once.
fn groups(samples: &[Sample]) -> Vec<f64> {
    let mut groups: Vec<f64> = samples.iter().map(|s| s.group).collect();
    groups.sort_by(f64::total_cmp);
    groups.dedup();
    groups
}

/// Per group, its samples read by the model fitted without it: (read, label) pairs.
fn held_out<M>(
    samples: &[Sample],
    groups: &[f64],
    fit: &Fitter<M>,
    predict: &impl Fn(&M, f64) -> f64,
) -> Vec<Vec<(f64, f64)>> {
    groups
        .iter()
        .map(|g| {
            let train: Vec<Sample> = samples.iter().copied().filter(|s| s.group != *g).collect();
            let m = fit(&train);
            (samples.iter().filter(|s| s.group == *g))
                .map(|s| (predict(&m, s.u), s.y))
                .collect()
        })
        .collect()
}

/// The parsimony rule: among candidates within one standard error of the best CV RMSE,
/// the one with the fewest parameters (then the lower CV RMSE).
fn choose<M: Clone>(
    scored: Vec<(M, CandidateScore)>,
) -> Option<(M, CandidateScore, Vec<CandidateScore>)> {
    let best = scored
        .iter()
        .map(|s| &s.1)
        .filter(|s| s.cv_rmse.is_finite() && s.refused.is_none())
        .min_by(|a, b| a.cv_rmse.total_cmp(&b.cv_rmse))?;
    let limit = best.cv_rmse + best.cv_se;
    let (m, s) = scored
        .iter()
        .filter(|(_, s)| s.cv_rmse <= limit && s.refused.is_none())
        .min_by(|a, b| {
            a.1.params
                .cmp(&b.1.params)
                .then(a.1.cv_rmse.total_cmp(&b.1.cv_rmse))
        })
        .cloned()?;
    Some((m, s, scored.into_iter().map(|x| x.1).collect()))
}

/// Phase → depth candidates: linear through the origin, the paper's saturating hinge, the
/// steepening growth form, polynomials of degree 2 and 3 through the origin, and a monotone
/// (isotonic) piecewise-linear fit.
///
/// The two-parameter forms bend one way at one rate; a skin whose phase saturates
/// otherwise (a response between exponential and `tanh`, say) leaves them off along the
/// range with the same sign at every depth, while the isotonic fit follows each
/// setpoint's noise. The cubic follows the inverses of such responses over a kit's range
/// (`docs/pipeline.md`), and the parsimony rule admits it only where the data ask for it.
/// A candidate that does not pass the file's own check over the phases it will meet (a
/// polynomial turning down past its last setpoint) is refused, not chosen.
pub fn fit_depth(
    samples: &[Sample],
    progress: impl FnMut(usize, usize),
) -> Option<(DepthModel, CandidateScore, Vec<CandidateScore>)> {
    let cands = depth_candidates();
    let mut progress = progress;
    let mut scored = score_all(samples, cands, &|m: &DepthModel, u| m.depth_mm(u))?;
    let range = FitRange::of(samples.iter().map(|s| (s.u, s.y)));
    for (m, score) in &mut scored {
        // A monotone fit has as many free values as it has knots.
        if let DepthModel::Monotone { x_rad, .. } = m {
            score.params = x_rad.len();
        }
        if let Err(e) = check_depth(m, range.as_ref()) {
            score.refused = Some(e.why);
        }
    }
    progress(1, 1);
    choose(scored)
}

/// The depth model's candidate forms ([`fit_depth`]).
fn depth_candidates() -> Vec<Candidate<DepthModel>> {
    vec![
        Candidate {
            name: "linear".into(),
            params: 1,
            fit: Box::new(|s| DepthModel::Linear {
                k_mm_per_rad: scale_fit(s, |u| u).0,
            }),
        },
        Candidate {
            name: "hinge".into(),
            params: 2,
            fit: Box::new(|s| {
                let (a, b) = fit_ab(s, 1e-3, 50.0, |b, u| 1.0 - (-b * u).exp());
                DepthModel::Hinge {
                    h_mm: a,
                    k_per_rad: b,
                }
            }),
        },
        Candidate {
            name: "growth".into(),
            params: 2,
            fit: Box::new(|s| {
                let (a, b) = fit_ab(s, 1e-3, 5.0, |b, u| (b * u).exp() - 1.0);
                DepthModel::Growth {
                    a_mm: a,
                    b_per_rad: b,
                }
            }),
        },
        Candidate {
            name: "quadratic".into(),
            params: 2,
            fit: Box::new(|s| DepthModel::Polynomial {
                c_mm: polynomial_fit(s, 2),
            }),
        },
        Candidate {
            name: "cubic".into(),
            params: 3,
            fit: Box::new(|s| DepthModel::Polynomial {
                c_mm: polynomial_fit(s, 3),
            }),
        },
        Candidate {
            name: "monotone".into(),
            params: 0, // set from the fitted knots below
            fit: Box::new(|s| {
                let (x_rad, d_mm) = isotonic(s);
                DepthModel::Monotone { x_rad, d_mm }
            }),
        },
    ]
}

/// The kit's presses read by the depth model `fit_depth` chose (its candidate `name`),
/// each fitted without its setpoint: (read, label) pairs, mm. `None` for a name that is
/// no candidate's.
pub fn held_out_depths(samples: &[Sample], name: &str) -> Option<Vec<(f64, f64)>> {
    let c = depth_candidates().into_iter().find(|c| c.name == name)?;
    let read = |m: &DepthModel, u| m.depth_mm(u);
    Some(held_out(samples, &groups(samples), &c.fit, &read).concat())
}

/// The held-out error by depth ([`DepthError`]) of (read, label) pairs: the floor and
/// share whose `floor² + (share · label)²` fits the squared errors best (least squares,
/// neither negative). `None` without two pairs at different depths.
pub fn error_by_depth(pairs: &[(f64, f64)]) -> Option<DepthError> {
    // Squared error e² against y²: e² ≈ f² + c²·y², a line in (f², c²).
    let points: Vec<(f64, f64)> = (pairs.iter())
        .filter(|(r, y)| r.is_finite() && y.is_finite())
        .map(|(r, y)| (y * y, (r - y) * (r - y)))
        .collect();
    let n = points.len() as f64;
    let (mx, me) = (
        points.iter().map(|p| p.0).sum::<f64>() / n,
        points.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    if sxx.is_nan() || sxx <= 0.0 {
        return None;
    }
    let sxe: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - me)).sum();
    let (mut floor2, mut share2) = (me - sxe / sxx * mx, sxe / sxx);
    if share2 < 0.0 {
        (floor2, share2) = (me, 0.0);
    } else if floor2 < 0.0 {
        // Through the origin: c² = Σ e²·y² / Σ y⁴.
        let y4: f64 = points.iter().map(|p| p.0 * p.0).sum();
        (floor2, share2) = (0.0, points.iter().map(|p| p.0 * p.1).sum::<f64>() / y4);
    }
    Some(DepthError {
        floor_mm: floor2.sqrt(),
        share: share2.sqrt(),
    })
}

/// Measurement → force candidates: every feature with every form, chosen together.
pub fn fit_force(
    features: &[(ForceFeature, Vec<Sample>)],
    mut progress: impl FnMut(usize, usize),
) -> Option<(ForceModel, CandidateScore, Vec<CandidateScore>)> {
    let mut pool = Vec::new();
    for (k, (feature, samples)) in features.iter().enumerate() {
        let f = *feature;
        let form = |name: &str, params: usize, fit: fn(&[Sample]) -> ForceForm| Candidate {
            name: format!("{name}({})", f.symbol()),
            params,
            fit: Box::new(move |s| ForceModel {
                feature: f,
                form: fit(s),
            }),
        };
        let cands: Vec<Candidate<ForceModel>> = vec![
            form("linear", 1, |s| ForceForm::Linear {
                a: scale_fit(s, |u| u).0,
            }),
            form("hertz", 1, |s| ForceForm::Hertz {
                c: scale_fit(s, |u| u.max(0.0).powf(1.5)).0,
            }),
            form("power", 2, |s| {
                let (a, b) = fit_ab(s, 0.2, 4.0, |b, u| u.max(0.0).powf(b));
                ForceForm::PowerLaw { a, b }
            }),
            form("exp_growth", 2, |s| {
                let umax = s.iter().map(|x| x.u).fold(1e-9, f64::max);
                let (a, b) = fit_ab(s, 1e-3 / umax, 8.0 / umax, |b, u| (b * u).exp() - 1.0);
                ForceForm::Exponential { a, b }
            }),
        ];
        pool.extend(score_all(samples, cands, &|m: &ForceModel, u| {
            m.force_n(u)
        })?);
        progress(k + 1, features.len());
    }
    // A model on the reciprocal load whenever one fits: the feature contact mechanics
    // carries to indenters other than the calibration's (see `ForceFeature::ReciprocalLoad`;
    // a kit of one sphere cannot tell the features apart, and others that fit the sphere
    // more closely fail on a flat punch). Its form is chosen by the parsimony rule among
    // its own candidates; the rest are scored for the report.
    let physics: Vec<_> = pool
        .iter()
        .filter(|(m, _)| m.feature == ForceFeature::ReciprocalLoad)
        .cloned()
        .collect();
    match choose(physics) {
        Some((m, s, _)) => Some((m, s, pool.into_iter().map(|x| x.1).collect())),
        None => choose(pool),
    }
}

/// Setpoints read at fewer places than this say nothing of how places differ.
pub const PLACE_MIN_SAMPLES: usize = 2;
/// Fewer setpoints than this leave the spread between places unknown.
pub const PLACE_MIN_SETPOINTS: usize = 3;

/// How far a reading of one setpoint at a place the kit did not press may lie from the
/// model, as a share of the setpoint (a standard deviation). A kit presses each depth at
/// more than one place; a unit whose phase gain varies across the view (pigment mottle, a
/// lamp's glare, the lens) reads them apart by a share of the depth, where cross-validation
/// over setpoints averages it with the shallow presses' small errors.
///
/// The spread between places is the pooled standard deviation of `read(u) / y` within
/// each group of `samples` at least `min_y` deep (each group's mean taken out, so whatever
/// bias the model leaves at a setpoint does not count). The model passes through each
/// group's mean, which carries its own `n` places' errors, so a new place lies off it by
/// that spread times `√(1 + 1/n)` (the prediction interval's factor, `n` averaged over the
/// groups as `1/n`): with the usual two places a kit presses, half as much again in
/// variance. `None` with fewer than [`PLACE_MIN_SETPOINTS`] such groups read at
/// [`PLACE_MIN_SAMPLES`] places or more.
pub fn place_spread(samples: &[Sample], read: impl Fn(f64) -> f64, min_y: f64) -> Option<f64> {
    let mut groups: Vec<f64> = samples
        .iter()
        .filter(|s| s.y >= min_y)
        .map(|s| s.group)
        .collect();
    groups.sort_by(f64::total_cmp);
    groups.dedup();
    let (mut ss, mut dof, mut used, mut inverse_places) = (0.0, 0usize, 0usize, 0.0);
    for g in groups {
        let shares: Vec<f64> = samples
            .iter()
            .filter(|s| s.group == g && s.y > 0.0)
            .map(|s| read(s.u) / s.y)
            .collect();
        if shares.len() < PLACE_MIN_SAMPLES {
            continue;
        }
        let mean = shares.iter().sum::<f64>() / shares.len() as f64;
        ss += shares.iter().map(|r| (r - mean).powi(2)).sum::<f64>();
        dof += shares.len() - 1;
        used += 1;
        inverse_places += 1.0 / shares.len() as f64;
    }
    // Each group used gives at least one degree of freedom.
    (used >= PLACE_MIN_SETPOINTS)
        .then(|| (ss / dof as f64 * (1.0 + inverse_places / used as f64)).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Errors of `√(f² + (c·y)²)` over a kit's depths give back `f` and `c`; errors that
    /// do not grow with the depth give no share, errors in proportion to it no floor.
    #[test]
    fn held_out_errors_split_into_a_floor_and_a_share() {
        let pairs = |f: f64, c: f64| -> Vec<(f64, f64)> {
            (1..=12)
                .flat_map(|k| {
                    let y = 0.2 * f64::from(k);
                    let e = f.hypot(c * y);
                    [(y + e, y), (y - e, y)]
                })
                .collect()
        };
        let close = |a: f64, b: f64| (a - b).abs() < 1e-6;
        for (f, c) in [(0.01, 0.02), (0.02, 0.0), (0.0, 0.03)] {
            let e = error_by_depth(&pairs(f, c)).unwrap();
            assert!(close(e.floor_mm, f) && close(e.share, c), "{e:?}");
        }
        // Errors shrinking with the depth: the floor alone, at their mean square.
        let shrinking: Vec<(f64, f64)> = [(0.5, 0.04), (1.0, 0.02), (2.0, 0.01)]
            .iter()
            .map(|&(y, e)| (y + e, y))
            .collect();
        let e = error_by_depth(&shrinking).unwrap();
        let mean_square = (0.04f64.powi(2) + 0.02f64.powi(2) + 0.01f64.powi(2)) / 3.0;
        assert!(
            close(e.share, 0.0) && close(e.floor_mm, mean_square.sqrt()),
            "{e:?}"
        );
        // One depth says nothing of how the error grows.
        assert_eq!(error_by_depth(&[(1.1, 1.0), (0.9, 1.0)]), None);
    }

    #[test]
    fn places_reading_a_depth_apart_by_a_share_of_it_give_that_share() {
        // Two places per depth, one reading 3 % deep and the other 3 % shallow: a pooled
        // standard deviation of 3 % · √2 over one degree of freedom per depth, and a new
        // place off the model (their mean) by that times √(1 + 1/2).
        let samples: Vec<Sample> = (1..=8)
            .flat_map(|k| {
                let y = 0.25 * k as f64;
                [1.03, 0.97].map(|g| Sample {
                    u: y * g,
                    y,
                    group: y,
                })
            })
            .collect();
        let spread = place_spread(&samples, |u| u, 0.0).unwrap();
        let two_places = 0.03 * 2f64.sqrt() * 1.5f64.sqrt();
        assert!((spread - two_places).abs() < 1e-9, "{spread}");
        // A bias shared by both places is the model's, not the places'.
        let biased = place_spread(&samples, |u| 1.1 * u, 0.0).unwrap();
        assert!((biased - 1.1 * two_places).abs() < 1e-9, "{biased}");
        // Only the setpoints at least `min_y` deep count.
        let shallow_only: Vec<Sample> = samples
            .iter()
            .map(|s| Sample {
                u: if s.y < 1.0 { s.u } else { s.y },
                ..*s
            })
            .collect();
        assert_eq!(place_spread(&shallow_only, |u| u, 1.0), Some(0.0));
    }

    #[test]
    fn a_kit_of_more_places_foretells_a_new_place_more_closely() {
        // The same pooled spread between places, read at two and at four places per depth:
        // a new place lies off the model by √(1 + 1/n) of it.
        let at = |gains: &[f64]| -> Vec<Sample> {
            (1..=8)
                .flat_map(|k| {
                    let y = 0.25 * k as f64;
                    gains.iter().map(move |&g| Sample {
                        u: y * g,
                        y,
                        group: y,
                    })
                })
                .collect()
        };
        let two = place_spread(&at(&[1.03, 0.97]), |u| u, 0.0).unwrap();
        // 3 % off the mean at each of four places: a pooled deviation of 3 % · √(4/3).
        let four = place_spread(&at(&[1.03, 0.97, 1.03, 0.97]), |u| u, 0.0).unwrap();
        let between = |n: f64| 0.03 * (n / (n - 1.0)).sqrt();
        assert!((two - between(2.0) * 1.5f64.sqrt()).abs() < 1e-9, "{two}");
        assert!(
            (four - between(4.0) * 1.25f64.sqrt()).abs() < 1e-9,
            "{four}"
        );
    }

    #[test]
    fn too_few_setpoints_read_at_two_places_leave_the_spread_unknown() {
        let one_place: Vec<Sample> = (1..=8)
            .map(|k| Sample {
                u: 0.25 * k as f64,
                y: 0.25 * k as f64,
                group: k as f64,
            })
            .collect();
        assert_eq!(place_spread(&one_place, |u| u, 0.0), None);
        let two: Vec<Sample> = (1..=2)
            .flat_map(|k| {
                [0.99, 1.01].map(|g| Sample {
                    u: g * k as f64,
                    y: k as f64,
                    group: k as f64,
                })
            })
            .collect();
        assert_eq!(place_spread(&two, |u| u, 0.0), None);
    }

    fn samples(f: impl Fn(f64) -> f64, noise: f64) -> Vec<Sample> {
        (1..=12)
            .flat_map(|g| {
                let u = g as f64 * 0.25;
                [-1.0, 1.0].map(|s| Sample {
                    u: u * (1.0 + 0.01 * s),
                    y: f(u) + s * noise,
                    group: g as f64,
                })
            })
            .collect()
    }

    #[test]
    fn recovers_a_hinge_and_prefers_fewer_parameters_when_linear_suffices() {
        let s = samples(|u| 2.0 * (1.0 - (-0.8 * u).exp()), 0.005);
        let (m, score, all) = fit_depth(&s, |_, _| {}).unwrap();
        assert_eq!(all.len(), 6);
        assert!(
            matches!(m, DepthModel::Hinge { .. } | DepthModel::Monotone { .. }),
            "{m:?}"
        );
        assert!(score.cv_rmse < 0.03, "{score:?}");
        let lin = samples(|u| 0.7 * u, 0.01);
        let (m, _, _) = fit_depth(&lin, |_, _| {}).unwrap();
        assert!(
            matches!(m, DepthModel::Linear { .. }),
            "parsimony picks linear: {m:?}"
        );
    }

    /// A phase saturating between an exponential and a `tanh` (an inverse no two-parameter
    /// form follows along the whole range) is left to the cubic, which follows it several
    /// times closer than the best of them.
    #[test]
    fn a_response_no_two_parameter_form_follows_is_left_to_the_cubic() {
        let (s_mm, g) = (3.0, 1.2);
        let phase = |d: f64| g * s_mm * (0.5 * (1.0 - (-d / s_mm).exp()) + 0.5 * (d / s_mm).tanh());
        let samples: Vec<Sample> = (1..=12)
            .flat_map(|k| {
                let d = 0.2 * k as f64;
                [-1.0, 1.0].map(|e| Sample {
                    u: phase(d),
                    y: d + e * 0.002,
                    group: k as f64,
                })
            })
            .collect();
        let (m, score, all) = fit_depth(&samples, |_, _| {}).unwrap();
        assert!(
            matches!(&m, DepthModel::Polynomial { c_mm } if c_mm.len() == 3),
            "{m:?} {all:?}"
        );
        assert!(score.cv_rmse < 0.006, "{score:?}");
        let two = all
            .iter()
            .filter(|c| c.params == 2)
            .map(|c| c.cv_rmse)
            .fold(f64::INFINITY, f64::min);
        assert!(two > 3.0 * score.cv_rmse, "{all:?}");
    }

    /// A polynomial that falls within twice its setpoints' phases is never chosen, however
    /// well it fits them.
    #[test]
    fn a_polynomial_turning_down_past_its_setpoints_is_not_chosen() {
        // Depth saturating with phase: the quadratic's and cubic's fits turn over soon
        // after the last setpoint.
        let s = samples(|u| 2.0 * (1.0 - (-1.2 * u).exp()), 0.0005);
        let (m, _, all) = fit_depth(&s, |_, _| {}).unwrap();
        assert!(!matches!(m, DepthModel::Polynomial { .. }), "{m:?}");
        let range = FitRange::of(s.iter().map(|x| (x.u, x.y)));
        let quadratic = all.iter().find(|c| c.name == "quadratic").unwrap();
        assert!(
            quadratic
                .refused
                .as_deref()
                .is_some_and(|why| why.contains("must not decrease")),
            "{quadratic:?}"
        );
        for (name, n) in [("quadratic", 2), ("cubic", 3)] {
            let poly = DepthModel::Polynomial {
                c_mm: polynomial_fit(&s, n),
            };
            let score = all.iter().find(|c| c.name == name).unwrap();
            assert_eq!(
                check_depth(&poly, range.as_ref()).is_err(),
                score.refused.is_some(),
                "{name}: {score:?}"
            );
        }
    }

    #[test]
    fn polynomial_least_squares_recovers_exact_coefficients() {
        let s: Vec<Sample> = (1..=9)
            .map(|k| {
                let u = 0.3 * k as f64;
                Sample {
                    u,
                    y: 0.4 * u + 0.05 * u * u - 0.004 * u * u * u,
                    group: k as f64,
                }
            })
            .collect();
        let c = polynomial_fit(&s, 3);
        // Within the shared solver's ridge.
        for (got, want) in c.iter().zip([0.4, 0.05, -0.004]) {
            assert!((got - want).abs() < 1e-6, "{c:?}");
        }
    }

    #[test]
    fn force_selection_finds_the_generating_feature_and_form() {
        let good = samples(|u| 6.7 * u.powf(1.5), 0.05);
        let bad = samples(|u| (u * 7.0).sin().abs() * 10.0, 0.05);
        let (m, score, _) = fit_force(
            &[
                (ForceFeature::ContactArea, bad),
                (ForceFeature::PeakDepth, good),
            ],
            |_, _| {},
        )
        .unwrap();
        assert_eq!(m.feature, ForceFeature::PeakDepth);
        assert!(
            matches!(m.form, ForceForm::Hertz { .. } | ForceForm::PowerLaw { .. }),
            "{m:?}"
        );
        assert!(score.cv_rmse < 0.5, "{score:?}");
    }

    #[test]
    fn isotonic_is_monotone_through_the_origin_and_extrapolates_smoothly() {
        let sample = |u, y, group| Sample { u, y, group };
        let s = vec![
            sample(1.0, 1.0, 1.0),
            sample(2.0, 0.7, 2.0),
            sample(2.0, 0.9, 2.0),
            sample(3.0, 2.0, 3.0),
            sample(3.001, 2.2, 4.0),
        ];
        let (x, d) = isotonic(&s);
        assert!(d.windows(2).all(|p| p[1] >= p[0]));
        assert_eq!(x.len(), d.len());
        assert!((d[0] - 0.9).abs() < 1e-12, "1.0 and group 2 pool to 0.9");
        // Two near-duplicate last setpoints do not make the extrapolation explode.
        let m = DepthModel::Monotone { x_rad: x, d_mm: d };
        assert!(m.depth_mm(4.0) < 4.0, "{}", m.depth_mm(4.0));
    }

    /// A one-sphere kit cannot tell which feature carries to other indenters: the
    /// reciprocal load is chosen whenever it fits, even when a volume power law fits the
    /// sphere more closely, and its form by the parsimony rule (linear for linear data).
    /// Without it the rule chooses among the rest.
    #[test]
    fn the_reciprocal_load_is_chosen_whenever_it_fits_its_form_by_parsimony() {
        let volume = samples(|u| 3.0 * u.powf(0.8), 0.01);
        let load = samples(|u| 2.0 * u, 0.2);
        let (m, _, all) = fit_force(
            &[
                (ForceFeature::Volume, volume.clone()),
                (ForceFeature::ReciprocalLoad, load),
            ],
            |_, _| {},
        )
        .unwrap();
        assert_eq!(m.feature, ForceFeature::ReciprocalLoad);
        assert!(matches!(m.form, ForceForm::Linear { .. }), "{m:?}");
        // Every candidate is still scored for the report.
        assert!(all
            .iter()
            .any(|c| c.name.contains(ForceFeature::Volume.symbol())));
        let (m, _, _) = fit_force(&[(ForceFeature::Volume, volume)], |_, _| {}).unwrap();
        assert_eq!(m.feature, ForceFeature::Volume);
    }
}
