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
    // A render that may open a GL context answers once its files are written, before the
    // driver's release at exit (fragtrace::detach).
    let answer = cli.detaches().then(fragtrace::detach::split).flatten();
    let code = match fragtrace::cli::run(cli) {
        Ok(true) => 0,
        Ok(false) => 1,
        Err(e) => {
            eprintln!(
                "fragtrace: error: {}",
                fragtrace::cli::one_line(&e.to_string())
            );
            e.exit_code()
        }
    };
    fragtrace::detach::finish(answer, code);
    std::process::exit(code);
}
