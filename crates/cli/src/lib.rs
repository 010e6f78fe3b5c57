//! The `penumbra` command line: argument parsing, config → parameters, progress,
//! reports and exit codes (DESIGN §2). Libraries never print; this crate owns stdout
//! (JSON with `--json`) and stderr (human text, progress).
//!
//! Exit codes: 0 success; 1 a requested quality gate failed; 2 bad usage, config or input
//! (the message names the file and the problem); 101 internal bug (a panic).

pub mod args;
pub mod commands;
pub mod env_light;
pub mod exit;
pub mod figure;
pub mod fsutil;
pub mod png;
pub mod progress;
pub mod svgplot;

pub use exit::{CliError, ExitCode};
