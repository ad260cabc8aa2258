//! Loading a config for a run: the TOML file, then the command line's
//! overrides (`--set KEY=VALUE`) and sweeps (`--sweep KEY=V1,V2,...`, and
//! the file's own `[sweep]`, expanded into methods by [`super::sweep`]),
//! with dataset paths resolved through the data root
//! ([`crate::data::root`]).

use std::path::{Path, PathBuf};

use super::config::{check_dataset, check_outputs, parse_unchecked_in, LoadedConfig};
use crate::data::DataRoot;
use crate::Result;

/// How configs are loaded (`deformlab run` flags). The default: the data
/// root of the environment, no override, no sweep beyond the file's own.
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// `--data-root DIR` (else `DEFORMLAB_DATA`, else the default; see
    /// [`DataRoot::from_env`]).
    pub data_root: Option<PathBuf>,
    /// `--set KEY=VALUE`, in order (applied before the sweep).
    pub set: Vec<String>,
    /// `--sweep KEY=V1,V2,...`: axes added to every grid of the sweep.
    pub sweep: Vec<String>,
}

impl LoadOptions {
    /// The data root these options give.
    pub fn root(&self) -> DataRoot {
        DataRoot::from_env(self.data_root.as_deref())
    }
}

/// Reads and parses a config file (schema, values and dataset paths), its
/// `[sweep]` expanded, with the data root of the environment.
pub fn load_config(path: &Path) -> Result<LoadedConfig> {
    load_config_with(path, &LoadOptions::default())
}

/// Parses a config text (`path` is used in messages and to resolve relative
/// dataset paths).
pub fn parse_config(text: &str, path: &Path) -> Result<LoadedConfig> {
    parse_config_with(text, path, &LoadOptions::default())
}

/// [`load_config`] with overrides, sweeps and a data root.
pub fn load_config_with(path: &Path, o: &LoadOptions) -> Result<LoadedConfig> {
    let text = crate::mesh::io::read_input_text(path)?;
    parse_config_with(&text, path, o)
}

/// [`parse_config`] with overrides, sweeps and a data root.
pub fn parse_config_with(text: &str, path: &Path, o: &LoadOptions) -> Result<LoadedConfig> {
    let loaded = parse(text, path, o)?;
    loaded.check_paths()?;
    Ok(loaded)
}

/// Reads a config file and checks its schema and values, but not whether
/// its dataset paths exist: for checking configs whose data is elsewhere
/// (e.g. `experiments/real/` without a data root). A run needs
/// [`load_config`].
pub fn load_config_schema(path: &Path) -> Result<LoadedConfig> {
    let text = crate::mesh::io::read_input_text(path)?;
    parse_config_schema(&text, path)
}

/// [`parse_config`] without the dataset path check.
pub fn parse_config_schema(text: &str, path: &Path) -> Result<LoadedConfig> {
    parse(text, path, &LoadOptions::default())
}

fn parse(text: &str, path: &Path, o: &LoadOptions) -> Result<LoadedConfig> {
    let base = parse_unchecked_in(text, path, &o.root())?;
    let loaded = super::sweep::vary(base, text, &o.set, &o.sweep)?;
    check_dataset(&loaded)?;
    check_outputs(&loaded)?;
    Ok(loaded)
}
