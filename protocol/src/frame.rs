//! Framing: every message travels as `0x00 · COBS(postcard(msg) · CRC-32) · 0x00`.
//!
//! * **postcard** gives a compact, non-self-describing encoding (varints, no field names).
//! * **CRC-32** (ISO-HDLC, the Ethernet/zlib polynomial, little-endian on the wire) rejects
//!   corrupted frames. A 16-bit CRC would save two bytes, but a noisy line that produces
//!   thousands of garbage fragments would, with odds of 1 in 65 536 each, eventually let
//!   one through; with 32 bits the odds are 1 in 4·10⁹ per fragment *and* the fragment must
//!   still decode as a valid message.
//! * **COBS** removes every `0x00` from the body, so `0x00` delimits frames. The encoder
//!   writes a delimiter *before* and *after* each frame: garbage that reaches the line
//!   between two frames is then always cut off from the next frame instead of corrupting it.
//!   Two delimiters in a row are an empty frame, which the decoder skips without counting.
//!
//! The [`Decoder`] takes bytes in any chunking, never allocates, never panics, and counts
//! every frame it drops, by reason ([`DropCounts`]).

use core::marker::PhantomData;

use crc::{Crc, CRC_32_ISO_HDLC};
use postcard::experimental::max_size::MaxSize;
use postcard::ser_flavors::{crc::CrcModifier, Cobs, Slice};
use serde::{de::DeserializeOwned, Serialize};

use crate::msg::{DeviceMsg, HostMsg};
use crate::schema;

/// The frame checksum: CRC-32/ISO-HDLC.
pub const CRC32: Crc<u32> = Crc::<u32>::new(&CRC_32_ISO_HDLC);

/// Bytes of checksum at the end of every decoded frame body.
pub const CRC_LEN: usize = 4;

/// Largest framed size, in bytes on the wire, of a message whose postcard encoding is at
/// most `payload_max` bytes: two delimiters plus the COBS encoding of payload and CRC.
///
/// The COBS bound is the streaming encoder's, one byte above `cobs::max_encoding_length`
/// when the data is a whole number of 254-byte runs without a zero: postcard's encoder
/// closes each full run with a code byte and then writes one more for the empty run after
/// it. (A decoder reads the frame the same with or without that last byte.)
pub const fn frame_len_max(payload_max: usize) -> usize {
    let data = payload_max + CRC_LEN;
    data + data / 254 + 1 + 2
}

/// Largest framed [`DeviceMsg`], bytes (a full [`crate::Map`] tile).
pub const DEVICE_FRAME_MAX: usize = frame_len_max(DeviceMsg::POSTCARD_MAX_SIZE);

/// Largest framed [`HostMsg`], bytes.
pub const HOST_FRAME_MAX: usize = frame_len_max(HostMsg::POSTCARD_MAX_SIZE);

/// Largest framed [`crate::Summary`] message, bytes (worst case: every varint at its widest).
pub const SUMMARY_FRAME_MAX: usize =
    frame_len_max(1 + <crate::msg::Summary as MaxSize>::POSTCARD_MAX_SIZE);

/// The encoding ran out of room in the output buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BufferTooSmall;

impl core::fmt::Display for BufferTooSmall {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("frame buffer too small for the encoded message")
    }
}

#[cfg(feature = "std")]
impl std::error::Error for BufferTooSmall {}

/// Encodes `msg` as one frame into `out` and returns the number of bytes written.
///
/// A buffer of [`DEVICE_FRAME_MAX`] or [`HOST_FRAME_MAX`] bytes always suffices for the
/// matching message type.
pub fn encode<T: Serialize + ?Sized>(msg: &T, out: &mut [u8]) -> Result<usize, BufferTooSmall> {
    let (first, body) = out.split_first_mut().ok_or(BufferTooSmall)?;
    *first = 0;
    let cobs = Cobs::try_new(Slice::new(body)).map_err(|_| BufferTooSmall)?;
    let flavor = CrcModifier::new(cobs, CRC32.digest());
    let written = postcard::serialize_with_flavor(msg, flavor).map_err(|_| BufferTooSmall)?;
    Ok(written.len() + 1)
}

/// Why a frame was dropped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameError {
    /// More bytes than the largest valid frame arrived before a delimiter.
    Overflow,
    /// The body is not valid COBS.
    Cobs,
    /// The body is shorter than a message tag plus its checksum.
    TooShort,
    /// The checksum does not match: the frame was corrupted on the line.
    Crc,
    /// The checksum matches but the bytes are not a message of this protocol.
    Decode,
    /// A [`crate::Hello`] of another protocol version or schema: the peer speaks another
    /// protocol and nothing it sends can be trusted.
    ProtocolMismatch {
        /// The peer's protocol version.
        protocol_version: u16,
        /// The peer's schema hash.
        schema_hash: u64,
    },
}

impl core::fmt::Display for FrameError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            FrameError::Overflow => f.write_str("frame longer than the largest message"),
            FrameError::Cobs => f.write_str("invalid COBS encoding"),
            FrameError::TooShort => f.write_str("frame too short to hold a message and CRC"),
            FrameError::Crc => f.write_str("CRC mismatch (corrupted frame)"),
            FrameError::Decode => f.write_str("valid CRC but not a message of this protocol"),
            FrameError::ProtocolMismatch {
                protocol_version,
                schema_hash,
            } => write!(
                f,
                "peer speaks protocol v{protocol_version} (schema {schema_hash:#018x}); \
                 this build speaks v{} (schema {:#018x})",
                crate::PROTOCOL_VERSION,
                schema::schema_hash()
            ),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for FrameError {}

/// Dropped frames by reason.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DropCounts {
    /// See [`FrameError::Overflow`].
    pub overflow: u64,
    /// See [`FrameError::Cobs`].
    pub cobs: u64,
    /// See [`FrameError::TooShort`].
    pub too_short: u64,
    /// See [`FrameError::Crc`].
    pub crc: u64,
    /// See [`FrameError::Decode`] and [`FrameError::ProtocolMismatch`].
    pub decode: u64,
}

impl DropCounts {
    /// These counts and `other`'s, reason by reason (a link's over several connections).
    #[must_use]
    pub fn plus(self, other: DropCounts) -> DropCounts {
        DropCounts {
            overflow: self.overflow.saturating_add(other.overflow),
            cobs: self.cobs.saturating_add(other.cobs),
            too_short: self.too_short.saturating_add(other.too_short),
            crc: self.crc.saturating_add(other.crc),
            decode: self.decode.saturating_add(other.decode),
        }
    }

    /// All dropped frames.
    pub fn total(&self) -> u64 {
        self.overflow + self.cobs + self.too_short + self.crc + self.decode
    }

    fn record(&mut self, err: FrameError) {
        let slot = match err {
            FrameError::Overflow => &mut self.overflow,
            FrameError::Cobs => &mut self.cobs,
            FrameError::TooShort => &mut self.too_short,
            FrameError::Crc => &mut self.crc,
            FrameError::Decode | FrameError::ProtocolMismatch { .. } => &mut self.decode,
        };
        *slot = slot.saturating_add(1);
    }
}

/// Streaming frame decoder for messages of type `T`, with an `N`-byte frame buffer.
///
/// Use [`DeviceDecoder`] on the host and [`HostDecoder`] on the device.
#[derive(Debug)]
pub struct Decoder<T, const N: usize> {
    buf: [u8; N],
    len: usize,
    overflowed: bool,
    accepted: u64,
    drops: DropCounts,
    _msg: PhantomData<fn() -> T>,
}

/// Decodes what a device sends.
pub type DeviceDecoder = Decoder<DeviceMsg, DEVICE_FRAME_MAX>;
/// Decodes what a host sends.
pub type HostDecoder = Decoder<HostMsg, HOST_FRAME_MAX>;

impl<T: WireMessage, const N: usize> Default for Decoder<T, N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: WireMessage, const N: usize> Decoder<T, N> {
    /// An empty decoder.
    pub const fn new() -> Self {
        Decoder {
            buf: [0; N],
            len: 0,
            overflowed: false,
            accepted: 0,
            drops: DropCounts {
                overflow: 0,
                cobs: 0,
                too_short: 0,
                crc: 0,
                decode: 0,
            },
            _msg: PhantomData,
        }
    }

    /// Feeds `bytes` (any chunk of the stream) and calls `sink` once per completed frame,
    /// in stream order: `Ok(msg)` for a good frame, `Err(why)` for a dropped one.
    pub fn push(&mut self, bytes: &[u8], mut sink: impl FnMut(Result<T, FrameError>)) {
        for &b in bytes {
            if b == 0 {
                if let Some(result) = self.end_frame() {
                    sink(result);
                }
            } else if !self.overflowed {
                match self.buf.get_mut(self.len) {
                    Some(slot) => {
                        *slot = b;
                        self.len += 1;
                    }
                    None => self.overflowed = true,
                }
            }
        }
    }

    /// Declares the end of the stream. A partial frame still buffered is dropped, counted
    /// and returned (a stream cut mid-frame).
    pub fn finish(&mut self) -> Option<FrameError> {
        let pending = self.len > 0 || self.overflowed;
        let err = if self.overflowed {
            FrameError::Overflow
        } else {
            FrameError::TooShort
        };
        self.len = 0;
        self.overflowed = false;
        if pending {
            self.drops.record(err);
            Some(err)
        } else {
            None
        }
    }

    /// Frames decoded so far.
    pub fn accepted(&self) -> u64 {
        self.accepted
    }

    /// Frames dropped so far, by reason.
    pub fn drops(&self) -> DropCounts {
        self.drops
    }

    /// Bytes of an unfinished frame held in the buffer.
    pub fn pending(&self) -> usize {
        self.len
    }

    fn end_frame(&mut self) -> Option<Result<T, FrameError>> {
        let len = core::mem::replace(&mut self.len, 0);
        let result = if core::mem::replace(&mut self.overflowed, false) {
            Err(FrameError::Overflow)
        } else if len == 0 {
            return None;
        } else {
            decode_body(&mut self.buf[..len])
        };
        match &result {
            Ok(_) => self.accepted = self.accepted.saturating_add(1),
            Err(e) => self.drops.record(*e),
        }
        Some(result)
    }
}

/// A message the decoders accept: it decodes, and then says whether its fields agree with
/// each other (a `Map` whose cells do not fill its size decodes, but is not a map).
pub trait WireMessage: DeserializeOwned {
    /// Whether the decoded message is whole and consistent.
    fn is_valid(&self) -> bool;
}

impl WireMessage for crate::msg::DeviceMsg {
    fn is_valid(&self) -> bool {
        match self {
            crate::msg::DeviceMsg::Map(m) => m.is_consistent(),
            crate::msg::DeviceMsg::MapChunk(c) => c.is_consistent(),
            _ => true,
        }
    }
}

impl WireMessage for crate::msg::HostMsg {
    fn is_valid(&self) -> bool {
        true
    }
}

/// Decodes one frame body (the bytes between two delimiters), in place.
///
/// A body that does not decode but starts like a `Hello` of another protocol version or
/// schema is [`FrameError::ProtocolMismatch`]; one of this version that does not decode
/// (a malformed `Hello`, say) is a plain [`FrameError::Decode`], as is a message that
/// decodes but is not consistent ([`WireMessage::is_valid`]).
pub fn decode_body<T: WireMessage>(body: &mut [u8]) -> Result<T, FrameError> {
    let n = cobs::decode_in_place(body).map_err(|_| FrameError::Cobs)?;
    let decoded = body.get(..n).ok_or(FrameError::Cobs)?;
    if n <= CRC_LEN {
        return Err(FrameError::TooShort);
    }
    let (payload, crc_bytes) = decoded.split_at(n - CRC_LEN);
    let mut crc = [0u8; CRC_LEN];
    crc.copy_from_slice(crc_bytes);
    if CRC32.checksum(payload) != u32::from_le_bytes(crc) {
        return Err(FrameError::Crc);
    }
    match postcard::take_from_bytes::<T>(payload) {
        Ok((msg, [])) if msg.is_valid() => Ok(msg),
        Ok(_) => Err(FrameError::Decode),
        Err(_) => match schema::peek_hello(payload) {
            Some((protocol_version, schema_hash))
                if !schema::is_compatible(protocol_version, schema_hash) =>
            {
                Err(FrameError::ProtocolMismatch {
                    protocol_version,
                    schema_hash,
                })
            }
            _ => Err(FrameError::Decode),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::HostMsg;

    fn frame_of(msg: &HostMsg) -> ([u8; HOST_FRAME_MAX], usize) {
        let mut buf = [0u8; HOST_FRAME_MAX];
        let n = encode(msg, &mut buf).unwrap();
        (buf, n)
    }

    #[test]
    fn frame_has_delimiters_and_no_inner_zero() {
        let (buf, n) = frame_of(&HostMsg::Ping { nonce: 0 });
        let frame = &buf[..n];
        assert_eq!(frame[0], 0);
        assert_eq!(frame[n - 1], 0);
        assert!(frame[1..n - 1].iter().all(|&b| b != 0));
    }

    #[test]
    fn encode_reports_small_buffer() {
        let mut tiny = [0u8; 4];
        assert_eq!(
            encode(&HostMsg::Ping { nonce: u32::MAX }, &mut tiny),
            Err(BufferTooSmall)
        );
        assert_eq!(encode(&HostMsg::GetInfo, &mut []), Err(BufferTooSmall));
    }

    #[test]
    fn frame_len_max_holds_whole_runs_without_zeros() {
        // A 502-byte slice encodes as a two-byte length and its bytes: with the CRC, 508
        // bytes of data, two full COBS runs when no byte of the CRC is zero either, framed
        // as two delimiters, two run codes, the data and the empty run's code. Fills are
        // tried until one gives that longest frame.
        const PAYLOAD: usize = 504;
        const LONGEST: usize = 2 + 2 + 508 + 1;
        let mut roomy = [0u8; LONGEST + 8];
        let data = (1..=u8::MAX)
            .map(|fill| [fill; PAYLOAD - 2])
            .find(|data| encode(data.as_slice(), &mut roomy) == Ok(LONGEST))
            .unwrap();
        let mut buf = [0u8; frame_len_max(PAYLOAD)];
        assert_eq!(
            encode(data.as_slice(), &mut buf),
            Ok(buf.len()),
            "the bound fits"
        );
        let mut dec = Decoder::<Bytes, { frame_len_max(PAYLOAD) }>::new();
        let mut got = None;
        dec.push(&buf, |r| got = Some(r));
        assert_eq!(got.unwrap().unwrap().0.as_slice(), data.as_slice());
    }

    /// A bare byte string, to frame payloads of a chosen length.
    #[derive(serde::Deserialize)]
    struct Bytes(heapless::Vec<u8, 502>);

    impl WireMessage for Bytes {
        fn is_valid(&self) -> bool {
            true
        }
    }

    #[test]
    fn decoder_counts_each_reason() {
        let mut dec = HostDecoder::new();
        let mut got = heapless::Vec::<Result<HostMsg, FrameError>, 8>::new();
        // Overflow: a run of non-zero bytes longer than any frame.
        let long = [0x55u8; HOST_FRAME_MAX + 3];
        dec.push(&long, |r| got.push(r).unwrap());
        dec.push(&[0], |r| got.push(r).unwrap());
        // COBS error: a code byte pointing past the end.
        dec.push(&[0x09, 1, 0], |r| got.push(r).unwrap());
        // Too short: valid COBS of two bytes.
        dec.push(&[0x03, 1, 2, 0], |r| got.push(r).unwrap());
        // CRC: flip a payload bit of a good frame and re-encode it as valid COBS.
        let (mut buf, n) = frame_of(&HostMsg::Ping { nonce: 77 });
        let raw_len = cobs::decode_in_place(&mut buf[1..n - 1]).unwrap();
        buf[2] ^= 0x10;
        let mut reframed = [0u8; HOST_FRAME_MAX];
        let m = cobs::encode(&buf[1..1 + raw_len], &mut reframed[1..]);
        dec.push(&reframed[..m + 2], |r| got.push(r).unwrap());
        assert_eq!(
            got.as_slice(),
            &[
                Err(FrameError::Overflow),
                Err(FrameError::Cobs),
                Err(FrameError::TooShort),
                Err(FrameError::Crc)
            ]
        );
        let d = dec.drops();
        assert_eq!(
            (d.overflow, d.cobs, d.too_short, d.crc, d.decode),
            (1, 1, 1, 1, 0)
        );
        assert_eq!(d.total(), 4);
        assert_eq!(dec.accepted(), 0);
    }

    #[test]
    fn valid_crc_of_wrong_type_is_a_decode_drop() {
        // `Ack(Stop)` reads as the host's `Start` followed by a stray byte: refused whole.
        let mut buf = [0u8; DEVICE_FRAME_MAX];
        let n = encode(&crate::DeviceMsg::Ack(crate::Command::Stop), &mut buf).unwrap();
        let mut dec = HostDecoder::new();
        let mut errors = 0;
        dec.push(&buf[..n], |r| {
            assert!(matches!(r, Err(FrameError::Decode)), "{r:?}");
            errors += 1;
        });
        assert_eq!(errors, 1);
        assert_eq!(dec.drops().decode, 1);
    }

    #[test]
    fn finish_counts_a_cut_frame() {
        let (buf, n) = frame_of(&HostMsg::Start);
        let mut dec = HostDecoder::new();
        dec.push(&buf[..n - 2], |_| panic!("no frame is complete"));
        assert!(dec.pending() > 0);
        assert_eq!(dec.finish(), Some(FrameError::TooShort));
        assert_eq!(dec.finish(), None);
        assert_eq!(dec.drops().total(), 1);
    }
}
