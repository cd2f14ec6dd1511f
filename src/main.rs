//! The `fragtrace` binary: parse the command line, call the library, map errors to exit
//! codes (0 success, 2 bad input, 1 internal error).

use clap::Parser;

fn main() {
    let cli = fragtrace::cli::Cli::parse();
    match fragtrace::cli::run(cli) {
        Ok(true) => {}
        Ok(false) => std::process::exit(1),
        Err(e) => {
            // One line per error, whatever a dependency's message looks like.
            let msg = e
                .to_string()
                .lines()
                .map(str::trim)
                .collect::<Vec<_>>()
                .join(": ");
            eprintln!("fragtrace: error: {msg}");
            std::process::exit(e.exit_code());
        }
    }
}
