//! Framing: `COBS(postcard(message) ++ CRC-32 LE) ++ 0x00`, and a streaming decoder
//! with a fixed buffer that drops bad frames, counts them, and resyncs at the next 0x00.
//!
//! The CRC is CRC-32/ISO-HDLC (the zlib/Ethernet CRC-32: poly 0x04C11DB7 reflected,
//! init and xorout 0xFFFFFFFF), computed over the postcard bytes.

use crc::{CRC_32_ISO_HDLC, Crc};
use postcard::ser_flavors::{Cobs, Slice, crc::CrcModifier};
use serde::{Serialize, de::DeserializeOwned};

use crate::protocol::MAX_MESSAGE_LEN;

/// The CRC used by every frame.
pub const CRC: Crc<u32> = Crc::<u32>::new(&CRC_32_ISO_HDLC);

/// Longest encoded frame: COBS adds one byte per 254 plus one, then the 0x00.
pub const MAX_FRAME_LEN: usize = MAX_MESSAGE_LEN + MAX_MESSAGE_LEN / 254 + 2;

/// Why a frame could not be produced or accepted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameError {
    /// The output buffer is too small for the encoded frame.
    BufferFull,
    /// The frame exceeded the decoder's buffer (it was dropped up to the next 0x00), or
    /// its COBS-decoded body exceeds [`MAX_MESSAGE_LEN`] bytes.
    TooLong,
    /// The bytes between two 0x00 are not valid COBS.
    Cobs,
    /// The CRC does not match: the frame was corrupted in transit.
    Crc,
    /// CRC fine, but the bytes are not a message of this protocol (unknown variant,
    /// truncated or extra fields).
    Decode,
}

/// Encodes `msg` as a complete frame (ending in 0x00) into `buf`; returns its length.
pub fn encode<T: Serialize>(msg: &T, buf: &mut [u8]) -> Result<usize, FrameError> {
    let cobs = Cobs::try_new(Slice::new(buf)).map_err(|_| FrameError::BufferFull)?;
    let out = postcard::serialize_with_flavor(msg, CrcModifier::new(cobs, CRC.digest()))
        .map_err(|_| FrameError::BufferFull)?;
    Ok(out.len())
}

/// Decodes one frame body (the bytes before a 0x00, COBS-encoded) in place.
pub fn decode_body<T: DeserializeOwned>(body: &mut [u8]) -> Result<T, FrameError> {
    let n = check_body(body)?;
    decode_payload(&body[..n])
}

/// COBS-decodes `body` in place and checks its CRC; returns the payload length (the
/// payload is then `body[..len]`).
fn check_body(body: &mut [u8]) -> Result<usize, FrameError> {
    let n = cobs::decode_in_place(body).map_err(|_| FrameError::Cobs)?;
    // A body longer than any message is too long, whatever its CRC says: one length
    // rule, not "fits the buffer" (the buffer holds a few bytes more).
    if n > MAX_MESSAGE_LEN {
        return Err(FrameError::TooLong);
    }
    if n < 4 {
        return Err(if n == 0 {
            FrameError::Cobs
        } else {
            FrameError::Crc
        });
    }
    let (payload, crc) = body[..n].split_at(n - 4);
    let sent = u32::from_le_bytes([crc[0], crc[1], crc[2], crc[3]]);
    if CRC.checksum(payload) != sent {
        return Err(FrameError::Crc);
    }
    Ok(n - 4)
}

/// Decodes a CRC-checked payload; it must be consumed exactly.
fn decode_payload<T: DeserializeOwned>(payload: &[u8]) -> Result<T, FrameError> {
    match postcard::take_from_bytes::<T>(payload) {
        Ok((msg, [])) => Ok(msg),
        _ => Err(FrameError::Decode),
    }
}

/// Counters of what a decoder has seen.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FrameStats {
    /// Frames decoded successfully.
    pub ok: u32,
    /// Frames dropped for CRC mismatch.
    pub crc: u32,
    /// Frames dropped for invalid COBS.
    pub cobs: u32,
    /// Frames dropped for exceeding the buffer.
    pub too_long: u32,
    /// Intact frames that did not decode as a message.
    pub decode: u32,
}

impl FrameStats {
    /// All dropped frames.
    pub fn dropped(&self) -> u32 {
        self.crc + self.cobs + self.too_long + self.decode
    }
}

/// A streaming frame decoder with an `N`-byte buffer. Feed it bytes as they arrive.
pub struct FrameDecoder<const N: usize> {
    buf: [u8; N],
    len: usize,
    /// Length of the last frame's payload (CRC stripped) left in `buf`, if intact.
    last_payload: usize,
    overflowed: bool,
    stats: FrameStats,
}

impl<const N: usize> Default for FrameDecoder<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> FrameDecoder<N> {
    /// An empty decoder.
    pub const fn new() -> Self {
        FrameDecoder {
            buf: [0; N],
            len: 0,
            last_payload: 0,
            overflowed: false,
            stats: FrameStats {
                ok: 0,
                crc: 0,
                cobs: 0,
                too_long: 0,
                decode: 0,
            },
        }
    }

    /// What the decoder has accepted and dropped so far.
    pub fn stats(&self) -> FrameStats {
        self.stats
    }

    /// The payload of the frame just returned as `Err(FrameError::Decode)` (intact but
    /// not a `T`), e.g. to read the version of a newer protocol's `Info`. Empty
    /// otherwise, and once the next byte is pushed.
    pub fn undecoded_payload(&self) -> &[u8] {
        &self.buf[..self.last_payload]
    }

    /// Bytes of an unfinished frame held in the buffer.
    pub fn pending(&self) -> usize {
        self.len
    }

    /// Pushes one byte. Returns `None` until a 0x00 ends a frame, then the decoded
    /// message or why the frame was dropped. Empty frames (0x00 0x00) are ignored, so
    /// a sender may prefix a frame with 0x00 to flush line noise.
    pub fn push<T: DeserializeOwned>(&mut self, byte: u8) -> Option<Result<T, FrameError>> {
        if byte != 0 {
            self.last_payload = 0;
            if self.len < N {
                self.buf[self.len] = byte;
                self.len += 1;
            } else {
                self.overflowed = true;
            }
            return None;
        }
        let len = core::mem::replace(&mut self.len, 0);
        if core::mem::replace(&mut self.overflowed, false) {
            self.stats.too_long += 1;
            return Some(Err(FrameError::TooLong));
        }
        if len == 0 {
            return None;
        }
        let result = check_body(&mut self.buf[..len]).and_then(|n| {
            decode_payload::<T>(&self.buf[..n]).inspect_err(|_| self.last_payload = n)
        });
        match result {
            Ok(_) => self.stats.ok += 1,
            Err(FrameError::Crc) => self.stats.crc += 1,
            Err(FrameError::Cobs) => self.stats.cobs += 1,
            Err(FrameError::Decode) => self.stats.decode += 1,
            Err(FrameError::TooLong | FrameError::BufferFull) => self.stats.too_long += 1,
        }
        Some(result)
    }
}

#[cfg(test)]
#[path = "frame_tests.rs"]
mod tests;
