use clap::Parser;
use penumbra_cli::args::Cli;
use penumbra_cli::{commands, exit};

fn main() {
    let cli = Cli::parse();
    let code = match commands::run(cli) {
        Ok(code) => code,
        Err(e) => exit::report(&e),
    };
    std::process::exit(code as i32);
}
