//! Scenes, configurations and the oracle check shared by the culler tests.
#![allow(dead_code)] // each test binary uses its own subset

use hom::cull::{CullOutput, Culler};
use hom::geom::Camera;
use hom::glam::{Mat4, Quat, Vec3};
use hom::occluders::OccluderDbConfig;
use hom::scene::{Mesh, Scene, SceneBuilder};
use hom_render::{Framebuffer, Renderer};
use hom_scene::{Animation, Motion};

/// A unit cube centred on the origin.
pub fn cube() -> Mesh {
    let p: Vec<Vec3> = (0..8)
        .map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32) - 0.5)
        .collect();
    let faces = [
        [0, 1, 3, 2],
        [4, 6, 7, 5],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 5, 7, 3],
    ];
    let tris = faces
        .iter()
        .flat_map(|f| [[f[0], f[1], f[2]], [f[0], f[2], f[3]]])
        .collect();
    Mesh::new("cube", p, tris).unwrap()
}

/// Every object may be an occluder: the strongest test of the depth and overlap logic.
pub fn permissive_occluders() -> OccluderDbConfig {
    OccluderDbConfig {
        min_size: 0.0,
        max_triangles: u32::MAX,
        min_fill: 0.0,
        redundancy_margin: -1.0,
    }
}

/// Culls with `culler` and checks every object the oracle sees is kept.
pub fn assert_no_false_culls(scene: &Scene, camera: &Camera, culler: &mut dyn Culler) -> CullOutput {
    let renderer = Renderer::new(1).unwrap();
    let mut out = CullOutput::default();
    culler.cull(scene, &camera.to_view(), &mut out).unwrap();
    let mut fb = Framebuffer::new(camera.width, camera.height);
    let counts = hom_render::oracle_pixel_counts(&renderer, scene, camera, &mut fb);
    for (id, &n) in counts.iter().enumerate() {
        if n > 0 {
            assert!(
                out.visible.binary_search(&(id as u32)).is_ok(),
                "object {id} owns {n} pixels but was culled (occluded: {})",
                out.occluded.contains(&(id as u32))
            );
        }
    }
    out
}

/// A random scene of `n` boxes (half of them dynamic when `dynamic`), at time 0.
pub fn random_scene(seed: u64, n: usize, dynamic: bool) -> Scene {
    random_moving_scene(seed, n, dynamic).0
}

/// [`random_scene`] with the motion of its dynamic boxes.
pub fn random_moving_scene(seed: u64, n: usize, dynamic: bool) -> (Scene, Animation) {
    let mut state = seed | 1;
    let mut rnd = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f32 / (1u64 << 53) as f32
    };
    let mut b = SceneBuilder::new("random");
    let mut animation = Animation::none();
    let m = b.add_mesh(cube());
    for i in 0..n {
        let pos = Vec3::new(rnd() * 20.0 - 10.0, rnd() * 6.0 - 3.0, rnd() * 20.0 - 10.0);
        let scale = Vec3::new(0.2 + rnd() * 5.0, 0.2 + rnd() * 4.0, 0.2 + rnd() * 5.0);
        let rot = Quat::from_rotation_y(rnd() * 3.0);
        let t = Mat4::from_scale_rotation_translation(scale, rot, pos);
        if dynamic && i % 2 == 0 {
            let motion = Motion {
                velocity: Vec3::new(rnd() - 0.5, 0.0, rnd() - 0.5) * 4.0,
                region: hom::geom::Aabb::new(pos - 3.0, pos + 3.0),
                spin_axis: Vec3::Y,
                spin_rate: rnd() * 2.0,
            };
            let id = b.add_dynamic_object(format!("o{i}"), m, t).unwrap();
            animation.add(id, t, motion).unwrap();
        } else {
            b.add_object(format!("o{i}"), m, t).unwrap();
        }
    }
    (b.build().unwrap(), animation)
}

/// Over 60 random scenes, the culler `make` builds occlusion-culls at least
/// one object in 20 and never wrongly: the conservative property tests are
/// only meaningful if culling happens.
pub fn assert_culls_a_fair_share(mut make: impl FnMut(&Scene) -> Box<dyn Culler>) {
    let (mut occluded, mut total) = (0, 0);
    for seed in 0..60u64 {
        let scene = random_scene(seed * 31 + 5, 40, seed % 2 == 0);
        let eye = Vec3::new(0.0, 0.5, 13.0);
        let camera = Camera::new(eye, Vec3::new(0.0, 0.0, 0.0), Vec3::Y, 1.2, 0.1, 100.0, 80, 60);
        let out = assert_no_false_culls(&scene, &camera, make(&scene).as_mut());
        occluded += out.occluded.len();
        total += scene.objects().len();
    }
    assert!(
        occluded * 20 > total,
        "only {occluded} of {total} objects occlusion-culled"
    );
}

/// The case of the tests that compare an occluder raster with the renderer:
/// a random scene (`seed`), a 101×77 camera on it, every other object as an occluder.
pub fn occluder_raster_case(seed: u64) -> (Scene, Camera, Vec<u32>) {
    let scene = random_scene(seed * 104_729 + 3, 30, seed.is_multiple_of(3));
    let camera = Camera::new(
        Vec3::new(1.5, 2.0, 14.0),
        Vec3::new(0.0, -0.5, 0.0),
        Vec3::Y,
        1.1,
        0.1,
        100.0,
        101,
        77,
    );
    let ids: Vec<u32> = (0..scene.objects().len() as u32).filter(|i| i % 2 == 1).collect();
    (scene, camera, ids)
}

/// Clears `buf`, queues the meshes of the objects `ids` of `scene` as seen by
/// `camera` (two-sided) and draws them: an occlusion buffer as an engine fills it.
pub fn draw_objects(buf: &mut impl hom::occlusion::OcclusionBuffer, scene: &Scene, ids: &[u32], camera: &Camera) {
    buf.clear();
    for &id in ids {
        let o = scene.object(id);
        let m = scene.mesh_of(o);
        let mvp = camera.view_proj() * o.transform;
        buf.render_triangles(m.positions(), m.triangles(), &mvp, hom::occlusion::FaceCull::None)
            .unwrap();
    }
    buf.flush();
}

/// Buffer options with the reference renderer's sampling, for comparisons with it.
pub fn exact() -> hom::occlusion::BufferOptions {
    hom::occlusion::BufferOptions {
        sampling: hom::occlusion::Sampling::Exact,
        ..Default::default()
    }
}

/// OpenArena's `pak1-maps.pk3` from the fetched cache, or `None` after
/// printing why the calling test skips (run `scripts/fetch-scenes.sh --tests-only`).
pub fn openarena_maps() -> Option<std::path::PathBuf> {
    let pk3 = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../.cache/scenes/debian/usr/share/games/openarena/baseoa/pak1-maps.pk3");
    if pk3.exists() {
        return Some(pk3);
    }
    eprintln!(
        "skipping: {} is missing; run scripts/fetch-scenes.sh --tests-only",
        pk3.display()
    );
    None
}
