//! TOSCA `.vert` + `.tri` reader: the input is split at its first NUL byte
//! into the `.vert` text and the `.tri` text (no NUL: all `.vert`, empty
//! `.tri`).
#![no_main]

use std::path::Path;

use deformlab::mesh::io::parse_vert_tri;
use deformlab::mesh::validate::DefectReport;
use deformlab::mesh::Mesh;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let (vert, tri) = match data.iter().position(|&b| b == 0) {
        Some(k) => (&data[..k], &data[k + 1..]),
        None => (data, &data[data.len()..]),
    };
    if let Ok(raw) = parse_vert_tri(vert, tri, Path::new("fuzz")) {
        let _ = DefectReport::of(&raw).summary();
        let _ = Mesh::try_from(raw);
    }
});
