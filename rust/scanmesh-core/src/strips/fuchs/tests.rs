use super::dp::*;
use super::lookahead::*;
use super::weights::*;
use super::*;
use crate::geometry;
use std::f64::consts::FRAC_PI_3;
use std::f64::consts::PI;

/// A deterministic generator for test data (LCG, top 53 bits).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Random 3-D points, no structure at all.
fn random_line(rng: &mut Lcg, n: usize) -> Vec<DVec3> {
    (0..n)
        .map(|_| DVec3::new(rng.next(), rng.next(), rng.next()))
        .collect()
}

/// Two noisy scan lines along x, at y = 0 and y = 1, over a bumpy height, with
/// unequal point counts and a shifted start: what strips see in practice.
fn scan_pair(rng: &mut Lcg, n: usize, m: usize) -> (Vec<DVec3>, Vec<DVec3>) {
    let mut line = |count: usize, y: f64, shift: f64| -> Vec<DVec3> {
        let step = 10.0 / count as f64;
        (0..count)
            .map(|k| {
                let x = shift + step * (k as f64 + 0.3 * rng.next());
                let y = y + 0.1 * rng.next();
                DVec3::new(
                    x,
                    y,
                    (x * 0.9).sin() + 0.5 * (y * 2.0).cos() + 0.05 * rng.next(),
                )
            })
            .collect()
    };
    let a = line(n, 0.0, 0.0);
    let shift = 0.4 * (n as f64 * 0.618).fract();
    (a, line(m, 1.0, shift))
}

/// Case `k` of a mixed corpus: every third a pair of random lines, else a scan pair.
fn mixed_pair(rng: &mut Lcg, k: usize, n: usize, m: usize) -> (Vec<DVec3>, Vec<DVec3>) {
    if k % 3 == 0 {
        (random_line(rng, n), random_line(rng, m))
    } else {
        scan_pair(rng, n, m)
    }
}

const WEIGHTS: [Weight; 5] = [
    Weight::LENGTH,
    Weight::AREA,
    Weight::ANGLE,
    Weight::DIHEDRAL,
    Weight {
        length: 0.5,
        area: 2.0,
        angle: 1.0,
        dihedral: 0.3,
    },
];

/// Every monotone path with n − 1 A-steps and m − 1 B-steps, by recursion.
fn all_paths(n: usize, m: usize) -> Vec<Vec<Step>> {
    fn go(na: usize, nb: usize, prefix: &mut Vec<Step>, out: &mut Vec<Vec<Step>>) {
        if na == 0 && nb == 0 {
            out.push(prefix.clone());
            return;
        }
        for (s, left) in [(Step::A, na), (Step::B, nb)] {
            if left > 0 {
                prefix.push(s);
                if s == Step::A {
                    go(na - 1, nb, prefix, out);
                } else {
                    go(na, nb - 1, prefix, out);
                }
                prefix.pop();
            }
        }
    }
    let mut out = Vec::new();
    go(n - 1, m - 1, &mut Vec::new(), &mut out);
    out
}

fn binomial(n: usize, k: usize) -> usize {
    (0..k).fold(1, |acc, i| acc * (n - i) / (i + 1))
}

fn close(x: f64, y: f64) -> bool {
    (x - y).abs() <= 1e-9 * (1.0 + x.abs().max(y.abs()))
}

#[test]
fn smallest_angle_matches_three_atan2() {
    let mut rng = Lcg(7);
    for _ in 0..1000 {
        // Step A at (0, 0) adds triangle (a_0, a_1, b_0) at cost π/3 − smallest angle.
        let p = random_line(&mut rng, 3);
        let t = Terms::new(&p[..2], &p[2..], Weight::ANGLE).unwrap();
        let fast = FRAC_PI_3 - t.step(0, 0, Step::A).cost;
        let slow = geometry::smallest_angle(p[0], p[1], p[2]);
        assert!((fast - slow).abs() < 1e-12, "{fast} vs {slow}");
    }
}

#[test]
fn row_cache_steps_are_bit_identical_to_direct_steps() {
    let mut rng = Lcg(13);
    for trial in 0..80 {
        let (n, m) = (1 + trial % 9, 1 + (trial * 5) % 11);
        let (a, b) = if trial % 2 == 0 {
            (random_line(&mut rng, n), random_line(&mut rng, m))
        } else {
            scan_pair(&mut rng, 3 * n, 3 * m)
        };
        let (n, m) = (a.len(), b.len());
        // The whole matrix, and a band of half width 1 around the diagonal.
        let full = (vec![0; n], vec![m - 1; n]);
        let mut lo: Vec<usize> = (0..n).map(|i| (i * m / n).saturating_sub(1)).collect();
        let mut hi: Vec<usize> = (0..n).map(|i| (i * m / n + 1).min(m - 1)).collect();
        lo[0] = 0;
        hi[n - 1] = m - 1;
        for i in (0..n - 1).rev() {
            hi[i] = hi[i].max(lo[i + 1]).min(hi[i + 1]);
        }
        for (lo, hi) in [full, (lo, hi)] {
            for w in WEIGHTS {
                let t = Terms::new(&a, &b, w).unwrap();
                let ask = t.ask("test", String::new());
                let fast = dp_in_band(&t, &lo, &hi, &ask).unwrap();
                let slow = dp_in_band_with(&t, Direct(&t), &mut Sealed, &lo, &hi, &ask)
                    .unwrap()
                    .unwrap();
                assert_eq!(fast.cost.to_bits(), slow.cost.to_bits(), "{trial} {w:?}");
                assert_eq!(fast.path, slow.path);
            }
        }
    }
}

/// The cost of `path` straight from the definitions of [`Weight`], with libm's atan2
/// and the cross product form of the dihedral angle: the slow reference.
fn reference_path_cost(a: &[DVec3], b: &[DVec3], w: Weight, path: &[Step]) -> f64 {
    let (mut i, mut j) = (0, 0);
    let mut cost = w.length * (a[0] - b[0]).length();
    let mut previous: Option<DVec3> = None;
    for &s in path {
        let (p, q, r) = match s {
            Step::A => (a[i], a[i + 1], b[j]),
            Step::B => (a[i], b[j + 1], b[j]),
        };
        match s {
            Step::A => i += 1,
            Step::B => j += 1,
        }
        let normal = (q - p).cross(r - p);
        cost += w.length * (a[i] - b[j]).length()
            + w.area * geometry::triangle_area(p, q, r)
            + w.angle * (FRAC_PI_3 - geometry::smallest_angle(p, q, r));
        if let Some(n1) = previous {
            let angle = if n1 == DVec3::ZERO || normal == DVec3::ZERO {
                PI
            } else {
                n1.cross(normal).length().atan2(n1.dot(normal))
            };
            cost += w.dihedral * angle;
        }
        previous = Some(normal);
    }
    cost
}

#[test]
fn costs_match_the_reference_definitions() {
    let mut rng = Lcg(17);
    for trial in 0..60 {
        let (n, m) = (2 + trial % 40, 2 + (trial * 7) % 45);
        let (a, b) = mixed_pair(&mut rng, trial, n, m);
        for w in WEIGHTS {
            let s = shortest_path_banded(&a, &b, w, DEFAULT_BAND).unwrap();
            let reference = reference_path_cost(&a, &b, w, &s.path);
            let tolerance = 1e-12 * reference.abs().max(1.0);
            assert!(
                (s.cost - reference).abs() <= tolerance,
                "trial {trial} {w:?}: {} vs {reference}",
                s.cost
            );
            let again = path_cost(&a, &b, w, &s.path).unwrap();
            assert!((again - reference).abs() <= tolerance);
        }
    }
}

#[test]
fn dp_dijkstra_and_brute_force_agree_on_random_strips() {
    let mut rng = Lcg(11);
    for n in 1..=8 {
        for m in 1..=8 {
            let (a, b) = (random_line(&mut rng, n), random_line(&mut rng, m));
            let paths = all_paths(n, m);
            assert_eq!(paths.len(), binomial(n + m - 2, n - 1));
            for w in WEIGHTS {
                let brute = paths
                    .iter()
                    .map(|p| path_cost(&a, &b, w, p).unwrap())
                    .fold(f64::INFINITY, f64::min);
                let dp = shortest_path_dp(&a, &b, w).unwrap();
                let dij = shortest_path_dijkstra(&a, &b, w).unwrap();
                assert!(
                    close(dp.cost, brute),
                    "n={n} m={m} {w:?}: dp {} brute {brute}",
                    dp.cost
                );
                assert!(
                    close(dij.cost, brute),
                    "n={n} m={m} {w:?}: dijkstra {} brute {brute}",
                    dij.cost
                );
                // The reported cost is the cost of the reported path.
                assert!(close(path_cost(&a, &b, w, &dp.path).unwrap(), dp.cost));
                assert!(close(path_cost(&a, &b, w, &dij.path).unwrap(), dij.cost));
            }
        }
    }
}

#[test]
fn banded_equals_full_dp_on_scan_strips() {
    let mut rng = Lcg(23);
    for trial in 0..60 {
        let n = 5 + (rng.next() * 120.0) as usize;
        let m = 5 + (rng.next() * 120.0) as usize;
        let (a, b) = scan_pair(&mut rng, n, m);
        for w in WEIGHTS {
            let full = shortest_path_dp(&a, &b, w).unwrap();
            let band = shortest_path_banded(&a, &b, w, 1 + trial % 4).unwrap();
            assert!(
                close(full.cost, band.cost),
                "trial {trial} n={n} m={m} {w:?}: {} vs {}",
                full.cost,
                band.cost
            );
            assert!(close(path_cost(&a, &b, w, &band.path).unwrap(), band.cost));
        }
    }
}

#[test]
fn banded_is_a_valid_path_never_below_the_optimum_on_random_points() {
    let mut rng = Lcg(29);
    for n in 1..=8 {
        for m in 1..=8 {
            let (a, b) = (random_line(&mut rng, n), random_line(&mut rng, m));
            for w in WEIGHTS {
                let full = shortest_path_dp(&a, &b, w).unwrap();
                let band = shortest_path_banded(&a, &b, w, 1).unwrap();
                assert!(close(path_cost(&a, &b, w, &band.path).unwrap(), band.cost));
                assert!(band.cost >= full.cost - 1e-12, "n={n} m={m} {w:?}");
            }
        }
    }
}

/// One strip of the fuzz corpus: seeded by `k`, one of five kinds.
fn fuzz_strip(rng: &mut Lcg, k: usize) -> (Vec<DVec3>, Vec<DVec3>) {
    let mut size = |hi: usize| 1 + (rng.next() * hi as f64) as usize;
    match k % 5 {
        // No structure at all.
        0 => {
            let (n, m) = (size(9), size(9));
            (random_line(rng, n), random_line(rng, m))
        }
        // Noisy scan lines, unequal counts.
        1 => {
            let (n, m) = (1 + size(16), 1 + size(16));
            scan_pair(rng, n, m)
        }
        // Small integer coordinates (as the fuzz target decodes bytes): duplicates,
        // collinear runs, coincident points across the lines.
        2 => {
            let (n, m) = (size(8), size(8));
            let mut grid = |count: usize| -> Vec<DVec3> {
                (0..count)
                    .map(|_| {
                        let c = |r: &mut Lcg| (r.next() * 5.0).floor();
                        DVec3::new(c(rng), c(rng), c(rng) - 2.0)
                    })
                    .collect()
            };
            (grid(n), grid(m))
        }
        // A dense line against a sparse one, and a line folding back on itself.
        3 => {
            let (n, m) = (size(4), 5 + size(20));
            let (a, mut b) = scan_pair(rng, n, m);
            if k % 2 == 0 {
                let half = b.len() / 2;
                b[half..].reverse();
            }
            (a, b)
        }
        // Scan lines far apart (slivers everywhere) or nearly on top of each other.
        _ => {
            let (n, m) = (2 + size(12), 2 + size(12));
            let (mut a, b) = scan_pair(rng, n, m);
            let lift = if k % 2 == 0 { 8.0 } else { 0.99 };
            a.iter_mut().for_each(|p| p.y += lift);
            (a, b)
        }
    }
}

/// A random weight: each coefficient 0 or one of several magnitudes, one positive.
fn fuzz_weight(rng: &mut Lcg) -> Weight {
    const LEVELS: [f64; 6] = [0.0, 0.0, 1e-6, 0.3, 1.0, 100.0];
    loop {
        let mut c = || LEVELS[(rng.next() * LEVELS.len() as f64) as usize];
        let w = Weight {
            length: c(),
            area: c(),
            angle: c(),
            dihedral: c(),
        };
        if w.check().is_ok() {
            return w;
        }
    }
}

/// The fuzz corpus: `count` strips (see [`fuzz_strip`]), each with its weight (every third
/// one of [`WEIGHTS`], the others random), numbered.
fn fuzz_corpus(count: usize) -> impl Iterator<Item = (usize, Vec<DVec3>, Vec<DVec3>, Weight)> {
    let mut rng = Lcg(53);
    (0..count).map(move |k| {
        let (a, b) = fuzz_strip(&mut rng, k);
        let w = if k % 3 == 0 {
            WEIGHTS[k / 3 % WEIGHTS.len()]
        } else {
            fuzz_weight(&mut rng)
        };
        (k, a, b, w)
    })
}

#[test]
fn banded_is_exact_on_a_fuzz_corpus_of_100_000_strips() {
    let tol = |x: f64| 1e-9 * x.abs().max(1.0);
    for (k, a, b, w) in fuzz_corpus(100_000) {
        let dp = shortest_path_dp(&a, &b, w).unwrap();
        let band = shortest_path_banded(&a, &b, w, 1 + k % 4).unwrap();
        let context = || format!("strip {k}: n={} m={} {w:?}", a.len(), b.len());
        assert!(
            (band.cost - dp.cost).abs() <= tol(dp.cost),
            "{}: banded {} dp {}",
            context(),
            band.cost,
            dp.cost
        );
        let cost = path_cost(&a, &b, w, &band.path).unwrap();
        assert!((cost - band.cost).abs() <= tol(cost), "{}", context());
        // Dijkstra and look-ahead on every 8th strip: they are the slow references.
        if k % 8 == 0 {
            let dijkstra = shortest_path_dijkstra(&a, &b, w).unwrap();
            assert!(
                (dijkstra.cost - dp.cost).abs() <= tol(dp.cost),
                "{}",
                context()
            );
            let look = lookahead(&a, &b, w, 1 + k % 5).unwrap();
            assert!(look.cost >= dp.cost - tol(dp.cost), "{}", context());
        }
    }
}

#[test]
fn shortest_path_is_never_above_lookahead() {
    let mut rng = Lcg(31);
    for trial in 0..40 {
        let (n, m) = (2 + trial % 9, 2 + (trial * 7) % 13);
        let (a, b) = if trial % 2 == 0 {
            scan_pair(&mut rng, n * 3, m * 3)
        } else {
            (random_line(&mut rng, n), random_line(&mut rng, m))
        };
        for w in WEIGHTS {
            let best = shortest_path_dp(&a, &b, w).unwrap().cost;
            for alpha in 1..=6 {
                let look = lookahead(&a, &b, w, alpha).unwrap();
                assert!(close(path_cost(&a, &b, w, &look.path).unwrap(), look.cost));
                assert!(
                    best <= look.cost + 1e-9 * (1.0 + best.abs()),
                    "alpha {alpha} {w:?}: {best} > {}",
                    look.cost
                );
            }
        }
    }
}

#[test]
fn lookahead_reaching_the_end_is_optimal() {
    let mut rng = Lcg(37);
    for _ in 0..20 {
        let (a, b) = (random_line(&mut rng, 6), random_line(&mut rng, 5));
        for w in WEIGHTS {
            let look = lookahead(&a, &b, w, 9).unwrap();
            let best = shortest_path_dp(&a, &b, w).unwrap();
            assert!(
                close(look.cost, best.cost),
                "{w:?}: {} vs {}",
                look.cost,
                best.cost
            );
        }
    }
}

#[test]
fn greedy_lookahead_is_the_shortest_diagonal_rule() {
    let mut rng = Lcg(41);
    let (a, b) = scan_pair(&mut rng, 30, 20);
    let look = lookahead(&a, &b, Weight::LENGTH, 1).unwrap();
    let (mut i, mut j) = (0, 0);
    for &s in &look.path {
        if i + 1 < a.len() && j + 1 < b.len() {
            let shorter_a = (a[i + 1] - b[j]).length() <= (a[i] - b[j + 1]).length();
            assert_eq!(s == Step::A, shorter_a);
        }
        if s == Step::A {
            i += 1;
        } else {
            j += 1;
        }
    }
}

#[test]
fn greedy_walk_is_the_one_step_window_walk_bit_for_bit() {
    let mut rng = Lcg(43);
    for k in 0..300 {
        let (n, m) = (2 + k % 17, 2 + (k * 7) % 23);
        let (a, b) = mixed_pair(&mut rng, k, n, m);
        for w in WEIGHTS {
            let t = Terms::new(&a, &b, w).unwrap();
            let window = Window {
                cells: vec![UNREACHED; 4],
            };
            let slow = windowed(&t, window, 1).unwrap();
            let fast = greedy(&t).unwrap();
            assert_eq!(fast.path, slow.path, "{n} x {m}, {w:?}");
            assert_eq!(fast.cost.to_bits(), slow.cost.to_bits(), "{n} x {m}, {w:?}");
        }
    }
}

#[test]
fn unequal_lines_give_n_plus_m_minus_2_ccw_triangles() {
    let mut rng = Lcg(43);
    let (a, b) = scan_pair(&mut rng, 17, 40);
    for w in WEIGHTS {
        let s = shortest_path_banded(&a, &b, w, DEFAULT_BAND).unwrap();
        assert_eq!(s.path.len(), 17 + 40 - 2);
        let a_ids: Vec<u32> = (0..17).collect();
        let b_ids: Vec<u32> = (17..57).collect();
        let tris = path_triangles(&s.path, &a_ids, &b_ids).unwrap();
        let all: Vec<DVec3> = a.iter().chain(&b).copied().collect();
        let uv: Vec<[f64; 2]> = all.iter().map(|p| [p.x, p.y]).collect();
        // b lies at larger y, to the left of a's +x direction: every triangle is CCW.
        for t in &tris {
            assert!(
                geometry::orient2d(uv[t[0] as usize], uv[t[1] as usize], uv[t[2] as usize]) > 0.0
            );
        }
        let mesh = crate::mesh::HalfEdgeMesh::from_triangles(all.len(), &tris).unwrap();
        mesh.validate(&uv).unwrap();
    }
}

#[test]
fn bad_input_is_an_error() {
    let a = vec![DVec3::ZERO, DVec3::X];
    assert!(shortest_path_dp(&a, &[], Weight::LENGTH).is_err());
    assert!(lookahead(&a, &a, Weight::LENGTH, 0).is_err());
    assert!(shortest_path_banded(&a, &a, Weight::LENGTH, 0).is_err());
    let zero = Weight {
        length: 0.0,
        area: 0.0,
        angle: 0.0,
        dihedral: 0.0,
    };
    assert!(shortest_path_dp(&a, &a, zero).is_err());
    let negative = Weight {
        length: -1.0,
        ..Weight::AREA
    };
    assert!(shortest_path_dp(&a, &a, negative).is_err());
    let nan = vec![DVec3::ZERO, DVec3::new(f64::NAN, 0.0, 0.0)];
    assert!(shortest_path_dijkstra(&nan, &a, Weight::LENGTH).is_err());
    assert!(path_cost(&a, &a, Weight::LENGTH, &[Step::A]).is_err());
    assert!(path_triangles(&[Step::A, Step::A], &[0, 1], &[2, 3]).is_err());
}

/// `result` is a refusal of `option` whose message says `what`.
fn assert_refused(result: Result<Solution>, option: &str, what: &str) {
    match result {
        Err(Error::InvalidParameter { name, value, .. }) => {
            assert_eq!(name, option, "{value}");
            assert!(value.contains(what), "{value}");
        }
        other => panic!("expected a refusal of {option}, got {other:?}"),
    }
}

#[test]
fn oversized_strips_are_refused_before_the_work() {
    let line =
        |n: usize, y: f64| -> Vec<DVec3> { (0..n).map(|k| DVec3::new(k as f64, y, 0.0)).collect() };
    let (a, b) = (line(20_000, 0.0), line(20_000, 1.0));
    // 8e8 states: 7.2 GB.
    assert_refused(
        shortest_path_dijkstra(&a, &b, Weight::ANGLE),
        "solver",
        "GB",
    );
    let (a, b) = (line(50_000, 0.0), line(50_000, 1.0));
    // 2.5e9 cells of back-pointers.
    assert_refused(shortest_path_dp(&a, &b, Weight::ANGLE), "solver", "GB");
    let (a, b) = (line(1_500, 0.0), line(1_500, 1.0));
    assert_refused(
        lookahead(&a, &b, Weight::ANGLE, 1_000),
        "alpha",
        "window cells",
    );
}

#[test]
fn memory_the_system_refuses_is_an_error() {
    let a = vec![DVec3::ZERO, DVec3::X];
    let t = Terms::new(&a, &a, Weight::ANGLE).unwrap();
    let ask = t.ask("solver", "'dp'".into());
    let huge = ask.filled(usize::MAX / 4, 0u8);
    assert!(
        matches!(&huge, Err(Error::OutOfMemory { what, .. })
            if what.starts_with("the solver 'dp' on a strip of 2 × 2 points")),
        "{huge:?}"
    );
    assert!(matches!(
        ask.vec::<Step>(usize::MAX / 4),
        Err(Error::OutOfMemory { .. })
    ));
}

#[test]
fn lookahead_beyond_the_strip_is_the_optimum_at_dp_cost() {
    let mut rng = Lcg(47);
    for trial in 0..30 {
        let (a, b) = if trial % 2 == 0 {
            scan_pair(&mut rng, 5 + trial, 3 + 2 * trial)
        } else {
            (
                random_line(&mut rng, 1 + trial % 7),
                random_line(&mut rng, 2 + trial % 5),
            )
        };
        let edge = a.len() + b.len() - 2;
        for w in WEIGHTS {
            let best = shortest_path_dp(&a, &b, w).unwrap();
            for alpha in [edge.max(1), edge + 1, usize::MAX] {
                let look = lookahead(&a, &b, w, alpha).unwrap();
                assert!(close(look.cost, best.cost), "{trial} {w:?} {alpha}");
            }
            // Just below the edge, the windows still decide: a path, never below.
            if edge > 1 {
                let look = lookahead(&a, &b, w, edge - 1).unwrap();
                assert!(look.cost >= best.cost - 1e-9 * best.cost.abs().max(1.0));
            }
        }
    }
}

#[test]
fn single_points_make_fans() {
    let a: Vec<DVec3> = (0..5).map(|k| DVec3::new(k as f64, 0.0, 0.0)).collect();
    let b = vec![DVec3::new(2.0, 1.0, 0.0)];
    let s = shortest_path_dp(&a, &b, Weight::ANGLE).unwrap();
    assert_eq!(s.path, vec![Step::A; 4]);
    let one = shortest_path_dp(&a[..1], &b, Weight::LENGTH).unwrap();
    assert!(one.path.is_empty());
    assert!(close(one.cost, (a[0] - b[0]).length()));
}

/// Inputs of atan2 as the strips produce them and worse: random magnitudes in every
/// decade from 1e-300 to 1e300, and the near-degenerate cases (y far below |x|, x near 0,
/// y = |x|, zeros of either sign, sliver triangles' area and dot products).
fn atan2_inputs(rng: &mut Lcg, k: usize) -> (f64, f64) {
    let magnitude = |r: &mut Lcg| 10f64.powf(600.0 * r.next() - 300.0);
    let sign = |r: &mut Lcg| if r.next() < 0.5 { -1.0 } else { 1.0 };
    match k % 8 {
        0 => (rng.next(), 2.0 * rng.next() - 1.0),
        1 => (magnitude(rng), sign(rng) * magnitude(rng)),
        2 => {
            let x = sign(rng) * magnitude(rng);
            (x.abs() * 10f64.powf(-16.0 * rng.next()), x)
        }
        3 => {
            let y = magnitude(rng);
            (y, sign(rng) * y * 10f64.powf(-16.0 * rng.next()))
        }
        4 => {
            let y = magnitude(rng);
            (y, sign(rng) * y * (1.0 + 1e-12 * (rng.next() - 0.5)))
        }
        5 => [
            (0.0, 0.0),
            (0.0, -0.0),
            (0.0, 1.0),
            (0.0, -1.0),
            (1.0, 0.0),
            (1.0, -0.0),
        ][k / 8 % 6],
        _ => {
            // A sliver: p, q and r nearly on a line, at a random scale.
            let s = magnitude(rng).min(1e100);
            let p = DVec3::new(rng.next(), rng.next(), rng.next()) * s;
            let d = DVec3::new(rng.next(), rng.next(), rng.next()) * s;
            let off = DVec3::new(rng.next(), rng.next(), rng.next()) * s * 1e-9 * rng.next();
            let (q, r) = (p + d, p + d * (2.0 * rng.next() - 0.5) + off);
            ((q - p).cross(r - p).length(), (q - p).dot(r - p))
        }
    }
}

#[test]
fn atan2_cheap_is_within_its_bound() {
    // 2 million inputs (about 1 s in a debug build); `--ignored` runs 50 million.
    check_atan2_cheap(2_000_000);
}

#[test]
#[ignore]
fn atan2_cheap_is_within_its_bound_50_million() {
    check_atan2_cheap(50_000_000);
}

fn check_atan2_cheap(count: usize) {
    let mut rng = Lcg(34);
    let mut worst = 0.0f64;
    for k in 0..count {
        let (y, x) = atan2_inputs(&mut rng, k);
        let (cheap, exact) = (filter::atan2_cheap(y, x), geometry::atan2_upper(y, x));
        let error = (cheap - exact).abs();
        assert!(
            error <= filter::ATAN_ERROR,
            "atan2({y:e}, {x:e}): cheap {cheap} exact {exact}, error {error:e}"
        );
        worst = worst.max(error);
    }
    // The bound is not vacuous: the polynomial's own error shows.
    assert!(worst > 1e-9, "largest error {worst:e}");
    println!("{count} inputs, largest error {worst:e}");
}

#[test]
fn filtered_greedy_is_the_exact_walk_bit_for_bit_on_the_fuzz_corpus() {
    let mut counts = filter::FilterCounts::default();
    for (k, a, b, w) in fuzz_corpus(100_000) {
        let t = Terms::new(&a, &b, w).unwrap();
        let (exact, filtered) = (
            greedy(&t).unwrap(),
            greedy_filtered(&t, &mut counts).unwrap(),
        );
        assert_eq!(exact.path, filtered.path, "strip {k}: {w:?}");
        assert_eq!(exact.cost.to_bits(), filtered.cost.to_bits(), "strip {k}");
    }
    // The corpus has ties (integer coordinates, mirrored strips) and random strips where
    // turns decide: about a fifth fall back, which exercises the exact path.
    assert!(
        counts.fallbacks > 0 && counts.fallbacks < counts.decisions / 2,
        "{counts:?}"
    );
}

#[test]
fn filtered_greedy_is_the_exact_walk_on_long_scan_strips() {
    // The strips' default weight (the one the filter is used for) and the others; strips
    // with lines far apart (slivers) and with lines as far apart as their points.
    let default = Weight {
        length: 0.0,
        area: 0.0,
        angle: 1.0,
        dihedral: 0.3,
    };
    let mut rng = Lcg(7);
    let mut even = filter::FilterCounts::default();
    for k in 0..40 {
        let (a, b) = if k % 2 == 0 {
            scan_pair(&mut rng, 300 + 7 * k, 320 - 5 * k)
        } else {
            // The benches' height scan: spacing 1 along and across, jittered by ±0.15.
            let mut line = |y: f64, count: usize| -> Vec<DVec3> {
                (0..count)
                    .map(|c| {
                        let x = c as f64 + 0.3 * (rng.next() - 0.5);
                        let y = y + 0.3 * (rng.next() - 0.5);
                        DVec3::new(x, y, 5.0 * (0.05 * x).sin() * (0.04 * y).cos())
                    })
                    .collect()
            };
            (line(k as f64, 300 + k), line(k as f64 + 1.0, 310 - k))
        };
        for w in std::iter::once(default).chain(WEIGHTS) {
            let t = Terms::new(&a, &b, w).unwrap();
            let mut counts = filter::FilterCounts::default();
            let (exact, filtered) = (
                greedy(&t).unwrap(),
                greedy_filtered(&t, &mut counts).unwrap(),
            );
            assert_eq!(exact.path, filtered.path, "strip {k}: {w:?}");
            assert_eq!(exact.cost.to_bits(), filtered.cost.to_bits(), "strip {k}");
            if k % 2 == 1 && w == default {
                even.decisions += counts.decisions;
                even.fallbacks += counts.fallbacks;
            }
        }
    }
    // On a smooth scan with lines as far apart as their points, the bounds settle almost
    // every decision under the default weight (on rough or sliver strips the turn decides
    // more often, and then both steps are needed).
    assert!(
        even.decisions > 5_000 && even.fallbacks < even.decisions / 20,
        "{even:?}"
    );
}

#[test]
fn a_tie_falls_back_and_goes_to_a() {
    // A unit square: both first triangles are right isosceles, so their costs tie exactly
    // and no bound can separate them; the exact rule sends ties to A.
    let a = [DVec3::ZERO, DVec3::X];
    let b = [DVec3::Y, DVec3::X + DVec3::Y];
    let t = Terms::new(&a, &b, Weight::ANGLE).unwrap();
    let mut counts = filter::FilterCounts::default();
    let filtered = greedy_filtered(&t, &mut counts).unwrap();
    assert_eq!(
        counts,
        filter::FilterCounts {
            decisions: 1,
            fallbacks: 1
        }
    );
    assert_eq!(filtered.path, vec![Step::A, Step::B]);
    assert_eq!(filtered, greedy(&t).unwrap());
}
