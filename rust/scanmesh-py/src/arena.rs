//! glibc's malloc arenas under an address-space limit.
//!
//! Why: glibc gives each thread that allocates an arena of its own and reserves 64 MiB of
//! address space for it (twice that while aligning it), which `RLIMIT_AS` (`ulimit -v`)
//! counts in full. Under such a limit a core worker's or a call's thread then failed its
//! first allocation with most of the room unused, and an allocation that cannot fail
//! aborted the process ("memory allocation of 16 bytes failed" with 120 MB of room, 2
//! merges in 10). The core's own buffers are fallible; these small ones are not.

/// Under an address-space limit, makes every thread allocate from glibc's main arena:
/// once, the first time such a limit is seen (a limit may be set after the pool started).
/// The price, contention on one arena's lock, is paid only under such a limit. O(1).
#[cfg(all(target_os = "linux", target_env = "gnu"))]
pub(crate) fn share_arena_under_address_limit() {
    use std::sync::atomic::{AtomicBool, Ordering::Relaxed};
    static SHARED: AtomicBool = AtomicBool::new(false);
    if SHARED.load(Relaxed) {
        return;
    }
    let mut limit = libc::rlimit {
        rlim_cur: libc::RLIM_INFINITY,
        rlim_max: libc::RLIM_INFINITY,
    };
    // SAFETY: getrlimit only writes the struct it is given.
    let read = unsafe { libc::getrlimit(libc::RLIMIT_AS, &mut limit) } == 0;
    if read && limit.rlim_cur != libc::RLIM_INFINITY {
        // SAFETY: mallopt only sets one of the allocator's tunables; any thread may call it.
        if unsafe { libc::mallopt(libc::M_ARENA_MAX, 1) } == 1 {
            SHARED.store(true, Relaxed);
        }
    }
}

/// Other allocators reserve no address space per thread: nothing to do.
#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
pub(crate) fn share_arena_under_address_limit() {}
