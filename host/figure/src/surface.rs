//! The indented surface in 3-D: the depth map as a relief seen from above at an angle,
//! each facet coloured by its depth and shaded by a light from the upper left, so the
//! shape of the contact reads at a glance.
//!
//! The depth map is averaged down to at most [`MAX_FACETS`] facets on its long side
//! (a relief of 80 000 facets draws no better and makes a heavy SVG); the facets are drawn
//! from the farthest to the nearest (painter's order), as the chart library does not hide
//! surfaces.

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::colour::ColourMap;
use crate::font::FAMILY;
use crate::panel::{empty, err, Drawn};
use crate::Grid;

/// Facets along the long side of the relief, at most.
pub const MAX_FACETS: usize = 60;

/// `grid` averaged over blocks, so its long side has at most `max` cells; untrusted cells
/// count as flat (0).
pub fn coarse(grid: &Grid, max: usize) -> Grid {
    let b = grid.width.max(grid.height).div_ceil(max.max(1)).max(1);
    let (w, h) = (grid.width.div_ceil(b), grid.height.div_ceil(b));
    let mut values = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            let (mut sum, mut n) = (0.0f32, 0u32);
            for yy in y * b..((y + 1) * b).min(grid.height) {
                for xx in x * b..((x + 1) * b).min(grid.width) {
                    let v = grid.values[yy * grid.width + xx];
                    sum += if v.is_finite() { v } else { 0.0 };
                    n += 1;
                }
            }
            values.push(sum / n.max(1) as f32);
        }
    }
    Grid {
        width: w,
        height: h,
        pitch_mm: grid.pitch_mm * b as f64,
        values,
    }
}

/// The relief of a depth map (mm), coloured by `map` over `range`.
pub fn relief<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    caption: &str,
    depth: Option<&Grid>,
    map: ColourMap,
    range: (f64, f64),
) -> Drawn {
    let Some(g) = depth.filter(|g| g.is_consistent() && g.width > 1 && g.height > 1) else {
        return empty(area, caption, "no map");
    };
    let c = coarse(g, MAX_FACETS);
    let (w_mm, h_mm) = (c.width as f64 * c.pitch_mm, c.height as f64 * c.pitch_mm);
    let deepest = range.1.max(1e-3);
    let mut chart = ChartBuilder::on(area)
        .caption(caption, (FAMILY, 19))
        .margin(12)
        .build_cartesian_3d(0.0..w_mm, -deepest..0.0, 0.0..h_mm)
        .map_err(err)?;
    // A flat box: the relief is drawn a third as high as it is wide, so the skin reads
    // as a sheet with a dimple, not as a column.
    let (pw, ph) = area.dim_in_pixel();
    let side = pw.min(ph) as i32;
    chart.set_3d_pixel_range((side, side / 3, side));
    chart.with_projection(|mut p| {
        p.yaw = 0.55;
        p.pitch = 0.55;
        p.scale = 0.85;
        p.into_matrix()
    });
    chart
        .configure_axes()
        .light_grid_style(RGBColor(225, 225, 225))
        .max_light_lines(2)
        .label_style((FAMILY, 12))
        .x_formatter(&|v| format!("{v:.0} mm"))
        .z_formatter(&|v| format!("{v:.0} mm"))
        // Depth is down: the labels count it positive (and never as "-0.0").
        .y_formatter(&|v| format!("{:.1} mm", 0.0 - v))
        .draw()
        .map_err(err)?;
    // How much the drawn box stretches depth against length: the shading follows the
    // relief as drawn, not as it is (a 1 mm dimple in a 30 mm skin would look flat).
    let stretch = w_mm.max(h_mm) / deepest / 3.0;
    let light = normalise([-0.45, 1.0, -0.35]);
    let at = |x: usize, y: usize| f64::from(c.values[y * c.width + x]);
    let mut facets = Vec::with_capacity((c.width - 1) * (c.height - 1));
    for y in 0..c.height - 1 {
        for x in 0..c.width - 1 {
            let d = [at(x, y), at(x + 1, y), at(x + 1, y + 1), at(x, y + 1)];
            let (x0, x1) = ((x as f64 + 0.5) * c.pitch_mm, (x as f64 + 1.5) * c.pitch_mm);
            let (z0, z1) = ((y as f64 + 0.5) * c.pitch_mm, (y as f64 + 1.5) * c.pitch_mm);
            let corners = [
                (x0, -d[0], z0),
                (x1, -d[1], z0),
                (x1, -d[2], z1),
                (x0, -d[3], z1),
            ];
            // The facet's normal in the drawn box: height up, depth stretched.
            let ddx = (d[1] + d[2] - d[0] - d[3]) / 2.0 / c.pitch_mm * stretch;
            let ddz = (d[3] + d[2] - d[0] - d[1]) / 2.0 / c.pitch_mm * stretch;
            let n = normalise([ddx, 1.0, ddz]);
            let lit = 0.45 + 0.55 * (n[0] * light[0] + n[1] * light[1] + n[2] * light[2]).max(0.0);
            let mean = d.iter().sum::<f64>() / 4.0;
            let rgb = map
                .of(mean as f32, range)
                .map(|v| (f64::from(v) * lit).min(255.0) as u8);
            let centre = ((x0 + x1) / 2.0, -mean, (z0 + z1) / 2.0);
            let depth = chart
                .as_coord_spec()
                .projected_depth(&centre.0, &centre.1, &centre.2);
            facets.push((depth, corners, rgb));
        }
    }
    // The library's projected depth grows towards the viewer.
    facets.sort_by_key(|f| f.0);
    chart
        .draw_series(facets.into_iter().map(|(_, corners, [r, g, b])| {
            Polygon::new(corners.to_vec(), RGBColor(r, g, b).filled())
        }))
        .map_err(err)?;
    Ok(())
}

fn normalise(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt().max(1e-12);
    v.map(|x| x / n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coarse_keeps_the_mean_and_the_extent() {
        let g = Grid {
            width: 130,
            height: 90,
            pitch_mm: 0.1,
            values: (0..130 * 90)
                .map(|i| if i % 2 == 0 { 1.0 } else { f32::NAN })
                .collect(),
        };
        let c = coarse(&g, 60);
        assert_eq!((c.width, c.height), (44, 30));
        assert!((c.pitch_mm - 0.3).abs() < 1e-12);
        // Columns 0 and 2 of the first block are trusted (1.0), column 1 counts as flat.
        assert!((c.values[0] - 2.0 / 3.0).abs() < 1e-6);
    }
}
