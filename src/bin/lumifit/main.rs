//! `lumifit` command-line front end. `main` parses, dispatches and owns the exit codes:
//! 0 on success, 2 on any error (clap's own usage errors also exit with 2).

mod args;
mod commands;

use clap::Parser;

fn main() {
    let cli = args::Cli::parse();
    if let Err(err) = commands::run(cli) {
        let mut shown = err.to_string();
        eprintln!("error: {shown}");
        // Library errors already include their cause in the message ("FILE: OS error"); print
        // a cause only when it adds something, so no line is said twice.
        for cause in err.chain().skip(1) {
            let text = cause.to_string();
            if !shown.contains(&text) {
                eprintln!("  caused by: {text}");
                shown.push_str(&text);
            }
        }
        std::process::exit(2);
    }
}
