//! The four occlusion buffers as [`OccluderCuller`]'s buffers: each one's
//! name, options, worst hole and report, the friendly names of the cullers
//! over them ([`HomCuller`], [`HzbCuller`], [`MaskedCuller`], [`OtreeCuller`])
//! and of their settings, and each one's diagnostic accessors.

use super::depth_check::SampleDepthQuery;
use super::occluder_culler::{CullerBuffer, OccluderCuller, OccluderCullerConfig};
use super::CullStats;
use crate::geom::ScreenRect;
use crate::occlusion::details::setup::Tri;
use crate::occlusion::details::{find_worst_hole, worst_hole_of_coverage, Hole, Pyramid, SampleDepths, TiledZBuffer};
use crate::occlusion::{
    BufferOptions, HomBuffer, HzBuffer, MapOptions, MaskedBuffer, OcclusionBuffer, OcclusionError, OcclusionTree,
    DEFAULT_NODE_CAP,
};
use crate::occlusion::{RasterBackend, Threads};

/// The hierarchical occlusion map culler (Zhang et al. 1997): per frame,
/// select occluders → draw them into a [`HomBuffer`] (coverage, opacity
/// pyramid, depth estimation buffer or single Z plane) → traverse the BVH
/// front to back with frustum, depth and overlap tests.
///
/// # Conservative by default
/// With opacity threshold 1.0 (the default) a map pixel is opaque only when
/// every output-resolution sample under it is covered by occluder triangles,
/// rasterized with the reference renderer's exact sampling rule (pixel
/// centres, top-left fill, the same fixed-point snapping). An object is culled
/// only when every map pixel under its screen rectangle is opaque *and* its
/// nearest depth lies beyond the farthest occluder depth over that rectangle;
/// then every sample it could cover is covered by a nearer occluder triangle,
/// so it owns no pixel of the final image.
///
/// What breaks the guarantee: an opacity threshold below 1.0 (approximate
/// culling: it hides objects seen through small holes, on purpose); rendering
/// the final image at another resolution or with another sampling rule than
/// the camera the culler was given; occluder stand-in meshes that are not
/// contained in the object they stand for; and transparent occluders.
///
/// Statistics besides the shared ones: [`crate::occlusion::details::OverlapStats`] (the overlap
/// tests' work).
pub type HomCuller = OccluderCuller<HomBuffer>;

/// Settings of the HOM culler; its buffer options are the occlusion map's
/// (resolution, opacity thresholds, depth test).
pub type HomConfig = OccluderCullerConfig<MapOptions>;

/// The hierarchical Z-buffer culler (Greene, Kass and Miller 1993), as the
/// variation the HOM paper discusses in section 7.2 (Zhang et al. 1997): the
/// same occluder selection and BVH traversal as [`HomCuller`], but the
/// occlusion test uses a Z-pyramid of the occluders' per-sample depth instead
/// of occlusion maps plus a depth estimation buffer, so a comparison of the
/// two isolates the representation.
///
/// Per frame: select occluders → draw them into an [`HzBuffer`]: per-sample
/// depth in a tiled z-buffer (the renderer's own depth formula, `f32::INFINITY` where
/// uncovered; occluders hidden by nearer ones are rejected a tile or a block
/// at a time) with its pyramid of farthest depths above → traverse the BVH
/// front to back, culling a node or object when its screen rectangle is
/// behind the pyramid. (The row-major [`crate::occlusion::details::ZPyramid`] is the
/// reference the tiled buffer is tested against.)
///
/// # Conservative
/// A box is culled only when every sample of its rectangle holds an occluder
/// triangle nearer than the box's nearest depth (by [`crate::occlusion::details::DEPTH_MARGIN`]),
/// with the renderer's sampling and depth; boxes straddling the near plane are
/// never culled. The same caveats as HOM's apply (same resolution and sampling
/// as the final image, stand-ins contained in their objects, opaque occluders).
///
/// Hole filling (occluder selection's feedback) needs the opacity of screen
/// regions, which the Z-pyramid does not hold: when the selector asks for the
/// worst hole, an opacity pyramid is built from the last frame's depth
/// (covered = finite depth), with HOM's default geometry, and searched
/// ([`crate::occlusion::details::worst_hole_of_coverage`]).
pub type HzbCuller = OccluderCuller<HzBuffer>;

/// Settings of the HZB culler: the shared ones (its buffer has no options).
pub type HzbConfig = OccluderCullerConfig<()>;

/// The masked occlusion culler (masked software occlusion culling,
/// Hasselgren et al. 2016): [`HzbCuller`]'s pipeline over a [`MaskedBuffer`],
/// a coverage mask and two conservative depth layers per 32×8 tile, far
/// cheaper to draw than per-sample depth, coarser to test. Conservative, with
/// HZB's caveats; its hole filling searches the tiles' coverage as HZB's does.
pub type MaskedCuller = OccluderCuller<MaskedBuffer>;

/// Settings of the masked culler: the shared ones (its buffer has no options).
pub type MaskedConfig = OccluderCullerConfig<()>;

/// The occlusion-tree culler (Bittner, Havran and Slavík, "Hierarchical
/// visibility culling with occlusion trees", CGI 1998; the culler Bittner
/// and Havran 2002 measure their coherence methods with): the same occluder
/// selection, BVH traversal and coherence as [`HomCuller`] and
/// [`HzbCuller`], with the occluders' shadow frusta merged into an
/// [`OcclusionTree`] — an object-space representation beside the two
/// image-space ones, so a comparison of the three isolates the representation.
///
/// Per frame: select occluders → insert their triangles, nearest occluder
/// first, into the tree (a BSP of the image plane over their projected edges,
/// *in* leaves naming the covering triangle) → traverse the BVH front to
/// back, culling a node or object when the constrained depth-first search of
/// its screen rectangle finds it hidden in every leaf it reaches.
///
/// # Conservative
/// By construction: a leaf's region holds only samples its triangle covers
/// (exact fixed-point edge functions, the renderer's setup and fill rule),
/// and a rectangle is culled only when it lies beyond the triangle's farthest
/// depth over the samples that reach each leaf (by
/// [`crate::occlusion::details::DEPTH_MARGIN`]). The same caveats as HOM's apply (same
/// resolution and sampling as the final image, stand-ins contained in their
/// objects, opaque occluders).
///
/// Hole filling (occluder selection's feedback) needs the opacity of screen
/// regions, which the tree does not keep: as HZB does from its depth, an
/// opacity pyramid is built from the samples last frame's tree covered (its
/// *in* leaves' triangles, [`OcclusionTree::coverage_bits`]) and searched
/// ([`crate::occlusion::details::worst_hole_of_coverage`]).
///
/// Statistics besides the shared ones: [`crate::occlusion::TreeStats`], the tree's
/// size, the out leaves left out at the node cap, and the tests' classes.
pub type OtreeCuller = OccluderCuller<OcclusionTree>;

/// Settings of the occlusion-tree culler; its buffer options are the tree's size cap.
pub type OtreeConfig = OccluderCullerConfig<TreeOptions>;

/// The occlusion tree's own options in [`OtreeConfig`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TreeOptions {
    /// Most nodes of the tree; occluder triangles that do not fit are left out.
    pub node_cap: usize,
}

impl Default for TreeOptions {
    /// [`DEFAULT_NODE_CAP`].
    fn default() -> Self {
        TreeOptions {
            node_cap: DEFAULT_NODE_CAP,
        }
    }
}

/// The worst hole of the per-sample coverage mask `w` × `h` that `coverage`
/// writes, with HOM's default map geometry.
fn coverage_hole(w: u32, h: u32, hole_opacity: f32, coverage: impl FnOnce(&mut Vec<u64>)) -> Option<Hole> {
    let mut bits = Vec::new();
    coverage(&mut bits);
    worst_hole_of_coverage(&bits, w, h, &MapOptions::default(), hole_opacity)
}

impl CullerBuffer for HomBuffer {
    type Options = MapOptions;
    const NAME: &'static str = "hom";

    fn make(width: u32, height: u32, buffer: BufferOptions, map: &MapOptions) -> Result<Self, OcclusionError> {
        HomBuffer::with_map(width, height, buffer, map.clone())
    }

    fn worst_hole(&self, hole_opacity: f32) -> Option<Hole> {
        find_worst_hole(self.last_pyramid(), hole_opacity)
    }

    fn describe(c: &MapOptions) -> Vec<(&'static str, String)> {
        vec![
            ("map_size", c.map_size.to_string()),
            ("min_level_side", c.min_level_side.to_string()),
            ("opacity", format!("{:?}", c.opacity)),
            ("transparency", c.transparency.to_string()),
            ("depth", format!("{:?}", c.depth)),
        ]
    }

    fn frame_stats(&self, stats: &mut CullStats) {
        stats.map = Some(self.overlap_stats());
    }
}

impl CullerBuffer for HzBuffer {
    type Options = ();
    const NAME: &'static str = "hzb";

    fn make(width: u32, height: u32, buffer: BufferOptions, _: &()) -> Result<Self, OcclusionError> {
        HzBuffer::new(width, height, buffer)
    }

    fn worst_hole(&self, hole_opacity: f32) -> Option<Hole> {
        let zb = self.last_zbuffer();
        coverage_hole(zb.width(), zb.height(), hole_opacity, |bits| zb.coverage_bits(bits))
    }

    fn describe(_: &()) -> Vec<(&'static str, String)> {
        vec![("depth", "per-sample tiled z-buffer, pyramid of farthest depth".into())]
    }
}

impl CullerBuffer for MaskedBuffer {
    type Options = ();
    const NAME: &'static str = "masked";

    fn make(width: u32, height: u32, buffer: BufferOptions, _: &()) -> Result<Self, OcclusionError> {
        MaskedBuffer::new(width, height, buffer)
    }

    /// Counted from its tiles (`MaskedZBuffer::worst_hole`), without a
    /// per-sample mask or the finer levels: 0.10–0.15 ms a frame on the
    /// Quake 3 maps through the coverage bits.
    fn worst_hole(&self, hole_opacity: f32) -> Option<Hole> {
        self.last_zbuffer().worst_hole(&MapOptions::default(), hole_opacity)
    }

    fn describe(_: &()) -> Vec<(&'static str, String)> {
        vec![(
            "depth",
            "masked: coverage mask and two depth layers per 32x8 tile".into(),
        )]
    }
}

impl CullerBuffer for OcclusionTree {
    type Options = TreeOptions;
    const NAME: &'static str = "otree";

    fn make(width: u32, height: u32, buffer: BufferOptions, tree: &TreeOptions) -> Result<Self, OcclusionError> {
        OcclusionTree::new(width, height, buffer).map(|t| t.with_node_cap(tree.node_cap))
    }

    fn worst_hole(&self, hole_opacity: f32) -> Option<Hole> {
        coverage_hole(self.width(), self.height(), hole_opacity, |bits| {
            self.coverage_bits(bits)
        })
    }

    fn describe(tree: &TreeOptions) -> Vec<(&'static str, String)> {
        let tree = format!(
            "occlusion tree: 2D BSP of the occluders' projected edges, at most {} nodes",
            tree.node_cap
        );
        vec![("depth", tree)]
    }

    fn frame_stats(&self, stats: &mut CullStats) {
        stats.otree = Some(self.last_tree_stats());
    }
}

impl HomCuller {
    /// The last frame's occlusion pyramid (for pictures).
    pub fn pyramid(&self) -> Option<&Pyramid> {
        self.buffer().map(|b| b.last_pyramid())
    }
}

impl HzbCuller {
    /// The last frame's per-sample occluder depth and its pyramid.
    pub fn zbuffer(&self) -> Option<&TiledZBuffer> {
        self.buffer().map(|b| b.last_zbuffer())
    }
}

impl SampleDepthQuery for HomBuffer {
    /// Draws the occluders' depth lazily from the triangles the map drew
    /// ([`SampleDepths`]), the first time a frame asks.
    fn triangles_hidden(&mut self, tris: &[Tri], scratch: &mut SampleDepths, draw: bool) -> Option<bool> {
        if !scratch.is_begun() {
            if !draw {
                return None;
            }
            let (w, h) = (self.width(), self.height());
            let options = self.options();
            let (backend, parallel) = (
                options.backend.unwrap_or_else(RasterBackend::active),
                options.threads == Threads::Pool,
            );
            scratch.begin(w, h, self.drawn_triangles()?, backend, parallel);
        }
        Some(scratch.hidden(tris))
    }

    fn rect_is_covered(&mut self, r: &ScreenRect) -> bool {
        self.rect_is_opaque(r)
    }
}

impl SampleDepthQuery for HzBuffer {
    /// Asked of its own z-buffer, which holds every occluder's depth at every sample.
    fn triangles_hidden(&mut self, tris: &[Tri], _: &mut SampleDepths, _: bool) -> Option<bool> {
        Some(self.zbuffer().triangles_hidden(tris))
    }

    /// Every sample holds a finite depth: behind it lies the greatest float.
    fn rect_is_covered(&mut self, r: &ScreenRect) -> bool {
        let beyond_all = ScreenRect { z_near: f32::MAX, ..*r };
        self.zbuffer().is_behind(&beyond_all)
    }
}

impl SampleDepthQuery for MaskedBuffer {
    /// Asked of its own layers: per sample, the bound of its subtile's
    /// reference or working layer. Coarser than a depth per sample, so it
    /// culls no more than HZB's check, but it costs only its comparisons.
    fn triangles_hidden(&mut self, tris: &[Tri], _: &mut SampleDepths, _: bool) -> Option<bool> {
        Some(self.zbuffer().triangles_hidden(tris))
    }

    /// Every sample holds a finite bound: behind it lies the greatest float.
    fn rect_is_covered(&mut self, r: &ScreenRect) -> bool {
        let beyond_all = ScreenRect { z_near: f32::MAX, ..*r };
        self.zbuffer().is_behind(&beyond_all)
    }
}

/// No per-sample depth: never checked.
impl SampleDepthQuery for OcclusionTree {}
