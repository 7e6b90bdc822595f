//! Shared decoding of fuzz bytes into points: the bytes pick small-integer coordinates (so
//! duplicates, collinear runs and cocircular grids are common) and a scale exponent.

use scanmesh_core::glam::DVec3;

/// Planar points (and heights) from the bytes: 3 bytes per point, the first byte a scale.
pub fn points(data: &[u8]) -> (Vec<[f64; 2]>, Vec<DVec3>) {
    let Some((&s, rest)) = data.split_first() else {
        return (Vec::new(), Vec::new());
    };
    // scales 2^-990 .. 2^990 by steps of 2^66 (1e-298 .. 1e298)
    let scale = 2f64.powi((s as i32 % 31 - 15) * 66);
    let mut uv = Vec::new();
    let mut xyz = Vec::new();
    for c in rest.chunks_exact(3) {
        let (x, y, z) = (
            c[0] as f64 % 17.0,
            c[1] as f64 % 17.0,
            (c[2] as f64 - 128.0) / 16.0,
        );
        uv.push([x * scale, y * scale]);
        xyz.push(DVec3::new(x, y, z) * scale);
    }
    (uv, xyz)
}
