//! `raycast`: parses the command line, runs the command, and is the one
//! place that prints an error and chooses the exit code
//! (`raycast::error::EXIT_CODES`).

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    raycast::gpu::prepare_process();
    let cli = match raycast::cli::Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            // --help and --version print and succeed; usage errors exit 2.
            let _ = e.print();
            return ExitCode::from(if e.use_stderr() { 2 } else { 0 });
        }
    };
    match raycast::cli::run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let code = e.exit_code();
            {
                use std::io::Write as _;
                let _ = writeln!(std::io::stderr(), "{}", e.line());
            }
            if raycast::gpu::device_left_running() {
                end_now(code);
            }
            ExitCode::from(code)
        }
    }
}

/// Ends the process at once with `code`, without the clean-up at exit: a
/// device was left running work that outlived its timeout
/// (`gpu::device_left_running`), and Mesa's clean-up at exit joins its
/// worker threads, one of which runs that work for ever.
fn end_now(code: u8) -> ! {
    use std::io::Write as _;
    let _ = std::io::stdout().flush();
    let _ = std::io::stderr().flush();
    // SAFETY: _exit (POSIX) ends the process; the buffered output is flushed above.
    unsafe { libc::_exit(i32::from(code)) }
}
