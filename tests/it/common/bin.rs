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

/// A report.html holds no script and loads nothing (the only URL is the
/// SVG namespace), and inlines `figures` SVG figures when the `figures`
/// feature is on.
pub fn assert_self_contained(html: &str, figures: usize) {
    assert!(html.starts_with("<!DOCTYPE html>"));
    assert!(!html.contains("<script"), "a script");
    let urls = html.matches("http").count();
    let namespaces = html.matches("http://www.w3.org/").count();
    assert_eq!(urls, namespaces, "a URL other than the SVG namespace");
    let expected = if cfg!(feature = "figures") {
        figures
    } else {
        0
    };
    assert_eq!(html.matches("<figure><svg").count(), expected, "figures");
}

/// Runs `hbis args...` in `dir` with standard error on `/dev/full`, so
/// every write to it fails.
pub fn hbis_full_stderr(dir: &Path, args: &[&str]) -> Output {
    let full = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .expect("/dev/full");
    Command::new(env!("CARGO_BIN_EXE_hbis"))
        .current_dir(dir)
        .args(args)
        .stderr(full)
        .output()
        .expect("runs")
}
