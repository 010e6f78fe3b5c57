//! `penumbra shaders export -o DIR`: the runtime's WGSL shaders and their naga translations
//! (SPIR-V, HLSL, GLSL, MSL), with a README of bindings and layouts (issue #20).

use crate::commands::print_json;
use crate::exit::{CliError, ExitCode};
use anyhow::{Context, anyhow};
use clap::{Args, Subcommand};
use serde_json::json;
use std::path::PathBuf;

/// `penumbra shaders`.
#[derive(Debug, Args)]
pub struct ShadersArgs {
    /// What to do.
    #[command(subcommand)]
    pub command: ShadersCommand,
}

/// Subcommands of `penumbra shaders`.
#[derive(Debug, Subcommand)]
pub enum ShadersCommand {
    /// Write every shader as .wgsl, .spv, .hlsl, .msl and one .glsl per entry point.
    Export(ShadersExportArgs),
}

/// `penumbra shaders export`.
#[derive(Debug, Args)]
pub struct ShadersExportArgs {
    /// Output directory (created; existing files of the same names are replaced).
    #[arg(short = 'o', long)]
    pub output: PathBuf,
    /// One JSON object on stdout (the files written).
    #[arg(long)]
    pub json: bool,
}

/// The README written next to the shaders.
pub const README: &str = include_str!("../../../gpu/shaders/README.md");

/// Runs `penumbra shaders …`.
#[allow(clippy::print_stderr)]
pub fn run(a: &ShadersArgs) -> Result<ExitCode, CliError> {
    let ShadersCommand::Export(e) = &a.command;
    // translate everything before writing anything
    let mut files = vec![("README.md".to_string(), README.as_bytes().to_vec())];
    for s in penumbra_gpu::SHADERS {
        for f in penumbra_gpu::export::translate(s).map_err(|err| CliError::internal(anyhow!("{err}")))? {
            files.push((f.name, f.bytes));
        }
    }
    std::fs::create_dir_all(&e.output).with_context(|| format!("cannot create {}", e.output.display()))?;
    let mut written = Vec::new();
    for (name, bytes) in &files {
        let p = e.output.join(name);
        crate::fsutil::write_atomic(&p, bytes).with_context(|| format!("cannot write {}", p.display()))?;
        written.push(json!({"file": name, "bytes": bytes.len()}));
    }
    if e.json {
        print_json(&json!({"output": e.output.display().to_string(), "files": written}));
    } else {
        eprintln!("wrote {} files to {}", files.len(), e.output.display());
    }
    Ok(ExitCode::Ok)
}
