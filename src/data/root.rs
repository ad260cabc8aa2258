//! The data root: where the real meshes live, so that a config can name a
//! dataset independently of the checkout it sits in.
//!
//! A dataset path that starts with `@data` (`path = "@data/faust"` in an
//! experiment config, `file = "@data/sumner/cat-lion/cat-01.obj"` in a
//! dataset manifest) is relative to the data root; any other relative path
//! is relative to the file that names it, as before. The root is, first
//! found:
//!
//! 1. `deformlab run --data-root DIR`;
//! 2. the environment variable `DEFORMLAB_DATA` ([`DATA_ROOT_ENV`]);
//! 3. `DEFORMLAB_SHARED_DATA` (its former name, still read);
//! 4. `../shared/data` from the working directory ([`DEFAULT_DATA_ROOT`]:
//!    the development data beside a checkout, when commands and tests run
//!    from the repository root).
//!
//! Tests and benchmarks find the real meshes the same way
//! ([`super::shared_data_dir`]).

use std::path::{Component, Path, PathBuf};

/// The environment variable naming the data root.
pub const DATA_ROOT_ENV: &str = "DEFORMLAB_DATA";
/// The former name of [`DATA_ROOT_ENV`], read when that one is not set.
pub const LEGACY_DATA_ROOT_ENV: &str = "DEFORMLAB_SHARED_DATA";
/// The data root when neither the flag nor the environment names one,
/// relative to the working directory.
pub const DEFAULT_DATA_ROOT: &str = "../shared/data";
/// The first component of a path relative to the data root.
pub const DATA_PREFIX: &str = "@data";

/// Where the data root was taken from (for messages).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum RootSource {
    /// `--data-root`.
    Flag,
    /// An environment variable (its name).
    Env(&'static str),
    /// [`DEFAULT_DATA_ROOT`].
    Default,
}

/// The data root and where it came from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DataRoot {
    pub dir: PathBuf,
    pub source: RootSource,
}

impl Default for DataRoot {
    /// The root from the environment (or the default).
    fn default() -> Self {
        DataRoot::from_env(None)
    }
}

impl DataRoot {
    /// The root: `flag` if given, else the environment, else the default
    /// (see the module documentation).
    pub fn from_env(flag: Option<&Path>) -> DataRoot {
        if let Some(f) = flag {
            return DataRoot {
                dir: f.to_path_buf(),
                source: RootSource::Flag,
            };
        }
        for var in [DATA_ROOT_ENV, LEGACY_DATA_ROOT_ENV] {
            if let Some(d) = std::env::var_os(var).filter(|d| !d.is_empty()) {
                return DataRoot {
                    dir: PathBuf::from(d),
                    source: RootSource::Env(var),
                };
            }
        }
        DataRoot {
            dir: PathBuf::from(DEFAULT_DATA_ROOT),
            source: RootSource::Default,
        }
    }

    /// A root given explicitly (as `--data-root` would).
    pub fn at(dir: impl Into<PathBuf>) -> DataRoot {
        DataRoot {
            dir: dir.into(),
            source: RootSource::Flag,
        }
    }

    /// Where the root came from and how to set it, for error messages.
    pub fn describe(&self) -> String {
        let from = match &self.source {
            RootSource::Flag => "from --data-root".to_string(),
            RootSource::Env(v) => format!("from the environment variable {v}"),
            RootSource::Default => format!(
                "the default, from the working directory {}: neither --data-root nor \
                 {DATA_ROOT_ENV} is set",
                std::env::current_dir()
                    .map(|d| d.display().to_string())
                    .unwrap_or_else(|_| "(unknown)".into())
            ),
        };
        format!(
            "data root {} ({from}); set it with `deformlab run --data-root DIR` or \
             {DATA_ROOT_ENV}=DIR",
            self.dir.display()
        )
    }

    /// `p` without its `@data` component, when it has one (`@data` alone:
    /// the empty path).
    pub fn relative_part(p: &Path) -> Option<PathBuf> {
        let mut c = p.components();
        match c.next() {
            Some(Component::Normal(first)) if first == DATA_PREFIX => Some(c.as_path().into()),
            _ => None,
        }
    }

    /// Whether `p` is relative to the data root (`@data/...`).
    pub fn names(p: &Path) -> bool {
        Self::relative_part(p).is_some()
    }

    /// `p` resolved: `@data/...` against the root, a relative path against
    /// `base` (the folder of the file naming it), an absolute path as is.
    pub fn resolve(&self, p: &Path, base: &Path) -> PathBuf {
        match Self::relative_part(p) {
            Some(rel) if rel.as_os_str().is_empty() => self.dir.clone(),
            Some(rel) => self.dir.join(rel),
            None => base.join(p),
        }
    }

    /// The sentence an error about a missing `p` (as written) adds: for a
    /// path under the root, where the root came from and how to set it.
    pub fn hint(&self, p: &Path) -> String {
        if Self::names(p) {
            format!(" ({})", self.describe())
        } else {
            String::new()
        }
    }

    /// `path` (resolved) as `@data/...` when it lies in the root (compared
    /// after resolving symbolic links), else `None`.
    pub fn spell(&self, path: &Path) -> Option<String> {
        let root = std::fs::canonicalize(&self.dir).ok()?;
        let full = std::fs::canonicalize(path).ok()?;
        let rel = full.strip_prefix(&root).ok()?;
        let rel = rel.to_string_lossy().replace('\\', "/");
        Some(if rel.is_empty() {
            DATA_PREFIX.to_string()
        } else {
            format!("{DATA_PREFIX}/{rel}")
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn data_paths_resolve_against_the_root_others_against_the_base() {
        let r = DataRoot::at("/data");
        let base = Path::new("/cfg");
        assert_eq!(
            r.resolve(Path::new("@data/faust"), base),
            Path::new("/data/faust")
        );
        assert_eq!(r.resolve(Path::new("@data"), base), Path::new("/data"));
        assert_eq!(r.resolve(Path::new("faust"), base), Path::new("/cfg/faust"));
        assert_eq!(r.resolve(Path::new("/x/y"), base), Path::new("/x/y"));
        assert!(!DataRoot::names(Path::new("@database/x")));
        assert!(r.hint(Path::new("@data/x")).contains("--data-root"));
        assert!(r.hint(Path::new("x")).is_empty());
    }
}
