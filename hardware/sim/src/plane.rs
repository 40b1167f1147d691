//! Operations on planes sampled on the image grid.

/// Gaussian blur of one plane in place (separable, edge-clamped). σ ≤ 0.1 px is a no-op.
pub fn blur(buf: &mut [f32], w: usize, h: usize, sigma_px: f32) {
    if sigma_px <= 0.1 || w == 0 || h == 0 {
        return;
    }
    let r = (3.0 * sigma_px).ceil() as usize;
    let k: Vec<f32> = (0..=2 * r)
        .map(|i| {
            let d = i as f32 - r as f32;
            (-d * d / (2.0 * sigma_px * sigma_px)).exp()
        })
        .collect();
    let sum: f32 = k.iter().sum();
    let k: Vec<f32> = k.iter().map(|v| v / sum).collect();
    // Rows: pad each row by clamping, then a straight convolution.
    let mut padded = vec![0.0f32; w + 2 * r];
    let mut tmp = vec![0.0f32; w * h];
    for y in 0..h {
        let row = &buf[y * w..(y + 1) * w];
        for (i, p) in padded.iter_mut().enumerate() {
            *p = row[i.saturating_sub(r).min(w - 1)];
        }
        for (x, out) in tmp[y * w..(y + 1) * w].iter_mut().enumerate() {
            *out = k
                .iter()
                .zip(&padded[x..x + 2 * r + 1])
                .map(|(a, b)| a * b)
                .sum();
        }
    }
    // Columns: accumulate whole rows at a time (cache friendly).
    buf.iter_mut().for_each(|v| *v = 0.0);
    for y in 0..h {
        let out = &mut buf[y * w..(y + 1) * w];
        for (j, kv) in k.iter().enumerate() {
            let yy = (y + j).saturating_sub(r).min(h - 1);
            let src = &tmp[yy * w..(yy + 1) * w];
            for (o, s) in out.iter_mut().zip(src) {
                *o += kv * s;
            }
        }
    }
}

/// One plane of a `w × h` image magnified by `1 + chi` about the image's centre (a lens
/// that images this colour at another scale): each pixel takes the value bilinearly
/// interpolated at `c + (p − c)/(1 + chi)`, clamped at the edges. `chi = 0` is a no-op.
pub fn magnify(buf: &mut [f32], w: usize, h: usize, chi: f32) {
    if chi == 0.0 || w == 0 || h == 0 {
        return;
    }
    let src = buf.to_vec();
    let (cx, cy) = (w as f32 / 2.0, h as f32 / 2.0);
    let at = |x: usize, y: usize| src[y.min(h - 1) * w + x.min(w - 1)];
    for y in 0..h {
        for x in 0..w {
            // Pixel centres at +0.5, as the renderer samples them.
            let sx = (cx + (x as f32 + 0.5 - cx) / (1.0 + chi) - 0.5).clamp(0.0, (w - 1) as f32);
            let sy = (cy + (y as f32 + 0.5 - cy) / (1.0 + chi) - 0.5).clamp(0.0, (h - 1) as f32);
            let (x0, y0) = (sx.floor() as usize, sy.floor() as usize);
            let (fx, fy) = (sx - x0 as f32, sy - y0 as f32);
            let top = at(x0, y0) * (1.0 - fx) + at(x0 + 1, y0) * fx;
            let bottom = at(x0, y0 + 1) * (1.0 - fx) + at(x0 + 1, y0 + 1) * fx;
            buf[y * w + x] = top * (1.0 - fy) + bottom * fy;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bright column magnified by 1 % about the centre of a 201-pixel row lies 1 % of its
    /// distance further out; the centre column stays.
    #[test]
    fn magnify_moves_features_out_in_proportion_to_their_distance() {
        let (w, h) = (201usize, 3usize);
        let centroid = |chi: f32, col: usize| {
            let mut p = vec![0.0f32; w * h];
            for y in 0..h {
                p[y * w + col] = 1.0;
            }
            magnify(&mut p, w, h, chi);
            let row = &p[w..2 * w];
            let sum: f32 = row.iter().sum();
            row.iter()
                .enumerate()
                .map(|(x, v)| x as f32 * v)
                .sum::<f32>()
                / sum
        };
        // Column 180's centre (180.5) lies 80 px right of the row's (100.5).
        assert!(
            (centroid(0.01, 180) - 180.8).abs() < 0.05,
            "{}",
            centroid(0.01, 180)
        );
        assert!((centroid(0.01, 100) - 100.0).abs() < 0.01);
        assert!(
            (centroid(-0.01, 20) - 20.8).abs() < 0.05,
            "{}",
            centroid(-0.01, 20)
        );
        assert_eq!(centroid(0.0, 180), 180.0);
    }
}
