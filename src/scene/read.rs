//! Reading scene files (TOML, OBJ, glTF and their buffers) safely: regular files only, of a
//! bounded size, optionally never through a symbolic link.

use crate::Error;
use std::path::Path;

/// Reads a regular file of at most `limit` bytes: devices, pipes and folders are refused by
/// name before anything is read (a read from `/dev/zero` would never end).
pub fn read_regular(path: &Path, what: &str, limit: u64) -> Result<Vec<u8>, Error> {
    read_file(path, what, limit, false)
}

/// [`read_regular`], never through a symbolic link (`path` itself a link is refused, and the
/// file opened must be the one checked): for files another party may have planted, such as
/// a sweep shard's.
pub fn read_unlinked(path: &Path, what: &str, limit: u64) -> Result<Vec<u8>, Error> {
    read_file(path, what, limit, true)
}

fn read_file(path: &Path, what: &str, limit: u64, unlinked: bool) -> Result<Vec<u8>, Error> {
    use std::io::Read;
    let doing = format!("cannot read {what}");
    let meta = file_meta(path, what, limit, unlinked)?;
    let f = std::fs::File::open(path).map_err(|e| Error::io(path, &doing, e))?;
    #[cfg(unix)]
    if unlinked {
        use std::os::unix::fs::MetadataExt;
        let opened = f.metadata().map_err(|e| Error::io(path, &doing, e))?;
        if (opened.dev(), opened.ino()) != (meta.dev(), meta.ino()) {
            return Err(Error::io(path, &doing, "the file changed while it was opened"));
        }
    }
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    f.take(limit + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| Error::io(path, &doing, e))?;
    if bytes.len() as u64 > limit {
        return Err(Error::scene(path, format!("{what} grew past {limit} bytes while read")));
    }
    Ok(bytes)
}

/// Checks that `path` is a regular file of at most `limit` bytes (see [`read_regular`]);
/// returns its length.
pub fn check_regular(path: &Path, what: &str, limit: u64) -> Result<u64, Error> {
    file_meta(path, what, limit, false).map(|m| m.len())
}

/// The metadata of a regular file of at most `limit` bytes (of the link itself where
/// `unlinked`, which refuses it).
fn file_meta(path: &Path, what: &str, limit: u64, unlinked: bool) -> Result<std::fs::Metadata, Error> {
    let doing = format!("cannot read {what}");
    let meta = if unlinked {
        std::fs::symlink_metadata(path)
    } else {
        std::fs::metadata(path)
    }
    .map_err(|e| Error::io(path, &doing, e))?;
    let kind = meta.file_type();
    if kind.is_symlink() {
        return Err(Error::io(
            path,
            &doing,
            "it is a symbolic link, and links are not followed",
        ));
    }
    if kind.is_dir() {
        return Err(Error::io(path, &doing, "it is a folder"));
    }
    if !kind.is_file() {
        return Err(Error::io(path, &doing, "not a regular file (a device, pipe or socket)"));
    }
    if meta.len() > limit {
        return Err(Error::scene(
            path,
            format!(
                "{what} of {} bytes is larger than the {limit} bytes read at most",
                meta.len()
            ),
        ));
    }
    Ok(meta)
}
