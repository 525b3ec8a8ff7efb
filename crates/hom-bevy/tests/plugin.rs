//! The plugin in a headless `App` (no window, no GPU): its systems over
//! transforms, meshes and visibility. What it removes is checked against
//! brute-force ray casting through every sample of its buffer.

use bevy::app::App;
use bevy::asset::{AssetApp, Assets, Handle};
use bevy::camera::primitives::Aabb;
use bevy::camera::visibility::{Visibility, VisibleEntities};
use bevy::camera::{Camera3d, PerspectiveProjection, Projection};
use bevy::ecs::prelude::*;
use bevy::image::Image;
use bevy::math::primitives::Cuboid;
use bevy::math::{Mat4, UVec2, Vec3, Vec4};
use bevy::mesh::{Mesh, Mesh3d};
use bevy::prelude::Transform;
use hom_bevy::{
    BufferKind, NeverOccluder, Occluder, OcclusionCulling, OcclusionDebugView, OcclusionScene, OcclusionSettings,
    OcclusionStats,
};
use std::any::TypeId;

mod common;
use common::app;

const BUFFERS: [BufferKind; 3] = [BufferKind::Hom, BufferKind::Hzb, BufferKind::Masked];

fn camera(app: &mut App, buffer: BufferKind, eye: Vec3, target: Vec3, resolution: UVec2) -> Entity {
    app.world_mut()
        .spawn((
            Camera3d::default(),
            Projection::Perspective(PerspectiveProjection {
                aspect_ratio: resolution.x as f32 / resolution.y as f32,
                ..Default::default()
            }),
            Transform::from_translation(eye).looking_at(target, Vec3::Y),
            OcclusionCulling {
                buffer,
                resolution: Some(resolution),
                ..Default::default()
            },
        ))
        .id()
}

fn cuboid(app: &mut App, size: Vec3) -> Handle<Mesh> {
    app.world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(Cuboid::new(size.x, size.y, size.z))
}

fn spawn(app: &mut App, mesh: &Handle<Mesh>, at: Vec3) -> Entity {
    app.world_mut()
        .spawn((Mesh3d(mesh.clone()), Transform::from_translation(at)))
        .id()
}

fn visible(app: &App, camera: Entity) -> Vec<Entity> {
    app.world()
        .get::<VisibleEntities>(camera)
        .expect("a camera has VisibleEntities")
        .get(TypeId::of::<Mesh3d>())
        .to_vec()
}

/// A wall across the view, a box behind it, one in front of it and one beside it.
struct WallScene {
    camera: Entity,
    wall: Entity,
    behind: Entity,
    front: Entity,
    beside: Entity,
}

fn wall_scene(app: &mut App, buffer: BufferKind) -> WallScene {
    let camera = camera(app, buffer, Vec3::ZERO, Vec3::NEG_Z, UVec2::new(128, 96));
    let wall_mesh = cuboid(app, Vec3::new(40.0, 30.0, 1.0));
    let small = cuboid(app, Vec3::splat(1.0));
    WallScene {
        camera,
        wall: spawn(app, &wall_mesh, Vec3::new(0.0, 0.0, -10.0)),
        behind: spawn(app, &small, Vec3::new(0.5, 0.0, -20.0)),
        front: spawn(app, &small, Vec3::new(-0.5, 0.0, -5.0)),
        beside: spawn(app, &small, Vec3::new(30.0, 0.0, -40.0)),
    }
}

#[test]
fn a_wall_hides_what_is_behind_it_and_nothing_else() {
    for buffer in BUFFERS {
        let mut app = app();
        let s = wall_scene(&mut app, buffer);
        app.update();
        let seen = visible(&app, s.camera);
        // `beside` is out of the view's 45° field: bevy culls it, the plugin never adds it.
        assert_eq!(seen, sorted(vec![s.wall, s.front]), "{buffer:?}");
        let stats = app.world().resource::<OcclusionStats>().cameras[&s.camera];
        assert_eq!((stats.tested, stats.occluded), (3, 1), "{buffer:?}: {stats:?}");
        assert!(
            stats.occluders >= 1 && stats.resolution == (128, 96),
            "{buffer:?}: {stats:?}"
        );
        let _ = s.beside;
    }
}

#[test]
fn a_camera_without_occlusion_culling_keeps_what_bevy_keeps() {
    let mut app = app();
    let s = wall_scene(&mut app, BufferKind::Masked);
    let plain = app
        .world_mut()
        .spawn((
            Camera3d::default(),
            Transform::from_xyz(0.0, 0.0, 0.0).looking_at(Vec3::NEG_Z, Vec3::Y),
        ))
        .id();
    app.update();
    assert_eq!(visible(&app, plain), sorted(vec![s.wall, s.behind, s.front]));
    assert_eq!(visible(&app, s.camera), sorted(vec![s.wall, s.front]));
    // Taking the component away gives the camera bevy's list back.
    app.world_mut().entity_mut(s.camera).remove::<OcclusionCulling>();
    app.update();
    assert_eq!(visible(&app, s.camera), sorted(vec![s.wall, s.behind, s.front]));
    assert!(!app.world().resource::<OcclusionStats>().cameras.contains_key(&s.camera));
}

#[test]
fn a_hidden_wall_a_wall_marked_never_and_a_despawned_wall_occlude_nothing() {
    type Change = fn(&mut App, Entity);
    let changes: [(&str, Change); 4] = [
        ("hidden", |app, wall| {
            app.world_mut().entity_mut(wall).insert(Visibility::Hidden);
        }),
        ("never", |app, wall| {
            app.world_mut().entity_mut(wall).insert(NeverOccluder);
        }),
        ("despawned", |app, wall| {
            app.world_mut().entity_mut(wall).despawn();
        }),
        ("moved away", |app, wall| {
            app.world_mut().get_mut::<Transform>(wall).unwrap().translation.x = 100.0;
        }),
    ];
    for (what, change) in changes {
        let mut app = app();
        let s = wall_scene(&mut app, BufferKind::Masked);
        app.update();
        assert!(!visible(&app, s.camera).contains(&s.behind), "{what}: culled before");
        let object = app.world().resource::<OcclusionScene>().object_of(s.wall);
        change(&mut app, s.wall);
        app.update();
        if what == "hidden" || what == "never" {
            // A change of role keeps the entity's object: only its occluder flag changes.
            assert_eq!(
                app.world().resource::<OcclusionScene>().object_of(s.wall),
                object,
                "{what}"
            );
        }
        let seen = visible(&app, s.camera);
        assert!(seen.contains(&s.behind) && seen.contains(&s.front), "{what}: {seen:?}");
    }
}

#[test]
fn only_marked_occluders_occlude_when_asked_and_a_stand_in_draws_in_their_place() {
    let mut app = app();
    app.insert_resource(OcclusionSettings { auto_occluders: false });
    let s = wall_scene(&mut app, BufferKind::Masked);
    app.update();
    assert!(visible(&app, s.camera).contains(&s.behind), "no occluder is marked");
    // The wall marked, drawn as a stand-in 4 m wide (x -2..2 at 10 m): it
    // hides what lies behind x -1..1 at 20 m.
    let stand_in = cuboid(&mut app, Vec3::new(4.0, 4.0, 1.0));
    app.world_mut().entity_mut(s.wall).insert(Occluder {
        stand_in: Some(stand_in.clone()),
    });
    let small = cuboid(&mut app, Vec3::splat(0.5));
    let left = spawn(&mut app, &small, Vec3::new(-0.5, 0.0, -20.0));
    let right = spawn(&mut app, &small, Vec3::new(1.5, 0.0, -20.0));
    let outside = spawn(&mut app, &small, Vec3::new(5.0, 0.0, -20.0));
    app.update();
    let seen = visible(&app, s.camera);
    assert!(
        !seen.contains(&left) && !seen.contains(&right),
        "behind the stand-in: {seen:?}"
    );
    assert!(seen.contains(&outside), "past the stand-in, behind the wall: {seen:?}");
    // Moved left by 2 m the stand-in spans x -4..0: it still hides `left`
    // (x -0.375..-0.125 at 10 m), no longer `right` (0.625..0.875).
    app.world_mut()
        .entity_mut(s.wall)
        .insert(Transform::from_xyz(-2.0, 0.0, -10.0));
    app.update();
    let seen = visible(&app, s.camera);
    assert!(!seen.contains(&left), "the stand-in moved with its entity: {seen:?}");
    assert!(seen.contains(&right), "the stand-in moved with its entity: {seen:?}");
}

#[test]
fn a_mesh_that_loads_later_takes_part_once_loaded() {
    let mut app = app();
    let s = wall_scene(&mut app, BufferKind::Hzb);
    let late: Handle<Mesh> = app.world().resource::<Assets<Mesh>>().reserve_handle();
    app.world_mut().entity_mut(s.wall).insert(Mesh3d(late.clone()));
    app.update();
    // Not loaded: bevy has no box for it either way; the box behind is kept.
    assert!(visible(&app, s.camera).contains(&s.behind));
    assert_eq!(app.world().resource::<OcclusionScene>().object_of(s.wall), None);
    app.world_mut()
        .resource_mut::<Assets<Mesh>>()
        .insert(late.id(), Mesh::from(Cuboid::new(40.0, 30.0, 1.0)))
        .unwrap();
    app.update();
    app.update();
    assert!(app.world().resource::<OcclusionScene>().object_of(s.wall).is_some());
    assert!(!visible(&app, s.camera).contains(&s.behind));
}

#[test]
fn a_mesh_with_a_nan_vertex_or_no_triangles_is_left_to_bevy() {
    let mut app = app();
    let s = wall_scene(&mut app, BufferKind::Masked);
    let mut broken = Mesh::from(Cuboid::new(40.0, 30.0, 1.0));
    if let Some(bevy::mesh::VertexAttributeValues::Float32x3(p)) = broken.attribute_mut(Mesh::ATTRIBUTE_POSITION) {
        p[0] = [f32::NAN, 0.0, 0.0];
    }
    let nan_wall = app.world_mut().resource_mut::<Assets<Mesh>>().add(broken);
    let lines = app.world_mut().resource_mut::<Assets<Mesh>>().add(Mesh::new(
        bevy::mesh::PrimitiveTopology::LineList,
        bevy::asset::RenderAssetUsages::default(),
    ));
    app.world_mut().entity_mut(s.wall).insert(Mesh3d(nan_wall));
    let line_entity = spawn(&mut app, &lines, Vec3::new(0.0, 0.0, -3.0));
    app.update();
    let mirror = app.world().resource::<OcclusionScene>();
    assert_eq!(mirror.object_of(s.wall), None);
    assert_eq!(mirror.object_of(line_entity), None);
    assert!(visible(&app, s.camera).contains(&s.behind), "a NaN wall hides nothing");
}

#[test]
fn a_transform_that_is_not_finite_takes_the_entity_out_until_it_is() {
    let mut app = app();
    let s = wall_scene(&mut app, BufferKind::Masked);
    app.update();
    assert!(!visible(&app, s.camera).contains(&s.behind));
    app.world_mut()
        .entity_mut(s.wall)
        .insert(Transform::from_xyz(f32::NAN, 0.0, -10.0));
    app.update();
    assert_eq!(app.world().resource::<OcclusionScene>().object_of(s.wall), None);
    assert!(visible(&app, s.camera).contains(&s.behind), "a NaN wall hides nothing");
    app.world_mut()
        .entity_mut(s.wall)
        .insert(Transform::from_xyz(0.0, 0.0, -10.0));
    app.update();
    assert!(app.world().resource::<OcclusionScene>().object_of(s.wall).is_some());
    assert!(
        !visible(&app, s.camera).contains(&s.behind),
        "back in place, it hides again"
    );
}

#[test]
fn the_debug_view_shows_the_wall_covering_the_buffer() {
    let mut app = app();
    app.init_asset::<Image>();
    let s = wall_scene(&mut app, BufferKind::Masked);
    let image = app.world_mut().resource_mut::<Assets<Image>>().add(Image::default());
    app.world_mut()
        .entity_mut(s.camera)
        .insert(OcclusionDebugView { image: image.clone() });
    app.update();
    let images = app.world().resource::<Assets<Image>>();
    let picture = images.get(&image).unwrap();
    assert_eq!((picture.width(), picture.height()), (128, 96));
    let data = picture.data.as_ref().unwrap();
    // The wall spans the whole view at 10 m: every sample is covered.
    assert!(data.chunks_exact(4).all(|p| p[0] == 255), "not all covered");
    // Moved aside it covers the left part only.
    app.world_mut()
        .entity_mut(s.wall)
        .insert(Transform::from_xyz(-20.0, 0.0, -10.0));
    app.update();
    let images = app.world().resource::<Assets<Image>>();
    let data = images.get(&image).unwrap().data.clone().unwrap();
    let white = data.chunks_exact(4).filter(|p| p[0] == 255).count();
    assert!(white > 0 && white < 128 * 96, "{white} white samples");
    // Column 0 (left) covered, the last column not.
    assert_eq!(data[0], 255);
    assert_eq!(data[127 * 4], 0);
}

// ---- Brute force: rays through every sample of the buffer ----

/// Every entity's world-space triangles.
fn world_triangles(app: &mut App) -> Vec<(Entity, [Vec3; 3])> {
    let mut out = Vec::new();
    let world = app.world_mut();
    let mut q = world.query::<(Entity, &Mesh3d, &bevy::transform::components::GlobalTransform)>();
    let meshes = world.resource::<Assets<Mesh>>();
    for (entity, mesh, transform) in q.iter(world) {
        let mesh = meshes.get(&mesh.0).unwrap();
        let positions = mesh.attribute(Mesh::ATTRIBUTE_POSITION).unwrap().as_float3().unwrap();
        let indices: Vec<usize> = mesh.indices().unwrap().iter().collect();
        for t in indices.chunks_exact(3) {
            let p = |i: usize| transform.transform_point(Vec3::from_array(positions[t[i]]));
            out.push((entity, [p(0), p(1), p(2)]));
        }
    }
    out
}

/// The distance along `dir` from `origin` to the triangle, if the ray hits it (Möller–Trumbore, in f64).
fn hit(origin: Vec3, dir: Vec3, t: &[Vec3; 3]) -> Option<f64> {
    let d = |v: Vec3| [v.x as f64, v.y as f64, v.z as f64];
    let (o, dir, a, b, c) = (d(origin), d(dir), d(t[0]), d(t[1]), d(t[2]));
    let sub = |p: [f64; 3], q: [f64; 3]| [p[0] - q[0], p[1] - q[1], p[2] - q[2]];
    let cross = |p: [f64; 3], q: [f64; 3]| {
        [
            p[1] * q[2] - p[2] * q[1],
            p[2] * q[0] - p[0] * q[2],
            p[0] * q[1] - p[1] * q[0],
        ]
    };
    let dot = |p: [f64; 3], q: [f64; 3]| p[0] * q[0] + p[1] * q[1] + p[2] * q[2];
    let (e1, e2) = (sub(b, a), sub(c, a));
    let p = cross(dir, e2);
    let det = dot(e1, p);
    if det.abs() < 1e-12 {
        return None;
    }
    let s = sub(o, a);
    let u = dot(s, p) / det;
    let q = cross(s, e1);
    let v = dot(dir, q) / det;
    let t = dot(e2, q) / det;
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0).then_some(t)
}

/// The entity a ray meets first, if it is the first by a clear margin.
fn first_hit(origin: Vec3, dir: Vec3, tris: &[(Entity, [Vec3; 3])]) -> Option<Entity> {
    let mut best: Option<(f64, Entity)> = None;
    let mut second = f64::INFINITY;
    for (e, t) in tris {
        if let Some(d) = hit(origin, dir, t) {
            match best {
                Some((b, be)) if d < b => {
                    if be != *e {
                        second = second.min(b);
                    }
                    best = Some((d, *e));
                }
                Some((_, be)) if be != *e => second = second.min(d),
                None => best = Some((d, *e)),
                _ => {}
            }
        }
    }
    let (d, e) = best?;
    (second > d * 1.0001).then_some(e)
}

/// The entities a ray through a sample of a `w` × `h` buffer meets first,
/// robustly: the same entity for rays 0.05 sample off in x and y.
fn seen_by_rays(world_to_clip: Mat4, w: u32, h: u32, tris: &[(Entity, [Vec3; 3])]) -> Vec<Entity> {
    let inv = world_to_clip.inverse();
    let unproject = |x: f32, y: f32, z: f32| {
        let p = inv * Vec4::new(x, y, z, 1.0);
        p.truncate() / p.w
    };
    let mut seen = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let rays: Vec<Option<Entity>> = [(0.0, 0.0), (0.05, 0.0), (-0.05, 0.0), (0.0, 0.05), (0.0, -0.05)]
                .iter()
                .map(|(dx, dy)| {
                    let nx = -1.0 + (x as f32 + 0.5 + dx) * 2.0 / w as f32;
                    let ny = 1.0 - (y as f32 + 0.5 + dy) * 2.0 / h as f32;
                    // Reversed Z: 1 at the near plane.
                    let near = unproject(nx, ny, 1.0);
                    let far = unproject(nx, ny, 0.01);
                    first_hit(near, (far - near).normalize(), tris)
                })
                .collect();
            if let Some(e) = rays[0] {
                if rays.iter().all(|r| *r == Some(e)) {
                    seen.push(e);
                }
            }
        }
    }
    seen.sort_unstable();
    seen.dedup();
    seen
}

fn world_to_clip(app: &mut App, camera: Entity) -> Mat4 {
    let world = app.world_mut();
    let projection = world.get::<Projection>(camera).unwrap().clone();
    let transform = *world
        .get::<bevy::transform::components::GlobalTransform>(camera)
        .unwrap();
    projection.get_clip_from_view() * transform.to_matrix().inverse()
}

fn sorted(mut v: Vec<Entity>) -> Vec<Entity> {
    v.sort_unstable();
    v
}

/// A tiny xorshift, so the city is the same every run.
struct Rng(u64);
impl Rng {
    fn f(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f()
    }
}

#[test]
fn no_entity_a_ray_reaches_is_removed_over_a_moving_city() {
    let (w, h) = (80u32, 60u32);
    for (seed, buffer) in BUFFERS.into_iter().enumerate() {
        let mut app = app();
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15 ^ seed as u64);
        let camera = camera(
            &mut app,
            buffer,
            Vec3::new(0.0, 2.0, 30.0),
            Vec3::ZERO,
            UVec2::new(w, h),
        );
        // Buildings (the occluders) on a 5 × 5 grid, props between them, a few that move.
        let mut movers = Vec::new();
        for i in 0..5 {
            for j in 0..5 {
                let size = Vec3::new(rng.range(3.0, 6.0), rng.range(2.0, 9.0), rng.range(3.0, 6.0));
                let mesh = cuboid(&mut app, size);
                let at = Vec3::new(i as f32 * 10.0 - 20.0, size.y / 2.0, j as f32 * 10.0 - 20.0);
                spawn(&mut app, &mesh, at);
            }
        }
        let prop = cuboid(&mut app, Vec3::new(0.8, 1.6, 0.8));
        for k in 0..40 {
            let at = Vec3::new(rng.range(-25.0, 25.0), 0.8, rng.range(-25.0, 25.0));
            let e = spawn(&mut app, &prop, at);
            if k % 4 == 0 {
                movers.push(e);
            }
        }
        let mut removed_total = 0;
        for frame in 0..16 {
            // The camera walks around the city's edge at eye height, looking at its middle.
            let a = frame as f32 * 0.35;
            let eye = Vec3::new(28.0 * a.sin(), 1.7 + (frame % 3) as f32, 28.0 * a.cos());
            *app.world_mut().get_mut::<Transform>(camera).unwrap() =
                Transform::from_translation(eye).looking_at(Vec3::new(0.0, 1.0, 0.0), Vec3::Y);
            for &m in &movers {
                let mut t = app.world_mut().get_mut::<Transform>(m).unwrap();
                t.translation.x += rng.range(-1.5, 1.5);
                t.translation.z += rng.range(-1.5, 1.5);
            }
            app.update();
            let kept = visible(&app, camera);
            let tris = world_triangles(&mut app);
            let m = world_to_clip(&mut app, camera);
            for e in seen_by_rays(m, w, h, &tris) {
                assert!(
                    kept.binary_search(&e).is_ok(),
                    "{buffer:?} frame {frame}: {e:?} is seen by a ray and was removed"
                );
            }
            removed_total += app.world().resource::<OcclusionStats>().cameras[&camera].occluded;
        }
        // Not a vacuous pass: the city hides much of itself from eye height.
        assert!(
            removed_total > 50,
            "{buffer:?}: only {removed_total} removed over 16 frames"
        );
    }
}

/// bevy tests its `Aabb` against the frustum; hom tests its own bounds of
/// the same mesh behind the occluders: the two agree.
#[test]
fn bevy_and_hom_bound_a_mesh_alike() {
    let mut app = app();
    let s = wall_scene(&mut app, BufferKind::Masked);
    app.update();
    let aabb = *app.world().get::<Aabb>(s.wall).unwrap();
    let mirror = app.world().resource::<OcclusionScene>();
    let object = mirror.scene().object(mirror.object_of(s.wall).unwrap());
    let b = object.aabb;
    let (min, max) = (aabb.min(), aabb.max());
    let wall_at = Vec3::new(0.0, 0.0, -10.0);
    assert!(
        (Vec3::from_array(b.min.to_array()) - (Vec3::from(min) + wall_at))
            .abs()
            .max_element()
            < 1e-5
    );
    assert!(
        (Vec3::from_array(b.max.to_array()) - (Vec3::from(max) + wall_at))
            .abs()
            .max_element()
            < 1e-5
    );
}
