//! How far a long call has got, readable from another thread while it runs.
//!
//! Why: the long one-shot calls (Delaunay, the strips, fusion's integration and extraction)
//! run with the caller's thread waiting, so a caller that reports progress has nothing to
//! report until they return. Each such call takes a [`Progress`], plans the items its
//! passes will handle ([`Progress::plan`]) and counts them as they are done
//! ([`Progress::add`]), in batches of thousands, so that the count costs a relaxed atomic
//! add per batch; a watcher reads [`Progress::done`] of [`Progress::total`] at any time.

use std::sync::atomic::{AtomicU64, Ordering::Relaxed};

/// Items done of items planned by one long call, shared with a watcher: all updates are
/// relaxed atomics (a watcher needs no ordering, only a count that never goes back).
#[derive(Debug, Default)]
pub struct Progress {
    done: AtomicU64,
    total: AtomicU64,
}

impl Progress {
    /// Nothing planned, nothing done. O(1).
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds `items` to the items planned: a call plans its passes when it starts, so that
    /// the share done never goes back. O(1).
    pub fn plan(&self, items: u64) {
        self.total.fetch_add(items, Relaxed);
    }

    /// Counts `items` more done. O(1): called per batch, not per item, in hot loops.
    pub fn add(&self, items: u64) {
        self.done.fetch_add(items, Relaxed);
    }

    /// Items done so far.
    pub fn done(&self) -> u64 {
        self.done.load(Relaxed)
    }

    /// Items planned so far.
    pub fn total(&self) -> u64 {
        self.total.load(Relaxed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;

    #[test]
    fn counts_from_many_threads_reach_the_items_planned() {
        let p = Progress::new();
        p.plan(1_000_000);
        (0..1_000u64).into_par_iter().for_each(|_| p.add(1_000));
        assert_eq!((p.done(), p.total()), (1_000_000, 1_000_000));
    }
}
