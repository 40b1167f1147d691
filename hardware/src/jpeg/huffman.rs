//! Huffman decoding of a scan's entropy-coded data: the bit reader (byte stuffing and
//! markers) and the code tables, with an 11-bit lookup that settles most codes, and most
//! whole AC coefficients (code, run and value), in one step.

use super::JpegError;

/// Bits looked up at once: 11 settle more of a high-quality frame's coefficients (code and
/// value bits together) than 9, for more than the larger tables, built per frame, cost
/// (`docs/service.md`).
const FAST_BITS: u32 = 11;
pub const FAST_SIZE: usize = 1 << FAST_BITS;

/// One Huffman table (DHT), as canonical codes of 1–16 bits.
#[derive(Debug, Clone)]
pub struct Huffman {
    /// By the next 11 bits: `length << 8 | symbol`, or 0 when the code is longer.
    fast: [u16; FAST_SIZE],
    /// AC tables, by the next 11 bits: a whole coefficient, `value << 8 | run << 4 |
    /// bits`, when its code and value bits fit in 11; else 0.
    fast_ac: Option<Box<[i32; FAST_SIZE]>>,
    /// For each length: the first 16-bit window past the codes of that length.
    limit: [u32; 17],
    /// For each length: index of its first symbol minus its first code.
    delta: [i32; 17],
    values: Vec<u8>,
}

impl Huffman {
    /// The table of `counts[l − 1]` codes of each length `l` for `values`, in order.
    pub fn new(counts: &[u8; 16], values: &[u8], ac: bool) -> Result<Huffman, JpegError> {
        let total: usize = counts.iter().map(|&c| usize::from(c)).sum();
        if total > 256 || values.len() < total {
            return Err(JpegError::Corrupt(
                "a Huffman table of too many codes".into(),
            ));
        }
        let mut t = Huffman {
            fast: [0; FAST_SIZE],
            fast_ac: None,
            limit: [0; 17],
            delta: [0; 17],
            values: values[..total].to_vec(),
        };
        let (mut code, mut k) = (0u32, 0usize);
        for len in 1..=16u32 {
            let count = u32::from(counts[len as usize - 1]);
            t.delta[len as usize] = k as i32 - code as i32;
            if code + count > 1 << len {
                return Err(JpegError::Corrupt(
                    "a Huffman table of overlapping codes".into(),
                ));
            }
            for _ in 0..count {
                if len <= FAST_BITS {
                    let first = (code << (FAST_BITS - len)) as usize;
                    let entry = (len << 8) as u16 | u16::from(t.values[k]);
                    t.fast[first..first + (1 << (FAST_BITS - len))].fill(entry);
                }
                code += 1;
                k += 1;
            }
            t.limit[len as usize] = code << (16 - len);
            code <<= 1;
        }
        if ac {
            t.fast_ac = Some(Box::new(t.whole_coefficients()));
        }
        Ok(t)
    }

    /// Whole AC coefficients by the next 11 bits (an AC table's only).
    pub fn ac_lookup(&self) -> Option<&[i32; FAST_SIZE]> {
        self.fast_ac.as_deref()
    }

    /// The AC lookup: for each 11 bits whose code and value bits both fit in them.
    fn whole_coefficients(&self) -> [i32; FAST_SIZE] {
        let mut table = [0; FAST_SIZE];
        for (bits, (slot, &e)) in table.iter_mut().zip(&self.fast).enumerate() {
            let (len, rs) = (u32::from(e >> 8), u32::from(e & 0xFF));
            let (run, size) = (rs >> 4, rs & 15);
            if e == 0 || size == 0 || len + size > FAST_BITS {
                continue;
            }
            let raw = (bits as u32 >> (FAST_BITS - len - size)) & ((1 << size) - 1);
            *slot = (extend(raw, size) << 8) | (run << 4) as i32 | (len + size) as i32;
        }
        table
    }
}

/// A value of `size` bits as JPEG codes it: the lower half of the range is negative.
#[inline(always)]
pub fn extend(raw: u32, size: u32) -> i32 {
    if size == 0 {
        0
    } else if raw < 1 << (size - 1) {
        raw as i32 - (1 << size) + 1
    } else {
        raw as i32
    }
}

/// The entropy-coded data of a scan, read a bit at a time from the most significant:
/// a stuffed 0xFF 0x00 is a 0xFF, and a marker (or the data's end) reads as zeros.
pub struct Bits<'a> {
    data: &'a [u8],
    pos: usize,
    /// Unread bits, most significant first.
    acc: u64,
    /// How many bits of `acc` are valid.
    n: u32,
    /// Zero bits appended past a marker or the end of the data.
    padded: u32,
    at_marker: bool,
}

impl<'a> Bits<'a> {
    /// Bits of `data` from `pos`.
    pub fn new(data: &'a [u8], pos: usize) -> Bits<'a> {
        Bits {
            data,
            pos,
            acc: 0,
            n: 0,
            padded: 0,
            at_marker: false,
        }
    }

    /// Fills the accumulator to at least 57 bits.
    fn refill(&mut self) {
        while self.n <= 56 {
            let byte = if self.at_marker {
                self.padded += 8;
                0
            } else {
                match (self.data.get(self.pos), self.data.get(self.pos + 1)) {
                    (Some(&0xFF), Some(&0)) => {
                        self.pos += 2;
                        0xFF
                    }
                    (Some(&0xFF), _) | (None, _) => {
                        self.at_marker = true;
                        self.padded += 8;
                        0
                    }
                    (Some(&b), _) => {
                        self.pos += 1;
                        b
                    }
                }
            };
            self.acc |= u64::from(byte) << (56 - self.n);
            self.n += 8;
        }
    }

    /// At least 32 bits ready: a code (≤ 16) and its value (≤ 16).
    #[inline(always)]
    fn ready(&mut self) {
        if self.n < 32 {
            self.refill();
        }
    }

    #[inline(always)]
    fn peek(&self, k: u32) -> u32 {
        (self.acc >> (64 - k)) as u32
    }

    #[inline(always)]
    fn consume(&mut self, k: u32) {
        self.acc <<= k;
        self.n -= k;
    }

    /// The next symbol of table `t`.
    #[inline(always)]
    pub fn symbol(&mut self, t: &Huffman) -> Result<u8, JpegError> {
        self.ready();
        let e = t.fast[self.peek(FAST_BITS) as usize];
        if e != 0 {
            self.consume(u32::from(e >> 8));
            return Ok(e as u8);
        }
        let window = self.peek(16);
        for len in FAST_BITS + 1..=16 {
            if window < t.limit[len as usize] {
                let i = (window >> (16 - len)) as i32 + t.delta[len as usize];
                self.consume(len);
                return t
                    .values
                    .get(i as usize)
                    .copied()
                    .ok_or_else(|| JpegError::Corrupt("a Huffman code out of its table".into()));
            }
        }
        Err(JpegError::Corrupt(
            "a bit pattern no Huffman code starts".into(),
        ))
    }

    /// A whole AC coefficient from the 9-bit lookup (`value << 8 | run << 4 | bits`, its
    /// bits consumed), or 0 when it needs the long way.
    #[inline(always)]
    pub fn fast_ac(&mut self, table: &[i32; FAST_SIZE]) -> i32 {
        self.ready();
        let e = table[self.peek(FAST_BITS) as usize];
        if e != 0 {
            self.consume((e & 15) as u32);
        }
        e
    }

    /// The `size`-bit value after a symbol, extended to its sign.
    #[inline(always)]
    pub fn value(&mut self, size: u32) -> i32 {
        if size == 0 {
            return 0;
        }
        let raw = self.peek(size);
        self.consume(size);
        extend(raw, size)
    }

    /// Whether bits were read past the data's end or a marker: a frame cut short.
    pub fn overran(&self) -> bool {
        self.padded > self.n
    }

    /// Skips to the restart marker that ends an interval, and past it; an error when the
    /// interval read past its data or the marker is not there.
    pub fn restart(&mut self) -> Result<(), JpegError> {
        if self.overran() {
            return Err(JpegError::Corrupt("a restart interval cut short".into()));
        }
        while self.data.get(self.pos) == Some(&0xFF) && self.data.get(self.pos + 1) == Some(&0xFF) {
            self.pos += 1;
        }
        match (self.data.get(self.pos), self.data.get(self.pos + 1)) {
            (Some(&0xFF), Some(0xD0..=0xD7)) => self.pos += 2,
            _ => return Err(JpegError::Corrupt("a restart marker missing".into())),
        }
        (self.acc, self.n, self.padded, self.at_marker) = (0, 0, 0, false);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_read_across_stuffed_bytes_and_stop_at_markers() {
        // Codes: "0" → 5, "10" → 6, "110" → 7.
        let t = Huffman::new(
            &[1, 1, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
            &[5, 6, 7],
            false,
        )
        .unwrap();
        // 0 10 110 0 | 11111111 (stuffed) | then a marker.
        let data = [0b0101_1001, 0xFF, 0x00, 0xFF, 0xD9];
        let mut b = Bits::new(&data, 0);
        let got: Vec<u8> = (0..4).map(|_| b.symbol(&t).unwrap()).collect();
        assert_eq!(got, [5, 6, 7, 5]);
        assert_eq!(b.value(8), 255);
        assert_eq!(b.value(1), 1);
        assert!(!b.overran());
        assert_eq!(b.symbol(&t).unwrap(), 5); // a zero past the marker
        assert!(b.overran());
    }

    #[test]
    fn values_extend_to_their_sign() {
        assert_eq!(extend(0, 1), -1);
        assert_eq!(extend(1, 1), 1);
        assert_eq!(extend(0b011, 3), -4);
        assert_eq!(extend(0b100, 3), 4);
        assert_eq!(extend(0, 0), 0);
    }

    #[test]
    fn overlapping_codes_are_refused() {
        let counts = [3, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0];
        assert!(Huffman::new(&counts, &[1, 2, 3], false).is_err());
    }
}
