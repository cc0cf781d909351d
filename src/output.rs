//! Writing output files: never through a symbolic link, a FIFO or a device planted where an
//! output goes, and never half a file. Every command that writes (images, scenes, reports,
//! exports) writes through [`write_plain`] into folders made by [`create_folder`].

use crate::Error;
use std::path::Path;

/// Writes `bytes` to `path` as a regular file: a regular file already there is replaced; a
/// symbolic link, folder, FIFO or device there is refused, never written through. The bytes
/// go to a new file beside it (created exclusively, which follows no link) that is renamed
/// over `path` (which replaces an entry, never writes through one), so that two writers of
/// the same file leave one whole file.
pub fn write_plain(path: &Path, bytes: &[u8]) -> Result<(), Error> {
    use std::io::Write;
    use std::sync::atomic::{AtomicU64, Ordering};
    static NEXT: AtomicU64 = AtomicU64::new(0);
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_file() => {}
        Ok(_) => {
            return Err(Error::io(
                path,
                "cannot write",
                "a symbolic link, folder, FIFO or device is in its place: not written through",
            ))
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => return Err(Error::io(path, "cannot write", e)),
    }
    let name = path
        .file_name()
        .map_or("file".into(), |n| n.to_string_lossy().into_owned());
    let tmp = path.with_file_name(format!(
        ".{name}.{}-{}.part",
        std::process::id(),
        NEXT.fetch_add(1, Ordering::Relaxed)
    ));
    let written = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&tmp)
        .and_then(|mut f| f.write_all(bytes))
        .and_then(|()| std::fs::rename(&tmp, path));
    written.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        Error::io(path, "cannot write", e)
    })
}

/// Creates the folder `dir` of an output (and its parents) unless it is one already: a
/// symbolic link or a file in its place is refused (writing into a linked `images/` would
/// write outside the output folder).
pub fn create_folder(dir: &Path) -> Result<(), Error> {
    match std::fs::symlink_metadata(dir) {
        Ok(m) if m.file_type().is_dir() => Ok(()),
        Ok(_) => Err(Error::io(
            dir,
            "cannot write into",
            "it is a symbolic link or a file, not a folder: output is not written through links",
        )),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, "cannot create folder", e))
        }
        Err(e) => Err(Error::io(dir, "cannot create folder", e)),
    }
}
