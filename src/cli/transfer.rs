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

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use clap::{ArgGroup, Args, ValueEnum};
use serde_json::{json, Value};

use deformlab::data::correspondence::{check_pairs, read_pairs, PairFormat};
use deformlab::mesh::io::{read_mesh, write_ply};
use deformlab::skin::Affine;
use deformlab::transfer::keypoints::{fit_keypoints, select_keypoints, SelectionMode};
use deformlab::transfer::{
    auto_correspondence, transfer_detailed, AutoCorrespondence, AutoOptions, TargetWeights,
    TransferFrame, TransferOptions,
};
use deformlab::{Error, Mesh, Result};

use super::keypoints::{
    create_dir, print_selection, read_keypoints_csv, refuse_overwrite, selection_json, write_json,
    write_keypoints_csv, KeypointRow, SelectArgs,
};

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum FrameArg {
    /// T_k applied to B as is (A and B in one frame).
    Direct,
    /// Same linear part and same handle displacement as on A.
    HandleRelative,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum FormatArg {
    Csv,
    MarkersYml,
    Cons,
}

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
    target option.")]
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
    pub format: Option<FormatArg>,
    /// Index base of the correspondence file (default: the format's).
    #[arg(long, requires = "correspondence")]
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
    /// How the transforms act on B.
    #[arg(long, value_enum, default_value_t = FrameArg::Direct)]
    pub frame: FrameArg,
    /// Refine each B′ with handle-constrained reduced ARAP on B.
    #[arg(long)]
    pub refine: bool,
    /// Overwrite existing outputs.
    #[arg(long)]
    pub force: bool,
}

enum TargetMap {
    Same,
    List(Vec<usize>),
    Markers {
        path: PathBuf,
        map: HashMap<usize, usize>,
        sources: Vec<usize>,
    },
    FromFile,
    Auto,
}

fn stem(p: &Path) -> String {
    p.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "mesh".into())
}

pub fn run(a: TransferArgs) -> Result<ExitCode> {
    let t_all = Instant::now();
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

    let (source, deformed) = a.select.load()?;
    let target = read_mesh(&a.target)?;
    let mut opts = a.select.options();

    let given = match &a.keypoints {
        Some(p) => Some((p.clone(), read_keypoints_csv(p)?)),
        None => None,
    };
    let map = target_map(&a, &source, &target, given.as_ref())?;
    if let TargetMap::Markers { sources, .. } = &map {
        opts.candidate_pool = sources.clone();
    }

    // Source key points and their transforms.
    let log_sel: Value;
    let (source_kp, transforms, fit_error): (Vec<usize>, Vec<Vec<Affine>>, f64) = match &given {
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
            let t = Instant::now();
            let fit = fit_keypoints(&source, &deformed, &kp, &opts)
                .map_err(|e| Error::invalid(format!("{}: {e}", path.display())))?;
            println!(
                "{} key points from {}, fit error {:.6} (unit-sphere units), {:.2} s",
                kp.len(),
                path.display(),
                fit.error,
                t.elapsed().as_secs_f64()
            );
            log_sel = json!({"from_file": path.display().to_string(), "keypoints": kp,
                "error": fit.error, "seconds": t.elapsed().as_secs_f64()});
            (kp, fit.transforms, fit.error)
        }
        None => {
            let sel = select_keypoints(&source, &deformed, &opts)?;
            print_selection(&sel);
            log_sel = selection_json(&sel);
            (sel.keypoints.clone(), sel.transforms.clone(), sel.error)
        }
    };

    let mut auto: Option<AutoCorrespondence> = None;
    let target_kp: Vec<usize> = match &map {
        TargetMap::Auto => {
            let landmarks = match &a.landmarks {
                Some(path) => {
                    let pairs = read_pairs(path, PairFormat::from_path(path), None)?;
                    check_pairs(path, &pairs, source.n_vertices(), target.n_vertices())?;
                    if pairs.is_empty() {
                        return Err(Error::parse(path, "file", "no landmarks"));
                    }
                    pairs.iter().map(|p| (p.source, p.target)).collect()
                }
                None => Vec::new(),
            };
            let r = auto_correspondence(
                &source,
                &source_kp,
                &target,
                &AutoOptions {
                    seed: a.select.seed,
                    landmarks,
                    ..AutoOptions::default()
                },
            )?;
            println!(
                "automatic correspondence: coarse residual {:.4}, registration residual {:.4} \
                 (√area(B) units), α {:.3}, {:.2} s; target key points {:?}",
                r.coarse.residual, r.residual, r.alpha, r.seconds, r.target_keypoints
            );
            let kp = r.target_keypoints.clone();
            auto = Some(r);
            kp
        }
        TargetMap::Same => source_kp.clone(),
        TargetMap::List(v) => {
            if v.len() != source_kp.len() {
                return Err(Error::invalid(format!(
                    "--target-keypoints has {} vertices but there are {} key points {:?}; \
                     pass --keypoints FILE to fix the source key points",
                    v.len(),
                    source_kp.len(),
                    source_kp
                )));
            }
            v.clone()
        }
        TargetMap::Markers { path, map, .. } => source_kp
            .iter()
            .map(|s| {
                map.get(s).copied().ok_or_else(|| {
                    Error::parse(
                        path,
                        "markers",
                        format!("key point (source vertex {s}) is not a source vertex of the file"),
                    )
                })
            })
            .collect::<Result<_>>()?,
        TargetMap::FromFile => given
            .as_ref()
            .map(|(_, rows)| rows.iter().filter_map(|r| r.target).collect())
            .unwrap_or_default(),
    };

    let topts = TransferOptions {
        frame: match a.frame {
            FrameArg::Direct => TransferFrame::Direct,
            FrameArg::HandleRelative => TransferFrame::HandleRelative,
        },
        weights: opts.weights,
        // B is skinned the way A was when the transforms were fitted.
        weight_kind: match opts.mode {
            SelectionMode::Exact => TargetWeights::Bounded,
            SelectionMode::Fast => TargetWeights::Fast(opts.fast.bounds),
        },
        refine: a.refine,
        seed: a.select.seed,
        ..TransferOptions::default()
    };
    // A rotated onto B by the registration: transforms in B's frame.
    let (source_t, transforms) = match &auto {
        Some(r) => (
            r.source_in_target_frame(&source)?,
            r.target_frame_transforms(&transforms),
        ),
        None => (source.clone(), transforms),
    };
    let res = transfer_detailed(
        &source_t,
        &source_kp,
        &transforms,
        &target,
        &target_kp,
        &topts,
    )?;

    create_dir(&a.out)?;
    for (p, m) in mesh_out.iter().zip(&res.meshes) {
        write_ply(p, m)?;
    }
    if let Some(r) = &auto {
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
        "target_map": match &map {
            TargetMap::Same => "same-connectivity".to_string(),
            TargetMap::List(_) => "list".to_string(),
            TargetMap::Markers { path, sources, .. } => format!(
                "correspondence {} (candidates drawn from its {} source vertices)",
                path.display(),
                sources.len()
            ),
            TargetMap::FromFile => "keypoints file".to_string(),
            TargetMap::Auto => "automatic (registration of the source onto the target)".to_string(),
        },
        "auto_correspondence": auto.as_ref().map(|r| json!({
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
        "frame": topts.frame.name(),
        "refine": a.refine,
        "selection": log_sel,
        "fit_error": fit_error,
        "source_keypoints": source_kp,
        "target_keypoints": target_kp,
        "seconds": {
            "target_weights": res.seconds_weights,
            "lbs": res.seconds_lbs,
            "refine": res.seconds_refine,
            "total": t_all.elapsed().as_secs_f64(),
        },
        "outputs": mesh_out.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
    });
    write_json(&log_out, &log)?;
    println!(
        "transferred {} deformation(s) to {} ({} key points, frame {}, {}): weights {:.2} s, LBS {:.2} s, refine {:.2} s, total {:.2} s",
        res.meshes.len(),
        a.target.display(),
        source_kp.len(),
        topts.frame.name(),
        if a.refine { "refined" } else { "not refined" },
        res.seconds_weights,
        res.seconds_lbs,
        res.seconds_refine,
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

fn target_map(
    a: &TransferArgs,
    source: &Mesh,
    target: &Mesh,
    given: Option<&(PathBuf, Vec<KeypointRow>)>,
) -> Result<TargetMap> {
    if a.auto_correspondence {
        return Ok(TargetMap::Auto);
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
        return Ok(TargetMap::Same);
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
        return Ok(TargetMap::List(v.clone()));
    }
    if let Some(path) = &a.correspondence {
        let format = match a.format {
            Some(FormatArg::Csv) => PairFormat::Csv,
            Some(FormatArg::MarkersYml) => PairFormat::MarkersYml,
            Some(FormatArg::Cons) => PairFormat::Cons,
            None => PairFormat::from_path(path),
        };
        let pairs = read_pairs(path, format, a.base)?;
        check_pairs(path, &pairs, source.n_vertices(), target.n_vertices())?;
        if pairs.is_empty() {
            return Err(Error::parse(path, "file", "no correspondences"));
        }
        let mut map = HashMap::new();
        let mut sources = Vec::new();
        for p in &pairs {
            if let Some(&t) = map.get(&p.source) {
                if t != p.target {
                    return Err(Error::parse(
                        path,
                        "markers",
                        format!(
                            "source vertex {} is matched to both {t} and {}",
                            p.source, p.target
                        ),
                    ));
                }
            } else {
                map.insert(p.source, p.target);
                sources.push(p.source);
            }
        }
        return Ok(TargetMap::Markers {
            path: path.clone(),
            map,
            sources,
        });
    }
    match given {
        Some((_, rows)) if rows.iter().all(|r| r.target.is_some()) => Ok(TargetMap::FromFile),
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
