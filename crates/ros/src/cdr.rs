//! ROS 2 CDR payloads: the 4-byte encapsulation header, then the body in plain CDR (via `cdr-encoding`,
//! the crate RustDDS and `ros2-client` use). Alignment counts from the end of the header, as in ROS 2.

use byteorder::{BigEndian, LittleEndian};
use cdr_encoding::{from_bytes, to_vec};
use serde::de::DeserializeOwned;
use serde::Serialize;

/// Encapsulation identifier of little-endian plain CDR (`CDR_LE`), what ROS 2 writes on x86 and ARM.
pub const CDR_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];
/// Encapsulation identifier of big-endian plain CDR (`CDR_BE`).
pub const CDR_BE: [u8; 4] = [0x00, 0x00, 0x00, 0x00];

/// A payload that is not the expected message.
#[derive(Debug, thiserror::Error)]
pub enum CdrError {
    /// Fewer than 4 bytes: no encapsulation header.
    #[error("CDR payload of {0} bytes has no encapsulation header")]
    Truncated(usize),
    /// Not plain CDR (e.g. XCDR2 or a parameter list).
    #[error("unsupported CDR encapsulation {0:#04x}{1:02x} (only CDR_LE and CDR_BE)")]
    Encapsulation(u8, u8),
    /// The body does not decode as the expected type (too short, bad bool, bad UTF-8, ...).
    #[error("malformed CDR: {0}")]
    Body(String),
}

/// Decodes a ROS 2 CDR payload (encapsulation header included). Trailing bytes (padding) are allowed.
///
/// # Errors
/// [`CdrError`] on a short payload, an unsupported encapsulation or a malformed body.
pub fn decode<T: DeserializeOwned>(payload: &[u8]) -> Result<T, CdrError> {
    let (head, body) = payload.split_at_checked(4).ok_or(CdrError::Truncated(payload.len()))?;
    let result = match (head.first(), head.get(1)) {
        (Some(0), Some(1)) => from_bytes::<T, LittleEndian>(body),
        (Some(0), Some(0)) => from_bytes::<T, BigEndian>(body),
        (a, b) => return Err(CdrError::Encapsulation(a.copied().unwrap_or(0), b.copied().unwrap_or(0))),
    };
    result.map(|(value, _)| value).map_err(|e| CdrError::Body(e.to_string()))
}

/// Encodes a message as a little-endian ROS 2 CDR payload (encapsulation header included).
///
/// # Errors
/// [`CdrError::Body`] when serde refuses the value (it does not for the types of [`crate::msg`]).
pub fn encode<T: Serialize>(value: &T) -> Result<Vec<u8>, CdrError> {
    let body = to_vec::<T, LittleEndian>(value).map_err(|e| CdrError::Body(e.to_string()))?;
    let mut out = Vec::with_capacity(body.len() + 4);
    out.extend_from_slice(&CDR_LE);
    out.extend_from_slice(&body);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::{Header, Time};

    #[test]
    fn header_round_trips_and_matches_hand_laid_bytes() {
        let h = Header { stamp: Time { sec: 7, nanosec: 5 }, frame_id: "map".into() };
        let bytes = encode(&h).unwrap();
        // CDR_LE, sec, nanosec, string length 4 (with NUL), "map\0".
        let expected = [0, 1, 0, 0, 7, 0, 0, 0, 5, 0, 0, 0, 4, 0, 0, 0, b'm', b'a', b'p', 0];
        assert_eq!(bytes, expected);
        assert_eq!(decode::<Header>(&bytes).unwrap(), h);
    }

    #[test]
    fn big_endian_decodes() {
        let bytes = [0, 0, 0, 0, 0, 0, 0, 7, 0, 0, 0, 5, 0, 0, 0, 2, b'a', 0];
        let h: Header = decode(&bytes).unwrap();
        assert_eq!(h.stamp, Time { sec: 7, nanosec: 5 });
        assert_eq!(h.frame_id, "a");
    }

    #[test]
    fn malformed_payloads_are_errors_not_panics() {
        assert!(matches!(decode::<Header>(&[0, 1]), Err(CdrError::Truncated(2))));
        assert!(matches!(decode::<Header>(&[0, 7, 0, 0, 1, 2, 3, 4]), Err(CdrError::Encapsulation(0, 7))));
        // A string length far beyond the payload.
        let bytes = [0, 1, 0, 0, 7, 0, 0, 0, 5, 0, 0, 0, 0xff, 0xff, 0xff, 0x7f, b'a'];
        assert!(matches!(decode::<Header>(&bytes), Err(CdrError::Body(_))));
        // Every truncation of a valid payload fails cleanly.
        let full = encode(&Header { stamp: Time { sec: 1, nanosec: 2 }, frame_id: "base_link".into() }).unwrap();
        for n in 0..full.len() - 1 {
            assert!(decode::<Header>(&full[..n]).is_err(), "truncated to {n}");
        }
    }
}
