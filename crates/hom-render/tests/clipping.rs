//! Near/far plane handling and robustness against non-finite coordinates.

mod common;

use common::{compare_with_ray_cast, scene_of};
use hom::geom::Camera;
use hom::glam::{Mat4, Vec3};
use hom::scene::{Mesh, SceneBuilder};
use hom_render::{Framebuffer, RenderOptions, Renderer, Shading, NO_OBJECT};

fn camera() -> Camera {
    // At the origin looking down -Z; near 1, far 50.
    Camera::new(Vec3::ZERO, -Vec3::Z, Vec3::Y, 1.2, 1.0, 50.0, 64, 48)
}

fn options() -> RenderOptions<'static> {
    RenderOptions {
        shading: Shading::ItemOnly,
        ..RenderOptions::default()
    }
}

fn owned(fb: &Framebuffer, id: u32) -> usize {
    fb.items().iter().filter(|&&i| i == id).count()
}

#[test]
fn triangle_crossing_the_near_plane_draws_its_front_part() {
    // Two vertices well in front, one behind the eye (w < 0 there).
    let tri = [
        Vec3::new(-2.0, -1.0, -6.0),
        Vec3::new(2.0, -1.0, -6.0),
        Vec3::new(0.0, -0.5, 4.0),
    ];
    let scene = scene_of(&[(vec![tri], Mat4::IDENTITY)]);
    let camera = camera();
    let r = Renderer::new(2).unwrap();
    let mut fb = Framebuffer::new(1, 1);
    let stats = r.render(&scene, &[0], &camera, &options(), &mut fb);
    assert_eq!(stats.triangles_submitted, 1);
    assert!(stats.triangles_rasterized >= 1);
    let n = owned(&fb, 0);
    assert!(n > 100, "only {n} pixels drawn");
    // Every drawn pixel has a depth in [0, 1); and the picture matches the ray cast.
    for (&i, &d) in fb.items().iter().zip(fb.depth()) {
        if i == 0 {
            assert!((0.0..1.0).contains(&d), "depth {d}");
        }
    }
    let (_, bad) = compare_with_ray_cast(&scene, &[0], &camera, fb.items());
    assert!(bad.is_empty(), "{bad:?}");
}

#[test]
fn triangle_wholly_behind_the_near_plane_draws_nothing() {
    let behind_eye = [
        Vec3::new(-2.0, -1.0, 3.0),
        Vec3::new(2.0, -1.0, 3.0),
        Vec3::new(0.0, 2.0, 3.0),
    ];
    // Between the eye and the near plane (view depth 0.5 < near 1).
    let before_near = [
        Vec3::new(-0.2, -0.1, -0.5),
        Vec3::new(0.2, -0.1, -0.5),
        Vec3::new(0.0, 0.2, -0.5),
    ];
    // Beyond the far plane.
    let beyond_far = [
        Vec3::new(-20.0, -10.0, -60.0),
        Vec3::new(20.0, -10.0, -60.0),
        Vec3::new(0.0, 20.0, -60.0),
    ];
    let scene = scene_of(&[
        (vec![behind_eye], Mat4::IDENTITY),
        (vec![before_near], Mat4::IDENTITY),
        (vec![beyond_far], Mat4::IDENTITY),
    ]);
    let r = Renderer::new(2).unwrap();
    let mut fb = Framebuffer::new(1, 1);
    let stats = r.render(&scene, &[0, 1, 2], &camera(), &options(), &mut fb);
    assert_eq!(stats.triangles_submitted, 3);
    assert_eq!(stats.triangles_rasterized, 0);
    assert_eq!(stats.fragments_written, 0);
    assert!(fb.items().iter().all(|&i| i == NO_OBJECT));
    assert!(fb.depth().iter().all(|&d| d == 1.0));
}

#[test]
fn triangle_crossing_the_far_plane_draws_only_its_near_part() {
    // A floor strip from depth 10 to depth 90: the far part is cut per pixel.
    let tris = vec![
        [
            Vec3::new(-5.0, -1.0, -10.0),
            Vec3::new(5.0, -1.0, -10.0),
            Vec3::new(5.0, -1.0, -90.0),
        ],
        [
            Vec3::new(-5.0, -1.0, -10.0),
            Vec3::new(5.0, -1.0, -90.0),
            Vec3::new(-5.0, -1.0, -90.0),
        ],
    ];
    let scene = scene_of(&[(tris, Mat4::IDENTITY)]);
    let camera = camera();
    let r = Renderer::new(1).unwrap();
    let mut fb = Framebuffer::new(1, 1);
    r.render(&scene, &[0], &camera, &options(), &mut fb);
    assert!(owned(&fb, 0) > 0);
    assert!(fb.depth().iter().all(|&d| d <= 1.0));
    let (_, bad) = compare_with_ray_cast(&scene, &[0], &camera, fb.items());
    assert!(bad.is_empty(), "{bad:?}");
}

#[test]
fn non_finite_clip_coordinates_are_skipped_without_panic() {
    // Mesh vertices are finite, but a transform scaling x by 1e30 sends them
    // to +-inf (and the rotation mixes inf - inf = NaN into other coordinates).
    let mut b = SceneBuilder::new("nan");
    let huge = b.add_mesh(
        Mesh::new(
            "huge",
            vec![
                Vec3::new(1e10, 0.0, -5.0),
                Vec3::new(-1e10, 1.0, -5.0),
                Vec3::new(1e10, -1.0, -5.0),
            ],
            vec![[0, 1, 2]],
        )
        .unwrap(),
    );
    let quad = b.add_mesh(
        Mesh::new(
            "quad",
            vec![
                Vec3::new(-1.0, -1.0, -5.0),
                Vec3::new(1.0, -1.0, -5.0),
                Vec3::new(1.0, 1.0, -5.0),
                Vec3::new(-1.0, 1.0, -5.0),
            ],
            vec![[0, 1, 2], [0, 2, 3]],
        )
        .unwrap(),
    );
    let blow_up = Mat4::from_rotation_y(0.3) * Mat4::from_scale(Vec3::new(1e30, 1e-30, 1.0));
    b.add_object("inf", huge, blow_up).unwrap();
    b.add_object("fine", quad, Mat4::IDENTITY).unwrap();
    let scene = b.build().unwrap();
    let r = Renderer::new(2).unwrap();
    let mut fb = Framebuffer::new(1, 1);
    for shading in [Shading::Flat, Shading::ItemOnly] {
        let o = RenderOptions {
            shading,
            ..RenderOptions::default()
        };
        r.render(&scene, &[0, 1], &camera(), &o, &mut fb);
        assert_eq!(owned(&fb, 0), 0);
        assert!(owned(&fb, 1) > 0);
    }
}

#[test]
fn huge_triangles_through_the_view_are_clipped_exactly() {
    // Vertices far outside the guard band in front of and behind the eye.
    let tris = vec![[
        Vec3::new(-1e6, -2.0, -1e6),
        Vec3::new(1e6, -2.0, -1e6),
        Vec3::new(0.0, -2.0, 1e6),
    ]];
    let scene = scene_of(&[(tris, Mat4::IDENTITY)]);
    let camera = Camera { far: 1e5, ..camera() };
    let r = Renderer::new(2).unwrap();
    let mut fb = Framebuffer::new(1, 1);
    r.render(&scene, &[0], &camera, &options(), &mut fb);
    // The plane y = -2 fills the lower half of the image.
    for y in 0..48u32 {
        for x in 0..64u32 {
            let item = fb.item_at(x, y);
            if y >= 26 {
                assert_eq!(item, 0, "pixel {x},{y}");
            } else if y < 23 {
                assert_eq!(item, NO_OBJECT, "pixel {x},{y}");
            }
        }
    }
    let (_, bad) = compare_with_ray_cast(&scene, &[0], &camera, fb.items());
    assert!(bad.is_empty(), "{bad:?}");
}
