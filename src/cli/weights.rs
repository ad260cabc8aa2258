//! `deformlab weights`: bounded biharmonic weights (BDT Eq. 1) of one mesh
//! for given or farthest-point-sampled handles, with the solver's figures
//! (time, active-set iterations, KKT residual) and optionally the weights as
//! CSV. It is how the size limit of the bounded weights is measured
//! (README, "Large meshes").

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use clap::Args;

use deformlab::mesh::io::write_atomic;
use deformlab::mesh::repair::DefectPolicy;
use deformlab::ops::{farthest_point_sampling, FpsMetric};
use deformlab::skin::bbw::{BbwOptions, Biharmonic, WeightMode};
use deformlab::{Error, Result};

use deformlab::bench::cpu_seconds;

use super::keypoints::load_checked;

/// `deformlab weights` arguments.
#[derive(Args, Debug)]
#[command(after_help = "Examples:\n  \
    deformlab weights ../shared/data/faust/tr_reg_001.ply --handles 10\n  \
    deformlab weights mesh.off --handle-vertices 12,400,977 --weights per-handle --out W.csv\n\n\
    Prints the vertex and handle counts, the wall and CPU time of the precomputation\n\
    (L, M, Q = L M⁻¹ L) and of the weights, the active-set iterations (per handle, and\n\
    of the coupled support iteration) and the KKT residual. With --out, W.csv has one\n\
    row per vertex and one column per handle (not overwritten unless --force).")]
pub struct WeightsArgs {
    /// The mesh (.ply, .off, .obj, .vert/.tri).
    pub mesh: PathBuf,
    /// Number of handles, placed by Euclidean farthest point sampling
    /// (seeded), 1..=1000 [default: 10].
    #[arg(long, conflicts_with = "handle_vertices", value_parser = Handles::parse)]
    pub handles: Option<usize>,
    /// Handle vertices (0-based, comma-separated) instead of sampling.
    #[arg(long, value_delimiter = ',')]
    pub handle_vertices: Option<Vec<usize>>,
    /// Seed of the first farthest-point sample.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Help text (with the library's default) in `help` below.
    /// `--weights`, as in `transfer` and the configs (`weights = …`); the
    /// former `--mode` is still read (hidden): `--mode` is the candidate
    /// scoring in `keypoints` and `transfer`.
    #[arg(long = "weights", alias = "mode", value_name = "WEIGHTS", value_enum, help = super::keypoints::default_help(
        "Which weights: coupled = BDT Eq. 1 (bounds and partition of unity in one problem); \
         per-handle = each handle bounded, rows normalised",
        super::keypoints::value_name(&BbwOptions::default().mode)))]
    pub mode: Option<WeightMode>,
    /// Help text (with the library's default) in `help` below.
    #[arg(long, value_parser = MaxIter::parse, help = super::keypoints::default_help(
        "Active-set iterations allowed, 1..=100000", BbwOptions::default().max_iter))]
    pub max_iter: Option<usize>,
    /// Help text (with the library's default) in `help` below.
    #[arg(long, value_parser = Hops::parse, help = super::keypoints::default_help(
        "Local refinement of the per-handle active sets: steps of Q's graph around the \
         changed vertices, 0..=64 (0 = off; the result passes the same optimality test)",
        BbwOptions::default().local_hops))]
    pub local_hops: Option<usize>,
    /// Help text (with the library's default) in `help` below.
    #[arg(long, value_parser = Hops::parse, help = super::keypoints::default_help(
        "Local refinement of the coupled support iteration, 0..=64 (0 = off)",
        BbwOptions::default().coupled_local_hops))]
    pub coupled_local_hops: Option<usize>,
    /// Help text (with the library's default) in `help` below.
    #[arg(long, value_parser = Tol::parse, help = super::keypoints::default_help(
        "Active-set tolerance of the per-handle weights in weight units, 1e-15..=1e-3 (their \
         optimality test; smaller is tighter and slower)",
        format!("{:e}", BbwOptions::default().tol)))]
    pub tol: Option<f64>,
    /// Help text (with the library's default) in `help` below.
    #[arg(long, value_parser = Tol::parse, help = super::keypoints::default_help(
        "Active-set tolerance of the coupled weights (both stages), 1e-15..=1e-3",
        format!("{:e}", BbwOptions::default().coupled_tol)))]
    pub coupled_tol: Option<f64>,
    /// Help text (with the library's default) in `help` below.
    #[arg(long, value_parser = StepTol::parse, help = super::keypoints::default_help(
        "Step test of the coupled support iteration: stop once an iteration moves no weight \
         by more than this, 0..=1e-2 (0 = stop only when the supports no longer change)",
        format!("{:e}", BbwOptions::default().coupled_step_tol)))]
    pub coupled_step_tol: Option<f64>,
    /// Help text (with the library's default) in `help` below.
    #[arg(long, value_parser = AdmmIter::parse, help = super::keypoints::default_help(
        "ADMM iterations on the coupled problem that set the support iteration's start, \
         0..=10000 (0 = start from the normalised per-handle weights; only the start changes)",
        BbwOptions::default().coupled_admm_iter))]
    pub coupled_admm_iter: Option<usize>,
    /// Write the weights (n × handles) as CSV.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Overwrite --out if it exists.
    #[arg(long)]
    pub force: bool,
    /// Refuse meshes with defects that change results.
    #[arg(long)]
    pub strict: bool,
    /// Repair duplicate / zero-area faces and winding first.
    #[arg(long, conflicts_with = "strict")]
    pub repair: bool,
}

type Handles = deformlab::experiment::range::Int<1, 1000>;
type MaxIter = deformlab::experiment::range::Int<1, 100_000>;
type Tol = deformlab::methods::spec::BbwTolerance;
type StepTol = deformlab::methods::spec::BbwStepTolerance;
type Hops = deformlab::experiment::range::Int<0, 64>;
type AdmmIter = deformlab::experiment::range::Int<0, 10_000>;

/// Handles sampled when neither `--handles` nor `--handle-vertices` is given.
pub const DEFAULT_HANDLES: usize = 10;

pub fn run(a: WeightsArgs) -> Result<ExitCode> {
    let policy = DefectPolicy {
        strict: a.strict,
        repair: a.repair,
    };
    if let Some(out) = &a.out {
        super::keypoints::check_out_file(out)?;
        if out.exists() && !a.force {
            return Err(Error::invalid(format!(
                "{}: exists (give --force to overwrite)",
                out.display()
            )));
        }
    }
    let mesh = load_checked(&a.mesh, policy, &mut Vec::new())?;
    let n = mesh.n_vertices();
    let handles = match &a.handle_vertices {
        Some(h) => {
            if let Some(&bad) = h.iter().find(|&&v| v >= n) {
                return Err(Error::invalid(format!(
                    "--handle-vertices: vertex {bad} out of range ({} has {n} vertices)",
                    a.mesh.display()
                )));
            }
            h.clone()
        }
        None => {
            let k = a.handles.unwrap_or(DEFAULT_HANDLES);
            if k > n {
                return Err(Error::invalid(format!(
                    "--handles {k}: {} has only {n} vertices",
                    a.mesh.display()
                )));
            }
            farthest_point_sampling(&mesh, k, FpsMetric::Euclidean, a.seed)?
        }
    };
    let d = BbwOptions::default();
    let opts = BbwOptions {
        mode: a.mode.unwrap_or(d.mode),
        max_iter: a.max_iter.unwrap_or(d.max_iter),
        local_hops: a.local_hops.unwrap_or(d.local_hops),
        coupled_local_hops: a.coupled_local_hops.unwrap_or(d.coupled_local_hops),
        tol: a.tol.unwrap_or(d.tol),
        coupled_tol: a.coupled_tol.unwrap_or(d.coupled_tol),
        coupled_step_tol: a.coupled_step_tol.unwrap_or(d.coupled_step_tol),
        coupled_admm_iter: a.coupled_admm_iter.unwrap_or(d.coupled_admm_iter),
        ..d
    };
    let progress = super::progress::for_command("weights");
    let (t0, c0) = (Instant::now(), cpu_seconds());
    let bih = Biharmonic::new(&mesh)?;
    let (t1, c1) = (Instant::now(), cpu_seconds());
    let report = bih.weights_with_report(&handles, &opts)?;
    let (t2, c2) = (Instant::now(), cpu_seconds());
    drop(progress);
    let cpu = |a: Option<f64>, b: Option<f64>| match (a, b) {
        (Some(a), Some(b)) => format!("{:.2} s CPU", b - a),
        _ => "CPU n/a".to_string(),
    };
    println!("mesh: {} ({n} vertices)", a.mesh.display());
    println!("handles: {} {:?}", handles.len(), handles);
    println!(
        "mode: {:?}, max_iter {}, tol {:.0e}",
        opts.mode,
        opts.max_iter,
        opts.mode_tol()
    );
    println!(
        "precompute (L, M, Q): {:.2} s wall, {}",
        (t1 - t0).as_secs_f64(),
        cpu(c0, c1)
    );
    println!(
        "weights: {:.2} s wall, {} (unbounded {:.2} s, per-handle active sets {:.2} s, coupled {:.2} s)",
        (t2 - t1).as_secs_f64(),
        cpu(c1, c2),
        report.seconds[0],
        report.seconds[1],
        report.seconds[2]
    );
    if !report.handle_iterations.is_empty() {
        println!(
            "per-handle active-set iterations: {:?} (max {})",
            report.handle_iterations,
            report.handle_iterations.iter().max().copied().unwrap_or(0)
        );
    }
    if opts.mode == WeightMode::Coupled {
        println!(
            "coupled support iterations: {} after {} ADMM iterations (last system {} unknowns; stopped on {})",
            report.coupled_iterations,
            opts.coupled_admm_iter,
            report.coupled_unknowns,
            if report.coupled_stopped_on_step {
                format!(
                    "the step test, no weight moved by more than {:.0e}",
                    opts.coupled_step_tol
                )
            } else {
                "unchanged supports".to_string()
            }
        );
    }
    println!(
        "local refinement iterations: {} (regions within {} / {} steps of Q's graph for the per-handle / coupled iterations)",
        report.local_iterations, opts.local_hops, opts.coupled_local_hops
    );
    println!(
        "KKT residual {:.2e}, converged {}, numeric factorisations {}",
        report.kkt_residual, report.converged, report.factorizations
    );
    if let Some(out) = &a.out {
        let w = &report.weights;
        let mut text = String::with_capacity(w.nrows() * w.ncols() * 20);
        for i in 0..w.nrows() {
            for k in 0..w.ncols() {
                if k > 0 {
                    text.push(',');
                }
                text.push_str(&format!("{:.17e}", w[(i, k)]));
            }
            text.push('\n');
        }
        write_atomic(out, text.as_bytes())?;
        println!("weights written to {}", out.display());
    }
    Ok(ExitCode::SUCCESS)
}
