//! `deformlab keypoints`: automatic key point selection (BDT Sec. 3.5,
//! Algorithm 1) on a source mesh and its deformed poses. Also the pieces
//! `deformlab transfer` shares: selection options, mesh loading, the key
//! point CSV and the JSON log.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use clap::Args;
use serde_json::{json, Value};

use deformlab::mesh::io::{read_mesh, write_atomic};
use deformlab::mesh::repair::{DefectPolicy, FaceRepair};
use deformlab::mesh::Face;
use deformlab::methods::spec::{Epsilon, MaxKeypoints, NCandidates};
use deformlab::methods::KeypointSource;
use deformlab::skin::bbw::{BbwOptions, WeightMode};
use deformlab::transfer::keypoints::{
    ErrorNorm, KeypointOptions, KeypointSelection, SelectionMode,
};
use deformlab::{Error, Mesh, Result};

/// An option's help line ending in the library's default (the one
/// definition), so `--help` cannot drift from [`KeypointOptions::default`]
/// or [`deformlab::skin::bbw::BbwOptions::default`].
pub(crate) fn default_help(text: &str, default: impl std::fmt::Display) -> String {
    format!("{text} [default: the library's, {default}]")
}

/// The command-line spelling of an enum value.
pub(crate) fn value_name<T: clap::ValueEnum>(v: &T) -> String {
    v.to_possible_value()
        .map(|p| p.get_name().to_string())
        .unwrap_or_else(|| "?".into())
}

/// Source, deformed sources and the selection settings (shared by
/// `keypoints` and `transfer`). Every option left out takes the library's
/// default ([`KeypointOptions::default`]), as a config without the key does.
#[derive(Args, Debug, Clone)]
pub struct SelectArgs {
    /// Source reference mesh A.
    #[arg(long)]
    pub source: PathBuf,
    /// Deformed sources A′ (same connectivity as A), one or more.
    #[arg(long, num_args = 1.., required = true)]
    pub deformed: Vec<PathBuf>,
    /// Help text (with the library's default) in `help` below.
    #[arg(long, value_parser = NCandidates::parse, help = default_help(
        "Number of farthest-point-sampled candidates n_c, 1..=100000 and at most the source's vertex count",
        KeypointOptions::default().n_candidates))]
    pub candidates: Option<usize>,
    /// Help text (with the library's default) in `help` below.
    #[arg(long, help = default_help(
        "Seed of every random choice (first FPS sample, k-means of the groups)",
        KeypointOptions::default().seed))]
    pub seed: Option<u64>,
    /// Help text (with the library's default) in `help` below.
    #[arg(long, value_parser = Epsilon::parse, help = default_help(
        "Stop adding key points when the error (unit-sphere units) is below ε, a finite number ≥ 0",
        KeypointOptions::default().epsilon))]
    pub epsilon: Option<f64>,
    /// Help text (with the library's default) in `help` below.
    #[arg(long, value_parser = MaxKeypoints::parse, help = default_help(
        "Upper bound on the number of key points, 1..=1000",
        KeypointOptions::default().max_keypoints))]
    pub max_keypoints: Option<usize>,
    /// Help text (with the library's default) in `help` below.
    #[arg(long, value_enum, help = default_help(
        "Candidate scoring", value_name(&KeypointOptions::default().mode)))]
    pub mode: Option<SelectionMode>,
    /// Help text (with the library's default) in `help` below.
    #[arg(long, value_enum, help = default_help(
        "Error compared with ε", value_name(&KeypointOptions::default().error_norm)))]
    pub error_norm: Option<ErrorNorm>,
    /// Help text (with the library's default) in `help` below.
    #[arg(long, value_enum, help = default_help(
        "Bounded biharmonic weights of every fit on the source (trials and the final fit) and of \
         the target in `transfer`: per-handle = each handle bounded separately, rows normalised \
         (libigl's bbw, BDT's ref. [5]); coupled = BDT Eq. 1 as written (bounds and partition of \
         unity in one problem, slower)",
        value_name(&KeypointOptions::default().weights.mode)))]
    pub weights: Option<WeightMode>,
    /// Refuse meshes with defects that change results (duplicate or
    /// zero-area faces, non-manifold edges or vertices, inconsistent winding,
    /// several components, unreferenced vertices) instead of warning.
    #[arg(long)]
    pub strict: bool,
    /// Repair the meshes first: drop duplicate and zero-area faces, wind
    /// each component consistently (A′ get A's repair when they share its
    /// faces); each repair is printed and logged.
    #[arg(long)]
    pub repair: bool,
}

impl SelectArgs {
    /// Library options from the command line: [`KeypointOptions::default`]
    /// with the flags given.
    pub fn options(&self) -> KeypointOptions {
        let d = KeypointOptions::default();
        KeypointOptions {
            n_candidates: self.candidates.unwrap_or(d.n_candidates),
            seed: self.seed.unwrap_or(d.seed),
            epsilon: self.epsilon.unwrap_or(d.epsilon),
            max_keypoints: self.max_keypoints.unwrap_or(d.max_keypoints),
            mode: self.mode.unwrap_or(d.mode),
            error_norm: self.error_norm.unwrap_or(d.error_norm),
            weights: match self.weights {
                Some(m) => BbwOptions::with_mode(m),
                None => d.weights,
            },
            ..d
        }
    }

    /// The defect policy of `--strict` / `--repair` (each left out: the
    /// library's [`DefectPolicy::default`]).
    pub fn policy(&self) -> DefectPolicy {
        let d = DefectPolicy::default();
        DefectPolicy {
            strict: self.strict || d.strict,
            repair: self.repair || d.repair,
        }
    }

    /// Loads A and the A′, each under [`Self::policy`] (see
    /// [`load_checked`]; the A′ with A's face list get A's repair; the
    /// checks are appended to `log`), checking that A is one connected
    /// surface of a size `f64` handles and that every A′ has A's vertex
    /// count.
    pub fn load(&self, log: &mut Vec<Value>) -> Result<(Mesh, Vec<Mesh>)> {
        let policy = self.policy();
        let raw = read_mesh(&self.source)?;
        let plan = policy.repair.then(|| FaceRepair::plan(&raw));
        let original = raw.faces().to_vec();
        let shared = plan.as_ref().map(|p| (original.as_slice(), p));
        let source = check_mesh(raw, &self.source, policy, shared, log)?;
        let parts = source.component_count();
        if parts > 1 {
            return Err(Error::parse(
                &self.source,
                "mesh",
                format!(
                    "{parts} connected components (separate parts, or an unwelded triangle \
                     soup: one per face); the source must be one connected surface (weld \
                     duplicate vertices, or keep one part)"
                ),
            ));
        }
        check_size(&self.source, &source)?;
        let deformed = self
            .deformed
            .iter()
            .map(|p| {
                let m = check_mesh(read_mesh(p)?, p, policy, shared, log)?;
                if m.n_vertices() != source.n_vertices() {
                    return Err(Error::parse(
                        p,
                        "mesh",
                        format!(
                            "{} vertices, but the source {} has {}",
                            m.n_vertices(),
                            self.source.display(),
                            source.n_vertices()
                        ),
                    ));
                }
                Ok(m)
            })
            .collect::<Result<Vec<_>>>()?;
        Ok((source, deformed))
    }

    /// Errors (naming the flag and the file) when the selection would draw
    /// more candidates than the source has vertices.
    pub fn check_candidates(&self, source: &Mesh, opts: &KeypointOptions) -> Result<()> {
        let n = source.n_vertices();
        if opts.n_candidates > n {
            return Err(Error::invalid(format!(
                "--candidates {}{} exceeds the {n} vertices of the source {}; expected 1..={n}",
                opts.n_candidates,
                if self.candidates.is_none() {
                    " (the default)"
                } else {
                    ""
                },
                self.source.display()
            )));
        }
        Ok(())
    }

    /// The settings as JSON (for the log).
    pub fn json(&self, opts: &KeypointOptions) -> Value {
        json!({
            "source": self.source.display().to_string(),
            "deformed": self.deformed.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
            "candidates": opts.n_candidates,
            "seed": opts.seed,
            "epsilon": opts.epsilon,
            "max_keypoints": opts.max_keypoints,
            "mode": opts.mode,
            "error_norm": format!("{:?}", opts.error_norm),
            "weights": format!("{:?}", opts.weights.mode),
            "strict": self.policy().strict,
            "repair": self.policy().repair,
        })
    }
}

/// Errors (naming the file) when a mesh's coordinates span a range whose
/// squares overflow or underflow `f64` ([`deformlab::mesh::check_extent`]).
pub fn check_size(path: &Path, mesh: &Mesh) -> Result<()> {
    deformlab::mesh::check_extent(deformlab::mesh::half_diagonal(mesh.vertices()))
        .map_err(|msg| Error::parse(path, "mesh", msg))
}

/// Reads a mesh and applies `policy` to it ([`check_mesh`]).
pub fn load_checked(path: &Path, policy: DefectPolicy, log: &mut Vec<Value>) -> Result<Mesh> {
    check_mesh(read_mesh(path)?, path, policy, None, log)
}

/// Applies `policy` to a mesh read from `path` ([`DefectPolicy::apply`];
/// `shared`: another mesh's original faces and repair): prints one
/// `repaired: PATH: …` line for a repair and one `warning: PATH: …` line per
/// defect kind left (strict mode: an error naming the file), and appends
/// them to `log` (nothing for a clean mesh).
pub fn check_mesh(
    mesh: Mesh,
    path: &Path,
    policy: DefectPolicy,
    shared: Option<(&[Face], &FaceRepair)>,
    log: &mut Vec<Value>,
) -> Result<Mesh> {
    let c = policy.apply(mesh, path, shared)?;
    if let Some(r) = &c.repair {
        eprintln!("repaired: {}: {r}", path.display());
    }
    for d in &c.defects {
        eprintln!("warning: {}: {d}", path.display());
    }
    if c.repair.is_some() || !c.defects.is_empty() {
        log.push(json!({
            "file": path.display().to_string(),
            "repaired": c.repair.as_ref().map(|r| r.to_string()),
            "defects": c.defects.iter().map(|d| json!({
                "kind": d.kind.name(), "count": d.count, "detail": d.to_string(),
            })).collect::<Vec<_>>(),
        }));
    }
    Ok(c.mesh)
}

/// `deformlab keypoints` arguments.
#[derive(Args, Debug)]
#[command(after_help = "Examples:\n  \
    deformlab keypoints --source faust/tr_reg_000.ply --deformed faust/tr_reg_003.ply faust/tr_reg_007.ply\n  \
    deformlab keypoints --source A.ply --deformed A1.ply A2.ply --candidates 50 --mode exact --out kp/\n\n\
    With --out DIR: DIR/keypoints.csv (source vertex, x y z on A) and DIR/log.json (settings,\n\
    error trace, timings). Existing files are not overwritten unless --force is given.\n\
    Mesh defects that change results are printed as one warning per file and kind (and logged);\n\
    --strict refuses such meshes, --repair fixes the standard ones and says what it did.")]
pub struct KeypointsArgs {
    #[command(flatten)]
    pub select: SelectArgs,
    /// Output folder for keypoints.csv and log.json (created if missing).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Overwrite existing outputs.
    #[arg(long)]
    pub force: bool,
}

pub fn run(a: KeypointsArgs) -> Result<ExitCode> {
    let _progress = super::progress::for_command("keypoints");
    let t_all = Instant::now();
    if a.force && a.out.is_none() {
        return Err(Error::invalid(
            "--force has no effect without --out (nothing is written); add --out DIR or drop \
             --force",
        ));
    }
    let outputs = a
        .out
        .as_ref()
        .map(|d| vec![d.join("keypoints.csv"), d.join("log.json")])
        .unwrap_or_default();
    refuse_overwrite(&outputs, a.force)?;
    if let Some(dir) = &a.out {
        prepare_out_dir(dir)?;
    }
    let mut checks = Vec::new();
    let (source, deformed) = a.select.load(&mut checks)?;
    let opts = a.select.options();
    a.select.check_candidates(&source, &opts)?;
    let picked = KeypointSource::Automatic {
        selection_poses: None,
    }
    .pick(&source, &deformed, &opts)?;
    let sel = picked
        .selection
        .map(|(s, _)| s)
        .ok_or_else(|| Error::invalid("the automatic selection returned no selection"))?;
    print_selection(&sel);
    if let Some(dir) = &a.out {
        create_dir(dir)?;
        let rows: Vec<KeypointRow> = sel
            .keypoints
            .iter()
            .map(|&s| KeypointRow {
                source: s,
                target: None,
            })
            .collect();
        write_keypoints_csv(&outputs[0], &rows, &source, None)?;
        let log = json!({
            "command": "keypoints",
            "version": env!("CARGO_PKG_VERSION"),
            "settings": a.select.json(&opts),
            "selection": selection_json(&sel),
            "mesh_checks": checks,
            "seconds_total": t_all.elapsed().as_secs_f64(),
        });
        write_json(&outputs[1], &log)?;
        println!(
            "wrote {} and {}",
            outputs[0].display(),
            outputs[1].display()
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// Errors if any of `paths` exists and `force` is not set.
pub fn refuse_overwrite(paths: &[PathBuf], force: bool) -> Result<()> {
    if force {
        return Ok(());
    }
    if let Some(p) = paths.iter().find(|p| p.exists()) {
        return Err(Error::invalid(format!(
            "{} already exists; pass --force to overwrite it",
            p.display()
        )));
    }
    Ok(())
}

pub fn create_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))
}

/// The output folder `--out DIR`, checked before anything is computed (it
/// is made only when the outputs are written, so a refused command leaves
/// nothing behind): an existing file of that name, or a path under a file,
/// is refused at once instead of after the computation.
pub fn prepare_out_dir(dir: &Path) -> Result<()> {
    let mut p = dir;
    loop {
        match std::fs::metadata(p) {
            Ok(m) if m.is_dir() => return Ok(()),
            Ok(_) if p == dir => {
                return Err(Error::invalid(format!(
                    "--out {}: a file of that name exists; --out names a folder",
                    dir.display()
                )))
            }
            Ok(_) => {
                return Err(Error::invalid(format!(
                    "--out {}: {} is a file, so the folder cannot be made",
                    dir.display(),
                    p.display()
                )))
            }
            Err(_) => match p.parent() {
                Some(q) if !q.as_os_str().is_empty() => p = q,
                _ => return Ok(()),
            },
        }
    }
}

/// The output file `--out FILE`, checked before anything is computed: a
/// folder of that name, or a parent that is not an existing folder, is
/// refused at once instead of after the computation.
pub fn check_out_file(file: &Path) -> Result<()> {
    if file.is_dir() {
        return Err(Error::invalid(format!(
            "--out {}: is a folder; --out names the file to write",
            file.display()
        )));
    }
    let parent = match file.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !parent.is_dir() {
        return Err(Error::invalid(format!(
            "--out {}: the folder {} does not exist (or is not a folder)",
            file.display(),
            parent.display()
        )));
    }
    Ok(())
}

pub fn write_json(path: &Path, v: &Value) -> Result<()> {
    let mut s = serde_json::to_string_pretty(v)
        .map_err(|e| Error::invalid(format!("cannot encode the log: {e}")))?;
    s.push('\n');
    write_atomic(path, s.as_bytes())
}

/// Prints the key points, the error trace and the time.
pub fn print_selection(sel: &KeypointSelection) {
    println!(
        "{} key points (of {} candidates), error {:.6} (unit-sphere units), {} evaluations, {:.2} s",
        sel.keypoints.len(),
        sel.candidates.len(),
        sel.error,
        sel.evaluations,
        sel.seconds
    );
    println!("key points (source vertices): {:?}", sel.keypoints);
    println!("error trace:");
    for (i, s) in sel.trace.iter().enumerate() {
        println!(
            "  {i:3}  stage {}  {:3} key points  error {:.6}",
            s.stage,
            s.keypoints.len(),
            s.error
        );
    }
}

/// The selection as JSON.
pub fn selection_json(sel: &KeypointSelection) -> Value {
    json!({
        "keypoints": sel.keypoints,
        "candidates": sel.candidates,
        "error": sel.error,
        "evaluations": sel.evaluations,
        "seconds": sel.seconds,
        "normalization": { "center": [sel.normalization.center.x, sel.normalization.center.y, sel.normalization.center.z], "scale": sel.normalization.scale },
        "trace": sel.trace.iter().map(|s| json!({
            "stage": s.stage, "keypoints": s.keypoints, "error": s.error
        })).collect::<Vec<_>>(),
    })
}

/// One row of a key point CSV.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct KeypointRow {
    pub source: usize,
    pub target: Option<usize>,
}

/// Writes `source,ax,ay,az` rows, or `source,target,ax,ay,az,bx,by,bz` when
/// a target mesh is given (0-based vertex indices).
pub fn write_keypoints_csv(
    path: &Path,
    rows: &[KeypointRow],
    source: &Mesh,
    target: Option<&Mesh>,
) -> Result<()> {
    let mut s = String::new();
    match target {
        None => s.push_str("source,ax,ay,az\n"),
        Some(_) => s.push_str("source,target,ax,ay,az,bx,by,bz\n"),
    }
    for r in rows {
        let a = source.vertices()[r.source];
        match (target, r.target) {
            (Some(b), Some(t)) => {
                let bp = b.vertices()[t];
                s.push_str(&format!("{},{},{},{}\n", r.source, t, xyz(&a), xyz(&bp)));
            }
            _ => s.push_str(&format!("{},{}\n", r.source, xyz(&a))),
        }
    }
    write_atomic(path, s.as_bytes())
}

/// `x,y,z`, each in the shortest form that reads back exactly (exponent
/// form for tiny values).
fn xyz(p: &deformlab::Point) -> String {
    let f = |x: f64| {
        if x != 0.0 && x.abs() < 1e-4 {
            format!("{x:e}")
        } else {
            format!("{x}")
        }
    };
    format!("{},{},{}", f(p.x), f(p.y), f(p.z))
}

/// Reads a key point CSV written by [`write_keypoints_csv`] (a header with a
/// `source` column and optionally a `target` column; 0-based indices).
pub fn read_keypoints_csv(path: &Path) -> Result<Vec<KeypointRow>> {
    let text = deformlab::mesh::io::read_input_text(path)?;
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
    let Some((_, header)) = lines.next() else {
        return Err(Error::parse(path, "header", "empty key point file"));
    };
    let cols: Vec<&str> = header.split(',').map(str::trim).collect();
    let Some(src_col) = cols.iter().position(|c| *c == "source") else {
        return Err(Error::parse(
            path,
            "header",
            "no `source` column (expected the keypoints.csv written by deformlab)",
        ));
    };
    let tgt_col = cols.iter().position(|c| *c == "target");
    let mut rows = Vec::new();
    for (i, line) in lines {
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        let parse = |c: usize| -> Result<usize> {
            let s = f.get(c).copied().unwrap_or("");
            s.parse().map_err(|_| {
                Error::parse(
                    path,
                    format!("line {}", i + 1),
                    format!("{s:?} is not a vertex index"),
                )
            })
        };
        let source = parse(src_col)?;
        let target = match tgt_col {
            Some(c) if f.get(c).is_some_and(|s| !s.is_empty()) => Some(parse(c)?),
            _ => None,
        };
        rows.push(KeypointRow { source, target });
        // The same bound as --max-keypoints: a larger set is refused before
        // anything is computed (their weights would take hours).
        if rows.len() as u64 > MaxKeypoints::MAX {
            return Err(Error::parse(
                path,
                format!("line {}", i + 1),
                format!(
                    "more than {} key points (the range of --max-keypoints); the file has                      {} key point rows",
                    MaxKeypoints::MAX,
                    text.lines()
                        .filter(|l| !l.trim().is_empty() && !l.trim_start().starts_with('#'))
                        .count()
                        - 1
                ),
            ));
        }
    }
    if rows.is_empty() {
        return Err(Error::parse(path, "file", "no key points"));
    }
    Ok(rows)
}
