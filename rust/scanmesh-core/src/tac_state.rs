//! Incremental total absolute curvature of a triangulation under edge flips.
//!
//! The energy is `E = Σ_v f(S_v)` over interior vertices, with `S_v` the sum of the 3-D
//! corner angles at v and `f(S) = |2π − S|^p` (p ≥ 1; p = 1 is the tac 1-norm). Corner
//! angles are cached per half-edge slot and angle sums per vertex, so a proposed flip
//! computes only the six corner angles of its two new triangles and changes the energy of
//! its four corners alone. Both annealing and LOP use this one state.

use crate::delaunay::NONE;
use crate::geometry::triangle_angles;
use crate::mesh::{next, prev, HalfEdgeMesh};
use crate::{Error, Result};
use glam::DVec3;
use std::f64::consts::TAU;

/// A flip that has been evaluated but not applied.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlipMove {
    /// The interior half-edge to flip.
    pub h: u32,
    /// Energy after minus energy before.
    pub delta_energy: f64,
    /// Corner angles (radians) of the two new triangles in slot order h, next(h), prev(h),
    /// t, next(t), prev(t) as [`HalfEdgeMesh::flip`] rewrites them.
    pub new_angles: [f64; 6],
    /// Smallest 3-D angle of the two triangles before the flip (radians).
    pub old_min_angle: f64,
    /// Smallest 3-D angle of the two triangles after the flip (radians).
    pub new_min_angle: f64,
}

/// Mesh, positions and the caches that make a flip's energy change O(1).
#[derive(Debug, Clone)]
pub struct TacState {
    mesh: HalfEdgeMesh,
    uv: Vec<[f64; 2]>,
    xyz: Vec<DVec3>,
    corner: Vec<f64>,
    sum: Vec<f64>,
    interior: Vec<bool>,
    p: f64,
    energy: f64,
}

/// Energy contribution `|2π − S|^p` of an interior vertex with angle sum `s`. O(1).
#[inline]
pub fn vertex_energy(s: f64, p: f64) -> f64 {
    let tac = (TAU - s).abs();
    if p == 1.0 {
        tac
    } else if p == 2.0 {
        tac * tac
    } else {
        tac.powf(p)
    }
}

impl TacState {
    /// Builds the caches. `uv` are the planar positions the flips are checked in (use
    /// [`crate::delaunay::unit_square`] of the projection), `xyz` the 3-D positions the angles
    /// are measured on (normalize with [`crate::geometry::Normalizer`] to be scale-safe). O(m).
    pub fn new(mesh: HalfEdgeMesh, uv: Vec<[f64; 2]>, xyz: Vec<DVec3>, p: f64) -> Result<Self> {
        if !(p.is_finite() && p >= 1.0) {
            return Err(Error::InvalidParameter {
                name: "p",
                value: p.to_string(),
                expected: "a finite p >= 1",
            });
        }
        if uv.len() != mesh.n_vertices() || xyz.len() != mesh.n_vertices() {
            return Err(Error::InvalidParameter {
                name: "positions",
                value: format!(
                    "{} planar and {} 3-D for {} vertices",
                    uv.len(),
                    xyz.len(),
                    mesh.n_vertices()
                ),
                expected: "one of each per vertex",
            });
        }
        let interior = (0..mesh.n_vertices() as u32)
            .map(|v| mesh.is_interior(v))
            .collect();
        let mut state = TacState {
            corner: vec![0.0; mesh.n_half_edges()],
            sum: vec![0.0; mesh.n_vertices()],
            mesh,
            uv,
            xyz,
            interior,
            p,
            energy: 0.0,
        };
        for t in 0..state.mesh.n_triangles() {
            let [a, b, c] = state.mesh.triangle(t).map(|v| state.xyz[v as usize]);
            let angles = triangle_angles(a, b, c);
            state.corner[3 * t..3 * t + 3].copy_from_slice(&angles);
        }
        for v in 0..state.mesh.n_vertices() as u32 {
            state.sum[v as usize] = state.fan_sum(v);
        }
        state.energy = state.recompute_energy();
        Ok(state)
    }

    /// Angle sum around `v` from the corner cache, walking its fan. O(degree).
    fn fan_sum(&self, v: u32) -> f64 {
        if !self.mesh.is_used(v) {
            return 0.0;
        }
        self.mesh.fan(v).map(|h| self.corner[h as usize]).sum()
    }

    /// The triangulation. O(1).
    pub fn mesh(&self) -> &HalfEdgeMesh {
        &self.mesh
    }

    /// Planar positions. O(1).
    pub fn uv(&self) -> &[[f64; 2]] {
        &self.uv
    }

    /// 3-D positions. O(1).
    pub fn xyz(&self) -> &[DVec3] {
        &self.xyz
    }

    /// Current energy, maintained incrementally. O(1).
    pub fn energy(&self) -> f64 {
        self.energy
    }

    /// The energy exponent p.
    pub fn p(&self) -> f64 {
        self.p
    }

    /// Energy recomputed from the cached angle sums, resetting accumulated rounding. O(n).
    pub fn resync_energy(&mut self) -> f64 {
        self.energy = self.recompute_energy();
        self.energy
    }

    /// Energy from the cached vertex sums. O(n).
    fn recompute_energy(&self) -> f64 {
        self.sum
            .iter()
            .zip(&self.interior)
            .filter(|(_, &i)| i)
            .map(|(&s, _)| vertex_energy(s, self.p))
            .sum()
    }

    /// Energy computed from scratch from positions and connectivity, sharing no cache: the
    /// reference the incremental value is tested against. O(m).
    pub fn energy_from_scratch(&self) -> f64 {
        let sums = crate::criteria::angle_sums(&self.xyz, &self.mesh.triangles());
        sums.iter()
            .zip(&self.interior)
            .filter(|(_, &i)| i)
            .map(|(&s, _)| vertex_energy(s, self.p))
            .sum()
    }

    /// Number of half-edges that have a twin (twice the number of interior edges). O(m).
    pub fn count_interior_half_edges(&self) -> usize {
        (0..self.mesh.n_half_edges() as u32)
            .filter(|&h| self.mesh.twin(h) != NONE)
            .count()
    }

    /// Evaluates flipping `h`: `None` when it is a boundary edge or its quadrilateral is not
    /// strictly convex in the plane. O(1): two exact orientations and six corner angles.
    #[inline]
    pub fn evaluate(&self, h: u32) -> Option<FlipMove> {
        if !self.mesh.can_flip(h, &self.uv) {
            return None;
        }
        let t = self.mesh.twin(h);
        let [a, b, c, d] = self.mesh.quad(h, t);
        let [pa, pb, pc, pd] = [a, b, c, d].map(|v| self.xyz[v as usize]);
        let [d0, c0, a0] = triangle_angles(pd, pc, pa);
        let [c1, d1, b1] = triangle_angles(pc, pd, pb);
        let new_angles = [d0, c0, a0, c1, d1, b1];
        let (h1, h2, t1, t2) = (next(h), prev(h), next(t), prev(t));
        let k = &self.corner;
        let old = [
            k[h as usize],
            k[h1 as usize],
            k[h2 as usize],
            k[t as usize],
            k[t1 as usize],
            k[t2 as usize],
        ];
        let deltas = [
            (a, a0 - (old[0] + old[4])),
            (b, b1 - (old[1] + old[3])),
            (c, c0 + c1 - old[2]),
            (d, d0 + d1 - old[5]),
        ];
        let mut delta_energy = 0.0;
        for (v, delta) in deltas {
            if self.interior[v as usize] {
                let s = self.sum[v as usize];
                delta_energy += vertex_energy(s + delta, self.p) - vertex_energy(s, self.p);
            }
        }
        let min6 = |x: [f64; 6]| x.iter().copied().fold(f64::INFINITY, f64::min);
        Some(FlipMove {
            h,
            delta_energy,
            new_angles,
            old_min_angle: min6(old),
            new_min_angle: min6(new_angles),
        })
    }

    /// Applies an evaluated move: flips, writes the six new corner angles, re-sums the four
    /// touched vertices from their fans (so sums never drift) and updates the energy. O(degree).
    pub fn apply(&mut self, mv: &FlipMove) {
        let h = mv.h;
        let t = self.mesh.twin(h);
        let quad = self.mesh.quad(h, t);
        self.mesh.flip(h);
        for (slot, angle) in [h, next(h), prev(h), t, next(t), prev(t)]
            .into_iter()
            .zip(mv.new_angles)
        {
            self.corner[slot as usize] = angle;
        }
        for v in quad {
            self.sum[v as usize] = self.fan_sum(v);
        }
        self.energy += mv.delta_energy;
    }

    /// Consumes the state, returning the mesh. O(1).
    pub fn into_mesh(self) -> HalfEdgeMesh {
        self.mesh
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::delaunay::{delaunay, unit_square};

    /// A bumpy height field sampled at random planar points.
    pub(crate) fn bumpy_state(n: usize, seed: u64, p: f64) -> TacState {
        let mut s = seed;
        let mut rnd = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let uv: Vec<[f64; 2]> = (0..n).map(|_| [rnd(), rnd()]).collect();
        let xyz: Vec<DVec3> = uv
            .iter()
            .map(|q| {
                DVec3::new(
                    q[0],
                    q[1],
                    0.3 * (6.0 * q[0]).sin() * (4.0 * q[1]).cos() + 0.2 * q[0] * q[0],
                )
            })
            .collect();
        let uv = unit_square(&uv);
        let d = delaunay(&uv).unwrap();
        let mesh = HalfEdgeMesh::from_triangles(n, &d.triangles).unwrap();
        TacState::new(mesh, uv, xyz, p).unwrap()
    }

    #[test]
    fn delta_energy_matches_recomputation() {
        for p in [1.0, 2.0, 3.5] {
            let mut st = bumpy_state(300, 4, p);
            let e0 = st.energy_from_scratch();
            assert!((st.energy() - e0).abs() <= 1e-12 * e0.max(1.0));
            let edges = st.mesh().interior_edges();
            let mut applied = 0;
            for &h in edges.iter().take(400) {
                if let Some(mv) = st.evaluate(h) {
                    let before = st.energy_from_scratch();
                    st.apply(&mv);
                    let after = st.energy_from_scratch();
                    assert!(
                        ((after - before) - mv.delta_energy).abs() <= 1e-10 * before.max(1.0),
                        "p={p}"
                    );
                    applied += 1;
                }
            }
            assert!(applied > 100);
            let scratch = st.energy_from_scratch();
            assert!(
                (st.energy() - scratch).abs() <= 1e-9 * scratch,
                "{} vs {scratch}",
                st.energy()
            );
            st.mesh().validate(st.uv()).unwrap();
        }
    }

    #[test]
    fn boundary_and_reflex_edges_are_not_moves() {
        let st = bumpy_state(100, 5, 1.0);
        for h in 0..st.mesh().n_half_edges() as u32 {
            if st.mesh().twin(h) == NONE {
                assert!(st.evaluate(h).is_none());
            } else {
                assert_eq!(st.evaluate(h).is_some(), st.mesh().can_flip(h, st.uv()));
            }
        }
    }

    #[test]
    fn bad_p_is_refused() {
        let st = bumpy_state(20, 1, 1.0);
        let (mesh, uv) = (st.mesh().clone(), st.uv().to_vec());
        assert!(TacState::new(mesh, uv, st.xyz().to_vec(), 0.5).is_err());
    }
}
