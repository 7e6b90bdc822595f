//! Jitter for synthetic bench scans from a fixed 64-bit LCG (Knuth's MMIX constants): the
//! same points on every platform and with every crate version.

/// A generator of offsets uniform in [-amplitude / 2, amplitude / 2), seeded. O(1) per call.
pub fn jitter(seed: u64, amplitude: f64) -> impl FnMut() -> f64 {
    let mut s = seed;
    move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((s >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * amplitude
    }
}
