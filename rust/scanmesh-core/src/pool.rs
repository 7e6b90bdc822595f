//! The global thread pool, started with the worker threads this process has room for.
//!
//! Why: rayon starts its global pool at the first parallel call, and when a worker's stack
//! cannot be mapped (under an address-space limit, `ulimit -v`) it panics there; the panic's
//! own allocations then fail too, and the process hung or aborted. A failed start cannot be
//! retried either: rayon sets its global pool once, and every later parallel call panics.
//! So [`start_pool`] starts the workers' threads itself first, each one parked until the
//! pool hands it its work loop, and builds the pool over the threads that did start: the
//! pool's own spawning cannot fail then. Fewer threads than asked for make a smaller pool;
//! none is an [`Error::OutOfMemory`], and the pool is left unbuilt so that a later call may
//! try again (after memory was freed or the limit raised).
//!
//! Callers that enter the core from outside (the Python binding) call [`start_pool`]
//! before any parallel work.

use crate::budget::memory_room;
use crate::{Error, Result};
use rayon::ThreadBuilder;
use std::sync::mpsc::{channel, Sender};
use std::sync::{Mutex, OnceLock, PoisonError};

/// Stack of each worker thread, in bytes: Rust's default for a spawned thread, what
/// rayon's workers had when rayon started them.
pub const WORKER_STACK_BYTES: usize = 2 << 20;

/// The number of workers of the started pool.
static STARTED: OnceLock<usize> = OnceLock::new();

/// Held while a start is tried, so that two callers never both build the pool.
static STARTING: Mutex<()> = Mutex::new(());

/// Starts the global pool if it is not running yet, with `RAYON_NUM_THREADS` workers (when
/// set to a positive number, else one per core) or as many of them as fit; returns the
/// number of workers. O(threads) the first time, O(1) after.
///
/// Raises [`Error::OutOfMemory`] naming the threads, their stack and the memory limit when
/// not even one worker's thread starts; nothing is built then.
pub fn start_pool() -> Result<usize> {
    if let Some(&threads) = STARTED.get() {
        return Ok(threads);
    }
    let _starting = STARTING.lock().unwrap_or_else(PoisonError::into_inner);
    if let Some(&threads) = STARTED.get() {
        return Ok(threads);
    }
    let wanted = wanted_threads();
    let mut parked: Vec<Sender<ThreadBuilder>> = Vec::with_capacity(wanted);
    let mut refused = None;
    for index in 0..wanted {
        let (hand, work) = channel::<ThreadBuilder>();
        let spawned = std::thread::Builder::new()
            .name(format!("scanmesh-worker-{index}"))
            .stack_size(WORKER_STACK_BYTES)
            // a thread whose sender is dropped unused (the pool was started elsewhere) ends
            .spawn(move || work.recv().map_or((), ThreadBuilder::run));
        match spawned {
            Ok(_) => parked.push(hand),
            Err(e) => {
                refused = Some(e);
                break;
            }
        }
    }
    if parked.is_empty() {
        let limit = memory_room().map_or_else(|| "what the system gives".to_string(), |r| r.limit);
        let reason = refused.map_or_else(String::new, |e| format!(": {e}"));
        return Err(Error::OutOfMemory {
            what: format!(
                "the core's thread pool ({wanted} worker threads, none could start{reason})"
            ),
            needs: WORKER_STACK_BYTES as u64,
            limit,
        });
    }
    let threads = parked.len();
    let built = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .spawn_handler(move |worker| {
            // infallible: the thread is running, the send wakes it
            let _ = parked[worker.index()].send(worker);
            Ok(())
        })
        .build_global();
    // already built (a parallel call before this one): the parked threads end unused
    let threads = if built.is_ok() {
        threads
    } else {
        rayon::current_num_threads()
    };
    Ok(*STARTED.get_or_init(|| threads))
}

/// Workers asked for: `RAYON_NUM_THREADS` when a positive number (rayon's own rule), else
/// one per core. O(1).
fn wanted_threads() -> usize {
    std::env::var("RAYON_NUM_THREADS")
        .ok()
        .and_then(|s| s.parse::<usize>().ok())
        .filter(|&n| n > 0)
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;

    #[test]
    fn the_pool_starts_once_and_runs_parallel_work() {
        let threads = start_pool().unwrap();
        assert!(threads >= 1);
        assert_eq!(start_pool().unwrap(), threads);
        assert_eq!(rayon::current_num_threads(), threads);
        let sum: u64 = (0..10_000u64).into_par_iter().sum();
        assert_eq!(sum, 10_000 * 9_999 / 2);
    }
}
