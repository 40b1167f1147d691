//! Choosing the field a frame shows and spreading it over the coarse grid: what the
//! measurement takes out of a frame's phase.

use crate::calibration::colour_phase::{at, median, nodes_of, ColourPhase};
use crate::phase::PhaseNum;
use crate::unwrap::Phase;

/// A field is chosen only where it lowers the frame's mismatch ([`Candidates::choose`]) by
/// more than this share of what it would lower it by were the frame to show it whole
/// over its noise (`Mismatch::gain`): a frame that does not show it is raised by as much,
/// so the frame must show more than half of the field. A large press, which adds the
/// same to every candidate's mismatch, does not enter the test, and the noise is read
/// between neighbouring nodes, which a press moves alike.
pub const SHOWN_SHARE: f64 = 0.5;

/// Where between the best setpoint's field and a neighbour's a frame's field is also
/// looked for: the share of the neighbour's. The colour moves fastest between setpoints a
/// degree or two apart, faster than a straight line between them follows, and a skin
/// lies anywhere between.
pub const BETWEEN: [f64; 3] = [0.25, 0.5, 0.75];

/// The scales the chosen field is also tried at. The pull of the fixed term on the
/// fringe's phase grows as the fringe's amplitude falls against it, and the camera's
/// exposure and white balance move from frame to frame (`docs/pipeline.md` gives a frame
/// that showed twice what its kit did).
pub const SCALES: [f64; 5] = [0.5, 0.75, 1.25, 1.5, 2.0];

/// A node's phase is the colour's only within the most any field reaches there (at the
/// largest of [`SCALES`]) plus this many of the frame's noise.
pub const REACH_SIGMAS: f64 = 4.0;

/// `a` moved a share `w` of the way to `b`, node by node.
fn mixed(a: &[i32], b: &[i32], w: f64) -> Vec<i32> {
    let mix = |(&a, &b): (&i32, &i32)| a + (w * f64::from(i32::wrapped_diff(b, a))).round() as i32;
    a.iter().zip(b).map(mix).collect()
}

/// A frame's phase at its reliable nodes, and what is left of it once a field is taken out.
struct Mismatch {
    /// `(node, units)` of the reliable nodes.
    at: Vec<(usize, i32)>,
    /// The phase's median over them (its registration), units.
    offset: i32,
    /// Room to find medians in.
    order: Vec<i32>,
}

impl Mismatch {
    fn new(at: Vec<(usize, i32)>) -> Mismatch {
        let mut order: Vec<i32> = at.iter().map(|&(_, p)| p).collect();
        let offset = median(&mut order);
        Mismatch { at, offset, order }
    }

    /// What the phase departs from the registration by at each of `n` nodes (units), and
    /// whether the node is read: what [`Mismatch::change`] reads.
    fn left(&self, n: usize) -> (Vec<i32>, Vec<bool>) {
        let (mut left, mut read) = (vec![0; n], vec![false; n]);
        for &(node, p) in &self.at {
            if let (Some(l), Some(r)) = (left.get_mut(node), read.get_mut(node)) {
                (*l, *r) = (i32::wrapped_diff(p, self.offset), true);
            }
        }
        (left, read)
    }

    /// Keeps the nodes whose phase departs from the registration by no more than the
    /// node's `reach` plus [`REACH_SIGMAS`] of the `noise`.
    fn retain_within(&mut self, reach: &[i32], noise: f64) {
        let slack = REACH_SIGMAS * noise;
        let offset = self.offset;
        self.at.retain(|&(node, p)| {
            let r = reach.get(node).map_or(0.0, |&r| f64::from(r));
            f64::from(i32::wrapped_diff(p, offset).abs()) <= r + slack
        });
    }

    /// The phase's noise at a node, units: the robust spread (1.4826 × MAD) of the
    /// differences between neighbouring reliable nodes along a row (`nw` nodes), over √2.
    /// A press or a field moves neighbours alike, so neither counts as noise.
    fn noise(&mut self, nw: usize) -> f64 {
        self.order.clear();
        let pairs = self
            .at
            .windows(2)
            .filter(|p| p[1].0 == p[0].0 + 1 && p[1].0 % nw != 0);
        self.order
            .extend(pairs.map(|p| i32::wrapped_diff(p[1].1, p[0].1)));
        let m = median(&mut self.order);
        for v in &mut self.order {
            *v = i32::wrapped_diff(*v, m).abs();
        }
        1.4826 * f64::from(median(&mut self.order)) / std::f64::consts::SQRT_2
    }

    /// How much taking `field` out lowers the mismatch of a frame that shows it whole,
    /// over noise of spread `sigma` (units): at each node, what a Gaussian's mean absolute
    /// value gains from an offset of the field's size. A field well above the noise gains
    /// nearly its size, one within it far less: a faint field in a noisy frame is held to
    /// what it can show.
    fn gain(&self, field: &[i32], sigma: f64) -> f64 {
        let g = |&(node, _): &(usize, i32)| field.get(node).map_or(0, |u| u.abs());
        let spots = self.at.iter().map(g).filter(|&g| g != 0);
        spots.map(|g| abs_mean_gain(f64::from(g), sigma)).sum()
    }
}

/// `E|n + g| − E|n|` for `n` Gaussian of spread `sigma` and an offset `g ≥ 0`.
fn abs_mean_gain(g: f64, sigma: f64) -> f64 {
    if sigma <= 0.0 {
        return g;
    }
    let root_2_over_pi = (2.0 / std::f64::consts::PI).sqrt();
    let z = g / sigma;
    sigma * root_2_over_pi * ((-z * z / 2.0).exp() - 1.0) + g * erf(z / std::f64::consts::SQRT_2)
}

/// The error function (Abramowitz and Stegun 7.1.26, within 1.5 × 10⁻⁷).
fn erf(x: f64) -> f64 {
    let t = 1.0 / (1.0 + 0.327_591_1 * x.abs());
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    (1.0 - poly * (-x * x).exp()).copysign(x)
}

/// The colour's fields relative to one reference: what a frame's phase is compared with.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Candidates {
    /// Coarse samples between nodes, and the nodes across and down.
    pub(super) step: usize,
    pub(super) nodes: [usize; 2],
    /// Per setpoint, units per node.
    pub(super) fields: Vec<Vec<i32>>,
    /// Each field's nodes where it is not zero, with its value there.
    pub(super) spots: Vec<Vec<(usize, i32)>>,
    /// Per node, the most any field reaches there at the largest of [`SCALES`], units.
    pub(super) reach: Vec<i32>,
    /// Every setpoint's temperature, °C, and field (units per node), those that move
    /// nothing included: what a temperature read leaves to take out.
    pub(super) by_temperature: (Vec<f64>, Vec<Vec<i32>>),
}

impl Candidates {
    /// The fields of `record` relative to a reference taken at `reference_c` (°C; the
    /// kit's own reference temperature where the reference's is unknown): each setpoint's less the
    /// field at the reference's temperature, those that move nothing dropped. Empty where
    /// the record names nodes it does not have.
    pub fn relative_to(record: &ColourPhase, reference_c: Option<f64>) -> Candidates {
        let dense = record.dense().unwrap_or_default();
        let temps: Vec<f64> = record.setpoints.iter().map(|f| f.t_c).collect();
        let base = reference_c.map(|t| at(&temps, &dense, t));
        let fields = dense
            .into_iter()
            .map(|f| match &base {
                Some(b) => f
                    .iter()
                    .zip(b)
                    .map(|(&u, &b)| i32::wrapped_diff(u, b))
                    .collect(),
                None => f,
            })
            .collect();
        Candidates::new(record.step.max(1), record.nodes, (temps, fields))
    }
    /// The candidates `fields` (units per node) on `nodes` nodes `step` coarse samples
    /// apart.
    pub(super) fn new(
        step: usize,
        nodes: [usize; 2],
        (temps, all): (Vec<f64>, Vec<Vec<i32>>),
    ) -> Candidates {
        let fields: Vec<Vec<i32>> = (all.iter())
            .filter(|f| f.iter().any(|&u| u != 0))
            .cloned()
            .collect();
        let most = SCALES.iter().fold(1.0f64, |a, &b| a.max(b));
        let mut reach = vec![0; nodes[0] * nodes[1]];
        for f in &fields {
            for (r, &u) in reach.iter_mut().zip(f) {
                *r = (*r).max((most * f64::from(u.abs())).ceil() as i32);
            }
        }
        let spots = (fields.iter())
            .map(|f| {
                (f.iter().enumerate().filter(|(_, &u)| u != 0))
                    .map(|(k, &u)| (k, u))
                    .collect()
            })
            .collect();
        Candidates {
            step,
            nodes,
            fields,
            spots,
            reach,
            by_temperature: (temps, all),
        }
    }

    /// Whether the field at a skin temperature of `t_c` (°C; between setpoints, the line
    /// between theirs) reaches `threshold` (units) at some node.
    pub fn reaches_at(&self, t_c: f64, threshold: i32) -> bool {
        let (temps, all) = &self.by_temperature;
        at(temps, all, t_c).iter().any(|u| u.abs() >= threshold)
    }

    /// Whether there is any field to take out.
    pub fn is_empty(&self) -> bool {
        self.fields.is_empty()
    }

    /// The field that best explains the coarse phase `phase` (`cw × ch` samples, reliable
    /// where `rel`) at the nodes, spread over every coarse sample (units); `None` where the
    /// frame does not show the best field, or where the grid is not the calibration's.
    ///
    /// The mismatch is the summed absolute departure of the phase less the field from the
    /// phase's registration (its median), over the reliable nodes: a press adds the same to
    /// every candidate except where it overlaps a field's spots, while a field's spots add
    /// theirs wherever the frame does not show them ([`SHOWN_SHARE`]).
    pub fn choose<P: PhaseNum>(
        &self,
        phase: &[P],
        rel: &[bool],
        (cw, ch): (usize, usize),
    ) -> Option<Vec<i32>> {
        if self.fields.is_empty() || nodes_of((cw, ch), self.step) != self.nodes {
            return None;
        }
        let mut m = Mismatch::new(self.read(phase, rel, cw));
        if m.at.is_empty() {
            return None;
        }
        let nw = self.nodes[0];
        // A node whose phase no field reaches (a press) is not the colour's: where a press
        // overlaps a field of its own sign, the field would lower the mismatch by its whole
        // size there.
        let noise = m.noise(nw);
        m.retain_within(&self.reach, noise);
        let noise = m.noise(nw);
        let (best, change) = self.best_fit(&m);
        let shown = -change as f64 > SHOWN_SHARE * m.gain(&best, noise);
        shown.then(|| self.spread(&best, (cw, ch)))
    }

    /// The reliable nodes' phase: `(node, units)`.
    fn read<P: PhaseNum>(&self, phase: &[P], rel: &[bool], cw: usize) -> Vec<(usize, i32)> {
        let [nw, nh] = self.nodes;
        let cells = (0..nh).flat_map(|j| (0..nw).map(move |i| (i, j)));
        cells
            .enumerate()
            .filter_map(|(node, (i, j))| {
                let k = j * self.step * cw + i * self.step;
                (*rel.get(k)?).then(|| Some((node, phase.get(k)?.units())))?
            })
            .collect()
    }

    /// The field that leaves the least mismatch `m`, and what taking it out changes the
    /// mismatch by (units; negative where it lowers it): the best setpoint's,
    /// then mixed with a neighbour's ([`BETWEEN`]), then scaled ([`SCALES`]).
    fn best_fit(&self, m: &Mismatch) -> (Vec<i32>, i64) {
        // A field changes the mismatch only where it is not zero: each costs what taking
        // it out changes there (the fields are sparse, the frame's nodes many).
        let (left, read) = m.left(self.nodes[0] * self.nodes[1]);
        let change = |spots: &mut dyn Iterator<Item = (usize, i32)>| -> i64 {
            spots
                .filter(|&(node, _)| read[node])
                .map(|(node, g)| {
                    let l = left[node];
                    i64::from(i32::wrapped_diff(l, g).abs()) - i64::from(l.abs())
                })
                .sum()
        };
        let dense = |f: &[i32]| -> i64 {
            let mut spots = f
                .iter()
                .enumerate()
                .filter(|(_, &g)| g != 0)
                .map(|(k, &g)| (k, g));
            change(&mut spots)
        };
        let costs: Vec<i64> = (self.spots.iter())
            .map(|f| change(&mut f.iter().copied()))
            .collect();
        let b = (0..costs.len()).min_by_key(|&i| costs[i]).unwrap_or(0);
        let mut best = (self.fields[b].clone(), costs[b]);
        let try_field = |f: Vec<i32>, best: &mut (Vec<i32>, i64)| {
            let c = dense(&f);
            if c < best.1 {
                *best = (f, c);
            }
        };
        let neighbours = [b.checked_sub(1), Some(b + 1).filter(|&i| i < costs.len())];
        for nb in neighbours.into_iter().flatten() {
            for w in BETWEEN {
                try_field(mixed(&self.fields[b], &self.fields[nb], w), &mut best);
            }
        }
        let found = best.0.clone();
        for k in SCALES {
            let scaled = found.iter().map(|&u| (k * f64::from(u)).round() as i32);
            try_field(scaled.collect(), &mut best);
        }
        best
    }

    /// A node field spread bilinearly over the coarse grid (`cw × ch`); beyond the last
    /// node, the last node's values.
    pub(super) fn spread(&self, field: &[i32], (cw, ch): (usize, usize)) -> Vec<i32> {
        let [nw, nh] = self.nodes;
        let node = |i: usize, j: usize| field[j.min(nh - 1) * nw + i.min(nw - 1)];
        let (s, step) = (self.step, self.step as i64);
        let mut out = Vec::with_capacity(cw * ch);
        for cy in 0..ch {
            let (j, fy) = (cy / s, (cy % s) as i64);
            for cx in 0..cw {
                let (i, fx) = (cx / s, (cx % s) as i64);
                let top = i64::from(node(i, j)) * (step - fx) + i64::from(node(i + 1, j)) * fx;
                let bottom =
                    i64::from(node(i, j + 1)) * (step - fx) + i64::from(node(i + 1, j + 1)) * fx;
                out.push(((top * (step - fy) + bottom * fy) / (step * step)) as i32);
            }
        }
        out
    }
}
