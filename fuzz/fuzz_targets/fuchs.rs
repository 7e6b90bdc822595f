//! The Fuchs shortest path: DP, Dijkstra and the banded DP agree on the optimum,
//! look-ahead is never cheaper, and every path's cost is what `path_cost` says.
#![no_main]

use libfuzzer_sys::fuzz_target;
use scanmesh_core::glam::DVec3;
use scanmesh_core::strips::fuchs::{
    lookahead, path_cost, shortest_path_banded, shortest_path_dijkstra, shortest_path_dp, Weight,
};

mod common;

fuzz_target!(|data: &[u8]| {
    if data.len() < 6 {
        return;
    }
    let (w, rest) = data.split_at(5);
    let weight = Weight {
        length: (w[0] % 4) as f64,
        area: (w[1] % 4) as f64,
        angle: (w[2] % 4) as f64,
        dihedral: (w[3] % 4) as f64,
    };
    if weight.check().is_err() {
        return;
    }
    // unit scale: the path solvers take the caller's units (strips normalize before them)
    let mut bytes = vec![15u8];
    bytes.extend_from_slice(rest);
    let (_, xyz) = common::points(&bytes);
    let split = (w[4] as usize % xyz.len().max(1)).max(1).min(xyz.len());
    let (a, b): (Vec<DVec3>, Vec<DVec3>) = (xyz[..split].to_vec(), xyz[split..].to_vec());
    let Ok(dp) = shortest_path_dp(&a, &b, weight) else {
        // refusals must agree
        assert!(shortest_path_dijkstra(&a, &b, weight).is_err());
        return;
    };
    let dijkstra = shortest_path_dijkstra(&a, &b, weight).unwrap();
    let band = 1 + (w[4] as usize % 5);
    let banded = shortest_path_banded(&a, &b, weight, band).unwrap();
    let tol = |x: f64| 1e-9 * x.abs().max(1.0);
    assert!(
        (dp.cost - dijkstra.cost).abs() <= tol(dp.cost),
        "{} vs {}",
        dp.cost,
        dijkstra.cost
    );
    // The banded DP widens until it proves its optimum (crash-ef0a4d08 found a 2 x 4 matrix
    // where the former unproven band returned 3x the optimum).
    assert!(
        (banded.cost - dp.cost).abs() <= tol(dp.cost),
        "{} vs {}",
        dp.cost,
        banded.cost
    );
    for s in [&dp, &dijkstra, &banded] {
        let c = path_cost(&a, &b, weight, &s.path).unwrap();
        assert!(
            (c - s.cost).abs() <= tol(c),
            "path cost {c} vs reported {}",
            s.cost
        );
    }
    for alpha in [1, 2, 4] {
        let la = lookahead(&a, &b, weight, alpha).unwrap();
        assert!(
            la.cost >= dp.cost - tol(dp.cost),
            "look-ahead {} below optimum {}",
            la.cost,
            dp.cost
        );
    }
});
