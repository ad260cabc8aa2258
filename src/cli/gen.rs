//! `deformlab gen`: the synthetic FAUST-style / TOSCA-style / remeshed set.

use std::path::Path;
use std::process::ExitCode;
use std::time::Instant;

use deformlab::data::synthetic::{write_all, FaustStyle};
use deformlab::{Error, Result};

pub struct GenArgs<'a> {
    pub out: &'a Path,
    pub seed: u64,
    pub subjects: usize,
    pub poses: usize,
    pub resolution: u32,
    pub no_tail: bool,
    pub force: bool,
}

pub fn run(a: GenArgs<'_>) -> Result<ExitCode> {
    let _progress = super::progress::for_command("gen");
    // Never overwrite a finished set silently.
    if a.out.join("faust").exists() && !a.force {
        return Err(Error::invalid(format!(
            "{} already holds a generated set (faust/ exists); pass --force to overwrite it",
            a.out.display()
        )));
    }
    let cfg = FaustStyle {
        subjects: a.subjects,
        poses: a.poses,
        seed: a.seed,
        resolution: a.resolution,
        tail: !a.no_tail,
        ..FaustStyle::default()
    };
    let t = Instant::now();
    let s = write_all(a.out, &cfg)?;
    println!(
        "wrote {} meshes ({} vertices, {} faces each) to {}/faust, the TOSCA-style class to {}/tosca \
         and a remeshed subject ({} vertices, {} faces) to {}/remesh in {:.2} s (seed {})",
        s.n_meshes,
        s.n_vertices,
        s.n_faces,
        a.out.display(),
        a.out.display(),
        s.remesh_vertices,
        s.remesh_faces,
        a.out.display(),
        t.elapsed().as_secs_f64(),
        a.seed
    );
    Ok(ExitCode::SUCCESS)
}
