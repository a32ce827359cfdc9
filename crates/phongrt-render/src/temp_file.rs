//! Temporary files beside an output, named so that they cannot collide: a random suffix (not
//! the process ID, which is 1 in every container's PID namespace), created with `O_EXCL` and
//! retried on a collision, so a file found under the name is never this process's to delete.
//!
//! Every [`TempFile`] alive is listed in one registry, so that [`remove_on_signals`] can delete
//! them when SIGTERM, SIGINT or SIGHUP arrives (a scheduler pre-empting a job sends SIGTERM)
//! and exit with status 128 + the signal. Creating a file and listing it, and renaming it and
//! striking it off, each happen under the registry's lock: a signal never finds a file that is
//! not listed, nor deletes one that is already the output.

use std::collections::hash_map::RandomState;
use std::fs::File;
use std::hash::{BuildHasher, Hasher};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

/// How many names are tried before giving up (a collision of 64 random bits is already rare).
const ATTEMPTS: usize = 16;

/// The temporary files this process has created and not yet renamed or removed.
static LIVE: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// The registry, even after a panic elsewhere while it was held (it is a plain list).
fn live() -> MutexGuard<'static, Vec<PathBuf>> {
    LIVE.lock().unwrap_or_else(|e| e.into_inner())
}

/// 64 random bits: std seeds every `RandomState` from the operating system's random source
/// (the process ID, time and a counter are mixed in too, for good measure).
fn random_suffix(attempt: usize) -> u64 {
    let mut h = RandomState::new().build_hasher();
    h.write_u32(std::process::id());
    h.write_usize(attempt);
    let now = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap_or_default();
    h.write_u128(now.as_nanos());
    h.finish()
}

/// A temporary file `.{name}.{random}.tmp`, removed when dropped unless [`TempFile::persist`]
/// renamed it, and removed by [`remove_on_signals`]'s handler while it lives.
#[derive(Debug)]
pub struct TempFile {
    path: PathBuf,
    file: File,
    persisted: bool,
}

impl TempFile {
    /// Create a new file `.{name}.{random}.tmp` in `dir` with `O_EXCL` (`create_new`), trying
    /// another name when one exists.
    pub fn create(dir: &Path, name: &str) -> std::io::Result<TempFile> {
        let mut last = None;
        for attempt in 0..ATTEMPTS {
            let path = dir.join(format!(".{name}.{:016x}.tmp", random_suffix(attempt)));
            let mut registry = live();
            match std::fs::OpenOptions::new().write(true).create_new(true).open(&path) {
                Ok(file) => {
                    registry.push(path.clone());
                    return Ok(TempFile { path, file, persisted: false });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => last = Some(e),
                Err(e) => return Err(e),
            }
        }
        Err(last.unwrap_or_else(|| std::io::Error::other("no unique temporary name found")))
    }

    /// The file, open for writing.
    pub fn file(&mut self) -> &mut File {
        &mut self.file
    }

    /// Where the file is.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Rename the file over `target` (the caller has written and synced it). On failure the
    /// file is removed when `self` drops.
    pub fn persist(mut self, target: &Path) -> std::io::Result<()> {
        let mut registry = live();
        std::fs::rename(&self.path, target)?;
        self.persisted = true;
        registry.retain(|p| *p != self.path);
        Ok(())
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        if self.persisted {
            return;
        }
        let mut registry = live();
        let _ = std::fs::remove_file(&self.path);
        registry.retain(|p| *p != self.path);
    }
}

/// The exit status for a process ended by signal `sig`, as shells report it.
pub fn signal_exit_status(sig: i32) -> i32 {
    128 + sig
}

/// From now on, SIGTERM, SIGINT and SIGHUP remove every live [`TempFile`] and exit the process
/// with status 128 + the signal (143, 130, 129). A thread of signal-hook's receives the signals
/// (its handler only writes to a pipe); the files are removed there, under the registry's lock,
/// which is then held until the process ends, so no rename can follow.
///
/// The process ends with `_exit`, not [`std::process::exit`]: the latter runs the C and C++
/// at-exit destructors (Embree's and its task scheduler's) while other threads are still
/// tracing, which crashed 3 of 180 signalled renders with SIGSEGV or SIGABRT instead of the status.
pub fn remove_on_signals() -> std::io::Result<()> {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let mut signals = signal_hook::iterator::Signals::new([SIGTERM, SIGINT, SIGHUP])?;
    std::thread::Builder::new().name("phongrt-signals".into()).spawn(move || {
        if let Some(sig) = signals.forever().next() {
            let registry = live();
            for p in registry.iter() {
                let _ = std::fs::remove_file(p);
            }
            signal_hook::low_level::exit(signal_exit_status(sig));
        }
    })?;
    Ok(())
}

/// The first of `inputs` that is the same file as `output` (same device and inode, so after
/// following symbolic links and through hard links), if any: writing `output` would destroy it.
pub fn input_that_is<'a>(output: &Path, inputs: &'a [PathBuf]) -> Option<&'a Path> {
    use std::os::unix::fs::MetadataExt;
    let out = std::fs::metadata(output).ok()?;
    inputs
        .iter()
        .map(PathBuf::as_path)
        .find(|p| std::fs::metadata(p).is_ok_and(|m| (m.dev(), m.ino()) == (out.dev(), out.ino())))
}
