//! `deformlab inspect`: defect tables and a set summary. Exits with 1 when
//! a file cannot be read, is empty (no faces) or cannot be used (indices
//! out of range, NaN/inf coordinates), so scripts can rely on the status.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use deformlab::mesh::io::{read_raw, Format};
use deformlab::mesh::set::ConnectivityReport;
use deformlab::mesh::validate::{flattened, DefectReport};
use deformlab::{Error, Mesh, Result};

/// Expands folders into the mesh files they hold (sorted); files are kept as
/// given. A `.tri` beside a `.vert` is not listed twice. Entries named like
/// meshes that are not regular files (a FIFO, a device, a folder) are
/// listed too, so they are reported as unreadable rather than skipped.
fn expand(paths: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for p in paths {
        // The system's own reason when the path cannot be used (a loop of
        // symbolic links, no permission), not "no such file" for all.
        let meta = std::fs::metadata(p).map_err(|e| Error::io(p, e))?;
        if meta.is_dir() {
            let mut files: Vec<PathBuf> = std::fs::read_dir(p)
                .map_err(|e| Error::io(p, e))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|f| {
                    Format::of_path(f).is_some()
                        && f.extension().and_then(|e| e.to_str()) != Some("tri")
                })
                .collect();
            files.sort();
            out.extend(files);
        } else {
            out.push(p.clone());
        }
    }
    Ok(out)
}

pub fn run(paths: &[PathBuf], brief: bool) -> Result<ExitCode> {
    let files = expand(paths)?;
    let mut failed = 0usize;
    let mut unusable = 0usize;
    let mut loaded: Vec<(PathBuf, Mesh)> = Vec::new();
    let mut clean = 0usize;
    for path in &files {
        match read_raw(path) {
            Err(e) => {
                failed += 1;
                println!("{}: UNREADABLE: {e}", path.display());
            }
            Ok(raw) => {
                let report = DefectReport::of(&raw);
                if brief {
                    println!("{}: {}", path.display(), report.summary());
                } else {
                    println!("== {}", path.display());
                    print!("{report}");
                }
                // Empty or unusable input: no command can compute on it.
                let refusal = if report.n_faces == 0 {
                    Some(format!(
                        "EMPTY: no faces ({} vertices); no command can use it",
                        report.n_vertices
                    ))
                } else if !report.is_loadable() {
                    Some(format!(
                        "UNUSABLE: {} faces with an index out of range, {} vertices with NaN/inf; \
                         no command can use it",
                        report.out_of_range_faces.count, report.non_finite_vertices.count
                    ))
                } else {
                    None
                };
                let mesh = match refusal {
                    Some(why) => Err(why),
                    None => match Mesh::try_from(raw) {
                        Ok(m) => match flattened(&m, &report) {
                            Some(why) => Err(format!("UNUSABLE: {why}; no command can use it")),
                            None => Ok(Some(m)),
                        },
                        Err(_) => Ok(None),
                    },
                };
                match mesh {
                    Err(why) => {
                        unusable += 1;
                        println!("{}: {why}", path.display());
                    }
                    Ok(Some(m)) => {
                        // An open surface is clean: its boundary is no defect.
                        clean += usize::from(report.is_clean_ignoring_boundary());
                        loaded.push((path.clone(), m));
                    }
                    Ok(None) => {}
                }
                if !brief {
                    println!();
                }
            }
        }
    }
    print_set_summary(&loaded, files.len(), failed, unusable, clean, brief);
    Ok(if failed + unusable == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

/// Groups meshes by vertex count (only meshes of equal size can share
/// connectivity) and compares connectivity within each group against its
/// first member.
fn print_set_summary(
    loaded: &[(PathBuf, Mesh)],
    n_files: usize,
    failed: usize,
    unusable: usize,
    clean: usize,
    brief: bool,
) {
    println!(
        "== set summary: {n_files} file(s), {} loaded, {failed} unreadable, {unusable} empty or \
         unusable; {clean} without any defect, {} with defects",
        loaded.len(),
        n_files - failed - clean
    );
    let mut groups: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for (i, (_, m)) in loaded.iter().enumerate() {
        groups.entry(m.n_vertices()).or_default().push(i);
    }
    for (nv, members) in groups {
        let names: Vec<String> = members
            .iter()
            .enumerate()
            .map(|(k, &i)| format!("[{k}] {}", short(&loaded[i].0)))
            .collect();
        if members.len() == 1 {
            println!("-- {nv} vertices: {} (alone)", names[0]);
            continue;
        }
        let meshes: Vec<Mesh> = members.iter().map(|&i| loaded[i].1.clone()).collect();
        let report = ConnectivityReport::of(&meshes);
        println!("-- {nv} vertices: {}", names.join(" "));
        let text = report.to_string();
        let shown = if brief { 1 } else { usize::MAX };
        for line in text.lines().take(shown) {
            println!("   {line}");
        }
    }
}

fn short(p: &Path) -> String {
    p.file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_else(|| p.display().to_string())
}
