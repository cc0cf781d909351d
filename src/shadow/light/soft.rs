//! The soft-shadow geometry of an area light seen from a receiver (Fernando 2005; RTR 7.6,
//! eq. 7.6 and fig. 7.25): the light's width, the blocker-search width and the penumbra
//! width, in world units and in a light view's texels. PCSS, contact-hardening shadows, the
//! penumbra volumes and the hybrid all measure their penumbrae with these.

use super::LightView;
use crate::frame::Frame;
use crate::math;
use crate::scene::LightKind;
use crate::shadow::options::Field;

/// The light's width for PCSS-style estimates: the scene's area light (a disk's or sphere's
/// diameter, a rectangle's mean side) times `scale`; `2 tan(angle / 2)` for a directional
/// light of angular diameter `angle` degrees; 0 for point and spot lights.
pub fn light_width(frame: &Frame, scale: f32, angle: f32) -> f32 {
    match frame.light.kind {
        LightKind::Area(shape) => shape.width() * scale,
        LightKind::Directional => 2.0 * math::tan(angle.to_radians() * 0.5),
        LightKind::Point | LightKind::Spot { .. } => 0.0,
    }
}

/// A width in world units at distance `d` from the light, in texels of `view`.
#[inline(always)]
pub fn texels(view: &LightView, world: f32, d: f32) -> f32 {
    if view.perspective() {
        world / (view.texel * d.max(1e-6))
    } else {
        world / view.texel
    }
}

/// The blocker search width in texels: the cone from a receiver at distance `d_r` to a light
/// of width `w` (directional: `2 tan(angle / 2)`), cut at the nearest caster `d_min`:
/// `w (d_r - d_min) / d_r` wide there.
#[inline(always)]
pub fn search_texels(view: &LightView, w: f32, d_r: f32, d_min: f32) -> f32 {
    if view.perspective() {
        texels(view, w * (d_r - d_min) / d_r.max(1e-6), d_min)
    } else {
        texels(view, (d_r - d_min) * w, d_r)
    }
}

/// RTR eq. 7.6, `w_penumbra = w_light (d_r - d_o) / d_o` (directional:
/// `(d_r - d_o) 2 tan(angle / 2)`), in texels at the receiver.
#[inline(always)]
pub fn penumbra_texels(view: &LightView, w: f32, d_r: f32, d_o: f32) -> f32 {
    if view.perspective() {
        texels(view, w * (d_r - d_o).max(0.0) / d_o.max(1e-6), d_r)
    } else {
        texels(view, (d_r - d_o).max(0.0) * w, d_r)
    }
}

/// A width of `texels` texels of `view` at distance `d` from the light, in world units (the
/// inverse of [`texels`]).
#[inline(always)]
pub fn world(view: &LightView, texels: f32, d: f32) -> f32 {
    let texel = if view.perspective() { view.texel * d } else { view.texel };
    texels * texel
}

/// The declaration of the light-size options of the PCSS-style techniques (`light`, `angle`)
/// at `light` and `angle`.
pub fn light_size_fields<O: Clone + Default + 'static>(
    light: fn(&mut O) -> &mut f32,
    angle: fn(&mut O) -> &mut f32,
) -> [Field<O>; 2] {
    [
        Field::range(
            "light",
            "the light's width as a multiple of the scene's area light (0: hard shadow)",
            0.0,
            1e3,
            light,
        ),
        Field::range(
            "angle",
            "directional lights: angular diameter in degrees (0: hard shadow)",
            0.0,
            90.0,
            angle,
        ),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Mat4;

    #[test]
    fn eq_7_6_in_texels_and_back() {
        for perspective in [false, true] {
            let view = LightView {
                matrix: Mat4::IDENTITY,
                texel: 0.01,
                kind: if perspective {
                    crate::shadow::light::ViewKind::Perspective
                } else {
                    crate::shadow::light::ViewKind::Ortho
                },
            };
            // A light 0.5 wide, a blocker at 2, a receiver at 6: the penumbra is
            // 0.5 * 4 / 2 = 1 world unit wide (perspective; orthographic: 4 * 0.5 = 2).
            let t = penumbra_texels(&view, 0.5, 6.0, 2.0);
            let w = world(&view, t, 6.0);
            let want = if perspective { 1.0 } else { 2.0 };
            assert!((w - want).abs() < 1e-5, "{perspective}: {w}");
            // No blocker between: no penumbra.
            assert_eq!(penumbra_texels(&view, 0.5, 2.0, 3.0), 0.0);
            // The search cone at the receiver itself is empty.
            assert_eq!(search_texels(&view, 0.5, 6.0, 6.0), 0.0);
        }
    }
}
