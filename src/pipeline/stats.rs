//! What a draw did, counted ([`DrawStats`]).

/// Per-draw counters, for users exploring internals. Summed over draws with `+=`.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct DrawStats {
    /// Triangles submitted.
    pub triangles_in: u64,
    /// Triangles dropped for non-finite (NaN/inf) coordinates or a clip-space component
    /// beyond [`super::clip::MAX_CLIP_COORD`].
    pub dropped_nonfinite: u64,
    /// Triangles that needed clipping.
    pub clipped: u64,
    /// Triangles produced by clipping (fans of clipped polygons).
    pub clip_triangles_out: u64,
    /// Triangles culled by winding.
    pub culled_backface: u64,
    /// Triangles with zero area after snapping.
    pub culled_degenerate: u64,
    /// Triangles entirely outside the view or covering no pixel of the viewport.
    pub culled_outside: u64,
    /// Triangles that reached binning.
    pub triangles_setup: u64,
    /// (triangle, tile) pairs binned.
    pub bin_entries: u64,
    /// Pixels covered (fragments generated).
    pub fragments_rasterized: u64,
    /// Fragments killed by the early depth test (never shaded).
    pub early_z_killed: u64,
    /// Fragments failing the late depth test (after shading).
    pub depth_failed: u64,
    /// Fragments failing the stencil test.
    pub stencil_failed: u64,
    /// Fragment-program invocations.
    pub fragments_shaded: u64,
    /// Fragments that passed the depth test but were hidden by a later fragment of the same
    /// tile before shading ([`super::state::Shading::Deferred`]), so never shaded.
    pub fragments_hidden: u64,
    /// Fragments discarded by the program.
    pub fragments_discarded: u64,
    /// Fragments that passed every test (depth/stencil written, colour blended).
    pub fragments_passed: u64,
    /// Nodes appended to fragment lists.
    pub list_nodes: u64,
}

macro_rules! add_fields {
    ($s:ident, $o:ident; $($f:ident),*) => { $( $s.$f += $o.$f; )* };
}

impl std::ops::AddAssign for DrawStats {
    fn add_assign(&mut self, o: DrawStats) {
        add_fields!(self, o; triangles_in, dropped_nonfinite, clipped, clip_triangles_out, culled_backface,
            culled_degenerate, culled_outside, triangles_setup, bin_entries, fragments_rasterized,
            early_z_killed, depth_failed, stencil_failed, fragments_shaded, fragments_hidden, fragments_discarded,
            fragments_passed, list_nodes);
    }
}
