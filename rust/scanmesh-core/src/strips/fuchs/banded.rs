//! The cheapest path inside a band around the strip's diagonal, widened until the band's
//! edge is provably not better.

use super::dp::{check_band, dp_in_band, dp_in_band_with, RowCache};
use super::weights::{Terms, Weight};
use super::{Ask, Solution};
use crate::{Error, Result};
use glam::DVec3;

/// The cheapest path of the whole matrix by DP inside a band around the diagonal, widened
/// until the band proves its path optimal.
///
/// The diagonal c(i) is the j of the b point nearest a_i along the strip's direction (so
/// lines of unequal extent, length or spacing get a diagonal that follows them). The DP
/// runs in the band of half width w around it (initially w = `half_width`) and lets paths
/// back in from outside at lower bounds of what they cost there (`fuchs/outside.rs`: the
/// length and the angle of a triangle whose corner lies far from the band bound its cost
/// from below). When its cheapest path stays inside the band, no path through the outside
/// can be cheaper, and that path is optimal over the whole matrix; otherwise w doubles and
/// the DP repeats; at the latest the band becomes the whole matrix (the full DP). So the
/// result is always the optimum (up to rounding: the same cost as [`shortest_path_dp`](super::shortest_path_dp) to
/// about 1e-12 relative; tested against it and Dijkstra on 100,000 fuzzed strips).
///
/// Time O((n + m) · w) and memory O(n · w) bytes for the final w (each round doubles the
/// width, so all rounds together cost less than twice the last); with the default weight
/// on scan strips the first band proves itself on almost every strip. Weights with only
/// area or dihedral angle bound nothing far away and widen to the full DP, O(nm) (refused
/// above [`MAX_STRIP_BYTES`](super::MAX_STRIP_BYTES)). Errors as [`shortest_path`](super::shortest_path), and `half_width` = 0.
pub fn shortest_path_banded(
    a: &[DVec3],
    b: &[DVec3],
    w: Weight,
    half_width: usize,
) -> Result<Solution> {
    let t = Terms::new(a, b, w)?;
    if half_width == 0 {
        return Err(Error::InvalidParameter {
            name: "half_width",
            value: "0".into(),
            expected: "a band half width of at least 1 column",
        });
    }
    let (n, m) = (t.n(), t.m());
    let ask = t.ask("solver", "'banded'".into());
    let center = diagonal(a, b, &ask)?;
    // Rows of the band of half width `w` around the diagonal, made passable.
    let band = |w: usize| -> Result<(Vec<usize>, Vec<usize>)> {
        let mut lo = ask.collect(center.iter().map(|&c| c.saturating_sub(w)))?;
        let mut hi = ask.collect(center.iter().map(|&c| c.saturating_add(w).min(m - 1)))?;
        lo[0] = 0;
        hi[n - 1] = m - 1;
        // Consecutive rows must share a column for a path to step down.
        for i in (0..n - 1).rev() {
            hi[i] = hi[i].max(lo[i + 1]).min(hi[i + 1]);
        }
        Ok((lo, hi))
    };
    let mut width = half_width;
    loop {
        let (lo, hi) = band(width)?;
        if lo.iter().all(|&x| x == 0) && hi.iter().all(|&x| x == m - 1) {
            return dp_in_band(&t, &lo, &hi, &ask);
        }
        let row_width = check_band(&t, &lo, &hi, &ask)?;
        let steps = RowCache::new(&t, row_width, &ask)?;
        let mut bounds = super::outside::Bounds::new(&t, &lo, &hi, &ask)?;
        if let Some(solution) = dp_in_band_with(&t, steps, &mut bounds, &lo, &hi, &ask)? {
            return Ok(solution);
        }
        width = width.saturating_mul(2);
    }
}

/// For each i, the index j of the b point nearest a_i along the strip's direction: the
/// projections onto d = (a_{n−1} − a_0) + (b_{m−1} − b_0) are matched by a merge walk. This
/// follows lines of unequal extent, spacing and point count; when d vanishes (closed or
/// coincident lines) normalized arc length stands in. Allocations as `ask`'s. O(n + m).
pub(super) fn diagonal(a: &[DVec3], b: &[DVec3], ask: &Ask) -> Result<Vec<usize>> {
    let d = (a[a.len() - 1] - a[0]) + (b[b.len() - 1] - b[0]);
    let (ta, tb) = if d.length_squared() > 0.0 {
        (
            ask.collect(a.iter().map(|p| p.dot(d)))?,
            ask.collect(b.iter().map(|p| p.dot(d)))?,
        )
    } else {
        (arc_length_fractions(a, ask)?, arc_length_fractions(b, ask)?)
    };
    let mut j = 0;
    ask.collect(ta.iter().map(|&x| {
        while j + 1 < tb.len() && (tb[j + 1] - x).abs() <= (tb[j] - x).abs() {
            j += 1;
        }
        j
    }))
}

/// Cumulative 3-D arc length of a line divided by its total (index fractions when the
/// points coincide). Allocations as `ask`'s. O(n).
pub(super) fn arc_length_fractions(line: &[DVec3], ask: &Ask) -> Result<Vec<f64>> {
    let mut s = ask.vec(line.len())?;
    let mut total = 0.0;
    s.push(0.0);
    for k in 1..line.len() {
        total += (line[k] - line[k - 1]).length();
        s.push(total);
    }
    let count = (line.len().max(2) - 1) as f64;
    ask.collect(s.iter().enumerate().map(|(k, &x)| {
        if total > 0.0 {
            x / total
        } else {
            k as f64 / count
        }
    }))
}
