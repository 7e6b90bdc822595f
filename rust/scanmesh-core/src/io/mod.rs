//! Readers: numeric text tables and binary STL records.

pub(crate) mod stl;
pub(crate) mod text;
