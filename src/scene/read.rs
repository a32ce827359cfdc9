//! Reading input files whole, within a size limit, refusing what is not a regular file.

use std::path::Path;

/// The most an OBJ file may hold (1 GiB): more is refused before it is read.
pub const MAX_OBJ_BYTES: u64 = 1 << 30;
/// The most an MTL file may hold (64 MiB).
pub const MAX_MTL_BYTES: u64 = 64 << 20;

/// Why an input file could not be read whole.
#[derive(Debug)]
pub enum ReadFailure {
    /// Opening or reading failed.
    Io(std::io::Error),
    /// A FIFO, device, socket or directory (named: "a FIFO"): reading it could block or never
    /// end.
    NotRegular(&'static str),
    /// More bytes than the limit given to [`read_regular_file`].
    TooLarge,
}

/// Read a whole regular file of at most `limit` bytes. FIFOs, devices (`/dev/zero`), sockets
/// and directories are refused before they are opened, so reading never blocks or runs away;
/// the size is checked again while reading (the file may grow).
pub fn read_regular_file(path: &Path, limit: u64) -> Result<Vec<u8>, ReadFailure> {
    use std::io::Read;
    let kind = |m: &std::fs::Metadata| -> Option<&'static str> {
        use std::os::unix::fs::FileTypeExt;
        let t = m.file_type();
        if t.is_file() {
            None
        } else if t.is_dir() {
            Some("a directory")
        } else if t.is_fifo() {
            Some("a FIFO")
        } else if t.is_char_device() {
            Some("a character device")
        } else if t.is_block_device() {
            Some("a block device")
        } else if t.is_socket() {
            Some("a socket")
        } else {
            Some("not a file")
        }
    };
    let meta = std::fs::metadata(path).map_err(ReadFailure::Io)?;
    if let Some(k) = kind(&meta) {
        return Err(ReadFailure::NotRegular(k));
    }
    if meta.len() > limit {
        return Err(ReadFailure::TooLarge);
    }
    let f = std::fs::File::open(path).map_err(ReadFailure::Io)?;
    // The path may have been replaced between the two calls: check what was opened.
    if let Some(k) = kind(&f.metadata().map_err(ReadFailure::Io)?) {
        return Err(ReadFailure::NotRegular(k));
    }
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    f.take(limit + 1).read_to_end(&mut bytes).map_err(ReadFailure::Io)?;
    if bytes.len() as u64 > limit {
        return Err(ReadFailure::TooLarge);
    }
    Ok(bytes)
}

impl std::fmt::Display for ReadFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ReadFailure::Io(e) => write!(f, "cannot read: {e}"),
            ReadFailure::NotRegular(k) => write!(f, "not a regular file ({k})"),
            ReadFailure::TooLarge => write!(f, "too large"),
        }
    }
}
