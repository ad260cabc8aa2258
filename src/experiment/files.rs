//! The files of a results folder are opened as regular files only: never
//! through a symbolic link (someone who can write into a shared results
//! folder could plant one to make a run create, truncate or read a file
//! elsewhere) and never a FIFO or a device (a FIFO would block the run
//! forever). Either is refused with an error naming the file. Writes go
//! through a fresh temporary file renamed into place
//! ([`crate::mesh::io::temp`]), which replaces a planted link rather than
//! following it.

use std::fs::{File, OpenOptions};
use std::io::Read;
use std::path::Path;

use crate::{Error, Result};

/// The error for a file of a results folder that is not a regular file.
fn refuse(path: &Path, what: &str) -> Error {
    Error::invalid(format!(
        "{}: {what}; the files of a results folder are regular files that deformlab \
         writes. Remove it and run again",
        path.display()
    ))
}

/// Opens `path` of a results folder for reading (and writing, creating it
/// when absent, with `create`): refused when it is a symbolic link or not a
/// regular file (see the module docs).
pub fn open_regular(path: &Path, create: bool) -> Result<File> {
    if let Ok(m) = std::fs::symlink_metadata(path) {
        if m.file_type().is_symlink() {
            return Err(refuse(path, "is a symbolic link"));
        }
        if !m.is_file() {
            return Err(refuse(path, "is not a regular file"));
        }
    }
    let mut o = OpenOptions::new();
    o.read(true);
    if create {
        o.write(true).create(true).truncate(false);
    }
    #[cfg(unix)]
    {
        // Closes the gap between the check above and the open: the open
        // itself refuses a link planted meanwhile, and does not wait on a
        // FIFO.
        use std::os::unix::fs::OpenOptionsExt;
        o.custom_flags(libc::O_NOFOLLOW | libc::O_NONBLOCK);
    }
    let f = o
        .open(path)
        .map_err(|e| match std::fs::symlink_metadata(path) {
            Ok(m) if m.file_type().is_symlink() => refuse(path, "is a symbolic link"),
            _ => Error::io(path, e),
        })?;
    let m = f.metadata().map_err(|e| Error::io(path, e))?;
    if !m.is_file() {
        return Err(refuse(path, "is not a regular file"));
    }
    Ok(f)
}

/// The text of `path` of a results folder (a regular file, see
/// [`open_regular`]).
pub fn read_regular(path: &Path) -> Result<String> {
    let mut f = open_regular(path, false)?;
    let mut s = String::new();
    f.read_to_string(&mut s).map_err(|e| Error::io(path, e))?;
    Ok(s)
}
