//! The paper's covariance analysis in two configurations: the literal reading of the paper and the
//! reconciled one (see `docs/paper-check.md`).

use crate::config::{ConfigError, RunConfig};

/// The reconciled configuration of the paper's covariance analysis, embedded.
pub const PAPER_RECONCILED_TOML: &str = include_str!("../configs/paper-reconciled.toml");

/// The literal reading of the paper (`configs/paper.toml`).
pub fn literal() -> RunConfig {
    RunConfig::paper()
}

/// The reconciled configuration (`configs/paper-reconciled.toml`).
pub fn reconciled() -> RunConfig {
    RunConfig::from_toml_str(PAPER_RECONCILED_TOML, "<embedded paper-reconciled config>")
        .expect("embedded configuration is valid")
}

/// Read a configuration by name (`paper`, `paper-reconciled`) or path.
pub fn named_or_file(name: &str) -> Result<RunConfig, ConfigError> {
    match name {
        "paper" => Ok(literal()),
        "paper-reconciled" => Ok(reconciled()),
        path => {
            let p = std::path::Path::new(path);
            // A name that is no file and no built-in configuration: say which names exist.
            if !p.exists() && !path.contains(['/', '\\', '.']) {
                return Err(ConfigError::Invalid {
                    origin: path.to_string(),
                    message: "no such file and no built-in configuration of that name: the \
                              built-in configurations are `paper` and `paper-reconciled`"
                        .into(),
                });
            }
            RunConfig::from_file(p)
        }
    }
}
