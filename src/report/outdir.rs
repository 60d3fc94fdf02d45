//! An output folder that cannot be corrupted: locked while a run uses it,
//! every file written under a temporary name and renamed into place, and a
//! manifest written last, so a folder is either complete or visibly not.
//!
//! - **Lock.** `open` creates `.hbis.lock` exclusively (it holds the process
//!   id and the command). A second run into the same folder refuses at once
//!   and names the first. A lock left by a process that no longer exists
//!   (killed with SIGKILL) is taken over, so a killed run can be resumed.
//! - **Atomic files.** [`OutDir::write`] writes `name` through a temporary
//!   file in the same folder, synced, then renamed: a reader sees the old
//!   file or the new one, never half of one.
//! - **Manifest.** [`OutDir::finish`] writes `manifest.json` (every file with
//!   its size and SHA-256, the seed, the model, the record's SHA-256) last.
//!   `open` removes an old manifest first, so a run killed half-way leaves a
//!   folder without one. Files an earlier run wrote that this run did not
//!   rewrite (a `--map-only` run after a sampling run, fewer ensembles) are
//!   listed in `.hbis-stale` when the run starts and removed when it
//!   finishes, so a complete folder holds only this run's outputs.
//! - **Inputs.** `open` refuses a folder that contains one of the run's
//!   input files: a run never writes over what it reads.

use std::collections::BTreeSet;
use std::fs::{self, File, OpenOptions};
use std::io::{self, Write};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use thiserror::Error;

/// The lock file's name.
pub const LOCK: &str = ".hbis.lock";
/// The manifest's name.
pub const MANIFEST: &str = "manifest.json";
/// Files of earlier runs still to be removed.
const STALE: &str = ".hbis-stale";

/// Why an output folder cannot be used.
#[derive(Debug, Error)]
pub enum OutError {
    /// Another run holds the lock.
    #[error("output folder {dir} is in use by another hbis run (process {pid}: `{command}`); wait for it or choose another --out (if no such run exists, delete {lock})")]
    Locked {
        dir: String,
        pid: u32,
        command: String,
        lock: String,
    },
    /// An input lies inside the output folder.
    #[error("input file {input} is inside the output folder {dir}: hbis never writes where its inputs are; choose another --out")]
    InputInside { input: String, dir: String },
    /// An output file is one of the inputs.
    #[error("output {output} is the input file {input}: hbis never writes over its inputs; choose another name")]
    SameFile { input: String, output: String },
    /// A file system operation failed.
    #[error("{action} {path}")]
    Io {
        action: &'static str,
        path: String,
        #[source]
        source: io::Error,
    },
}

fn io_err<'a>(action: &'static str, path: &'a Path) -> impl FnOnce(io::Error) -> OutError + 'a {
    move |source| OutError::Io {
        action,
        path: path.display().to_string(),
        source,
    }
}

/// What the lock file holds.
#[derive(Debug, Serialize, Deserialize)]
struct LockInfo {
    pid: u32,
    command: String,
}

/// One output file in the manifest.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct FileEntry {
    /// Path relative to the folder, `/`-separated.
    pub name: String,
    /// Size in bytes.
    pub bytes: u64,
    /// SHA-256 of the contents, lower-case hex.
    pub sha256: String,
}

/// `manifest.json`: what a complete run wrote.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Manifest {
    /// Always `true`: the manifest is written only by a run that finished.
    pub complete: bool,
    /// hbis version.
    pub hbis_version: String,
    /// The command (`fit`, `diagnose`, `ladder`, `demo`).
    pub command: String,
    /// Seed of every random number.
    pub seed: u64,
    /// Model spec.
    pub model: String,
    /// The record: path as given and SHA-256 of its bytes.
    pub record: Option<InputEntry>,
    /// Every output file, in the order written.
    pub files: Vec<FileEntry>,
}

/// An input file and its hash.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct InputEntry {
    /// Path as given.
    pub path: String,
    /// SHA-256 of its bytes.
    pub sha256: String,
}

impl InputEntry {
    /// Hashes the file at `path`.
    pub fn of(path: &Path) -> Result<Self, OutError> {
        let bytes = fs::read(path).map_err(io_err("cannot read", path))?;
        Ok(Self {
            path: path.display().to_string(),
            sha256: sha256_hex(&bytes),
        })
    }
}

/// SHA-256 of `bytes` as lower-case hex.
///
/// ```
/// assert_eq!(
///     hbis::report::outdir::sha256_hex(b"abc"),
///     "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
/// );
/// ```
pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// An output folder held by this run.
#[derive(Debug)]
pub struct OutDir {
    root: PathBuf,
    written: Vec<FileEntry>,
    stale: BTreeSet<String>,
    locked: bool,
    prefix: String,
}

impl OutDir {
    /// Creates (if needed) and locks `root` for `command`, after checking
    /// that no file of `inputs` lies inside it.
    pub fn open(root: &Path, inputs: &[&Path], command: &str) -> Result<Self, OutError> {
        refuse_inputs_inside(root, inputs)?;
        fs::create_dir_all(root).map_err(io_err("cannot create folder", root))?;
        // Checked again on the real folder: a symbolic link may lead into it.
        refuse_inputs_inside(root, inputs)?;
        lock(root, command)?;
        let mut dir = Self {
            root: root.to_path_buf(),
            written: Vec::new(),
            stale: BTreeSet::new(),
            locked: true,
            prefix: String::new(),
        };
        dir.mark_stale()?;
        Ok(dir)
    }

    /// The folder.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// The final path of output `name`.
    pub fn path(&self, name: &str) -> PathBuf {
        self.root.join(format!("{}{name}", self.prefix))
    }

    /// Names given to `write` from now on are inside sub-folder `prefix`
    /// (`""` for the folder itself): one locked folder, several reports.
    pub fn set_prefix(&mut self, prefix: &str) {
        self.prefix = match prefix.trim_end_matches('/') {
            "" => String::new(),
            p => format!("{p}/"),
        };
    }

    /// Writes output `name` (relative, `/`-separated) atomically.
    pub fn write(&mut self, name: &str, bytes: &[u8]) -> Result<(), OutError> {
        self.write_with(name, |tmp| {
            let mut f = File::create(tmp)?;
            f.write_all(bytes)?;
            f.sync_all()
        })
    }

    /// Writes output `name` atomically through `make`, which must create
    /// the file at the temporary path it is given (same folder, same
    /// extension, so that writers that pick a format by extension work).
    pub fn write_with<E>(
        &mut self,
        name: &str,
        make: impl FnOnce(&Path) -> Result<(), E>,
    ) -> Result<(), OutError>
    where
        E: Into<Box<dyn std::error::Error + Send + Sync>>,
    {
        let name = &format!("{}{name}", self.prefix);
        let path = self.root.join(name);
        write_path_atomic(&path, &[], make)?;
        let bytes = fs::read(&path).map_err(io_err("cannot read back", &path))?;
        self.stale.remove(name);
        self.written.retain(|f| &f.name != name);
        self.written.push(FileEntry {
            name: name.clone(),
            bytes: bytes.len() as u64,
            sha256: sha256_hex(&bytes),
        });
        Ok(())
    }

    /// Files written so far.
    pub fn written(&self) -> &[FileEntry] {
        &self.written
    }

    /// Removes what earlier runs left and this one did not rewrite, writes
    /// the manifest last and releases the lock.
    pub fn finish(
        mut self,
        command: &str,
        seed: u64,
        model: &str,
        record: Option<InputEntry>,
    ) -> Result<Manifest, OutError> {
        for name in std::mem::take(&mut self.stale) {
            let p = self.root.join(&name);
            match fs::remove_file(&p) {
                Ok(()) => {}
                Err(e) if e.kind() == io::ErrorKind::NotFound => {}
                Err(e) => return Err(io_err("cannot remove stale output", &p)(e)),
            }
        }
        let stale = self.root.join(STALE);
        let _ = fs::remove_file(&stale);
        let manifest = Manifest {
            complete: true,
            hbis_version: env!("CARGO_PKG_VERSION").to_string(),
            command: command.to_string(),
            seed,
            model: model.to_string(),
            record,
            files: self.written.clone(),
        };
        let text = serde_json::to_string_pretty(&manifest).expect("manifest serialises") + "\n";
        let path = self.root.join(MANIFEST);
        let tmp = temporary(&path);
        write_synced(&tmp, text.as_bytes())?;
        fs::rename(&tmp, &path).map_err(io_err("cannot rename into place", &path))?;
        self.unlock();
        Ok(manifest)
    }

    /// Records the previous run's outputs as stale and removes its manifest,
    /// so the folder reads as incomplete until this run finishes.
    fn mark_stale(&mut self) -> Result<(), OutError> {
        let stale_path = self.root.join(STALE);
        let mut stale: BTreeSet<String> = match fs::read_to_string(&stale_path) {
            Ok(t) => t.lines().map(str::to_string).collect(),
            Err(_) => BTreeSet::new(),
        };
        let manifest = self.root.join(MANIFEST);
        if let Ok(text) = fs::read_to_string(&manifest) {
            if let Ok(m) = serde_json::from_str::<Manifest>(&text) {
                stale.extend(m.files.into_iter().map(|f| f.name));
            }
        }
        // Only plain relative names inside the folder are ever removed.
        stale.retain(|n| safe_name(n));
        if !stale.is_empty() {
            let text: String = stale.iter().map(|n| format!("{n}\n")).collect();
            let tmp = temporary(&stale_path);
            write_synced(&tmp, text.as_bytes())?;
            fs::rename(&tmp, &stale_path).map_err(io_err("cannot write", &stale_path))?;
        }
        match fs::remove_file(&manifest) {
            Ok(()) => {}
            Err(e) if e.kind() == io::ErrorKind::NotFound => {}
            Err(e) => return Err(io_err("cannot remove old manifest", &manifest)(e)),
        }
        self.stale = stale;
        Ok(())
    }

    fn unlock(&mut self) {
        if self.locked {
            let _ = fs::remove_file(self.root.join(LOCK));
            self.locked = false;
        }
    }
}

impl Drop for OutDir {
    fn drop(&mut self) {
        self.unlock();
    }
}

/// A name an earlier manifest may list: relative, no `..`.
fn safe_name(n: &str) -> bool {
    !n.is_empty()
        && !n.starts_with('/')
        && !n.contains('\\')
        && n.split('/').all(|c| !c.is_empty() && c != "." && c != "..")
        && n != LOCK
        && n != MANIFEST
}

/// `dir/.name.<pid>.tmp.ext`: same folder (rename stays atomic), same
/// extension.
fn temporary(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    path.with_file_name(temporary_name(&name, std::process::id()))
}

/// The temporary file name of output `name` written by process `pid`.
fn temporary_name(name: &str, pid: u32) -> String {
    let (stem, ext) = match name.rsplit_once('.') {
        Some((s, e)) if !s.is_empty() => (s.to_string(), format!(".{e}")),
        _ => (name.to_string(), String::new()),
    };
    format!(".{stem}.{pid}.tmp{ext}")
}

/// The output name and the writing process of a temporary file name made
/// by this module (`.fit.123.tmp.json` -> `fit.json`, 123); `None` for any
/// other name.
///
/// ```
/// use hbis::report::outdir::temporary_of;
/// assert_eq!(temporary_of(".fit.123.tmp.json"), Some(("fit.json".into(), 123)));
/// assert_eq!(temporary_of("fit.json"), None);
/// ```
pub fn temporary_of(file_name: &str) -> Option<(String, u32)> {
    let rest = file_name.strip_prefix('.')?;
    // The extension, if any, follows `.tmp`; try without one, then with.
    let without = rest.strip_suffix(".tmp").map(|head| (head, ""));
    let with = rest
        .rsplit_once('.')
        .and_then(|(h, e)| Some((h.strip_suffix(".tmp")?, e)));
    [without, with]
        .into_iter()
        .flatten()
        .find_map(|(head, ext)| {
            let (stem, pid) = head.rsplit_once('.')?;
            let pid: u32 = pid.parse().ok()?;
            let name = if ext.is_empty() {
                stem.to_string()
            } else {
                format!("{stem}.{ext}")
            };
            // Only a name this module would have made for that output.
            (temporary_name(&name, pid) == file_name).then_some((name, pid))
        })
}

/// Removes from `dir` (and, when `deep`, its sub-folders; symbolic links
/// are not followed) the temporary files that runs killed before their
/// rename left: names [`temporary_of`] recognises, of an output `owned`
/// accepts, written by a process that no longer exists. Returns how many.
pub fn remove_orphan_temporaries(
    dir: &Path,
    deep: bool,
    owned: &dyn Fn(&str) -> bool,
) -> Result<usize, OutError> {
    let entries = match fs::read_dir(dir) {
        Ok(e) => e,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(0),
        Err(e) => return Err(io_err("cannot list", dir)(e)),
    };
    let mut removed = 0;
    for entry in entries {
        let entry = entry.map_err(io_err("cannot list", dir))?;
        let path = entry.path();
        let kind = entry.file_type().map_err(io_err("cannot inspect", &path))?;
        if kind.is_dir() && deep {
            removed += remove_orphan_temporaries(&path, deep, owned)?;
            continue;
        }
        let name = entry.file_name().to_string_lossy().into_owned();
        let orphan = temporary_of(&name).is_some_and(|(out, pid)| owned(&out) && !alive(pid));
        if kind.is_file() && orphan {
            match fs::remove_file(&path) {
                Ok(()) => removed += 1,
                Err(e) if e.kind() == io::ErrorKind::NotFound => {}
                Err(e) => return Err(io_err("cannot remove leftover temporary", &path)(e)),
            }
        }
    }
    Ok(removed)
}

fn write_synced(path: &Path, bytes: &[u8]) -> Result<(), OutError> {
    let mut f = File::create(path).map_err(io_err("cannot create", path))?;
    f.write_all(bytes).map_err(io_err("cannot write", path))?;
    f.sync_all().map_err(io_err("cannot write", path))
}

/// Writes a single output file atomically (a temporary file beside it,
/// then a rename), refusing to write over one of `inputs`.
pub fn write_file_atomic(path: &Path, inputs: &[&Path], bytes: &[u8]) -> Result<(), OutError> {
    write_path_atomic(path, inputs, |tmp| {
        let mut f = File::create(tmp)?;
        f.write_all(bytes)?;
        f.sync_all()
    })
}

/// Writes a single output file atomically through `make`, which creates
/// the file at the temporary path it is given (same folder and extension).
pub fn write_path_atomic<E>(
    path: &Path,
    inputs: &[&Path],
    make: impl FnOnce(&Path) -> Result<(), E>,
) -> Result<(), OutError>
where
    E: Into<Box<dyn std::error::Error + Send + Sync>>,
{
    refuse_same_file(path, inputs)?;
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        fs::create_dir_all(parent).map_err(io_err("cannot create folder", parent))?;
    }
    let tmp = temporary(path);
    if let Err(e) = make(&tmp) {
        let _ = fs::remove_file(&tmp);
        return Err(OutError::Io {
            action: "cannot write",
            path: path.display().to_string(),
            source: io::Error::other(e),
        });
    }
    fs::rename(&tmp, path).map_err(io_err("cannot rename into place", path))
}

/// Refuses an output path that is one of the inputs.
pub fn refuse_same_file(path: &Path, inputs: &[&Path]) -> Result<(), OutError> {
    let Some(out) = absolute(path) else {
        return Ok(());
    };
    for input in inputs {
        if absolute(input).as_ref() == Some(&out) {
            return Err(OutError::SameFile {
                input: input.display().to_string(),
                output: path.display().to_string(),
            });
        }
    }
    Ok(())
}

fn refuse_inputs_inside(root: &Path, inputs: &[&Path]) -> Result<(), OutError> {
    let Some(dir) = absolute(root) else {
        return Ok(());
    };
    for input in inputs {
        if let Some(p) = absolute(input) {
            if p.starts_with(&dir) {
                return Err(OutError::InputInside {
                    input: input.display().to_string(),
                    dir: root.display().to_string(),
                });
            }
        }
    }
    Ok(())
}

/// The path with symbolic links resolved as far as it exists.
fn absolute(p: &Path) -> Option<PathBuf> {
    if let Ok(c) = fs::canonicalize(p) {
        return Some(c);
    }
    let parent = p.parent().filter(|q| !q.as_os_str().is_empty());
    let base = match parent {
        Some(q) => absolute(q)?,
        None => std::env::current_dir().ok()?,
    };
    Some(base.join(p.file_name()?))
}

/// Takes the lock, or names the run that holds it.
fn lock(root: &Path, command: &str) -> Result<(), OutError> {
    let path = root.join(LOCK);
    let info = LockInfo {
        pid: std::process::id(),
        command: command.to_string(),
    };
    let text = serde_json::to_string(&info).expect("lock serialises");
    for _ in 0..3 {
        match OpenOptions::new().write(true).create_new(true).open(&path) {
            Ok(mut f) => {
                f.write_all(text.as_bytes())
                    .and_then(|_| f.sync_all())
                    .map_err(io_err("cannot write lock", &path))?;
                return Ok(());
            }
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists => {
                let holder = fs::read_to_string(&path)
                    .ok()
                    .and_then(|t| serde_json::from_str::<LockInfo>(&t).ok());
                match holder {
                    Some(h) if alive(h.pid) => {
                        return Err(OutError::Locked {
                            dir: root.display().to_string(),
                            pid: h.pid,
                            command: h.command,
                            lock: path.display().to_string(),
                        })
                    }
                    // A lock of a process that is gone, or one being written
                    // this instant (empty): gone ones are taken over.
                    Some(_) => {
                        let _ = fs::remove_file(&path);
                    }
                    None => {
                        std::thread::sleep(std::time::Duration::from_millis(50));
                        let again = fs::read_to_string(&path).unwrap_or_default();
                        if again.trim().is_empty() {
                            let _ = fs::remove_file(&path);
                        }
                    }
                }
            }
            Err(e) => return Err(io_err("cannot create lock", &path)(e)),
        }
    }
    Err(OutError::Locked {
        dir: root.display().to_string(),
        pid: 0,
        command: "unknown".into(),
        lock: path.display().to_string(),
    })
}

/// Whether process `pid` exists (Linux: `/proc/<pid>`; elsewhere assumed
/// alive, so a stale lock must be removed by hand).
fn alive(pid: u32) -> bool {
    if pid == std::process::id() {
        return true;
    }
    if Path::new("/proc/self").exists() {
        Path::new(&format!("/proc/{pid}")).exists()
    } else {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_open_is_refused_and_names_the_first() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = OutDir::open(tmp.path(), &[], "fit").unwrap();
        let err = OutDir::open(tmp.path(), &[], "ladder").unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("in use") && msg.contains("`fit`"), "{msg}");
        drop(dir);
        OutDir::open(tmp.path(), &[], "ladder").unwrap();
    }

    #[test]
    fn a_lock_of_a_dead_process_is_taken_over() {
        let tmp = tempfile::tempdir().unwrap();
        // Process ids are below 2^22 on Linux.
        fs::write(
            tmp.path().join(LOCK),
            r#"{"pid":4294967000,"command":"fit"}"#,
        )
        .unwrap();
        let d = OutDir::open(tmp.path(), &[], "fit").unwrap();
        let held: LockInfo =
            serde_json::from_str(&fs::read_to_string(tmp.path().join(LOCK)).unwrap()).unwrap();
        assert_eq!(held.pid, std::process::id());
        drop(d);
        assert!(!tmp.path().join(LOCK).exists());
    }

    #[test]
    fn an_input_inside_the_folder_is_refused() {
        let tmp = tempfile::tempdir().unwrap();
        let rec = tmp.path().join("out/fit.csv");
        fs::create_dir_all(rec.parent().unwrap()).unwrap();
        fs::write(&rec, "t,a\n").unwrap();
        let err = OutDir::open(&tmp.path().join("out"), &[&rec], "fit").unwrap_err();
        assert!(matches!(err, OutError::InputInside { .. }), "{err}");
        assert_eq!(fs::read_to_string(&rec).unwrap(), "t,a\n");
        // Also through a relative path with `..`.
        let rel = tmp.path().join("out/../out/fit.csv");
        assert!(OutDir::open(&tmp.path().join("out"), &[&rel], "fit").is_err());
        assert!(refuse_same_file(&rec, &[&rel]).is_err());
        assert!(refuse_same_file(&tmp.path().join("x.csv"), &[&rec]).is_ok());
    }

    #[test]
    fn manifest_lists_what_was_written_and_stale_outputs_go() {
        let tmp = tempfile::tempdir().unwrap();
        let mut d = OutDir::open(tmp.path(), &[], "fit").unwrap();
        d.write("fit.json", b"{}").unwrap();
        d.write("chains/chain-1.csv", b"x").unwrap();
        d.write("chains/chain-2.csv", b"y").unwrap();
        d.finish("fit", 1, "m", None).unwrap();
        // A second run writes less: the chains of the first must go.
        let mut d = OutDir::open(tmp.path(), &[], "fit").unwrap();
        assert!(
            !tmp.path().join(MANIFEST).exists(),
            "incomplete while running"
        );
        d.write("fit.json", b"{\"a\":1}").unwrap();
        let m = d.finish("fit", 2, "m", None).unwrap();
        assert_eq!(m.files.len(), 1);
        assert_eq!(m.files[0].sha256, sha256_hex(b"{\"a\":1}"));
        assert!(!tmp.path().join("chains/chain-1.csv").exists());
        assert!(!tmp.path().join(STALE).exists());
        let read: Manifest =
            serde_json::from_str(&fs::read_to_string(tmp.path().join(MANIFEST)).unwrap()).unwrap();
        assert_eq!(read.seed, 2);
        assert!(!tmp.path().join(LOCK).exists());
    }

    #[test]
    fn a_run_killed_before_finishing_leaves_the_stale_list_for_the_next() {
        let tmp = tempfile::tempdir().unwrap();
        let mut d = OutDir::open(tmp.path(), &[], "fit").unwrap();
        d.write("a.csv", b"1").unwrap();
        d.write("b.csv", b"2").unwrap();
        d.finish("fit", 1, "m", None).unwrap();
        // Killed: no finish, lock released by drop here (a dead process's is
        // taken over, tested above).
        let mut d = OutDir::open(tmp.path(), &[], "fit").unwrap();
        d.write("a.csv", b"3").unwrap();
        drop(d);
        assert!(!tmp.path().join(MANIFEST).exists());
        let mut d = OutDir::open(tmp.path(), &[], "fit").unwrap();
        d.write("a.csv", b"4").unwrap();
        d.finish("fit", 1, "m", None).unwrap();
        assert!(!tmp.path().join("b.csv").exists(), "b.csv of the first run");
        assert_eq!(fs::read_to_string(tmp.path().join("a.csv")).unwrap(), "4");
    }

    #[test]
    fn a_failed_writer_leaves_the_old_file_and_no_temporary() {
        let tmp = tempfile::tempdir().unwrap();
        let mut d = OutDir::open(tmp.path(), &[], "fit").unwrap();
        d.write("fig.png", b"old").unwrap();
        let r = d.write_with("fig.png", |p| {
            fs::write(p, b"half")?;
            Err::<(), _>(io::Error::other("disk full"))
        });
        assert!(r.is_err());
        assert_eq!(fs::read(tmp.path().join("fig.png")).unwrap(), b"old");
        let names: Vec<_> = fs::read_dir(tmp.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert!(names.iter().all(|n| !n.contains(".tmp")), "{names:?}");
    }

    #[test]
    fn temporary_names_are_recognised_and_nothing_else() {
        for name in [
            "fit.json",
            "chain-1.csv",
            "noext",
            ".hbis-stale",
            "a.b.png",
            "x.tmp",
        ] {
            let t = temporary_name(name, 4242);
            assert_eq!(temporary_of(&t), Some((name.to_string(), 4242)), "{t}");
        }
        for other in [
            "fit.json",
            ".fit.json",
            ".fit.tmp.json",
            ".fit.12a.tmp.json",
            "fit.123.tmp.json",
            ".fit.123.tmp.json.bak",
            "state.json.tmp",
            "ensemble-2.bin.tmp",
        ] {
            assert_eq!(temporary_of(other), None, "{other}");
        }
    }

    #[test]
    fn temporaries_keep_the_extension() {
        let t = temporary(Path::new("/x/fit.png"));
        assert!(t.to_string_lossy().ends_with(".tmp.png"), "{}", t.display());
        assert_eq!(t.parent(), Some(Path::new("/x")));
    }
}
