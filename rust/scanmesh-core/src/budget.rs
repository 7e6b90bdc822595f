//! What a run may cost: limits on the work and memory an option can ask for, this machine's
//! memory, and copies whose allocation may fail.
//!
//! Why: options multiply work and memory (chains × sweeps × edges proposals, chains ×
//! state bytes), so a few digits too many turn a run into one that never ends or that
//! aborts the process when an allocation fails (Rust's default on a failed allocation).
//! Every such product is checked before the work starts, and the copies an option
//! multiplies are made with `try_reserve`, so both end in an [`Error::TooCostly`] that names
//! the option.

use crate::{Error, Result};
use std::collections::TryReserveError;

/// Most flip proposals (calibration included, all chains together) one annealing run may
/// plan: about 18 hours on one core at [`PROPOSALS_PER_SECOND`]; 3,000 sweeps on a million
/// points plan 9 × 10^9.
pub const MAX_PROPOSALS: u64 = 1_000_000_000_000;

/// Most calibration proposals (all chains together) before a run's first sweep: about a
/// second and a half on one core. Calibration runs when the run is set up, before a caller
/// can interrupt it, so its bound is much tighter than [`MAX_PROPOSALS`]; the default
/// (2,000 samples) allows 10,000 chains.
pub const MAX_CALIBRATION_PROPOSALS: u64 = 20_000_000;

/// Proposals per second of one annealing chain on one core, measured on the rod
/// (docs/benchmarks/speed.md, "Annealing throughput": 11-15 million): only for the time in
/// messages.
pub const PROPOSALS_PER_SECOND: f64 = 15e6;

/// `count` of `what` (proposals) as a time on one core at [`PROPOSALS_PER_SECOND`], for
/// messages. O(1).
pub fn describe_proposals(count: u64, what: &str) -> String {
    let seconds = count as f64 / PROPOSALS_PER_SECOND;
    let time = if seconds < 120.0 {
        format!("{seconds:.0} s")
    } else if seconds < 2.0 * 3600.0 {
        format!("{:.0} minutes", seconds / 60.0)
    } else {
        format!("{:.0} hours", seconds / 3600.0)
    };
    format!("{count:.3e} {what} (about {time} on one core)")
}

/// `bytes` for messages: GiB, MiB or bytes. O(1).
pub fn describe_bytes(bytes: u64) -> String {
    const MIB: f64 = (1u64 << 20) as f64;
    const GIB: f64 = (1u64 << 30) as f64;
    let b = bytes as f64;
    if b >= GIB {
        format!("{:.1} GiB", b / GIB)
    } else if b >= MIB {
        format!("{:.1} MiB", b / MIB)
    } else {
        format!("{bytes} bytes")
    }
}

/// Memory this process may still allocate: the smallest of the physical memory and the
/// room left under the address-space and data-size limits (`ulimit -v`, `-d`), read from
/// `/proc`. `None` where `/proc` does not tell (not Linux): then only the fallible copies
/// guard. Deterministic on a machine: physical memory, not what other processes use now.
/// O(1) (three small files).
pub fn memory_available() -> Option<u64> {
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok()?;
    let mut room = kib_field(&meminfo, "MemTotal:")?;
    let limits = std::fs::read_to_string("/proc/self/limits").unwrap_or_default();
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    for (limit, used) in [
        ("Max address space", "VmSize:"),
        ("Max data size", "VmData:"),
    ] {
        if let Some(max) = soft_limit(&limits, limit) {
            let used = kib_field(&status, used).unwrap_or(0);
            room = room.min(max.saturating_sub(used));
        }
    }
    Some(room)
}

/// The value of a `Name:   123 kB` line, in bytes.
fn kib_field(text: &str, name: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(name))?;
    let kib: u64 = line[name.len()..].split_whitespace().next()?.parse().ok()?;
    Some(kib.saturating_mul(1024))
}

/// The soft limit of a `/proc/self/limits` row, in bytes; `None` when unlimited or absent.
fn soft_limit(limits: &str, name: &str) -> Option<u64> {
    let line = limits.lines().find(|l| l.starts_with(name))?;
    line[name.len()..].split_whitespace().next()?.parse().ok()
}

/// Refuses `bytes` of memory asked for by option `name` = `value` when this process cannot
/// have them (see [`memory_available`]). O(1).
pub fn check_memory(name: &'static str, value: impl ToString, bytes: u64) -> Result<()> {
    match memory_available() {
        Some(room) if bytes > room => Err(Error::TooCostly {
            name,
            value: value.to_string(),
            needs: format!("about {} of memory", describe_bytes(bytes)),
            limit: format!("the {} this process may use", describe_bytes(room)),
        }),
        _ => Ok(()),
    }
}

/// A copy of `src` whose allocation may fail (`try_reserve_exact`) instead of aborting.
/// O(len).
pub fn try_copy<T: Clone>(src: &[T]) -> std::result::Result<Vec<T>, TryReserveError> {
    let mut v = Vec::new();
    v.try_reserve_exact(src.len())?;
    v.extend_from_slice(src);
    Ok(v)
}

/// The error of a failed allocation of `bytes` that option `name` = `value` asked for.
pub fn allocation_failed(name: &'static str, value: impl ToString, bytes: u64) -> Error {
    Error::TooCostly {
        name,
        value: value.to_string(),
        needs: format!("about {} of memory", describe_bytes(bytes)),
        limit: "what the allocator could give".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn proc_fields_parse() {
        let meminfo = "MemTotal:       24684084 kB\nMemFree:  1 kB\n";
        assert_eq!(kib_field(meminfo, "MemTotal:"), Some(24_684_084 * 1024));
        assert_eq!(kib_field(meminfo, "VmSize:"), None);
        let limits = "Limit                     Soft Limit           Hard Limit           Units     \n\
                      Max data size             unlimited            unlimited            bytes     \n\
                      Max address space         1610612736           unlimited            bytes     \n";
        assert_eq!(soft_limit(limits, "Max data size"), None);
        assert_eq!(soft_limit(limits, "Max address space"), Some(1_610_612_736));
    }

    #[test]
    fn this_machine_has_some_memory_and_refuses_an_exabyte() {
        if let Some(room) = memory_available() {
            assert!(room > 1 << 20, "{room}");
            let e = check_memory("chains", 7, u64::MAX).unwrap_err();
            assert!(e.to_string().starts_with("chains=7 needs about"), "{e}");
        }
    }

    #[test]
    fn messages_read_well() {
        assert_eq!(describe_bytes(512), "512 bytes");
        assert_eq!(describe_bytes(3 << 30), "3.0 GiB");
        assert!(describe_proposals(15_000_000 * 3600 * 10, "proposals").contains("10 hours"));
        assert!(describe_proposals(30_000_000, "proposals").contains("2 s"));
    }

    #[test]
    fn try_copy_copies() {
        assert_eq!(try_copy(&[1, 2, 3]).unwrap(), vec![1, 2, 3]);
    }
}
