//! Regenerates the sample figures of the plotting layer for eyeballing:
//! `cargo test --release --test plot_samples -- --ignored` writes them to
//! `$PLOT_SAMPLES_DIR` (default `/tmp/plot_samples`).

#[test]
#[ignore = "writes sample figures for a person to look at"]
fn write_samples() {
    let dir = std::env::var_os("PLOT_SAMPLES_DIR")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| std::path::PathBuf::from("/tmp/plot_samples"));
    let files = deformlab::plot::demo(&dir).expect("demo figures");
    for f in &files {
        assert!(f.exists(), "{} missing", f.display());
        println!("{}", f.display());
    }
}
