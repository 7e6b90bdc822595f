//! What the native functions return when it is more than a pair or a triple: frozen
//! classes with named read-only attributes, so that Python reads each part by name.

use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;

type Ints2 = Py<PyArray2<i64>>;
type Ints1 = Py<PyArray1<i64>>;
type Floats2 = Py<PyArray2<f64>>;
type Floats1 = Py<PyArray1<f64>>;

/// The strips between consecutive scan lines as one mesh (`strip_mesh`).
#[pyclass(frozen, get_all, module = "scanmesh._core")]
pub(crate) struct StripResult {
    /// (M, 3) int64 faces, counter-clockwise in the plane.
    pub faces: Ints2,
    /// (K,) int64 points in no triangle.
    pub unused: Ints1,
    /// (D, 2) int64 pairs (dropped point, the point it coincides with).
    pub duplicates: Ints2,
    /// Number of strips.
    pub n_strips: usize,
    /// Sum of the strips' path costs.
    pub cost: f64,
    /// Why the mesh is not planar-valid, or None.
    pub planar_error: Option<String>,
    /// Triangles dropped at depth jumps (and the pinches that left).
    pub dropped_jumps: usize,
    /// Triangles dropped where lines cross or fold, to make the mesh planar-valid.
    pub dropped_overlaps: usize,
    /// (T,) int64 unused points whose every triangle was dropped.
    pub trimmed: Ints1,
    /// Twice the planar signed area before the faces were turned counter-clockwise.
    pub signed_area: f64,
}

/// Scan lines split at gaps (`scan_segments`).
#[pyclass(frozen, get_all, module = "scanmesh._core")]
pub(crate) struct ScanSegments {
    /// Per line, its segments in scan order, each a (K,) int64 array of point indices.
    pub lines: Vec<Vec<Ints1>>,
    /// The median planar step between consecutive points of a line.
    pub median_step: f64,
    /// The gap length: a step longer than this splits a line.
    pub gap: f64,
    /// (D, 2) int64 pairs (dropped point, the earlier point it coincides with).
    pub duplicates: Ints2,
}

/// The end of an annealing run (`Annealer.finish`): the winner's faces and trace, and the
/// run's summary.
#[pyclass(frozen, get_all, module = "scanmesh._core")]
pub(crate) struct AnnealOutcome {
    /// (M, 3) int64 faces of the winning chain's best state, polished.
    pub faces: Ints2,
    /// (S, 4) float64 per sweep of the winner: temperature, energy, best, acceptance.
    pub trace: Floats2,
    /// Energy of the initial triangulation.
    pub initial_energy: f64,
    /// Energy of `faces`.
    pub energy: f64,
    /// T0, the calibrated initial temperature.
    pub initial_temperature: f64,
    /// Flips of the final polish.
    pub polish_flips: usize,
    /// Proposals of the winner, summed over its sweeps.
    pub proposals: u64,
    /// Why the winner stopped: "patience", "sweeps" or "exhausted".
    pub stopped: &'static str,
    /// Number of chains run.
    pub chains: usize,
    /// Index of the winning chain.
    pub best_chain: usize,
    /// Final energy of each chain.
    pub chain_energies: Vec<f64>,
}

/// A Delaunay triangulation trimmed in the same call (`delaunay_trimmed`).
#[pyclass(frozen, get_all, module = "scanmesh._core")]
pub(crate) struct TrimmedDelaunay {
    /// (M, 3) int64 faces, counter-clockwise.
    pub faces: Ints2,
    /// (N,) int64: -1, or the index of the earlier identical point standing in.
    pub duplicate_of: Ints1,
    /// (K,) int64 points that lost every triangle to the trimming.
    pub trimmed: Ints1,
    /// The planar edge length trimmed at.
    pub max_edge: f64,
    /// Seconds of (triangulation, trimming).
    pub seconds: (f64, f64),
}

/// A range grid triangulated along its neighbours (`grid_triangulate`).
#[pyclass(frozen, get_all, module = "scanmesh._core")]
pub(crate) struct GridTriangles {
    /// (M, 3) int64 faces, counter-clockwise in the plane.
    pub faces: Ints2,
    /// Candidate triangles (grid neighbours).
    pub candidates: usize,
    /// Candidates dropped for a normal turned more than θ from the line of sight.
    pub turned: usize,
    /// Candidates dropped for an edge longer than k x the local grid spacing.
    pub long: usize,
    /// Candidates dropped as folded or degenerate in the plane.
    pub folded: usize,
    /// Triangles peeled afterwards (pinches, boundary slivers).
    pub peeled: usize,
    /// Median grid spacing across the line of sight (input units).
    pub spacing: f64,
    /// (K,) int64 points in no face.
    pub unused: Ints1,
}

/// The cheapest fans around some vertices (`cheapest_fans`): for K fans found, the
/// cheapest of each vertex first, fan k is `fans[offsets[k]:offsets[k + 1]]`.
#[pyclass(frozen, get_all, module = "scanmesh._core")]
pub(crate) struct CheapestFans {
    /// (I,) float64 lower bound per vertex asked about.
    pub lower_bounds: Floats1,
    /// (K,) int64 position of each fan's vertex among those asked about.
    pub owner: Ints1,
    /// (K,) float64 value of each fan.
    pub values: Floats1,
    /// (F,) int64 triangles of the fans, one after the other.
    pub fans: Ints1,
    /// (K + 1,) int64 where each fan starts in `fans`.
    pub offsets: Ints1,
}

/// Bytes parsed as a numeric table (`parse_text_table`).
#[pyclass(frozen, get_all, module = "scanmesh._core")]
pub(crate) struct TextTable {
    /// (R, ncols) float64, or (V, 1) holding every value with `ncols` 0.
    pub values: Floats2,
    /// (R,) int64 0-based line index of each row within the range.
    pub row_lines: Ints1,
    /// (B,) int64 0-based indices of the blank lines within the range.
    pub blank_lines: Ints1,
    /// Number of lines in the range.
    pub n_lines: usize,
    /// None, or for a refused range its first bad line, the other fields then empty.
    pub problem: Option<Py<TextProblem>>,
}

/// The first bad line of a text range the parser refused (`TextTable.problem`).
#[pyclass(frozen, get_all, module = "scanmesh._core")]
pub(crate) struct TextProblem {
    /// 0-based index of the line within the range.
    pub line: usize,
    /// Byte offset within the range: the token that is not a number, or the line's start.
    pub offset: usize,
    /// "number" (a token that is not a number) or "count" (a wrong count of numbers).
    pub kind: &'static str,
}
