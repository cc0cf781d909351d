//! Writing surfaces to image files: PNG for looking at, PFM and OpenEXR for the float data
//! (visibility, depth, stages) that other tools read back.

use crate::pipeline::{Rgba8, Surface};
use crate::Error;
use std::path::Path;

/// Writes an RGBA8 surface as a PNG (row 0 at the top). Creates the parent folder.
pub fn write_png(path: &Path, s: &Surface<Rgba8>) -> Result<(), Error> {
    if let Some(dir) = path.parent() {
        if !dir.as_os_str().is_empty() {
            crate::output::create_folder(dir)?;
        }
    }
    let png = encode_png(s).map_err(|e| Error::io(path, "cannot write", e))?;
    crate::output::write_plain(path, &png)
}

/// An RGBA8 surface as the bytes of a PNG file (row 0 at the top).
pub fn encode_png(s: &Surface<Rgba8>) -> Result<Vec<u8>, image::ImageError> {
    use image::ImageEncoder;
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out).write_image(
        s.data().as_flattened(),
        s.width(),
        s.height(),
        image::ExtendedColorType::Rgba8,
    )?;
    Ok(out)
}

/// A grey-scale view of a float surface mapped from `[lo, hi]` to black..white.
pub fn grey(s: &Surface<f32>, lo: f32, hi: f32) -> Surface<Rgba8> {
    let k = if hi > lo { 1.0 / (hi - lo) } else { 0.0 };
    s.map(|v| {
        let g = (((v - lo) * k).clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
        [g, g, g, 255]
    })
}

/// Writes a float image of `channels` (1 or 3) interleaved channels as PFM (rows bottom-up, as
/// the format requires; little-endian).
pub fn write_pfm(path: &Path, w: u32, h: u32, channels: usize, data: &[f32]) -> Result<(), Error> {
    check_float_image(path, w, h, channels, data)?;
    let mut bytes = format!("{}\n{w} {h}\n-1.0\n", if channels == 3 { "PF" } else { "Pf" }).into_bytes();
    for y in (0..h as usize).rev() {
        for v in &data[y * w as usize * channels..(y + 1) * w as usize * channels] {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    crate::output::write_plain(path, &bytes)
}

/// Writes a float image of `channels` (1: channel `Y`; 3: `R`, `G`, `B`) interleaved channels
/// as OpenEXR (32-bit float samples, row 0 at the top, no compression loss).
pub fn write_exr(path: &Path, w: u32, h: u32, channels: usize, data: &[f32]) -> Result<(), Error> {
    use exr::prelude::{Image, SpecificChannels, Vec2, WritableImage};
    check_float_image(path, w, h, channels, data)?;
    let (wu, hu) = (w as usize, h as usize);
    let err = |e: exr::error::Error| Error::io(path, "cannot write", e);
    // Compressed one block after another: in parallel, the blocks would be written in the
    // order they finish, and the same image would not always be the same bytes.
    let mut bytes = std::io::Cursor::new(Vec::new());
    if channels == 3 {
        let ch = SpecificChannels::rgb(|p: Vec2<usize>| {
            let i = (p.y() * wu + p.x()) * 3;
            (data[i], data[i + 1], data[i + 2])
        });
        Image::from_channels((wu, hu), ch)
            .write()
            .non_parallel()
            .to_buffered(&mut bytes)
            .map_err(err)?;
    } else {
        let ch = SpecificChannels::build()
            .with_channel::<f32>("Y")
            .with_pixel_fn(|p: Vec2<usize>| (data[p.y() * wu + p.x()],));
        Image::from_channels((wu, hu), ch)
            .write()
            .non_parallel()
            .to_buffered(&mut bytes)
            .map_err(err)?;
    }
    crate::output::write_plain(path, bytes.get_ref())
}

fn check_float_image(path: &Path, w: u32, h: u32, channels: usize, data: &[f32]) -> Result<(), Error> {
    if !(channels == 1 || channels == 3) || data.len() != w as usize * h as usize * channels || w == 0 || h == 0 {
        return Err(Error::input(format!(
            "cannot write {}: {} values are not a {w}x{h} image of {channels} channels (1 or 3)",
            path.display(),
            data.len()
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The same image is the same bytes, write after write (blocks compressed in parallel
    /// would land in the order they finish).
    #[test]
    fn exr_files_are_the_same_bytes_every_time() {
        let dir = std::env::temp_dir().join(format!("penumbra-exr-same-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (w, h) = (300u32, 200u32);
        for channels in [1, 3] {
            let data: Vec<f32> = (0..w as usize * h as usize * channels)
                .map(|i| ((i * 2654435761) % 1000) as f32 / 999.0)
                .collect();
            let first = dir.join("first.exr");
            write_exr(&first, w, h, channels, &data).unwrap();
            let want = std::fs::read(&first).unwrap();
            for k in 0..6 {
                let p = dir.join(format!("again{k}.exr"));
                write_exr(&p, w, h, channels, &data).unwrap();
                assert!(
                    std::fs::read(&p).unwrap() == want,
                    "{channels} channels: write {k} differs"
                );
            }
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn exr_reads_back_bit_for_bit() {
        let dir = std::env::temp_dir().join(format!("penumbra-exr-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (w, h) = (5u32, 3u32);
        let grey: Vec<f32> = (0..w * h).map(|i| i as f32 * 0.1 - 0.3).collect();
        let p1 = dir.join("grey.exr");
        write_exr(&p1, w, h, 1, &grey).unwrap();
        let img = exr::prelude::read_first_flat_layer_from_file(&p1).unwrap();
        assert_eq!(img.layer_data.size.width(), 5);
        let ch = &img.layer_data.channel_data.list[0];
        assert_eq!(ch.name.to_string(), "Y");
        let back: Vec<f32> = ch.sample_data.values_as_f32().collect();
        assert_eq!(back, grey);
        let rgb: Vec<f32> = (0..w * h * 3).map(|i| i as f32 / 7.0).collect();
        let p3 = dir.join("rgb.exr");
        write_exr(&p3, w, h, 3, &rgb).unwrap();
        let img = exr::prelude::read_first_flat_layer_from_file(&p3).unwrap();
        let names: Vec<String> = img
            .layer_data
            .channel_data
            .list
            .iter()
            .map(|c| c.name.to_string())
            .collect();
        // Channels are stored sorted by name: B, G, R.
        assert_eq!(names, ["B", "G", "R"]);
        let r: Vec<f32> = img.layer_data.channel_data.list[2]
            .sample_data
            .values_as_f32()
            .collect();
        assert_eq!(r, rgb.iter().step_by(3).copied().collect::<Vec<_>>());
        assert!(write_exr(&p3, w, h, 2, &rgb).is_err());
        assert!(write_pfm(&p3, w, h, 3, &rgb[1..]).is_err());
    }
}
