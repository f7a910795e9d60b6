//! Fixed-size, NUL-terminated text fields filled from the core's `Display` impls, without allocating.

use core::fmt::{self, Write};

/// Writes `value`'s `Display` into `buf` as a NUL-terminated string, truncated to fit.
pub(crate) fn write_display<const N: usize>(buf: &mut [u8; N], value: &dyn fmt::Display) {
    struct Cursor<'b> {
        buf: &'b mut [u8],
        len: usize,
    }
    impl Write for Cursor<'_> {
        fn write_str(&mut self, s: &str) -> fmt::Result {
            for b in s.bytes() {
                // Keep the last byte for the NUL.
                if self.len + 1 >= self.buf.len() {
                    return Err(fmt::Error);
                }
                if let Some(slot) = self.buf.get_mut(self.len) {
                    *slot = b;
                }
                self.len += 1;
            }
            Ok(())
        }
    }
    buf.fill(0);
    let mut c = Cursor { buf: buf.as_mut_slice(), len: 0 };
    // A truncated text is still NUL-terminated: the error only says it did not fit.
    let _ = write!(c, "{value}");
}

#[cfg(test)]
#[allow(clippy::indexing_slicing)]
mod tests {
    use super::*;

    #[test]
    fn texts_are_terminated_and_truncated() {
        let mut b = [0xffu8; 8];
        write_display(&mut b, &"ghost");
        assert_eq!(&b[..6], b"ghost\0");
        write_display(&mut b, &"position_error");
        assert_eq!(&b, b"positio\0");
    }
}
