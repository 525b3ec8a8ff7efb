//! The per-sample depth check, after the traversal: each object the
//! traversal left visible whose rectangle the occluders cover (depth aside)
//! is asked again with its own triangles against the occluders' depth at
//! every sample ([`SampleDepths`]), and culled when it lies behind them at
//! every sample it covers. Every other frame, an object drawn in the frame
//! before is not checked ([`DepthChecker::run`]).
//!
//! Why: an object close behind its hider passes the coverage test and fails
//! the box's depth test — its box's nearest corner is nearer than its
//! surface, and a cell's farthest cover varies with a sloped hider by more
//! than the gap. Most are this frame's own occluders, large on screen; on
//! the Quake 3 maps they were most of what HOM drew beyond the oracle's set
//! (`docs/decisions/occluders.md`, "The per-sample depth check").
//!
//! # Conservative
//! The object's triangles are set up exactly as the renderer sets them up
//! (the same vertex transform, [`object_to_clip`], clipping, snapping and
//! fill rule) and compared with the renderer's depth formula; the occluders
//! are the triangles the buffer drew (the renderer's rule for originals;
//! the inner rule, covering fewer samples and no nearer, for stand-ins,
//! which lie inside their objects), or, in the masked buffer, a bound its
//! layers hold for every occluder sample of a subtile (the same bounds its
//! box test trusts). So at every sample the object covers, an occluder's
//! surface lies nearer by [`DEPTH_MARGIN`]. Following "hidden
//! by" from a culled object reaches, depth falling strictly at every step,
//! the nearest occluder at that sample, which no test can cull: an object
//! it hides owns no pixel. The same caveats as the box tests apply (the
//! image at the buffer's resolution and sampling, opaque occluders).
//!
//! [`DEPTH_MARGIN`]: crate::occlusion::details::DEPTH_MARGIN

use super::coherence::{TemporalState, Vis};
use super::DepthCheckStats;
use crate::geom::{object_to_clip, project_points, Footprint, ScreenRect};
use crate::occlusion::details::setup::{Tri, Viewport};
use crate::occlusion::details::setup_triangles;
use crate::occlusion::details::SampleDepths;
use crate::occlusion::RasterBackend;
use crate::scene::Scene;
use glam::{Mat4, Vec4};

/// Objects with more triangles than this are not checked: setting them up
/// costs more than the check saves. The clusters real levels are cut into
/// have at most 64.
pub const DEPTH_CHECK_MAX_TRIANGLES: u32 = 256;

/// Where an occluder culler runs the per-sample depth check (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum DepthCheck {
    /// Never.
    Off,
    /// Where the buffer already holds the occluders' depth at every sample
    /// (HZB) or a bound of it (masked: its subtiles' layers), so the check
    /// costs only its comparisons. The default: on the Quake 3 maps it takes
    /// the masked culler's efficiency from 54–90 % to 72–97 %, and moves no
    /// built-in scene beyond noise (`docs/decisions/occluders.md`).
    #[default]
    IfDrawn,
    /// Also where the buffer does not (HOM, which then draws its occluders'
    /// depth for it with HZB's rasterizer: 1.2–1.5 ms on the Quake 3 maps,
    /// more than the check saves there today).
    On,
}

impl std::fmt::Display for DepthCheck {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            DepthCheck::Off => "off",
            DepthCheck::IfDrawn => "if-drawn",
            DepthCheck::On => "on",
        })
    }
}

/// What the per-sample depth check asks of an occluder culler's buffer
/// (a part of [`super::CullerBuffer`]). Both answers have defaults: a
/// buffer that cannot tell is never checked.
pub trait SampleDepthQuery {
    /// Whether `tris` (set up for this frame's viewport by the renderer's
    /// rule) lie behind the occluders drawn at every sample they cover: the
    /// per-sample depth check (`depth_check.rs`). A buffer without
    /// per-sample depth draws it into `scratch` (reset each frame) on first
    /// use, when `draw` allows ([`DepthCheck::On`]). `None` (the default),
    /// and no check, for a buffer that cannot tell.
    fn triangles_hidden(&mut self, _tris: &[Tri], _scratch: &mut SampleDepths, _draw: bool) -> Option<bool> {
        None
    }

    /// Whether the occluders drawn cover every sample of `r`, depth aside:
    /// where the per-sample depth check may cull. `true` by default.
    fn rect_is_covered(&mut self, _r: &ScreenRect) -> bool {
        true
    }
}

/// The check's scratch, kept across frames.
#[derive(Default)]
pub(crate) struct DepthChecker {
    /// Whether buffers without per-sample depth draw it for the check ([`DepthCheck::On`]).
    draw: bool,
    depths: SampleDepths,
    /// The checked object's vertices in clip space.
    vertices: Vec<Vec4>,
    tris: Vec<Tri>,
    hidden: Vec<u32>,
    /// Frames checked so far (calls of [`DepthChecker::run`]).
    frames: u64,
    /// Per object id, the last checked frame (`frames` then) that drew it.
    drawn_in: Vec<u64>,
}

impl DepthChecker {
    /// The check as `mode` asks; `None` when off.
    pub fn new(mode: DepthCheck) -> Option<DepthChecker> {
        (mode != DepthCheck::Off).then(|| DepthChecker {
            draw: mode == DepthCheck::On,
            ..DepthChecker::default()
        })
    }

    /// Bytes held on the heap.
    pub fn heap_bytes(&self) -> usize {
        self.depths.heap_bytes()
            + crate::vec_bytes(&self.vertices)
            + crate::vec_bytes(&self.tris)
            + crate::vec_bytes(&self.hidden)
            + crate::vec_bytes(&self.drawn_in)
    }

    /// Checks the objects of `visible` (ascending) against `buffer`'s
    /// occluders, drawn this frame through `world_to_clip` into a `width` ×
    /// `height` viewport; moves those hidden at every sample to `occluded`
    /// (ascending) and tells `temporal`. `None` when the buffer cannot tell
    /// (no per-sample depth, and `draw` off or no occluder triangles kept).
    ///
    /// **Rest.** On every second frame checked, an object drawn in the frame
    /// checked before is not checked: it stays visible (always safe). Most
    /// checks find their object visible, and it usually still is a frame
    /// later (oa_shouse, masked: 226 checks a frame, 35 culled). The
    /// schedule depends on the frame and on what was drawn, not on what the
    /// check found, so that a culler that draws more (skip coherence: what
    /// exact coherence draws and more) rests at least the same objects and
    /// never culls what the other draws.
    #[allow(clippy::too_many_arguments)]
    pub fn run<B: SampleDepthQuery>(
        &mut self,
        scene: &Scene,
        buffer: &mut B,
        (world_to_clip, width, height): (Mat4, u32, u32),
        visible: &mut Vec<u32>,
        occluded: &mut Vec<u32>,
        temporal: &mut TemporalState,
    ) -> Option<DepthCheckStats> {
        let viewport = Viewport::new(width, height);
        let mut stats = DepthCheckStats::default();
        self.depths.reset();
        self.hidden.clear();
        self.frames += 1;
        let resting = self.frames.is_multiple_of(2);
        if self.drawn_in.len() < scene.objects().len() {
            self.drawn_in.resize(scene.objects().len(), 0);
        }
        for &id in visible.iter() {
            let o = scene.object(id);
            if o.triangles > DEPTH_CHECK_MAX_TRIANGLES || o.is_removed() {
                continue;
            }
            let straddles = match project_points(&o.test_corners(), &world_to_clip, width, height) {
                Footprint::Rect(r) if !buffer.rect_is_covered(&r) => continue,
                Footprint::Rect(_) => false,
                Footprint::Straddles => true,
            };
            if resting && self.drawn_in[id as usize] == self.frames - 1 {
                stats.rested += 1;
                continue;
            }
            let mesh = scene.mesh_of(o);
            self.vertices.clear();
            self.vertices.extend(
                mesh.positions()
                    .iter()
                    .map(|&p| object_to_clip(&world_to_clip, &o.transform, p)),
            );
            self.tris.clear();
            let backend = RasterBackend::active();
            setup_triangles(backend, &self.vertices, mesh.triangles(), &viewport, id, &mut self.tris);
            // A box across the near plane has no rectangle: its triangles' bounds stand in.
            if straddles && !self.tris.is_empty() && !buffer.rect_is_covered(&bounds(&self.tris)) {
                continue;
            }
            stats.checked += 1;
            if buffer.triangles_hidden(&self.tris, &mut self.depths, self.draw)? {
                self.hidden.push(id);
            }
        }
        let s = self.depths.stats();
        stats.culled = self.hidden.len() as u64;
        if self.depths.is_begun() {
            stats.tiles_drawn = s.tiles_drawn;
        }
        if !self.hidden.is_empty() {
            let hidden = &self.hidden;
            visible.retain(|id| hidden.binary_search(id).is_err());
            occluded.extend_from_slice(hidden);
            occluded.sort_unstable();
            for &id in hidden {
                temporal.set_object(id, Vis::Invisible);
            }
        }
        for &id in visible.iter() {
            self.drawn_in[id as usize] = self.frames;
        }
        Some(stats)
    }
}

/// The samples `tris` (not empty) may cover.
fn bounds(tris: &[Tri]) -> ScreenRect {
    let mut r = ScreenRect {
        x0: u32::MAX,
        y0: u32::MAX,
        x1: 0,
        y1: 0,
        z_near: 0.0,
        z_far: 1.0,
    };
    for t in tris {
        r.x0 = r.x0.min(u32::from(t.x0));
        r.y0 = r.y0.min(u32::from(t.y0));
        r.x1 = r.x1.max(u32::from(t.x1));
        r.y1 = r.y1.max(u32::from(t.y1));
    }
    r
}
