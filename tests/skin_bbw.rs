//! Bounded biharmonic weights: properties on random small meshes.

#[test]
#[ignore = "benchmark: cargo test --release --test skin_bbw -- --ignored --nocapture"]
fn bench_skin_table() {
    let quick = std::env::var_os("BENCH_QUICK").is_some();
    println!("{}", deformlab::bench_skin::run(quick).unwrap());
}
