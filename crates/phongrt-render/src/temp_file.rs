//! Temporary files beside an output, named so that they cannot collide: a random suffix (not
//! the process ID, which is 1 in every container's PID namespace), created with `O_EXCL` and
//! retried on a collision, so a file found under the name is never this process's to delete.

use std::collections::hash_map::RandomState;
use std::fs::File;
use std::hash::{BuildHasher, Hasher};
use std::path::{Path, PathBuf};

/// How many names are tried before giving up (a collision of 64 random bits is already rare).
const ATTEMPTS: usize = 16;

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

/// Create a new file `.{name}.{random}.tmp` in `dir` with `O_EXCL` (`create_new`), trying
/// another name when one exists. Returns the path (this process's to remove) and the file.
pub fn create_unique(dir: &Path, name: &str) -> std::io::Result<(PathBuf, File)> {
    let mut last = None;
    for attempt in 0..ATTEMPTS {
        let path = dir.join(format!(".{name}.{:016x}.tmp", random_suffix(attempt)));
        match std::fs::OpenOptions::new().write(true).create_new(true).open(&path) {
            Ok(f) => return Ok((path, f)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => last = Some(e),
            Err(e) => return Err(e),
        }
    }
    Err(last.unwrap_or_else(|| std::io::Error::other("no unique temporary name found")))
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
