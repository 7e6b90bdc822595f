//! Deterministic test data shared by the unit tests (compiled for tests only).

/// `n` points uniform in the unit square from a 64-bit LCG (Knuth's MMIX constants): the
/// same on every platform and independent of any crate's sampling algorithm.
pub(crate) fn random_points(n: usize, seed: u64) -> Vec<[f64; 2]> {
    let mut s = seed;
    let mut next = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..n).map(|_| [next(), next()]).collect()
}
