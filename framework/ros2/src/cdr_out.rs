//! Plain CDR (XCDR1, little-endian) written straight into a buffer that is kept: what
//! [`crate::direct`] writes the arm's samples with. Each value is aligned to its size from the
//! start of the data after the 4-byte encapsulation header, as `cdr_encoding` (and every DDS)
//! does; `direct`'s tests check the bytes against [`crate::encode`] of the message types.

use std::fmt::Write as _;

/// A CDR message being written into `buf` (its encapsulation header first).
pub(crate) struct CdrOut<'a> {
    buf: &'a mut Vec<u8>,
}

/// The encapsulation header (see [`crate::encode`]).
const HEADER: [u8; 4] = [0, 1, 0, 0];

impl<'a> CdrOut<'a> {
    /// Empties `buf` (keeping its capacity) and writes the encapsulation header.
    pub(crate) fn begin(buf: &'a mut Vec<u8>) -> Self {
        buf.clear();
        buf.extend_from_slice(&HEADER);
        CdrOut { buf }
    }

    fn align(&mut self, to: usize) {
        let at = self.buf.len() - HEADER.len();
        let pad = (to - at % to) % to;
        self.buf.resize(self.buf.len() + pad, 0);
    }

    pub(crate) fn u8(&mut self, v: u8) {
        self.buf.push(v);
    }

    pub(crate) fn bool(&mut self, v: bool) {
        self.buf.push(u8::from(v));
    }

    /// A value of `N` bytes, aligned to its size.
    fn put<const N: usize>(&mut self, bytes: [u8; N]) {
        self.align(N);
        self.buf.extend_from_slice(&bytes);
    }

    pub(crate) fn u32(&mut self, v: u32) {
        self.put(v.to_le_bytes());
    }

    pub(crate) fn i32(&mut self, v: i32) {
        self.put(v.to_le_bytes());
    }

    pub(crate) fn u64(&mut self, v: u64) {
        self.put(v.to_le_bytes());
    }

    pub(crate) fn f64(&mut self, v: f64) {
        self.put(v.to_le_bytes());
    }

    /// A sequence's length (its elements follow).
    pub(crate) fn len(&mut self, n: usize) {
        self.u32(n as u32);
    }

    /// A string made of `parts` one after the other: its length with the NUL, the bytes, the NUL.
    pub(crate) fn str_of(&mut self, parts: &[&str]) {
        let n: usize = parts.iter().map(|p| p.len()).sum();
        self.u32((n + 1) as u32);
        for p in parts {
            self.buf.extend_from_slice(p.as_bytes());
        }
        self.buf.push(0);
    }

    pub(crate) fn str(&mut self, s: &str) {
        self.str_of(&[s]);
    }

    /// A number as its decimal text (what `u64::to_string` gives), written without allocating
    /// once `scratch` has grown to a number's length.
    pub(crate) fn str_u64(&mut self, v: u64, scratch: &mut String) {
        scratch.clear();
        // Writing into a String cannot fail.
        let _ = write!(scratch, "{v}");
        self.str(scratch);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Alignment counts from the end of the encapsulation header: a u8 at 0, then a u32 at 4,
    /// an f64 at 8.
    #[test]
    fn values_are_aligned_from_the_data_start() {
        let mut buf = Vec::new();
        let mut w = CdrOut::begin(&mut buf);
        w.u8(7);
        w.u32(1);
        w.f64(2.0);
        assert_eq!(buf.len(), 4 + 16);
        assert_eq!(&buf[4..8], &[7, 0, 0, 0]);
        assert_eq!(&buf[8..12], &1u32.to_le_bytes());
        assert_eq!(&buf[12..20], &2.0f64.to_le_bytes());
    }

    #[test]
    fn a_string_of_parts_is_one_string_with_its_nul() {
        let mut buf = vec![9; 40];
        let mut w = CdrOut::begin(&mut buf);
        w.str_of(&["ab", "", "c"]);
        assert_eq!(buf, [0, 1, 0, 0, 4, 0, 0, 0, b'a', b'b', b'c', 0]);
    }
}
