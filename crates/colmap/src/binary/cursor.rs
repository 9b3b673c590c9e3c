//! A bounds-checked little-endian reader over a byte slice.

use crate::error::Problem;

pub(crate) struct Cursor<'a> {
    buf: &'a [u8],
    pos: usize,
}

/// A problem at a byte offset (the record is added by the caller).
pub(crate) type At<T> = Result<T, (usize, Problem)>;

impl<'a> Cursor<'a> {
    pub(crate) fn new(buf: &'a [u8]) -> Self {
        Cursor { buf, pos: 0 }
    }

    pub(crate) fn pos(&self) -> usize {
        self.pos
    }

    pub(crate) fn remaining(&self) -> usize {
        self.buf.len() - self.pos
    }

    pub(crate) fn take(&mut self, n: usize, what: &'static str) -> At<&'a [u8]> {
        let remaining = self.remaining();
        if n > remaining {
            return Err((
                self.pos,
                Problem::Truncated {
                    what,
                    needed: n,
                    remaining,
                },
            ));
        }
        let s = &self.buf[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    pub(crate) fn array<const N: usize>(&mut self, what: &'static str) -> At<[u8; N]> {
        let s = self.take(N, what)?;
        let mut a = [0u8; N];
        a.copy_from_slice(s);
        Ok(a)
    }

    pub(crate) fn u8(&mut self, what: &'static str) -> At<u8> {
        Ok(self.array::<1>(what)?[0])
    }

    pub(crate) fn u32(&mut self, what: &'static str) -> At<u32> {
        Ok(u32::from_le_bytes(self.array(what)?))
    }

    pub(crate) fn i32(&mut self, what: &'static str) -> At<i32> {
        Ok(i32::from_le_bytes(self.array(what)?))
    }

    pub(crate) fn u64(&mut self, what: &'static str) -> At<u64> {
        Ok(u64::from_le_bytes(self.array(what)?))
    }

    pub(crate) fn f64s<const N: usize>(&mut self, what: &'static str) -> At<[f64; N]> {
        let start = self.pos;
        let s = self.take(8 * N, what).map_err(|(_, p)| (start, p))?;
        let mut out = [0.0; N];
        for (o, c) in out.iter_mut().zip(s.chunks_exact(8)) {
            *o = f64_at(c);
        }
        Ok(out)
    }

    /// Reads a count and checks that `count` records of at least `min_each` bytes fit in
    /// what remains, so that no allocation is ever sized by an unchecked count.
    pub(crate) fn count(&mut self, what: &'static str, min_each: usize) -> At<usize> {
        let at = self.pos;
        let count = self.u64(what)?;
        self.check_count(at, what, count, min_each)
    }

    pub(crate) fn count_u32(&mut self, what: &'static str, min_each: usize) -> At<usize> {
        let at = self.pos;
        let count = u64::from(self.u32(what)?);
        self.check_count(at, what, count, min_each)
    }

    fn check_count(&self, at: usize, what: &'static str, count: u64, min_each: usize) -> At<usize> {
        let min_bytes = u128::from(count) * min_each as u128;
        let remaining = self.remaining();
        if min_bytes > remaining as u128 {
            return Err((
                at,
                Problem::CountTooLarge {
                    what,
                    count,
                    min_bytes,
                    remaining,
                },
            ));
        }
        // Fits in the remaining bytes, hence in usize.
        Ok(count as usize)
    }

    /// Bytes up to (not including) the next NUL; the cursor moves past the NUL.
    pub(crate) fn c_string(&mut self) -> At<&'a [u8]> {
        let rest = &self.buf[self.pos..];
        match rest.iter().position(|&b| b == 0) {
            Some(n) => {
                self.pos += n + 1;
                Ok(&rest[..n])
            }
            None => Err((self.pos, Problem::UnterminatedName)),
        }
    }

    pub(crate) fn finish(&self) -> At<()> {
        match self.remaining() {
            0 => Ok(()),
            count => Err((self.pos, Problem::TrailingBytes { count })),
        }
    }
}

#[inline]
pub(crate) fn f64_at(b: &[u8]) -> f64 {
    let mut a = [0u8; 8];
    a.copy_from_slice(&b[..8]);
    f64::from_le_bytes(a)
}

#[inline]
pub(crate) fn u64_at(b: &[u8]) -> u64 {
    let mut a = [0u8; 8];
    a.copy_from_slice(&b[..8]);
    u64::from_le_bytes(a)
}

#[inline]
pub(crate) fn u32_at(b: &[u8]) -> u32 {
    let mut a = [0u8; 4];
    a.copy_from_slice(&b[..4]);
    u32::from_le_bytes(a)
}
