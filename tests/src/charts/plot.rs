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

/// A tick label without float noise.
fn tick(v: f64) -> String {
    let a = v.abs();
    if a >= 100.0 || a == 0.0 {
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
                    for (p, t) in s.points.iter().zip(&s.labels) {
                        chart
                            .draw_series(std::iter::once(Text::new(
                                t.clone(),
                                *p,
                                ("sans-serif", 12),
                            )))
                            .map_err(err)?;
                    }
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
        match (log_x, log_y) {
            (false, false) => body!(b.build_cartesian_2d(x.0..x.1, y.0..y.1).map_err(err)?),
            (false, true) => {
                body!(b
                    .build_cartesian_2d(x.0..x.1, (y.0..y.1).log_scale())
                    .map_err(err)?)
            }
            (true, false) => {
                body!(b
                    .build_cartesian_2d((x.0..x.1).log_scale(), y.0..y.1)
                    .map_err(err)?)
            }
            (true, true) => body!(b
                .build_cartesian_2d((x.0..x.1).log_scale(), (y.0..y.1).log_scale())
                .map_err(err)?),
        }
        Ok(())
    };
    draw(&mut sink)
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
    let labels: Vec<String> = ok.iter().map(|r| format!("  {}", r.config.name)).collect();
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
