//! The public API: framebuffer, options, shading, PNG output, oracle counts.

mod common;

use common::scene_of;
use hom::geom::Camera;
use hom::glam::{Mat4, Vec3};
use hom_render::{
    id_colour, oracle_pixel_counts, write_png, Colouring, Framebuffer, RenderError, RenderOptions, RenderStats,
    Renderer, Shading, DEFAULT_BACKGROUND, NO_OBJECT,
};

fn camera(w: u32, h: u32) -> Camera {
    Camera::new(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 1.0, 0.1, 100.0, w, h)
}

/// A unit quad facing +Z at z = `z`, shifted by `dx`.
fn quad(dx: f32, z: f32) -> Vec<[Vec3; 3]> {
    let p = |x: f32, y: f32| Vec3::new(x + dx, y, z);
    vec![
        [p(-1.0, -1.0), p(1.0, -1.0), p(1.0, 1.0)],
        [p(-1.0, -1.0), p(1.0, 1.0), p(-1.0, 1.0)],
    ]
}

#[test]
fn new_framebuffer_is_clear() {
    let fb = Framebuffer::new(7, 5);
    assert_eq!((fb.width(), fb.height()), (7, 5));
    assert_eq!(fb.color().len(), 35);
    assert!(fb.depth().iter().all(|&d| d == 1.0));
    assert!(fb.items().iter().all(|&i| i == NO_OBJECT));
    assert_eq!(fb.visible_pixel_counts(3), vec![0, 0, 0]);
}

#[test]
fn render_resizes_clears_and_counts() {
    // Object 1 in front of object 0 (partly overlapping), object 2 hidden behind 1.
    let scene = scene_of(&[
        (quad(-0.8, 0.0), Mat4::IDENTITY),
        (quad(0.5, 1.0), Mat4::IDENTITY),
        (
            quad(0.0, 0.0),
            Mat4::from_translation(Vec3::new(0.5, 0.0, -1.0)) * Mat4::from_scale(Vec3::splat(0.5)),
        ),
    ]);
    let r = Renderer::new(0).unwrap();
    assert!(r.threads() >= 1);
    let mut fb = Framebuffer::new(3, 2);
    let options = RenderOptions::default();
    let stats = r.render(&scene, &[0, 1, 2], &camera(80, 60), &options, &mut fb);
    assert_eq!((fb.width(), fb.height()), (80, 60));
    assert_eq!(stats.triangles_submitted, 6);
    assert_eq!(stats.triangles_rasterized, 6);
    let counts = fb.visible_pixel_counts(3);
    assert!(counts[0] > 0 && counts[1] > 0);
    assert_eq!(counts[2], 0, "object 2 is hidden");
    assert_eq!(
        counts.iter().sum::<u32>() as u64,
        fb.items().iter().filter(|&&i| i != NO_OBJECT).count() as u64
    );
    assert!(stats.fragments_written >= u64::from(counts[0] + counts[1]));
    // Background pixels have the background colour, drawn ones do not.
    let bg = [DEFAULT_BACKGROUND[0], DEFAULT_BACKGROUND[1], DEFAULT_BACKGROUND[2], 255];
    for (c, &i) in fb.color().iter().zip(fb.items()) {
        assert_eq!(i == NO_OBJECT, *c == bg);
    }
    // The oracle agrees, drawing everything.
    assert_eq!(oracle_pixel_counts(&r, &scene, &camera(80, 60), &mut fb), counts);
    // Drawing a subset clears what was there before.
    let stats = r.render(&scene, &[2], &camera(40, 30), &options, &mut fb);
    assert_eq!(stats.triangles_submitted, 2);
    assert_eq!((fb.width(), fb.height()), (40, 30));
    let counts = fb.visible_pixel_counts(3);
    assert_eq!(counts[0] + counts[1], 0);
    assert!(counts[2] > 0);
}

#[test]
fn flat_shading_uses_object_colour_and_headlight() {
    let scene = scene_of(&[(quad(0.0, 0.0), Mat4::IDENTITY)]);
    let r = Renderer::new(1).unwrap();
    let mut fb = Framebuffer::new(1, 1);
    let colours = [[200u8, 100, 40]];
    let options = RenderOptions {
        shading: Shading::Flat,
        colouring: Colouring::PerObject(&colours),
        background: [1, 2, 3],
    };
    r.render(&scene, &[0], &camera(64, 64), &options, &mut fb);
    // Facing the camera almost head on: |n.v| close to 1 at the centre.
    let c = fb.color()[32 * 64 + 32];
    assert!(c[0] >= 195 && c[1] >= 97 && c[2] >= 38 && c[3] == 255, "{c:?}");
    assert!(c[0] <= 200 && c[1] <= 100 && c[2] <= 40, "{c:?}");
    assert_eq!(fb.color()[0], [1, 2, 3, 255]);
    // Seen edge-on-ish the same quad is darker, but never below the ambient 25 %.
    let oblique = Camera::new(Vec3::new(4.9, 0.0, 0.3), Vec3::ZERO, Vec3::Y, 1.0, 0.1, 100.0, 64, 64);
    r.render(&scene, &[0], &oblique, &options, &mut fb);
    let lit: Vec<[u8; 4]> = fb
        .color()
        .iter()
        .zip(fb.items())
        .filter(|(_, &i)| i == 0)
        .map(|(c, _)| *c)
        .collect();
    assert!(!lit.is_empty());
    for c in lit {
        assert!(c[0] < 120 && c[0] >= 50, "{c:?}");
    }
    // ItemOnly leaves colour at the background.
    let item_only = RenderOptions {
        shading: Shading::ItemOnly,
        ..options
    };
    r.render(&scene, &[0], &camera(64, 64), &item_only, &mut fb);
    assert!(fb.color().iter().all(|&c| c == [1, 2, 3, 255]));
    assert_eq!(fb.items()[32 * 64 + 32], 0);
}

#[test]
fn id_colours_are_stable_and_varied() {
    assert_eq!(id_colour(42), id_colour(42));
    let distinct: std::collections::HashSet<[u8; 3]> = (0..1000).map(id_colour).collect();
    assert!(distinct.len() > 950);
    for id in 0..1000 {
        let c = id_colour(id);
        let max = *c.iter().max().unwrap();
        assert!(max >= 190, "{c:?} too dark");
    }
    let d = RenderOptions::default();
    assert_eq!(d.shading, Shading::Flat);
    assert_eq!(d.colouring, Colouring::ById);
    assert_eq!(d.background, DEFAULT_BACKGROUND);
}

#[test]
fn invalid_camera_clears_and_draws_nothing() {
    let scene = scene_of(&[(quad(0.0, 0.0), Mat4::IDENTITY)]);
    let r = Renderer::new(1).unwrap();
    let mut fb = Framebuffer::new(1, 1);
    let bad = Camera {
        near: -1.0,
        ..camera(20, 10)
    };
    let stats = r.render(&scene, &[0], &bad, &RenderOptions::default(), &mut fb);
    assert_eq!(stats, RenderStats::default());
    assert_eq!((fb.width(), fb.height()), (20, 10));
    assert!(fb.items().iter().all(|&i| i == NO_OBJECT));
}

#[test]
#[should_panic(expected = "object id 5")]
fn unknown_object_id_panics_clearly() {
    let scene = scene_of(&[(quad(0.0, 0.0), Mat4::IDENTITY)]);
    let r = Renderer::new(1).unwrap();
    r.render(
        &scene,
        &[0, 5],
        &camera(8, 8),
        &RenderOptions::default(),
        &mut Framebuffer::new(8, 8),
    );
}

#[test]
fn png_round_trip_and_errors_name_the_path() {
    let scene = scene_of(&[(quad(0.0, 0.0), Mat4::IDENTITY)]);
    let r = Renderer::new(2).unwrap();
    let mut fb = Framebuffer::new(1, 1);
    r.render(&scene, &[0], &camera(31, 17), &RenderOptions::default(), &mut fb);
    let dir = std::env::temp_dir().join(format!("hom-render-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("frame.png");
    fb.save_png(&path).unwrap();
    let img = image::open(&path).unwrap().to_rgba8();
    assert_eq!(img.dimensions(), (31, 17));
    for (p, c) in img.pixels().zip(fb.color()) {
        assert_eq!(p.0, *c);
    }
    std::fs::remove_dir_all(&dir).unwrap();

    let missing = std::path::Path::new("/nonexistent-hom-dir/x.png");
    let err = fb.save_png(missing).unwrap_err();
    assert!(matches!(err, RenderError::Png { .. }));
    assert!(err.to_string().contains("/nonexistent-hom-dir/x.png"), "{err}");
    // The I/O error is the source, not repeated in the message.
    let cause = std::error::Error::source(&err).expect("an I/O cause").to_string();
    assert!(!err.to_string().contains(&cause), "{err}");
    let err = write_png(&path, 4, 4, &[[0; 4]; 3]).unwrap_err();
    assert!(matches!(err, RenderError::BufferSize { len: 3, .. }), "{err}");
}
