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
