//! The one error type of the core: every variant names the offending value.

use std::fmt;

/// Everything that can go wrong in `scanmesh-core`. Bindings map each variant to an exception.
#[derive(Debug, Clone, PartialEq)]
pub enum Error {
    /// A coordinate is NaN or infinite (`index` is the point, `axis` 0..3).
    NonFinite {
        /// The point.
        index: usize,
        /// 0, 1 or 2 for x, y, z.
        axis: usize,
        /// The offending value.
        value: f64,
    },
    /// Fewer than three distinct points (after merging exact duplicates in the plane).
    TooFewPoints {
        /// How many distinct points there are.
        distinct: usize,
    },
    /// All points lie on one line: in 3-D, or only after projection onto the plane.
    Collinear {
        /// False when collinear in 3-D, true when only their projection is.
        after_projection: bool,
    },
    /// A parameter outside its valid range.
    InvalidParameter {
        /// The parameter's name.
        name: &'static str,
        /// Its value, printed.
        value: String,
        /// What was expected instead.
        expected: &'static str,
    },
    /// A parameter asks for more work or memory than the run can be given (see
    /// [`crate::budget`]).
    TooCostly {
        /// The parameter's name.
        name: &'static str,
        /// Its value, printed.
        value: String,
        /// What it would need ("about 14.9 GiB of memory").
        needs: String,
        /// The limit it exceeds.
        limit: String,
    },
    /// A stage's memory, estimated from its input before it runs or asked for by an
    /// allocation that failed, is more than this process may have (see [`crate::budget`]).
    OutOfMemory {
        /// The stage and its input ("Delaunay of 2000000 points").
        what: String,
        /// The bytes it needs.
        needs: u64,
        /// The limit it exceeds ("the 520.3 MiB left under RLIMIT_AS (ulimit -v) of ...").
        limit: String,
    },
    /// A face refers to a vertex that does not exist, repeats a vertex, or is degenerate.
    InvalidFace {
        /// Index of the face.
        face: usize,
        /// What is wrong with it.
        reason: String,
    },
    /// A mesh invariant does not hold (see `HalfEdgeMesh::validate`).
    Invariant(String),
    /// The caller asked the computation to stop.
    Interrupted,
}

/// Result alias of the core.
pub type Result<T> = std::result::Result<T, Error>;

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::NonFinite { index, axis, value } => write!(
                f,
                "point {index} has a non-finite coordinate {}={value}",
                ["x", "y", "z"].get(*axis).copied().unwrap_or("?")
            ),
            Error::TooFewPoints { distinct } => write!(
                f,
                "need at least 3 distinct points to triangulate, got {distinct}"
            ),
            Error::Collinear {
                after_projection: false,
            } => {
                write!(f, "all points are collinear: they span no surface")
            }
            Error::Collinear {
                after_projection: true,
            } => write!(
                f,
                "all points are collinear after projection onto the plane: choose another plane"
            ),
            Error::InvalidParameter {
                name,
                value,
                expected,
            } => {
                write!(f, "invalid {name}={value}: expected {expected}")
            }
            Error::TooCostly {
                name,
                value,
                needs,
                limit,
            } => write!(f, "{name}={value} needs {needs}, more than {limit}"),
            Error::OutOfMemory { what, needs, limit } => write!(
                f,
                "{what} needs about {} of memory, more than {limit}",
                describe_bytes(*needs)
            ),
            Error::InvalidFace { face, reason } => write!(f, "face {face}: {reason}"),
            Error::Invariant(what) => write!(f, "mesh invariant violated: {what}"),
            Error::Interrupted => write!(f, "interrupted"),
        }
    }
}

impl std::error::Error for Error {}

/// `bytes` for messages: GiB, MiB or bytes. O(1).
pub(crate) fn describe_bytes(bytes: u64) -> String {
    const MIB: f64 = (1u64 << 20) as f64;
    const GIB: f64 = (1u64 << 30) as f64;
    let b = bytes as f64;
    if b >= GIB {
        format!("{:.1} GiB", b / GIB)
    } else if b >= MIB {
        format!("{:.1} MiB", b / MIB)
    } else {
        format!("{bytes} bytes")
    }
}
