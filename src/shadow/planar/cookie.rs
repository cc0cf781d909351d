//! Projective shadow textures (light cookies, drop shadows; RTR 7.2 "Projection shadows";
//! Cournia section 3.1's projective texturing; Segal et al. 1992): the occluders' silhouette
//! is drawn from the light into a mask texture, which is projected onto the receivers like a
//! slide projector, darkening them where the mask is covered. No depth is stored, so:
//!
//! - occluders never shadow themselves or each other (they are not receivers);
//! - a receiver between the light and the occluders is darkened all the same ("shadows cast
//!   backward": the projection cannot tell in front from behind).
//!
//! Both failures are measured on the `cookie` fixture. The light views are the shadow map's
//! (orthographic for directional lights, the spot's cone, six cube faces for point lights, the
//! face picked by direction so no seams). Occluders: every non-planar object unless named.

use crate::choice_enum;
use crate::frame::Frame;
use crate::pipeline::sampler::{sample_bilinear, sample_nearest, Address};
use crate::pipeline::*;
use crate::shadow::inspect::{self, NoTrace, Step, Steps, Trace};
use crate::shadow::light::{light_views, LightView, Payload, ViewMaps};
use crate::shadow::pixels::per_pixel;
use crate::shadow::technique::{object_named, Declaration, Entry, Family, Field, ShadowTechnique, Stage, Visibility};
use crate::shadow::timing::Passes;
use crate::Error;
use glam::Vec4;

/// Registry entry (its options and constructor: `registry.rs`).
pub const ENTRY: Entry = Entry {
    name: "cookie",
    family: Family::Planar,
    summary: "projective shadow texture (RTR 7.2): occluder mask projected from the light; no self-shadowing, shadows cast backward",
    sweep: &[&[], &[("filter", "bilinear")]],
    ..Entry::BASE
};

/// Options of the projective shadow texture.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Comma-separated names of the objects drawn into the texture, or `auto`: every
    /// non-planar object; all others receive. Default: auto.
    pub occluders: String,
    /// Texture side in texels (per cube face for point lights). Default: 1024.
    pub size: u32,
    /// Mask filter. Default: nearest.
    pub filter: CookieFilter,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            occluders: "auto".into(),
            size: 1024,
            filter: CookieFilter::Nearest,
        }
    }
}

choice_enum! {
    /// How the mask is sampled.
    pub enum CookieFilter {
        /// The nearest texel: a hard edge.
        Nearest = "nearest",
        /// Bilinear: a one-texel soft edge, as cookies are usually sampled.
        Bilinear = "bilinear",
    }
}

/// The option declaration.
pub fn declaration() -> Declaration<Options> {
    Declaration::new(
        "cookie",
        vec![
            Field::new(
                "occluders",
                "comma-separated names of the objects drawn into the texture, or auto: every non-planar object; all others receive",
                |o: &mut Options| &mut o.occluders,
            ),
            Field::size("texture side in texels (per cube face for point lights)", |o: &mut Options| &mut o.size),
            Field::new(
                "filter",
                "nearest (hard edge) or bilinear (a one-texel soft edge, as cookies are usually sampled)",
                |o: &mut Options| &mut o.filter,
            ),
        ],
    )
}

/// The projective shadow texture technique (see the module docs).
pub struct Cookie {
    opts: Options,
    /// Last run: one mask and view per light view, and which objects occluded.
    masks: ViewMaps<Surface<f32>>,
    occluding: Vec<bool>,
    times: Vec<(&'static str, f64)>,
}

impl Cookie {
    /// A cookie with `opts`; an option out of its range is an error.
    pub fn new(opts: Options) -> Result<Cookie, Error> {
        declaration().check(&opts)?;
        Ok(Cookie {
            opts,
            masks: ViewMaps::default(),
            occluding: Vec::new(),
            times: Vec::new(),
        })
    }

    /// Which objects are occluders.
    fn pick(&self, frame: &Frame) -> Result<Vec<bool>, Error> {
        let objs = &frame.scene.objects;
        if self.opts.occluders == "auto" {
            return Ok(objs
                .iter()
                .map(|o| super::projected::plane_of(&o.mesh).is_none())
                .collect());
        }
        let mut pick = vec![false; objs.len()];
        for name in self.opts.occluders.split(',').map(str::trim) {
            let i = object_named(frame, "cookie", "occluders", name)?;
            pick[i] = true;
        }
        Ok(pick)
    }
}

impl Cookie {
    /// Pass 2 at one pixel: the mask projected onto the pixel's point.
    #[inline(always)]
    fn project(&self, frame: &Frame, x: usize, y: usize, t: &mut impl Trace) -> f32 {
        let w = frame.width() as usize;
        let Some(s) = frame.points()[y * w + x] else {
            return f32::NAN;
        };
        let obj = frame.gbuffer.object.data()[y * w + x] as usize;
        if self.occluding[obj] {
            t.step(|| {
                Step::new(
                    "occluder",
                    "the pixel's object is drawn into the mask, so it receives nothing: lit",
                )
                .text("object", frame.scene.objects[obj].name.clone())
            });
            return 1.0;
        }
        let Some(at) = self.masks.locate(&frame.light, s.position) else {
            t.step(|| Step::new("behind the light", "the point is behind the projector: lit"));
            return 1.0;
        };
        let (face, uv, inside) = (at.view, at.uv, at.inside());
        let m = &self.masks.get(face).0;
        t.step(|| {
            Step::new(
                "projection",
                "the point's texture coordinate in the light's mask (no depth is stored)",
            )
            .int("view", face)
            .vec2("uv", uv)
            .vec2("texel", uv * m.width() as f32)
            .flag("inside the mask", inside)
        });
        if !inside {
            return 1.0;
        }
        let covered = match self.opts.filter {
            CookieFilter::Bilinear => sample_bilinear(m, uv, Address::Clamp),
            CookieFilter::Nearest => sample_nearest(m, uv, Address::Clamp),
        };
        t.step(|| {
            Step::new(
                "mask",
                "coverage of the occluders at the texel; visibility = 1 - coverage",
            )
            .text("filter", self.opts.filter.as_str())
            .num("coverage", covered)
        });
        1.0 - covered
    }
}

/// The mask pass's payload: per view, 1 where an occluder covers the texel (no depth).
struct Coverage<'a> {
    frame: &'a Frame<'a>,
    size: u32,
    /// Per scene object: whether it occludes.
    occluding: &'a [bool],
}

impl Payload for Coverage<'_> {
    type Map = Surface<f32>;

    fn what(&self) -> &'static str {
        "the cookie's masks"
    }

    fn draw(
        &mut self,
        p: &Pipeline,
        _: usize,
        view: &LightView,
        _: Option<Surface<f32>>,
    ) -> Result<Surface<f32>, Error> {
        let mut mask = Surface::new(self.size, self.size, 0.0f32)?;
        for (o, _) in self.frame.scene.objects.iter().zip(self.occluding).filter(|(_, k)| **k) {
            p.draw(
                &mut Targets::color(&mut mask),
                &RenderState {
                    depth: DepthState {
                        func: CompareFunc::Always,
                        write: false,
                        ..Default::default()
                    },
                    ..Default::default()
                },
                &o.mesh.positions,
                &o.mesh.indices,
                &TransformPositions(view.matrix),
                &Shader(|_: &Fragment<()>| Vec4::ONE),
            )?;
        }
        Ok(mask)
    }
}

impl ShadowTechnique for Cookie {
    fn name(&self) -> &'static str {
        "cookie"
    }

    fn visibility(&mut self, p: &Pipeline, frame: &Frame) -> Result<Visibility, Error> {
        let mut passes = Passes::start();
        self.occluding = self.pick(frame)?;
        let size = self.opts.size;
        // Pass 1: the occluders' silhouette, 1 where covered (no depth).
        let mut coverage = Coverage {
            frame,
            size,
            occluding: &self.occluding,
        };
        self.masks.render(p, light_views(frame, size), size, &mut coverage)?;
        passes.end("mask pass");
        // Pass 2: project the mask onto every receiver pixel.
        let this = &*self;
        let out = per_pixel(p, frame, |x, y| this.project(frame, x, y, &mut NoTrace));
        passes.end("projection pass");
        self.times = passes.finish();
        Ok(Visibility::Scalar(out))
    }

    fn inspect(&self, frame: &Frame, x: u32, y: u32) -> Vec<Step> {
        let mut t = Steps::default();
        if self.masks.is_empty() {
            return t.0;
        }
        let v = self.project(frame, x as usize, y as usize, &mut t);
        t.0.push(inspect::result(v));
        t.0
    }

    fn timings(&self) -> Vec<(&'static str, f64)> {
        self.times.clone()
    }

    fn counters(&self) -> Vec<(&'static str, f64)> {
        vec![("occluders", self.occluding.iter().filter(|k| **k).count() as f64)]
    }

    fn stages(&self, _: &Pipeline, _: &Frame) -> Result<Vec<Stage>, Error> {
        Ok(self
            .masks
            .iter()
            .enumerate()
            .map(|(i, (m, _))| Stage::unit(format!("cookie{i}"), m.clone()))
            .collect())
    }
}
