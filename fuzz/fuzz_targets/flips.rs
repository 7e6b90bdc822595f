//! Random flip sequences on a Delaunay start: the mesh stays valid and the incremental tac
//! energy equals a recomputation from scratch.
#![no_main]

use libfuzzer_sys::fuzz_target;
use scanmesh_core::optimize::{Detail, TacState};
use scanmesh_core::triangulate::delaunay;

mod common;

fuzz_target!(|data: &[u8]| {
    // first half: points; second half: the flip sequence (2 bytes per proposal)
    let (head, moves) = data.split_at(data.len() / 2);
    let (uv, xyz) = common::points(head);
    let Ok(d) = delaunay(&uv) else { return };
    let p = [1.0, 2.0, 3.5][data.len() % 3];
    let (mut state, _) = TacState::from_input(&xyz, &uv, d.triangles, p).unwrap();
    let edges = state.mesh().n_half_edges().max(1);
    for m in moves.chunks_exact(2) {
        let h = (u16::from_le_bytes([m[0], m[1]]) as usize % edges) as u32;
        let detail = if m[0] & 1 == 0 {
            Detail::Energy
        } else {
            Detail::Shape
        };
        if let Some(mv) = state.evaluate(h, detail) {
            state.apply(&mv);
        }
    }
    state.mesh().validate(&state.uv().unwrap()).unwrap();
    let (inc, full) = (state.energy(), state.energy_from_scratch());
    assert!(
        (inc - full).abs() <= 1e-9 * full.max(1.0),
        "incremental {inc} vs from scratch {full}"
    );
});
