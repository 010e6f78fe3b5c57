//! Command implementations.

pub mod bake;
pub mod bake_cache;
pub mod bake_merge;
pub mod drt;
pub mod drt_target;
pub mod fiv;
pub mod fiv_target;
pub mod floor_view;
pub mod gate;
pub mod inspect;
pub mod mrt;
pub mod mrt_level;
pub mod plan;
pub mod plan_level;
pub mod shaders;
pub mod spheres;
pub mod sweep;
pub mod sweep_drt;
pub mod sweep_fiv;
pub mod sweep_mrt;
pub mod sweep_shadows;
pub mod sweep_spheres;
pub mod sweep_tables;
pub mod tables;
pub mod target;
pub mod verify_drt;
pub mod verify_drt_vector;
pub mod verify_fiv;
pub mod verify_gpu;
pub mod verify_mrt;
pub mod verify_mrt_vector;
pub mod verify_shadows;
pub mod verify_vo;
pub mod vo;

use crate::args::{Cli, Command};
use crate::exit::{CliError, ExitCode};

/// Runs a parsed command line.
pub fn run(cli: Cli) -> Result<ExitCode, CliError> {
    if let Some(n) = cli.threads {
        rayon::ThreadPoolBuilder::new().num_threads(n as usize).build_global().map_err(CliError::internal)?;
    }
    match cli.command {
        Command::Tables(a) => tables::run(&a, cli.progress),
        Command::Spheres(a) => spheres::run(&a, cli.progress),
        Command::Mrt(a) => mrt::run(&a, cli.progress),
        Command::Inspect(a) => inspect::run(&a),
        Command::Bake(a) => bake::run(&a, cli.progress),
        Command::Fiv(a) => fiv::run(&a, cli.progress),
        Command::Drt(a) => drt::run(&a, cli.progress),
        Command::Vo(a) => vo::run(&a, cli.progress),
        Command::Plan(a) => plan::run(&a),
        Command::Shaders(a) => shaders::run(&a),
        Command::Verify(a) => match a.command {
            crate::args::VerifyCommand::Fiv(v) => verify_fiv::run(&v),
            crate::args::VerifyCommand::Shadows(v) => verify_shadows::run(&v),
            crate::args::VerifyCommand::Mrt(v) => verify_mrt::run(&v, cli.progress),
            crate::args::VerifyCommand::Drt(v) => verify_drt::run(&v, cli.progress),
            crate::args::VerifyCommand::Vo(v) => verify_vo::run(&v),
            crate::args::VerifyCommand::Gpu(v) => verify_gpu::run(&v),
        },
        Command::Sweep(a) => match a.command {
            crate::args::SweepCommand::Shadows(v) => sweep_shadows::run(&v, cli.progress),
            crate::args::SweepCommand::Spheres(v) => sweep_spheres::run(&v, cli.progress),
            crate::args::SweepCommand::Tables(v) => sweep_tables::run(&v, cli.progress),
            crate::args::SweepCommand::Fiv(v) => sweep_fiv::run(&v, cli.progress),
            crate::args::SweepCommand::Drt(v) => sweep_drt::run(&v, cli.progress),
            crate::args::SweepCommand::Mrt(v) => sweep_mrt::run(&v, cli.progress),
        },
        Command::Schema(a) => {
            let s = if a.level {
                penumbra_config::level_schema_json()
            } else if a.clutter {
                penumbra_config::clutter::clutter_schema_json()
            } else {
                penumbra_config::schema_json()
            };
            stdout_write(&s);
            Ok(ExitCode::Ok)
        }
    }
}

/// Prints a JSON value on stdout (one object, newline-terminated).
pub fn print_json(v: &serde_json::Value) {
    stdout_write(&format!("{}\n", serde_json::to_string_pretty(v).unwrap_or_else(|_| "{}".into())));
}

/// Writes text to stdout. A reader that closed the pipe early (`penumbra … --json | grep -q …`,
/// `| head`) is not an error of the command: the bake already finished and its outputs are
/// written, so the rest of the report is dropped and the exit code stays the command's own
/// (`println!` would panic with exit 101 here). Other write errors are reported on stderr.
#[allow(clippy::print_stderr)]
pub fn stdout_write(text: &str) {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {}
        Err(e) => eprintln!("warning: could not write the report to stdout: {e}"),
    }
}

/// `println!` to stdout through [`stdout_write`] (no panic on a closed pipe).
#[macro_export]
macro_rules! outln {
    ($($arg:tt)*) => { $crate::commands::stdout_write(&format!("{}\n", format_args!($($arg)*))) };
}
