//! Variance shadow maps (Donnelly and Lauritzen 2006; RTR 7.7, eqs. 7.7-7.8).
//!
//! Each texel stores the first two moments of its linear depth, `M1 = z` and `M2 = z^2`; after
//! filtering they are the mean `mu` and the mean square over the kernel, the variance is
//! `sigma^2 = M2 - mu^2` (eq. 7.7), and Chebyshev's one-tailed inequality bounds the lit
//! share of a receiver at depth `t > mu`: `p_max = sigma^2 / (sigma^2 + (t - mu)^2)` (eq. 7.8).
//!
//! - The slope-based second-moment bias (Donnelly and Lauritzen 2006, sec. 3.3, the
//!   derivation RTR mentions): a texel's depth varies across its footprint, so `M2` gets
//!   `(dz/dx^2 + dz/dy^2) / 4` added, from the depth's change per texel (`slope`).
//! - A least variance (`min_variance`) against the numerical acne of flat receivers.
//! - Light-bleeding reduction (Lauritzen 2007, RTR 7.7): `linstep(bleeding, 1, p_max)`.
//! - Variable width (`variable=true`, summed-area tables; Lauritzen 2007's SAVSM with PCSS's
//!   estimate): over the blocker-search region, the share `p` at the receiver's depth `t` is
//!   taken as unoccluded, so the blockers' average depth is `(mu - p t) / (1 - p)`; eq. 7.6
//!   then gives the penumbra width of the lookup.
//!
//! Known failure: light bleeding. Where two occluders at different depths overlap in a
//! kernel, the variance is large and the bound lets light through onto the lower one's
//! shadow (RTR fig. 7.28, the `overlap` fixture). Bleeding reduction darkens it at the price
//! of sharper, narrower penumbrae.

use super::{bleeding_field, build, chebyshev, reduce_bleeding, FilteredPass, Filtering, Moments, Storage, Variable};
use crate::shadow::inspect::{Step, Trace};
use crate::shadow::light::soft::light_size_fields;
use crate::shadow::options::within;
use crate::shadow::pass::PassTechnique;
use crate::shadow::technique::{Declaration, Entry, Family, Field};
use crate::Error;
use glam::{Vec2, Vec4};

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "vsm",
    family: Family::Filtered,
    summary: "variance shadow map (Donnelly and Lauritzen 2006; RTR eqs. 7.7-7.8): two moments prefiltered, Chebyshev's bound: light bleeding where occluders overlap",
    sweep: &[
        &[],
        &[("bleeding", "0.3")],
        &[("prefilter", "box"), ("radius", "2")],
        &[("prefilter", "sat"), ("variable", "true")],
    ],
    extended: &[
        &[("prefilter", "mips")],
        &[("storage", "f16")],
        &[("radius", "8"), ("size", "1024")],
        &[("cascades", "4")],
    ],
    ..Entry::BASE
};

/// Options of the variance shadow map.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// The map pass, the prefilter and the channel storage (f32, f16 or u16). Default: their
    /// defaults (512 texels, 9x9 Gaussian, f32).
    pub filtering: Filtering,
    /// Least variance (in linear depth squared). Default: 0.00002.
    pub min_variance: f32,
    /// Add the slope-based second-moment bias. Default: true.
    pub slope_bias: bool,
    /// Light-bleeding reduction amount (0: none). Default: 0.
    pub bleeding: f32,
    /// Variable width from a blocker estimate (summed-area tables only). Default: false.
    pub variable: bool,
    /// Variable width: the light's width as a multiple of the scene's area light. Default: 1.
    pub light: f32,
    /// Variable width, directional lights: angular diameter in degrees. Default: 0.5.
    pub angle: f32,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            filtering: Filtering::default(),
            min_variance: 0.00002,
            slope_bias: true,
            bleeding: 0.0,
            variable: false,
            light: 1.0,
            angle: 0.5,
        }
    }
}

/// The option declaration.
pub fn declaration() -> Declaration<Options> {
    let mut fields = within(Filtering::fields(), |o: &mut Options| &mut o.filtering);
    fields.extend([
        Field::range(
            "min_variance",
            "least variance, in linear depth squared",
            0.0,
            1.0,
            |o: &mut Options| &mut o.min_variance,
        ),
        Field::new(
            "slope_bias",
            "add the slope-based second-moment bias (the depth's change across a texel)",
            |o: &mut Options| &mut o.slope_bias,
        ),
        bleeding_field(|o: &mut Options| &mut o.bleeding),
        Field::new(
            "variable",
            "variable width from a blocker estimate over the light's search region (prefilter=sat only)",
            |o: &mut Options| &mut o.variable,
        ),
    ]);
    fields.extend(light_size_fields(
        |o: &mut Options| &mut o.light,
        |o: &mut Options| &mut o.angle,
    ));
    Declaration::new("vsm", fields)
}

/// The two moments and Chebyshev's bound.
#[derive(Clone, Debug, PartialEq)]
pub struct Variance {
    storage: Storage,
    min_variance: f32,
    slope_bias: bool,
    bleeding: f32,
}

impl Moments for Variance {
    const STORAGES: &'static [Storage] = &[Storage::F32, Storage::F16, Storage::U16];

    fn planes(&self) -> usize {
        1
    }

    fn channels(&self) -> Vec<String> {
        vec!["m1".into(), "m2".into()]
    }

    fn storage(&self) -> Storage {
        self.storage
    }

    fn uses_slope(&self) -> bool {
        self.slope_bias
    }

    fn encode(&self, t: f32, slope: Vec2, out: &mut [Vec4]) {
        // Donnelly and Lauritzen 2006, sec. 3.3: the texel's own depth variance.
        let bias = if self.slope_bias {
            0.25 * (slope.x * slope.x + slope.y * slope.y)
        } else {
            0.0
        };
        out[0] = Vec4::new(t, t * t + bias, 0.0, 0.0);
    }

    fn visibility(&self, m: &[Vec4], t: f32, tr: &mut impl Trace) -> f32 {
        // RTR eqs. 7.7 (variance) and 7.8 (Chebyshev's one-tailed bound).
        let (p, var) = chebyshev(m[0].x, m[0].y, t, self.min_variance);
        let v = reduce_bleeding(p, self.bleeding);
        tr.step(|| {
            Step::new(
                "chebyshev",
                "variance M2 - M1^2 (at least min_variance); lit if the receiver is at or before the mean, else sigma^2 / (sigma^2 + (t - mu)^2); then the bleeding reduction",
            )
            .num("mean", m[0].x)
            .num("variance", var)
            .num("receiver", t)
            .num("p_max", p)
            .num("bleeding reduction", self.bleeding)
        });
        v
    }

    fn blocker(&self, m: &[Vec4], t: f32) -> Option<f32> {
        // The share p lit at the receiver's depth: the rest is the blockers', whose mean
        // makes up the kernel's: mu = p t + (1 - p) z_blocker.
        let (p, _) = chebyshev(m[0].x, m[0].y, t, self.min_variance);
        (p < 0.999).then(|| ((m[0].x - p * t) / (1.0 - p)).clamp(0.0, t))
    }
}

/// The variance shadow map (see the module docs).
pub type Vsm = PassTechnique<FilteredPass<Variance>>;

impl Vsm {
    /// A variance shadow map with `opts`; an option out of its range is an error.
    pub fn new(opts: Options) -> Result<Vsm, Error> {
        let variable = opts.variable.then_some(Variable {
            light: opts.light,
            angle: opts.angle,
        });
        build(declaration(), &opts, &opts.filtering, variable, |d| {
            if opts.variable && opts.filtering.prefilter != super::Prefilter::Sat {
                return Err(d.error(
                    "variable",
                    "true",
                    format!(
                        "needs prefilter=sat (a box of any width per pixel), not prefilter={}",
                        opts.filtering.prefilter.as_str()
                    ),
                ));
            }
            Ok(Variance {
                storage: opts.filtering.storage,
                min_variance: opts.min_variance,
                slope_bias: opts.slope_bias,
                bleeding: opts.bleeding,
            })
        })
    }
}
