//! Holes narrower than the planar trim length: a triangle much longer and larger in the
//! plane than the triangles around it spans samples the scan does not have (rays through a
//! drilled hole or a slot hit nothing), even when its edges are short enough for the
//! planar rule and its corners lie at one height (so no depth jump or 3-D gap shows).

use crate::budget::{try_filled, try_grow, try_indices, try_par_collect};
use crate::geometry::unit_square;
use crate::geometry::PAR_BLOCK;
use crate::mesh::well_formed;
use crate::Result;
use rayon::prelude::*;

/// Default hole factor (a ratio of planar lengths): in trimming, a triangle spans missing
/// samples and is dropped (`covering_holes`) when its longest planar edge exceeds this
/// multiple of the local edge length **and** its planar area exceeds `HOLE_AREA_FACTOR`
/// times the local triangle area; either condition alone keeps it. The local values of a
/// triangle are the median over its three corners of each corner's lower median (of the
/// lengths of the two edges at that corner of every well-formed triangle there, and of
/// those triangles' areas). Degenerate triangles are never dropped by this rule; the
/// comparison is on squared lengths in single precision, in [`unit_square`] coordinates,
/// so the rule is scale-free. Chosen by benches/depth_jumps.py: it drops the thin triangles
/// left across the rocker arm's oil holes (narrower than the planar trim length) and keeps
/// nearly all the area of samplings without holes; an area rule alone had to be so loose
/// to keep irregular samplings that it left those thin triangles (figures in
/// docs/benchmarks/depth-jumps.md, "Figures behind the core's constants").
pub const DEFAULT_HOLE_FACTOR: f64 = 2.8;

/// The area condition of the hole rule: more than this multiple of the area of the
/// triangles around, so a long thin triangle that misses no sample (along the staircase
/// rim of a large bore, where lines meet the rim several spacings apart) stays. A Delaunay
/// triangle between neighbouring scan lines covers half a sampling cell; one that misses a
/// sample covers a whole cell (2 ×); 1.8 leaves room for jitter.
pub const HOLE_AREA_FACTOR: f64 = 1.8;

/// The median of three numbers.
fn median3([a, b, c]: [f32; 3]) -> f32 {
    a.max(b).min(a.min(b).max(c))
}

/// For each of `triangles` (counter-clockwise in `uv`), whether it spans missing samples:
/// its longest planar edge exceeds `factor` times the local edge length and its planar
/// area [`HOLE_AREA_FACTOR`] times the local triangle area. Local means the median over its
/// three corners of the lower median at each corner (of the lengths of the two edges of
/// each triangle there, and of those triangles' areas): a corner on the rim of a hole
/// keeps most of its triangles on the sampled side, so its lower medians are those of the
/// ordinary triangles, and the median of the corners lets no single corner with unusual
/// triangles (jitter, a sliver fan) decide. Numerically degenerate triangles are never
/// flagged (trimming peels them) and count in no median; `factor = ∞` flags nothing.
/// Scale-free (on [`unit_square`] coordinates). O(m) plus a sort of the triangles at the
/// corners of candidates: the smallest edge and area at each vertex bound its lower medians
/// from below, so a triangle within the factors of those bounds is no hole, and a regularly
/// sampled scan sorts nothing. Errors: an [`crate::Error::OutOfMemory`] for its buffers.
pub fn covering_holes(uv: &[[f64; 2]], triangles: &[[u32; 3]], factor: f64) -> Result<Vec<bool>> {
    const WHAT: &str = "the hole rule's measures";
    let mut flags = try_filled(WHAT, false, triangles.len())?;
    if !factor.is_finite() || triangles.is_empty() {
        return Ok(flags);
    }
    let unit = unit_square(uv);
    // Squared edge lengths (edge k from corner k) and area of a triangle; None when it is
    // degenerate (no flag, no vote).
    let measure = |t: &[u32; 3]| {
        let [a, b, c] = t.map(|v| unit[v as usize]);
        well_formed(a, b, c).then(|| {
            let sq = |p: [f64; 2], q: [f64; 2]| (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2);
            let area = 0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]));
            ([sq(a, b), sq(b, c), sq(c, a)], area)
        })
    };
    // Per triangle its squared edges and area (single precision: thresholds, not
    // geometry; NaN when degenerate), then the smallest area and squared edge at each
    // vertex in one sequential pass (the labels are the sweep's, so it reads in order).
    let records = triangles.par_iter().with_min_len(PAR_BLOCK).map(|t| {
        measure(t).map_or([f32::NAN; 4], |(e, area)| {
            [e[0] as f32, e[1] as f32, e[2] as f32, area as f32]
        })
    });
    let records: Vec<[f32; 4]> = try_par_collect(WHAT, records)?;
    let mut smallest = try_filled(WHAT, [f32::INFINITY; 2], uv.len())?;
    for (t, r) in triangles.iter().zip(&records) {
        if !r[3].is_nan() {
            for k in 0..3 {
                let m = &mut smallest[t[k] as usize];
                m[0] = m[0].min(r[3]);
                m[1] = m[1].min(r[k].min(r[(k + 2) % 3]));
            }
        }
    }
    // Whether triangle i exceeds both factors against the local values `at` (area, squared
    // edge) of its corners; a corner without well-formed triangles is ∞ (no hole).
    let exceeds = |i: usize, at: &[[f32; 2]]| {
        let [e0, e1, e2, area] = records[i];
        let local = triangles[i].map(|v| at[v as usize]);
        // NaN (degenerate) compares false: never flagged.
        e0.max(e1).max(e2) > (factor * factor) as f32 * median3(local.map(|l| l[1]))
            && area > HOLE_AREA_FACTOR as f32 * median3(local.map(|l| l[0]))
    };
    let candidates = try_indices(WHAT, 0..triangles.len(), |i| exceeds(i, &smallest))?;
    if candidates.is_empty() {
        return Ok(flags);
    }
    // Lower medians at the candidates' corners only.
    let mut wanted = try_filled(WHAT, false, uv.len())?;
    for &i in &candidates {
        triangles[i].iter().for_each(|&v| wanted[v as usize] = true);
    }
    let (mut areas, mut edges) = (Vec::new(), Vec::new());
    for t in triangles {
        if !t.iter().any(|&v| wanted[v as usize]) {
            continue;
        }
        if let Some((e, area)) = measure(t) {
            let (e, area) = (e.map(|x| x as f32), area as f32);
            for k in (0..3).filter(|&k| wanted[t[k] as usize]) {
                try_grow(WHAT, &mut areas, 1)?;
                try_grow(WHAT, &mut edges, 2)?;
                areas.push((t[k], area));
                edges.extend([(t[k], e[k]), (t[k], e[(k + 2) % 3])]);
            }
        }
    }
    let mut local = smallest;
    for (list, j) in [(areas, 0), (edges, 1)] {
        let mut list: Vec<(u32, f32)> = list;
        list.par_sort_unstable_by(|p, q| p.0.cmp(&q.0).then(p.1.total_cmp(&q.1)));
        for run in list.chunk_by(|p, q| p.0 == q.0) {
            local[run[0].0 as usize][j] = run[(run.len() - 1) / 2].1;
        }
    }
    for i in candidates {
        flags[i] = exceeds(i, &local);
    }
    Ok(flags)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::triangulate::delaunay::delaunay;
    use crate::triangulate::jumps::{bridging_triangles, DepthJumps, DEFAULT_JUMP_FACTOR};
    use crate::triangulate::trim::trim_long_edges;
    use glam::DVec3;

    /// A square grid of `n` × `n` points 1 apart at height 0, jittered in the plane by up to
    /// `jitter` (seeded), without those closer than `r` to `centre`.
    fn plate(n: usize, jitter: f64, centre: [f64; 2], r: f64) -> Vec<DVec3> {
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        (0..n * n)
            .map(|k| {
                let (x, y) = ((k % n) as f64, (k / n) as f64);
                DVec3::new(x + 2.0 * jitter * next(), y + 2.0 * jitter * next(), 0.0)
            })
            .filter(|p| (p.x - centre[0]).hypot(p.y - centre[1]) >= r)
            .collect()
    }

    fn planar(p: &[DVec3]) -> Vec<[f64; 2]> {
        p.iter().map(|q| [q.x, q.y]).collect()
    }

    #[test]
    fn a_bore_narrower_than_the_trim_length_is_opened_by_this_rule_alone() {
        // A bore 4.4 spacings across, off the grid's symmetry, in a flat plate: planar
        // trimming at 5 spacings covers it and no depth jump or 3-D gap shows.
        let centre = [12.3, 11.8];
        let p = plate(25, 0.0, centre, 2.2);
        let uv = planar(&p);
        let d = delaunay(&uv).unwrap();
        let over = |t: &[u32; 3]| {
            let m = t.iter().fold([0.0, 0.0], |s, &v| {
                [
                    s[0] + uv[v as usize][0] / 3.0,
                    s[1] + uv[v as usize][1] / 3.0,
                ]
            });
            (m[0] - centre[0]).hypot(m[1] - centre[1]) < 1.6
        };
        let jumps = DepthJumps {
            points: &p,
            factor: DEFAULT_JUMP_FACTOR,
            gaps: true,
        };
        let planar_only = trim_long_edges(&uv, &d.triangles, 5.0, None).unwrap();
        assert!(
            planar_only.iter().any(over),
            "the fixture must cover the bore"
        );
        let bridges = bridging_triangles(&uv, &d.triangles, jumps).unwrap();
        let flags = covering_holes(&uv, &d.triangles, DEFAULT_HOLE_FACTOR).unwrap();
        let near =
            |v: u32| (uv[v as usize][0] - centre[0]).hypot(uv[v as usize][1] - centre[1]) < 3.5;
        for ((t, &b), &h) in d.triangles.iter().zip(&bridges).zip(&flags) {
            assert!(
                !(over(t) && b),
                "{t:?}: the 3-D rules see no hole in a flat plate"
            );
            // Among the triangles planar trimming keeps, only those at the bore are flagged.
            if h && planar_only.contains(t) {
                assert!(
                    t.iter().any(|&v| near(v)),
                    "{t:?} flagged away from the bore"
                );
            }
        }
        let kept = trim_long_edges(&uv, &d.triangles, 5.0, Some(jumps)).unwrap();
        assert!(!kept.iter().any(over));
        // What the rule dropped besides the planar rule lies at the bore.
        assert!(planar_only.len() - kept.len() < 30);
        // Off at an infinite factor; the same flags at any scale.
        assert!(!covering_holes(&uv, &d.triangles, f64::INFINITY)
            .unwrap()
            .into_iter()
            .any(|f| f));
        for s in [1e-300, 1e300] {
            let scaled: Vec<[f64; 2]> = uv.iter().map(|q| [q[0] * s, q[1] * s]).collect();
            assert_eq!(
                covering_holes(&scaled, &d.triangles, DEFAULT_HOLE_FACTOR).unwrap(),
                flags
            );
        }
    }

    #[test]
    fn jittered_samples_without_a_hole_keep_their_inner_triangles() {
        let n = 40;
        let p = plate(n, 0.3, [-100.0, -100.0], 0.0);
        let uv = planar(&p);
        let d = delaunay(&uv).unwrap();
        let flags = covering_holes(&uv, &d.triangles, DEFAULT_HOLE_FACTOR).unwrap();
        let inner = |v: u32| {
            let q = uv[v as usize];
            (1.0..(n - 2) as f64).contains(&q[0]) && (1.0..(n - 2) as f64).contains(&q[1])
        };
        let flagged: Vec<_> = d
            .triangles
            .iter()
            .zip(&flags)
            .filter(|(t, &f)| f && t.iter().all(|&v| inner(v)))
            .collect();
        assert!(flagged.is_empty(), "{flagged:?}");
    }
}
