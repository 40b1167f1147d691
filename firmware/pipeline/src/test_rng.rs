//! Reproducible pseudo-random inputs for tests: xorshift64, so a failing case is the same
//! on every run and every machine, without a dependency.

/// A xorshift64 generator; the seed must not be zero.
pub(crate) struct XorShift(pub(crate) u64);

impl XorShift {
    /// The next 64 pseudo-random bits.
    pub(crate) fn next(&mut self) -> u64 {
        let s = &mut self.0;
        *s ^= *s << 13;
        *s ^= *s >> 7;
        *s ^= *s << 17;
        *s
    }
}
