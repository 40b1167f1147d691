//! Charts (plotters): PNG and SVG of each, with a bundled font so text renders anywhere.

use std::path::Path;

use anyhow::{anyhow, Result};
use plotters::coord::Shift;
use plotters::prelude::*;

use super::stability::Sweep;
use super::tradeoff::Row;

/// The bundled font, shared with the figures (text renders on a machine with none).
fn register_font() {
    vistaf_figure::font::register();
}

/// A tick label without float noise (and no ".0" on whole numbers).
fn tick(v: f64) -> String {
    let a = v.abs();
    if a >= 100.0 || a == 0.0 || (a >= 1.0 && (v - v.round()).abs() < 1e-9 * a) {
        format!("{v:.0}")
    } else if a >= 1.0 {
        format!("{v:.1}")
    } else if a >= 0.01 {
        format!("{v:.2}")
    } else {
        format!("{v:.0e}")
    }
}

fn err<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow!("drawing: {e}")
}

/// Writes `draw` as `<stem>.png` and `<stem>.svg` in `dir`.
fn both(
    dir: &Path,
    stem: &str,
    size: (u32, u32),
    draw: impl Fn(&mut dyn FnMut(Shape) -> Result<()>) -> Result<()>,
) -> Result<()> {
    register_font();
    let png = dir.join(format!("{stem}.png"));
    let svg = dir.join(format!("{stem}.svg"));
    {
        let root = BitMapBackend::new(&png, size).into_drawing_area();
        render(&root, &draw)?;
        root.present().map_err(err)?;
    }
    let root = SVGBackend::new(&svg, size).into_drawing_area();
    render(&root, &draw)?;
    root.present().map_err(err)?;
    Ok(())
}

/// The shapes a chart is made of, drawn the same on any backend.
#[derive(Debug)]
pub enum Shape {
    /// A whole chart: caption, axis labels, ranges (log y when `log_y`), and series.
    Chart {
        /// Area: top (0) or bottom (1) of a two-panel figure, or the whole (2).
        panel: u8,
        /// Caption.
        caption: String,
        /// X label.
        x_label: String,
        /// Y label.
        y_label: String,
        /// X range.
        x: (f64, f64),
        /// Y range.
        y: (f64, f64),
        /// Log y axis.
        log_y: bool,
        /// Log x axis.
        log_x: bool,
        /// Series.
        series: Vec<Series>,
    },
}

/// One series of a chart.
#[derive(Debug)]
pub struct Series {
    /// Legend label.
    pub label: String,
    /// Points.
    pub points: Vec<(f64, f64)>,
    /// Colour.
    pub color: RGBColor,
    /// Line through the points (else markers only).
    pub line: bool,
    /// Text beside each point.
    pub labels: Vec<String>,
}

fn render<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    draw: &impl Fn(&mut dyn FnMut(Shape) -> Result<()>) -> Result<()>,
) -> Result<()> {
    root.fill(&WHITE).map_err(err)?;
    let panels = root.split_evenly((2, 1));
    let mut sink = |s: Shape| -> Result<()> {
        let Shape::Chart {
            panel,
            caption,
            x_label,
            y_label,
            x,
            y,
            log_y,
            log_x,
            series,
        } = s;
        let area = match panel {
            0 => &panels[0],
            1 => &panels[1],
            _ => root,
        };
        let mut b = ChartBuilder::on(area);
        b.caption(caption, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60);
        macro_rules! body {
            ($chart:expr) => {{
                let mut chart = $chart;
                chart
                    .configure_mesh()
                    .x_desc(x_label.as_str())
                    .y_desc(y_label.as_str())
                    .label_style(("sans-serif", 13))
                    .x_label_formatter(&|v| tick(*v))
                    .y_label_formatter(&|v| tick(*v))
                    .draw()
                    .map_err(err)?;
                for s in &series {
                    let color = s.color;
                    if s.line {
                        chart
                            .draw_series(LineSeries::new(
                                s.points.iter().copied(),
                                color.stroke_width(2),
                            ))
                            .map_err(err)?
                            .label(s.label.clone())
                            .legend(move |(x, y)| {
                                PathElement::new(vec![(x, y), (x + 16, y)], color)
                            });
                    } else {
                        chart
                            .draw_series(
                                s.points.iter().map(|&p| Circle::new(p, 4, color.filled())),
                            )
                            .map_err(err)?
                            .label(s.label.clone())
                            .legend(move |(x, y)| Circle::new((x + 8, y), 4, color.filled()));
                    }
                }
                // Point labels where they overlap nothing; a point without room is numbered
                // and named in a key.
                let all: Vec<(i32, i32)> = series
                    .iter()
                    .flat_map(|s| s.points.iter().map(|p| chart.backend_coord(p)))
                    .collect();
                let area_px = chart.plotting_area().strip_coord_spec();
                let base = area_px.get_base_pixel();
                let (pw, ph) = area_px.dim_in_pixel();
                let mut placer = Placer::new(
                    (base.0, base.1, base.0 + pw as i32, base.1 + ph as i32),
                    &all,
                );
                let mut key = Vec::new();
                for s in &series {
                    for (p, t) in s.points.iter().zip(&s.labels) {
                        let at = chart.backend_coord(p);
                        let text = match placer.place(at, t) {
                            Some(spot) => (t.clone(), spot),
                            None => {
                                key.push(format!("{}: {t}", key.len() + 1));
                                let n = key.len().to_string();
                                let spot = placer.force(at, &n);
                                (n, spot)
                            }
                        };
                        area.draw(&Text::new(
                            text.0,
                            (
                                text.1 .0 - area.get_base_pixel().0,
                                text.1 .1 - area.get_base_pixel().1,
                            ),
                            ("sans-serif", LABEL_PX),
                        ))
                        .map_err(err)?;
                    }
                }
                for (i, line) in key.iter().enumerate() {
                    let (x0, y0) = (base.0 + 10, base.1 + 10 + i as i32 * (LABEL_PX + 4));
                    area.draw(&Text::new(
                        line.clone(),
                        (x0 - area.get_base_pixel().0, y0 - area.get_base_pixel().1),
                        ("sans-serif", LABEL_PX),
                    ))
                    .map_err(err)?;
                }
                chart
                    .configure_series_labels()
                    .background_style(WHITE.mix(0.8))
                    .border_style(BLACK)
                    .label_font(("sans-serif", 12))
                    .draw()
                    .map_err(err)?;
            }};
        }
        // Log axes get round ticks inside the range ([`log_ticks`]), so the data's decade
        // is always labelled.
        let (xt, yt) = (log_ticks(x), log_ticks(y));
        match (log_x, log_y) {
            (false, false) => body!(b.build_cartesian_2d(x.0..x.1, y.0..y.1).map_err(err)?),
            (false, true) => {
                body!(b
                    .build_cartesian_2d(x.0..x.1, (y.0..y.1).log_scale().with_key_points(yt))
                    .map_err(err)?)
            }
            (true, false) => {
                body!(b
                    .build_cartesian_2d((x.0..x.1).log_scale().with_key_points(xt), y.0..y.1)
                    .map_err(err)?)
            }
            (true, true) => body!(b
                .build_cartesian_2d(
                    (x.0..x.1).log_scale().with_key_points(xt),
                    (y.0..y.1).log_scale().with_key_points(yt)
                )
                .map_err(err)?),
        }
        Ok(())
    };
    draw(&mut sink)
}

/// Height of a point label, pixels.
const LABEL_PX: i32 = 12;

/// Ticks of a log axis over `range`: 1, 2, 3, 5 and 7 times each power of ten inside it
/// over two decades or less, 1, 2 and 5 over three, the powers of ten alone beyond.
fn log_ticks((lo, hi): (f64, f64)) -> Vec<f64> {
    if !(lo > 0.0 && hi > lo) {
        return Vec::new();
    }
    let steps: &[f64] = match hi / lo {
        r if r > 1e3 => &[1.0],
        r if r > 1e2 => &[1.0, 2.0, 5.0],
        _ => &[1.0, 2.0, 3.0, 5.0, 7.0],
    };
    let mut out = Vec::new();
    // Each tick parsed from its decimal text, so 3 × 0.1 is 0.3 and not 0.30000000000000004.
    let first = lo.log10().floor() as i32;
    for k in first..=hi.log10().ceil() as i32 {
        for &m in steps {
            let v: f64 = format!("{m}e{k}").parse().unwrap_or(f64::NAN);
            if v >= lo && v <= hi {
                out.push(v);
            }
        }
    }
    out
}

/// Puts point labels where they cover no other label, no point and stay inside the plot.
struct Placer {
    /// The plotting area, `(x0, y0, x1, y1)` pixels.
    bounds: (i32, i32, i32, i32),
    /// Boxes taken: labels and the points' markers.
    taken: Vec<(i32, i32, i32, i32)>,
}

impl Placer {
    fn new(bounds: (i32, i32, i32, i32), points: &[(i32, i32)]) -> Placer {
        let taken = points
            .iter()
            .map(|&(x, y)| (x - 5, y - 5, x + 5, y + 5))
            .collect();
        Placer { bounds, taken }
    }

    /// The box of `text` drawn from `(x, y)` (its top left), pixels.
    fn rect((x, y): (i32, i32), text: &str) -> (i32, i32, i32, i32) {
        // DejaVu Sans at 12 px: about 7 px a character.
        (x, y, x + 7 * text.chars().count() as i32, y + LABEL_PX + 2)
    }

    fn free(&self, r: (i32, i32, i32, i32)) -> bool {
        let (b0, b1, b2, b3) = self.bounds;
        r.0 >= b0
            && r.1 >= b1
            && r.2 <= b2
            && r.3 <= b3
            && self
                .taken
                .iter()
                .all(|t| r.2 <= t.0 || t.2 <= r.0 || r.3 <= t.1 || t.3 <= r.1)
    }

    /// Where `text` for the point at `p` goes (top left of the text), if anywhere free.
    fn place(&mut self, (x, y): (i32, i32), text: &str) -> Option<(i32, i32)> {
        let w = 7 * text.chars().count() as i32;
        let h = LABEL_PX + 2;
        for d in [1, 2, 3] {
            let g = 7 * d;
            let spots = [
                (x + g, y - h / 2),
                (x - g - w, y - h / 2),
                (x - w / 2, y - g - h),
                (x - w / 2, y + g),
                (x + g, y - g - h),
                (x + g, y + g),
                (x - g - w, y - g - h),
                (x - g - w, y + g),
            ];
            if let Some(&s) = spots.iter().find(|&&s| self.free(Placer::rect(s, text))) {
                self.taken.push(Placer::rect(s, text));
                return Some(s);
            }
        }
        None
    }

    /// A spot for a short `text` (a key number) even when none is free: right of the
    /// point, kept inside the plot.
    fn force(&mut self, at: (i32, i32), text: &str) -> (i32, i32) {
        let spot = self.place(at, text).unwrap_or((at.0 + 6, at.1 - LABEL_PX));
        let spot = (spot.0.min(self.bounds.2 - 20), spot.1.max(self.bounds.1));
        self.taken.push(Placer::rect(spot, text));
        spot
    }
}

/// Error (log, in tolerances; unmeasurable frames drawn at the top) and flag rate against
/// a sweep's axis.
pub fn stability_chart(dir: &Path, s: &Sweep) -> Result<()> {
    let cap = 100.0;
    let xs: Vec<f64> = s.points.iter().map(|p| f64::from(p.x)).collect();
    let (x0, x1) = xs
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    let pad = (x1 - x0).max(1e-3) * 0.05;
    let pt = |p: &super::stability::Point| (f64::from(p.x), f64::from(p.error).clamp(1e-3, cap));
    let flagged: Vec<(f64, f64)> = s.points.iter().filter(|p| p.flagged).map(pt).collect();
    let clean: Vec<(f64, f64)> = s.points.iter().filter(|p| !p.flagged).map(pt).collect();
    let mut xs_u = xs.clone();
    xs_u.sort_by(f64::total_cmp);
    xs_u.dedup();
    let rate: Vec<(f64, f64)> = xs_u
        .iter()
        .map(|&x| {
            let at: Vec<_> = s.points.iter().filter(|p| f64::from(p.x) == x).collect();
            (
                x,
                at.iter().filter(|p| p.flagged).count() as f64 / at.len().max(1) as f64,
            )
        })
        .collect();
    let out_rate: Vec<(f64, f64)> = xs_u
        .iter()
        .map(|&x| {
            let at: Vec<_> = s.points.iter().filter(|p| f64::from(p.x) == x).collect();
            (
                x,
                at.iter().filter(|p| p.error > 1.0).count() as f64 / at.len().max(1) as f64,
            )
        })
        .collect();
    let stem = format!("stability-{}", s.name);
    both(dir, &stem, (900, 760), |sink| {
        sink(Shape::Chart {
            panel: 0,
            caption: format!("{}: error", s.axis),
            x_label: s.axis.into(),
            y_label: "error / tolerance".into(),
            x: (x0 - pad, x1 + pad),
            y: (1e-3, cap),
            log_y: true,
            log_x: false,
            series: vec![
                Series {
                    label: "tolerance".into(),
                    points: vec![(x0 - pad, 1.0), (x1 + pad, 1.0)],
                    color: BLACK,
                    line: true,
                    labels: vec![],
                },
                Series {
                    label: "frame, flagged".into(),
                    points: flagged.clone(),
                    color: RED,
                    line: false,
                    labels: vec![],
                },
                Series {
                    label: "frame, not flagged".into(),
                    points: clean.clone(),
                    color: BLUE,
                    line: false,
                    labels: vec![],
                },
            ],
        })?;
        sink(Shape::Chart {
            panel: 1,
            caption: "flag rate and out-of-tolerance rate".into(),
            x_label: s.axis.into(),
            y_label: "fraction of frames".into(),
            x: (x0 - pad, x1 + pad),
            y: (-0.02, 1.05),
            log_y: false,
            log_x: false,
            series: vec![
                Series {
                    label: "flagged".into(),
                    points: rate.clone(),
                    color: RED,
                    line: true,
                    labels: vec![],
                },
                Series {
                    label: "out of tolerance".into(),
                    points: out_rate.clone(),
                    color: BLACK,
                    line: true,
                    labels: vec![],
                },
            ],
        })
    })
}

/// Accuracy against cost with the Pareto front.
pub fn tradeoff_chart(dir: &Path, rows: &[Row], front: &[usize], use_instr: bool) -> Result<()> {
    let cost = |r: &Row| {
        if use_instr {
            r.instructions.map_or(f64::NAN, |i| i as f64 / 1e6)
        } else {
            r.ms
        }
    };
    let ok: Vec<&Row> = rows
        .iter()
        .filter(|r| r.refused.is_none() && cost(r).is_finite())
        .collect();
    let (c0, c1) = ok
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), r| {
            (a.min(cost(r)), b.max(cost(r)))
        });
    let (e0, e1) = ok
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), r| {
            (a.min(r.depth_error), b.max(r.depth_error))
        });
    let mut f: Vec<(f64, f64)> = front
        .iter()
        .map(|&i| (cost(&rows[i]), rows[i].depth_error))
        .collect();
    f.sort_by(|a, b| a.0.total_cmp(&b.0));
    let points: Vec<(f64, f64)> = ok.iter().map(|r| (cost(r), r.depth_error)).collect();
    let labels: Vec<String> = ok.iter().map(|r| r.config.name.clone()).collect();
    both(dir, "tradeoff", (1000, 700), |sink| {
        sink(Shape::Chart {
            panel: 2,
            caption: "accuracy against cost (reference build, 640×480)".into(),
            x_label: if use_instr {
                "instructions per frame (M, callgrind)".into()
            } else {
                "median time per frame (ms, this machine)".into()
            },
            y_label: "peak depth error / tolerance (mean)".into(),
            x: (c0 * 0.8, c1 * 1.25),
            y: (e0 * 0.8, e1 * 1.25),
            log_y: true,
            log_x: true,
            series: vec![
                Series {
                    label: "Pareto front".into(),
                    points: f.clone(),
                    color: RED,
                    line: true,
                    labels: vec![],
                },
                Series {
                    label: "configuration".into(),
                    points: points.clone(),
                    color: BLUE,
                    line: false,
                    labels: labels.clone(),
                },
            ],
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_of_crowded_points_never_overlap_or_leave_the_plot() {
        // Five points almost on top of each other near the right edge, as the trade-off
        // chart's configurations at one cost are.
        let points: Vec<(i32, i32)> = (0..5).map(|i| (880 + 3 * i, 500 + i)).collect();
        let mut placer = Placer::new((70, 40, 990, 650), &points);
        let mut boxes = Vec::new();
        let mut keyed = 0;
        for (i, &p) in points.iter().enumerate() {
            let text = format!("fixed ÷2, configuration {i}");
            match placer.place(p, &text) {
                Some(at) => boxes.push(Placer::rect(at, &text)),
                None => {
                    keyed += 1;
                    boxes.push(Placer::rect(placer.force(p, &keyed.to_string()), "9"));
                }
            }
        }
        for (i, a) in boxes.iter().enumerate() {
            assert!(
                a.0 >= 70 && a.2 <= 990 && a.1 >= 40 && a.3 <= 650,
                "{a:?} outside"
            );
            for b in &boxes[i + 1..] {
                let apart = a.2 <= b.0 || b.2 <= a.0 || a.3 <= b.1 || b.3 <= a.1;
                assert!(apart, "{a:?} overlaps {b:?}");
            }
        }
    }

    #[test]
    fn log_ticks_label_the_data_decade() {
        assert_eq!(
            log_ticks((0.056, 0.85)),
            vec![0.07, 0.1, 0.2, 0.3, 0.5, 0.7]
        );
        assert_eq!(
            log_ticks((1e-3, 100.0)),
            vec![1e-3, 1e-2, 0.1, 1.0, 10.0, 100.0]
        );
        assert_eq!(tick(20.0), "20");
        assert_eq!(tick(0.07), "0.07");
    }
}
