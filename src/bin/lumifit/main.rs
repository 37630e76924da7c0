//! `lumifit` command-line front end. `main` parses, dispatches and owns the exit codes:
//! 0 on success, 2 on any error (clap's own usage errors also exit with 2).

mod args;
mod commands;

use clap::Parser;

fn main() {
    let cli = args::Cli::parse();
    if let Err(err) = commands::run(cli) {
        eprintln!("error: {err}");
        for cause in err.chain().skip(1) {
            eprintln!("  caused by: {cause}");
        }
        std::process::exit(2);
    }
}
