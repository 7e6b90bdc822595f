//! The path weights: the four criteria's coefficients ([`Weight`]), their per-strip terms
//! (node lengths, triangle areas and angles, dihedral turns) and a step as the searches see it.

use super::{Ask, Step};
use crate::geometry::{atan2_upper, check_finite};
use crate::{Error, Result};
use glam::DVec3;
use std::f64::consts::{FRAC_PI_3, PI};

/// Coefficients of the four path criteria; the cost of a path is their weighted sum.
///
/// - `length`: on every node (i, j) of the path, including both ends, the 3-D length
///   |a_i − b_j| of the mesh edge it stands for (input units). Minimizing it with α = 1 is
///   the greedy shortest-diagonal rule.
/// - `area`: on every step, the 3-D area of the triangle it adds (squared input units);
///   the sum is the strip's surface area, the criterion of Fuchs, Kedem and Uselton (1977).
/// - `angle`: on every step, π/3 − (smallest 3-D angle of the triangle it adds), in
///   radians: 0 for an equilateral triangle, π/3 for a degenerate one. A strip always has
///   n + m − 2 triangles, so this maximizes the sum of the smallest angles.
/// - `dihedral`: on every pair of consecutive steps, the angle in [0, π] between the
///   normals of their two triangles, which share the edge of the node between the steps
///   (radians; `atan2(|n1 × n2|, n1 · n2)`); a degenerate triangle counts as a full fold
///   (π). This is smoothness inside the strip; it needs the previous step's direction in
///   the search state, which doubles the states.
///
/// Each coefficient must be finite and ≥ 0, and at least one positive. Mixing criteria of
/// different units is the caller's choice of scale (`strips` measures lengths in median
/// point steps so that mixtures are scale-free).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Weight {
    /// Coefficient of the edge length (per node).
    pub length: f64,
    /// Coefficient of the triangle area (per step).
    pub area: f64,
    /// Coefficient of the smallest-angle penalty π/3 − min angle (per step).
    pub angle: f64,
    /// Coefficient of the dihedral angle between consecutive triangles (per pair of steps).
    pub dihedral: f64,
}

impl Weight {
    /// Only the edge length.
    pub const LENGTH: Weight = Weight {
        length: 1.0,
        area: 0.0,
        angle: 0.0,
        dihedral: 0.0,
    };
    /// Only the triangle area (Fuchs et al.).
    pub const AREA: Weight = Weight {
        length: 0.0,
        area: 1.0,
        angle: 0.0,
        dihedral: 0.0,
    };
    /// Only the smallest-angle penalty.
    pub const ANGLE: Weight = Weight {
        length: 0.0,
        area: 0.0,
        angle: 1.0,
        dihedral: 0.0,
    };
    /// Only the dihedral angle.
    pub const DIHEDRAL: Weight = Weight {
        length: 0.0,
        area: 0.0,
        angle: 0.0,
        dihedral: 1.0,
    };

    /// Checks that every coefficient is finite and ≥ 0 and one is positive. O(1).
    pub fn check(&self) -> Result<()> {
        let all = [self.length, self.area, self.angle, self.dihedral];
        if all.iter().any(|c| !(c.is_finite() && *c >= 0.0)) || all.iter().all(|&c| c == 0.0) {
            return Err(Error::InvalidParameter {
                name: "weight",
                value: format!("{self:?}"),
                expected: "finite non-negative coefficients, at least one positive",
            });
        }
        Ok(())
    }
}

/// Per-criterion terms of one strip; every search below evaluates costs through it.
pub(super) struct Terms<'a> {
    pub(super) a: &'a [DVec3],
    pub(super) b: &'a [DVec3],
    pub(super) w: Weight,
}

/// Dihedral angle (radians, [0, π]) between triangles with normals `n1`, `n2` of any
/// length that share an edge e of length `len`; `apex` is the first triangle's corner off
/// e minus a point of e. π when a normal is zero (a degenerate triangle). O(1).
///
/// The definition is `atan2(|n1 × n2|, n1 · n2)`; both normals are perpendicular to e, so
/// n1 × n2 is parallel to it and, with n1 = ±apex × e, |n1 × n2| = |apex · n2| · |e|
/// (Lagrange: (u × e) × (v × e) = (u · (e × v)) e). That is one dot product where the
/// cross product form needs a cross product and a square root; `len` is the node length
/// every search computes anyway. Equal to the cross product form up to rounding (tested
/// against it to 1e-12 in path costs).
#[inline(always)]
pub(super) fn dihedral(n1: DVec3, apex: DVec3, len: f64, n2: DVec3) -> f64 {
    if n1 == DVec3::ZERO || n2 == DVec3::ZERO {
        return PI;
    }
    atan2_upper(apex.dot(n2).abs() * len, n1.dot(n2))
}

impl<'a> Terms<'a> {
    pub(super) fn new(a: &'a [DVec3], b: &'a [DVec3], w: Weight) -> Result<Self> {
        w.check()?;
        for (name, line) in [("a", a), ("b", b)] {
            if line.is_empty() {
                return Err(Error::InvalidParameter {
                    name: "line",
                    value: format!("{name} with 0 points"),
                    expected: "at least one point on each line",
                });
            }
            check_finite(line)?;
        }
        Ok(Terms { a, b, w })
    }

    pub(super) fn n(&self) -> usize {
        self.a.len()
    }

    /// This strip as chosen by `option` = `value`, for refusals.
    pub(super) fn ask(&self, option: &'static str, value: String) -> Ask {
        Ask {
            option,
            value,
            n: self.n(),
            m: self.m(),
        }
    }

    pub(super) fn m(&self) -> usize {
        self.b.len()
    }

    /// Weight of node (i, j). O(1).
    #[inline]
    pub(super) fn node(&self, i: usize, j: usize) -> f64 {
        if self.w.length == 0.0 {
            0.0
        } else {
            self.w.length * (self.a[i] - self.b[j]).length()
        }
    }

    /// The step `s` leaving (i, j): its cost (including the weight of the node it enters)
    /// and what the turn to the next step needs. O(1).
    #[inline]
    pub(super) fn step(&self, i: usize, j: usize, s: Step) -> Tri {
        self.triangle_of(&self.parts(i, j, s))
    }

    /// The vectors of the step `s` leaving (i, j), before any square root or atan2. O(1).
    #[inline]
    pub(super) fn parts(&self, i: usize, j: usize, s: Step) -> Parts {
        // The entered node (ti, tj) is the edge shared with the next triangle; the apex is
        // this triangle's third corner, taken relative to a_ti.
        let (p, q, r, ti, tj, apex) = match s {
            Step::A => (self.a[i], self.a[i + 1], self.b[j], i + 1, j, self.a[i]),
            Step::B => (self.a[i], self.b[j + 1], self.b[j], i, j + 1, self.b[j]),
        };
        let e = self.b[tj] - self.a[ti];
        Parts {
            len: e.length(),
            cross: (q - p).cross(r - p),
            sides: [
                (q - p).length_squared(),
                (r - q).length_squared(),
                (p - r).length_squared(),
            ],
            dots: [(p - r).dot(q - r), (q - p).dot(r - p), (r - q).dot(p - q)],
            apex: apex - self.a[ti],
        }
    }

    /// [`Terms::triangle`] of `parts`. O(1).
    #[inline(always)]
    pub(super) fn triangle_of(&self, parts: &Parts) -> Tri {
        self.triangle(parts.len, parts.cross, parts.sides, parts.dots, parts.apex)
    }

    /// [`Terms::triangle_of`] given its doubled area |cross| (a triangle criterion on). O(1).
    #[inline(always)]
    pub(super) fn triangle_with_area(&self, parts: &Parts, twice_area: f64) -> Tri {
        let angle = if self.w.angle != 0.0 {
            atan2_upper(twice_area, smallest_angle_dot(parts.sides, parts.dots))
        } else {
            0.0
        };
        Tri {
            cost: self.cost_at(parts.len, twice_area, angle),
            // The dihedral angle is scale-free: the cross product serves as the normal.
            normal: if self.w.dihedral != 0.0 {
                parts.cross
            } else {
                DVec3::ZERO
            },
            apex: parts.apex,
            len: parts.len,
        }
    }

    /// Whether any triangle criterion (area, angle, dihedral) is on. O(1).
    #[inline]
    pub(super) fn needs_triangles(&self) -> bool {
        self.w.area != 0.0 || self.w.angle != 0.0 || self.w.dihedral != 0.0
    }

    /// A step from its parts: `len` = length of the entered node's edge a_i–b_j,
    /// its triangle (p, q, r) by `cross` = (q − p) × (r − p), squared sides
    /// [|pq|², |qr|², |rp|²], the dot products of the two sides at the corners opposite
    /// them [at r, at p, at q], and `apex` = the corner off the entered edge minus a_i.
    /// Every evaluation of a step goes through here, whether its vectors are computed on
    /// the spot ([`Terms::step`]) or taken from the DP's row caches ([`dp_in_band`](super::dp::dp_in_band)), so
    /// both give bit-identical costs. Branch-free apart from the weight switches, which are
    /// the same for every call. O(1).
    #[inline(always)]
    pub(super) fn triangle(
        &self,
        len: f64,
        cross: DVec3,
        sides: [f64; 3],
        dots: [f64; 3],
        apex: DVec3,
    ) -> Tri {
        if !self.needs_triangles() {
            // The length weight alone needs no triangle (the hot path of `Weight::LENGTH`).
            return Tri {
                cost: self.cost_at(len, 0.0, 0.0),
                normal: DVec3::ZERO,
                apex: DVec3::ZERO,
                len,
            };
        }
        let parts = Parts {
            len,
            cross,
            sides,
            dots,
            apex,
        };
        self.triangle_with_area(&parts, cross.length())
    }

    /// A step's cost from the entered node's length `len`, its triangle's doubled area
    /// and its smallest angle `angle` (radians; read only when the angle weight is on):
    /// the length, area and angle terms added in that order. Non-increasing in `angle`
    /// (every operation is monotone and rounding to nearest is too), which the filtered
    /// walk (`filter`) uses to bound the cost from a bound on the angle. O(1).
    #[inline(always)]
    pub(super) fn cost_at(&self, len: f64, twice_area: f64, angle: f64) -> f64 {
        let mut cost = if self.w.length == 0.0 {
            0.0
        } else {
            self.w.length * len
        };
        if self.w.area != 0.0 {
            cost += self.w.area * 0.5 * twice_area;
        }
        if self.w.angle != 0.0 {
            cost += self.w.angle * (FRAC_PI_3 - angle);
        }
        cost
    }

    /// Cost of the turn from triangle `from` to the next one, with normal `n2`. O(1).
    #[inline(always)]
    pub(super) fn turn(&self, n1: DVec3, apex: DVec3, len: f64, n2: DVec3) -> f64 {
        if self.w.dihedral == 0.0 {
            0.0
        } else {
            self.w.dihedral * dihedral(n1, apex, len, n2)
        }
    }

    /// [`Terms::turn`] from a whole step. O(1).
    #[inline]
    pub(super) fn turn_from(&self, from: &Tri, n2: DVec3) -> f64 {
        self.turn(from.normal, from.apex, from.len, n2)
    }
}

/// The cost `step` adds after the triangle `entered` (none at the start): its own cost
/// plus the turn. O(1).
#[inline(always)]
pub(super) fn with_turn(t: &Terms, step: Tri, entered: &Option<Tri>) -> f64 {
    step.cost + entered.map_or(0.0, |e| t.turn_from(&e, step.normal))
}

/// The dot product of the two sides at a triangle's smallest angle, from its squared sides
/// [|pq|², |qr|², |rp|²] and its corner products [at r, at p, at q] (see
/// [`Terms::triangle`]); 0 for a degenerate triangle. O(1).
#[inline(always)]
pub(super) fn smallest_angle_dot(sides: [f64; 3], dots: [f64; 3]) -> f64 {
    // The smallest angle is at the corner opposite the shortest side (law of sines).
    let [pq, qr, rp] = sides;
    let k = usize::from(pq > qr || pq > rp) * (1 + usize::from(qr > rp));
    // That angle is at most π/3, so its cosine is positive; only a degenerate triangle
    // (coincident corners) gives a dot product of 0 or below, and a -0.0 (the row cache
    // negates differences) would make atan2 return π and the penalty negative. Its
    // smallest angle is 0.
    if dots[k] > 0.0 {
        dots[k]
    } else {
        0.0
    }
}

/// The vectors of one step (see [`Terms::triangle`] for their meaning).
#[derive(Debug, Clone, Copy)]
pub(super) struct Parts {
    pub(super) len: f64,
    pub(super) cross: DVec3,
    pub(super) sides: [f64; 3],
    pub(super) dots: [f64; 3],
    pub(super) apex: DVec3,
}

/// A step as the searches need it.
#[derive(Debug, Clone, Copy)]
pub(super) struct Tri {
    /// Its cost: the weight of the node it enters plus its triangle's terms.
    pub(super) cost: f64,
    /// (q − p) × (r − p) of its triangle (p, q, r), unnormalized; zero when the dihedral
    /// weight is off.
    pub(super) normal: DVec3,
    /// Its triangle's corner off the edge a_i–b_j of the node (i, j) it enters, minus a_i.
    pub(super) apex: DVec3,
    /// |a_i − b_j| of the node it enters.
    pub(super) len: f64,
}
