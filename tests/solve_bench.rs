//! The benchmark entry point: a quick smoke run, and the full run (ignored;
//! `cargo test --release --test solve_bench -- --ignored --nocapture`).

#[test]
fn quick_bench_runs_and_rejects_unknown_groups() {
    let table = deformlab::bench::kernels::run(&["ops".into(), "cholesky".into()], true).unwrap();
    assert!(table.contains("| 7200 |"), "{table}");
    assert!(table.contains("faer 3 solves"));
    assert!(deformlab::bench::kernels::run(&["nope".into()], true).is_err());
}

#[test]
#[ignore = "full benchmark, minutes"]
fn full_benchmark() {
    let table = deformlab::bench::kernels::run(&[], false).unwrap();
    println!("{table}");
}
