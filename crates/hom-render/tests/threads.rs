//! Output is bit-identical whatever the thread count, and across repeated frames.

mod common;

use hom::geom::Camera;
use hom::glam::{Mat4, Quat, Vec3};
use hom::scene::{Mesh, Scene, SceneBuilder};
use hom_render::{Colouring, Framebuffer, RenderOptions, Renderer, Shading};
use hom_testkit::Rng;

/// Many objects sharing a few random meshes (some large), scattered around
/// and through the camera, so chunks, bands, clipping and depth ties all occur.
fn scene() -> Scene {
    let mut rng = Rng::new(2024);
    let mut b = SceneBuilder::new("threads");
    let mut meshes = Vec::new();
    for k in 0..4 {
        // Triangles of varied size: a few big ones, most small.
        let n = [3, 60, 600, 3000][k];
        let size = [1.0, 0.5, 0.2, 0.08][k];
        let positions: Vec<Vec3> = (0..n)
            .flat_map(|_| {
                let c = rng.vec3(-1.0, 1.0);
                [0; 3].map(|_| c + rng.vec3(-size, size))
            })
            .collect();
        let triangles: Vec<[u32; 3]> = (0..n as u32).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
        meshes.push(b.add_mesh(Mesh::new(format!("m{k}"), positions, triangles).unwrap()));
    }
    for i in 0..300 {
        let m = meshes[(rng.next_u64() % 4) as usize];
        let t = Mat4::from_scale_rotation_translation(
            Vec3::splat(rng.range(0.3, 3.0)),
            Quat::from_axis_angle(rng.vec3(-1.0, 1.0).normalize(), rng.range(0.0, 6.0)),
            rng.vec3(-20.0, 20.0),
        );
        b.add_object(format!("o{i}"), m, t).unwrap();
    }
    // Coplanar duplicates: equal depths everywhere, so draw order decides.
    b.add_object("dup-a", meshes[2], Mat4::from_scale(Vec3::splat(4.0)))
        .unwrap();
    b.add_object("dup-b", meshes[2], Mat4::from_scale(Vec3::splat(4.0)))
        .unwrap();
    b.build().unwrap()
}

fn frame(renderer: &Renderer, scene: &Scene, ids: &[u32], camera: &Camera, shading: Shading) -> Framebuffer {
    let colours: Vec<[u8; 3]> = (0..scene.objects().len())
        .map(|i| [(i * 7) as u8, (i * 13) as u8, 200])
        .collect();
    let options = RenderOptions {
        shading,
        colouring: Colouring::PerObject(&colours),
        ..RenderOptions::default()
    };
    let mut fb = Framebuffer::new(3, 3);
    let stats = renderer.render(scene, ids, camera, &options, &mut fb);
    assert!(stats.triangles_rasterized > 0 && stats.fragments_written > 0);
    fb
}

#[test]
fn one_two_and_four_threads_give_identical_buffers() {
    let scene = scene();
    let n = scene.objects().len() as u32;
    let forward: Vec<u32> = (0..n).collect();
    let backward: Vec<u32> = (0..n).rev().collect();
    let cameras = [
        Camera::new(
            Vec3::new(0.0, 2.0, 30.0),
            Vec3::ZERO,
            Vec3::Y,
            1.0,
            0.1,
            100.0,
            333,
            257,
        ),
        Camera::new(
            Vec3::new(1.0, 0.5, 2.0),
            Vec3::new(-5.0, 0.0, -5.0),
            Vec3::Y,
            1.4,
            0.05,
            30.0,
            640,
            480,
        ),
    ];
    let renderers: Vec<Renderer> = [1, 2, 4].into_iter().map(|t| Renderer::new(t).unwrap()).collect();
    assert_eq!(renderers[0].threads(), 1);
    assert_eq!(renderers[2].threads(), 4);
    for camera in &cameras {
        for shading in [Shading::Flat, Shading::ItemOnly] {
            for ids in [&forward, &backward] {
                let reference = frame(&renderers[0], &scene, ids, camera, shading);
                for r in &renderers[1..] {
                    // Twice each: scratch memory reused across frames must not leak state.
                    for _ in 0..2 {
                        let fb = frame(r, &scene, ids, camera, shading);
                        assert!(fb.items() == reference.items(), "{} threads: items differ", r.threads());
                        assert!(
                            fb.color() == reference.color(),
                            "{} threads: colour differs",
                            r.threads()
                        );
                        let same_depth = fb
                            .depth()
                            .iter()
                            .zip(reference.depth())
                            .all(|(a, b)| a.to_bits() == b.to_bits());
                        assert!(same_depth, "{} threads: depth differs", r.threads());
                    }
                }
            }
        }
    }
}

#[test]
fn equal_depth_ties_go_to_the_earlier_drawn_object() {
    let scene = scene();
    let n = scene.objects().len() as u32;
    let (a, b) = (n - 2, n - 1); // coplanar duplicates
    let camera = Camera::new(
        Vec3::new(0.0, 0.0, 12.0),
        Vec3::ZERO,
        Vec3::Y,
        1.0,
        0.1,
        100.0,
        200,
        150,
    );
    let r = Renderer::new(2).unwrap();
    let ab = frame(&r, &scene, &[a, b], &camera, Shading::ItemOnly);
    let ba = frame(&r, &scene, &[b, a], &camera, Shading::ItemOnly);
    assert!(ab.items().contains(&a));
    assert!(ab.items().iter().all(|&i| i != b), "later-drawn duplicate won a tie");
    assert!(ba.items().iter().all(|&i| i != a), "later-drawn duplicate won a tie");
}
