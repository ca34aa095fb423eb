//! The one place where messages become bytes and back.
//!
//! Every transport (Zenoh, DDS, MCAP) carries the same payload: a 4-byte
//! encapsulation header followed by a plain-CDR (XCDR1) body, so keeping a
//! single choke point guarantees all of them agree byte for byte.

use byteorder::{BigEndian, LittleEndian};

use crate::message::RosMessage;

/// Encapsulation header for plain CDR, little endian, no options.
pub const CDR_LE_HEADER: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// CDR bodies are padded to a multiple of 4 bytes by some DDS vendors, so up
/// to 3 bytes after the last field are padding, not an error.
const MAX_PADDING: usize = 3;

/// Why a payload could not be decoded.
#[derive(Debug, thiserror::Error)]
pub enum DecodeError {
    #[error("payload has {len} bytes, fewer than the 4-byte encapsulation header")]
    TooShort { len: usize },
    #[error("encapsulation {0:02x}{1:02x} is not plain CDR (0000 big endian or 0001 little endian)", id[0], id[1])]
    UnsupportedEncapsulation { id: [u8; 2] },
    #[error("body is truncated: a field or length prefix runs past the end of the payload")]
    Truncated,
    #[error("string is not valid UTF-8: {0}")]
    InvalidUtf8(std::str::Utf8Error),
    #[error("bool byte is {0}, expected 0 or 1")]
    InvalidBool(u8),
    #[error("{count} bytes follow the message, more than the {MAX_PADDING} bytes of padding CDR allows")]
    TrailingBytes { count: usize },
    #[error("malformed CDR body: {0}")]
    Malformed(String),
}

impl From<cdr_encoding::Error> for DecodeError {
    fn from(e: cdr_encoding::Error) -> Self {
        match e {
            cdr_encoding::Error::Eof => Self::Truncated,
            cdr_encoding::Error::BadUTF8(u) => Self::InvalidUtf8(u),
            cdr_encoding::Error::BadBoolean(b) => Self::InvalidBool(b),
            other => Self::Malformed(other.to_string()),
        }
    }
}

/// Why a message could not be encoded. Cannot happen for the crate's own
/// message types (every serde shape they use maps to CDR); kept for
/// [`try_encode`] callers with their own [`RosMessage`] types.
#[derive(Debug, thiserror::Error)]
#[error("cannot encode as CDR: {0}")]
pub struct EncodeError(String);

/// Encodes a message as header + CDR body, ready for any ROS 2 transport.
pub fn try_encode<T: RosMessage>(msg: &T) -> Result<Vec<u8>, EncodeError> {
    let body = cdr_encoding::to_vec::<T, LittleEndian>(msg).map_err(|e| EncodeError(e.to_string()))?;
    let mut out = Vec::with_capacity(CDR_LE_HEADER.len() + body.len());
    out.extend_from_slice(&CDR_LE_HEADER);
    out.extend_from_slice(&body);
    Ok(out)
}

/// Encodes a message as header + CDR body, ready for any ROS 2 transport.
///
/// # Panics
/// Only if `T`'s serde representation has no CDR form (e.g. a map or an
/// unsized sequence), which the round-trip tests rule out for every message
/// type this crate defines. Use [`try_encode`] for foreign types.
pub fn encode<T: RosMessage>(msg: &T) -> Vec<u8> {
    match try_encode(msg) {
        Ok(bytes) => bytes,
        Err(e) => panic!("{} is not CDR-encodable: {e}", T::TYPE_NAME),
    }
}

/// Decodes header + CDR body. Lengths are checked against the bytes actually
/// present before anything is allocated, so a hostile length prefix cannot
/// make this allocate more than the payload's size.
pub fn decode<T: RosMessage>(payload: &[u8]) -> Result<T, DecodeError> {
    let Some((header, body)) = payload.split_first_chunk::<4>() else {
        return Err(DecodeError::TooShort { len: payload.len() });
    };
    let (value, used) = match [header[0], header[1]] {
        [0x00, 0x01] => cdr_encoding::from_bytes::<T, LittleEndian>(body)?,
        [0x00, 0x00] => cdr_encoding::from_bytes::<T, BigEndian>(body)?,
        id => return Err(DecodeError::UnsupportedEncapsulation { id }),
    };
    let count = body.len().saturating_sub(used);
    if count > MAX_PADDING {
        return Err(DecodeError::TrailingBytes { count });
    }
    Ok(value)
}
