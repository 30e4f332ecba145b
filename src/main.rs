//! The `vkpath` command line (contract: docs/cli.md). Parses flags, runs the command (`cli`), maps errors
//! to exit codes: 0 success, 2 bad input (scene, flags), 1 anything else.

mod cli;

use clap::Parser;

fn main() {
    let cli = match cli::Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => e.exit(), // --help, --version: print and exit 0
        Err(e) => {
            // Clap's usage errors span several paragraphs; the contract asks for one.
            let text = e.to_string();
            let msg: Vec<&str> = text
                .lines()
                .map(str::trim)
                .filter(|l| !l.is_empty())
                .collect();
            eprintln!("vkpath: {}", msg.join(" "));
            std::process::exit(2);
        }
    };
    match cli::run(cli.command) {
        Ok(code) => std::process::exit(code),
        Err(e) => {
            eprintln!("vkpath: error: {e}");
            std::process::exit(e.exit_code());
        }
    }
}
