//! CDR, the byte layout of ROS 2 messages (OMG XCDR1, little-endian), as far as the message
//! types of [`super::msgs`] need it.
//!
//! A message is a 4-byte encapsulation header (`00 01 00 00`: CDR, little-endian) and then
//! its fields in order, each primitive aligned to its own size counted from the end of the
//! header; a string is its length with the closing NUL as a `u32`, its bytes and the NUL; a
//! sequence is its length as a `u32` and its elements. Written by hand because it is this
//! small: a general CDR crate would bring a serde model of types we write once.

/// Builds one CDR message.
#[derive(Debug, Clone)]
pub struct CdrWriter {
    buf: Vec<u8>,
}

/// The encapsulation header: plain CDR, little-endian.
const HEADER: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

impl Default for CdrWriter {
    fn default() -> CdrWriter {
        CdrWriter::new()
    }
}

impl CdrWriter {
    /// An empty message (its header only).
    pub fn new() -> CdrWriter {
        CdrWriter {
            buf: HEADER.to_vec(),
        }
    }

    fn align(&mut self, n: usize) {
        while !(self.buf.len() - HEADER.len()).is_multiple_of(n) {
            self.buf.push(0);
        }
    }

    /// An `int32`.
    pub fn i32(&mut self, v: i32) -> &mut Self {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
        self
    }

    /// A `uint32`.
    pub fn u32(&mut self, v: u32) -> &mut Self {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
        self
    }

    /// A `uint8` (or `byte`).
    pub fn u8(&mut self, v: u8) -> &mut Self {
        self.buf.push(v);
        self
    }

    /// A `float64`.
    pub fn f64(&mut self, v: f64) -> &mut Self {
        self.align(8);
        self.buf.extend_from_slice(&v.to_le_bytes());
        self
    }

    /// A `string`.
    pub fn string(&mut self, s: &str) -> &mut Self {
        let len = u32::try_from(s.len() + 1).unwrap_or(u32::MAX);
        self.u32(len);
        self.buf.extend_from_slice(s.as_bytes());
        self.buf.push(0);
        self
    }

    /// A sequence's length (its elements follow).
    pub fn len(&mut self, n: usize) -> &mut Self {
        self.u32(u32::try_from(n).unwrap_or(u32::MAX))
    }

    /// A `uint8[]`.
    pub fn bytes(&mut self, b: &[u8]) -> &mut Self {
        self.len(b.len());
        self.buf.extend_from_slice(b);
        self
    }

    /// The message's bytes.
    pub fn finish(self) -> Vec<u8> {
        self.buf
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_are_aligned_from_the_end_of_the_header() {
        let mut w = CdrWriter::new();
        w.i32(-1).string("ab").f64(1.5).u8(7).u32(9);
        let b = w.finish();
        assert_eq!(&b[..4], &HEADER);
        assert_eq!(&b[4..8], &(-1i32).to_le_bytes());
        assert_eq!(&b[8..12], &3u32.to_le_bytes());
        assert_eq!(&b[12..15], b"ab\0");
        // 11 bytes after the header: padded to 16 for the float64.
        assert_eq!(&b[15..20], &[0; 5]);
        assert_eq!(&b[20..28], &1.5f64.to_le_bytes());
        assert_eq!(b[28], 7);
        assert_eq!(&b[29..32], &[0; 3]);
        assert_eq!(&b[32..36], &9u32.to_le_bytes());
    }
}
