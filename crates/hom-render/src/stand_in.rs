//! An occluder's stand-in against its original: the stand-in as the cullers
//! draw it, the original as the renderer draws it. The check behind virtual
//! occluders' guarantee (Law & Tan 1999, section 4.1: a stand-in may hide
//! only what the original hides) and the coverage they keep.

use crate::{oracle_pixel_counts, Framebuffer, Renderer};
use glam::{Mat4, Vec3};
use hom::geom::{Aabb, Camera};
use hom::occluders::VirtualOccluder;
use hom::occlusion::{BufferOptions, FaceCull, HzBuffer, OcclusionBuffer, OcclusionError, Sampling};
use hom::scene::{Mesh, SceneBuilder};

/// Samples of one view: what each mesh covers alone, and where the stand-in
/// breaks the guarantee.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StandInComparison {
    /// Samples the original covers.
    pub original: u64,
    /// Samples the stand-in covers.
    pub stand_in: u64,
    /// Samples the stand-in covers where the original covers nothing or lies
    /// farther (0 is the guarantee).
    pub violations: u64,
}

impl std::ops::AddAssign for StandInComparison {
    fn add_assign(&mut self, o: StandInComparison) {
        self.original += o.original;
        self.stand_in += o.stand_in;
        self.violations += o.violations;
    }
}

impl StandInComparison {
    /// Stand-in ÷ original covered samples (1 when the original covers none).
    pub fn kept(&self) -> f64 {
        if self.original == 0 {
            1.0
        } else {
            self.stand_in as f64 / self.original as f64
        }
    }
}

/// Draws `original` alone with the renderer (the truth) and `stand_in`
/// alone as the cullers draw occluders (an exact-sampling z-buffer, the
/// stand-in set up by the inner rule: only samples the unsnapped triangle
/// covers, depth no nearer than its own), each placed by `transform`, seen
/// from `camera`, and compares them sample by sample.
pub fn compare_stand_in(
    renderer: &Renderer,
    original: &Mesh,
    stand_in: &Mesh,
    transform: Mat4,
    camera: &Camera,
) -> StandInComparison {
    compare(stand_in_depths(renderer, original, stand_in, transform, camera))
}

/// [`compare_stand_in`] for a virtual occluder, drawn as the cullers draw
/// it ([`VirtualOccluder::render`]: its boxes as their silhouettes).
pub fn compare_virtual_occluder(
    renderer: &Renderer,
    original: &Mesh,
    virtual_occluder: &VirtualOccluder,
    transform: Mat4,
    camera: &Camera,
) -> StandInComparison {
    compare(virtual_occluder_depths(
        renderer,
        original,
        virtual_occluder,
        transform,
        camera,
    ))
}

/// Counts the samples of the two depth images of [`stand_in_depths`].
fn compare((o, s): (Vec<f32>, Vec<f32>)) -> StandInComparison {
    let mut c = StandInComparison::default();
    for (&o, &s) in o.iter().zip(&s) {
        c.original += u64::from(o < 1.0);
        c.stand_in += u64::from(s < 1.0);
        c.violations += u64::from(s < 1.0 && (o >= 1.0 || s < o));
    }
    c
}

/// The two depth images [`compare_stand_in`] compares, row-major, 1.0 where
/// nothing is drawn: the original's as the renderer draws it, the stand-in's
/// as the cullers do.
pub fn stand_in_depths(
    renderer: &Renderer,
    original: &Mesh,
    stand_in: &Mesh,
    transform: Mat4,
    camera: &Camera,
) -> (Vec<f32>, Vec<f32>) {
    depths(renderer, original, transform, camera, |buffer, mvp| {
        buffer.render_stand_in_triangles(stand_in.positions(), stand_in.triangles(), mvp, FaceCull::None)
    })
}

/// [`stand_in_depths`] for a virtual occluder, drawn as the cullers draw it.
pub fn virtual_occluder_depths(
    renderer: &Renderer,
    original: &Mesh,
    virtual_occluder: &VirtualOccluder,
    transform: Mat4,
    camera: &Camera,
) -> (Vec<f32>, Vec<f32>) {
    depths(renderer, original, transform, camera, |buffer, mvp| {
        virtual_occluder.render(buffer, mvp)
    })
}

/// The original's depths as the renderer draws it, and what `draw` queues
/// in an exactly sampled z-buffer under the same placement.
fn depths(
    renderer: &Renderer,
    original: &Mesh,
    transform: Mat4,
    camera: &Camera,
    draw: impl FnOnce(&mut HzBuffer, &Mat4) -> Result<(), OcclusionError>,
) -> (Vec<f32>, Vec<f32>) {
    let mut b = SceneBuilder::new("stand-in check");
    let m = b.add_mesh(original.clone());
    let placed = b.add_object("object", m, transform);
    let mut fb = Framebuffer::new(camera.width, camera.height);
    if let Ok(scene) = placed.and_then(|_| b.build()) {
        oracle_pixel_counts(renderer, &scene, camera, &mut fb);
    }
    let mut drawn = Vec::new();
    // The cullers' buffers sample exactly; stand-ins go in conservatively.
    let exact = BufferOptions {
        sampling: Sampling::Exact,
        ..BufferOptions::default()
    };
    if let Ok(mut buffer) = HzBuffer::new(camera.width, camera.height, exact) {
        let mvp = camera.view_proj() * transform;
        if draw(&mut buffer, &mvp).is_ok() {
            buffer.zbuffer().to_row_major(&mut drawn);
        }
    }
    drawn.resize((camera.width * camera.height) as usize, f32::INFINITY);
    // The z-buffer's cleared depth is infinite; the renderer's is 1.0.
    let drawn = drawn
        .into_iter()
        .map(|d| if d.is_finite() && d < 1.0 { d } else { 1.0 })
        .collect();
    (fb.depth().to_vec(), drawn)
}

/// Six `side`×`side` views of `bounds` along the axes (±x, ±y, ±z), from
/// outside it, each framing the whole box.
pub fn axis_views(bounds: &Aabb, side: u32) -> [Camera; 6] {
    [Vec3::X, Vec3::NEG_X, Vec3::Y, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z].map(|axis| view_from(bounds, axis, side))
}

/// A `side` × `side` view of `bounds` from `direction` (from the box's
/// centre towards the eye, any length but zero), framing the box's
/// bounding sphere at a 40° field of view, as [`axis_views`] does.
pub fn view_from(bounds: &Aabb, direction: Vec3, side: u32) -> Camera {
    let centre = bounds.center();
    let radius = bounds.half_extent().length().max(1e-3);
    let fov = 40f32.to_radians();
    let distance = radius / (fov * 0.5).sin();
    let dir = direction.normalize_or(Vec3::Z);
    // Y up, unless the view looks along it.
    let up = if dir.cross(Vec3::Y).length() < 1e-3 {
        Vec3::Z
    } else {
        Vec3::Y
    };
    Camera::new(
        centre + dir * distance,
        centre,
        up,
        fov,
        (distance - radius) * 0.5,
        distance + radius * 2.0,
        side,
        side,
    )
}
