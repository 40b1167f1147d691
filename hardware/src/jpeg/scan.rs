//! A scan's MCUs, block by block: each block's coefficients Huffman-decoded (those the
//! reduced transform does not read are skipped past, never stored), transformed at the
//! output's scale, and written into the output's Y, Cb or Cr byte of each pixel it covers
//! (a subsampled chroma block covers two or four).

use super::header::{max_sampling, Component, Header};
use super::huffman::{Bits, Huffman, FAST_SIZE};
use super::idct::{self, COEF_LIMIT};
use super::JpegError;

/// Natural (row-major) index of each coefficient in zig-zag order.
const ZIGZAG: [u8; 64] = [
    0, 1, 8, 16, 9, 2, 3, 10, 17, 24, 32, 25, 18, 11, 4, 5, 12, 19, 26, 33, 40, 48, 41, 34, 27, 20,
    13, 6, 7, 14, 21, 28, 35, 42, 49, 56, 57, 50, 43, 36, 29, 22, 15, 23, 30, 37, 44, 51, 58, 59,
    52, 45, 38, 31, 39, 46, 53, 60, 61, 54, 47, 55, 62, 63,
];

/// Not read by the reduced transform.
const SKIP: u8 = u8::MAX;

/// One component's decoding: its tables and where its coefficients and pixels go.
struct Plan<'h> {
    c: &'h Component,
    dc: &'h Huffman,
    ac: &'h Huffman,
    ac_lookup: &'h [i32; FAST_SIZE],
    /// For each zig-zag index: the coefficient's place in the `N × N` block, or [`SKIP`].
    dest: [u8; 64],
    /// For each zig-zag index: its row's bit and (8 bits up) its column's, for the mask
    /// of rows and columns a block's coefficients occupy.
    occupies: [u16; 64],
    /// Output pixels per block sample each way, as a shift (0: 1, 1: 2).
    h_shift: usize,
    v_shift: usize,
}

/// Where the output goes: `width × height` pixels of three bytes.
struct Target<'o> {
    out: &'o mut [u8],
    width: usize,
    height: usize,
}

/// Decodes `header`'s scan of `data` at `N/8` of its size into `out` (three bytes per
/// pixel, Y, Cb, Cr; a grey frame's chroma is 128).
pub fn decode<const N: usize>(
    header: &Header,
    data: &[u8],
    out: &mut [u8],
) -> Result<(), JpegError> {
    let (w, h) = (
        header.width as usize * N / 8,
        header.height as usize * N / 8,
    );
    if out.len() != w * h * 3 {
        return Err(JpegError::Corrupt(
            "an output buffer of another size".into(),
        ));
    }
    let (hmax, vmax) = max_sampling(header.components.iter().map(|c| (c.h, c.v)));
    let plans = header
        .components
        .iter()
        .map(|c| plan::<N>(header, c, hmax, vmax))
        .collect::<Result<Vec<_>, _>>()?;
    if plans.len() == 1 {
        for p in out.chunks_exact_mut(3) {
            (p[1], p[2]) = (128, 128);
        }
    }
    let mut target = Target {
        out,
        width: w,
        height: h,
    };
    let (full_w, full_h) = (header.width as usize, header.height as usize);
    let (mcus_x, mcus_y) = (full_w.div_ceil(8 * hmax), full_h.div_ceil(8 * vmax));
    let mut bits = Bits::new(data, header.scan_start);
    let mut pred = [0i32; 3];
    let (mut coef, mut px, mut scratch) = ([0i32; 64], [0u8; 64], [0i32; 64]);
    for m in 0..mcus_x * mcus_y {
        if header.restart_interval > 0 && m > 0 && m % header.restart_interval == 0 {
            bits.restart()?;
            pred = [0; 3];
        }
        let (mx, my) = (m % mcus_x, m / mcus_x);
        for (ci, p) in plans.iter().enumerate() {
            for by in 0..p.c.v {
                for bx in 0..p.c.h {
                    let (rows, cols) = block::<N>(&mut bits, p, &mut pred[ci], &mut coef)?;
                    idct::block::<N>(&coef, rows, cols, &mut scratch, &mut px);
                    let x0 = ((mx * p.c.h + bx) * N) << p.h_shift;
                    let y0 = ((my * p.c.v + by) * N) << p.v_shift;
                    target.put::<N>(ci, x0, y0, p, &px);
                }
            }
        }
    }
    if bits.overran() {
        return Err(JpegError::Corrupt(
            "the entropy-coded data ends early".into(),
        ));
    }
    Ok(())
}

fn plan<'h, const N: usize>(
    header: &'h Header,
    c: &'h Component,
    hmax: usize,
    vmax: usize,
) -> Result<Plan<'h>, JpegError> {
    let missing = || JpegError::Corrupt("a Huffman table never defined".into());
    let dc = header.dc[c.dc].as_ref().ok_or_else(missing)?;
    let ac = header.ac[c.ac].as_ref().ok_or_else(missing)?;
    let (mut dest, mut occupies) = ([SKIP; 64], [0; 64]);
    for k in 0..64 {
        let nat = usize::from(ZIGZAG[k]);
        let (row, col) = (nat / 8, nat % 8);
        if row < N && col < N {
            dest[k] = (row * N + col) as u8;
            occupies[k] = (1 << row) | (1 << (8 + col));
        }
    }
    Ok(Plan {
        c,
        dc,
        ac,
        ac_lookup: ac.ac_lookup().ok_or_else(missing)?,
        dest,
        occupies,
        h_shift: usize::from(c.h < hmax),
        v_shift: usize::from(c.v < vmax),
    })
}

/// One block's coefficients into `coef` (natural order in `N × N`, dequantised); returns
/// how many rows and columns of it may be non-zero.
#[inline(always)]
fn block<const N: usize>(
    bits: &mut Bits<'_>,
    p: &Plan<'_>,
    pred: &mut i32,
    coef: &mut [i32; 64],
) -> Result<(usize, usize), JpegError> {
    coef[..N * N].fill(0);
    let size = u32::from(bits.symbol(p.dc)?);
    if size > 15 {
        return Err(JpegError::Corrupt(
            "a DC difference of more than 15 bits".into(),
        ));
    }
    *pred = pred.wrapping_add(bits.value(size));
    let q = &p.c.quant;
    coef[0] = dequantise(*pred, q[0]);
    let mut mask = 0x0101u16;
    let mut k = 1;
    while k < 64 {
        let e = bits.fast_ac(p.ac_lookup);
        let (run, v) = if e != 0 {
            (((e >> 4) & 15) as usize, e >> 8)
        } else {
            let rs = bits.symbol(p.ac)?;
            let (run, size) = (usize::from(rs >> 4), u32::from(rs & 15));
            if size == 0 {
                if run != 15 {
                    break; // end of block
                }
                k += 16;
                continue;
            }
            (run, bits.value(size))
        };
        k += run;
        if k > 63 {
            return Err(JpegError::Corrupt(
                "a block of more than 64 coefficients".into(),
            ));
        }
        let d = p.dest[k];
        if d != SKIP {
            coef[usize::from(d)] = dequantise(v, q[k]);
            mask |= p.occupies[k];
        }
        k += 1;
    }
    let rows = 8 - (mask as u8).leading_zeros() as usize;
    let cols = 8 - ((mask >> 8) as u8).leading_zeros() as usize;
    Ok((rows, cols))
}

#[inline(always)]
fn dequantise(v: i32, q: u16) -> i32 {
    v.saturating_mul(i32::from(q))
        .clamp(-COEF_LIMIT, COEF_LIMIT)
}

impl Target<'_> {
    /// Writes a block's `N × N` samples of component `ci` at output pixel `(x0, y0)`, each
    /// over `2^shift` pixels each way, clipped to the image.
    #[inline(always)]
    fn put<const N: usize>(
        &mut self,
        ci: usize,
        x0: usize,
        y0: usize,
        p: &Plan<'_>,
        px: &[u8; 64],
    ) {
        // One loop per channel and spread, so the byte offsets are constants.
        match (ci, p.h_shift) {
            (0, 0) => self.put_with::<N, 0, 0>(x0, y0, p.v_shift, px),
            (1, 0) => self.put_with::<N, 1, 0>(x0, y0, p.v_shift, px),
            (2, 0) => self.put_with::<N, 2, 0>(x0, y0, p.v_shift, px),
            (0, _) => self.put_with::<N, 0, 1>(x0, y0, p.v_shift, px),
            (1, _) => self.put_with::<N, 1, 1>(x0, y0, p.v_shift, px),
            _ => self.put_with::<N, 2, 1>(x0, y0, p.v_shift, px),
        }
    }

    #[inline(always)]
    fn put_with<const N: usize, const C: usize, const HS: usize>(
        &mut self,
        x0: usize,
        y0: usize,
        v_shift: usize,
        px: &[u8; 64],
    ) {
        let x_end = (x0 + (N << HS)).min(self.width);
        let y_end = (y0 + (N << v_shift)).min(self.height);
        for y in y0..y_end {
            let src = &px[((y - y0) >> v_shift) * N..][..N];
            let row = &mut self.out[(y * self.width + x0) * 3..(y * self.width + x_end) * 3];
            if HS == 0 {
                let px = row.as_chunks_mut::<3>().0;
                if let Ok(whole) = <&mut [[u8; 3]; N]>::try_from(&mut *px) {
                    // A block inside the image: a fixed loop the compiler unrolls.
                    for (o, &v) in whole.iter_mut().zip(src) {
                        o[C] = v;
                    }
                } else {
                    for (o, &v) in px.iter_mut().zip(src) {
                        o[C] = v;
                    }
                }
            } else {
                let (pairs, rest) = row.as_chunks_mut::<6>();
                for (o, &v) in pairs.iter_mut().zip(src) {
                    (o[C], o[C + 3]) = (v, v);
                }
                // An odd width's last pixel.
                if let (Some(o), Some(&v)) = (rest.get_mut(C), src.get(pairs.len())) {
                    *o = v;
                }
            }
        }
    }
}
