//! Prints the FBT benchmark (Table 1 timings and NICP on a partial cat):
//! `cargo test --release --test fbt_bench -- --ignored --nocapture`.

#[test]
#[ignore = "benchmark: run explicitly"]
fn fbt_benchmark() {
    let quick = std::env::var_os("FBT_BENCH_QUICK").is_some();
    let report = deformlab::bench::fbt::run(quick).unwrap();
    println!("{report}");
}
