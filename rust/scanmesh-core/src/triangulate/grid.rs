//! Triangulation along a range grid: neighbours in the scanner's grid of samples form the
//! candidate triangles, and a triangle is kept only where the scanner could have seen it
//! (its normal within a turn of the line of sight, its edges within a multiple of the
//! local grid spacing), so no curtain hangs across a depth jump.
//!
//! ```text
//!   row r    a ── b        4 corners: split along the shorter 3-D diagonal
//!            │ ╲  │        (a-e here: triangles a b e and a e d);
//!   row r+1  d ── e        3 corners: their one triangle; fewer: nothing
//! ```
//!
//! Where an outline crosses the grid at a slant, the cells leave a staircase of notches
//! along it; notches no ray of the grid passes through are filled where the outline is not
//! concave (`notches`).

use crate::budget::{shares_mut, try_filled, try_grow, try_indices, try_vec};
use crate::geometry::UnitSquare;
use crate::mesh::NONE;
use crate::triangulate::notches::{area_sign, fill_notches, GridAt, EAR_TURN_DEG};
use crate::triangulate::trim::peeled_flags;
use crate::{Error, Result};
use glam::DVec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering::Relaxed};

/// Default largest turn (degrees) of a kept triangle's normal away from the line of sight.
/// 85°: every kept face is then at least 5° from the sight, the curtain report's angle (the
/// issue's curtain), so the rule drops exactly the curtains. Chosen by benches/curtains.py
/// over nine simulated range scans of four CAD parts: faces on the part turn far less than
/// 85°, while the sheets turned 80-85° across a step a few spacings high are what the best
/// peers cover walls with, so a lower limit leaves more of the area missed and a higher one
/// allows faces the curtain report counts; the price is some height error where those
/// sheets stand (figures in docs/benchmarks/curtains.md, "Figures behind the core's
/// constants").
pub const DEFAULT_GRID_TURN_DEG: f64 = 85.0;

/// Default edge factor: a triangle with a 3-D edge longer than this multiple of the local
/// grid spacing (see [`grid_triangulate`]) is dropped. On the same panel the longest edge of
/// faces within 0.25 spacings of the part is 5.88 spacings at the 99th percentile, of the
/// sheets 0.25 to 2 spacings off 7.0 at the median (the pocket's 7-spacing step: up to 7.2).
/// 8 keeps those sheets (6, the earlier default, drops them at any θ); with θ = 85° no face
/// more than 2 spacings off is kept (without the turn rule 8 keeps none either, ∞ keeps all
/// 88 of them; 85° without an edge limit keeps sheets 0.090 spacings RMS off).
pub const DEFAULT_GRID_EDGE_FACTOR: f64 = 8.0;

/// Rows of the grid per rayon task.
const ROWS_PER_TASK: usize = 64;

/// Columns of the grid per rayon task of the column spacings.
const COLS_PER_TASK: usize = 32;

/// The rules of [`grid_triangulate`]: where the scanner looked from and what it can see.
#[derive(Debug, Clone, Copy)]
pub struct GridParams {
    /// The line of sight (either sign; normalized here).
    pub sight: DVec3,
    /// θ: the largest turn (degrees, in (0, 90]) of a kept normal from the line of sight.
    pub max_turn_deg: f64,
    /// k: the longest kept 3-D edge in local grid spacings (> 0; ∞ turns the rule off).
    pub edge_factor: f64,
}

impl GridParams {
    /// The defaults ([`DEFAULT_GRID_TURN_DEG`], [`DEFAULT_GRID_EDGE_FACTOR`]) along `sight`.
    pub fn along(sight: DVec3) -> Self {
        Self {
            sight,
            max_turn_deg: DEFAULT_GRID_TURN_DEG,
            edge_factor: DEFAULT_GRID_EDGE_FACTOR,
        }
    }
}

/// What [`grid_triangulate`] made and why it dropped what it dropped.
#[derive(Debug, Clone, Default)]
pub struct GridTriangles {
    /// Kept triangles, counter-clockwise in the plane (`uv`), over the caller's indices.
    pub triangles: Vec<[u32; 3]>,
    /// Candidate triangles (grid neighbours).
    pub candidates: usize,
    /// Candidates dropped because their normal turns more than θ from the line of sight.
    pub turned: usize,
    /// Candidates dropped for an edge longer than k x the local grid spacing.
    pub long: usize,
    /// Candidates dropped because they are folded over or degenerate in the plane.
    pub folded: usize,
    /// Triangles dropped afterwards so that the rest is a valid planar triangulation:
    /// the smaller fans at a pinched vertex, collinear slivers on the boundary.
    pub peeled: usize,
    /// Triangles added afterwards in the notches of the outline (`fill_notches`).
    pub filled: usize,
    /// Median grid spacing across the line of sight (input units; 0 when there is none).
    pub spacing: f64,
    /// The points in no kept triangle (in the grid or not), ascending.
    pub unused: Vec<u32>,
}

/// Checks the grid's shape and indices and the two factors.
fn check(grid: &[i64], rows: usize, cols: usize, n: usize, turn: f64, factor: f64) -> Result<()> {
    if rows.checked_mul(cols) != Some(grid.len()) {
        return Err(Error::InvalidParameter {
            name: "grid",
            value: format!("{} cells for {rows} x {cols}", grid.len()),
            expected: "rows x cols cells",
        });
    }
    if let Some(cell) = grid.iter().position(|&g| g < -1 || g >= n as i64) {
        return Err(Error::InvalidParameter {
            name: "grid",
            value: format!("cell {cell} = {} (of {n} points)", grid[cell]),
            expected: "-1 or the index of a point",
        });
    }
    if !(turn > 0.0 && turn <= 90.0) {
        return Err(Error::InvalidParameter {
            name: "max_turn",
            value: format!("{turn}"),
            expected: "degrees in (0, 90]",
        });
    }
    if factor.is_nan() || factor <= 0.0 {
        return Err(Error::InvalidParameter {
            name: "edge_factor",
            value: format!("{factor}"),
            expected: "a positive number (inf: no limit)",
        });
    }
    Ok(())
}

/// Length of `d` across the unit line of sight `s`, measured on `d` scaled to about 1 by a
/// power of two (exact) so that coordinates from 1e-300 to 1e300 neither overflow nor
/// underflow.
fn across(d: DVec3, s: DVec3) -> f64 {
    let unit = UnitSquare::by(d.abs().max_element());
    let u = d.map(|x| unit.scale(x));
    unit.unscale((u - u.dot(s) * s).length())
}

/// Median of `values` (NaN for none); reorders them. O(n).
fn median(values: &mut [f64]) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    let mid = values.len() / 2;
    *values.select_nth_unstable_by(mid, f64::total_cmp).1
}

/// Per row, the median spacing between neighbours along it, and per column, between
/// neighbours across rows, measured across the line of sight (NaN where a row or column
/// has no neighbouring pair). O(rows x cols).
fn local_spacings(
    grid: &[i64],
    rows: usize,
    cols: usize,
    points: &[DVec3],
    s: DVec3,
) -> (Vec<f64>, Vec<f64>) {
    let at = |r: usize, c: usize| grid[r * cols + c];
    let row_spacing: Vec<f64> = (0..rows)
        .into_par_iter()
        .map(|r| {
            let mut steps: Vec<f64> = (0..cols.saturating_sub(1))
                .filter_map(|c| match (at(r, c), at(r, c + 1)) {
                    (a, b) if a >= 0 && b >= 0 => {
                        Some(across(points[b as usize] - points[a as usize], s))
                    }
                    _ => None,
                })
                .collect();
            median(&mut steps)
        })
        .collect();
    // Columns are taken COLS_PER_TASK at a time and walked row by row, so each step reads
    // a contiguous run of the grid (one column alone would stride a whole row per step).
    let col_spacing: Vec<f64> = (0..cols.div_ceil(COLS_PER_TASK))
        .into_par_iter()
        .flat_map_iter(|task| {
            let columns = task * COLS_PER_TASK..((task + 1) * COLS_PER_TASK).min(cols);
            let mut steps = vec![Vec::with_capacity(rows.saturating_sub(1)); columns.len()];
            for r in 0..rows.saturating_sub(1) {
                for (column, c) in steps.iter_mut().zip(columns.clone()) {
                    let (a, b) = (at(r, c), at(r + 1, c));
                    if a >= 0 && b >= 0 {
                        column.push(across(points[b as usize] - points[a as usize], s));
                    }
                }
            }
            steps.into_iter().map(|mut column| median(&mut column))
        })
        .collect();
    (row_spacing, col_spacing)
}

/// Corners of a grid cell by code: 0 = a (r, c), 1 = b (r, c + 1), 2 = d (r + 1, c),
/// 3 = e (r + 1, c + 1).
type Codes = [u8; 3];

/// The candidate triangles of a cell with these corner indices (-1: missing), as corner
/// codes in the grid's own winding (a b e / a e d or a b d / b e d, or the three present
/// corners in the same turn).
fn cell_triangles(corners: [i64; 4], points: &[DVec3], out: &mut Vec<Codes>) {
    let [a, b, d, e] = corners;
    let p = |k: i64| points[k as usize];
    match (a >= 0, b >= 0, d >= 0, e >= 0) {
        (true, true, true, true) => {
            if (p(e) - p(a)).length_squared() <= (p(d) - p(b)).length_squared() {
                out.extend([[0, 1, 3], [0, 3, 2]]);
            } else {
                out.extend([[0, 1, 2], [1, 3, 2]]);
            }
        }
        (false, true, true, true) => out.push([1, 3, 2]),
        (true, false, true, true) => out.push([0, 3, 2]),
        (true, true, false, true) => out.push([0, 1, 3]),
        (true, true, true, false) => out.push([0, 1, 2]),
        _ => {}
    }
}

/// The neighbouring cell (offset in rows and columns) across the cell edge between corner
/// codes `x` and `y`, and the codes of the same two corners there; the diagonal stays in
/// the cell.
fn across_edge(x: u8, y: u8) -> (isize, isize, u8, u8) {
    // corner (dr, dc) of code k: 0 = (0, 0), 1 = (0, 1), 2 = (1, 0), 3 = (1, 1)
    let (rx, cx, ry, cy) = (
        (x >> 1) as isize,
        (x & 1) as isize,
        (y >> 1) as isize,
        (y & 1) as isize,
    );
    let (dr, dc) = match (rx == ry, cx == cy) {
        (true, false) => (2 * rx - 1, 0), // a row edge: the cell above (top edge) or below
        (false, true) => (0, 2 * cx - 1), // a column edge: the cell left or right
        _ => (0, 0),                      // the diagonal
    };
    let code = |r: isize, c: isize| ((r - dr) * 2 + (c - dc)) as u8;
    (dr, dc, code(rx, cx), code(ry, cy))
}

/// Half-edge twins of triangles given by cell and corner codes, cells ascending (half-edge
/// 3t + k runs from corner k of triangle t; NONE on the boundary), from the grid itself:
/// the twin lies in the same cell or the one across the edge, found through each cell's
/// first triangle, in parallel; an [`Error::OutOfMemory`] when its arrays cannot be
/// allocated. O(m + cells).
fn grid_twins(cells: &[u32], codes: &[Codes], cols: usize, rows: usize) -> Result<Vec<u32>> {
    let n_cells = (rows - 1) * (cols - 1);
    let mut first = try_filled(GRID, 0u32, n_cells + 1)?;
    for &cell in cells {
        first[cell as usize + 1] += 1;
    }
    for k in 0..n_cells {
        first[k + 1] += first[k];
    }
    let mut twins = try_filled(GRID, NONE, 3 * codes.len())?;
    let last = ((rows - 1) as isize, (cols - 1) as isize);
    twins
        .par_chunks_mut(3)
        .with_min_len(1 << 12)
        .enumerate()
        .for_each(|(t, out)| {
            // one division per triangle: its cell's row and column
            let cell = cells[t] as usize;
            let (row, col) = ((cell / (cols - 1)) as isize, (cell % (cols - 1)) as isize);
            for (k, twin) in out.iter_mut().enumerate() {
                let (x, y) = (codes[t][k], codes[t][(k + 1) % 3]);
                let (dr, dc, nx, ny) = across_edge(x, y);
                let (r, c) = (row + dr, col + dc);
                if r < 0 || c < 0 || r >= last.0 || c >= last.1 {
                    continue;
                }
                let other = r as usize * (cols - 1) + c as usize;
                // the twin runs the other way: from y to x
                *twin = (first[other]..first[other + 1])
                    .filter(|&u| u as usize != t)
                    .find_map(|u| {
                        let code = codes[u as usize];
                        (0..3)
                            .find(|&j| code[j] == ny && code[(j + 1) % 3] == nx)
                            .map(|j| 3 * u + j as u32)
                    })
                    .unwrap_or(NONE);
            }
        });
    Ok(twins)
}

/// What the grid's failed allocations name.
const GRID: &str = "the grid's triangles";

/// The candidates of a block of rows: those kept (in the grid's winding) with the signs of
/// their planar areas, and the counts of each verdict.
struct Block {
    kept: Vec<[u32; 3]>,
    codes: Vec<Codes>,
    cells: Vec<u32>,
    signs: Vec<i8>,
    /// How many kept have each sign: -1, 0, 1 at 0, 1, 2.
    of_sign: [usize; 3],
    candidates: usize,
    turned: usize,
    long: usize,
}

impl Block {
    /// An empty block with room for `candidates` triangles in each list, allocated
    /// fallibly (an [`Error::OutOfMemory`]): the lists then never grow. O(1).
    fn with_room(candidates: usize) -> Result<Self> {
        Ok(Block {
            kept: try_vec(GRID, candidates)?,
            codes: try_vec(GRID, candidates)?,
            cells: try_vec(GRID, candidates)?,
            signs: try_vec(GRID, candidates)?,
            of_sign: [0; 3],
            candidates: 0,
            turned: 0,
            long: 0,
        })
    }
}

/// What becomes of a candidate: kept, or dropped by which rule.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Verdict {
    Keep,
    Turned,
    Long,
}

/// Triangulates a range grid: the candidate triangles of every grid cell (a 2 x 2 block of
/// neighbouring samples; four present corners split along the shorter 3-D diagonal, three
/// give one triangle), less those the scanner cannot have seen:
///
/// - **turned**: the triangle's normal turns more than `params.max_turn_deg` (θ) from the
///   line of sight `params.sight` (either sign): a sheet across a depth jump stands edge-on to the rays;
/// - **long**: a 3-D edge exceeds `params.edge_factor` (k) x the local grid spacing, the largest
///   of the median neighbour spacings (measured across the line of sight) of the cell's
///   rows and columns;
/// - **folded**: zero or reversed area in the plane `uv` against the grid's own winding
///   (the sign most candidates have), so the kept triangles never
///   overlap locally in the plane;
/// - **peeled**: then the smaller fans at each pinched vertex and the collinear slivers on
///   the boundary (as trimming peels them), so the result is a valid planar triangulation
///   LOP and annealing can start from.
///
/// `grid` is `rows x cols`, row-major: `grid[r * cols + c]` the index of the sample at row
/// `r` (a scan line) and column `c`, or -1 where the scanner saw nothing. `uv` (planar) and
/// `points` (3-D) share indices. Kept triangles are counter-clockwise in `uv`. O(rows x
/// cols), in parallel over blocks of rows; the output keeps row order, so it does not
/// depend on the number of threads.
///
/// # Errors
/// `InvalidParameter` for a grid of the wrong size or with an index out of range, a zero
/// or non-finite line of sight, θ outside (0, 90], or a factor that is not positive.
pub fn grid_triangulate(
    grid: &[i64],
    rows: usize,
    cols: usize,
    uv: &[[f64; 2]],
    points: &[DVec3],
    params: GridParams,
) -> Result<GridTriangles> {
    let GridParams {
        sight,
        max_turn_deg,
        edge_factor,
    } = params;
    let n = points.len().min(uv.len());
    check(grid, rows, cols, n, max_turn_deg, edge_factor)?;
    let s = sight.normalize_or_zero();
    if !s.is_finite() || s == DVec3::ZERO {
        return Err(Error::InvalidParameter {
            name: "sight",
            value: format!("{sight}"),
            expected: "a non-zero finite direction",
        });
    }
    let (row_spacing, col_spacing) = local_spacings(grid, rows, cols, points, s);
    let mut all: Vec<f64> = row_spacing
        .iter()
        .chain(&col_spacing)
        .copied()
        .filter(|x| x.is_finite())
        .collect();
    let spacing = median(&mut all);
    let spacing = if spacing.is_finite() { spacing } else { 0.0 };
    let cos_turn = max_turn_deg.to_radians().cos();
    // The local spacing of a cell: its rows' and columns' medians, the scan's where a row
    // or column has none.
    let local = |r: usize, c: usize| -> f64 {
        [
            row_spacing[r],
            row_spacing[(r + 1).min(rows - 1)],
            col_spacing[c],
            col_spacing[(c + 1).min(cols - 1)],
        ]
        .into_iter()
        .filter(|x| x.is_finite())
        .fold(f64::NAN, f64::max)
    };
    let judge = |t: &[u32; 3], h: f64, cos_turn: f64| -> Verdict {
        let [a, b, c] = t.map(|k| points[k as usize]);
        // edges scaled to about 1 by a power of two (exact, a multiply where a division
        // cost a third of the judging): no overflow or underflow from 1e-300 to 1e300
        let unit = UnitSquare::by((b - a).abs().max_element().max((c - a).abs().max_element()));
        let (e1, e2) = (
            (b - a).map(|x| unit.scale(x)),
            (c - a).map(|x| unit.scale(x)),
        );
        let n = e1.cross(e2);
        let length = n.length();
        if length == 0.0 || n.dot(s).abs() < cos_turn * length {
            return Verdict::Turned;
        }
        let limit = unit.scale(edge_factor * if h.is_finite() { h } else { spacing });
        let longest = e1
            .length_squared()
            .max(e2.length_squared())
            .max((e2 - e1).length_squared());
        if longest > limit * limit {
            return Verdict::Long;
        }
        Verdict::Keep
    };
    let blocks: Vec<Block> = (0..rows.saturating_sub(1))
        .collect::<Vec<_>>()
        .par_chunks(ROWS_PER_TASK)
        .map(|block| {
            // At most two triangles a cell.
            let mut out = Block::with_room(2 * block.len() * cols.saturating_sub(1))?;
            let mut cell = Vec::with_capacity(2);
            for &r in block {
                for c in 0..cols.saturating_sub(1) {
                    let at = |i: usize, j: usize| grid[i * cols + j];
                    cell.clear();
                    let corners = [at(r, c), at(r, c + 1), at(r + 1, c), at(r + 1, c + 1)];
                    cell_triangles(corners, points, &mut cell);
                    let h = local(r, c);
                    for code in &cell {
                        out.candidates += 1;
                        let t = code.map(|k| corners[k as usize] as u32);
                        match judge(&t, h, cos_turn) {
                            Verdict::Keep => {
                                out.kept.push(t);
                                out.codes.push(*code);
                                out.cells.push((r * (cols - 1) + c) as u32);
                                let [a, b, c] = t.map(|k| k as usize);
                                let area = area_sign(uv, a, b, c);
                                out.signs.push(area);
                                out.of_sign[(area + 1) as usize] += 1;
                            }
                            Verdict::Turned => out.turned += 1,
                            Verdict::Long => out.long += 1,
                        }
                    }
                }
            }
            Ok(out)
        })
        .collect::<Result<_>>()?;
    let count = |sign: i8| -> usize { blocks.iter().map(|b| b.of_sign[(sign + 1) as usize]).sum() };
    let sign: i8 = if count(-1) > count(1) { -1 } else { 1 };
    // The blocks' triangles of the majority sign, written in place in parallel: block i's
    // share starts after the shares of blocks 0..i.
    let shares: Vec<usize> = blocks
        .iter()
        .map(|b| b.of_sign[(sign + 1) as usize])
        .collect();
    let total_kept: usize = shares.iter().sum();
    let mut triangles = try_filled(GRID, [0u32; 3], total_kept)?;
    let mut codes = try_filled(GRID, [0u8; 3], total_kept)?;
    let mut cells = try_filled(GRID, 0u32, total_kept)?;
    let parts: Vec<_> = (shares_mut(&mut triangles, &shares).into_iter())
        .zip(shares_mut(&mut codes, &shares))
        .zip(shares_mut(&mut cells, &shares))
        .map(|((t, c), e)| (t, c, e))
        .collect();
    let flip = sign < 0;
    let mut out = GridTriangles {
        spacing,
        candidates: blocks.iter().map(|b| b.candidates).sum(),
        turned: blocks.iter().map(|b| b.turned).sum(),
        long: blocks.iter().map(|b| b.long).sum(),
        folded: blocks.iter().map(|b| b.kept.len()).sum::<usize>() - total_kept,
        ..GridTriangles::default()
    };
    blocks
        .into_par_iter()
        .zip(parts)
        .for_each(|(block, (t_out, c_out, e_out))| {
            let same = (block.kept.iter().zip(&block.codes).zip(&block.cells))
                .zip(&block.signs)
                .filter(|(_, &area)| area == sign);
            for ((((t, code), &cell), _), ((t_to, c_to), e_to)) in
                same.zip(t_out.iter_mut().zip(c_out.iter_mut()).zip(e_out.iter_mut()))
            {
                *t_to = if flip { [t[0], t[2], t[1]] } else { *t };
                *c_to = if flip {
                    [code[0], code[2], code[1]]
                } else {
                    *code
                };
                *e_to = cell;
            }
        });
    out.triangles = triangles;
    // Cells dropped around a vertex can leave it joining two fans (a pinch); LOP and
    // annealing need a manifold start, as trimming gives them. The twins come from the
    // grid's edges, so no half-edge search is needed.
    if !out.triangles.is_empty() {
        let twins = grid_twins(&cells, &codes, cols, rows)?;
        let candidates = out.triangles.len();
        let keep = try_filled(GRID, true, candidates)?;
        let (keep, boundary) = peeled_flags(uv, &out.triangles, &twins, keep, None)?;
        let grid_at = GridAt { grid, rows, cols };
        let cos_ear = cos_turn.max(EAR_TURN_DEG.to_radians().cos());
        let ears = fill_notches(
            &grid_at,
            uv,
            (&out.triangles, &cells, &codes),
            (&keep, &boundary),
            (
                |t: &[u32; 3], [r, c]: [usize; 2]| {
                    judge(t, local(r.min(rows - 2), c.min(cols - 2)), cos_ear) == Verdict::Keep
                },
                |[r, c]: [usize; 2]| {
                    let h = local(r.min(rows - 2), c.min(cols - 2));
                    if h.is_finite() {
                        h
                    } else {
                        spacing
                    }
                },
            ),
        )?;
        // in place, in order (retain visits each element once, in order)
        let mut flags = keep.iter();
        out.triangles.retain(|_| flags.next() == Some(&true));
        out.peeled = candidates - out.triangles.len();
        out.filled = ears.len();
        try_grow(GRID, &mut out.triangles, ears.len())?;
        out.triangles.extend(ears);
    }
    // which points a kept triangle uses, marked on every core (relaxed stores: plain writes)
    let mut used = try_vec(GRID, points.len())?;
    used.extend((0..points.len()).map(|_| AtomicBool::new(false)));
    out.triangles
        .par_iter()
        .with_min_len(1 << 14)
        .for_each(|t| {
            t.iter()
                .for_each(|&v| used[v as usize].store(true, Relaxed))
        });
    out.unused = try_indices(GRID, 0..points.len() as u32, |v| {
        !used[v as usize].load(Relaxed)
    })?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn buffers_beyond_memory_are_errors_not_aborts() {
        // Cells and candidates no allocator gives: an error naming the grid.
        let side = 1usize << 31;
        for e in [
            grid_twins(&[], &[], side, side).unwrap_err(),
            Block::with_room(usize::MAX / 8).err().unwrap(),
        ] {
            assert!(
                matches!(&e, Error::OutOfMemory { what, .. } if what.starts_with(GRID)),
                "{e}"
            );
        }
        assert!(grid_twins(&[], &[], 3, 3).unwrap().is_empty());
    }

    fn rules(sight: DVec3, max_turn_deg: f64, edge_factor: f64) -> GridParams {
        GridParams {
            sight,
            max_turn_deg,
            edge_factor,
        }
    }

    /// A rows x cols grid of unit spacing in x, y with heights `h(r, c)`, seen along z.
    fn terrain(
        rows: usize,
        cols: usize,
        h: impl Fn(usize, usize) -> f64,
    ) -> (Vec<i64>, Vec<[f64; 2]>, Vec<DVec3>) {
        let mut pts = Vec::new();
        for r in 0..rows {
            for c in 0..cols {
                pts.push(DVec3::new(c as f64, r as f64, h(r, c)));
            }
        }
        let uv = pts.iter().map(|p| [p.x, p.y]).collect();
        ((0..(rows * cols) as i64).collect(), uv, pts)
    }

    #[test]
    fn flat_grid_gives_two_triangles_per_cell_counter_clockwise() {
        let (g, uv, p) = terrain(4, 5, |_, _| 0.0);
        let t = grid_triangulate(&g, 4, 5, &uv, &p, rules(DVec3::Z, 80.0, 6.0)).unwrap();
        assert_eq!(t.triangles.len(), 2 * 3 * 4);
        assert_eq!(t.candidates, 24);
        assert!((t.spacing - 1.0).abs() < 1e-12);
        for f in &t.triangles {
            assert_eq!(
                area_sign(&uv, f[0] as usize, f[1] as usize, f[2] as usize),
                1
            );
        }
    }

    #[test]
    fn a_step_loses_its_curtain_and_keeps_both_levels() {
        // columns 0..3 at height 0, columns 3.. at height 10: the cells between columns 2
        // and 3 stand edge-on to the rays
        let (g, uv, p) = terrain(5, 6, |_, c| if c >= 3 { 10.0 } else { 0.0 });
        let t = grid_triangulate(&g, 5, 6, &uv, &p, rules(DVec3::Z, 80.0, 6.0)).unwrap();
        assert_eq!(t.turned, 2 * 4);
        assert_eq!(t.triangles.len(), 2 * 4 * 4);
        // with no turn limit the edge rule still drops them (10 > 6 spacings)
        let t = grid_triangulate(&g, 5, 6, &uv, &p, rules(DVec3::Z, 90.0, 6.0)).unwrap();
        assert_eq!(t.long, 2 * 4);
    }

    #[test]
    fn the_defaults_keep_a_wall_seven_spacings_high_and_drop_a_taller_one() {
        // a step 7 spacings high: the cells across it turn atan(7) = 81.9° from the rays,
        // with edges up to 7.1 spacings; θ = 85° and k = 8 keep them (docs/benchmarks/
        // curtains.md), θ = 80° drops them for their turn, k = 6 for their length
        let (g, uv, p) = terrain(5, 6, |_, c| if c >= 3 { 7.0 } else { 0.0 });
        let t = grid_triangulate(&g, 5, 6, &uv, &p, GridParams::along(DVec3::Z)).unwrap();
        assert_eq!((t.turned, t.long), (0, 0));
        assert_eq!(t.triangles.len(), 2 * 4 * 5);
        let t = grid_triangulate(&g, 5, 6, &uv, &p, rules(DVec3::Z, 80.0, 8.0)).unwrap();
        assert_eq!(t.turned, 2 * 4);
        let t = grid_triangulate(&g, 5, 6, &uv, &p, rules(DVec3::Z, 85.0, 6.0)).unwrap();
        assert_eq!(t.long, 2 * 4);
        // 10 spacings high: 84.3°, within θ, but longer than k
        let (g, uv, p) = terrain(5, 6, |_, c| if c >= 3 { 10.0 } else { 0.0 });
        let t = grid_triangulate(&g, 5, 6, &uv, &p, GridParams::along(DVec3::Z)).unwrap();
        assert_eq!((t.turned, t.long), (0, 2 * 4));
        assert_eq!(t.triangles.len(), 2 * 4 * 4);
    }

    #[test]
    fn missing_samples_leave_three_corner_cells_and_holes() {
        let (mut g, uv, p) = terrain(5, 5, |_, _| 0.0);
        g[12] = -1; // (2, 2): its four cells keep one triangle each, the rest two
        let t = grid_triangulate(&g, 5, 5, &uv, &p, rules(DVec3::Z, 80.0, 6.0)).unwrap();
        assert_eq!(t.triangles.len(), 2 * 16 - 4);
        assert!(t.triangles.iter().all(|f| !f.contains(&12)));
        assert_eq!(t.unused, vec![12]);
        assert_eq!(t.peeled, 0);
    }

    #[test]
    fn reversed_rows_are_wound_counter_clockwise_and_folds_are_dropped() {
        let (g, uv, p) = terrain(3, 3, |_, _| 0.0);
        let flipped: Vec<[f64; 2]> = uv.iter().map(|q| [q[0], -q[1]]).collect();
        let t = grid_triangulate(&g, 3, 3, &flipped, &p, rules(DVec3::Z, 80.0, 6.0)).unwrap();
        assert_eq!(t.triangles.len(), 8);
        for f in &t.triangles {
            assert_eq!(
                area_sign(&flipped, f[0] as usize, f[1] as usize, f[2] as usize),
                1
            );
        }
        let mut folded = uv.clone();
        folded[4] = [3.0, 1.0]; // the centre pulled past its right neighbour
        let t =
            grid_triangulate(&g, 3, 3, &folded, &p, rules(DVec3::Z, 90.0, f64::INFINITY)).unwrap();
        assert!(t.folded > 0);
    }

    #[test]
    fn pinches_are_peeled_so_the_result_is_a_valid_triangulation() {
        // samples missing so that two triangles meet at the centre (1, 1) only
        let (mut g, uv, p) = terrain(3, 3, |_, _| 0.0);
        for k in [2, 3, 5, 6] {
            g[k] = -1;
        }
        let t = grid_triangulate(&g, 3, 3, &uv, &p, rules(DVec3::Z, 80.0, 6.0)).unwrap();
        assert_eq!((t.peeled, t.triangles.len()), (1, 1));
        let (g, uv, p) = terrain(6, 6, |r, c| if r >= 3 && c >= 3 { 9.0 } else { 0.0 });
        let t = grid_triangulate(&g, 6, 6, &uv, &p, rules(DVec3::Z, 80.0, 6.0)).unwrap();
        let unit = crate::geometry::unit_square(&uv);
        let mesh = crate::mesh::HalfEdgeMesh::from_triangles(uv.len(), &t.triangles).unwrap();
        mesh.validate(&unit).unwrap();
    }

    /// Twice the planar area of triangles over `uv`.
    fn twice_area(uv: &[[f64; 2]], triangles: &[[u32; 3]]) -> f64 {
        (triangles.iter())
            .map(|t| {
                let [a, b, c] = t.map(|k| uv[k as usize]);
                (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
            })
            .sum()
    }

    #[test]
    fn notches_of_a_slanted_outline_fill_to_the_samples_hull() {
        // samples on and below the line row = (col + 2) / 3: the cells leave a staircase,
        // the ears fill it to within 2 cells of the samples' hull, (row, col) = (0, 0),
        // (0, 36), (12, 36), (12, 34), (1, 1): 239 cells; near the acute corner at
        // (12, 34), whose turn over 90° reads as a spur's tip (`notches::sag`), they stop
        let (rows, cols) = (13, 37);
        let (mut g, uv, p) = terrain(rows, cols, |_, _| 0.0);
        for r in 0..rows {
            for c in 0..cols {
                if 3 * r > c + 2 {
                    g[r * cols + c] = -1;
                }
            }
        }
        let t = grid_triangulate(&g, rows, cols, &uv, &p, rules(DVec3::Z, 80.0, 6.0)).unwrap();
        assert!(t.filled > 0);
        let area = twice_area(&uv, &t.triangles) / 2.0;
        assert!((237.0..=239.0).contains(&area), "{area}");
        let unit = crate::geometry::unit_square(&uv);
        let mesh = crate::mesh::HalfEdgeMesh::from_triangles(uv.len(), &t.triangles).unwrap();
        mesh.validate(&unit).unwrap();
        // a notch across a step is no ear: the same outline with the upper level 10 higher
        let (g2, uv2, p2) = (g.clone(), uv.clone(), {
            let mut q = p.clone();
            for (k, x) in q.iter_mut().enumerate() {
                if (k % cols) >= 3 * (k / cols) {
                    x.z = 10.0;
                }
            }
            q
        });
        let t2 = grid_triangulate(&g2, rows, cols, &uv2, &p2, rules(DVec3::Z, 80.0, 6.0)).unwrap();
        for f in &t2.triangles[t2.triangles.len() - t2.filled..] {
            let z = f.map(|k| p2[k as usize].z);
            assert!(
                z.iter().all(|&h| h == z[0]),
                "an ear across the step: {f:?}"
            );
        }
    }

    #[test]
    fn no_ear_covers_a_missing_sample() {
        // a disc of samples with a bore: every lattice point without a sample stays
        // outside every triangle, ears or not, and the bore's rim gets no ear
        let (n, r_out, r_in) = (21usize, 9.3f64, 3.6f64);
        let (mut g, uv, p) = terrain(n, n, |_, _| 0.0);
        let d = |k: usize| ((k / n) as f64 - 10.0).hypot((k % n) as f64 - 10.0);
        for (k, cell) in g.iter_mut().enumerate() {
            if d(k) > r_out || d(k) < r_in {
                *cell = -1;
            }
        }
        let t = grid_triangulate(&g, n, n, &uv, &p, rules(DVec3::Z, 80.0, 6.0)).unwrap();
        assert!(t.filled > 0);
        // the ears lie along the outer circle (convex seen from the mesh), none along the
        // bore's rim (concave: there an ear's chord leaves the part)
        for f in &t.triangles[t.triangles.len() - t.filled..] {
            assert!(
                f.iter().all(|&k| d(k as usize) > 6.0),
                "an ear at the rim: {f:?}"
            );
        }
        for k in (0..n * n).filter(|&k| g[k] < 0) {
            for f in &t.triangles {
                let inside =
                    (0..3).all(|j| area_sign(&uv, f[j] as usize, f[(j + 1) % 3] as usize, k) >= 0);
                assert!(!inside, "missing sample {k} under {f:?}");
            }
        }
        let unit = crate::geometry::unit_square(&uv);
        let mesh = crate::mesh::HalfEdgeMesh::from_triangles(uv.len(), &t.triangles).unwrap();
        mesh.validate(&unit).unwrap();
    }

    #[test]
    fn grid_twins_are_the_half_edge_meshs_twins() {
        let (rows, cols) = (7, 9);
        let (mut g, _, p) = terrain(rows, cols, |r, c| ((r * 7 + c * 3) % 5) as f64 * 0.1);
        for k in [3, 11, 12, 30, 40, 41, 62] {
            g[k] = -1;
        }
        let (mut tris, mut codes, mut cells) = (Vec::new(), Vec::new(), Vec::new());
        for r in 0..rows - 1 {
            for c in 0..cols - 1 {
                let at = |i: usize, j: usize| g[i * cols + j];
                let corners = [at(r, c), at(r, c + 1), at(r + 1, c), at(r + 1, c + 1)];
                let mut cell = Vec::new();
                cell_triangles(corners, &p, &mut cell);
                for code in cell {
                    // the grid's winding is clockwise in (x, y) here: flip to counter-clockwise
                    let code = [code[0], code[2], code[1]];
                    tris.push(code.map(|k| corners[k as usize] as u32));
                    codes.push(code);
                    cells.push((r * (cols - 1) + c) as u32);
                }
            }
        }
        let mesh = crate::mesh::HalfEdgeMesh::from_triangles(p.len(), &tris).unwrap();
        let expected: Vec<u32> = (0..3 * tris.len() as u32).map(|h| mesh.twin(h)).collect();
        assert_eq!(grid_twins(&cells, &codes, cols, rows).unwrap(), expected);
    }

    #[test]
    fn extreme_magnitudes_give_the_same_triangles() {
        let (g, uv, p) = terrain(5, 6, |_, c| if c >= 3 { 10.0 } else { 0.1 * c as f64 });
        let t = grid_triangulate(&g, 5, 6, &uv, &p, rules(DVec3::Z, 80.0, 6.0)).unwrap();
        for scale in [1e-300, 1e-150, 1e150, 1e300] {
            let uv_s: Vec<[f64; 2]> = uv.iter().map(|q| [q[0] * scale, q[1] * scale]).collect();
            let p_s: Vec<DVec3> = p.iter().map(|q| *q * scale).collect();
            let s = grid_triangulate(&g, 5, 6, &uv_s, &p_s, rules(DVec3::Z, 80.0, 6.0)).unwrap();
            assert_eq!(s.triangles, t.triangles, "scale {scale}");
        }
    }

    #[test]
    fn bad_grids_and_parameters_are_refused() {
        let (g, uv, p) = terrain(2, 2, |_, _| 0.0);
        assert!(grid_triangulate(&g, 2, 3, &uv, &p, rules(DVec3::Z, 80.0, 6.0)).is_err());
        assert!(
            grid_triangulate(&[0, 1, 2, 9], 2, 2, &uv, &p, rules(DVec3::Z, 80.0, 6.0)).is_err()
        );
        assert!(grid_triangulate(&g, 2, 2, &uv, &p, rules(DVec3::ZERO, 80.0, 6.0)).is_err());
        assert!(grid_triangulate(&g, 2, 2, &uv, &p, rules(DVec3::Z, f64::NAN, 6.0)).is_err());
        assert!(grid_triangulate(&g, 2, 2, &uv, &p, rules(DVec3::Z, 80.0, 0.0)).is_err());
        let empty = grid_triangulate(&[], 0, 0, &uv, &p, rules(DVec3::Z, 80.0, 6.0)).unwrap();
        assert!(empty.triangles.is_empty());
    }
}
