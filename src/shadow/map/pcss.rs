//! Percentage-closer soft shadows (Fernando 2005; RTR 7.6, eq. 7.6 and fig. 7.25), the
//! technique: its options, their declaration and the registry entry; the blocker search, the
//! penumbra estimate and the filter are [`super::soft`]'s, which the hybrid shares.
//!
//! Known failures: the average-blocker assumption (two occluders at different heights over
//! one search disk), thin blockers missed by the search's taps, a penumbra turned to umbra by
//! the all-blockers early out, and the estimate quantized by the map's resolution
//! ([`super::soft`] has the details).

use super::soft::SoftShadows;
pub use super::soft::{Disk, Options};
use crate::shadow::light::soft::light_size_fields;
use crate::shadow::pass::PassTechnique;
use crate::shadow::sample::kernel::MAX_TAPS;
use crate::shadow::sample::lookup::lookup_fields;
use crate::shadow::technique::{Declaration, Entry, Family, Field};
use crate::Error;

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "pcss",
    family: Family::Map,
    summary: "percentage-closer soft shadows (Fernando 2005): blocker search, penumbra by RTR eq. 7.6, PCF that wide",
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
    models: &[crate::shadow::technique::Effect::AreaLight],
    ..Entry::BASE
};

/// The option declaration.
pub fn declaration() -> Declaration<Options> {
    let mut fields = lookup_fields(
        |o: &mut Options| &mut o.map,
        |o: &mut Options| &mut o.bias,
        |o: &mut Options| &mut o.wide,
    );
    fields.extend(light_size_fields(
        |o: &mut Options| &mut o.light,
        |o: &mut Options| &mut o.angle,
    ));
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
    Declaration::new("pcss", fields)
}

/// Percentage-closer soft shadows (see the module docs): the shared pass as a technique.
pub type Pcss = PassTechnique<SoftShadows>;

impl Pcss {
    /// PCSS with `opts`; an option out of its range is an error.
    pub fn new(opts: Options) -> Result<Pcss, Error> {
        declaration().check(&opts)?;
        Ok(PassTechnique::with("pcss", SoftShadows::new(opts)))
    }
}

#[cfg(all(test, feature = "files"))]
mod tests {
    use super::*;
    use crate::shadow::inspect::NoTrace;
    use crate::shadow::sample::testing::assert_lookups;

    /// `inspect`'s lookup is the image at every pixel of every fixture
    /// ([`crate::shadow::sample::testing::assert_lookups_on_fixtures`]).
    #[test]
    fn the_image_is_the_traced_lookup_on_every_fixture() {
        crate::shadow::sample::testing::assert_lookups_on_fixtures(&ENTRY, declaration, Pcss::new, |t, f, x, y| {
            t.pass.lookup(f, x, y, &mut NoTrace).0
        });
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
