//! The `fragtrace` binary: parse the command line, call the library, map errors to exit
//! codes (0 success, 2 bad input, 1 internal error).

use clap::Parser;

fn main() {
    let cli = fragtrace::cli::Cli::parse();
    if let Err(e) = fragtrace::cli::run(cli) {
        eprintln!("fragtrace: error: {e}");
        std::process::exit(e.exit_code());
    }
}
