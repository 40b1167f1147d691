//! The inverse DCT of a block's lowest `N × N` frequencies, `N` = 8, 4, 2 or 1: the
//! block's `N × N` pixels at `N/8` of its size, as libjpeg's scaled decoding makes them.
//!
//! An `N`-point inverse transform of the lowest `N` coefficients is the 8-point one's
//! band-limited curve sampled at the centres of the `N` coarse pixels (`cos((2x'+1)uπ/2N)`
//! is `cos((2x+1)uπ/16)` at `x = 8x'/N + (8/N − 1)/2`), so a 1/8 decode is the block's DC
//! alone and a 1/2 decode passes what a 2 × 2 area filter would. Rows and columns that hold
//! no coefficient are skipped: most blocks of a camera frame end early. On aarch64 the
//! 4 × 4 transform runs in NEON lanes instead, where computing the empty ones costs less
//! than testing for them.

/// Largest coefficient magnitude kept: an 8-bit image's DCT stays within ±1024 plus a
/// quantisation step, so this only bounds what corrupt data could make overflow.
pub const COEF_LIMIT: i32 = 4095;

/// The `N × N` pixels (row-major, level-shifted to 0…255) of `coef`, the block's
/// dequantised coefficients in natural order at `v·N + u`, of which only the first `rows`
/// rows and `cols` columns may be non-zero; `tmp` is scratch. At `N = 1` a block is its
/// DC alone.
#[inline(always)]
pub fn block<const N: usize>(
    coef: &[i32; 64],
    rows: usize,
    cols: usize,
    tmp: &mut [i32; 64],
    out: &mut [u8; 64],
) {
    if N == 1 || (rows <= 1 && cols <= 1) {
        // The DC alone: F(0,0)/8, flat.
        out[..N * N].fill(pixel((coef[0] + 4) >> 3));
        return;
    }
    match N {
        8 => separable::<8>(coef, rows, cols, tmp, out, idct8),
        4 => four(coef, rows, cols, tmp, out),
        _ => separable::<2>(coef, rows, cols, tmp, out, idct2),
    }
}

/// The 4 × 4 transform (a 1/2-scale decode, the scale of a 720p or 1080p camera): on
/// aarch64 all four rows at once in NEON lanes (`neon::idct4x4`), else [`separable`].
#[inline(always)]
fn four(coef: &[i32; 64], rows: usize, cols: usize, tmp: &mut [i32; 64], out: &mut [u8; 64]) {
    #[cfg(target_arch = "aarch64")]
    {
        let _ = (rows, cols, tmp);
        neon::idct4x4(coef, out);
    }
    #[cfg(not(target_arch = "aarch64"))]
    separable::<4>(coef, rows, cols, tmp, out, idct4);
}

/// [`separable`]'s 4 × 4 transform with the block's four rows (then its four columns) in
/// the lanes of NEON vectors: the same integers, the empty rows and columns computed
/// rather than skipped. Every 8 × 8 block of the image is transformed, and the scalar
/// transform, which the compiler does not vectorise, was the largest part of a 1/2-scale
/// decode after the entropy decoding.
#[cfg(target_arch = "aarch64")]
mod neon {
    use core::arch::aarch64::{
        int32x4_t, int32x4x4_t, vaddq_s32, vcombine_s16, vcombine_u8, vdupq_n_s32, vld1q_s32,
        vld4q_s32, vmlaq_n_s32, vmlsq_n_s32, vmulq_n_s32, vqmovn_s32, vqmovun_s16, vrshrq_n_s32,
        vst1q_u8, vst4q_s32, vsubq_s32,
    };

    use super::{C1, C3, C4};

    /// [`super::idct4`] on four vectors, lane by lane.
    ///
    /// # Safety
    /// NEON must be present, as it is on every aarch64 target.
    #[allow(unsafe_code)]
    #[inline(always)]
    unsafe fn pass([f0, f1, f2, f3]: [int32x4_t; 4]) -> [int32x4_t; 4] {
        let (e0, e1) = (
            vmulq_n_s32(vaddq_s32(f0, f2), C4),
            vmulq_n_s32(vsubq_s32(f0, f2), C4),
        );
        let o0 = vmlaq_n_s32(vmulq_n_s32(f1, C1), f3, C3);
        let o1 = vmlsq_n_s32(vmulq_n_s32(f1, C3), f3, C1);
        [
            vaddq_s32(e0, o0),
            vaddq_s32(e1, o1),
            vsubq_s32(e1, o1),
            vsubq_s32(e0, o0),
        ]
    }

    /// The 4 × 4 pixels (`out[..16]`, row-major) of the coefficients `coef[..16]`
    /// (row-major). The workspace denies `unsafe` code; NEON's loads and stores take
    /// pointers.
    #[allow(unsafe_code)]
    pub(super) fn idct4x4(coef: &[i32; 64], out: &mut [u8; 64]) {
        let mut tmp = [0i32; 16];
        // SAFETY: NEON is part of every aarch64 target. `vld4q_s32` reads 16 values of
        // `coef` (64 long), `vst4q_s32` writes the 16 of `tmp` and each `vld1q_s32` reads
        // four of them at 0, 4, 8 or 12; `vst1q_u8` writes 16 bytes of `out` (64 long).
        unsafe {
            // Lane v of column u: coef[4v + u]; the rows' transforms, lane by lane.
            let c = vld4q_s32(coef.as_ptr());
            let t = pass([c.0, c.1, c.2, c.3]).map(|v| vrshrq_n_s32::<10>(v));
            // Stored interleaved and read back whole: lane x of row v.
            vst4q_s32(tmp.as_mut_ptr(), int32x4x4_t(t[0], t[1], t[2], t[3]));
            let rows = [0, 4, 8, 12].map(|v| vld1q_s32(tmp.as_ptr().add(v)));
            let level = vdupq_n_s32(128);
            let p = pass(rows).map(|v| vaddq_s32(vrshrq_n_s32::<14>(v), level));
            // Level-shifted, saturated to 0…255 as `super::pixel` clamps.
            let top = vcombine_s16(vqmovn_s32(p[0]), vqmovn_s32(p[1]));
            let bottom = vcombine_s16(vqmovn_s32(p[2]), vqmovn_s32(p[3]));
            vst1q_u8(
                out.as_mut_ptr(),
                vcombine_u8(vqmovun_s16(top), vqmovun_s16(bottom)),
            );
        }
    }
}

/// `cos(π/4)`, `cos(π/8)`, `cos(3π/8)`, Q11: the 1-D transforms below are
/// `x_n = Σ C(u)·cos((2n+1)uπ/2N)·f_u` with `C(0) = 1/√2`, factored into even and odd
/// halves.
const C4: i32 = 1448;
const C1: i32 = 1892;
const C3: i32 = 784;

/// The 4-point transform by even and odd halves: six multiplications instead of sixteen.
#[inline(always)]
fn idct4(f: [i32; 8]) -> [i32; 8] {
    let (e0, e1) = ((f[0] + f[2]) * C4, (f[0] - f[2]) * C4);
    let (o0, o1) = (f[1] * C1 + f[3] * C3, f[1] * C3 - f[3] * C1);
    [e0 + o0, e1 + o1, e1 - o1, e0 - o0, 0, 0, 0, 0]
}

/// `cos(kπ/16)` for odd `k`, Q11.
const K1: i32 = 2009;
const K3: i32 = 1703;
const K5: i32 = 1138;
const K7: i32 = 400;

/// The 8-point transform: the even coefficients are a 4-point transform ([`idct4`]), the
/// odd ones a 4 × 4 product; 22 multiplications instead of 64.
#[inline(always)]
fn idct8(f: [i32; 8]) -> [i32; 8] {
    let e = idct4([f[0], f[2], f[4], f[6], 0, 0, 0, 0]);
    let (a, b, c, d) = (f[1], f[3], f[5], f[7]);
    let o = [
        a * K1 + b * K3 + c * K5 + d * K7,
        a * K3 - b * K7 - c * K1 - d * K5,
        a * K5 - b * K1 + c * K7 + d * K3,
        a * K7 - b * K5 + c * K3 - d * K1,
    ];
    [
        e[0] + o[0],
        e[1] + o[1],
        e[2] + o[2],
        e[3] + o[3],
        e[3] - o[3],
        e[2] - o[2],
        e[1] - o[1],
        e[0] - o[0],
    ]
}

/// The 2-point transform.
#[inline(always)]
fn idct2(f: [i32; 8]) -> [i32; 8] {
    [(f[0] + f[1]) * C4, (f[0] - f[1]) * C4, 0, 0, 0, 0, 0, 0]
}

/// The 2-D transform by rows (those with coefficients), then columns, with the 1-D
/// transform `t` (Q11); the coefficients past `cols` in a row are zero. Rows descaled to half a coefficient (Q1), columns by the rest
/// and the 2-D transform's factor of 1/4.
#[inline(always)]
fn separable<const N: usize>(
    coef: &[i32; 64],
    rows: usize,
    cols: usize,
    tmp: &mut [i32; 64],
    out: &mut [u8; 64],
    t: impl Fn([i32; 8]) -> [i32; 8],
) {
    let rows = rows.min(N);
    for v in 0..rows {
        let c = &coef[v * N..v * N + N];
        let r = if cols <= 1 {
            // The row's DC alone: flat.
            [c[0] * C4; 8]
        } else {
            let mut f = [0; 8];
            f[..N].copy_from_slice(c);
            t(f)
        };
        for x in 0..N {
            tmp[v * N + x] = (r[x] + 512) >> 10;
        }
    }
    for x in 0..N {
        let mut f = [0; 8];
        for v in 0..rows {
            f[v] = tmp[v * N + x];
        }
        let c = if rows <= 1 { [f[0] * C4; 8] } else { t(f) };
        for y in 0..N {
            out[y * N + x] = pixel((c[y] + (1 << 13)) >> 14);
        }
    }
}

/// A level-shifted sample as a byte.
#[inline(always)]
fn pixel(v: i32) -> u8 {
    (v + 128).clamp(0, 255) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The 8-point transform, in floating point, as the JPEG standard writes it (A.3.3).
    fn reference(coef: &[f64; 64]) -> [f64; 64] {
        let c = |u: usize| {
            if u == 0 {
                std::f64::consts::FRAC_1_SQRT_2
            } else {
                1.0
            }
        };
        let mut out = [0.0; 64];
        for y in 0..8 {
            for x in 0..8 {
                let mut s = 0.0;
                for v in 0..8 {
                    for u in 0..8 {
                        let cx =
                            ((2 * x + 1) as f64 * u as f64 * std::f64::consts::PI / 16.0).cos();
                        let cy =
                            ((2 * y + 1) as f64 * v as f64 * std::f64::consts::PI / 16.0).cos();
                        s += c(u) * c(v) * coef[v * 8 + u] * cx * cy;
                    }
                }
                out[y * 8 + x] = s / 4.0 + 128.0;
            }
        }
        out
    }

    fn coefficients(seed: u64) -> [f64; 64] {
        let mut state = seed | 1;
        let mut c = [0.0; 64];
        for (k, v) in c.iter_mut().enumerate() {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let r = (state % 401) as f64 - 200.0;
            *v = r / (1 + k / 4) as f64;
        }
        c[0] = 300.0;
        c
    }

    /// The vector 4 × 4 transform gives the scalar one's integers, extreme coefficients
    /// and empty rows or columns included.
    #[cfg(target_arch = "aarch64")]
    #[test]
    fn the_vector_transform_is_the_scalar_one() {
        for seed in 1..200u64 {
            let c = coefficients(seed);
            let mut coef = [0i32; 64];
            let (rows, cols) = (1 + seed as usize % 4, 1 + (seed / 4) as usize % 4);
            for v in 0..rows {
                for u in 0..cols {
                    let scale = if seed % 7 == 0 { 40.0 } else { 1.0 };
                    coef[v * 4 + u] =
                        ((c[v * 8 + u] * scale) as i32).clamp(-COEF_LIMIT, COEF_LIMIT);
                }
            }
            let (mut want, mut got) = ([0u8; 64], [0u8; 64]);
            separable::<4>(&coef, rows, cols, &mut [0; 64], &mut want, idct4);
            neon::idct4x4(&coef, &mut got);
            assert_eq!(got[..16], want[..16], "seed {seed}: {:?}", &coef[..16]);
        }
    }

    #[test]
    fn the_full_transform_matches_the_standard_within_a_level() {
        for seed in 1..20 {
            let c = coefficients(seed);
            let want = reference(&c);
            let coef = c.map(|v| v as i32);
            let mut out = [0u8; 64];
            block::<8>(&coef, 8, 8, &mut [0; 64], &mut out);
            let want_i = reference(&coef.map(f64::from));
            for k in 0..64 {
                let d = f64::from(out[k]) - want_i[k].clamp(0.0, 255.0);
                assert!(
                    d.abs() <= 1.0,
                    "seed {seed} pixel {k}: {} vs {}",
                    out[k],
                    want[k]
                );
            }
        }
    }

    /// A reduced transform samples the full one's low-frequency curve at the coarse
    /// pixels' centres: on a block of only low frequencies, it is the full transform's
    /// pixels averaged (within what the averaging does to the curve).
    #[test]
    fn reduced_transforms_sample_the_low_frequencies() {
        let mut c = [0i32; 64];
        c[0] = 200;
        c[1] = 60;
        c[8] = -40;
        let mut full = [0u8; 64];
        block::<8>(&c, 2, 2, &mut [0; 64], &mut full);
        for (n, idct) in [(4, 0), (2, 1)] {
            let mut low = [0i32; 64];
            for v in 0..2 {
                for u in 0..2 {
                    low[v * n + u] = c[v * 8 + u];
                }
            }
            let mut out = [0u8; 64];
            if idct == 0 {
                block::<4>(&low, 2, 2, &mut [0; 64], &mut out);
            } else {
                block::<2>(&low, 2, 2, &mut [0; 64], &mut out);
            }
            let s = 8 / n;
            for y in 0..n {
                for x in 0..n {
                    let mean: f64 = (0..s * s)
                        .map(|i| f64::from(full[(y * s + i / s) * 8 + x * s + i % s]))
                        .sum::<f64>()
                        / (s * s) as f64;
                    let d = f64::from(out[y * n + x]) - mean;
                    assert!(
                        d.abs() <= 2.5,
                        "N = {n} at ({x}, {y}): {} vs {mean}",
                        out[y * n + x]
                    );
                }
            }
        }
        let mut dc = [0u8; 64];
        block::<1>(&c, 1, 1, &mut [0; 64], &mut dc);
        assert_eq!(dc[0], 128 + 25);
    }
}
