//! Key point selection benchmark (`deformlab::bench_bdt`). Long: run
//! explicitly with
//! `DEFORMLAB_SHARED_DATA=/path/to/shared/data cargo test --release --test keypoints_bench -- --ignored --nocapture`
//! (set `DEFORMLAB_BENCH_QUICK=1` for a short run).

#[test]
#[ignore]
fn bench_bdt_table() {
    let quick = std::env::var_os("DEFORMLAB_BENCH_QUICK").is_some();
    println!("{}", deformlab::bench_bdt::run(quick).unwrap());
}
