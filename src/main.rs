//! The `hbis` command line: a thin layer over the library.

fn main() -> std::process::ExitCode {
    hbis::cli::main()
}
