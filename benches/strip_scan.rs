//! The synthetic height scan and the default weight shared by the strip benches
//! (`strips.rs`, criterion; `strips_best.rs`, best-of runs).

use scanmesh_core::glam::DVec3;
use scanmesh_core::strips::fuchs::Weight;

#[path = "jitter.rs"]
mod jitter;

/// The default weight of the Python layer (`scanmesh.strips.DEFAULT_WEIGHT`).
pub const DEFAULT_WEIGHT: Weight = Weight {
    length: 0.0,
    area: 0.0,
    angle: 1.0,
    dihedral: 0.3,
};

/// About `n` points on √n lines of √n points over z = 5 sin(0.05 x) cos(0.04 y), spacing 1
/// along and across, jittered by ±0.15: (points, planar positions, line ids).
pub fn height_scan(n: usize) -> (Vec<DVec3>, Vec<[f64; 2]>, Vec<i64>) {
    let side = (n as f64).sqrt().round() as usize;
    let mut jitter = jitter::jitter(17, 0.3);
    let mut points = Vec::with_capacity(side * side);
    let mut ids = Vec::with_capacity(side * side);
    for r in 0..side {
        for c in 0..side {
            let (x, y) = (c as f64 + jitter(), r as f64 + jitter());
            points.push(DVec3::new(x, y, 5.0 * (0.05 * x).sin() * (0.04 * y).cos()));
            ids.push(r as i64);
        }
    }
    let uv = points.iter().map(|p| [p.x, p.y]).collect();
    (points, uv, ids)
}
