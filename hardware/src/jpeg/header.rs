//! The markers before a JPEG's first scan: quantisation and Huffman tables, the frame
//! header, the restart interval and the scan header. Anything a UVC camera does not send
//! (progressive or arithmetic coding, 12-bit samples, several scans, odd sampling
//! factors) is [`JpegError::Unsupported`], for a general decoder to take.

use super::huffman::Huffman;
use super::JpegError;

/// One colour component of the frame: its sampling factors and tables.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Component {
    /// Horizontal sampling factor (1 or 2).
    pub h: usize,
    /// Vertical sampling factor (1 or 2).
    pub v: usize,
    /// Quantisation table, zig-zag order.
    pub quant: [u16; 64],
    /// DC Huffman table index.
    pub dc: usize,
    /// AC Huffman table index.
    pub ac: usize,
}

/// What the first scan needs: the frame's size and components, the Huffman tables, the
/// restart interval and where the entropy-coded data begins.
#[derive(Debug, Clone)]
pub struct Header {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// One (grey) or three (Y, Cb, Cr) components, in the scan's order.
    pub components: Vec<Component>,
    /// DC tables by index.
    pub dc: [Option<Huffman>; 4],
    /// AC tables by index.
    pub ac: [Option<Huffman>; 4],
    /// MCUs between restart markers (0: none).
    pub restart_interval: usize,
    /// Offset of the first byte of entropy-coded data.
    pub scan_start: usize,
}

const SOI: u8 = 0xD8;
const SOF0: u8 = 0xC0;
const SOF1: u8 = 0xC1;
const DHT: u8 = 0xC4;
const DQT: u8 = 0xDB;
const DRI: u8 = 0xDD;
const SOS: u8 = 0xDA;
const EOI: u8 = 0xD9;

/// A frame header's component before the scan names its tables.
#[derive(Clone, Copy)]
struct FrameComponent {
    id: u8,
    h: usize,
    v: usize,
    tq: usize,
}

fn corrupt(what: &str) -> JpegError {
    JpegError::Corrupt(what.to_string())
}

/// Reads the markers of `data` up to and including the first scan header.
pub fn parse(data: &[u8]) -> Result<Header, JpegError> {
    if data.len() < 4 || data[0] != 0xFF || data[1] != SOI {
        return Err(corrupt("no start-of-image marker"));
    }
    let mut quant: [Option<[u16; 64]>; 4] = [None; 4];
    let mut dc: [Option<Huffman>; 4] = Default::default();
    let mut ac: [Option<Huffman>; 4] = Default::default();
    let mut frame: Option<(u32, u32, Vec<FrameComponent>)> = None;
    let mut restart_interval = 0;
    let mut i = 2;
    loop {
        // Markers may be preceded by fill bytes (0xFF).
        while data.get(i) == Some(&0xFF) && data.get(i + 1) == Some(&0xFF) {
            i += 1;
        }
        let (Some(&0xFF), Some(&marker)) = (data.get(i), data.get(i + 1)) else {
            return Err(corrupt("a marker expected before the first scan"));
        };
        if marker == EOI {
            return Err(corrupt("end of image before any scan"));
        }
        let len = data
            .get(i + 2..i + 4)
            .map(|b| usize::from(u16::from_be_bytes([b[0], b[1]])))
            .ok_or_else(|| corrupt("a segment cut short"))?;
        let body = data
            .get(i + 4..i + 2 + len)
            .filter(|_| len >= 2)
            .ok_or_else(|| corrupt("a segment longer than the frame"))?;
        match marker {
            DQT => read_dqt(body, &mut quant)?,
            DHT => read_dht(body, &mut dc, &mut ac)?,
            SOF0 | SOF1 => frame = Some(read_sof(body)?),
            0xC2 | 0xC3 | 0xC5..=0xC7 | 0xC9..=0xCB | 0xCD..=0xCF => {
                return Err(JpegError::Unsupported(
                    "not baseline or extended sequential Huffman coding".into(),
                ))
            }
            DRI => {
                let b = body.get(..2).ok_or_else(|| corrupt("short DRI segment"))?;
                restart_interval = usize::from(u16::from_be_bytes([b[0], b[1]]));
            }
            SOS => {
                let (width, height, fc) =
                    frame.ok_or_else(|| corrupt("scan before frame header"))?;
                let components = read_sos(body, &fc, &quant)?;
                standard_tables_where_missing(&components, &mut dc, &mut ac);
                for c in &components {
                    if dc[c.dc].is_none() || ac[c.ac].is_none() {
                        return Err(corrupt("a scan names a Huffman table never defined"));
                    }
                }
                return Ok(Header {
                    width,
                    height,
                    components,
                    dc,
                    ac,
                    restart_interval,
                    scan_start: i + 2 + len,
                });
            }
            _ => {} // APPn, COM and the like: nothing the pixels need.
        }
        i += 2 + len;
    }
}

fn read_dqt(mut body: &[u8], quant: &mut [Option<[u16; 64]>; 4]) -> Result<(), JpegError> {
    while let Some((&pq_tq, rest)) = body.split_first() {
        let (sixteen, tq) = (pq_tq >> 4, usize::from(pq_tq & 15));
        let n = if sixteen == 1 { 128 } else { 64 };
        if sixteen > 1 || tq > 3 || rest.len() < n {
            return Err(corrupt("bad DQT segment"));
        }
        let mut table = [0u16; 64];
        for (k, q) in table.iter_mut().enumerate() {
            *q = if sixteen == 1 {
                u16::from_be_bytes([rest[2 * k], rest[2 * k + 1]])
            } else {
                u16::from(rest[k])
            };
        }
        quant[tq] = Some(table);
        body = &rest[n..];
    }
    Ok(())
}

fn read_dht(
    mut body: &[u8],
    dc: &mut [Option<Huffman>; 4],
    ac: &mut [Option<Huffman>; 4],
) -> Result<(), JpegError> {
    while body.len() >= 17 {
        let (class, th) = (body[0] >> 4, usize::from(body[0] & 15));
        let counts: [u8; 16] = body[1..17].try_into().unwrap_or([0; 16]);
        let n: usize = counts.iter().map(|&c| usize::from(c)).sum();
        let values = body
            .get(17..17 + n)
            .ok_or_else(|| corrupt("DHT segment cut short"))?;
        if class > 1 || th > 3 {
            return Err(corrupt("bad DHT table class or index"));
        }
        let table = Huffman::new(&counts, values, class == 1)?;
        if class == 0 {
            dc[th] = Some(table);
        } else {
            ac[th] = Some(table);
        }
        body = &body[17 + n..];
    }
    if body.is_empty() {
        Ok(())
    } else {
        Err(corrupt("DHT segment cut short"))
    }
}

fn read_sof(body: &[u8]) -> Result<(u32, u32, Vec<FrameComponent>), JpegError> {
    if body.len() < 6 {
        return Err(corrupt("short frame header"));
    }
    if body[0] != 8 {
        return Err(JpegError::Unsupported(format!("{}-bit samples", body[0])));
    }
    let height = u32::from(u16::from_be_bytes([body[1], body[2]]));
    let width = u32::from(u16::from_be_bytes([body[3], body[4]]));
    let n = usize::from(body[5]);
    if height == 0 || width == 0 {
        return Err(JpegError::Unsupported(
            "a height given after the scan".into(),
        ));
    }
    if n != 1 && n != 3 {
        return Err(JpegError::Unsupported(format!("{n} components")));
    }
    let spec = body
        .get(6..6 + 3 * n)
        .ok_or_else(|| corrupt("short frame header"))?;
    let components: Vec<FrameComponent> = spec
        .chunks_exact(3)
        .map(|c| FrameComponent {
            id: c[0],
            h: usize::from(c[1] >> 4),
            v: usize::from(c[1] & 15),
            tq: usize::from(c[2]),
        })
        .collect();
    for c in &components {
        if !(1..=4).contains(&c.h) || !(1..=4).contains(&c.v) || c.tq > 3 {
            return Err(corrupt("bad sampling factor or table index"));
        }
    }
    let (hmax, vmax) = max_sampling(components.iter().map(|c| (c.h, c.v)));
    // Each component at the full size or half of it, each way: 4:4:4, 4:2:2, 4:2:0, grey.
    let halves = |f: usize, max: usize| f == max || 2 * f == max;
    if n == 1 {
        // A lone component's scan is not interleaved: one block per MCU.
        return Ok((
            width,
            height,
            vec![FrameComponent {
                h: 1,
                v: 1,
                ..components[0]
            }],
        ));
    }
    if hmax > 2
        || vmax > 2
        || !components
            .iter()
            .all(|c| halves(c.h, hmax) && halves(c.v, vmax))
    {
        return Err(JpegError::Unsupported(
            "sampling factors other than 1 and 2".into(),
        ));
    }
    Ok((width, height, components))
}

/// The largest horizontal and vertical sampling factors of `(h, v)` pairs: the MCU's
/// size in blocks.
pub fn max_sampling(factors: impl Iterator<Item = (usize, usize)>) -> (usize, usize) {
    factors.fold((1, 1), |(hm, vm), (h, v)| (hm.max(h), vm.max(v)))
}

fn read_sos(
    body: &[u8],
    frame: &[FrameComponent],
    quant: &[Option<[u16; 64]>; 4],
) -> Result<Vec<Component>, JpegError> {
    let n = usize::from(*body.first().ok_or_else(|| corrupt("short scan header"))?);
    let spec = body
        .get(1..1 + 2 * n + 3)
        .ok_or_else(|| corrupt("short scan header"))?;
    if n != frame.len() {
        return Err(JpegError::Unsupported(
            "components in separate scans".into(),
        ));
    }
    let (ss, se, a) = (spec[2 * n], spec[2 * n + 1], spec[2 * n + 2]);
    if ss != 0 || se != 63 || a != 0 {
        return Err(JpegError::Unsupported(
            "a spectral or successive scan".into(),
        ));
    }
    spec[..2 * n]
        .chunks_exact(2)
        .zip(frame)
        .map(|(s, f)| {
            if s[0] != f.id {
                return Err(JpegError::Unsupported(
                    "a scan in another component order".into(),
                ));
            }
            let quant = quant[f.tq].ok_or_else(|| corrupt("a quantisation table never defined"))?;
            let (dc, ac) = (usize::from(s[1] >> 4), usize::from(s[1] & 15));
            if dc > 3 || ac > 3 {
                return Err(corrupt("bad Huffman table index"));
            }
            Ok(Component {
                h: f.h,
                v: f.v,
                quant,
                dc,
                ac,
            })
        })
        .collect()
}

/// A UVC camera's MJPEG frame leaves out its Huffman tables: the standard ones of the
/// JPEG standard's Annex K (K.3) are implied, the luminance tables at index 0 and the
/// chrominance tables at index 1.
fn standard_tables_where_missing(
    components: &[Component],
    dc: &mut [Option<Huffman>; 4],
    ac: &mut [Option<Huffman>; 4],
) {
    for c in components {
        implied(&mut dc[c.dc], c.dc, [STD_DC_LUMA, STD_DC_CHROMA], false);
        implied(&mut ac[c.ac], c.ac, [STD_AC_LUMA, STD_AC_CHROMA], true);
    }
}

/// The standard table of index `index` (0: luminance, 1: chrominance) in an empty slot.
fn implied(slot: &mut Option<Huffman>, index: usize, standard: [Table; 2], ac: bool) {
    if let (None, Some(&(counts, values))) = (&slot, standard.get(index)) {
        *slot = Huffman::new(counts, values, ac).ok();
    }
}

type Table = (&'static [u8; 16], &'static [u8]);

const STD_DC_LUMA: Table = (
    &[0, 1, 5, 1, 1, 1, 1, 1, 1, 0, 0, 0, 0, 0, 0, 0],
    &[0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11],
);
const STD_DC_CHROMA: Table = (
    &[0, 3, 1, 1, 1, 1, 1, 1, 1, 1, 1, 0, 0, 0, 0, 0],
    &[0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11],
);
const STD_AC_LUMA: Table = (
    &[0, 2, 1, 3, 3, 2, 4, 3, 5, 5, 4, 4, 0, 0, 1, 0x7d],
    &[
        0x01, 0x02, 0x03, 0x00, 0x04, 0x11, 0x05, 0x12, 0x21, 0x31, 0x41, 0x06, 0x13, 0x51, 0x61,
        0x07, 0x22, 0x71, 0x14, 0x32, 0x81, 0x91, 0xa1, 0x08, 0x23, 0x42, 0xb1, 0xc1, 0x15, 0x52,
        0xd1, 0xf0, 0x24, 0x33, 0x62, 0x72, 0x82, 0x09, 0x0a, 0x16, 0x17, 0x18, 0x19, 0x1a, 0x25,
        0x26, 0x27, 0x28, 0x29, 0x2a, 0x34, 0x35, 0x36, 0x37, 0x38, 0x39, 0x3a, 0x43, 0x44, 0x45,
        0x46, 0x47, 0x48, 0x49, 0x4a, 0x53, 0x54, 0x55, 0x56, 0x57, 0x58, 0x59, 0x5a, 0x63, 0x64,
        0x65, 0x66, 0x67, 0x68, 0x69, 0x6a, 0x73, 0x74, 0x75, 0x76, 0x77, 0x78, 0x79, 0x7a, 0x83,
        0x84, 0x85, 0x86, 0x87, 0x88, 0x89, 0x8a, 0x92, 0x93, 0x94, 0x95, 0x96, 0x97, 0x98, 0x99,
        0x9a, 0xa2, 0xa3, 0xa4, 0xa5, 0xa6, 0xa7, 0xa8, 0xa9, 0xaa, 0xb2, 0xb3, 0xb4, 0xb5, 0xb6,
        0xb7, 0xb8, 0xb9, 0xba, 0xc2, 0xc3, 0xc4, 0xc5, 0xc6, 0xc7, 0xc8, 0xc9, 0xca, 0xd2, 0xd3,
        0xd4, 0xd5, 0xd6, 0xd7, 0xd8, 0xd9, 0xda, 0xe1, 0xe2, 0xe3, 0xe4, 0xe5, 0xe6, 0xe7, 0xe8,
        0xe9, 0xea, 0xf1, 0xf2, 0xf3, 0xf4, 0xf5, 0xf6, 0xf7, 0xf8, 0xf9, 0xfa,
    ],
);
const STD_AC_CHROMA: Table = (
    &[0, 2, 1, 2, 4, 4, 3, 4, 7, 5, 4, 4, 0, 1, 2, 0x77],
    &[
        0x00, 0x01, 0x02, 0x03, 0x11, 0x04, 0x05, 0x21, 0x31, 0x06, 0x12, 0x41, 0x51, 0x07, 0x61,
        0x71, 0x13, 0x22, 0x32, 0x81, 0x08, 0x14, 0x42, 0x91, 0xa1, 0xb1, 0xc1, 0x09, 0x23, 0x33,
        0x52, 0xf0, 0x15, 0x62, 0x72, 0xd1, 0x0a, 0x16, 0x24, 0x34, 0xe1, 0x25, 0xf1, 0x17, 0x18,
        0x19, 0x1a, 0x26, 0x27, 0x28, 0x29, 0x2a, 0x35, 0x36, 0x37, 0x38, 0x39, 0x3a, 0x43, 0x44,
        0x45, 0x46, 0x47, 0x48, 0x49, 0x4a, 0x53, 0x54, 0x55, 0x56, 0x57, 0x58, 0x59, 0x5a, 0x63,
        0x64, 0x65, 0x66, 0x67, 0x68, 0x69, 0x6a, 0x73, 0x74, 0x75, 0x76, 0x77, 0x78, 0x79, 0x7a,
        0x82, 0x83, 0x84, 0x85, 0x86, 0x87, 0x88, 0x89, 0x8a, 0x92, 0x93, 0x94, 0x95, 0x96, 0x97,
        0x98, 0x99, 0x9a, 0xa2, 0xa3, 0xa4, 0xa5, 0xa6, 0xa7, 0xa8, 0xa9, 0xaa, 0xb2, 0xb3, 0xb4,
        0xb5, 0xb6, 0xb7, 0xb8, 0xb9, 0xba, 0xc2, 0xc3, 0xc4, 0xc5, 0xc6, 0xc7, 0xc8, 0xc9, 0xca,
        0xd2, 0xd3, 0xd4, 0xd5, 0xd6, 0xd7, 0xd8, 0xd9, 0xda, 0xe2, 0xe3, 0xe4, 0xe5, 0xe6, 0xe7,
        0xe8, 0xe9, 0xea, 0xf2, 0xf3, 0xf4, 0xf5, 0xf6, 0xf7, 0xf8, 0xf9, 0xfa,
    ],
);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_standard_tables_hold_every_symbol_of_their_class() {
        for (counts, values) in [STD_DC_LUMA, STD_DC_CHROMA, STD_AC_LUMA, STD_AC_CHROMA] {
            let n: usize = counts.iter().map(|&c| usize::from(c)).sum();
            assert_eq!(n, values.len());
        }
        assert_eq!(STD_AC_LUMA.1.len(), 162);
        assert_eq!(STD_AC_CHROMA.1.len(), 162);
    }
}
