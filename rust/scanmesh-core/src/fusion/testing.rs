//! Views and checks shared by the fusion's unit tests (compiled for tests only).

use super::depth::DepthView;
use super::tsdf::Volume;
use crate::Error;

/// A view looking down -z from the identity pose moved by `shift` (world x, y): `width` ×
/// `height` rays `step` apart from the scanner's origin, ray (i, j) at scanner (i, j) ·
/// `step` with the return `depth(i, j)` (NaN: none), each seen head-on (cosine 1).
pub(crate) fn view_from_above(
    shift: [f64; 2],
    step: f64,
    [width, height]: [usize; 2],
    depth: impl Fn(usize, usize) -> f64,
) -> DepthView {
    let mut pose = [0.0; 16];
    for k in 0..4 {
        pose[k * 5] = 1.0;
    }
    (pose[3], pose[7]) = (shift[0], shift[1]);
    let depth: Vec<f64> = (0..width * height)
        .map(|p| depth(p % width, p / width))
        .collect();
    let cos = vec![1.0; depth.len()];
    DepthView::new(pose, [0.0; 2], step, width, height, depth, cos).unwrap()
}

/// A grid of unit voxels from `origin` with `dims` nodes and distances truncated at
/// `truncation`, `view` integrated and carved into it.
pub(crate) fn fused_volume(
    view: &DepthView,
    origin: [f64; 3],
    dims: [usize; 3],
    truncation: f64,
) -> Volume {
    let mut vol = Volume::new(origin, 1.0, dims, truncation).unwrap();
    vol.integrate(view).unwrap();
    vol.carve(view).unwrap();
    vol
}

/// Asserts that `err` refuses an allocation beyond `max_voxels`.
pub(crate) fn assert_beyond_max_voxels(err: &Error) {
    assert!(
        matches!(
            err,
            Error::TooCostly {
                name: "max_voxels",
                ..
            }
        ),
        "{err}"
    );
}
