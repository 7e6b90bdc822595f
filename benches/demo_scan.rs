//! The embedded connecting-rod scan for Rust benches: a minimal reader of the `.npz` that the
//! Python package ships (a zip of deflated `.npy` arrays), so benches and Python share one file.

use scanmesh_core::glam::DVec3;
use std::path::PathBuf;

/// Path of `python/scanmesh/data/conrod_scan.npz` from this crate's manifest folder.
pub fn demo_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../python/scanmesh/data/conrod_scan.npz")
}

/// The rod scan's points (14,340 of them), in scan order.
pub fn demo_points() -> Vec<DVec3> {
    let bytes = std::fs::read(demo_path()).expect("the demo scan ships with the package");
    let npy = zip_member(&bytes, "points.npy");
    let values = npy_f64(&npy);
    values
        .chunks_exact(3)
        .map(|c| DVec3::new(c[0], c[1], c[2]))
        .collect()
}

/// Inflated bytes of one member of a zip archive (local headers, deflate or stored).
fn zip_member(zip: &[u8], name: &str) -> Vec<u8> {
    let u16_at = |i: usize| u16::from_le_bytes([zip[i], zip[i + 1]]) as usize;
    let u32_at =
        |i: usize| u32::from_le_bytes([zip[i], zip[i + 1], zip[i + 2], zip[i + 3]]) as usize;
    let mut at = 0;
    while u32_at(at) == 0x0403_4b50 {
        let (method, packed) = (u16_at(at + 8), u32_at(at + 18));
        let (name_len, extra_len) = (u16_at(at + 26), u16_at(at + 28));
        let data = at + 30 + name_len + extra_len;
        if &zip[at + 30..at + 30 + name_len] == name.as_bytes() {
            let raw = &zip[data..data + packed];
            return match method {
                0 => raw.to_vec(),
                8 => miniz_oxide::inflate::decompress_to_vec(raw).expect("valid deflate stream"),
                m => panic!("zip method {m} not supported"),
            };
        }
        at = data + packed;
    }
    panic!("{name} not found in the demo archive")
}

/// The little-endian f64 payload of a C-ordered `.npy` array.
fn npy_f64(npy: &[u8]) -> Vec<f64> {
    assert_eq!(&npy[..6], b"\x93NUMPY", "not an .npy file");
    let header_len = u16::from_le_bytes([npy[8], npy[9]]) as usize;
    let header = std::str::from_utf8(&npy[10..10 + header_len]).expect("ascii header");
    assert!(
        header.contains("'<f8'") && header.contains("'fortran_order': False"),
        "{header}"
    );
    npy[10 + header_len..]
        .chunks_exact(8)
        .map(|b| f64::from_le_bytes(b.try_into().unwrap()))
        .collect()
}
