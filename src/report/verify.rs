//! Reading a finished run's folder back: only what its manifest lists, and
//! only when every listed file still has the size and SHA-256 the run
//! wrote.
//!
//! A folder changes after its run in ways no parser notices: a refit killed
//! between two chain renames leaves chains of two seeds side by side; a
//! chain cut at a line end, with digits changed or deleted, still parses;
//! an edited `fit.json` names another model. The manifest ([`super::outdir`])
//! is written last by a run that finished, so checking against it refuses
//! all of these, and a file that is not listed is never read.
//!
//! ```
//! use hbis::report::outdir::OutDir;
//! use hbis::report::verify::read_manifest;
//!
//! let tmp = tempfile::tempdir()?;
//! let mut dir = OutDir::open(tmp.path(), &[], "fit")?;
//! dir.write("fit.json", b"{}\n")?;
//! dir.finish("fit", 7, "bilinear+coulomb", None)?;
//! assert_eq!(read_manifest(tmp.path())?.files[0].name, "fit.json");
//!
//! std::fs::write(tmp.path().join("fit.json"), b"[]\n")?;
//! let err = read_manifest(tmp.path()).unwrap_err().to_string();
//! assert!(err.contains("fit.json") && err.contains("SHA-256"), "{err}");
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::fs;
use std::path::Path;

use thiserror::Error;

use super::outdir::{sha256_hex, FileEntry, Manifest, MANIFEST};

/// Why a finished run's folder cannot be read back.
#[derive(Debug, Error)]
pub enum VerifyError {
    /// Neither the folder nor its parent (a sub-report of `demo`) holds a
    /// manifest that lists it.
    #[error("{dir} has no {MANIFEST} listing it: the run that wrote it did not finish (killed or still running), or the folder was not written by hbis; rerun it")]
    NoManifest {
        /// The folder.
        dir: String,
    },
    /// The manifest cannot be read.
    #[error("{path}: {problem}")]
    BadManifest {
        /// The manifest.
        path: String,
        /// What is wrong.
        problem: String,
    },
    /// A listed file is missing or changed.
    #[error("{path}: {problem}; the folder changed after its run finished: rerun it")]
    Changed {
        /// The file.
        path: String,
        /// What differs from the manifest.
        problem: String,
    },
}

/// A finished run's manifest with the files of one folder of it, their
/// names relative to that folder.
#[derive(Debug, Clone)]
pub struct Listed {
    /// The manifest.
    pub manifest: Manifest,
    /// The files it lists inside the folder, names relative to it, each
    /// checked.
    pub files: Vec<FileEntry>,
}

impl Listed {
    /// Whether `name` (relative to the folder) is listed.
    pub fn holds(&self, name: &str) -> bool {
        self.files.iter().any(|f| f.name == name)
    }
}

/// The manifest of the run that wrote `dir`, with every file it lists in
/// `dir` checked (size and SHA-256). The manifest is `dir/manifest.json`,
/// or the parent's when `dir` is a sub-report (`hbis-demo/fit`).
pub fn read_manifest(dir: &Path) -> Result<Listed, VerifyError> {
    let own = dir.join(MANIFEST);
    let (path, prefix) = if own.exists() {
        (own, String::new())
    } else {
        let name = dir.file_name().map(|n| n.to_string_lossy().into_owned());
        match (dir.parent(), name) {
            (Some(parent), Some(name)) if parent.join(MANIFEST).exists() => {
                (parent.join(MANIFEST), format!("{name}/"))
            }
            _ => return Err(no_manifest(dir)),
        }
    };
    let manifest = parse(&path)?;
    let files: Vec<FileEntry> = manifest
        .files
        .iter()
        .filter_map(|f| {
            let name = f.name.strip_prefix(&prefix)?;
            Some(FileEntry {
                name: name.to_string(),
                ..f.clone()
            })
        })
        .collect();
    if files.is_empty() {
        return Err(no_manifest(dir));
    }
    check_files(dir, &files)?;
    Ok(Listed { manifest, files })
}

fn no_manifest(dir: &Path) -> VerifyError {
    VerifyError::NoManifest {
        dir: dir.display().to_string(),
    }
}

fn parse(path: &Path) -> Result<Manifest, VerifyError> {
    let bad = |problem: String| VerifyError::BadManifest {
        path: path.display().to_string(),
        problem,
    };
    let text = fs::read_to_string(path).map_err(|e| bad(format!("cannot read: {e}")))?;
    let m: Manifest =
        serde_json::from_str(&text).map_err(|e| bad(format!("not a manifest: {e}")))?;
    if !m.complete {
        return Err(bad("`complete` is false".into()));
    }
    Ok(m)
}

/// Checks that each of `files` (names relative to `dir`) has the size and
/// SHA-256 listed.
pub fn check_files(dir: &Path, files: &[FileEntry]) -> Result<(), VerifyError> {
    for f in files {
        let path = dir.join(&f.name);
        let changed = |problem: String| VerifyError::Changed {
            path: path.display().to_string(),
            problem,
        };
        let bytes =
            fs::read(&path).map_err(|e| changed(format!("listed but cannot be read ({e})")))?;
        if bytes.len() as u64 != f.bytes {
            return Err(changed(format!(
                "{} bytes, the manifest lists {}",
                bytes.len(),
                f.bytes
            )));
        }
        if sha256_hex(&bytes) != f.sha256 {
            return Err(changed(
                "its SHA-256 differs from the manifest's (same size, changed content)".into(),
            ));
        }
    }
    Ok(())
}
