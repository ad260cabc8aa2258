//! The `deformlab` command line.

mod cli;

use std::process::ExitCode;

fn main() -> ExitCode {
    // A closed pipe (`deformlab weights … | head`) ends the process quietly,
    // as it does for other command-line tools, instead of a panic in
    // `println!`. Results written to files are not affected: they are
    // written atomically and never through stdout.
    #[cfg(unix)]
    // SAFETY: restoring the default disposition of SIGPIPE before any
    // thread is started.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    deformlab::solve::keep_freed_memory();
    let args = cli::Cli::parse_from_args(std::env::args_os());
    match cli::run(args) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}
