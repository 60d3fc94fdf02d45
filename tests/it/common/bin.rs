//! Running the real `hbis` binary in a folder (shared by the CLI tests).

use std::path::Path;
use std::process::{Command, Output};

/// Runs `hbis args...` in `dir` with `RAYON_NUM_THREADS = threads`.
pub fn hbis_with(dir: &Path, args: &[&str], threads: &str) -> Output {
    Command::new(env!("CARGO_BIN_EXE_hbis"))
        .current_dir(dir)
        .env("RAYON_NUM_THREADS", threads)
        .args(args)
        .output()
        .expect("runs")
}

/// Runs `hbis args...` in `dir`.
pub fn hbis(dir: &Path, args: &[&str]) -> Output {
    hbis_with(dir, args, "2")
}

/// Its standard error as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}
