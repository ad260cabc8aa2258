//! External methods: a transfer method that is a command the researcher
//! gives (kind `external`), evaluated exactly like a built-in one.
//!
//! Per case the command runs once, in the current working directory, with
//! its inputs in a fresh temporary folder. The template is split like a
//! shell command line (quotes respected, no shell run) and these
//! placeholders are replaced:
//!
//! | placeholder | value |
//! |---|---|
//! | `{source}` | A (the source at rest), an OBJ file |
//! | `{poses}` | the deformed sources A′₁ … A′ₘ (OBJ); as a whole argument, one argument per pose |
//! | `{target}` | B (the target at rest), OBJ |
//! | `{markers}` | a CSV `source,target` of key point pairs (BDT's selection on A and its target points); only computed when the template names it |
//! | `{out}` | an empty folder: the command writes `result_1.obj` … `result_m.obj` (or `.ply` / `.off`) there, B′ⱼ for A′ⱼ with B's vertices in B's order |
//! | `{n_poses}` | m |
//!
//! A command that exits with an error, outlives its `timeout`, or writes a
//! result with another vertex count than B is a failure of that case (the
//! message keeps the end of its standard error); the other cases run on.
//!
//! **Functions** (kind `callable`): a method given in-process by a host
//! program, e.g. a Python function passed to `deformlab.run(config,
//! methods={"mine": fn})`. The host registers it by name
//! ([`register_callable`]) before the config is loaded; the config names it
//! (`function = "mine"`). It gets A, A′ and B (and the key point pairs with
//! `markers = true`) and returns one vertex list per pose, evaluated like
//! every method's. The store keys results on the function's *name*: rename
//! it, or run with `--force`, when its code changes.

use std::collections::BTreeMap;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::{Arc, RwLock};
use std::time::{Duration, Instant};

use crate::mesh::io::{read_mesh, write_obj};
use crate::mesh::Mesh;
use crate::{Error, Result};

/// Default `timeout` of an external method (seconds).
pub const DEFAULT_TIMEOUT: f64 = 600.0;

/// The placeholders a command template may name.
pub const PLACEHOLDERS: [&str; 6] = ["source", "poses", "target", "markers", "out", "n_poses"];

/// A command to run per case.
#[derive(Clone, Debug, PartialEq)]
pub struct ExternalCommand {
    /// The command line as given.
    pub command: String,
    /// Its arguments (the first is the program), placeholders unreplaced.
    pub args: Vec<String>,
    /// Seconds before the command is killed and the case fails.
    pub timeout: f64,
}

impl ExternalCommand {
    /// Parses and checks a template: quotes balanced, a program, only known
    /// placeholders, `{out}` named (else nothing could be read back).
    pub fn new(command: &str, timeout: f64) -> std::result::Result<Self, String> {
        let args = split_command_line(command)?;
        if args.is_empty() {
            return Err(
                "expected a command line, e.g. \"python3 mine.py {source} {poses} {target} {out}\""
                    .into(),
            );
        }
        let mut named_out = false;
        for a in &args {
            let mut rest = a.as_str();
            while let Some(i) = rest.find('{') {
                let Some(j) = rest[i..].find('}') else {
                    return Err(format!("unclosed placeholder in {a:?}"));
                };
                let name = &rest[i + 1..i + j];
                if !PLACEHOLDERS.contains(&name) {
                    return Err(format!(
                        "unknown placeholder {{{name}}}; expected {}",
                        PLACEHOLDERS.map(|p| format!("{{{p}}}")).join(", ")
                    ));
                }
                named_out |= name == "out";
                rest = &rest[i + j + 1..];
            }
        }
        if !named_out {
            return Err(
                "the command must name {out}, the folder it writes result_1.obj … to".into(),
            );
        }
        Ok(ExternalCommand {
            command: command.to_string(),
            args,
            timeout,
        })
    }

    /// Whether the template names `{markers}` (the method then needs key
    /// point pairs).
    pub fn uses_markers(&self) -> bool {
        self.args.iter().any(|a| a.contains("{markers}"))
    }

    /// Runs the command for A → A′ⱼ onto B (with the key point pairs when it
    /// names `{markers}`) and reads back one B′ per pose.
    pub fn run(
        &self,
        a: &Mesh,
        a_def: &[Mesh],
        b: &Mesh,
        markers: Option<&[(usize, usize)]>,
    ) -> Result<Vec<Mesh>> {
        let dir = WorkDir::new()?;
        let io = |e: std::io::Error, p: &Path| {
            Error::invalid(format!("external method: {}: {e}", p.display()))
        };
        let source = dir.path.join("source.obj");
        write_obj(&source, a)?;
        let mut poses = Vec::new();
        for (j, m) in a_def.iter().enumerate() {
            let p = dir.path.join(format!("pose_{}.obj", j + 1));
            write_obj(&p, m)?;
            poses.push(p.display().to_string());
        }
        let target = dir.path.join("target.obj");
        write_obj(&target, b)?;
        let marker_file = dir.path.join("markers.csv");
        if let Some(pairs) = markers {
            let mut text = String::from("source,target\n");
            for (s, t) in pairs {
                text.push_str(&format!("{s},{t}\n"));
            }
            std::fs::write(&marker_file, text).map_err(|e| io(e, &marker_file))?;
        }
        let out = dir.path.join("out");
        std::fs::create_dir(&out).map_err(|e| io(e, &out))?;
        let value = |name: &str| -> String {
            match name {
                "source" => source.display().to_string(),
                "poses" => poses.join(","),
                "target" => target.display().to_string(),
                "markers" => marker_file.display().to_string(),
                "out" => out.display().to_string(),
                _ => a_def.len().to_string(),
            }
        };
        let mut argv: Vec<String> = Vec::new();
        for a in &self.args {
            if a == "{poses}" {
                argv.extend(poses.iter().cloned());
                continue;
            }
            let mut s = a.clone();
            for p in PLACEHOLDERS {
                s = s.replace(&format!("{{{p}}}"), &value(p));
            }
            argv.push(s);
        }
        let stderr_path = dir.path.join("stderr.txt");
        let stderr = std::fs::File::create(&stderr_path).map_err(|e| io(e, &stderr_path))?;
        let mut child = Command::new(&argv[0])
            .args(&argv[1..])
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(stderr)
            .spawn()
            .map_err(|e| {
                Error::invalid(format!(
                    "external method: cannot start {:?} ({e}); command: {}",
                    argv[0], self.command
                ))
            })?;
        let start = Instant::now();
        let status = loop {
            match child.try_wait() {
                Ok(Some(s)) => break s,
                Ok(None) => {
                    if start.elapsed().as_secs_f64() > self.timeout {
                        let _ = child.kill();
                        let _ = child.wait();
                        return Err(Error::invalid(format!(
                            "external method: killed after its timeout of {} s; command: {}{}",
                            self.timeout,
                            self.command,
                            stderr_tail(&stderr_path)
                        )));
                    }
                    std::thread::sleep(Duration::from_millis(10));
                }
                Err(e) => {
                    return Err(Error::invalid(format!(
                        "external method: waiting for {:?}: {e}",
                        argv[0]
                    )))
                }
            }
        };
        if !status.success() {
            return Err(Error::invalid(format!(
                "external method: the command failed ({status}); command: {}{}",
                self.command,
                stderr_tail(&stderr_path)
            )));
        }
        let mut meshes = Vec::with_capacity(a_def.len());
        for j in 1..=a_def.len() {
            let found = ["obj", "ply", "off"]
                .iter()
                .map(|x| out.join(format!("result_{j}.{x}")))
                .find(|p| p.is_file())
                .ok_or_else(|| {
                    Error::invalid(format!(
                        "external method: wrote no result_{j}.obj (or .ply / .off) for pose {j}; \
                         command: {}{}",
                        self.command,
                        stderr_tail(&stderr_path)
                    ))
                })?;
            let v = result_vertices(&found)
                .map_err(|e| Error::invalid(format!("external method: result_{j}: {e}")))?;
            if v.len() != b.n_vertices() {
                return Err(Error::invalid(format!(
                    "external method: result_{j} has {} vertices, the target {}: a result keeps \
                     the target's vertices in its order; command: {}",
                    v.len(),
                    b.n_vertices(),
                    self.command
                )));
            }
            meshes.push(b.with_vertices(v)?);
        }
        Ok(meshes)
    }
}

/// The vertices of a result file: the `v` lines of an OBJ (faces
/// optional: B's are used), else any mesh format the library reads.
fn result_vertices(path: &Path) -> Result<Vec<crate::Point>> {
    if path.extension().is_some_and(|x| x == "obj") {
        let text = std::fs::read_to_string(path)
            .map_err(|e| Error::invalid(format!("{}: {e}", path.display())))?;
        let mut v = Vec::new();
        for (i, line) in text.lines().enumerate() {
            let mut w = line.split_whitespace();
            if w.next() != Some("v") {
                continue;
            }
            let xyz: Vec<f64> = w.take(3).filter_map(|t| t.parse().ok()).collect();
            if xyz.len() != 3 || xyz.iter().any(|x| !x.is_finite()) {
                return Err(Error::invalid(format!(
                    "{} line {}: expected `v x y z` with three finite numbers, got {line:?}",
                    path.display(),
                    i + 1
                )));
            }
            v.push(crate::Point::new(xyz[0], xyz[1], xyz[2]));
        }
        Ok(v)
    } else {
        Ok(read_mesh(path)?.vertices().to_vec())
    }
}

/// What a registered function gets for one case.
#[derive(Clone, Copy, Debug)]
pub struct CallInput<'a> {
    pub a: &'a Mesh,
    pub a_def: &'a [Mesh],
    pub b: &'a Mesh,
    /// The key point pairs `(source vertex, target vertex)` (`markers = true`).
    pub markers: Option<&'a [(usize, usize)]>,
}

/// A method as a function: one vertex list per pose, B's vertices in order.
pub type CallableFn = dyn Fn(&CallInput) -> Result<Vec<Vec<crate::Point>>> + Send + Sync;

/// A registered function, by name.
#[derive(Clone)]
pub struct Callable {
    pub name: String,
    pub f: Arc<CallableFn>,
}

impl std::fmt::Debug for Callable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Callable({})", self.name)
    }
}

/// Two callables are the same method when their names are.
impl PartialEq for Callable {
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
    }
}

impl Callable {
    /// Runs the function and checks what it returned.
    pub fn run(&self, input: &CallInput) -> Result<Vec<Mesh>> {
        let out = (self.f)(input)
            .map_err(|e| Error::invalid(format!("function {:?}: {e}", self.name)))?;
        if out.len() != input.a_def.len() {
            return Err(Error::invalid(format!(
                "function {:?} returned {} meshes for {} poses; return one B′ per pose",
                self.name,
                out.len(),
                input.a_def.len()
            )));
        }
        out.into_iter()
            .enumerate()
            .map(|(j, v)| {
                if v.len() != input.b.n_vertices() {
                    return Err(Error::invalid(format!(
                        "function {:?}: B′ for pose {} has {} vertices, the target {}",
                        self.name,
                        j + 1,
                        v.len(),
                        input.b.n_vertices()
                    )));
                }
                if v.iter().any(|p| !p.coords.iter().all(|x| x.is_finite())) {
                    return Err(Error::invalid(format!(
                        "function {:?}: B′ for pose {} has non-finite coordinates",
                        self.name,
                        j + 1
                    )));
                }
                input.b.with_vertices(v)
            })
            .collect()
    }
}

fn callables() -> &'static RwLock<BTreeMap<String, Callable>> {
    static REGISTRY: std::sync::OnceLock<RwLock<BTreeMap<String, Callable>>> =
        std::sync::OnceLock::new();
    REGISTRY.get_or_init(|| RwLock::new(BTreeMap::new()))
}

/// Registers `f` as the function `name` of `kind = "callable"` methods
/// (replacing a function of that name).
pub fn register_callable(name: &str, f: Arc<CallableFn>) {
    if let Ok(mut m) = callables().write() {
        m.insert(
            name.to_string(),
            Callable {
                name: name.to_string(),
                f,
            },
        );
    }
}

/// Removes the function `name`.
pub fn unregister_callable(name: &str) {
    if let Ok(mut m) = callables().write() {
        m.remove(name);
    }
}

/// The registered function `name`.
pub fn callable(name: &str) -> std::result::Result<Callable, String> {
    let m = callables()
        .read()
        .map_err(|_| "the function registry is poisoned".to_string())?;
    m.get(name).cloned().ok_or_else(|| {
        let known: Vec<&str> = m.keys().map(String::as_str).collect();
        format!(
            "no function {name:?} is registered (functions run from a host program, e.g. \
             Python: deformlab.run(config, methods={{{name:?}: fn}}){}",
            if known.is_empty() {
                ")".to_string()
            } else {
                format!("; registered: {})", known.join(", "))
            }
        )
    })
}

/// How an external method computes: a command, or a registered function.
#[derive(Clone, Debug, PartialEq)]
pub enum ExternalRunner {
    Command(ExternalCommand),
    Function(Callable),
}

impl ExternalRunner {
    /// The kind's name.
    pub fn kind_name(&self) -> &'static str {
        match self {
            ExternalRunner::Command(_) => "external",
            ExternalRunner::Function(_) => "callable",
        }
    }

    /// B′ per pose of A → A′ onto B.
    pub fn run(
        &self,
        a: &Mesh,
        a_def: &[Mesh],
        b: &Mesh,
        markers: Option<&[(usize, usize)]>,
    ) -> Result<Vec<Mesh>> {
        match self {
            ExternalRunner::Command(c) => c.run(a, a_def, b, markers),
            ExternalRunner::Function(f) => f.run(&CallInput {
                a,
                a_def,
                b,
                markers,
            }),
        }
    }
}

/// The last lines of the command's standard error, for a message.
fn stderr_tail(path: &Path) -> String {
    let mut text = String::new();
    if let Ok(mut f) = std::fs::File::open(path) {
        let _ = f.read_to_string(&mut text);
    }
    let lines: Vec<&str> = text.lines().collect();
    let tail = &lines[lines.len().saturating_sub(20)..];
    if tail.is_empty() {
        String::new()
    } else {
        format!("; its standard error ends:\n{}", tail.join("\n"))
    }
}

/// Splits a command line like a POSIX shell would split words: blanks
/// separate, single quotes keep everything, double quotes keep all but
/// `\"` and `\\`, a backslash outside quotes escapes the next character.
pub fn split_command_line(s: &str) -> std::result::Result<Vec<String>, String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut in_word = false;
    let mut chars = s.chars();
    while let Some(c) = chars.next() {
        match c {
            ' ' | '\t' | '\n' => {
                if in_word {
                    out.push(std::mem::take(&mut cur));
                    in_word = false;
                }
            }
            '\'' => {
                in_word = true;
                loop {
                    match chars.next() {
                        Some('\'') => break,
                        Some(c) => cur.push(c),
                        None => return Err("unbalanced ' in the command".into()),
                    }
                }
            }
            '"' => {
                in_word = true;
                loop {
                    match chars.next() {
                        Some('"') => break,
                        Some('\\') => match chars.next() {
                            Some(c @ ('"' | '\\')) => cur.push(c),
                            Some(c) => {
                                cur.push('\\');
                                cur.push(c);
                            }
                            None => return Err("unbalanced \" in the command".into()),
                        },
                        Some(c) => cur.push(c),
                        None => return Err("unbalanced \" in the command".into()),
                    }
                }
            }
            '\\' => {
                in_word = true;
                match chars.next() {
                    Some(c) => cur.push(c),
                    None => return Err("a trailing \\ in the command".into()),
                }
            }
            c => {
                in_word = true;
                cur.push(c);
            }
        }
    }
    if in_word {
        out.push(cur);
    }
    Ok(out)
}

/// A fresh temporary folder, removed when dropped.
struct WorkDir {
    path: PathBuf,
}

impl WorkDir {
    fn new() -> Result<Self> {
        use std::sync::atomic::{AtomicU64, Ordering};
        static NEXT: AtomicU64 = AtomicU64::new(0);
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        let path = std::env::temp_dir().join(format!(
            "deformlab-external-{}-{n}-{}",
            std::process::id(),
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map(|d| d.subsec_nanos())
                .unwrap_or(0)
        ));
        // create_dir (not _all): fails if the name exists, never reuses a folder.
        std::fs::create_dir(&path).map_err(|e| {
            Error::invalid(format!(
                "external method: cannot create {}: {e}",
                path.display()
            ))
        })?;
        Ok(WorkDir { path })
    }
}

impl Drop for WorkDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.path);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn command_lines_split_like_a_shell() {
        assert_eq!(
            split_command_line(r#"python3 "my method.py" --x 'a b' c\ d {out}"#).unwrap(),
            ["python3", "my method.py", "--x", "a b", "c d", "{out}"]
        );
        assert!(split_command_line("echo 'oops").is_err());
        assert!(ExternalCommand::new("mine {out}", 1.0).is_ok());
        assert!(ExternalCommand::new("mine {source}", 1.0)
            .unwrap_err()
            .contains("{out}"));
        assert!(ExternalCommand::new("mine {outt}", 1.0)
            .unwrap_err()
            .contains("unknown placeholder"));
        assert!(ExternalCommand::new("mine {markers} {out}", 1.0)
            .unwrap()
            .uses_markers());
    }
}
