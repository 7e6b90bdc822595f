//! Delaunay, trimming and validate on arbitrary points: only the documented refusals, and
//! every result is a valid mesh that accounts for every point.
#![no_main]

use libfuzzer_sys::fuzz_target;
use scanmesh_core::geometry::unit_square;
use scanmesh_core::mesh::HalfEdgeMesh;
use scanmesh_core::mesh::NONE;
use scanmesh_core::triangulate::delaunay;
use scanmesh_core::triangulate::{median_spacing, trim_long_edges};
use scanmesh_core::Error;

mod common;

fuzz_target!(|data: &[u8]| {
    let (uv, _) = common::points(data);
    let d = match delaunay(&uv) {
        Ok(d) => d,
        Err(Error::TooFewPoints { .. }) | Err(Error::Collinear { .. }) => return,
        Err(e) => panic!("unexpected error {e}"),
    };
    let unit = unit_square(&uv);
    HalfEdgeMesh::from_triangles(uv.len(), &d.triangles)
        .unwrap()
        .validate(&unit)
        .unwrap();
    let mut vertex = vec![false; uv.len()];
    d.triangles
        .iter()
        .flatten()
        .for_each(|&v| vertex[v as usize] = true);
    for (i, &k) in d.duplicate_of.iter().enumerate() {
        assert!(vertex[i] != (k != NONE), "point {i} lost");
    }
    let factor = 1.0 + (data.len() % 7) as f64;
    let limit = factor * median_spacing(&uv, &d.triangles).unwrap();
    let trimmed = trim_long_edges(&uv, &d.triangles, limit, None).unwrap();
    HalfEdgeMesh::from_triangles(uv.len(), &trimmed)
        .unwrap()
        .validate(&unit)
        .unwrap();
});
