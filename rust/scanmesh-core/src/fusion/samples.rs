//! The samples (the views' kept points) by the grid cell they fall in, for the samples
//! around a cell: the vertex placement and the edge flips of the extraction read them.

use super::tsdf::Volume;
use crate::budget;
use crate::error::Result;
use glam::DVec3;
use rayon::prelude::*;

/// Samples sorted by the cell they fall in, for the samples around a cell.
pub(super) struct SampleIndex {
    dims: [usize; 3],
    /// (cell key, sample) sorted by key.
    keys: Vec<(usize, usize)>,
}

impl SampleIndex {
    /// The samples inside the grid by cell. O(samples log samples), on every core.
    ///
    /// Errors: `OutOfMemory`.
    pub(super) fn new(volume: &Volume, samples: &[DVec3]) -> Result<Self> {
        let dims = volume.dims();
        let origin = volume.node(0, 0, 0);
        let mut keys: Vec<(usize, usize)> = budget::try_vec("the samples by cell", samples.len())?;
        keys.extend(samples.iter().enumerate().filter_map(|(s, p)| {
            let g = ((*p - origin) / volume.voxel()).floor();
            let ok = (0..3).all(|a| g[a] >= 0.0 && g[a] < dims[a] as f64);
            ok.then(|| (volume.index(g.x as usize, g.y as usize, g.z as usize), s))
        }));
        keys.par_sort_unstable();
        Ok(Self { dims, keys })
    }

    /// Samples in the 27 cells around cell `c` (grid coordinates).
    pub(super) fn around(&self, c: [usize; 3]) -> impl Iterator<Item = usize> + '_ {
        let [nx, ny, nz] = self.dims;
        let range = |v: usize, n: usize| v.saturating_sub(1)..(v + 2).min(n);
        range(c[2], nz).flat_map(move |k| {
            range(c[1], ny).flat_map(move |j| {
                let first = (k * ny + j) * nx + c[0].saturating_sub(1);
                let last = (k * ny + j) * nx + (c[0] + 1).min(nx - 1);
                let lo = self.keys.partition_point(|&(key, _)| key < first);
                let hi = self.keys.partition_point(|&(key, _)| key <= last);
                self.keys[lo..hi].iter().map(|&(_, s)| s)
            })
        })
    }
}
