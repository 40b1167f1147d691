//! The contact window's resampling: from the coarse grid to every working pixel.

/// ×2 upsampling of a `w × h` grid each way: samples kept, midpoints by cubic convolution
/// (−1, 9, 9, −1)/16, edges replicated. The result is `(2w − 1) × (2h − 1)`.
pub fn upsample2(v: &[i32], w: usize, h: usize) -> Vec<i32> {
    let (ow, oh) = (2 * w - 1, 2 * h - 1);
    let mut out = vec![0i32; ow * oh];
    // Even rows: the coarse rows, upsampled along x (edges by clamping, the rest from
    // four neighbours at a time).
    for y in 0..h {
        let src = &v[y * w..(y + 1) * w];
        let dst = &mut out[2 * y * ow..(2 * y + 1) * ow];
        for (d, &s) in dst.iter_mut().step_by(2).zip(src) {
            *d = s;
        }
        let at = |k: isize| src[k.clamp(0, w as isize - 1) as usize];
        for x in [0, w.saturating_sub(2)] {
            if x + 1 < w {
                let k = x as isize;
                dst[2 * x + 1] = mid(at(k - 1), at(k), at(k + 1), at(k + 2));
            }
        }
        for (k, q) in src.windows(4).enumerate() {
            dst[2 * k + 3] = mid(q[0], q[1], q[2], q[3]);
        }
    }
    // Odd rows: midpoints of the even rows, along y.
    let mut row = vec![0i32; ow];
    for y in 0..h.saturating_sub(1) {
        let even = |k: isize| {
            let r = 2 * k.clamp(0, h as isize - 1) as usize * ow;
            &out[r..r + ow]
        };
        let k = y as isize;
        let (ra, rb, rc, rd) = (even(k - 1), even(k), even(k + 1), even(k + 2));
        for ((((o, &a), &b), &c), &d) in row.iter_mut().zip(ra).zip(rb).zip(rc).zip(rd) {
            *o = mid(a, b, c, d);
        }
        out[(2 * y + 1) * ow..(2 * y + 2) * ow].copy_from_slice(&row);
    }
    out
}

/// The cubic convolution's midpoint between `b` and `c`, with `a` and `d` beyond them.
fn mid(a: i32, b: i32, c: i32, d: i32) -> i32 {
    ((9 * (i64::from(b) + i64::from(c)) - i64::from(a) - i64::from(d) + 8) >> 4) as i32
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The upsampling as it was first written: every midpoint from clamped neighbours.
    fn upsample2_plain(v: &[i32], w: usize, h: usize) -> Vec<i32> {
        let (ow, oh) = (2 * w - 1, 2 * h - 1);
        let mut out = vec![0i32; ow * oh];
        for y in 0..h {
            let src = &v[y * w..(y + 1) * w];
            let at = |k: isize| src[k.clamp(0, w as isize - 1) as usize];
            for x in 0..w {
                out[2 * y * ow + 2 * x] = src[x];
                if x + 1 < w {
                    let k = x as isize;
                    out[2 * y * ow + 2 * x + 1] = mid(at(k - 1), at(k), at(k + 1), at(k + 2));
                }
            }
        }
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

    #[test]
    fn upsampling_matches_its_plain_form_on_any_size() {
        let mut rng = crate::test_rng::XorShift(0x51_7cc1_b727_220a);
        for (w, h) in [
            (1usize, 1usize),
            (2, 1),
            (1, 3),
            (3, 2),
            (4, 4),
            (5, 7),
            (37, 23),
        ] {
            let v: Vec<i32> = (0..w * h)
                .map(|_| (rng.next() % 20_001) as i32 - 10_000)
                .collect();
            assert_eq!(upsample2(&v, w, h), upsample2_plain(&v, w, h), "{w}x{h}");
        }
    }

    /// Quadratics are reproduced exactly at the midpoints (away from the clamped edges).
    #[test]
    fn midpoints_are_exact_for_quadratics() {
        let q = |x: i32| 3 * x * x - 5 * x + 7;
        // Samples at even x; the midpoint at odd x.
        for x in 2..20 {
            let m = mid(
                q(2 * x - 2) * 16,
                q(2 * x) * 16,
                q(2 * x + 2) * 16,
                q(2 * x + 4) * 16,
            );
            assert_eq!(m, q(2 * x + 1) * 16);
        }
    }
}
