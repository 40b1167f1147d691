//! The 2-D panels: a map drawn to scale on mm axes, with a numbered colour bar beside it,
//! and the camera image on the same axes.
//!
//! Maps are drawn as one bitmap scaled to the plotting area (nearest cell), not as a
//! rectangle per cell: a working-resolution map has tens of thousands of cells, and the
//! SVG twin stays small. The colour bar's ticks are drawn here rather than by the chart
//! library so they fall on round values and each carries its unit.

use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;

use crate::colour::ColourMap;
use crate::font::FAMILY;
use crate::range::step;
use crate::{Grid, Picture};

/// What a drawing call returns: the backend's error as text.
pub type Drawn = Result<(), String>;

/// Converts a backend error to text.
pub fn err<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

/// Width of a colour bar with its labels, pixels.
pub const BAR_AREA_PX: u32 = 118;

/// Label areas around a map's plotting area, pixels.
const Y_LABELS_PX: u32 = 54;
const X_LABELS_PX: u32 = 42;
const CAPTION_PX: u32 = 30;

/// A value as a tick label: as many decimals as the step needs.
pub fn tick_text(v: f64, step: f64) -> String {
    let decimals = (-step.log10().floor()).max(0.0) as usize;
    format!("{v:.decimals$}")
}

/// Where a cell of a `width × height` map lands: the plotting area, mm.
struct Extent {
    w_mm: f64,
    h_mm: f64,
}

/// A chart on `area` whose plotting area has the map's aspect: mm axes, y down (image
/// rows), the caption on top.
fn scaled_chart<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    caption: &str,
    e: &Extent,
) -> Result<MapChart<'a, DB>, String> {
    let (aw, ah) = area.dim_in_pixel();
    let free_w = f64::from(aw.saturating_sub(Y_LABELS_PX + 16));
    let free_h = f64::from(ah.saturating_sub(X_LABELS_PX + CAPTION_PX + 16));
    let s = (free_w / e.w_mm).min(free_h / e.h_mm).max(0.0);
    let (pw, ph) = ((e.w_mm * s) as u32, (e.h_mm * s) as u32);
    let extra_w = aw.saturating_sub(Y_LABELS_PX + 16 + pw);
    let extra_h = ah.saturating_sub(X_LABELS_PX + CAPTION_PX + 16 + ph);
    let mut chart = ChartBuilder::on(area)
        .caption(caption, (FAMILY, 19))
        .margin(8)
        .margin_right(8 + extra_w)
        .margin_bottom(8 + extra_h)
        .x_label_area_size(X_LABELS_PX)
        .y_label_area_size(Y_LABELS_PX)
        .build_cartesian_2d(0.0..e.w_mm, e.h_mm..0.0)
        .map_err(err)?;
    let ticks = step(e.w_mm.max(e.h_mm));
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc("x, mm")
        .y_desc("y, mm")
        .x_labels((e.w_mm / ticks) as usize + 2)
        .y_labels((e.h_mm / ticks) as usize + 2)
        .x_label_formatter(&|v| tick_text(*v, ticks))
        .y_label_formatter(&|v| tick_text(*v, ticks))
        .label_style((FAMILY, 13))
        .axis_desc_style((FAMILY, 14))
        .draw()
        .map_err(err)?;
    Ok(chart)
}

/// Fills the chart's plotting area with `pixel(x, y)` of a `w × h` raster, scaled to fit.
fn blit<DB: DrawingBackend>(
    chart: &mut MapChart<'_, DB>,
    (w, h): (usize, usize),
    pixel: impl Fn(usize, usize) -> [u8; 3],
) -> Drawn {
    let (pw, ph) = chart.plotting_area().dim_in_pixel();
    if pw == 0 || ph == 0 {
        return Ok(());
    }
    let mut buf = Vec::with_capacity((pw * ph * 3) as usize);
    for py in 0..ph as usize {
        let y = (py * h / ph as usize).min(h - 1);
        for px in 0..pw as usize {
            buf.extend(pixel((px * w / pw as usize).min(w - 1), y));
        }
    }
    let image = BitMapElement::with_owned_buffer((0.0, 0.0), (pw, ph), buf)
        .ok_or_else(|| "bitmap size".to_string())?;
    chart.draw_series(std::iter::once(image)).map_err(err)?;
    Ok(())
}

/// The chart type of a map panel: mm on both axes.
type MapChart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// A `w × h` raster of `pitch_mm` cells, `pixel(x, y)` each, drawn to scale on mm axes
/// ([`scaled_chart`], [`blit`]); the chart, for marks on top.
fn raster<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    caption: &str,
    (w, h, pitch_mm): (usize, usize, f64),
    pixel: impl Fn(usize, usize) -> [u8; 3],
) -> Result<MapChart<'a, DB>, String> {
    let e = Extent {
        w_mm: w as f64 * pitch_mm,
        h_mm: h as f64 * pitch_mm,
    };
    let mut chart = scaled_chart(area, caption, &e)?;
    blit(&mut chart, (w, h), pixel)?;
    Ok(chart)
}

/// The part of a panel left of where a colour bar goes (a panel without one keeps the
/// space, so every map is drawn at the same size).
fn beside_bar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
) -> (DrawingArea<DB, Shift>, DrawingArea<DB, Shift>) {
    let (aw, _) = area.dim_in_pixel();
    area.split_horizontally(aw.saturating_sub(BAR_AREA_PX))
}

/// A panel that has nothing to show says so.
pub(crate) fn empty<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    caption: &str,
    why: &str,
) -> Drawn {
    let (w, h) = area.dim_in_pixel();
    area.draw(&Text::new(
        format!("{caption}: {why}"),
        (w as i32 / 6, h as i32 / 2),
        (FAMILY, 16).into_font().color(&RGBColor(90, 90, 90)),
    ))
    .map_err(err)
}

/// A mark on a map: a place worth pointing at, with its text.
#[derive(Debug, Clone)]
pub struct Mark {
    /// The cell, `(x, y)`.
    pub cell: (usize, usize),
    /// What to write beside it.
    pub text: String,
}

/// A map of `grid` coloured by `map` over `range`, on mm axes, with its colour bar
/// (`unit` after every number, `title` above) and `marks` pointed at.
pub fn heat<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    caption: &str,
    grid: Option<&Grid>,
    map: ColourMap,
    range: (f64, f64),
    (title, unit): (&str, &str),
    marks: &[Mark],
) -> Drawn {
    let (main, bar) = beside_bar(area);
    colour_bar(&bar, map, range, title, unit)?;
    let Some(g) = grid.filter(|g| g.is_consistent()) else {
        return empty(&main, caption, "no map");
    };
    let chart = raster(&main, caption, (g.width, g.height, g.pitch_mm), |x, y| {
        map.of(g.values[y * g.width + x], range)
    })?;
    let w_mm = g.width as f64 * g.pitch_mm;
    for m in marks {
        let at = (
            (m.cell.0 as f64 + 0.5) * g.pitch_mm,
            (m.cell.1 as f64 + 0.5) * g.pitch_mm,
        );
        let area = chart.plotting_area();
        area.draw(&Circle::new(
            at,
            7,
            ShapeStyle::from(&WHITE).stroke_width(3),
        ))
        .map_err(err)?;
        area.draw(&Circle::new(
            at,
            7,
            ShapeStyle::from(&BLACK).stroke_width(1),
        ))
        .map_err(err)?;
        // The text goes where the panel has room: left of marks in the right half. White
        // on a black shadow, so it reads on the hottest and the coldest colour alike.
        let right_half = at.0 > w_mm / 2.0;
        let dx = if right_half {
            -12 - 8 * m.text.chars().count() as i32
        } else {
            12
        };
        for (shift, colour) in [(1, BLACK), (0, WHITE)] {
            let label = EmptyElement::at(at)
                + Text::new(
                    m.text.clone(),
                    (dx + shift, -8 + shift),
                    (FAMILY, 15).into_font().color(&colour),
                );
            area.draw(&label).map_err(err)?;
        }
    }
    Ok(())
}

/// The camera image on the same mm axes as the maps.
pub fn camera<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    caption: &str,
    picture: Option<&Picture>,
) -> Drawn {
    let (main, _) = beside_bar(area);
    let Some(p) = picture.filter(|p| p.is_consistent()) else {
        return empty(&main, caption, "no image");
    };
    raster(&main, caption, (p.width, p.height, p.pitch_mm), |x, y| {
        let i = (y * p.width + x) * 3;
        [p.rgb[i], p.rgb[i + 1], p.rgb[i + 2]]
    })
    .map(|_| ())
}

/// A vertical colour bar from `range.0` (bottom) to `range.1` (top), a tick and a number
/// with `unit` at every round step, `title` above.
pub fn colour_bar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    map: ColourMap,
    (lo, hi): (f64, f64),
    title: &str,
    unit: &str,
) -> Drawn {
    let (_, ah) = area.dim_in_pixel();
    let (x0, bw) = (6i32, 22i32);
    let (top, bottom) = (CAPTION_PX as i32 + 16, ah as i32 - X_LABELS_PX as i32 - 8);
    if bottom <= top + 10 || hi <= lo {
        return Ok(());
    }
    let hpx = bottom - top;
    area.draw(&Text::new(
        title.to_string(),
        (0, top - 22),
        (FAMILY, 14).into_font(),
    ))
    .map_err(err)?;
    let mut buf = Vec::with_capacity((bw * hpx * 3) as usize);
    for y in 0..hpx {
        let c = map.at(1.0 - y as f32 / (hpx - 1).max(1) as f32);
        for _ in 0..bw {
            buf.extend(c);
        }
    }
    let image = BitMapElement::with_owned_buffer((x0, top), (bw as u32, hpx as u32), buf)
        .ok_or_else(|| "bitmap size".to_string())?;
    area.draw(&image).map_err(err)?;
    area.draw(&Rectangle::new([(x0, top), (x0 + bw, bottom)], BLACK))
        .map_err(err)?;
    let s = step(hi - lo);
    let first = (lo / s).ceil() as i64;
    let last = (hi / s + 1e-9).floor() as i64;
    for k in first..=last {
        let v = k as f64 * s;
        let y = bottom - ((v - lo) / (hi - lo) * f64::from(hpx)).round() as i32;
        area.draw(&PathElement::new(
            vec![(x0 + bw, y), (x0 + bw + 5, y)],
            BLACK,
        ))
        .map_err(err)?;
        area.draw(&Text::new(
            format!("{} {unit}", tick_text(v, s)),
            (x0 + bw + 8, y - 7),
            (FAMILY, 13).into_font(),
        ))
        .map_err(err)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_have_the_decimals_their_step_needs() {
        assert_eq!(tick_text(0.5, 0.1), "0.5");
        assert_eq!(tick_text(1.0, 0.2), "1.0");
        assert_eq!(tick_text(25.0, 2.0), "25");
        assert_eq!(tick_text(0.05, 0.05), "0.05");
    }
}
