//! `deformlab transfer`: key point selection on the source (or reuse of a
//! key point file), then deformation transfer to a target (BDT Sec. 3.6).
//!
//! **Matching key points to the target.** Four ways:
//!
//! * `--same-connectivity`: target vertex = source vertex (same index);
//! * `--target-keypoints i,j,k`: an explicit list, in key point order (use
//!   it with `--keypoints FILE` so the count is known in advance);
//! * `--correspondence FILE`: a sparse marker set (source vertex → target
//!   vertex, e.g. user-clicked points, as in the paper). A key point must be
//!   a source vertex of the file, so the selection's candidates are drawn
//!   from the file's source vertices only
//!   ([`deformlab::transfer::KeypointOptions::candidate_pool`]: FPS inside
//!   the pool, `n_c` capped at its size). Key points given with
//!   `--keypoints` must be in the file too (else an error);
//! * `--auto-correspondence`: found by registering A onto B (coarse
//!   principal-axes alignment, nonrigid ICP with blended transformations,
//!   closest point on B snapped to a vertex; [`deformlab::transfer::auto`]).
//!   A and B may have any connectivity. Also writes DIR/registered_source.ply
//!   (A registered onto B) and the registration diagnostics in log.json.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use clap::{ArgGroup, Args};
use serde_json::json;

use deformlab::data::correspondence::{check_pairs, pair_map, read_pairs, PairFormat};
use deformlab::experiment::range::Int;
use deformlab::mesh::io::write_ply;
use deformlab::methods::{
    BdtOptions, KeypointSource, TargetCorrespondence, TargetPoints, TransferCase, TransferMethod,
};
use deformlab::transfer::{FrameAlign, TargetWeights, TransferFrame};
use deformlab::{Error, Mesh, Result};

use super::keypoints::{
    check_size, create_dir, load_checked, print_selection, read_keypoints_csv, refuse_overwrite,
    selection_json, write_json, write_keypoints_csv, KeypointRow, SelectArgs,
};

/// `deformlab transfer` arguments.
#[derive(Args, Debug)]
#[command(group(ArgGroup::new("target_map").args(["correspondence", "same_connectivity", "target_keypoints", "auto_correspondence"]).multiple(false)))]
#[command(after_help = "Examples:\n  \
    deformlab transfer --source faust/tr_reg_000.ply --deformed faust/tr_reg_003.ply faust/tr_reg_007.ply \\\n      \
    --target faust/tr_reg_010.ply --same-connectivity --out out/t1\n  \
    deformlab transfer --source A.ply --deformed A1.ply --target B.ply --correspondence markers.yml \\\n      \
    --format markers-yml --frame handle-relative --refine --out out/t2\n  \
    deformlab transfer --source A.ply --deformed A1.ply --target B.ply --keypoints out/t1/keypoints.csv \\\n      \
    --target-keypoints 12,40,77 --out out/t3\n  \
    deformlab transfer --source cat.obj --deformed cat-01.obj --target lion.obj --auto-correspondence \\\n      \
    --frame handle-relative --out out/t4\n\n\
    Writes DIR/<deformed>_to_<target>.ply (one per deformed source), DIR/keypoints.csv\n\
    (source vertex, target vertex, x y z on A, x y z on B) and DIR/log.json (settings, selection\n\
    error trace, timings). Existing files are not overwritten unless --force is given.\n\
    With --correspondence, candidate key points are drawn from the file's source vertices only.\n\
    A --keypoints file with a `target` column needs no other\n\
    target option. Mesh defects that change results are printed as one warning per file and\n\
    kind (and logged); --strict refuses such meshes, --repair fixes the standard ones.")]
pub struct TransferArgs {
    #[command(flatten)]
    pub select: SelectArgs,
    /// Target reference mesh B.
    #[arg(long)]
    pub target: PathBuf,
    /// Source→target vertex correspondences (markers).
    #[arg(long)]
    pub correspondence: Option<PathBuf>,
    /// Format of the correspondence file (default: from its extension).
    #[arg(long, value_enum, requires = "correspondence")]
    pub format: Option<PairFormat>,
    /// Index base of the correspondence file, 0 or 1 (default: the format's).
    #[arg(long, requires = "correspondence", value_parser = Int::<0, 1>::parse)]
    pub base: Option<usize>,
    /// A and B share connectivity: target key point = source key point.
    #[arg(long)]
    pub same_connectivity: bool,
    /// Find the target key points by registering the source onto the target
    /// (any connectivity); writes registered_source.ply too.
    #[arg(long)]
    pub auto_correspondence: bool,
    /// With --auto-correspondence: a few source→target vertex pairs
    /// (landmarks; same formats as --correspondence, chosen by extension)
    /// that guide the coarse alignment and stay constraints during the
    /// nonrigid registration.
    #[arg(long, requires = "auto_correspondence")]
    pub landmarks: Option<PathBuf>,
    /// Target vertices of the key points, comma separated, in key point order.
    #[arg(long, value_delimiter = ',')]
    pub target_keypoints: Option<Vec<usize>>,
    /// Reuse a keypoints.csv (from `deformlab keypoints` or `transfer`)
    /// instead of selecting; the transforms are fitted for these key points.
    #[arg(long)]
    pub keypoints: Option<PathBuf>,
    /// Output folder (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// Help text (with the library's default) in `help` below.
    #[arg(long, value_enum, help = super::keypoints::default_help(
        "How the transforms act on B",
        super::keypoints::value_name(&BdtOptions::default().frame)))]
    pub frame: Option<TransferFrame>,
    /// Help text (with the library's default) in `help` below.
    #[arg(long, value_enum, help = super::keypoints::default_help(
        "Rotation of B onto A in the unit-sphere frame (none: B is only centred and scaled, so \
         B′ follows translations and scalings of B, not rotations; keypoints: Kabsch on the key \
         point pairs, at least 3 and not collinear; dense: on every vertex, needs \
         --same-connectivity)",
        super::keypoints::value_name(&BdtOptions::default().align)))]
    pub align: Option<FrameAlign>,
    /// Help text (with the library's default) in `help` below.
    #[arg(long, value_enum, help = super::keypoints::default_help(
        "Weights computed on B (auto: those of the fit on A, per --mode)",
        super::keypoints::value_name(&BdtOptions::default().target_weights)))]
    pub target_weights: Option<TargetWeights>,
    /// Refine each B′ with handle-constrained reduced ARAP on B.
    #[arg(long)]
    pub refine: bool,
    /// Overwrite existing outputs.
    #[arg(long)]
    pub force: bool,
}

fn stem(p: &Path) -> String {
    p.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "mesh".into())
}

/// Options that have no effect without another option (or that another
/// option makes pointless) are errors naming both: they were silently
/// ignored.
fn check_option_dependencies(a: &TransferArgs) -> Result<()> {
    let refuse = |opt: &str, other: &str, why: &str| {
        Err(Error::invalid(format!(
            "{opt} has no effect without {other} ({why}); add {other} or drop {opt}"
        )))
    };
    if a.landmarks.is_some() && !a.auto_correspondence {
        return refuse(
            "--landmarks",
            "--auto-correspondence",
            "landmarks guide the automatic registration of the source onto the target",
        );
    }
    if a.correspondence.is_none() {
        if a.format.is_some() {
            return refuse(
                "--format",
                "--correspondence",
                "it is the format of the correspondence file",
            );
        }
        if a.base.is_some() {
            return refuse(
                "--base",
                "--correspondence",
                "it is the index base of the correspondence file",
            );
        }
    }
    if a.keypoints.is_some() {
        let s = &a.select;
        for (flag, set) in [
            ("--candidates", s.candidates.is_some()),
            ("--epsilon", s.epsilon.is_some()),
            ("--max-keypoints", s.max_keypoints.is_some()),
            ("--mode", s.mode.is_some()),
            ("--error-norm", s.error_norm.is_some()),
        ] {
            if set {
                return Err(Error::invalid(format!(
                    "{flag} has no effect with --keypoints (the key points are read from the \
                     file, not selected); drop one of them"
                )));
            }
        }
    }
    Ok(())
}

pub fn run(a: TransferArgs) -> Result<ExitCode> {
    let _progress = super::progress::on_terminal();
    let t_all = Instant::now();
    check_option_dependencies(&a)?;
    // Output paths first, so nothing is computed for a run that would refuse.
    let tstem = stem(&a.target);
    let mut mesh_out = Vec::new();
    for d in &a.select.deformed {
        let p = a.out.join(format!("{}_to_{tstem}.ply", stem(d)));
        if mesh_out.contains(&p) {
            return Err(Error::invalid(format!(
                "two deformed sources would both be written to {}; rename one",
                p.display()
            )));
        }
        mesh_out.push(p);
    }
    let kp_out = a.out.join("keypoints.csv");
    let log_out = a.out.join("log.json");
    let reg_out = a.out.join("registered_source.ply");
    let mut all_out = mesh_out.clone();
    all_out.extend([kp_out.clone(), log_out.clone()]);
    if a.auto_correspondence {
        all_out.push(reg_out.clone());
    }
    refuse_overwrite(&all_out, a.force)?;

    let mut checks = Vec::new();
    let (source, deformed) = a.select.load(&mut checks)?;
    let target = load_checked(&a.target, a.select.policy(), &mut checks)?;
    check_size(&a.target, &target)?;
    let mut opts = a.select.options();

    let given = match &a.keypoints {
        Some(p) => Some((p.clone(), read_keypoints_csv(p)?)),
        None => None,
    };
    let (correspondence, map_label, pool) = target_map(&a, &source, &target, given.as_ref())?;
    // With markers: candidates drawn from the file's source vertices only
    // (in the file's order; n_c capped at their count).
    if given.is_none() && pool.is_empty() {
        a.select.check_candidates(&source, &opts)?;
    }
    opts.candidate_pool = pool;
    let keypoints = match &given {
        Some((path, rows)) => {
            let kp: Vec<usize> = rows.iter().map(|r| r.source).collect();
            if let Some(&bad) = kp.iter().find(|&&v| v >= source.n_vertices()) {
                return Err(Error::parse(
                    path,
                    "key points",
                    format!(
                        "vertex {bad} out of range for the source ({} vertices)",
                        source.n_vertices()
                    ),
                ));
            }
            KeypointSource::Given(kp)
        }
        None => KeypointSource::Automatic {
            selection_poses: None,
        },
    };
    let landmarks = match &a.landmarks {
        Some(path) => {
            let pairs = read_pairs(path, PairFormat::from_path(path), None)?;
            check_pairs(path, &pairs, source.n_vertices(), target.n_vertices())?;
            if pairs.is_empty() {
                return Err(Error::parse(path, "file", "no landmarks"));
            }
            // Contradictions are refused as in a marker file.
            let (map, order) = pair_map(path, &pairs)?;
            order.iter().map(|s| (*s, map[s])).collect()
        }
        None => Vec::new(),
    };
    let d = BdtOptions::default();
    let options = BdtOptions {
        keypoints: opts.clone(),
        frame: a.frame.unwrap_or(d.frame),
        align: a.align.unwrap_or(d.align),
        target_weights: a.target_weights.unwrap_or(d.target_weights),
        refine: a.refine || d.refine,
    };
    let (frame, refine) = (options.frame, options.refine);
    let target_weights = options.transfer_options().weight_kind;
    let method = TransferMethod::Bdt {
        keypoints,
        target: TargetPoints {
            correspondence,
            landmarks,
            seed: opts.seed,
            ..TargetPoints::default()
        },
        options,
    };
    let res = method
        .run(&TransferCase {
            a: &source,
            a_def: &deformed,
            b: &target,
        })
        .map_err(|e| match &given {
            Some((path, _)) => Error::invalid(format!("{}: {e}", path.display())),
            None => e,
        })?;
    let (Some(picked), Some(found), Some(fit)) = (&res.keypoints, &res.target, &res.fit) else {
        return Err(Error::invalid("BDT returned no key points"));
    };
    let source_kp = picked.keypoints.clone();
    let target_kp = found.keypoints.clone();
    let auto = found.auto.as_ref();
    let fit_seconds = res.timings.fit.unwrap_or(0.0);
    let log_sel = match (&picked.selection, &given) {
        (Some((sel, _)), _) => {
            print_selection(sel);
            selection_json(sel)
        }
        (None, Some((path, _))) => {
            println!(
                "{} key points from {}, fit error {:.6} (unit-sphere units), {:.2} s",
                source_kp.len(),
                path.display(),
                fit.error,
                fit_seconds
            );
            json!({"from_file": path.display().to_string(), "keypoints": source_kp,
                "error": fit.error, "seconds": fit_seconds})
        }
        (None, None) => json!(null),
    };
    if let Some(r) = auto {
        println!(
            "automatic correspondence: coarse residual {:.4}, registration residual {:.4} \
             (√area(B) units), α {:.3}, {:.2} s; target key points {:?}",
            r.coarse.residual, r.residual, r.alpha, r.seconds, r.target_keypoints
        );
    }
    let fit_error = fit.error;
    let seconds_weights = res.timings.weights.unwrap_or(0.0);
    let seconds_lbs = res.timings.lbs.unwrap_or(0.0);
    let seconds_refine = res.timings.refine.unwrap_or(0.0);

    create_dir(&a.out)?;
    for (p, m) in mesh_out.iter().zip(&res.meshes) {
        write_ply(p, m)?;
    }
    if let Some(r) = auto {
        write_ply(&reg_out, &r.registered)?;
    }
    let rows: Vec<KeypointRow> = source_kp
        .iter()
        .zip(&target_kp)
        .map(|(&s, &t)| KeypointRow {
            source: s,
            target: Some(t),
        })
        .collect();
    write_keypoints_csv(&kp_out, &rows, &source, Some(&target))?;
    let log = json!({
        "command": "transfer",
        "version": env!("CARGO_PKG_VERSION"),
        "settings": a.select.json(&opts),
        "target": a.target.display().to_string(),
        "target_map": map_label,
        "auto_correspondence": auto.map(|r| json!({
            "coarse_residual_sqrt_area": r.coarse.residual,
            "coarse_candidate_scores": r.coarse.candidate_scores,
            "coarse_chosen": r.coarse.chosen,
            "residual_sqrt_area": r.residual,
            "residual_trace_sqrt_area": r.residual_trace,
            "alpha": r.alpha,
            "coarse_rotation_deg": r.coarse.motion.angle_deg(),
            "transforms_in_target_frame": r.frames_differ(),
            "seconds_coarse": r.seconds_coarse,
            "seconds_registration": r.seconds_registration,
            "seconds": r.seconds,
            "output": reg_out.display().to_string(),
        })),
        "frame": frame.name(),
        "target_weights": target_weights,
        "refine": refine,
        "selection": log_sel,
        "fit_error": fit_error,
        "source_keypoints": source_kp,
        "target_keypoints": target_kp,
        "seconds": {
            "fit": fit_seconds,
            "target_weights": seconds_weights,
            "lbs": seconds_lbs,
            "refine": seconds_refine,
            "total": t_all.elapsed().as_secs_f64(),
        },
        "outputs": mesh_out.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
        "mesh_checks": checks,
    });
    write_json(&log_out, &log)?;
    println!(
        "transferred {} deformation(s) to {} ({} key points, frame {}, {}): weights {:.2} s, LBS {:.2} s, refine {:.2} s, total {:.2} s",
        res.meshes.len(),
        a.target.display(),
        source_kp.len(),
        frame.name(),
        if refine { "refined" } else { "not refined" },
        seconds_weights,
        seconds_lbs,
        seconds_refine,
        t_all.elapsed().as_secs_f64()
    );
    for p in &mesh_out {
        println!("  wrote {}", p.display());
    }
    if auto.is_some() {
        println!("  wrote {}", reg_out.display());
    }
    println!("  wrote {} and {}", kp_out.display(), log_out.display());
    Ok(ExitCode::SUCCESS)
}

/// How the target key points are found, and its label for the log.
fn target_map(
    a: &TransferArgs,
    source: &Mesh,
    target: &Mesh,
    given: Option<&(PathBuf, Vec<KeypointRow>)>,
) -> Result<(TargetCorrespondence, String, Vec<usize>)> {
    if a.auto_correspondence {
        return Ok((
            TargetCorrespondence::Auto,
            "automatic (registration of the source onto the target)".to_string(),
            Vec::new(),
        ));
    }
    if a.same_connectivity {
        if source.n_vertices() != target.n_vertices() {
            return Err(Error::parse(
                &a.target,
                "mesh",
                format!(
                    "--same-connectivity, but the target has {} vertices and the source {} has {}",
                    target.n_vertices(),
                    a.select.source.display(),
                    source.n_vertices()
                ),
            ));
        }
        return Ok((
            TargetCorrespondence::Identity,
            "same-connectivity".to_string(),
            Vec::new(),
        ));
    }
    if let Some(v) = &a.target_keypoints {
        if let Some((path, rows)) = given {
            if rows.len() != v.len() {
                return Err(Error::invalid(format!(
                    "--target-keypoints has {} vertices but {} holds {} key points",
                    v.len(),
                    path.display(),
                    rows.len()
                )));
            }
        }
        return Ok((
            TargetCorrespondence::List(v.clone()),
            "list".to_string(),
            Vec::new(),
        ));
    }
    if let Some(path) = &a.correspondence {
        let format = a.format.unwrap_or_else(|| PairFormat::from_path(path));
        let pairs = read_pairs(path, format, a.base)?;
        check_pairs(path, &pairs, source.n_vertices(), target.n_vertices())?;
        if pairs.is_empty() {
            return Err(Error::parse(path, "file", "no correspondences"));
        }
        let (map, sources) = pair_map(path, &pairs)?;
        let label = format!(
            "correspondence {} (candidates drawn from its {} source vertices)",
            path.display(),
            map.len()
        );
        return Ok((
            TargetCorrespondence::Markers {
                file: path.display().to_string(),
                map,
            },
            label,
            sources,
        ));
    }
    match given {
        Some((_, rows)) if rows.iter().all(|r| r.target.is_some()) => Ok((
            TargetCorrespondence::List(rows.iter().filter_map(|r| r.target).collect()),
            "keypoints file".to_string(),
            Vec::new(),
        )),
        Some((path, _)) => Err(Error::invalid(format!(
            "{} has no `target` column; pass --same-connectivity, --target-keypoints, --correspondence or \
             --auto-correspondence",
            path.display()
        ))),
        None => Err(Error::invalid(
            "no target key points: pass --same-connectivity, --target-keypoints, --correspondence \
             or --auto-correspondence",
        )),
    }
}
