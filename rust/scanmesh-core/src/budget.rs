//! What a run may cost: limits on the work and memory an option can ask for, this machine's
//! memory, and copies whose allocation may fail.
//!
//! Why: options multiply work and memory (chains × sweeps × edges proposals, chains ×
//! state bytes), so a few digits too many turn a run into one that never ends or that
//! aborts the process when an allocation fails (Rust's default on a failed allocation).
//! Every such product is checked before the work starts, and the copies an option
//! multiplies are made with `try_reserve`, so both end in an [`Error::TooCostly`] that names
//! the option.

use crate::error::describe_bytes;
use crate::{Error, Result};
use rayon::prelude::*;
use std::collections::TryReserveError;
use std::ops::Range;

/// Items one task of [`try_filled`] writes at least.
const FILL_BLOCK: usize = 1 << 16;

/// Indices one task of [`try_indices`]' count takes at least: below this, splitting costs
/// more than it saves.
const COUNT_BLOCK: usize = 1 << 14;

/// Most flip proposals (calibration included, all chains together) one annealing run may
/// plan: about 18 hours on one core at [`PROPOSALS_PER_SECOND`]; 3,000 sweeps on a million
/// points plan 9 × 10^9.
pub(crate) const MAX_PROPOSALS: u64 = 1_000_000_000_000;

/// Most calibration proposals (all chains together) before a run's first sweep: about a
/// second and a half on one core. Calibration runs when the run is set up, before a caller
/// can interrupt it, so its bound is much tighter than [`MAX_PROPOSALS`]; the default
/// (2,000 samples) allows 10,000 chains.
pub(crate) const MAX_CALIBRATION_PROPOSALS: u64 = 20_000_000;

/// Proposals per second of one annealing chain on one core, measured on the rod
/// (docs/benchmarks/speed.md, "Annealing throughput": 11-15 million): only for the time in
/// messages.
pub(crate) const PROPOSALS_PER_SECOND: f64 = 15e6;

/// `count` of `what` (proposals) as a time on one core at [`PROPOSALS_PER_SECOND`], for
/// messages. O(1).
pub(crate) fn describe_proposals(count: u64, what: &str) -> String {
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

/// The memory this process may still allocate and the limit that leaves it ("the 520.3 MiB
/// left under RLIMIT_AS (ulimit -v) of 700.0 MiB"), for messages.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Room {
    /// Bytes this process may still allocate.
    pub bytes: u64,
    /// The limit that leaves them, for messages.
    pub limit: String,
}

/// Memory this process may still allocate: the smallest of the physical memory, the room
/// left under the address-space and data-size limits (`RLIMIT_AS`, `RLIMIT_DATA`: `ulimit
/// -v`, `-d`) and under its cgroup's `memory.max` (a container's limit), read from `/proc`
/// and `/sys/fs/cgroup`. `None` where `/proc` does not tell (not Linux): then only the
/// fallible copies guard. Physical memory, not what other processes use now; the cgroup's
/// room is its limit less its current use, since exceeding it kills the process. O(1)
/// (a few small files).
pub(crate) fn memory_room() -> Option<Room> {
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok()?;
    let total = kib_field(&meminfo, "MemTotal:")?;
    let mut room = Room {
        bytes: total,
        limit: format!("the {} of physical memory", describe_bytes(total)),
    };
    let mut tighten = |bytes: u64, limit: String| {
        if bytes < room.bytes {
            room = Room { bytes, limit };
        }
    };
    let limits = std::fs::read_to_string("/proc/self/limits").unwrap_or_default();
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    for (limit, used, name) in [
        ("Max address space", "VmSize:", "RLIMIT_AS (ulimit -v)"),
        ("Max data size", "VmData:", "RLIMIT_DATA (ulimit -d)"),
    ] {
        if let Some(max) = soft_limit(&limits, limit) {
            let left = max.saturating_sub(kib_field(&status, used).unwrap_or(0));
            let of = describe_bytes(max);
            tighten(
                left,
                format!("the {} left under {name} of {of}", describe_bytes(left)),
            );
        }
    }
    if let Some((max, current)) = cgroup_memory() {
        let left = max.saturating_sub(current);
        let of = describe_bytes(max);
        let text = format!(
            "the {} left under the cgroup's memory.max of {of}",
            describe_bytes(left)
        );
        tighten(left, text);
    }
    Some(room)
}

/// Memory this process may still allocate, in bytes: [`memory_room`]'s. O(1).
pub(crate) fn memory_available() -> Option<u64> {
    memory_room().map(|room| room.bytes)
}

/// This process's cgroup (v2) `memory.max` and `memory.current` in bytes; `None` without
/// a cgroup v2 limit.
fn cgroup_memory() -> Option<(u64, u64)> {
    let cgroup = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    let path = cgroup.lines().find_map(|l| l.strip_prefix("0::"))?.trim();
    let dir = std::path::Path::new("/sys/fs/cgroup").join(path.trim_start_matches('/'));
    let read = |name: &str| std::fs::read_to_string(dir.join(name)).ok();
    let max = read("memory.max")?.trim().parse().ok()?; // "max" when unlimited
    let current = read("memory.current")?.trim().parse().unwrap_or(0);
    Some((max, current))
}

/// Refuses a stage whose peak memory, estimated from its input as `bytes`, this process
/// cannot have: `what` names the stage and its input ("Delaunay of 2000000 points"). Beyond
/// the limits read by [`memory_room`], the estimate is reserved once (address space only:
/// nothing is touched) and freed, so a limit `/proc` does not show refuses too.
///
/// What the core allocates itself and sizes from the input is fallible besides
/// ([`try_vec`] and the helpers below); `spade` and `delaunator` allocate inside and cannot
/// be made so: their peak is guarded by this estimate, checked before the call. O(1).
pub(crate) fn check_stage(what: impl FnOnce() -> String, bytes: u64) -> Result<()> {
    let refuse = |limit: String| Error::OutOfMemory {
        what: what(),
        needs: bytes,
        limit,
    };
    if let Some(room) = memory_room() {
        if bytes > room.bytes {
            return Err(refuse(room.limit));
        }
    }
    let mut probe: Vec<u8> = Vec::new();
    match usize::try_from(bytes)
        .ok()
        .map(|b| probe.try_reserve_exact(b))
    {
        Some(Ok(())) => Ok(()),
        _ => Err(refuse("what the allocator could give".into())),
    }
}

/// An empty vector with room for `len` items of `T`, whose allocation may fail (an
/// [`Error::OutOfMemory`] naming `what`) instead of aborting the process. O(1).
pub fn try_vec<T>(what: &str, len: usize) -> Result<Vec<T>> {
    let mut v = Vec::new();
    v.try_reserve_exact(len)
        .map_err(|_| not_allocated::<T>(what, len))?;
    Ok(v)
}

/// Room in `v` for `additional` more items of `T`, grown as a push would grow it
/// (amortized doubling) but by an allocation that may fail (an [`Error::OutOfMemory`]
/// naming `what`) instead of aborting the process: for buffers that grow with the input
/// while a stage runs (LOP's edge stack). O(len) when it grows, else O(1).
pub(crate) fn try_grow<T>(what: &str, v: &mut Vec<T>, additional: usize) -> Result<()> {
    v.try_reserve(additional)
        .map_err(|_| not_allocated::<T>(what, v.len().saturating_add(additional)))
}

/// The error of a failed allocation of `len` items of `T` for `what`: for containers the
/// helpers above do not build (a heap's `try_reserve`). O(1).
pub(crate) fn not_allocated<T>(what: &str, len: usize) -> Error {
    Error::OutOfMemory {
        what: format!("{what} ({len} items)"),
        needs: (len as u64).saturating_mul(std::mem::size_of::<T>() as u64),
        limit: "what the allocator could give".into(),
    }
}

/// `len` copies of `value` in a vector whose allocation may fail (an
/// [`Error::OutOfMemory`] naming `what`) instead of aborting the process. O(len), written
/// on every core when long: a fresh buffer's first write is its page faults, which cost
/// more than the writes.
pub fn try_filled<T: Clone + Send + Sync>(what: &str, value: T, len: usize) -> Result<Vec<T>> {
    let mut v = try_vec(what, len)?;
    if len < FILL_BLOCK {
        v.resize(len, value);
    } else {
        // an indexed extend writes into the room reserved, without growing it
        v.par_extend(rayon::iter::repeat_n(value, len).with_min_len(FILL_BLOCK));
    }
    Ok(v)
}

/// The items of `items` in a vector allocated once for all of them, an allocation that may
/// fail (an [`Error::OutOfMemory`] naming `what`) instead of aborting the process. O(len).
pub(crate) fn try_collect<T>(
    what: &str,
    items: impl ExactSizeIterator<Item = T>,
) -> Result<Vec<T>> {
    let mut v = try_vec(what, items.len())?;
    v.extend(items);
    Ok(v)
}

/// The items of the indexed parallel iterator `items`, in order, in a vector allocated once
/// for all of them, an allocation that may fail (an [`Error::OutOfMemory`] naming `what`)
/// instead of aborting the process: [`try_collect`] on every core. O(len).
pub(crate) fn try_par_collect<T: Send>(
    what: &str,
    items: impl IndexedParallelIterator<Item = T>,
) -> Result<Vec<T>> {
    let mut v = try_vec(what, items.len())?;
    // An indexed extend writes into the room reserved, without growing it.
    v.par_extend(items);
    Ok(v)
}

/// The indices in `all` for which `keep` holds, ascending, in a vector allocated once for
/// exactly them, an allocation that may fail (an [`Error::OutOfMemory`] naming `what`)
/// instead of aborting the process. They are counted on every core first, so the buffer
/// is never grown; `keep` is asked twice per index and must answer the same. O(len).
pub(crate) fn try_indices<I>(
    what: &str,
    all: Range<I>,
    keep: impl Fn(I) -> bool + Sync,
) -> Result<Vec<I>>
where
    I: Copy + Send + Sync,
    Range<I>: ExactSizeIterator<Item = I>,
{
    // Blocks of COUNT_BLOCK indices: each counts its kept ones, then writes them into its
    // own share of the buffer (Range's skip is O(1)), so neither pass runs on one core.
    let block = |k: usize| {
        all.clone()
            .skip(k * COUNT_BLOCK)
            .take(COUNT_BLOCK)
            .filter(|&i| keep(i))
    };
    let counts: Vec<usize> = (0..all.len().div_ceil(COUNT_BLOCK))
        .into_par_iter()
        .map(|k| block(k).count())
        .collect();
    let mut v = try_filled(what, all.start, counts.iter().sum())?;
    shares_mut(&mut v, &counts)
        .into_par_iter()
        .enumerate()
        .for_each(|(k, share)| {
            for (slot, i) in share.iter_mut().zip(block(k)) {
                *slot = i;
            }
        });
    Ok(v)
}

/// `buffer` cut into consecutive shares of `counts[k]` items each, for tasks that write
/// their own part of one buffer in parallel. Panics if the counts exceed its length. O(k).
pub(crate) fn shares_mut<'a, T>(mut buffer: &'a mut [T], counts: &[usize]) -> Vec<&'a mut [T]> {
    counts
        .iter()
        .map(|&count| {
            let (share, rest) = std::mem::take(&mut buffer).split_at_mut(count);
            buffer = rest;
            share
        })
        .collect()
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
pub(crate) fn check_memory(name: &'static str, value: impl ToString, bytes: u64) -> Result<()> {
    match memory_room() {
        Some(room) if bytes > room.bytes => Err(Error::TooCostly {
            name,
            value: value.to_string(),
            needs: format!("about {} of memory", describe_bytes(bytes)),
            limit: room.limit,
        }),
        _ => Ok(()),
    }
}

/// A copy of `src` whose allocation may fail (`try_reserve_exact`) instead of aborting.
/// O(len).
pub(crate) fn try_copy<T: Clone>(src: &[T]) -> std::result::Result<Vec<T>, TryReserveError> {
    let mut v = Vec::new();
    v.try_reserve_exact(src.len())?;
    v.extend_from_slice(src);
    Ok(v)
}

/// The error of a failed allocation of `bytes` that option `name` = `value` asked for.
pub(crate) fn allocation_failed(name: &'static str, value: impl ToString, bytes: u64) -> Error {
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
    fn allocations_too_large_to_give_are_errors_not_aborts() {
        // Half the address space of u64s: no allocator gives it (capacity overflow or
        // refusal), and either way the answer is an error naming the buffer.
        for len in [usize::MAX / 16, isize::MAX as usize / 8 + 1] {
            match try_filled("test buffer", 0u64, len) {
                Err(Error::OutOfMemory { what, .. }) => assert!(what.contains("test buffer")),
                other => panic!("{len}: {:?}", other.map(|v| v.len())),
            }
        }
        let huge = (0..usize::MAX / 16).map(|_| 0u64);
        assert!(matches!(
            try_collect("test items", huge),
            Err(Error::OutOfMemory { .. })
        ));
        assert_eq!(try_filled("small", 7u8, 3).unwrap(), vec![7, 7, 7]);
        assert_eq!(try_collect("small", 0..4).unwrap(), vec![0, 1, 2, 3]);
        let huge = (0..usize::MAX / 16).into_par_iter().map(|_| 0u64);
        assert!(matches!(
            try_par_collect("test items", huge),
            Err(Error::OutOfMemory { .. })
        ));
        let squares = try_par_collect("small", (0..1000u32).into_par_iter().map(|k| k * k));
        assert_eq!(
            squares.unwrap(),
            (0..1000u32).map(|k| k * k).collect::<Vec<_>>()
        );
    }

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
    fn stages_beyond_memory_are_refused_and_failed_allocations_are_errors() {
        let e = check_stage(|| "Delaunay of 7 points".into(), u64::MAX).unwrap_err();
        assert!(
            e.to_string()
                .starts_with("Delaunay of 7 points needs about"),
            "{e}"
        );
        assert!(check_stage(|| "a small stage".into(), 1 << 20).is_ok());
        let e = try_vec::<u64>("edges", usize::MAX / 16).unwrap_err();
        assert!(matches!(e, Error::OutOfMemory { .. }), "{e}");
        assert!(try_vec::<u64>("edges", 10).unwrap().capacity() >= 10);
        let mut v = vec![1u64];
        let e = try_grow("a stack", &mut v, usize::MAX / 16).unwrap_err();
        assert!(e.to_string().starts_with("a stack ("), "{e}");
        try_grow("a stack", &mut v, 100).unwrap();
        assert!(v.capacity() >= 101 && v == [1]);
    }

    #[test]
    fn indices_are_listed_in_order_and_counted_exactly() {
        let odd = try_indices("odd", 0..100_000u32, |i| i % 2 == 1).unwrap();
        assert_eq!(
            odd,
            (0..100_000u32).filter(|i| i % 2 == 1).collect::<Vec<_>>()
        );
        assert!(try_indices("none", 0..10usize, |_| false)
            .unwrap()
            .is_empty());
    }

    #[test]
    fn try_copy_copies() {
        assert_eq!(try_copy(&[1, 2, 3]).unwrap(), vec![1, 2, 3]);
    }
}
