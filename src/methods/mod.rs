//! Every method as a value with one entry point, used identically by the
//! CLI, the experiment harness and the benchmarks.

pub mod completion;
