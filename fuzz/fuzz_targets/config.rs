//! Experiment config parser on arbitrary text (the path only names it; it
//! does not exist, so dataset path checks fail cleanly).
#![no_main]

use std::path::Path;

use deformlab::experiment::parse_config;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(loaded) = parse_config(text, Path::new("/nonexistent-fuzz/config.toml")) {
        let _ = loaded.config.hash();
    }
});
