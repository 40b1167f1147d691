//! Colour-mapped map images with a colour bar: depth and temperature maps for `analyze
//! --out` and the demo's session folder.

use std::path::Path;

use anyhow::{Context, Result};
use image::{Rgb, RgbImage};

use vistaf_pipeline::Measurement;

/// A perceptually ordered colour map (viridis, 5 anchors, linear between).
pub fn viridis(t: f32) -> Rgb<u8> {
    const A: [[f32; 3]; 5] = [
        [68.0, 1.0, 84.0],
        [59.0, 82.0, 139.0],
        [33.0, 145.0, 140.0],
        [94.0, 201.0, 98.0],
        [253.0, 231.0, 37.0],
    ];
    let t = t.clamp(0.0, 1.0) * 4.0;
    let i = (t.floor() as usize).min(3);
    let f = t - i as f32;
    let c = |k: usize| (A[i][k] + (A[i + 1][k] - A[i][k]) * f).round() as u8;
    Rgb([c(0), c(1), c(2)])
}

/// Writes a map (row-major `w × h`) scaled to [lo, hi], with a colour bar on the right and
/// tick marks at 0, ¼, ½, ¾ and 1 of the range.
pub fn map_png(
    values: &[f32],
    w: usize,
    h: usize,
    lo: f32,
    hi: f32,
    scale: usize,
    path: &Path,
) -> Result<()> {
    let s = scale.max(1);
    let bar = 24;
    let (iw, ih) = ((w * s + 8 + bar) as u32, (h * s) as u32);
    let mut img = RgbImage::from_pixel(iw, ih, Rgb([255, 255, 255]));
    let span = (hi - lo).max(1e-6);
    for y in 0..h * s {
        for x in 0..w * s {
            let v = values[(y / s) * w + x / s];
            img.put_pixel(
                x as u32,
                y as u32,
                if v.is_finite() {
                    viridis((v - lo) / span)
                } else {
                    Rgb([128, 128, 128])
                },
            );
        }
        let t = 1.0 - y as f32 / (h * s).max(1) as f32;
        for x in 0..bar {
            img.put_pixel((w * s + 8 + x) as u32, y as u32, viridis(t));
        }
    }
    for k in 0..=4 {
        let y = ((h * s - 1) as f32 * k as f32 / 4.0) as u32;
        for x in 0..6 {
            img.put_pixel((w * s + 8 + bar - 6 + x) as u32, y, Rgb([0, 0, 0]));
        }
    }
    img.save(path)
        .with_context(|| format!("writing {}", path.display()))
}

/// The temperature map as PNG: one cell per block, the bar spanning the frame's coldest to
/// hottest place (`min_c`, `max_c`; at least 2 °C wide, a stray block beyond it drawn at
/// the bar's end).
pub fn temperature_png(t: &vistaf_pipeline::thermal::Temperature, path: &Path) -> Result<()> {
    let (lo, hi) = if t.min_c.is_finite() {
        let mid = (t.min_c + t.max_c) / 2.0;
        let half = ((t.max_c - t.min_c) / 2.0).max(1.0);
        (mid - half, mid + half)
    } else {
        (20.0, 40.0)
    };
    let scale = (480 / t.bh.max(1)).clamp(4, 32);
    map_png(&t.map_c, t.bw, t.bh, lo, hi, scale, path)
}

/// The depth map of a result as PNG: the bar spans 0 to the frame's peak depth (its
/// `depth_mm` in the JSON output), at least 0.1 mm.
pub fn depth_png(d: &Measurement, path: &Path) -> Result<()> {
    let v: Vec<f32> = d.depth_um.iter().map(|&u| u as f32 / 1000.0).collect();
    map_png(
        &v,
        d.width_px,
        d.height_px,
        0.0,
        d.peak_depth_mm.max(0.1),
        d.factor,
        path,
    )
}

/// A map received over the wire as PNG (cells in µm or 0.01 °C; [`vistaf_protocol::msg::MAP_NO_DATA`]
/// cells grey), scaled to its own range.
///
/// A map whose cells do not fill its size is refused (the decoders drop such maps; one
/// built by hand may still be one).
pub fn wire_map_png(m: &vistaf_protocol::Map, path: &Path) -> Result<()> {
    if !m.is_consistent() {
        anyhow::bail!(
            "map {}×{} has {} cells: not drawn",
            m.width,
            m.height,
            m.cells.len()
        );
    }
    let (w, h) = (usize::from(m.width), usize::from(m.height));
    let scale = match m.kind {
        vistaf_protocol::MapKind::Depth => 1000.0,
        vistaf_protocol::MapKind::Temperature => 100.0,
    };
    let v: Vec<f32> = m
        .cells
        .iter()
        .map(|&c| {
            if c == vistaf_protocol::msg::MAP_NO_DATA {
                f32::NAN
            } else {
                f32::from(c) / scale
            }
        })
        .collect();
    let finite = v.iter().copied().filter(|x| x.is_finite());
    let lo = finite.clone().fold(f32::INFINITY, f32::min);
    let hi = finite.fold(f32::NEG_INFINITY, f32::max);
    let (lo, hi) = match m.kind {
        vistaf_protocol::MapKind::Depth => (0.0, hi.max(0.1)),
        vistaf_protocol::MapKind::Temperature if lo.is_finite() => {
            let mid = (lo + hi) / 2.0;
            let half = ((hi - lo) / 2.0).max(1.0);
            (mid - half, mid + half)
        }
        vistaf_protocol::MapKind::Temperature => (20.0, 40.0),
    };
    map_png(&v, w, h, lo, hi, (480 / h.max(1)).clamp(2, 32), path)
}
