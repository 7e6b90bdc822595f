//! The fusion grid's storage: blocks of [`BLOCK`]³ nodes, a block either uniform (every
//! node the same state, no distance measured: the space far in front of a surface, or
//! behind it) in 4 bytes, or allocated: with its nodes' distance sum, weight and flags (9
//! bytes per node) where some view's truncation band crosses it, with their flags alone
//! (1 byte per node) where only a silhouette or a carving edge does. So memory grows with
//! the surface, not with its box (hashed voxel blocks: Nießner et al. 2013, here with a
//! flat index of 4 bytes per block).

use crate::budget;
use crate::error::{Error, Result};
use rayon::prelude::*;

/// Nodes along each side of a block.
pub const BLOCK: usize = 8;

/// Nodes in a block.
pub(super) const BLOCK_NODES: usize = BLOCK * BLOCK * BLOCK;

/// Index entry bit: the block is uniform, its nodes' flags in the low 8 bits.
const UNIFORM: u32 = 1 << 31;

/// Index entry bit: the block holds its nodes' flags alone, at the slot in the low bits.
const FLAGS: u32 = 1 << 30;

/// A flags slot given up for a distance slot.
const FREED: u32 = u32::MAX;

/// What a block holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Entry {
    /// Every node: no distance, these flags.
    Uniform(u8),
    /// Its nodes' flags at this flags slot, no distance.
    Flags(usize),
    /// Its nodes' distances and flags at this slot.
    Slot(usize),
}

/// Where a grid's nodes fall in its blocks (copied into parallel loops).
#[derive(Debug, Clone, Copy)]
pub(super) struct Layout {
    dims: [usize; 3],
    /// Blocks along x, y, z.
    counts: [usize; 3],
}

impl Layout {
    /// Blocks along x, y, z.
    pub(super) fn counts(&self) -> [usize; 3] {
        self.counts
    }

    /// Nodes along x, y, z.
    pub(super) fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// Block `b`'s coordinates (in blocks).
    pub(super) fn coords(&self, b: usize) -> [usize; 3] {
        let [bx, by, _] = self.counts;
        [b % bx, (b / bx) % by, b / (bx * by)]
    }

    /// The block at block coordinates `c`.
    pub(super) fn at(&self, c: [usize; 3]) -> usize {
        (c[2] * self.counts[1] + c[1]) * self.counts[0] + c[0]
    }

    /// The block of node (i, j, k) and the node's place in it.
    pub(super) fn locate(&self, [i, j, k]: [usize; 3]) -> (usize, usize) {
        let b = self.at([i / BLOCK, j / BLOCK, k / BLOCK]);
        let local = ((k % BLOCK) * BLOCK + j % BLOCK) * BLOCK + i % BLOCK;
        (b, local)
    }

    /// The nodes of block `b` inside the grid: lowest and highest (inclusive) coordinates.
    pub(super) fn nodes(&self, b: usize) -> [[usize; 3]; 2] {
        let c = self.coords(b);
        let lo = c.map(|v| v * BLOCK);
        let hi = std::array::from_fn(|a| (lo[a] + BLOCK).min(self.dims[a]) - 1);
        [lo, hi]
    }
}

/// The blocks of a grid of `dims` nodes.
#[derive(Debug, Clone)]
pub(super) struct Blocks {
    layout: Layout,
    /// Per block, x fastest: `UNIFORM | flags`, or its slot.
    index: Vec<u32>,
    /// Per slot, [`BLOCK_NODES`] each, x fastest within the block: the distance sums.
    pub(super) sum: Vec<f32>,
    /// The weights, as `sum`.
    pub(super) weight: Vec<f32>,
    /// The flags, as `sum`.
    pub(super) flags: Vec<u8>,
    /// Per slot: its block.
    pub(super) owner: Vec<u32>,
    /// Per flags slot, [`BLOCK_NODES`] each: the flags of a block with no distance.
    pub(super) marks: Vec<u8>,
    /// Per flags slot: its block, or [`FREED`].
    pub(super) marks_owner: Vec<u32>,
    /// Slots of both kinds at most.
    max_slots: usize,
}

impl Blocks {
    /// Every block of a grid of `dims` nodes uniform with no evidence. O(nodes / 512), 4
    /// bytes per block.
    ///
    /// Errors: `OutOfMemory` when the index does not fit; `InvalidParameter` when it has
    /// 2³⁰ blocks or more.
    pub(super) fn new(dims: [usize; 3]) -> Result<Self> {
        let counts = dims.map(|d| d.div_ceil(BLOCK));
        let n = counts.iter().try_fold(1usize, |a, &c| a.checked_mul(c));
        let n = n
            .filter(|&n| n < FLAGS as usize)
            .ok_or_else(|| Error::InvalidParameter {
                name: "dims",
                value: format!("{dims:?}"),
                expected: "fewer than 2^30 blocks of 8³ nodes",
            })?;
        Ok(Self {
            layout: Layout { dims, counts },
            index: budget::try_filled("the fusion grid's block index", UNIFORM, n)?,
            sum: Vec::new(),
            weight: Vec::new(),
            flags: Vec::new(),
            owner: Vec::new(),
            marks: Vec::new(),
            marks_owner: Vec::new(),
            max_slots: usize::MAX,
        })
    }

    /// At most `max_nodes` nodes allocated (whole blocks) from now on.
    pub(super) fn limit(&mut self, max_nodes: usize) {
        self.max_slots = max_nodes / BLOCK_NODES;
    }

    /// Where nodes fall.
    pub(super) fn layout(&self) -> Layout {
        self.layout
    }

    /// Blocks in all.
    pub(super) fn len(&self) -> usize {
        self.index.len()
    }

    /// Nodes allocated (whole blocks) with a distance (9 bytes each) and with flags alone
    /// (1 byte each; those given up or made uniform again included: their room is kept).
    pub(super) fn allocated(&self) -> [usize; 2] {
        [self.owner.len(), self.marks_owner.len()].map(|s| s * BLOCK_NODES)
    }

    /// The nodes of block `b` inside the grid: lowest and highest (inclusive) coordinates.
    pub(super) fn nodes(&self, b: usize) -> [[usize; 3]; 2] {
        self.layout.nodes(b)
    }

    /// What block `b` holds.
    pub(super) fn entry(&self, b: usize) -> Entry {
        let e = self.index[b];
        if e & UNIFORM != 0 {
            Entry::Uniform(e as u8)
        } else if e & FLAGS != 0 {
            Entry::Flags((e & !FLAGS) as usize)
        } else {
            Entry::Slot(e as usize)
        }
    }

    /// The state (distance sum, weight, flags) of node (i, j, k). O(1).
    pub(super) fn state(&self, node: [usize; 3]) -> (f32, f32, u8) {
        let (b, local) = self.layout.locate(node);
        match self.entry(b) {
            Entry::Uniform(flags) => (0.0, 0.0, flags),
            Entry::Flags(s) => (0.0, 0.0, self.marks[s * BLOCK_NODES + local]),
            Entry::Slot(s) => {
                let at = s * BLOCK_NODES + local;
                (self.sum[at], self.weight[at], self.flags[at])
            }
        }
    }

    /// Sets the flags every node of uniform block `b` shares.
    pub(super) fn set_uniform(&mut self, b: usize, flags: u8) {
        debug_assert!(matches!(self.entry(b), Entry::Uniform(_)));
        self.index[b] = UNIFORM | u32::from(flags);
    }

    /// Refuses a slot more beyond the nodes allowed (`TooCostly`, `max_voxels`): a node
    /// with its flags alone counts as a ninth (1 byte against 9), every flags slot ever
    /// taken counted, so the blocks never hold more than 9 bytes per node allowed.
    fn check_room(&self, distances: bool) -> Result<()> {
        let used = 9 * self.owner.len() + self.marks_owner.len();
        let more = if distances { 9 } else { 1 };
        if used + more <= self.max_slots.saturating_mul(9) {
            return Ok(());
        }
        Err(Error::TooCostly {
            name: "max_voxels",
            value: (self.max_slots * BLOCK_NODES).to_string(),
            needs: format!(
                "more voxels near the surface than that (blocks of {BLOCK}³ allocated where a \
                 view's truncation band, silhouette or carving edge passes; a node with \
                 flags alone counts as a ninth)"
            ),
            limit: "the voxels allowed: raise max_voxels or the voxel".into(),
        })
    }

    /// Makes uniform again each block of flags alone whose nodes are all seen empty, or
    /// none is: once no distance can come (every view integrated), a node without one is
    /// empty or unseen by that bit alone, its votes counting no more. O(flags slots · 512),
    /// on every core.
    pub(super) fn settle_flags(&mut self, empty: u8) {
        let layout = self.layout;
        let settled: Vec<Option<u8>> = self
            .marks_owner
            .par_iter()
            .zip(self.marks.par_chunks(BLOCK_NODES))
            .map(|(&b, marks)| {
                if b == FREED {
                    return None;
                }
                let mut nodes =
                    block_nodes(layout.nodes(b as usize)).map(|(_, n)| marks[n] & empty);
                let first = nodes.next()?;
                nodes.all(|m| m == first).then_some(first)
            })
            .collect();
        for (s, flags) in settled.into_iter().enumerate() {
            if let Some(flags) = flags {
                self.index[self.marks_owner[s] as usize] = UNIFORM | u32::from(flags);
                self.marks_owner[s] = FREED;
            }
        }
    }

    /// Gives uniform block `b` its nodes' flags (the state it stood for), for a view that
    /// changes them node by node without a distance. O(512).
    ///
    /// Errors: `TooCostly` (`max_voxels`) beyond the nodes allowed; `OutOfMemory` when
    /// the slots do not fit.
    pub(super) fn allocate_flags(&mut self, b: usize) -> Result<()> {
        let Entry::Uniform(flags) = self.entry(b) else {
            return Ok(());
        };
        self.check_room(false)?;
        let what = "the fusion grid's blocks";
        budget::try_grow(what, &mut self.marks, BLOCK_NODES)?;
        budget::try_grow(what, &mut self.marks_owner, 1)?;
        let slot = self.marks_owner.len();
        self.marks.resize(self.marks.len() + BLOCK_NODES, flags);
        self.marks_owner.push(b as u32);
        self.index[b] = FLAGS | slot as u32;
        Ok(())
    }

    /// Gives block `b` its nodes' distances and flags, in the state it stood for (a
    /// uniform block's, or a flags slot's, which is given up). O(512).
    ///
    /// Errors: `TooCostly` (`max_voxels`) beyond the nodes allowed; `OutOfMemory` when
    /// the slots do not fit.
    pub(super) fn allocate(&mut self, b: usize) -> Result<()> {
        let entry = self.entry(b);
        if let Entry::Slot(_) = entry {
            return Ok(());
        }
        self.check_room(true)?;
        let what = "the fusion grid's blocks";
        budget::try_grow(what, &mut self.sum, BLOCK_NODES)?;
        budget::try_grow(what, &mut self.weight, BLOCK_NODES)?;
        budget::try_grow(what, &mut self.flags, BLOCK_NODES)?;
        budget::try_grow(what, &mut self.owner, 1)?;
        let slot = self.owner.len();
        self.sum.resize(self.sum.len() + BLOCK_NODES, 0.0);
        self.weight.resize(self.weight.len() + BLOCK_NODES, 0.0);
        match entry {
            Entry::Flags(s) => {
                let from = s * BLOCK_NODES;
                self.flags
                    .extend_from_slice(&self.marks[from..from + BLOCK_NODES]);
                self.marks_owner[s] = FREED;
            }
            Entry::Uniform(flags) => self.flags.resize(self.flags.len() + BLOCK_NODES, flags),
            Entry::Slot(_) => unreachable!("returned above"),
        }
        self.owner.push(b as u32);
        self.index[b] = slot as u32;
        Ok(())
    }

    /// The allocated blocks, on every core: (block, its sums, weights, flags).
    #[allow(clippy::type_complexity)]
    pub(super) fn par_slots_mut(
        &mut self,
    ) -> impl IndexedParallelIterator<Item = (usize, ((&mut [f32], &mut [f32]), &mut [u8]))> + '_
    {
        self.owner.par_iter().map(|&b| b as usize).zip(
            self.sum
                .par_chunks_mut(BLOCK_NODES)
                .zip(self.weight.par_chunks_mut(BLOCK_NODES))
                .zip(self.flags.par_chunks_mut(BLOCK_NODES)),
        )
    }

    /// The blocks holding their flags alone, on every core: (block, their flags).
    pub(super) fn par_marks_mut(
        &mut self,
    ) -> impl ParallelIterator<Item = (usize, &mut [u8])> + '_ {
        self.marks_owner
            .par_iter()
            .zip(self.marks.par_chunks_mut(BLOCK_NODES))
            .filter(|(&b, _)| b != FREED)
            .map(|(&b, marks)| (b as usize, marks))
    }
}

/// The coordinates (within the grid) of the nodes of a block between `lo` and `hi`
/// (inclusive), with their place in the block, x fastest.
pub(super) fn block_nodes([lo, hi]: [[usize; 3]; 2]) -> impl Iterator<Item = ([usize; 3], usize)> {
    (lo[2]..=hi[2]).flat_map(move |k| {
        (lo[1]..=hi[1]).flat_map(move |j| {
            (lo[0]..=hi[0]).map(move |i| {
                let local = ((k % BLOCK) * BLOCK + j % BLOCK) * BLOCK + i % BLOCK;
                ([i, j, k], local)
            })
        })
    })
}

#[cfg(test)]
mod tests {
    use super::super::testing::assert_beyond_max_voxels;
    use super::*;

    #[test]
    fn blocks_are_allocated_on_demand_and_nodes_found_in_them() {
        let mut blocks = Blocks::new([20, 9, 8]).unwrap();
        assert_eq!(blocks.layout().counts(), [3, 2, 1]);
        assert_eq!(blocks.allocated(), [0, 0]);
        blocks.set_uniform(blocks.layout().at([2, 1, 0]), 5);
        assert_eq!(blocks.state([19, 8, 7]), (0.0, 0.0, 5));
        let b = blocks.layout().at([2, 1, 0]);
        blocks.allocate(b).unwrap();
        assert_eq!(blocks.entry(b), Entry::Slot(0));
        assert_eq!(blocks.allocated(), [BLOCK_NODES, 0]);
        // the block's nodes inside the grid: x 16..=19, y 8..=8, z 0..=7
        assert_eq!(blocks.nodes(b), [[16, 8, 0], [19, 8, 7]]);
        let nodes: Vec<_> = block_nodes(blocks.nodes(b)).collect();
        assert_eq!(nodes.len(), 4 * 8);
        for (_, ((sum, _), flags)) in blocks.par_slots_mut().collect::<Vec<_>>() {
            for (node, local) in block_nodes([[16, 8, 0], [19, 8, 7]]) {
                sum[local] = (node[0] * 100 + node[2]) as f32;
                assert_eq!(flags[local], 5, "allocated in the uniform state");
            }
        }
        assert_eq!(blocks.state([18, 8, 3]).0, 1803.0);
        // another block stays uniform
        assert_eq!(blocks.state([3, 3, 3]), (0.0, 0.0, 0));
        // allocating twice keeps one slot
        blocks.allocate(b).unwrap();
        assert_eq!(blocks.allocated(), [BLOCK_NODES, 0]);
        // a block of flags alone keeps them when it gets distances
        let c = blocks.layout().at([0, 1, 0]);
        blocks.set_uniform(c, 3);
        blocks.allocate_flags(c).unwrap();
        assert_eq!(blocks.entry(c), Entry::Flags(0));
        let (_, marks) = blocks.par_marks_mut().collect::<Vec<_>>().pop().unwrap();
        marks[1] = 9;
        assert_eq!(blocks.state([1, 8, 0]), (0.0, 0.0, 9));
        assert_eq!(blocks.state([2, 8, 0]), (0.0, 0.0, 3));
        blocks.allocate(c).unwrap();
        assert_eq!(blocks.entry(c), Entry::Slot(1));
        assert_eq!(blocks.state([1, 8, 0]), (0.0, 0.0, 9));
        assert_eq!(
            blocks.par_marks_mut().count(),
            0,
            "the flags slot is given up"
        );
        assert_eq!(blocks.allocated(), [2 * BLOCK_NODES, BLOCK_NODES]);
    }

    #[test]
    fn allocation_beyond_max_voxels_is_refused() {
        let mut blocks = Blocks::new([32, 32, 16]).unwrap();
        blocks.limit(2 * BLOCK_NODES);
        blocks.allocate(0).unwrap();
        // a block of flags alone counts as a ninth: nine fit beside the distances
        for b in 1..=9 {
            blocks.allocate_flags(b).unwrap();
        }
        for err in [blocks.allocate(10), blocks.allocate_flags(10)] {
            assert_beyond_max_voxels(&err.unwrap_err());
        }
        assert_eq!(blocks.allocated(), [BLOCK_NODES, 9 * BLOCK_NODES]);
    }
}
