//! Exact checks on small point sets: empty triangles and every triangulation.

pub(crate) mod enumerate;

pub use enumerate::{cheapest_fans, empty_triangles, triangulations, CheapestFan};
