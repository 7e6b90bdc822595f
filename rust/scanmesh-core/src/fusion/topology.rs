//! The sides of the nodes the evidence does not decide, settled so that the scanners'
//! noise makes no handle. A handle of noise is a thin tunnel through the fused inside (rays
//! whose returns were lost, or grazed, carved it), made of nodes no view measured well. A
//! closing of the inside (dilation, then erosion) fills tunnels up to `2 · CLOSE_RADIUS`
//! nodes across; it moves only nodes whose side the evidence leaves open
//! ([`Volume::is_firm`]), and each group of nodes it would move (6-neighbours) moves only
//! when that raises the Euler characteristic of the inside: a handle taken off. A filled
//! pit or groove changes no topology and is left as measured. The opening (cutting thin
//! bridges the same way) was measured and left out: on the dragon's side series its cuts
//! split thin parts off the body (dropped as specks), holdout RMS 0.225 → 0.366 mm.

use super::blocks::{BLOCK, BLOCK_NODES};
use super::sides::{Sides, INSIDE};
use super::tsdf::Volume;
use crate::budget;
use crate::error::Result;
use std::collections::HashSet;

/// What the buffers of this module are called in a refusal.
const THIN: &str = "the thin parts of the fusion grid";

/// Returns' weights (cosine times trust, summed over the views) that decide a measured
/// node's side: one trusted return seen head-on. On the dragon's stand series at a 1 mm
/// voxel (docs/benchmarks/merge.md; with the opening then tried after the closing): genus
/// 19 at 1, 29 at 2.
pub const FIRM_WEIGHT: f32 = 1.0;

/// Tunnels up to twice this many nodes across are filled where that takes a handle off.
/// On the dragon's stand series (with the opening then tried): genus 164 unfilled, 19 at 1,
/// 12 at 2, 16 at 3 (its groups grow into whole grooves whose filling makes handles as it
/// takes them off). With the short handles cut on the mesh after the extraction
/// (`python/scanmesh/fusion/handles.py`), 1 fills less of what the views measured: holdout
/// RMS 0.1522 against 0.1577 mm on the happy Buddha, 0.1664 against 0.1668 on the dragon's
/// stand series, genus 3 and 1 either way (docs/benchmarks/merge-handles.md).
pub const CLOSE_RADIUS: usize = 1;

/// Nodes moved by [`settle`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Settled {
    /// Outside nodes moved inside (thin tunnels filled).
    pub closed: usize,
    /// The Euler characteristic of the inside gained: handles taken off (or voids sealed:
    /// a pit's mouth closed).
    pub handles: usize,
    /// Nodes of the largest group moved at once.
    pub largest: usize,
}

/// The closing of the inside's weak nodes (see the module comment), on `side` before the
/// manifold repair. O(nodes of the blocks near a side change · radius +
/// moved nodes).
///
/// Errors: `OutOfMemory`.
pub(super) fn settle(volume: &Volume, side: &mut Sides) -> Result<Settled> {
    let mut out = Settled::default();
    thin(volume, side, false, CLOSE_RADIUS, &mut out)?;
    Ok(out)
}

/// Moves the weak nodes of one side (`inside`) that form a part of it under `2 · radius`
/// nodes across to the other side, group by group where that takes a handle off: erosion of
/// the side's weak nodes by the 6-neighbourhood `radius` times, then dilation as often back
/// over them.
fn thin(
    volume: &Volume,
    side: &mut Sides,
    inside: bool,
    radius: usize,
    out: &mut Settled,
) -> Result<()> {
    let dims = side.dims();
    let [nx, ny, _] = dims;
    let is = |s: &Sides, n: usize| (s.get(n) & INSIDE != 0) == inside;
    let neighbours = |n: usize| {
        let c = [n % nx, (n / nx) % ny, n / (nx * ny)];
        let step = [1, nx, nx * ny];
        let mut out = [usize::MAX; 6];
        for a in 0..3 {
            if c[a] > 0 {
                out[2 * a] = n - step[a];
            }
            if c[a] + 1 < dims[a] {
                out[2 * a + 1] = n + step[a];
            }
        }
        out
    };
    let border = |n: usize| {
        let c = [n % nx, (n / nx) % ny, n / (nx * ny)];
        (0..3).any(|a| c[a] == 0 || c[a] + 1 == dims[a])
    };
    let set = |side: &mut Sides, n: usize, to_inside: bool| {
        if to_inside {
            side.add(n, INSIDE)
        } else {
            side.clear(n, INSIDE)
        }
    };
    // erosion, `radius` times: the weak nodes of the side with a neighbour on the other
    let mut eroded: Vec<usize> = Vec::new();
    for _ in 0..radius {
        let blocks = side.near_sides()?;
        let node_of = |k: usize| -> Option<usize> {
            let [lo, hi] = side.block_span(blocks[k / BLOCK_NODES]);
            let local = k % BLOCK_NODES;
            let c = [
                lo[0] + local % BLOCK,
                lo[1] + (local / BLOCK) % BLOCK,
                lo[2] + local / (BLOCK * BLOCK),
            ];
            (0..3)
                .all(|a| c[a] <= hi[a])
                .then(|| (c[2] * ny + c[1]) * nx + c[0])
        };
        let ring = budget::try_indices(THIN, 0..blocks.len() * BLOCK_NODES, |k| {
            node_of(k).is_some_and(|n| {
                is(side, n)
                    && !border(n)
                    && !volume.is_firm(n, FIRM_WEIGHT)
                    && neighbours(n)
                        .iter()
                        .any(|&m| m != usize::MAX && !is(side, m))
            })
        })?;
        let ring: Vec<usize> = ring.into_iter().filter_map(node_of).collect();
        for &n in &ring {
            set(side, n, !inside)?;
        }
        budget::try_grow(THIN, &mut eroded, ring.len())?;
        eroded.extend(ring);
    }
    // dilation as often over the eroded nodes: back where a neighbour is on the side
    let mut back: HashSet<usize> = HashSet::new();
    for _ in 0..radius {
        // at most every eroded node: the buffer never grows
        let mut ring: Vec<usize> = budget::try_vec(THIN, eroded.len())?;
        ring.extend(
            eroded
                .iter()
                .copied()
                .filter(|n| !back.contains(n))
                .filter(|&n| {
                    neighbours(n)
                        .iter()
                        .any(|&m| m != usize::MAX && is(side, m))
                }),
        );
        for &n in &ring {
            set(side, n, inside)?;
        }
        reserve(&mut back, ring.len())?;
        back.extend(ring);
    }
    // every node back where it was; then each group of moved nodes that touch (26-neighbours)
    // moved for good only where it takes a handle off
    for &n in &eroded {
        if !back.contains(&n) {
            set(side, n, inside)?;
        }
    }
    let mut moved: Vec<usize> = budget::try_vec(THIN, eroded.len())?;
    moved.extend(eroded.into_iter().filter(|n| !back.contains(n)));
    for group in groups(&moved, dims)? {
        let gain = euler_change(side, &group, dims)?;
        if gain > 0 {
            for &n in &group {
                set(side, n, !inside)?;
            }
            out.closed += group.len();
            out.handles += gain.max(0) as usize;
            out.largest = out.largest.max(group.len());
        }
    }
    Ok(())
}

/// The groups of `nodes` connected through their 6-neighbours (finer groups than through
/// 26: on the dragon's stand series genus 10 against 12, holdout RMS 0.6 % lower).
fn groups(nodes: &[usize], dims: [usize; 3]) -> Result<Vec<Vec<usize>>> {
    let [nx, ny, _] = dims;
    let mut left: HashSet<usize> = HashSet::new();
    reserve(&mut left, nodes.len())?;
    left.extend(nodes.iter().copied());
    let mut out = Vec::new();
    for &start in nodes {
        if !left.remove(&start) {
            continue;
        }
        let mut group = budget::try_vec(THIN, 1)?;
        group.push(start);
        let mut k = 0;
        while k < group.len() {
            let n = group[k];
            k += 1;
            let c = [n % nx, (n / nx) % ny, n / (nx * ny)];
            for d in 0..27 {
                let o = [d % 3, (d / 3) % 3, d / 9];
                if o.iter().filter(|&&v| v != 1).count() != 1
                    || (0..3).any(|a| c[a] + o[a] < 1 || c[a] + o[a] > dims[a])
                {
                    continue;
                }
                let m = ((c[2] + o[2] - 1) * ny + c[1] + o[1] - 1) * nx + c[0] + o[0] - 1;
                if left.remove(&m) {
                    budget::try_grow(THIN, &mut group, 1)?;
                    group.push(m);
                }
            }
        }
        budget::try_grow(THIN, &mut out, 1)?;
        out.push(group);
    }
    Ok(out)
}

/// How the Euler characteristic of the inside (the union of the closed unit cubes around
/// the inside nodes, whose boundary the extraction gives) changes when the nodes of
/// `group` change side: +1 for a handle taken off or a piece split off, −1 for one made.
/// Counted over the cubes, faces, edges and corners the group's cubes hold. O(group).
fn euler_change(side: &Sides, group: &[usize], dims: [usize; 3]) -> Result<i64> {
    let [nx, ny, _] = dims;
    let mut flipped: HashSet<usize> = HashSet::new();
    reserve(&mut flipped, group.len())?;
    flipped.extend(group.iter().copied());
    let inside_now = |c: [i64; 3]| {
        if (0..3).any(|a| c[a] < 0 || c[a] >= dims[a] as i64) {
            return false;
        }
        let n = (c[2] as usize * ny + c[1] as usize) * nx + c[0] as usize;
        side.get(n) & INSIDE != 0
    };
    let inside_after = |c: [i64; 3]| {
        let now = inside_now(c);
        let n = (c[2] as usize * ny + c[1] as usize) * nx + c[0] as usize;
        now ^ flipped.contains(&n)
    };
    // cells in doubled coordinates: a coordinate is odd where the cell lies between nodes
    let mut cells: HashSet<[i64; 3]> = HashSet::new();
    reserve(&mut cells, 27 * group.len())?;
    for &n in group {
        let c = [
            (n % nx) as i64,
            ((n / nx) % ny) as i64,
            (n / (nx * ny)) as i64,
        ];
        for d in 0..27 {
            let o = [d % 3, (d / 3) % 3, d / 9].map(|v| v as i64 - 1);
            cells.insert(std::array::from_fn(|a| 2 * c[a] + o[a]));
        }
    }
    let present = |cell: &[i64; 3], inside: &dyn Fn([i64; 3]) -> bool| {
        let options = |v: i64| {
            if v % 2 == 0 {
                [v / 2, v / 2]
            } else {
                [(v - 1) / 2, (v + 1) / 2]
            }
        };
        let [a, b, c] = [options(cell[0]), options(cell[1]), options(cell[2])];
        a.iter()
            .any(|&i| b.iter().any(|&j| c.iter().any(|&k| inside([i, j, k]))))
    };
    Ok(cells
        .iter()
        .map(|cell| {
            let sign = if cell.iter().filter(|v| *v % 2 != 0).count() % 2 == 0 {
                -1
            } else {
                1
            };
            sign * (i64::from(present(cell, &inside_after)) - i64::from(present(cell, &inside_now)))
        })
        .sum())
}

/// Room in `set` for `additional` more items, an allocation that may fail (an
/// [`crate::Error::OutOfMemory`]) instead of aborting: the sets here grow with the thin
/// parts, which a real scan makes by the hundred thousand. O(len) when it grows.
fn reserve<T: std::hash::Hash + Eq>(set: &mut HashSet<T>, additional: usize) -> Result<()> {
    set.try_reserve(additional)
        .map_err(|_| budget::not_allocated::<T>(THIN, set.len().saturating_add(additional)))
}

#[cfg(test)]
mod tests {
    use super::super::depth::DepthView;
    use super::super::extract::{extract, Fused};
    use super::*;
    use glam::DVec3;

    /// A 10³ grid whose every node but the border's is inside (unseen space is solid).
    fn solid() -> (Volume, [usize; 3]) {
        let vol = Volume::new([0.0; 3], 1.0, [10, 10, 10], 1.0).unwrap();
        let dims = vol.dims();
        (vol, dims)
    }

    #[test]
    fn the_euler_change_counts_handles_made_and_taken_off() {
        let (vol, dims) = solid();
        let mut side = Sides::new(&vol).unwrap();
        let at = |i: usize, j: usize, k: usize| (k * 10 + j) * 10 + i;
        // a tunnel from border to border: boring it makes a handle, filling it takes it off
        let tunnel: Vec<usize> = (1..9).map(|i| at(i, 5, 5)).collect();
        assert_eq!(euler_change(&side, &tunnel, dims).unwrap(), -1);
        for &n in &tunnel {
            side.clear(n, INSIDE).unwrap();
        }
        assert_eq!(euler_change(&side, &tunnel, dims).unwrap(), 1);
        // a pit (open at one end only) changes nothing; a cavity is a piece of its own
        let pit: Vec<usize> = (1..4).map(|j| at(3, j, 3)).collect();
        assert_eq!(euler_change(&side, &pit, dims).unwrap(), 0);
        assert_eq!(euler_change(&side, &[at(3, 3, 7)], dims).unwrap(), 1);
    }

    /// A slab seen from above (returns at z = 5), bored through where its rays had no
    /// return: by a bore 8 rays across (5 voxels) and by a pinhole 3 rays across (2
    /// voxels); below the slab no ray entered, so it is solid down to the grid's border.
    /// Both are handles of the fused inside; only the bore is wider than noise.
    fn pierced_slab() -> (DepthView, Volume) {
        let (w, h) = (30, 30);
        let within = |v: usize, lo: usize, hi: usize| (lo..hi).contains(&v);
        let depth: Vec<f64> = (0..w * h)
            .map(|p| {
                let (i, j) = (p % w, p / w);
                let slab = within(i, 2, 28) && within(j, 2, 28);
                let bore = within(i, 10, 18) && within(j, 10, 18);
                let pinhole = within(i, 21, 24) && within(j, 5, 8);
                if slab && !bore && !pinhole {
                    5.0
                } else {
                    f64::NAN
                }
            })
            .collect();
        let mut pose = [0.0; 16];
        for k in 0..4 {
            pose[k * 5] = 1.0;
        }
        let view = DepthView::new(pose, [0.0; 2], 1.0, w, h, depth, vec![1.0; w * h]).unwrap();
        let mut vol = Volume::new([-1.2, -1.2, -1.2], 1.5, [22, 22, 8], 3.0).unwrap();
        vol.integrate(&view).unwrap();
        vol.carve(&view).unwrap();
        (view, vol)
    }

    fn genus(f: &Fused) -> f64 {
        let euler = f.vertices.len() as f64 - 1.5 * f.faces.len() as f64 + f.faces.len() as f64;
        (2.0 - euler) / 2.0
    }

    #[test]
    fn a_pinhole_no_return_measured_is_closed_and_a_bore_kept() {
        let (view, vol) = pierced_slab();
        let samples: Vec<DVec3> = (2..28)
            .flat_map(|i| (2..28).map(move |j| DVec3::new(i as f64, j as f64, 5.0)))
            .filter(|p| !(10.0..18.0).contains(&p.x) || !(10.0..18.0).contains(&p.y))
            .filter(|p| !(21.0..24.0).contains(&p.x) || !(5.0..8.0).contains(&p.y))
            .collect();
        let normals = vec![DVec3::Z; samples.len()];
        let fused = extract(&vol, &samples, &normals, &[&view]).unwrap();
        // genus 2 without the settling: the pinhole's tunnel is a handle
        assert_eq!(genus(&fused), 1.0, "the bore is kept, the pinhole closed");
        assert!(
            fused.settled.closed > 0 && fused.settled.handles == 1,
            "{:?}",
            fused.settled
        );
    }
}
