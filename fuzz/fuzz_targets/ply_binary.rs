//! Binary PLY payloads: the first byte picks one of several binary headers
//! (both byte orders, several scalar and list types, an extra element), the
//! next eight bytes give the announced vertex and face counts (so headers
//! announcing billions of elements are tried), the rest is the payload.
#![no_main]

use std::path::Path;

use deformlab::mesh::io::{parse_raw, Format};
use deformlab::mesh::validate::DefectReport;
use deformlab::mesh::Mesh;
use libfuzzer_sys::fuzz_target;

const VARIANTS: [(&str, &str, &str); 4] = [
    (
        "binary_little_endian",
        "property float x\nproperty float y\nproperty float z\n",
        "property list uchar int vertex_indices\n",
    ),
    (
        "binary_big_endian",
        "property double x\nproperty double y\nproperty double z\n",
        "property list uint uint vertex_indices\n",
    ),
    (
        "binary_little_endian",
        "property double x\nproperty uchar red\nproperty double y\nproperty double z\n",
        "property list ushort short vertex_index\nproperty int flags\n",
    ),
    (
        "binary_big_endian",
        "property short z\nproperty char y\nproperty float x\n",
        "property list char uchar vertex_indices\n",
    ),
];

fuzz_target!(|data: &[u8]| {
    if data.len() < 9 {
        return;
    }
    let (format, vprops, fprops) = VARIANTS[usize::from(data[0]) % VARIANTS.len()];
    let nv = u32::from_le_bytes([data[1], data[2], data[3], data[4]]);
    let nf = u32::from_le_bytes([data[5], data[6], data[7], data[8]]);
    let extra = data[0] >= 128;
    let mut bytes = format!(
        "ply\nformat {format} 1.0\nelement vertex {nv}\n{vprops}element face {nf}\n{fprops}"
    );
    if extra {
        bytes.push_str("element edge 2\nproperty int vertex1\nproperty int vertex2\n");
    }
    bytes.push_str("end_header\n");
    let mut bytes = bytes.into_bytes();
    bytes.extend_from_slice(&data[9..]);
    if let Ok(raw) = parse_raw(Format::Ply, &bytes, Path::new("fuzz.ply")) {
        let _ = DefectReport::of(&raw).summary();
        let _ = Mesh::try_from(raw);
    }
});
