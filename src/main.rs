//! The `fragtrace` binary: parse the command line, call the library, map errors to exit
//! codes (0 success, 2 bad input, 1 internal error). Every error is one line on stderr.

use clap::Parser;

fn main() {
    let cli = match fragtrace::cli::Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(
                e.kind(),
                ErrorKind::DisplayHelp
                    | ErrorKind::DisplayVersion
                    | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
            ) {
                // Help and version are answers, not errors.
                let _ = e.print();
                std::process::exit(if e.use_stderr() { 2 } else { 0 });
            }
            eprintln!(
                "fragtrace: error: {}",
                fragtrace::cli::one_line_clap_error(&e)
            );
            std::process::exit(2);
        }
    };
    match fragtrace::cli::run(cli) {
        // A driver still compiling would hold the process at its exit (fragtrace::overlap).
        Ok(true) => fragtrace::overlap::end_now(0),
        Ok(false) => std::process::exit(1),
        Err(e) => {
            eprintln!(
                "fragtrace: error: {}",
                fragtrace::cli::one_line(&e.to_string())
            );
            std::process::exit(e.exit_code());
        }
    }
}
