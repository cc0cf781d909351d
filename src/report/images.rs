//! Images of a run: visibility (grey, or colour where it has channels), reference and the
//! error against it.

use crate::pipeline::{Rgba8, Surface};
use crate::visibility::Visibility;

/// Image of a visibility: grey for scalar images, the channels' colour for colour ones
/// (NaN: the background colour).
pub fn visibility_image(v: &Visibility, w: u32, h: u32) -> Surface<Rgba8> {
    let data = (0..v.len())
        .map(|i| {
            let c = v.rgb(i);
            if c.is_finite() {
                let b = |x: f32| (x.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
                [b(c.x), b(c.y), b(c.z), 255]
            } else {
                [40, 20, 60, 255]
            }
        })
        .collect();
    Surface::from_vec_derived(w, h, data).expect("frame size")
}

/// Error image (of the luminance for colour images): red where the technique is darker than
/// the truth, blue where brighter, black where equal, grey outside the metric mask.
pub fn error_image(v: &Visibility, r: &Visibility, mask: &[bool], w: u32, h: u32) -> Surface<Rgba8> {
    let data = mask
        .iter()
        .enumerate()
        .map(|(i, &m)| {
            let (a, b) = (v.value(i), r.value(i));
            if !m || !b.is_finite() {
                return [60, 60, 60, 255];
            }
            let d = if a.is_finite() { a - b } else { -1.0 };
            let k = (d.abs().min(1.0) * 255.0) as u8;
            if d < 0.0 {
                [k, 0, 0, 255]
            } else {
                [0, 0, k, 255]
            }
        })
        .collect();
    Surface::from_vec_derived(w, h, data).expect("frame size")
}
