//! Fixed-function state of a draw: culling, raster mode, depth, stencil, polygon offset,
//! blending and write masks. Every mode is an enum; every default is documented and matches
//! the usual GPU default unless stated.

/// Which faces to discard before rasterization.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Default)]
pub enum CullMode {
    /// Draw both faces. (Default.)
    #[default]
    None,
    /// Discard back faces.
    Back,
    /// Discard front faces.
    Front,
}

impl CullMode {
    /// The mode's name as the CLI and exported workloads spell it.
    pub fn name(self) -> &'static str {
        match self {
            CullMode::None => "none",
            CullMode::Back => "back",
            CullMode::Front => "front",
        }
    }
}

impl std::fmt::Display for CullMode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for CullMode {
    type Err = UnknownChoice;
    fn from_str(s: &str) -> Result<Self, UnknownChoice> {
        let modes = [CullMode::None, CullMode::Back, CullMode::Front];
        parse_choice(s, "cull mode", &modes.map(|m| (m.name(), m)))
    }
}

/// A name that is none of a mode's choices; it prints as "unknown cull mode 'x' (expected
/// none, back or front)".
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UnknownChoice {
    /// What was being named ("cull mode").
    pub what: &'static str,
    /// The name given.
    pub given: String,
    /// The names there are.
    pub expected: Vec<&'static str>,
}

impl std::fmt::Display for UnknownChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let expected = match self.expected.split_last() {
            Some((last, [])) => last.to_string(),
            Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
            None => String::new(),
        };
        write!(f, "unknown {} '{}' (expected {expected})", self.what, self.given)
    }
}

impl std::error::Error for UnknownChoice {}

/// The value named `s` among `choices` (name, value), or why not ([`UnknownChoice`]).
pub fn parse_choice<T: Copy>(s: &str, what: &'static str, choices: &[(&'static str, T)]) -> Result<T, UnknownChoice> {
    if let Some(&(_, v)) = choices.iter().find(|(name, _)| *name == s) {
        return Ok(v);
    }
    Err(UnknownChoice {
        what,
        given: s.to_string(),
        expected: choices.iter().map(|(name, _)| *name).collect(),
    })
}

/// Which winding is the front face, seen in NDC (y up) as GL and D3D define it.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Default)]
pub enum FrontFace {
    /// Counter-clockwise triangles are front-facing. (Default.)
    #[default]
    Ccw,
    /// Clockwise triangles are front-facing.
    Cw,
}

/// Which pixels a triangle covers.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Default)]
pub enum RasterMode {
    /// Pixel centres inside the triangle, top-left fill rule. (Default.)
    #[default]
    Standard,
    /// Conservative overestimate: every pixel whose closed square touches the closed triangle.
    Overestimate,
    /// Conservative underestimate: only pixels whose closed square lies inside the closed triangle.
    Underestimate,
}

/// A comparison function, for depth and stencil tests: `incoming OP stored`.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Default)]
pub enum CompareFunc {
    /// Never passes.
    Never,
    /// Passes if incoming < stored. (Default for depth.)
    #[default]
    Less,
    /// Passes if incoming == stored.
    Equal,
    /// Passes if incoming <= stored.
    LessEqual,
    /// Passes if incoming > stored.
    Greater,
    /// Passes if incoming != stored.
    NotEqual,
    /// Passes if incoming >= stored.
    GreaterEqual,
    /// Always passes.
    Always,
}

impl CompareFunc {
    /// Evaluates `a OP b`.
    #[inline(always)]
    pub fn test<T: PartialOrd>(self, a: T, b: T) -> bool {
        match self {
            CompareFunc::Never => false,
            CompareFunc::Less => a < b,
            CompareFunc::Equal => a == b,
            CompareFunc::LessEqual => a <= b,
            CompareFunc::Greater => a > b,
            CompareFunc::NotEqual => a != b,
            CompareFunc::GreaterEqual => a >= b,
            CompareFunc::Always => true,
        }
    }

    /// [`CompareFunc::test`] on four lanes (same NaN behaviour: only `NotEqual` and `Always`
    /// pass a NaN).
    #[inline(always)]
    pub fn test4(self, a: glam::Vec4, b: glam::Vec4) -> glam::BVec4A {
        match self {
            CompareFunc::Never => glam::BVec4A::FALSE,
            CompareFunc::Less => a.cmplt(b),
            CompareFunc::Equal => a.cmpeq(b),
            CompareFunc::LessEqual => a.cmple(b),
            CompareFunc::Greater => a.cmpgt(b),
            CompareFunc::NotEqual => a.cmpne(b),
            CompareFunc::GreaterEqual => a.cmpge(b),
            CompareFunc::Always => glam::BVec4A::TRUE,
        }
    }
}

/// How a depth value is stored: the precision a shadow map has.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Default)]
pub enum DepthFormat {
    /// 32-bit float. (Default.)
    #[default]
    F32,
    /// 24-bit normalized integer (stored quantized as `f32`).
    Unorm24,
    /// 16-bit normalized integer (stored quantized as `f32`).
    Unorm16,
}

impl DepthFormat {
    /// Rounds a depth in [0, 1] to the format's precision.
    #[inline(always)]
    pub fn quantize(self, z: f32) -> f32 {
        match self {
            DepthFormat::F32 => z,
            DepthFormat::Unorm24 => ((z as f64 * 16_777_215.0).round() / 16_777_215.0) as f32,
            DepthFormat::Unorm16 => (z * 65535.0).round() / 65535.0,
        }
    }

    /// The minimum resolvable depth difference `r` of glPolygonOffset for a triangle whose
    /// largest depth is `max_z` (D3D rules: 2^(exponent(max_z) - 23) for float, 1/2^n for unorm).
    pub fn resolvable(self, max_z: f32) -> f32 {
        match self {
            DepthFormat::F32 => {
                let m = max_z.abs().max(f32::MIN_POSITIVE);
                let e = ((m.to_bits() >> 23) & 0xff) as i32 - 127;
                // 2^(e - 23), built from its exponent bits (no powi call per triangle).
                let be = e - 23 + 127;
                if be > 0 {
                    f32::from_bits((be as u32) << 23)
                } else {
                    2f32.powi(e - 23)
                }
            }
            DepthFormat::Unorm24 => 1.0 / 16_777_216.0,
            DepthFormat::Unorm16 => 1.0 / 65536.0,
        }
    }
}

/// Depth test, write and clamp.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct DepthState {
    /// Compare function; `Always` disables the test. Default: `Less`.
    pub func: CompareFunc,
    /// Write passing depths. Default: `true`.
    pub write: bool,
    /// Depth clamp: no far-plane clipping; fragment depth clamped to [0, 1]. Default: `false`.
    /// (Near-plane clipping always happens.)
    pub clamp: bool,
    /// Storage precision of written and compared depths. Default: `F32`.
    pub format: DepthFormat,
}

impl Default for DepthState {
    fn default() -> Self {
        DepthState {
            func: CompareFunc::Less,
            write: true,
            clamp: false,
            format: DepthFormat::F32,
        }
    }
}

/// What a stencil update does to the stored value.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Default)]
pub enum StencilOp {
    /// Leave it. (Default.)
    #[default]
    Keep,
    /// Set to 0.
    Zero,
    /// Set to the reference value.
    Replace,
    /// Add 1, saturating at 255.
    IncrSat,
    /// Subtract 1, saturating at 0.
    DecrSat,
    /// Add 1, wrapping 255 to 0.
    IncrWrap,
    /// Subtract 1, wrapping 0 to 255.
    DecrWrap,
    /// Bitwise invert.
    Invert,
}

impl StencilOp {
    /// The op as a wrapping addition, when it is one (`Keep` 0, `IncrWrap` 1, `DecrWrap` 255):
    /// the shadow-volume ops, which the fragment stage then runs branch-free.
    #[inline]
    pub fn wrapping_delta(self) -> Option<u8> {
        match self {
            StencilOp::Keep => Some(0),
            StencilOp::IncrWrap => Some(1),
            StencilOp::DecrWrap => Some(255),
            _ => None,
        }
    }

    /// Applies the op to `s` with reference `r`.
    #[inline(always)]
    pub fn apply(self, s: u8, r: u8) -> u8 {
        match self {
            StencilOp::Keep => s,
            StencilOp::Zero => 0,
            StencilOp::Replace => r,
            StencilOp::IncrSat => s.saturating_add(1),
            StencilOp::DecrSat => s.saturating_sub(1),
            StencilOp::IncrWrap => s.wrapping_add(1),
            StencilOp::DecrWrap => s.wrapping_sub(1),
            StencilOp::Invert => !s,
        }
    }
}

/// Stencil test and ops for one face.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct StencilFace {
    /// `(ref & read_mask) FUNC (stored & read_mask)`. Default: `Always`.
    pub func: CompareFunc,
    /// Op when the stencil test fails. Default: `Keep`.
    pub fail: StencilOp,
    /// Op when the stencil test passes and the depth test fails. Default: `Keep`.
    pub depth_fail: StencilOp,
    /// Op when both pass. Default: `Keep`.
    pub pass: StencilOp,
}

impl Default for StencilFace {
    fn default() -> Self {
        StencilFace {
            func: CompareFunc::Always,
            fail: StencilOp::Keep,
            depth_fail: StencilOp::Keep,
            pass: StencilOp::Keep,
        }
    }
}

/// Two-sided stencil state.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct StencilState {
    /// Stencil test and ops on at all. Default: `false`.
    pub enabled: bool,
    /// Ops for front-facing triangles. Default: [`StencilFace::default`].
    pub front: StencilFace,
    /// Ops for back-facing triangles. Default: [`StencilFace::default`].
    pub back: StencilFace,
    /// Reference value. Default: 0.
    pub reference: u8,
    /// Mask applied to reference and stored value before the compare. Default: 0xff.
    pub read_mask: u8,
    /// Bits the ops may change. Default: 0xff.
    pub write_mask: u8,
}

impl Default for StencilState {
    fn default() -> Self {
        StencilState {
            enabled: false,
            front: StencilFace::default(),
            back: StencilFace::default(),
            reference: 0,
            read_mask: 0xff,
            write_mask: 0xff,
        }
    }
}

/// glPolygonOffset: `offset = factor * max|dz/dx, dz/dy| + units * r`, added to fragment depth.
#[derive(Copy, Clone, Debug, PartialEq, Default)]
pub struct PolygonOffset {
    /// Slope-scaled factor. Default: 0.
    pub factor: f32,
    /// Constant, in units of the depth format's minimum resolvable difference. Default: 0.
    pub units: f32,
}

/// How the fragment's colour combines with the stored colour (`s` source, `d` destination).
#[derive(Copy, Clone, Debug, PartialEq, Eq, Default)]
pub enum BlendMode {
    /// `s`. (Default.)
    #[default]
    Replace,
    /// `s + d`.
    Add,
    /// `s * s.a + d * (1 - s.a)`, alpha channel `s.a + d.a * (1 - s.a)`.
    Alpha,
    /// `s * d`.
    Multiply,
    /// `min(s, d)`.
    Min,
    /// `max(s, d)`.
    Max,
}

/// Which colour channels are written.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct ColorMask(pub [bool; 4]);

impl Default for ColorMask {
    /// All four channels.
    fn default() -> Self {
        ColorMask([true; 4])
    }
}

/// When the fragment program runs for a draw that it would otherwise run for every fragment
/// passing the depth test.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Default)]
pub enum Shading {
    /// Hidden surface removal before shading, where it gives the same image: per tile and
    /// batch, every triangle is depth-tested first and the program then runs once per pixel
    /// for the fragment that stays visible (tile-based deferred shading, as PowerVR, Apple and
    /// Mali hardware do). Taken for draws with a colour target, `Replace` blending, a 32-bit
    /// float depth target with `Less` or `LessEqual`, no stencil, no fragment lists and a
    /// program that cannot discard; other draws shade immediately. Images, depth and every
    /// counter but [`crate::pipeline::DrawStats::fragments_shaded`] and
    /// [`crate::pipeline::DrawStats::fragments_hidden`] equal `Immediate`'s. (Default.)
    #[default]
    Deferred,
    /// The program runs for every fragment that passes the depth test, in submission order.
    Immediate,
}

impl std::str::FromStr for Shading {
    type Err = UnknownChoice;
    fn from_str(s: &str) -> Result<Self, UnknownChoice> {
        parse_choice(
            s,
            "shading",
            &[("deferred", Shading::Deferred), ("immediate", Shading::Immediate)],
        )
    }
}

/// All fixed-function state of one draw.
#[derive(Copy, Clone, Debug, PartialEq, Default)]
pub struct RenderState {
    /// Face culling. Default: `None`.
    pub cull: CullMode,
    /// Front-face winding. Default: `Ccw`.
    pub front_face: FrontFace,
    /// Coverage rule. Default: `Standard`.
    pub raster: RasterMode,
    /// Depth test. Default: [`DepthState::default`].
    pub depth: DepthState,
    /// Stencil. Default: disabled.
    pub stencil: StencilState,
    /// Polygon offset. Default: none.
    pub offset: PolygonOffset,
    /// Blending. Default: `Replace`.
    pub blend: BlendMode,
    /// Colour write mask. Default: all channels.
    pub color_mask: ColorMask,
    /// When programs run. Default: `Deferred` (hidden surface removal where it is exact).
    pub shading: Shading,
}

impl RenderState {
    /// Every fragment added into the colour target: no depth test or depth write, depth
    /// clamp on (nothing is clipped at the far plane), additive blending. Counting passes
    /// (fragments per pixel) and accumulation passes (optical depth per slice) draw with it.
    pub fn accumulate() -> RenderState {
        RenderState {
            depth: DepthState {
                func: CompareFunc::Always,
                write: false,
                clamp: true,
                ..Default::default()
            },
            blend: BlendMode::Add,
            ..Default::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resolvable_is_two_to_the_exponent_minus_23() {
        for z in [1.0f32, 0.999, 0.5, 0.25, 0.3, 1e-3, 1e-30, 0.0] {
            let m = z.abs().max(f32::MIN_POSITIVE);
            let e = ((m.to_bits() >> 23) & 0xff) as i32 - 127;
            assert_eq!(DepthFormat::F32.resolvable(z), 2f32.powi(e - 23), "z = {z}");
        }
        assert_eq!(DepthFormat::Unorm16.resolvable(0.5), 1.0 / 65536.0);
    }

    #[test]
    fn cull_modes_parse_their_names_and_reject_others() {
        for m in [CullMode::None, CullMode::Back, CullMode::Front] {
            assert_eq!(m.name().parse::<CullMode>(), Ok(m));
            assert_eq!(m.to_string(), m.name());
        }
        let e = "sideways".parse::<CullMode>().unwrap_err().to_string();
        assert!(e.contains("sideways") && e.contains("none, back or front"), "{e}");
    }

    #[test]
    fn choices_parse_their_names_and_errors_list_them() {
        assert_eq!("immediate".parse::<Shading>(), Ok(Shading::Immediate));
        assert_eq!(
            "lazy".parse::<Shading>().unwrap_err().to_string(),
            "unknown shading 'lazy' (expected deferred or immediate)"
        );
        assert_eq!(
            parse_choice("b", "letter", &[("a", 1)]).unwrap_err().to_string(),
            "unknown letter 'b' (expected a)"
        );
    }
}
