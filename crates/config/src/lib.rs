//! penumbra-config: the TOML bake configuration (`penumbra bake <config.toml>`).
//!
//! - Types with `deny_unknown_fields`: a misspelt key is an error, never ignored.
//! - Every error names the file, the key path (e.g. `tables.order`) and the line.
//! - [`schema_json`] generates the JSON Schema committed as `schemas/bake-config.schema.json`.
//!
//! Paths inside a config are relative to the directory of the config file.

pub mod clutter;
mod error;
pub mod gate;
pub mod level;
mod types;
mod validate;

pub use error::{ConfigError, ConfigErrorKind};
pub use gate::{FivGate, RelErrorGate, VoGate};
pub use level::{LevelFile, level_schema_json, load_level};
pub use types::{
    BakeConfig, DrtStage, EnvRotate, FivStage, MrtLevelStage, MrtStage, NodeSelect, SphereMethod, SpheresStage,
    TablesStage, UpAxis, VoStage,
};
pub use validate::{Issue, validate};

use std::path::{Path, PathBuf};

/// A parsed and validated configuration with its location.
#[derive(Debug, Clone)]
pub struct LoadedConfig {
    /// The configuration.
    pub config: BakeConfig,
    /// The config file path as given.
    pub path: PathBuf,
    /// Directory that relative paths in the config are resolved against.
    pub base_dir: PathBuf,
    /// The raw text (for content hashing of the stage parameters).
    pub source: String,
}

impl LoadedConfig {
    /// Resolves a path from the config relative to the config's directory.
    pub fn resolve(&self, p: &str) -> PathBuf {
        let p = Path::new(p);
        if p.is_absolute() { p.to_path_buf() } else { self.base_dir.join(p) }
    }

    /// The output directory, resolved.
    pub fn output_dir(&self) -> PathBuf {
        self.resolve(&self.config.output_dir)
    }
}

/// Reads, parses and validates a config file.
pub fn load(path: &Path) -> Result<LoadedConfig, ConfigError> {
    let source = std::fs::read_to_string(path).map_err(|e| ConfigError::io(path, e))?;
    let config = parse_str(&source, path)?;
    let base_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let base_dir = if base_dir.as_os_str().is_empty() { PathBuf::from(".") } else { base_dir };
    Ok(LoadedConfig { config, path: path.to_path_buf(), base_dir, source })
}

/// Parses and validates config text; `path` is only used in messages.
pub fn parse_str(source: &str, path: &Path) -> Result<BakeConfig, ConfigError> {
    let de = toml::de::Deserializer::parse(source).map_err(|e| ConfigError::syntax(path, source, &e))?;
    let config: BakeConfig = serde_path_to_error::deserialize(de).map_err(|e| {
        let key = e.path().to_string();
        let inner = e.into_inner();
        ConfigError::field(path, source, key, &inner)
    })?;
    let issues = validate(&config);
    if let Some(first) = issues.first() {
        return Err(ConfigError::invalid(path, source, first, issues.len()));
    }
    Ok(config)
}

/// The JSON Schema of the bake configuration, pretty-printed with a trailing newline.
pub fn schema_json() -> String {
    let schema = schemars::schema_for!(BakeConfig);
    let mut s = serde_json::to_string_pretty(&schema).unwrap_or_else(|_| String::from("{}"));
    s.push('\n');
    s
}
