//! Exact checks on small point sets: empty triangles and every triangulation.

pub(crate) mod enumerate;
