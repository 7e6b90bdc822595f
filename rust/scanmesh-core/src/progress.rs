//! How far a long call has got, readable from another thread while it runs.
//!
//! Why: the long one-shot calls (Delaunay, the strips, fusion's integration and extraction)
//! run with the caller's thread waiting, so a caller that reports progress has nothing to
//! report until they return. Each such call takes a [`Progress`], plans the items its
//! passes will handle ([`Progress::plan`]) and counts them as they are done
//! ([`Progress::add`]), in batches of thousands, so that the count costs a relaxed atomic
//! add per batch; a watcher reads [`Progress::done`] of [`Progress::total`] at any time. A
//! pass whose number of items is known only when it starts counts them as a [`Share`] of
//! what was planned for it.

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

/// One pass of a call counted as `weight` of its planned items whatever number of `items`
/// it turns out to have (known only once it starts: the cells a mesh crosses): each item
/// adds its share, the shares summing to `weight` exactly.
#[derive(Debug)]
pub struct Share<'a> {
    progress: &'a Progress,
    weight: u64,
    items: u64,
    seen: AtomicU64,
}

impl<'a> Share<'a> {
    /// A pass of `items` items worth `weight` planned items of `progress`. O(1).
    pub fn new(progress: &'a Progress, weight: u64, items: u64) -> Self {
        Self {
            progress,
            weight,
            items,
            seen: AtomicU64::new(0),
        }
    }

    /// Counts `items` more of the pass done (from any thread). O(1).
    pub fn add(&self, items: u64) {
        let before = self.seen.fetch_add(items, Relaxed);
        self.progress
            .add(self.part(before.saturating_add(items)) - self.part(before));
    }

    /// Counts the rest of the pass (a pass that ended early, or one of no items). O(1).
    pub fn finish(self) {
        let seen = self.seen.load(Relaxed);
        if self.items == 0 {
            self.progress.add(self.weight);
        } else if seen < self.items {
            self.add(self.items - seen);
        }
    }

    /// The planned items `seen` items of the pass are worth.
    fn part(&self, seen: u64) -> u64 {
        let share = u128::from(seen.min(self.items)) * u128::from(self.weight);
        (share / u128::from(self.items.max(1))) as u64
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

    #[test]
    fn a_share_adds_its_weight_whatever_its_items() {
        for (weight, items, step) in [(10, 3, 1), (7, 1_000, 3), (1_000, 7, 2), (5, 0, 1)] {
            let p = Progress::new();
            p.plan(weight);
            let share = Share::new(&p, weight, items);
            let mut last = 0;
            for _ in 0..items / step {
                share.add(step);
                assert!(p.done() >= last && p.done() <= weight);
                last = p.done();
            }
            share.finish();
            assert_eq!(p.done(), weight, "{weight} {items} {step}");
        }
    }
}
