//! Which side of the surface each node of the fusion grid is on, for the extraction: stored
//! by blocks like the volume ([`super::blocks`]), one byte per node only in the blocks
//! where the sides may differ, and per block whether some cell with its lowest corner there
//! may hold both sides (the cells and edges the extraction visits).

use super::blocks::{block_nodes, Layout, BLOCK, BLOCK_NODES};
use super::tsdf::Volume;
use crate::budget;
use crate::error::Result;
use rayon::prelude::*;

/// Node mark: inside (negative fused distance, never on the grid's border).
pub(super) const INSIDE: u8 = 1;
/// Node mark: moved inside by the manifold repair.
pub(super) const MOVED: u8 = 2;

/// Index entry bit: every node of the block has the marks in the low 8 bits.
const UNIFORM: u32 = 1 << 31;

/// Per node, [`INSIDE`] and [`MOVED`].
pub(super) struct Sides {
    layout: Layout,
    dims: [usize; 3],
    /// Per block: `UNIFORM | marks`, or its slot.
    index: Vec<u32>,
    /// Per slot, the marks of its [`BLOCK_NODES`] nodes.
    marks: Vec<u8>,
    /// Per block: the sides may differ within it and its 7 neighbours towards +x, +y, +z.
    active: Vec<bool>,
    /// Per row of blocks (y, z): one of them is active.
    rows: Vec<bool>,
}

impl Sides {
    /// The sides of `volume`'s nodes: inside where the fused distance is negative, outside
    /// on the border. O(blocks + allocated nodes), on every core.
    ///
    /// Errors: `OutOfMemory`.
    pub(super) fn new(volume: &Volume) -> Result<Self> {
        let blocks = volume.blocks();
        let layout = blocks.layout();
        let dims = volume.dims();
        let mark = |[i, j, k]: [usize; 3]| {
            let border = (0..3).any(|a| [i, j, k][a] == 0 || [i, j, k][a] + 1 == dims[a]);
            u8::from(!border && volume.value(volume.index(i, j, k)) < 0.0)
        };
        // uniform where every node has the same side (most blocks: one test)
        let uniform: Vec<Option<u8>> = budget::try_par_collect(
            "the sides of the fusion grid",
            (0..blocks.len()).into_par_iter().map(|b| {
                let [lo, hi] = layout.nodes(b);
                let on_border = (0..3).any(|a| lo[a] == 0 || hi[a] + 1 == dims[a]);
                match volume.uniform_value(b) {
                    Some(v) if v >= 0.0 || !on_border => Some(u8::from(v < 0.0)),
                    _ => {
                        let first = mark(lo);
                        block_nodes([lo, hi])
                            .all(|(node, _)| mark(node) == first)
                            .then_some(first)
                    }
                }
            }),
        )?;
        let mut index = budget::try_vec("the sides of the fusion grid", uniform.len())?;
        let mut owners = Vec::new();
        for (b, u) in uniform.iter().enumerate() {
            index.push(match u {
                Some(marks) => UNIFORM | u32::from(*marks),
                None => {
                    budget::try_grow("the sides of the fusion grid", &mut owners, 1)?;
                    owners.push(b);
                    (owners.len() - 1) as u32
                }
            });
        }
        let mut marks = budget::try_filled(
            "the sides of the fusion grid",
            0u8,
            owners.len() * BLOCK_NODES,
        )?;
        marks
            .par_chunks_mut(BLOCK_NODES)
            .zip(owners.par_iter())
            .for_each(|(marks, &b)| {
                for (node, local) in block_nodes(layout.nodes(b)) {
                    marks[local] = mark(node);
                }
            });
        let [bx, by, bz] = layout.counts();
        let mut out = Self {
            layout,
            dims,
            index,
            marks,
            active: Vec::new(),
            rows: budget::try_filled("the sides of the fusion grid", false, by * bz)?,
        };
        let active = budget::try_par_collect(
            "the sides of the fusion grid",
            (0..out.index.len()).into_par_iter().map(|b| {
                let c = layout.coords(b);
                let mut seen = None;
                for d in 0..8 {
                    let n = [c[0] + (d & 1), c[1] + ((d >> 1) & 1), c[2] + ((d >> 2) & 1)];
                    if n[0] >= bx || n[1] >= by || n[2] >= bz {
                        continue;
                    }
                    let e = out.index[layout.at(n)];
                    if e & UNIFORM == 0 || seen.is_some_and(|s| s != e) {
                        return true;
                    }
                    seen = Some(e);
                }
                false
            }),
        )?;
        for (b, &a) in active.iter().enumerate() {
            if a {
                let c = layout.coords(b);
                out.rows[c[2] * by + c[1]] = true;
            }
        }
        out.active = active;
        Ok(out)
    }

    /// Every block active: the walk over every node (the dense grid's), for tests.
    #[cfg(test)]
    pub(super) fn activate_all(&mut self) {
        self.active.fill(true);
        self.rows.fill(true);
    }

    fn coords(&self, n: usize) -> [usize; 3] {
        let [nx, ny, _] = self.dims;
        [n % nx, (n / nx) % ny, n / (nx * ny)]
    }

    /// The marks of node `n` (flat index). O(1).
    pub(super) fn get(&self, n: usize) -> u8 {
        let (b, local) = self.layout.locate(self.coords(n));
        let e = self.index[b];
        if e & UNIFORM != 0 {
            e as u8
        } else {
            self.marks[e as usize * BLOCK_NODES + local]
        }
    }

    /// Adds `marks` to node `n`, allocating its block if uniform; the blocks whose cells
    /// hold the node become active. O(1), O(512) when it allocates.
    ///
    /// Errors: `OutOfMemory`.
    pub(super) fn add(&mut self, n: usize, marks: u8) -> Result<()> {
        let at = self.writable(n)?;
        self.marks[at] |= marks;
        Ok(())
    }

    /// Takes `marks` off node `n`, as [`Sides::add`] puts them on. O(1), O(512) when it
    /// allocates.
    ///
    /// Errors: `OutOfMemory`.
    pub(super) fn clear(&mut self, n: usize, marks: u8) -> Result<()> {
        let at = self.writable(n)?;
        self.marks[at] &= !marks;
        Ok(())
    }

    /// Where node `n`'s marks are stored, its block allocated if uniform; the blocks whose
    /// cells hold the node become active.
    fn writable(&mut self, n: usize) -> Result<usize> {
        let node = self.coords(n);
        let (b, local) = self.layout.locate(node);
        let e = self.index[b];
        let slot = if e & UNIFORM != 0 {
            let slot = self.marks.len() / BLOCK_NODES;
            budget::try_grow("the sides of the fusion grid", &mut self.marks, BLOCK_NODES)?;
            self.marks.resize(self.marks.len() + BLOCK_NODES, e as u8);
            self.index[b] = slot as u32;
            slot
        } else {
            e as usize
        };
        let c = self.layout.coords(b);
        let by = self.layout.counts()[1];
        for d in 0..8 {
            let (dx, dy, dz) = (d & 1, (d >> 1) & 1, (d >> 2) & 1);
            if c[0] < dx || c[1] < dy || c[2] < dz {
                continue;
            }
            let m = [c[0] - dx, c[1] - dy, c[2] - dz];
            self.active[self.layout.at(m)] = true;
            self.rows[m[2] * by + m[1]] = true;
        }
        Ok(slot * BLOCK_NODES + local)
    }

    /// The blocks where a node may have a neighbour (along an axis) on the other side:
    /// those whose nodes differ, or whose marks differ from a neighbouring block's.
    /// O(blocks).
    ///
    /// Errors: `OutOfMemory`.
    pub(super) fn near_sides(&self) -> Result<Vec<usize>> {
        let counts = self.layout.counts();
        budget::try_indices(
            "the blocks near the sides of the fusion grid",
            0..self.index.len(),
            |b| {
                let e = self.index[b];
                if e & UNIFORM == 0 {
                    return true;
                }
                let c = self.layout.coords(b);
                (0..3).any(|a| {
                    [-1i64, 1].iter().any(|&s| {
                        let mut m = c.map(|v| v as i64);
                        m[a] += s;
                        if m[a] < 0 || m[a] >= counts[a] as i64 {
                            return false;
                        }
                        self.index[self.layout.at(m.map(|v| v as usize))] != e
                    })
                })
            },
        )
    }

    /// The nodes of block `b` inside the grid: lowest and highest (inclusive) coordinates.
    pub(super) fn block_span(&self, b: usize) -> [[usize; 3]; 2] {
        self.layout.nodes(b)
    }

    /// The grid's nodes along x, y, z.
    pub(super) fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// Whether some block of node row (j, k) is active (read live: a block made active
    /// while the row is walked counts). O(1).
    pub(super) fn row_active(&self, j: usize, k: usize) -> bool {
        let by = self.layout.counts()[1];
        self.rows[(k / BLOCK) * by + j / BLOCK]
    }

    /// Whether the block of node (i, j, k) is active: some cell with its lowest corner
    /// there, or an edge from it towards +x, +y, +z, may hold both sides. O(1).
    pub(super) fn is_active(&self, [i, j, k]: [usize; 3]) -> bool {
        let (b, _) = self.layout.locate([i, j, k]);
        self.active[b]
    }
}
