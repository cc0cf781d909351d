//! Reference images cached on disk: one little-endian `f32` file per key (one value per
//! pixel, or three for colour references).

use crate::run::ReferenceCache;
use crate::visibility::Visibility;
use crate::Error;
use std::path::PathBuf;

/// A folder of cached reference images.
pub struct DirCache(pub PathBuf);

impl DirCache {
    fn file(&self, key: u64) -> PathBuf {
        self.0.join(format!("reference-{key:016x}.f32"))
    }
}

impl ReferenceCache for DirCache {
    fn get(&self, key: u64, pixels: usize) -> Option<Visibility> {
        // A regular file of at most three floats per pixel, never through a link (a FIFO
        // planted in the cache would hang the read).
        let bytes = super::files::read_plain(&self.file(key), "cached reference", pixels as u64 * 12).ok()?;
        if bytes.len() % 4 != 0 {
            return None;
        }
        let data = bytes
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        Visibility::from_flat(pixels, data)
    }

    fn put(&self, key: u64, v: &Visibility) -> Result<(), Error> {
        super::files::create_folder(&self.0)?;
        let bytes: Vec<u8> = v.to_flat().iter().flat_map(|x| x.to_le_bytes()).collect();
        super::files::write_plain(&self.file(key), &bytes)
    }
}
