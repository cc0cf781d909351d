//! Percentage-closer soft shadows (Fernando 2005; RTR 7.6, eq. 7.6 and fig. 7.25), the
//! technique: its options, their declaration and the registry entry; the blocker search, the
//! penumbra estimate and the filter are [`super::soft`]'s, which the hybrid shares.
//!
//! Known failures: the average-blocker assumption (two occluders at different heights over
//! one search disk), thin blockers missed by the search's taps, a penumbra turned to umbra by
//! the all-blockers early out, and the estimate quantized by the map's resolution
//! ([`super::soft`] has the details).

use super::kernel::MAX_TAPS;
use super::soft::SoftShadows;
pub use super::soft::{Disk, Options};
use crate::shadow::pass::PassTechnique;
use crate::shadow::{Declaration, Family, Field, TechniqueInfo};

/// The option declaration.
pub fn declaration() -> Declaration<Options> {
    let mut fields = crate::map_fields!(Options, |o| o.map);
    fields.extend(crate::bias_fields!(Options, |o| o.bias));
    fields.extend([
        crate::cone_field!(Options, |o| o.wide),
        crate::hierarchy_field!(Options, |o| o.wide),
    ]);
    fields.extend(crate::light_size_fields!(Options, |o| o));
    fields.extend([
        Field::range("blockers", "blocker-search taps", 1, MAX_TAPS, |o: &mut Options| {
            &mut o.blockers
        }),
        Field::range("taps", "filter taps", 1, MAX_TAPS, |o: &mut Options| &mut o.taps),
        Field::new(
            "disk",
            "poisson, rotated (per-pixel hashed angle) or spiral (interleaved gradient noise)",
            |o: &mut Options| &mut o.disk,
        ),
    ]);
    Declaration {
        technique: "pcss",
        fields,
    }
}

/// Registry entry.
pub fn info() -> TechniqueInfo {
    TechniqueInfo {
        name: "pcss",
        family: Family::Map,
        summary:
            "percentage-closer soft shadows (Fernando 2005): blocker search, penumbra by RTR eq. 7.6, PCF that wide",
        options: declaration().infos(),
        sweep: &[
            &[],
            &[("blockers", "32"), ("taps", "64")],
            &[("disk", "rotated")],
            &[("size", "512")],
        ],
        extended: &[
            &[("hierarchy", "true")],
            &[("disk", "spiral"), ("taps", "32")],
            &[("receiver", "true"), ("units", "0"), ("slope", "0")],
            &[("angle", "1")],
        ],
        create: |pairs| Ok(Box::new(Pcss::new(declaration().parse(pairs)?)?)),
    }
}

/// Percentage-closer soft shadows (see the module docs): the shared pass as a technique.
pub type Pcss = PassTechnique<SoftShadows>;

impl Pcss {
    /// PCSS with `opts`; an option out of its range is an error.
    pub fn new(opts: Options) -> Result<Pcss, String> {
        declaration().check(&opts)?;
        Ok(PassTechnique::with("pcss", SoftShadows::new(opts)))
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::shadow::inspect::NoTrace;

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

    #[test]
    fn four_pixel_lookups_equal_one_pixel_ones() {
        let sets: [&[(&str, &str)]; 6] = [
            &[("angle", "3")],
            // A map size that is not a power of two, and a search of two batches.
            &[
                ("angle", "3"),
                ("size", "300"),
                ("blockers", "20"),
                ("receiver", "true"),
            ],
            &[("angle", "3"), ("disk", "rotated"), ("receiver", "true")],
            &[("angle", "3"), ("disk", "spiral"), ("taps", "32"), ("size", "256")],
            &[("angle", "3"), ("hierarchy", "true"), ("blockers", "7")],
            &[("light", "0")],
        ];
        assert_lookups(
            &sets,
            |pairs| {
                let mut t = Pcss::new(declaration().parse(pairs).unwrap()).unwrap();
                t.pass.keep_penumbra(true);
                t
            },
            |t, f, x, y| t.pass.lookup(f, x, y, &mut NoTrace),
            // The penumbra kept for the hybrid is the one-pixel estimate's.
            |t, f, x, y, i| {
                let world = t.pass.penumbra_world(f, x, y).unwrap_or(f32::NAN);
                assert_eq!(t.pass.kept_penumbra()[i].to_bits(), world.to_bits(), "({x}, {y})");
            },
            |t| t.pass.taps | t.pass.early << 32,
        );
    }
}
