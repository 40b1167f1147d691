//! The contact's peak depth, corrected for the demodulator's blur.
//!
//! The phase map is the true phase convolved with the demodulator's low-pass `K` (a
//! triangle a grating period each way, [`crate::ftp::band::box_lengths`]), which lowers a
//! rounded apex and spares a plateau. A calibration on a sphere that read the blurred apex
//! would learn the sphere's loss as part of its depth model, and every other indenter would
//! then read wrong: flatter ones too deep, sharper ones too shallow. So both calibration
//! and use read the apex with the blur taken back out.
//!
//! **How.** From the map `b` blurred once more (`s₁ = K∗b`) and twice (`s₂ = K∗K∗b`), at
//! the deepest point of `s₁`, the ratio `q = s₂/s₁` says how sharp the apex is against the
//! kernel, and the depth is `s₁·G(q)`. Both readings are averages over a kernel footprint,
//! so neither the noise that made the deepest pixel the deepest nor a narrow bump at a
//! punch's rim sets the peak; `K` is the demodulator's own kernel, so no scale is chosen.
//!
//! `G` comes from contact mechanics, not from the renderer: a sphere pressed into an
//! elastic half-space (Hertz) has the surface `d·f(r/a)` for every radius and depth, `a` the
//! contact radius, so `q` and `d/s₁` are both functions of `a` alone for a given kernel.
//! [`BlurLoss`] tabulates them once per plan, from the kernel's own weights, and reads `G`
//! off by interpolation. It holds for contacts down to two kernel σ, where the kernel
//! reaches Hertz's surround and a first-order step (`s₁ + 2·(s₁ − s₂)`, exact only for a
//! paraboloid) keeps part of the loss; a calibration on one sphere would carry that part
//! into its depth model as a depth-dependent gain, and every flat punch would read deep.
//!
//! The surround of a real skin is a finite layer's, not a half-space's: it returns to rest
//! faster. The table multiplies Hertz's surround by `e^(−(r − a)/λ)` with
//! [`LAYER_DECAY_MM`], the model the simulated skin documents; the correction changes
//! little across the range of λ a layer of this build shows (`docs/pipeline.md`).
//!
//! **Where it stops.** Below [`RESOLVED_SIGMAS`] kernel σ of contact radius the gain grows
//! so steeply with `q` that a small background offset, or the noise of a shallow press,
//! moves the reading far, and a contact of another shape loses another share: such a
//! contact is not resolved. The table stops there, so a sharper contact reads low by what
//! it lacks; it is flagged (`depth_unresolved`, [`Apex::resolved`]) and left out of the
//! calibration's depth fit (the calibration sphere's shallowest kit presses are such
//! contacts): a depth model that took up their loss would read every wider contact of
//! that phase deep. The table does not run on below the resolved size to read such a
//! contact as a sphere: its steeper gains would amplify the noise of shallow presses past
//! the tolerance more often than they mend a low reading (`docs/pipeline.md`).
//!
//! A flat punch of a few σ, which loses less than a sphere of the same `q`, reads deep: a
//! sphere's and a punch's blurred profiles, surrounds included, match closely at depths a
//! tenth apart (a test below holds them within a percent), so the map cannot tell them.
//! Contacts much blunter or sharper than the calibrated indenter are flagged
//! ([`super::BLUNTNESS_RATIO`], [`super::SHARPNESS_RATIO`]). So is one whose profile
//! neither family describes, where a punch of its sharpness would read deeper than the
//! tolerance allows: the plan tabulates a punch's loss beside the sphere's, read up to the
//! width at which a punch's profile shows its plateau ([`BlurLoss::punch_excess`],
//! [`super::punch_beyond_tolerance`]).

use crate::ftp::band::box2_sigma_px;

/// Decay length of the skin's surface displacement beyond a contact's edge, mm: a finite
/// layer's surround, of the order of the clear buffer's thickness.
pub const LAYER_DECAY_MM: f64 = 3.0;
/// The smallest contact radius the blur correction resolves, in kernel σ.
pub const RESOLVED_SIGMAS: f64 = 2.0;
/// A plateau is chosen only for a contact at least this many kernel σ in radius (its
/// fit's, `super::profile`): it keeps its level in the blurred map only where the kernel,
/// which reaches about 2.5 σ, lies wholly on it, and below that size the two families'
/// blurred profiles differ by little more than a real skin's departures from either. The
/// punch table ([`BlurLoss::punch_excess`]) stops short of it.
pub const FLAT_MIN_SIGMAS: f64 = 3.0;
/// Successive tabulated contact radii grow by this factor.
const RADIUS_STEP: f64 = 1.07;
/// Tabulated contact radii stop where the gain is within this of 1.
const GAIN_END: f64 = 5e-4;

/// A contact's apex: its blur-corrected peak and where it is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Apex {
    /// The peak with the blur taken out, in the units of the map it was read from.
    pub peak: i32,
    /// The deepest point of the once-blurred map, an index into the map.
    pub at: usize,
    /// Whether the contact is as wide as the table resolves ([`RESOLVED_SIGMAS`]): below,
    /// the peak is raised by the table's first gain only, and reads low.
    pub resolved: bool,
    /// Its sharpness `q = s₂/s₁` (see the module documentation): 1 for a flat map, less
    /// the sharper the apex.
    pub q: f64,
}

/// The blur's share of a sphere's apex for one demodulator kernel, and of a flat punch's:
/// `d/s₁` against `q = s₂/s₁` (see the module documentation), built once per plan.
#[derive(Debug, Clone, PartialEq)]
pub struct BlurLoss {
    /// The kernel's two-box lengths `(lx, ly)`, working pixels.
    lengths: (usize, usize),
    /// `(q, d/s₁)` for growing contact radii, `q` increasing.
    rows: Vec<(f64, f64)>,
    /// The same for a flat punch's surface (Boussinesq's), from one kernel σ of radius to
    /// short of [`FLAT_MIN_SIGMAS`]: the punches too narrow to show their plateau.
    punch_rows: Vec<(f64, f64)>,
}

impl BlurLoss {
    /// The table for the kernel of two-box lengths `lengths`, on a map of working pixels
    /// `px_mm` wide.
    pub fn new(lengths: (usize, usize), px_mm: f32) -> BlurLoss {
        let (lx, ly) = lengths;
        let k1 = (unit_triangle(lx), unit_triangle(ly));
        let k2 = (convolve(&k1.0, &k1.0), convolve(&k1.1, &k1.1));
        let k3 = (convolve(&k2.0, &k1.0), convolve(&k2.1, &k1.1));
        let sigma_px = box2_sigma_px(lengths);
        let decay_px = LAYER_DECAY_MM / f64::from(px_mm).max(1e-6);
        // Contact radii from `from` to short of `to` kernel σ, or until the blur's loss
        // fades.
        let table = |surface: fn(f64, f64, f64) -> f64, from: f64, to: f64| {
            let mut rows: Vec<(f64, f64)> = Vec::new();
            let mut a = from * sigma_px;
            while a < to * sigma_px {
                let s1 = centre_sum(&k2, a, decay_px, surface);
                let s2 = centre_sum(&k3, a, decay_px, surface);
                let (q, gain) = (s2 / s1, 1.0 / s1);
                if rows.last().is_none_or(|&(q0, _)| q > q0) {
                    rows.push((q, gain));
                }
                if gain < 1.0 + GAIN_END || rows.len() >= 200 {
                    break;
                }
                a *= RADIUS_STEP;
            }
            rows
        };
        BlurLoss {
            lengths,
            rows: table(hertz, RESOLVED_SIGMAS, f64::INFINITY),
            punch_rows: table(punch, 1.0, FLAT_MIN_SIGMAS),
        }
    }

    /// How much deeper an apex of sharpness `q` reads as a sphere's than as a flat punch's
    /// (`d/s₁` of one over the other's, minus one): what the map cannot say of a contact
    /// whose profile neither family clearly describes. Zero where only a punch wide enough
    /// to show its plateau ([`FLAT_MIN_SIGMAS`]) is as blunt as the apex.
    pub fn punch_excess(&self, q: f64) -> f64 {
        if self
            .punch_rows
            .last()
            .is_some_and(|&(widest, _)| widest >= q)
        {
            gain_at(&self.rows, q) / gain_at(&self.punch_rows, q) - 1.0
        } else {
            0.0
        }
    }

    /// The kernel's two-box lengths, working pixels.
    pub fn lengths(&self) -> (usize, usize) {
        self.lengths
    }

    /// Whether an apex of sharpness `q` is as wide as the table resolves: not below its
    /// first row.
    pub fn resolves(&self, q: f64) -> bool {
        self.rows.first().is_none_or(|&(q0, _)| q >= q0)
    }

    /// `d/s₁` at `q`: the table's first gain below it (a contact under the resolved size),
    /// and towards 1 at `q = 1` beyond its last (at a maximum a blur cannot raise the peak).
    fn gain(&self, q: f64) -> f64 {
        gain_at(&self.rows, q)
    }
}

/// `d/s₁` at `q` in `rows`: the first row's below it, and towards 1 at `q = 1` beyond the
/// last.
fn gain_at(rows: &[(f64, f64)], q: f64) -> f64 {
    let Some(&first) = rows.first() else {
        return 1.0;
    };
    if q <= first.0 {
        return first.1;
    }
    let next = rows.iter().position(|&(qk, _)| qk >= q);
    let ((q0, g0), (q1, g1)) = match next {
        Some(k) => (rows[k - 1], rows[k]),
        None if q < 1.0 => (rows[rows.len() - 1], (1.0, 1.0)),
        None => return 1.0,
    };
    g0 + (g1 - g0) * (q - q0) / (q1 - q0)
}

/// The unit-depth surface of a flat punch of radius `a` at radius `r` (Boussinesq, the
/// surround decaying over `decay` beyond the edge), both in pixels.
pub(super) fn punch(r: f64, a: f64, decay: f64) -> f64 {
    if r <= a {
        return 1.0;
    }
    2.0 / std::f64::consts::PI * (a / r).asin() * (-(r - a) / decay).exp()
}

/// The unit-depth surface of a sphere's contact of radius `a` at radius `r` (Hertz, the
/// surround decaying over `decay` beyond the contact's edge), both in pixels.
pub(super) fn hertz(r: f64, a: f64, decay: f64) -> f64 {
    if r <= a {
        return 1.0 - r * r / (2.0 * a * a);
    }
    let p = r / a;
    let half_space =
        ((2.0 - p * p) * (1.0 / p).asin() + (p * p - 1.0).sqrt()) / std::f64::consts::PI;
    half_space * (-(r - a) / decay).exp()
}

/// The separable kernel `kx ⊗ ky` (centred, odd lengths) applied to the unit `surface`
/// ([`hertz`], [`punch`]) of contact radius `a` at its centre. The kernel's symmetry lets one quadrant stand for
/// all four.
fn centre_sum(
    (kx, ky): &(Vec<f64>, Vec<f64>),
    a: f64,
    decay: f64,
    surface: fn(f64, f64, f64) -> f64,
) -> f64 {
    let (cx, cy) = (kx.len() / 2, ky.len() / 2);
    let mut sum = 0.0;
    for (j, wy) in ky[cy..].iter().enumerate() {
        let wy = if j == 0 { *wy } else { 2.0 * wy };
        for (i, wx) in kx[cx..].iter().enumerate() {
            let wx = if i == 0 { *wx } else { 2.0 * wx };
            sum += wx * wy * surface((i as f64).hypot(j as f64), a, decay);
        }
    }
    sum
}

/// [`triangle`] normalised to unit sum.
fn unit_triangle(l: usize) -> Vec<f64> {
    let t = triangle(l);
    let total = t.iter().sum::<i64>() as f64;
    t.into_iter().map(|v| v as f64 / total).collect()
}

/// The full convolution of two kernels.
fn convolve(a: &[f64], b: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; a.len() + b.len() - 1];
    for (i, x) in a.iter().enumerate() {
        for (j, y) in b.iter().enumerate() {
            out[i + j] += x * y;
        }
    }
    out
}

/// The apex of the contact whose region is `region` (indices into `map`, `w` pixels wide;
/// `super::features::dominant_component`), the blur taken out by `loss`. `map` is the
/// window's indentation as read, surround and noise included (no threshold: the
/// correction compares blurs of the whole surface). `None` without indentation.
///
/// `s₁` is sought over the bounding box of the region's pixels at least half as deep as its
/// deepest (no shallower point can hold its maximum; another blob of the window is no part
/// of this contact), and only that box grown by two kernel reaches is blurred: `K∗s₁` reads
/// one reach around it, so every value used sees the map as the whole window would. The
/// blurred maximum, not the raw one, places the apex: a few pixels that read deeper than
/// the contact around them cannot.
pub fn apex(map: &[i32], w: usize, region: &[usize], loss: &BlurLoss) -> Option<Apex> {
    let (lx, ly) = loss.lengths();
    let deepest = region.iter().map(|&i| map[i]).max()?;
    let bbox = deep_box(map, w, region, deepest)?;
    let h = map.len() / w;
    let (rx, ry) = (lx.max(1) - 1, ly.max(1) - 1);
    let grow = |(a, b): (usize, usize), r: usize, n: usize| (a.saturating_sub(r), (b + r).min(n));
    let (xs, ys) = (grow(bbox.0, 2 * rx, w), grow(bbox.1, 2 * ry, h));
    let sw = xs.1 - xs.0;
    let sub: Vec<i32> = (ys.0..ys.1)
        .flat_map(|y| map[y * w + xs.0..y * w + xs.1].iter().copied())
        .collect();
    let once = blur(&sub, sw, (lx, ly));
    let ((ax, ay), s1) = (bbox.1 .0..bbox.1 .1)
        .flat_map(|y| (bbox.0 .0..bbox.0 .1).map(move |x| (x, y)))
        .map(|(x, y)| ((x, y), once[(y - ys.0) * sw + x - xs.0]))
        .max_by_key(|&((x, y), d)| (d, std::cmp::Reverse((y, x))))?;
    if s1 <= 0 {
        return None;
    }
    let (tx, ty) = (triangle(lx), triangle(ly));
    let (cx, cy) = (ax - xs.0, ay - ys.0);
    let s1_at = |x: usize, y: usize| f64::from(once[y * sw + x]);
    let s2_at = |x: usize, y: usize| weighted_mean(&once, sw, (x, y), &tx, &ty);
    let (s1, s2) = between_pixels((cx, cy), (sw, once.len() / sw), s1_at, s2_at);
    Some(Apex {
        peak: (s1 * loss.gain(s2 / s1)).round() as i32,
        at: ay * w + ax,
        resolved: loss.resolves(s2 / s1),
        q: s2 / s1,
    })
}

/// `s₁` and `s₂` at the maximum of `s₁` between pixels, from their values at the deepest
/// pixel `c` and its four neighbours (on a `size` grid): along each axis the parabola
/// through three values places the maximum within half a pixel, and both readings are
/// taken there. At a contact of a few kernel σ the pixel grid alone moves `q` (a press
/// read between pixels looks blunter), and the gain magnifies what moves `q`.
fn between_pixels(
    (cx, cy): (usize, usize),
    (w, h): (usize, usize),
    s1: impl Fn(usize, usize) -> f64,
    s2: impl Fn(usize, usize) -> f64,
) -> (f64, f64) {
    let (c1, c2) = (s1(cx, cy), s2(cx, cy));
    let (mut v1, mut v2) = (c1, c2);
    let axes = [
        (cx > 0 && cx + 1 < w).then(|| ((cx - 1, cy), (cx + 1, cy))),
        (cy > 0 && cy + 1 < h).then(|| ((cx, cy - 1), (cx, cy + 1))),
    ];
    for (m, p) in axes.into_iter().flatten() {
        let (m1, p1) = (s1(m.0, m.1), s1(p.0, p.1));
        let curvature = m1 - 2.0 * c1 + p1;
        if curvature >= 0.0 {
            continue;
        }
        let t = (0.5 * (m1 - p1) / curvature).clamp(-0.5, 0.5);
        let along = |m: f64, c: f64, p: f64| t * 0.5 * (p - m) + t * t * 0.5 * (p - 2.0 * c + m);
        v1 += along(m1, c1, p1);
        v2 += along(s2(m.0, m.1), c2, s2(p.0, p.1));
    }
    (v1, v2)
}

/// The half-open column and row spans of the pixels of `region` at least half as deep as
/// `deepest` (`None` without any, or a map `w` = 0 wide).
fn deep_box(
    map: &[i32],
    w: usize,
    region: &[usize],
    deepest: i32,
) -> Option<((usize, usize), (usize, usize))> {
    if w == 0 || deepest <= 0 {
        return None;
    }
    let (mut xs, mut ys) = ((usize::MAX, 0), (usize::MAX, 0));
    for &i in region.iter().filter(|&&i| 2 * map[i] >= deepest) {
        let (x, y) = (i % w, i / w);
        xs = (xs.0.min(x), xs.1.max(x + 1));
        ys = (ys.0.min(y), ys.1.max(y + 1));
    }
    Some((xs, ys))
}

/// `z` (`w` wide) blurred by the separable triangle of box lengths `(lx, ly)`, weights
/// renormalised over the part of the kernel inside the window.
pub(super) fn blur(z: &[i32], w: usize, (lx, ly): (usize, usize)) -> Vec<i32> {
    let h = z.len() / w;
    let mut scratch = Scratch::default();
    let mut rows = vec![0i64; w * h];
    for y in 0..h {
        let row = z[y * w..(y + 1) * w].iter().map(|&v| i64::from(v));
        scratch.triangle(row, lx, &mut rows[y * w..(y + 1) * w], 1);
    }
    let mut cols = vec![0i64; w * h];
    for x in 0..w {
        let col = (0..h).map(|y| rows[y * w + x]);
        scratch.triangle(col, ly, &mut cols[x..], w);
    }
    cols.into_iter().map(|v| v as i32).collect()
}

/// Prefix sums for [`Scratch::triangle`], kept from line to line.
#[derive(Default)]
struct Scratch {
    /// `Σ_{j<i} v_j` and `Σ_{j<i} j·v_j`.
    p0: Vec<i64>,
    p1: Vec<i64>,
}

impl Scratch {
    /// The line `v` filtered by the triangle `l − |d|` (`|d| < l`), renormalised where the
    /// line ends, written to every `stride`-th element of `out`. O(1) per sample whatever
    /// `l`: the triangle's two ramps are sums of `v` and of `i·v` over a span.
    fn triangle(&mut self, v: impl Iterator<Item = i64>, l: usize, out: &mut [i64], stride: usize) {
        let (p0, p1) = (&mut self.p0, &mut self.p1);
        p0.clear();
        p1.clear();
        let (mut s0, mut s1) = (0i64, 0i64);
        p0.push(0);
        p1.push(0);
        for (i, x) in v.enumerate() {
            s0 += x;
            s1 += i as i64 * x;
            p0.push(s0);
            p1.push(s1);
        }
        let n = p0.len() - 1;
        let l = l.max(1) as i64;
        for c in 0..n {
            let (lo, hi) = (c.saturating_sub(l as usize - 1), (c + l as usize).min(n));
            let ci = c as i64;
            // Left ramp i ∈ [lo, c]: weight (l − c) + i; right ramp i ∈ (c, hi): (l + c) − i.
            let left = (l - ci) * (p0[c + 1] - p0[lo]) + (p1[c + 1] - p1[lo]);
            let right = (l + ci) * (p0[hi] - p0[c + 1]) - (p1[hi] - p1[c + 1]);
            let (n_l, n_r) = ((c + 1 - lo) as i64, (hi - c - 1) as i64);
            let w_l = (l - ci) * n_l + (lo as i64 + ci) * n_l / 2;
            let w_r = (l + ci) * n_r - (ci + hi as i64) * n_r / 2;
            out[c * stride] = (left + right) / (w_l + w_r).max(1);
        }
    }
}

/// The triangle of two boxes of length `l`: weights `l − |d|` for `|d| < l`.
fn triangle(l: usize) -> Vec<i64> {
    let l = l.max(1) as i64;
    (1 - l..l).map(|d| l - d.abs()).collect()
}

/// The mean of `z` (`w` wide) around `(cx, cy)` under the separable centred kernel
/// `kx ⊗ ky`, over the part of it inside the window.
fn weighted_mean(z: &[i32], w: usize, (cx, cy): (usize, usize), kx: &[i64], ky: &[i64]) -> f64 {
    let h = z.len() / w;
    let (rx, ry) = (kx.len() / 2, ky.len() / 2);
    let xs = cx.saturating_sub(rx)..(cx + rx + 1).min(w);
    let ys = cy.saturating_sub(ry)..(cy + ry + 1).min(h);
    let (mut s, mut ws) = (0i128, 0i128);
    for y in ys {
        let wy = i128::from(ky[y + ry - cy]);
        let row = &z[y * w..(y + 1) * w];
        let sx: i128 = xs
            .clone()
            .map(|x| i128::from(kx[x + rx - cx]) * i128::from(row[x]))
            .sum();
        s += wy * sx;
        ws += wy;
    }
    let wx: i64 = xs.map(|x| kx[x + rx - cx]).sum();
    s as f64 / (ws * i128::from(wx)).max(1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Working pixels of the tests' maps, mm: the layer decays over 30 pixels.
    const PX_MM: f32 = 0.1;

    /// The blur-corrected peak of `z`, its region found as the measurement finds it.
    fn corrected(z: &[i32], w: usize, blur: (usize, usize)) -> i32 {
        let region = super::super::features::dominant_component(z, w, 0);
        apex(z, w, &region, &BlurLoss::new(blur, PX_MM)).map_or(0, |a| a.peak)
    }

    /// A paraboloid of curvature `k` µm/px² and apex depth `d` µm at `(cx, cy)` on a
    /// `w × h` window.
    fn paraboloid(w: usize, h: usize, (cx, cy): (f64, f64), d: f64, k: f64) -> Vec<i32> {
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f64 - cx, (i / w) as f64 - cy);
                (d - 0.5 * k * (x * x + y * y)).round() as i32
            })
            .collect()
    }

    /// A few pixels reading deeper than the press at its rim, in its region: the apex stays
    /// at the press's centre with its depth, not at the spot.
    #[test]
    fn a_deeper_spot_at_the_rim_does_not_place_the_apex() {
        let (w, h) = (81, 81);
        let z0: Vec<i32> = paraboloid(w, h, (40.0, 40.0), 800.0, 4.0)
            .into_iter()
            .map(|v| v.max(0))
            .collect();
        let alone = corrected(&z0, w, (5, 5));
        let mut z = z0.clone();
        for (x, y) in [(55, 40), (56, 40), (55, 41)] {
            z[y * w + x] = 1_200;
        }
        let region = super::super::features::dominant_component(&z, w, 0);
        let a = apex(&z, w, &region, &BlurLoss::new((5, 5), PX_MM)).unwrap();
        assert_eq!((a.at % w, a.at / w), (40, 40));
        assert!((a.peak - alone).abs() <= 30, "{} against {alone}", a.peak);
    }

    /// Unit-depth elastic surfaces at radius `r` for contact radius `a`: Hertz's sphere
    /// (its surround decaying as the table assumes) and Boussinesq's flat punch.
    fn sphere(r: f64, a: f64) -> f64 {
        hertz(r, a, LAYER_DECAY_MM / f64::from(PX_MM))
    }
    fn punch(r: f64, a: f64) -> f64 {
        if r <= a {
            1.0
        } else {
            2.0 / std::f64::consts::PI * (a / r).asin()
        }
    }

    /// `surface` of depth `d` µm centred at `(c + dx, c + dx)` of an `n × n` window
    /// (`c = n/2`), as the demodulator's triangle of box length `l` blurs it.
    fn blurred(
        surface: fn(f64, f64) -> f64,
        a: f64,
        d: f64,
        (n, dx): (usize, f64),
        l: usize,
    ) -> Vec<i32> {
        let c = (n / 2) as f64 + dx;
        let z: Vec<i32> = (0..n * n)
            .map(|i| {
                let r = ((i % n) as f64 - c).hypot((i / n) as f64 - c);
                (d * surface(r, a)).round() as i32
            })
            .collect();
        blur(&z, n, (l, l))
    }

    /// The kernel σ of two boxes of length `l`, px.
    fn sigma(l: usize) -> f64 {
        box2_sigma_px((l, l))
    }

    /// Spheres of every size the table resolves read their depth, centred on a pixel or
    /// between pixels.
    #[test]
    fn spheres_of_any_radius_read_their_depth() {
        let (l, n, d) = (7, 161, 1000.0);
        for a_sigmas in [2.0, 2.5, 3.0, 5.0, 8.0] {
            for dx in [0.0, 0.5] {
                let z = blurred(sphere, a_sigmas * sigma(l), d, (n, dx), l);
                let got = f64::from(corrected(&z, n, (l, l)));
                assert!(
                    (got - d).abs() <= 0.01 * d,
                    "a = {a_sigmas}σ, offset {dx}: {got}"
                );
            }
        }
    }

    /// Where the correction stops: a sphere under the resolved size reads shallow and is
    /// said to be unresolved, wider ones are resolved, and a punch of a few σ, which loses
    /// less than a sphere of its sharpness, reads deep.
    #[test]
    fn a_tiny_sphere_reads_shallow_and_a_narrow_punch_deep() {
        let (l, n, d) = (7, 161, 1000.0);
        let resolved = |z: &[i32]| {
            let region = super::super::features::dominant_component(z, n, 0);
            apex(z, n, &region, &BlurLoss::new((l, l), PX_MM)).map(|a| a.resolved)
        };
        let z = blurred(sphere, 1.2 * sigma(l), d, (n, 0.0), l);
        let got = corrected(&z, n, (l, l));
        assert!((400..=900).contains(&got), "sphere at 1.2σ: {got}");
        assert_eq!(
            resolved(&z),
            Some(false),
            "a sphere of 1.2σ is not resolved"
        );
        for a_sigmas in [2.2, 4.0] {
            let z = blurred(sphere, a_sigmas * sigma(l), d, (n, 0.0), l);
            assert_eq!(
                resolved(&z),
                Some(true),
                "a sphere of {a_sigmas}σ is resolved"
            );
        }
        let z = blurred(punch, 2.5 * sigma(l), d, (n, 0.0), l);
        let got = corrected(&z, n, (l, l));
        assert!((1030..=1250).contains(&got), "punch at 2.5σ: {got}");
        let z = blurred(punch, 8.0 * sigma(l), d, (n, 0.0), l);
        let got = corrected(&z, n, (l, l));
        assert!((995..=1010).contains(&got), "punch at 8σ: {got}");
    }

    /// What a punch's reading owes to the sphere's correction is what the table says of its
    /// sharpness: a punch of 2–2.8σ, read as a sphere, reads deep by its `punch_excess`
    /// (within a percent of the depth, on a map blurred and sampled as the demodulator's
    /// is); a sphere of the same sharpness is told the same excess, since the map does not
    /// say which pressed; and a sharpness only a punch at least [`FLAT_MIN_SIGMAS`] wide
    /// shows carries none.
    #[test]
    fn a_narrow_punch_reads_deep_by_its_punch_excess() {
        let (l, n, d) = (7, 161, 1000.0);
        let read = |z: &[i32]| {
            let region = super::super::features::dominant_component(z, n, 0);
            apex(z, n, &region, &BlurLoss::new((l, l), PX_MM)).unwrap()
        };
        // Boussinesq's punch with the surround decaying as the table assumes.
        let layer_punch = |r: f64, a: f64| super::punch(r, a, LAYER_DECAY_MM / f64::from(PX_MM));
        let table = BlurLoss::new((l, l), PX_MM);
        let excess = |a: &Apex| table.punch_excess(a.q);
        for a_sigmas in [2.0, 2.4, 2.8] {
            let a = read(&blurred(layer_punch, a_sigmas * sigma(l), d, (n, 0.0), l));
            let over = f64::from(a.peak) / d - 1.0;
            assert!(over > 0.04, "punch at {a_sigmas}σ: {over}");
            assert!(
                (over - excess(&a)).abs() <= 0.01 * (1.0 + over),
                "punch at {a_sigmas}σ reads {over} deep, excess {}",
                excess(&a)
            );
        }
        let wide = read(&blurred(layer_punch, 4.0 * sigma(l), d, (n, 0.0), l));
        assert_eq!(excess(&wide), 0.0);
        let dome = read(&blurred(sphere, 2.5 * sigma(l), d, (n, 0.0), l));
        assert!(excess(&dome) > 0.04, "{dome:?}");
    }

    /// …and the map cannot tell them there: a sphere of contact radius 2σ and a punch of
    /// 1.5σ about an eighth shallower blur to profiles within a percent of each other.
    #[test]
    fn a_narrow_sphere_and_a_shallower_punch_blur_alike() {
        let (l, n) = (7, 121);
        let s = sigma(l);
        let half_space = |r: f64, a: f64| hertz(r, a, f64::INFINITY);
        let sphere = blurred(half_space, 2.0 * s, 1000.0, (n, 0.0), l);
        let flat = blurred(punch, 1.5 * s, 1000.0, (n, 0.0), l);
        // The centre row out to 5σ, the punch scaled to fit the sphere.
        let row = (n / 2) * n + n / 2;
        let span = (5.0 * s) as usize;
        let (s, f): (Vec<f64>, Vec<f64>) = (0..span)
            .map(|x| (f64::from(sphere[row + x]), f64::from(flat[row + x])))
            .unzip();
        let scale = s.iter().zip(&f).map(|(a, b)| a * b).sum::<f64>()
            / f.iter().map(|b| b * b).sum::<f64>();
        let rms = (s
            .iter()
            .zip(&f)
            .map(|(a, b)| (a - scale * b).powi(2))
            .sum::<f64>()
            / span as f64)
            .sqrt();
        assert!(
            rms < 0.01 * s[0],
            "profiles differ by {rms} µm rms of {}",
            s[0]
        );
        assert!(
            (0.84..=0.92).contains(&scale),
            "punch depth {scale} of the sphere's"
        );
    }

    /// The table: `q` grows and the gain falls towards 1 as the contact widens; the gain
    /// is held at the resolved size below the table and is 1 at and beyond `q = 1`.
    #[test]
    fn the_gain_falls_to_one_as_the_contact_widens() {
        for lengths in [(3, 3), (5, 9), (12, 12)] {
            let t = BlurLoss::new(lengths, PX_MM);
            assert!(t.rows.len() > 10, "{lengths:?}: {} rows", t.rows.len());
            for pair in t.rows.windows(2) {
                assert!(pair[1].0 > pair[0].0 && pair[1].1 < pair[0].1, "{pair:?}");
            }
            let (q0, g0) = t.rows[0];
            assert!((1.5..4.0).contains(&g0), "{lengths:?}: first gain {g0}");
            assert_eq!(t.gain(q0 - 0.1), g0);
            assert_eq!(t.gain(1.0), 1.0);
            assert_eq!(t.gain(1.2), 1.0);
            let last = t.rows[t.rows.len() - 1];
            assert!(last.1 < 1.0 + GAIN_END);
            let mid = 0.5 * (last.0 + 1.0);
            assert!((1.0..=last.1).contains(&t.gain(mid)));
        }
    }

    /// A window that cuts the kernels through the apex renormalises them: an apex on the
    /// window's edge reads within a few percent of the same apex seen whole.
    #[test]
    fn an_apex_on_the_window_edge_is_corrected_alike() {
        let (l, n, d) = (6, 121, 800.0);
        let z = blurred(sphere, 4.0 * sigma(l), d, (n, 0.0), l);
        let whole = f64::from(corrected(&z, n, (l, l)));
        let c = n / 2;
        let cut: Vec<i32> = (0..n)
            .flat_map(|y| z[y * n + c..(y + 1) * n].iter().copied())
            .collect();
        let edge = f64::from(corrected(&cut, n - c, (l, l)));
        assert!((whole - d).abs() <= 0.02 * d, "{whole}");
        assert!((edge - whole).abs() <= 0.04 * d, "{edge} against {whole}");
    }

    /// Blurring only around the contact sees what the whole window would: a shallower,
    /// smaller blob elsewhere in the window leaves the corrected peak as it was.
    #[test]
    fn a_blob_elsewhere_does_not_move_the_peak() {
        let (w, h) = (120, 41);
        let mut z: Vec<i32> = paraboloid(w, h, (20.0, 20.0), 800.0, 10.0)
            .into_iter()
            .map(|v| v.max(0))
            .collect();
        let alone = corrected(&z, w, (5, 5));
        for y in 15..22 {
            for x in 90..97 {
                z[y * w + x] = 700;
            }
        }
        assert_eq!(corrected(&z, w, (5, 5)), alone);
        assert!(alone > 800, "{alone}");
    }

    /// The prefix-sum triangle equals the direct weighted sum, renormalised at the ends.
    #[test]
    fn the_running_triangle_is_the_direct_one() {
        let v: Vec<i64> = (0..37).map(|i| (i * 7919 % 113) - 40).collect();
        for l in [1, 2, 5, 9, 40] {
            let mut got = vec![0i64; v.len()];
            Scratch::default().triangle(v.iter().copied(), l, &mut got, 1);
            let k = triangle(l);
            let r = k.len() / 2;
            for (c, &g) in got.iter().enumerate() {
                let (mut s, mut ws) = (0i64, 0i64);
                for (i, &x) in v.iter().enumerate() {
                    let d = i as i64 - c as i64;
                    if d.unsigned_abs() as usize <= r {
                        s += k[(d + r as i64) as usize] * x;
                        ws += k[(d + r as i64) as usize];
                    }
                }
                assert_eq!(g, s / ws, "l {l} at {c}");
            }
        }
    }

    #[test]
    fn a_plateau_loses_nothing_and_a_lone_deep_pixel_is_averaged_away() {
        let w = 31;
        assert_eq!(corrected(&vec![500; w * w], w, (7, 7)), 500);
        let mut spike = vec![0; w * w];
        spike[15 * w + 15] = 400;
        // K∗b at the spike is its weight, 7·7 of 49², and the loss at most that again twice.
        let s1 = 400 * 49 / 2401;
        let got = corrected(&spike, w, (7, 7));
        assert!((s1..=3 * s1).contains(&got), "{got}");
        assert_eq!(corrected(&vec![0; w * w], w, (7, 7)), 0);
        assert_eq!(corrected(&[], w, (7, 7)), 0);
    }
}
