//! The record of the colour's phase the calibration writes: each setpoint's field on a
//! grid of nodes, kept where it stands out of the kit frames' noise. What a frame does
//! with it is [`crate::measure::colour_phase`]'s.

use serde::{Deserialize, Serialize};

use crate::phase::GRID;
use crate::unwrap::Phase;

/// Nodes per carrier period, each way: the field is smooth over a period (the
/// demodulator's kernel), and a lamp's reflection a period or two across is followed.
pub const NODES_PER_PERIOD: f32 = 2.0;

/// Most nodes a frame's phase is compared at: the choice reads every candidate at each
/// (`Candidates::choose`), and a frame's time is the device's budget.
pub const MAX_NODES_READ: usize = 1200;

/// Coarse samples between nodes for a carrier period of `period_px` working pixels on a
/// coarse grid of `cw × ch` samples: [`NODES_PER_PERIOD`], fewer where the grid would hold
/// more than [`MAX_NODES_READ`], at least one.
pub fn node_step(period_px: f32, (cw, ch): (usize, usize)) -> usize {
    let per_period = (period_px / (NODES_PER_PERIOD * GRID as f32)).round() as usize;
    let cap = ((cw * ch) as f64 / MAX_NODES_READ as f64).sqrt().ceil() as usize;
    per_period.max(cap).max(1)
}

/// The nodes (across, down) of a coarse grid `cw × ch` samples, `step` apart.
pub fn nodes_of((cw, ch): (usize, usize), step: usize) -> [usize; 2] {
    let step = step.max(1);
    [cw.div_ceil(step), ch.div_ceil(step)]
}

/// Median of `v` (0 when empty), reordering it.
pub(crate) fn median(v: &mut [i32]) -> i32 {
    if v.is_empty() {
        return 0;
    }
    let k = v.len() / 2;
    *v.select_nth_unstable(k).1
}

/// A setpoint's field counts at a node only beyond this many of its noise there (what the
/// kit's frames at one setpoint leave unexplained): elsewhere it is zero,
/// so taking it out adds no noise where there is nothing to take out.
pub const SIGNIFICANT_SIGMAS: f64 = 4.0;

/// What the calibration's uniform frames show of the colour's phase, per setpoint.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ColourPhase {
    /// Coarse samples between nodes, each way ([`node_step`]).
    pub step: usize,
    /// Nodes across and down: every `step`-th coarse sample of the calibration's working
    /// grid, from the first.
    pub nodes: [usize; 2],
    /// The fields, by rising temperature.
    pub setpoints: Vec<SetpointField>,
}

/// One setpoint's field, kept where it stands out of the noise (zero at every other node).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SetpointField {
    /// The setpoint, °C.
    pub t_c: f64,
    /// The phase against the kit's reference, less the frame's registration, at the nodes
    /// where it stands out: `[node, units]`, the node counted row-major, units of 2π/65 536.
    /// Written as one string of `node:units` pairs (`"12:-345 13:678"`), rising by node: a
    /// field holds hundreds of them.
    #[serde(with = "spots_text")]
    pub spots: Vec<[i32; 2]>,
}

/// [`SetpointField::spots`] as text: `node:units` pairs separated by spaces.
mod spots_text {
    use serde::{de::Error, Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(spots: &[[i32; 2]], s: S) -> Result<S::Ok, S::Error> {
        let pairs: Vec<String> = spots.iter().map(|[n, u]| format!("{n}:{u}")).collect();
        s.serialize_str(&pairs.join(" "))
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<[i32; 2]>, D::Error> {
        let text = String::deserialize(d)?;
        (text.split_whitespace())
            .map(|pair| {
                let parsed = pair
                    .split_once(':')
                    .and_then(|(n, u)| Some([n.parse().ok()?, u.parse().ok()?]));
                parsed.ok_or_else(|| {
                    D::Error::custom(format!("spot {pair:?}: expected node:units (integers)"))
                })
            })
            .collect()
    }
}

impl SetpointField {
    /// The field at every one of `n` nodes, units; `None` where a spot names no node.
    fn dense(&self, n: usize) -> Option<Vec<i32>> {
        let mut out = vec![0; n];
        for &[node, u] in &self.spots {
            *out.get_mut(usize::try_from(node).ok()?)? = u;
        }
        Some(out)
    }
}

impl ColourPhase {
    /// Why the record cannot serve a plan, if it cannot: a step of at least one sample,
    /// nodes across and down, setpoints finite and rising, and every spot on a node, rising
    /// by node, within half a turn.
    pub fn invalid(&self) -> Option<String> {
        let n = self.nodes[0].saturating_mul(self.nodes[1]);
        if self.step == 0 || n == 0 || n > MAX_NODES {
            return Some(format!(
                "step {} and nodes {:?}: need a step of 1 or more and 1…{MAX_NODES} nodes",
                self.step, self.nodes
            ));
        }
        let t = |f: &SetpointField| f.t_c;
        if !(self.setpoints.iter().all(|f| f.t_c.is_finite()))
            || self.setpoints.windows(2).any(|p| t(&p[1]) <= t(&p[0]))
        {
            return Some("setpoints must be finite temperatures, rising".into());
        }
        let half_turn = i32::from(i16::MAX);
        for f in &self.setpoints {
            let on_nodes = f.spots.iter().all(|&[node, u]| {
                usize::try_from(node).is_ok_and(|k| k < n) && u.abs() <= half_turn
            });
            if !on_nodes || f.spots.windows(2).any(|p| p[1][0] <= p[0][0]) {
                return Some(format!(
                    "setpoint {} °C: spots must name nodes 0…{} in rising order, each within                      half a turn (±{half_turn} units)",
                    f.t_c,
                    n - 1
                ));
            }
        }
        None
    }
}

/// Most nodes a record may hold (a 4K camera at one node per coarse sample holds less).
pub const MAX_NODES: usize = 1 << 22;

/// A frame's phase difference at the nodes of its coarse grid (`cw × ch` samples, units,
/// row-major), less its registration `offset`, each the mean over the samples within
/// half a carrier period (`period_px` working pixels) of the node; with the step between
/// nodes ([`node_step`]) and the nodes across and down. Every node is read, the view's
/// margins and faint fringes included: the colour moves the phase there too (most of all
/// under the lamps' reflections near the border), and a contact reaching there reads it;
/// where a node's phase is noise, it stays within the kit's noise and is dropped
/// ([`ColourPhase::from_frames`]).
///
/// The mean over a period keeps the field's smooth part, which nodes half a period apart
/// follow. Where the colour changes the stripes' profile, their harmonics folded onto the
/// band add a ripple of about the grating's period; nodes that sample it would put it
/// back, misplaced, between them, so it is left in the frame as it was.
pub fn at_nodes(
    coarse: &[i32],
    offset: i32,
    (cw, ch): (usize, usize),
    period_px: f32,
) -> ((usize, [usize; 2]), Vec<Option<i32>>) {
    let step = node_step(period_px, (cw, ch));
    let nodes = nodes_of((cw, ch), step);
    let r = ((period_px / GRID as f32 - 1.0) / 2.0).round().max(0.0) as usize;
    let mean = |cx: usize, cy: usize| {
        let (xs, ys) = (
            cx.saturating_sub(r)..(cx + r + 1).min(cw),
            cy.saturating_sub(r)..(cy + r + 1).min(ch),
        );
        let (mut sum, mut n) = (0i64, 0i64);
        for y in ys {
            for &u in coarse.get(y * cw + xs.start..y * cw + xs.end)? {
                sum += i64::from(i32::wrapped_diff(u, offset));
                n += 1;
            }
        }
        (n > 0).then(|| (sum / n) as i32)
    };
    let all = (0..nodes[1]).flat_map(|j| (0..nodes[0]).map(move |i| (i * step, j * step)));
    ((step, nodes), all.map(|(cx, cy)| mean(cx, cy)).collect())
}

impl ColourPhase {
    /// The fields of the kit's uniform frames: each frame's setpoint (°C) and its phase at
    /// the nodes (`nodes`), less its registration (units; `None` where unreliable).
    /// Frames of a setpoint are averaged. `None` with fewer than two setpoints, or where a
    /// frame's nodes are not `nodes` (`step` coarse samples apart).
    pub fn from_frames(
        (step, nodes): (usize, [usize; 2]),
        frames: &[(f64, Vec<Option<i32>>)],
    ) -> Option<Self> {
        let n = nodes[0] * nodes[1];
        if frames.iter().any(|(_, v)| v.len() != n) {
            return None;
        }
        let key = |t: f64| (t * 1000.0).round() / 1000.0;
        let mut temps: Vec<f64> = frames.iter().map(|(t, _)| key(*t)).collect();
        temps.sort_by(f64::total_cmp);
        temps.dedup();
        if temps.len() < 2 {
            return None;
        }
        let of = |t: f64| frames.iter().filter(move |(ft, _)| key(*ft) == t);
        let means: Vec<Vec<Option<i32>>> = (temps.iter())
            .map(|&t| mean_field(of(t).map(|(_, v)| v.as_slice()), n))
            .collect();
        let pairs: Vec<FramePair<'_>> = (temps.iter())
            .filter_map(|&t| {
                let mut two = of(t);
                Some((two.next()?.1.as_slice(), two.next()?.1.as_slice()))
            })
            .collect();
        let sigma = node_noise(&pairs, n);
        let needed = sigma.as_deref().map(|s| needed(&temps, &means, s));
        let setpoints = temps
            .iter()
            .zip(&means)
            .enumerate()
            .filter(|(i, _)| needed.as_ref().is_none_or(|k| k[*i]))
            .map(|(_, (&t, mean))| SetpointField {
                t_c: t,
                spots: significant(mean, sigma.as_deref()),
            })
            .collect();
        Some(ColourPhase {
            step,
            nodes,
            setpoints,
        })
    }

    /// Every setpoint's field at every node, units; `None` where a spot names no node.
    pub(crate) fn dense(&self) -> Option<Vec<Vec<i32>>> {
        let n = self.nodes[0] * self.nodes[1];
        self.setpoints.iter().map(|f| f.dense(n)).collect()
    }
}

/// The field at `t_c` of the fields `dense` at temperatures `temps` (rising), units per
/// node: linear between the setpoints around it, the nearest one's beyond them.
pub(crate) fn at(temps: &[f64], dense: &[Vec<i32>], t_c: f64) -> Vec<i32> {
    let above = temps.partition_point(|&t| t < t_c).min(dense.len());
    match (above.checked_sub(1), dense.get(above)) {
        (Some(lo), Some(hi)) if temps[above] > temps[lo] => {
            let w = (t_c - temps[lo]) / (temps[above] - temps[lo]);
            let mix = |(&a, &b): (&i32, &i32)| {
                (f64::from(a) + w * (f64::from(b) - f64::from(a))).round() as i32
            };
            dense[lo].iter().zip(hi).map(mix).collect()
        }
        (Some(lo), _) => dense[lo].clone(),
        (None, Some(hi)) => hi.clone(),
        (None, None) => Vec::new(),
    }
}

/// The mean of the frames' node values (`None`s skipped; `None` where no frame has one).
fn mean_field<'a>(frames: impl Iterator<Item = &'a [Option<i32>]>, n: usize) -> Vec<Option<i32>> {
    let mut sum = vec![(0i64, 0i64); n];
    for f in frames {
        for (s, v) in sum.iter_mut().zip(f) {
            if let Some(v) = v {
                *s = (s.0 + i64::from(*v), s.1 + 1);
            }
        }
    }
    sum.iter()
        .map(|&(s, c)| (c > 0).then(|| (s / c) as i32))
        .collect()
}

/// A setpoint's field is left out of the record where the straight line between its
/// neighbours' reproduces it within [`SIGNIFICANT_SIGMAS`] of the noise at all but this
/// share of the nodes: where the pigment has cleared, or its colour moves steadily, the
/// line serves as well.
pub const REDUNDANT_MISS_SHARE: f64 = 0.01;

/// Which setpoints (at `temps`, with mean fields `means`, and each node's noise `sigma`)
/// the record needs: the first and the last, and each one the line from the last one kept
/// to the next does not reproduce ([`REDUNDANT_MISS_SHARE`]).
fn needed(temps: &[f64], means: &[Vec<Option<i32>>], sigma: &[f64]) -> Vec<bool> {
    let mut keep = vec![true; temps.len()];
    let mut last = 0;
    for i in 1..temps.len().saturating_sub(1) {
        let w = (temps[i] - temps[last]) / (temps[i + 1] - temps[last]);
        let misses = (means[i]
            .iter()
            .zip(&means[last])
            .zip(&means[i + 1])
            .zip(sigma))
        .filter(|(((v, a), b), s)| match (v, a, b) {
            (Some(v), Some(a), Some(b)) => {
                let line = f64::from(*a) + w * f64::from(i32::wrapped_diff(*b, *a));
                (f64::from(*v) - line).abs() > SIGNIFICANT_SIGMAS * **s
            }
            _ => false,
        })
        .count();
        keep[i] = misses as f64 > REDUNDANT_MISS_SHARE * sigma.len() as f64;
        if keep[i] {
            last = i;
        }
    }
    keep
}

/// Two frames of one setpoint, their phase at each node (`None` where unread).
type FramePair<'a> = (&'a [Option<i32>], &'a [Option<i32>]);

/// Fewest setpoints with two frames each from which a node's noise is estimated: with
/// fewer, a field is held to its own robust spread over the nodes.
pub const MIN_NOISE_PAIRS: usize = 5;

/// Each node's noise in a two-frame setpoint mean, units: 1.4826 × the median over the
/// setpoints of half the two frames' difference (which has the mean's spread: the sensor's
/// noise and the frame-to-frame drift of light and exposure, all the kit cannot predict).
/// Per node, since the fringe is fainter, and its phase noisier, in some places than
/// others. `None` with fewer than [`MIN_NOISE_PAIRS`] setpoints of two frames.
fn node_noise(pairs: &[FramePair<'_>], n: usize) -> Option<Vec<f64>> {
    if pairs.len() < MIN_NOISE_PAIRS {
        return None;
    }
    let mut half = Vec::with_capacity(pairs.len());
    let sigma = (0..n)
        .map(|k| {
            half.clear();
            half.extend(pairs.iter().filter_map(|(a, b)| {
                let (a, b) = (a.get(k).copied().flatten()?, b.get(k).copied().flatten()?);
                Some(i32::wrapped_diff(a, b).abs() / 2)
            }));
            1.4826 * f64::from(median(&mut half))
        })
        .collect();
    Some(sigma)
}

/// The nodes of `field` beyond [`SIGNIFICANT_SIGMAS`] of their noise, as `[node, units]`:
/// each node's own (`sigma`), or without it the field's robust spread (1.4826 × the
/// median absolute value over the nodes that have a value: most of the view is flat).
fn significant(field: &[Option<i32>], sigma: Option<&[f64]>) -> Vec<[i32; 2]> {
    let spread = || {
        let mut abs: Vec<i32> = field.iter().flatten().map(|v| v.abs()).collect();
        1.4826 * f64::from(median(&mut abs))
    };
    let flat = sigma.is_none().then(spread).unwrap_or(0.0);
    (field.iter().enumerate())
        .filter_map(|(node, v)| {
            let v = (*v)?;
            let s = sigma.and_then(|s| s.get(node).copied()).unwrap_or(flat);
            let bar = (SIGNIFICANT_SIGMAS * s).max(1.0);
            (f64::from(v.abs()) > bar).then_some([node as i32, v])
        })
        .collect()
}
