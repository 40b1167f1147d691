//! The contact window's resampling: from the coarse grid to every working pixel.

/// ×2 upsampling of a `w × h` grid each way: samples kept, midpoints by cubic convolution
/// (−1, 9, 9, −1)/16, edges replicated. The result is `(2w − 1) × (2h − 1)`.
pub fn upsample2(v: &[i32], w: usize, h: usize) -> Vec<i32> {
    let mid = |a: i32, b: i32, c: i32, d: i32| {
        ((9 * (i64::from(b) + i64::from(c)) - i64::from(a) - i64::from(d) + 8) >> 4) as i32
    };
    let (ow, oh) = (2 * w - 1, 2 * h - 1);
    let mut out = vec![0i32; ow * oh];
    // Even rows: the coarse rows, upsampled along x.
    for y in 0..h {
        let src = &v[y * w..(y + 1) * w];
        let dst = &mut out[2 * y * ow..(2 * y + 1) * ow];
        let at = |k: isize| src[k.clamp(0, w as isize - 1) as usize];
        for x in 0..w {
            dst[2 * x] = src[x];
            if x + 1 < w {
                let k = x as isize;
                dst[2 * x + 1] = mid(at(k - 1), at(k), at(k + 1), at(k + 2));
            }
        }
    }
    // Odd rows: midpoints of the even rows, along y.
    for y in 0..h.saturating_sub(1) {
        let row = |k: isize| 2 * k.clamp(0, h as isize - 1) as usize * ow;
        let k = y as isize;
        let (ra, rb, rc, rd) = (row(k - 1), row(k), row(k + 1), row(k + 2));
        for x in 0..ow {
            out[(2 * y + 1) * ow + x] = mid(out[ra + x], out[rb + x], out[rc + x], out[rd + x]);
        }
    }
    out
}
