//! YUYV (V4L2 `YUYV`: Y0 U Y1 V per two pixels, BT.601 limited range) to three bytes per
//! pixel, Y, U, V, at `1/s` of the camera's size.
//!
//! At full size every pixel is a byte shuffle: Y its own, U and V its pair's. The compiler
//! vectorises neither this 4-to-6-byte shuffle nor any loop written around it (a shuffle
//! through planes, per pixel or per word was tried), and at 640 × 480 it is the largest part
//! of reading a YUYV frame. On aarch64 it is therefore written with NEON's structure loads
//! and stores (`ld4`, `zip`, `st3`): 16 pairs a step, a few instructions each; elsewhere a
//! plain loop does it. A test holds both to the per-pixel definition.

/// YUYV of `w` columns to Y, U, V per pixel at `1/s` (`s` 1 or even), appended to `out`.
pub(crate) fn yuyv(data: &[u8], w: usize, s: usize, out: &mut Vec<u8>) {
    let h = data.len() / (2 * w).max(1);
    let (ow, oh) = (w / s, h / s);
    if s == 1 {
        let start = out.len();
        out.resize(start + ow * oh * 3, 0);
        unpack(&data[..ow * oh * 2], &mut out[start..]);
    } else {
        block_means(data, w, s, out);
    }
}

/// Full size: each pair of `data` to two pixels of `out` (`out` 1.5 times as long).
fn unpack(data: &[u8], out: &mut [u8]) {
    #[cfg(target_arch = "aarch64")]
    let (data, out) = neon::unpack_steps(data, out);
    unpack_pairs(data, out);
}

/// The plain loop: one pair to two pixels.
fn unpack_pairs(data: &[u8], out: &mut [u8]) {
    for (o, q) in out
        .as_chunks_mut::<6>()
        .0
        .iter_mut()
        .zip(data.as_chunks::<4>().0)
    {
        *o = [q[0], q[1], q[3], q[2], q[1], q[3]];
    }
}

#[cfg(target_arch = "aarch64")]
mod neon {
    use core::arch::aarch64::{uint8x16x3_t, vld4q_u8, vst3q_u8, vzipq_u8};

    /// Pairs per step.
    const PAIRS: usize = 16;

    /// Unpacks whole steps of [`PAIRS`] pairs; returns what is left of both slices.
    pub(super) fn unpack_steps<'a, 'b>(
        data: &'a [u8],
        out: &'b mut [u8],
    ) -> (&'a [u8], &'b mut [u8]) {
        let steps = (data.len() / (4 * PAIRS)).min(out.len() / (6 * PAIRS));
        let (data, data_rest) = data.split_at(steps * 4 * PAIRS);
        let (out, out_rest) = out.split_at_mut(steps * 6 * PAIRS);
        for (o, q) in out
            .as_chunks_mut::<{ 6 * PAIRS }>()
            .0
            .iter_mut()
            .zip(data.as_chunks::<{ 4 * PAIRS }>().0)
        {
            step(q, o);
        }
        (data_rest, out_rest)
    }

    /// 16 pairs to 32 pixels. The workspace denies `unsafe` code; this is its one
    /// exception: NEON's loads and stores take pointers.
    #[allow(unsafe_code)]
    fn step(q: &[u8; 4 * PAIRS], o: &mut [u8; 6 * PAIRS]) {
        // SAFETY: NEON is part of every aarch64 target. `vld4q_u8` reads 64 bytes from `q`,
        // which holds 64; each `vst3q_u8` writes 48 bytes, at offsets 0 and 48 of `o`,
        // which holds 96.
        unsafe {
            let p = vld4q_u8(q.as_ptr());
            let (y, u, v) = (vzipq_u8(p.0, p.2), vzipq_u8(p.1, p.1), vzipq_u8(p.3, p.3));
            vst3q_u8(o.as_mut_ptr(), uint8x16x3_t(y.0, u.0, v.0));
            vst3q_u8(o.as_mut_ptr().add(48), uint8x16x3_t(y.1, u.1, v.1));
        }
    }
}

/// At `s` ≥ 2 (even): each output pixel the mean of its `s × s` block; a block holds
/// `s/2` pairs per row, each with its own chroma, so chroma is averaged over the same block.
fn block_means(data: &[u8], w: usize, s: usize, out: &mut Vec<u8>) {
    let h = data.len() / (2 * w).max(1);
    let (ow, oh) = (w / s, h / s);
    out.reserve(ow * oh * 3);
    let (n_y, n_c) = ((s * s) as u32, (s * s / 2) as u32);
    let mut sum = vec![[0u32; 3]; ow];
    for oy in 0..oh {
        sum.fill([0; 3]);
        for y in oy * s..(oy + 1) * s {
            let line = &data[y * w * 2..(y * w + ow * s) * 2];
            for (k, q) in line.as_chunks::<4>().0.iter().enumerate() {
                let b = &mut sum[2 * k / s];
                b[0] += u32::from(q[0]) + u32::from(q[2]);
                b[1] += u32::from(q[1]);
                b[2] += u32::from(q[3]);
            }
        }
        out.extend(sum.iter().flat_map(|b| {
            [
                ((b[0] + n_y / 2) / n_y) as u8,
                ((b[1] + n_c / 2) / n_c) as u8,
                ((b[2] + n_c / 2) / n_c) as u8,
            ]
        }));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_pixel_gets_its_own_y_and_its_pairs_u_and_v() {
        // Lengths around the vector step, so both the steps and the rest are read.
        for pairs in [0usize, 1, 15, 16, 17, 33, 320] {
            let data: Vec<u8> = (0..4 * pairs).map(|i| (i * 37 % 251) as u8).collect();
            let mut out = vec![7u8];
            yuyv(&data, 2 * pairs.max(1), 1, &mut out);
            if pairs == 0 {
                assert_eq!(out, [7]);
                continue;
            }
            assert_eq!(out.len(), 1 + 6 * pairs, "{pairs} pairs");
            for (x, p) in out[1..].as_chunks::<3>().0.iter().enumerate() {
                let q = &data[4 * (x / 2)..][..4];
                assert_eq!(
                    *p,
                    [q[2 * (x % 2)], q[1], q[3]],
                    "pixel {x} of {pairs} pairs"
                );
            }
        }
    }
}
