//! Readers: numeric text tables and binary STL records.

pub(crate) mod stl;
pub(crate) mod text;

pub use stl::records as stl_records;
pub use text::{parse_table, Table, TextError, TextErrorKind};
