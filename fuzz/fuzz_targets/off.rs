//! OFF reader on arbitrary bytes.
#![no_main]

use std::path::Path;

use deformlab::mesh::io::{parse_raw, Format};
use deformlab::mesh::validate::DefectReport;
use deformlab::mesh::Mesh;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(raw) = parse_raw(Format::Off, data, Path::new("fuzz.off")) {
        let _ = DefectReport::of(&raw).summary();
        let _ = Mesh::try_from(raw);
    }
});
