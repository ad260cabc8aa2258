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
    transfer_method, BdtOptions, Family, KeypointSource, MethodKind, TargetCorrespondence,
    TransferCase, TransferMethod,
};
use deformlab::transfer::{FrameAlign, TargetWeights, TransferFrame};
use deformlab::{Error, Mesh, Result};

use super::keypoints::{
    check_size, create_dir, load_checked, prepare_out_dir, print_selection, read_keypoints_csv,
    refuse_overwrite, selection_json, write_json, write_keypoints_csv, KeypointRow, SelectArgs,
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
    /// The transfer method, a kind of the registry (`deformlab methods`):
    /// bdt, bdt_random, bdt_extremity, sumner, cage, sumner_oracle, identity.
    #[arg(long, default_value = "bdt", value_parser = transfer_kind)]
    pub method: String,
    /// A key of the method, as in a config's `[[methods]]` entry (repeat it):
    /// `--opt count=8 --opt pool=vertices`; the value is TOML (a bare word is a
    /// string). Keys the method does not use are refused.
    #[arg(long = "opt", value_name = "KEY=VALUE")]
    pub opts: Vec<String>,
    /// Overwrite existing outputs.
    #[arg(long)]
    pub force: bool,
}

/// `--method identity` / `sumner_oracle` take no key points: the flags that
/// give or match them do not apply.
fn refuse_keypoint_flags(a: &TransferArgs) -> Result<()> {
    for (flag, set) in [
        ("--keypoints", a.keypoints.is_some()),
        ("--correspondence", a.correspondence.is_some()),
        ("--same-connectivity", a.same_connectivity),
        ("--target-keypoints", a.target_keypoints.is_some()),
        ("--auto-correspondence", a.auto_correspondence),
    ] {
        if set {
            return Err(Error::invalid(format!(
                "{flag} does not apply to --method {} (it takes no key points)",
                a.method
            )));
        }
    }
    Ok(())
}

/// `--method`: the name of a transfer kind of the registry.
fn transfer_kind(s: &str) -> std::result::Result<String, String> {
    match MethodKind::from_name(s) {
        Some(k) if k.info().family == Family::Transfer => Ok(s.to_string()),
        _ => Err(format!(
            "expected a transfer method: {}",
            MethodKind::ALL
                .iter()
                .filter(|k| k.info().family == Family::Transfer)
                .map(|k| k.name())
                .collect::<Vec<_>>()
                .join(", ")
        )),
    }
}

/// The method entry of the command line: `--method`, the selection and
/// transfer flags under their config keys, then `--opt KEY=VALUE`; resolved
/// through the registry like a config's `[[methods]]` entry.
fn method_of(a: &TransferArgs) -> Result<TransferMethod> {
    fn value<T: serde::Serialize>(v: &T) -> toml::Value {
        toml::Value::try_from(v).unwrap_or_else(|_| toml::Value::String(String::new()))
    }
    let s = &a.select;
    let mut t = toml::Table::new();
    let flags: [(&str, &str, Option<toml::Value>); 11] = [
        (
            "--candidates",
            "n_candidates",
            s.candidates.map(|v| value(&v)),
        ),
        ("--seed", "seed", s.seed.map(|v| value(&v))),
        ("--epsilon", "epsilon", s.epsilon.map(|v| value(&v))),
        (
            "--max-keypoints",
            "max_keypoints",
            s.max_keypoints.map(|v| value(&v)),
        ),
        ("--mode", "mode", s.mode.map(|v| value(&v))),
        (
            "--error-norm",
            "error_norm",
            s.error_norm.map(|v| value(&v)),
        ),
        ("--weights", "weights", s.weights.map(|v| value(&v))),
        ("--frame", "frame", a.frame.map(|v| value(&v))),
        ("--align", "align", a.align.map(|v| value(&v))),
        (
            "--target-weights",
            "target_weights",
            a.target_weights.map(|v| value(&v)),
        ),
        (
            "--refine",
            "refine",
            a.refine.then_some(toml::Value::Boolean(true)),
        ),
    ];
    let mut flag_of = std::collections::BTreeMap::new();
    for (flag, key, v) in flags {
        if let Some(v) = v {
            t.insert(key.into(), v);
            flag_of.insert(key.to_string(), flag.to_string());
        }
    }
    for o in &a.opts {
        let Some((k, v)) = o.split_once('=') else {
            return Err(Error::invalid(format!(
                "--opt {o:?}: expected KEY=VALUE (e.g. --opt count=8)"
            )));
        };
        let k = k.trim();
        if matches!(k, "name" | "kind" | "group" | "label") {
            return Err(Error::invalid(format!(
                "--opt {k}: not a method option (the method is --method)"
            )));
        }
        if k == "target_correspondence" {
            return Err(Error::invalid(
                "--opt target_correspondence: the command line matches key points with \
                 --same-connectivity, --target-keypoints, --correspondence or \
                 --auto-correspondence",
            ));
        }
        if let Some(flag) = flag_of.get(k) {
            return Err(Error::invalid(format!(
                "--opt {k} repeats {flag}; give it once"
            )));
        }
        if t.contains_key(k) {
            return Err(Error::invalid(format!("--opt {k} is given twice")));
        }
        let v = v.trim();
        let parsed = toml::from_str::<toml::Table>(&format!("v = {v}"))
            .ok()
            .and_then(|mut t| t.remove("v"))
            .unwrap_or_else(|| toml::Value::String(v.to_string()));
        t.insert(k.to_string(), parsed);
        flag_of.insert(k.to_string(), format!("--opt {k}"));
    }
    t.remove("name");
    t.remove("kind");
    transfer_method(&a.method, &t).map_err(|(key, msg)| {
        let top = key.split('.').next().unwrap_or(&key);
        Error::invalid(match flag_of.get(top) {
            _ if key.is_empty() => format!("--method {}: {msg}", a.method),
            Some(flag) => format!("{flag}: {msg}"),
            None => format!("--method {}: `{key}`: {msg} (--opt {key}=...)", a.method),
        })
    })
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
    let _progress = super::progress::for_command("transfer");
    let t_all = Instant::now();
    check_option_dependencies(&a)?;
    // The method first: a bad option is refused before anything is read.
    let method = method_of(&a)?;
    if method.keypoint_inputs().is_none() {
        refuse_keypoint_flags(&a)?;
    }
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
    prepare_out_dir(&a.out)?;

    let mut checks = Vec::new();
    let (source, deformed) = a.select.load(&mut checks)?;
    let target = load_checked(&a.target, a.select.policy(), &mut checks)?;
    check_size(&a.target, &target)?;

    let mut method = method;
    let given = match &a.keypoints {
        Some(p) => Some((p.clone(), read_keypoints_csv(p)?)),
        None => None,
    };
    let mut map_label = None;
    if let Some((source_kp, target_points, opts)) = method.keypoint_inputs_mut() {
        let (correspondence, label, pool) = target_map(&a, &source, &target, given.as_ref())?;
        map_label = Some(label);
        // With markers: candidates drawn from the file's source vertices
        // only (in the file's order; n_c capped at their count).
        if given.is_none()
            && pool.is_empty()
            && matches!(source_kp, KeypointSource::Automatic { .. })
        {
            a.select.check_candidates(&source, opts)?;
        }
        opts.candidate_pool = pool;
        if let Some((path, rows)) = &given {
            if !matches!(source_kp, KeypointSource::Automatic { .. }) {
                return Err(Error::invalid(format!(
                    "--keypoints replaces the selection, and --method {} picks its own key \
                     points; drop one of them",
                    a.method
                )));
            }
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
            *source_kp = KeypointSource::Given(kp);
        }
        target_points.correspondence = correspondence;
        target_points.landmarks = match &a.landmarks {
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
    }
    let opts = method
        .keypoint_inputs()
        .map(|(_, _, o)| o.clone())
        .unwrap_or_default();
    let (frame, refine, target_weights) = match &method {
        TransferMethod::Bdt { options, .. } => (
            Some(options.frame),
            options.refine,
            Some(options.transfer_options().weight_kind),
        ),
        _ => (None, false, None),
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
    let source_kp: Vec<usize> = res
        .keypoints
        .as_ref()
        .map(|p| p.keypoints.clone())
        .unwrap_or_default();
    let target_kp: Vec<usize> = res
        .target
        .as_ref()
        .map(|t| t.keypoints.clone())
        .unwrap_or_default();
    let auto = res.target.as_ref().and_then(|t| t.auto.as_ref());
    let fit_seconds = res.timings.fit.unwrap_or(0.0);
    let fit_error = res.fit.as_ref().map(|f| f.error);
    let log_sel = match (
        res.keypoints.as_ref().and_then(|p| p.selection.as_ref()),
        &given,
    ) {
        (Some((sel, _)), _) => {
            print_selection(sel);
            selection_json(sel)
        }
        (None, Some((path, _))) => {
            println!(
                "{} key points from {}{}",
                source_kp.len(),
                path.display(),
                match fit_error {
                    Some(e) =>
                        format!(", fit error {e:.6} (unit-sphere units), {fit_seconds:.2} s"),
                    None => String::new(),
                }
            );
            json!({"from_file": path.display().to_string(), "keypoints": source_kp,
                "error": fit_error, "seconds": fit_seconds})
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
    let t = &res.timings;

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
    if res.keypoints.is_some() {
        write_keypoints_csv(&kp_out, &rows, &source, Some(&target))?;
    }
    let log = json!({
        "command": "transfer",
        "version": env!("CARGO_PKG_VERSION"),
        "method": a.method,
        "method_options": a.opts,
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
        "frame": frame.map(|f| f.name()),
        "target_weights": target_weights,
        "refine": refine,
        "selection": log_sel,
        "fit_error": fit_error,
        "source_keypoints": source_kp,
        "target_keypoints": target_kp,
        "seconds": {
            "fit": t.fit,
            "target_weights": t.weights,
            "lbs": t.lbs,
            "refine": t.refine,
            "precompute": t.precompute,
            "factorise": t.factorise,
            "solve": t.solve,
            "total": t_all.elapsed().as_secs_f64(),
        },
        "outputs": mesh_out.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
        "mesh_checks": checks,
    });
    write_json(&log_out, &log)?;
    let secs = |x: Option<f64>| x.map_or("-".to_string(), |v| format!("{v:.2} s"));
    match frame {
        Some(frame) => println!(
            "transferred {} deformation(s) to {} with {} ({} key points, frame {}, {}): weights {}, LBS {}, refine {}, total {:.2} s",
            res.meshes.len(),
            a.target.display(),
            a.method,
            source_kp.len(),
            frame.name(),
            if refine { "refined" } else { "not refined" },
            secs(t.weights),
            secs(t.lbs),
            secs(t.refine),
            t_all.elapsed().as_secs_f64()
        ),
        None => println!(
            "transferred {} deformation(s) to {} with {} ({} key points): precompute {}, solve {}, total {:.2} s",
            res.meshes.len(),
            a.target.display(),
            a.method,
            source_kp.len(),
            secs(t.precompute),
            secs(t.solve),
            t_all.elapsed().as_secs_f64()
        ),
    }
    for p in &mesh_out {
        println!("  wrote {}", p.display());
    }
    if auto.is_some() {
        println!("  wrote {}", reg_out.display());
    }
    if res.keypoints.is_some() {
        println!("  wrote {}", kp_out.display());
    }
    println!("  wrote {}", log_out.display());
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
