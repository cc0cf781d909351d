//! Shared by the map family's tests: a small scene under every light kind, and the check
//! that a technique's four-pixel lookups equal its one-pixel ones.

use crate::frame::Frame;
use crate::pipeline::Pipeline;
use crate::shadow::technique::{ShadowTechnique, Visibility};

/// A box and a sphere on a ground, seen by a small camera, under `light` (TOML).
pub(crate) fn scene(light: &str) -> crate::scene::Scene {
    let text = format!(
        "[camera]\nposition = [3, 2.5, 4]\ntarget = [0, 0.4, 0]\nresolution = [97, 61]\n\n{light}\n\n[[object]]\nmesh = \"plane\"\nsize = 8\n\n[[object]]\nmesh = \"box\"\nsize = 1\ntranslate = [0, 0.5, 0]\nrotate = [0, 25, 0]\n\n[[object]]\nmesh = \"sphere\"\nradius = 0.4\ntranslate = [1.2, 0.6, -0.6]\n"
    );
    crate::scene::file::parse(&text, std::path::Path::new("t.toml")).unwrap()
}

/// Lights of every kind: a disk, a sun with an angular size, and a point light (cube
/// faces: four pixels may look up different views).
pub(crate) const LIGHTS: [&str; 3] = [
    "[[light]]\ntype = \"disk\"\nposition = [-2.5, 5, -1.5]\ntarget = [0, 0, 0]\nradius = 0.35",
    "[[light]]\ntype = \"directional\"\ndirection = [0.4, -1, 0.3]",
    "[[light]]\ntype = \"point\"\nposition = [0.3, 1.6, 0.9]",
];

/// For every light of [`LIGHTS`] and option set of `sets` on [`scene`]'s frame: the
/// technique `make` builds runs, and every pixel's value equals its one-pixel `lookup`
/// bit for bit (then `more` checks the pixel), and the run's count (`counted`) is the sum
/// of the one-pixel counts.
pub(crate) fn assert_lookups<T: ShadowTechnique>(
    sets: &[&[(&str, &str)]],
    make: impl Fn(&[(String, String)]) -> T,
    lookup: impl Fn(&T, &Frame, usize, usize) -> (f32, u64),
    more: impl Fn(&T, &Frame, usize, usize, usize),
    counted: impl Fn(&T) -> u64,
) {
    let p = Pipeline::new(2).unwrap();
    for light in LIGHTS {
        let s = scene(light);
        let f = crate::frame::frame(&p, &s, 0, 0).unwrap();
        for set in sets {
            let pairs: Vec<(String, String)> = set.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
            let mut t = make(&pairs);
            let Visibility::Scalar(v) = t.visibility(&p, &f).unwrap() else {
                panic!("scalar")
            };
            let (w, h) = (f.width() as usize, f.height() as usize);
            let mut total = 0u64;
            for y in 0..h {
                for x in 0..w {
                    let (one, n) = lookup(&t, &f, x, y);
                    total += n;
                    assert_eq!(v[y * w + x].to_bits(), one.to_bits(), "{light} {set:?} ({x}, {y})");
                    more(&t, &f, x, y, y * w + x);
                }
            }
            assert_eq!(counted(&t), total, "{light} {set:?}");
        }
    }
}

/// For every fixture scene (`fixtures/scenes`) on which the technique of `entry` applies and every
/// option set of its registry sweep: the image of the technique `new` makes of the options
/// `declaration` parses equals its one-pixel `lookup`
/// (the code `inspect` runs, with a recording trace instead of [`NoTrace`](crate::shadow::inspect::NoTrace))
/// at every pixel, bit for bit. This holds the four-lane image paths to the traced one on
/// every fixture, not only on [`scene`].
#[cfg(feature = "files")]
pub(crate) fn assert_lookups_on_fixtures<O: Clone + Default + 'static, T: ShadowTechnique + Sync>(
    entry: &crate::shadow::technique::Entry,
    declaration: fn() -> crate::shadow::technique::Declaration<O>,
    new: fn(O) -> Result<T, crate::Error>,
    lookup: impl Fn(&T, &Frame, usize, usize) -> f32 + Sync,
) {
    use rayon::prelude::*;
    let p = Pipeline::new(2).unwrap();
    let name = entry.name;
    let mut paths: Vec<_> = std::fs::read_dir("fixtures/scenes")
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    paths.sort();
    let mut checked = 0usize;
    for path in &paths {
        let s = crate::scene::file::load(path).unwrap();
        if !s.lights.iter().all(|l| entry.applies.is_none_or(|f| f(&s, l))) {
            continue;
        }
        let f = crate::frame::frame(&p, &s, 0, 0).unwrap();
        let (w, h) = (f.width() as usize, f.height() as usize);
        for set in entry.sweep {
            let pairs: Vec<(String, String)> = set.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
            let mut t = new(declaration().parse(&pairs).unwrap()).unwrap();
            let v = t.visibility(&p, &f).unwrap();
            let (t, f, lookup) = (&t, &f, &lookup);
            let wrong = p.install(|| {
                (0..h)
                    .into_par_iter()
                    .flat_map_iter(|y| (0..w).map(move |x| (x, y)))
                    .find_first(|&(x, y)| lookup(t, f, x, y).to_bits() != v.value(y * w + x).to_bits())
            });
            if let Some((x, y)) = wrong {
                panic!(
                    "{name} {set:?} on {}: at ({x}, {y}) the image has {} where the lookup gives {}",
                    path.display(),
                    v.value(y * w + x),
                    lookup(t, f, x, y)
                );
            }
            checked += w * h;
        }
    }
    assert!(checked > 1_000_000, "{name}: {checked} pixels checked");
}
