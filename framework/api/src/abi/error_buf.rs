//! The host-owned [`ErrorBuf`] a plugin writes an error or panic message into, and
//! [`copy_utf8_prefix`], the UTF-8-safe copy every fixed-size text field is written with.

/// A host-owned buffer a plugin writes an error or panic message into.
///
/// ```
/// use jointctl_api::abi::ErrorBuf;
/// let mut e = ErrorBuf::new();
/// e.write("must be > 0", Some("k"));
/// assert_eq!((e.message(), e.field()), ("must be > 0", Some("k")));
/// ```
#[repr(C)]
#[derive(Clone)]
pub struct ErrorBuf {
    pub(super) message_len: u32,
    pub(super) field_len: u32,
    pub(super) message: [u8; 1024],
    pub(super) field: [u8; 256],
}

impl Default for ErrorBuf {
    fn default() -> Self {
        Self::new()
    }
}

impl ErrorBuf {
    /// An empty buffer.
    pub const fn new() -> Self {
        ErrorBuf { message_len: 0, field_len: 0, message: [0; 1024], field: [0; 256] }
    }

    /// Stores a message and optional field path, truncated at a character boundary.
    pub fn write(&mut self, message: &str, field: Option<&str>) {
        self.message_len = copy_utf8_prefix(&mut self.message, message) as u32;
        self.field_len = copy_utf8_prefix(&mut self.field, field.unwrap_or("")) as u32;
    }

    /// The stored message. The length was written by the plugin's copy of this code, so it is
    /// clamped to the buffer and cut at the last whole UTF-8 character, never trusted.
    pub fn message(&self) -> &str {
        utf8_prefix(&self.message, self.message_len)
    }

    /// The stored field path, if any.
    pub fn field(&self) -> Option<&str> {
        let f = utf8_prefix(&self.field, self.field_len);
        (!f.is_empty()).then_some(f)
    }

    /// Clears the buffer.
    pub fn clear(&mut self) {
        self.message_len = 0;
        self.field_len = 0;
    }
}

/// The valid UTF-8 start of `buf[..len]`, with `len` clamped to the buffer and the text ending
/// at the first NUL (a forged length must not expose the buffer's unused bytes).
fn utf8_prefix(buf: &[u8], len: u32) -> &str {
    let bytes = &buf[..(len as usize).min(buf.len())];
    let bytes = &bytes[..bytes.iter().position(|b| *b == 0).unwrap_or(bytes.len())];
    match core::str::from_utf8(bytes) {
        Ok(s) => s,
        // The prefix up to the first invalid byte is valid UTF-8 by definition.
        Err(e) => core::str::from_utf8(&bytes[..e.valid_up_to()]).unwrap_or_default(),
    }
}

/// Copies the longest prefix of `src` that fits `dst` and ends at a character boundary, so the
/// bytes copied are always valid UTF-8; returns how many were copied. Every fixed-size text
/// field that crosses a process or plugin boundary is written with it.
///
/// ```
/// let mut buf = [0u8; 3];
/// assert_eq!(jointctl_api::abi::copy_utf8_prefix(&mut buf, "aü!"), 3);
/// assert_eq!(&buf, "aü".as_bytes());
/// assert_eq!(jointctl_api::abi::copy_utf8_prefix(&mut buf[..2], "aü"), 1, "ü does not fit whole");
/// ```
pub fn copy_utf8_prefix(dst: &mut [u8], src: &str) -> usize {
    let mut n = src.len().min(dst.len());
    while !src.is_char_boundary(n) {
        n -= 1;
    }
    dst[..n].copy_from_slice(&src.as_bytes()[..n]);
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue finding: `ErrorBuf::message` sliced by a length the plugin wrote. A length beyond the
    /// buffer, or one that cuts a character, gives the valid text, never a panic.
    #[test]
    fn an_error_buffer_with_a_forged_length_reads_safely() {
        let mut e = ErrorBuf::new();
        e.write("grüße", Some("k"));
        e.message_len = 5000;
        e.field_len = u32::MAX;
        assert_eq!(e.message(), "grüße");
        assert_eq!(e.field(), Some("k"));
        e.write("grüße", None);
        e.message_len = 3; // inside the two bytes of `ü`
        assert_eq!(e.message(), "gr");
    }
}
