//! wgpu's frames against hom's software renderer: the item buffers agree
//! (same objects visible, edge pixels aside), and a walk timed with wgpu
//! keeps the software walk's visible sets.

use hom_render::{Framebuffer, RenderOptions, Renderer, Shading, NO_OBJECT};
use hom_view::{ViewError, WgpuDraw};
use hom_walk::{FrameDraw, WalkOptions};

/// A wgpu renderer for `scene`, or `None` (and why, on stderr) where this
/// machine has no Vulkan adapter — unless `HOM_VIEW_REQUIRE_GPU` is set (CI
/// sets it, after installing lavapipe), when that fails the test.
fn wgpu_or_skip(scene: &hom::scene::Scene) -> Option<WgpuDraw> {
    match WgpuDraw::new(scene) {
        Ok(d) => Some(d),
        Err(e @ ViewError::NoAdapter(_)) if std::env::var_os("HOM_VIEW_REQUIRE_GPU").is_none() => {
            eprintln!("skipped: {e}");
            None
        }
        Err(e) => panic!("{e}"),
    }
}

/// Pixel counts per object of an item buffer.
fn counts(items: &[u32], objects: usize) -> Vec<u32> {
    let mut c = vec![0; objects];
    for &id in items.iter().filter(|&&id| id != NO_OBJECT) {
        c[id as usize] += 1;
    }
    c
}

#[test]
fn wgpu_item_buffer_equals_the_oracle_up_to_edge_pixels() {
    for name in ["city", "office", "dynamic"] {
        let (mut scene, path, animation) = hom_walk::open_scene(name).unwrap();
        let path = path.with_viewport(320, 240);
        let Some(mut draw) = wgpu_or_skip(&scene) else {
            return;
        };
        let renderer = Renderer::new(2).unwrap();
        let mut fb = Framebuffer::new(320, 240);
        let options = RenderOptions {
            shading: Shading::ItemOnly,
            ..RenderOptions::default()
        };
        let n = path.frames.len();
        for i in (0..n).step_by(n.div_ceil(5)) {
            animation.apply(&mut scene, i as f32 / 30.0);
            let camera = path.camera(i);
            let ids: Vec<u32> = scene.live_objects().map(|(id, _)| id).collect();
            renderer.render(&scene, &ids, &camera, &options, &mut fb);
            let gpu = draw.items(&scene, &ids, &camera).unwrap();
            assert_eq!(gpu.len(), fb.items().len());
            let differ = gpu.iter().zip(fb.items()).filter(|(a, b)| a != b).count();
            let share = differ as f64 / gpu.len() as f64;
            assert!(
                share < 0.002,
                "{name} frame {i}: {differ} of {} pixels differ",
                gpu.len()
            );
            // Every object with a few pixels in one image is in the other.
            let (a, b) = (
                counts(&gpu, scene.objects().len()),
                counts(fb.items(), scene.objects().len()),
            );
            for (id, (&g, &s)) in a.iter().zip(&b).enumerate() {
                assert!(
                    !((g >= 4 && s == 0) || (s >= 4 && g == 0)),
                    "{name} frame {i}: object {id} owns {g} pixels drawn by wgpu, {s} by the software renderer"
                );
            }
        }
    }
}

#[test]
fn a_walk_timed_by_wgpu_keeps_the_software_walks_frames() {
    let (mut scene, path, animation) = hom_walk::open_scene("city").unwrap();
    let path = path.with_viewport(256, 192);
    let Some(mut draw) = wgpu_or_skip(&scene) else {
        return;
    };
    assert!(draw.describe().starts_with("wgpu: "), "{}", draw.describe());
    let renderer = Renderer::new(2).unwrap();
    let options = WalkOptions {
        frames: Some(12),
        oracle: true,
        ..WalkOptions::default()
    };
    let walk = |frame_draw: Option<&mut dyn FrameDraw>, scene: &mut hom::scene::Scene| {
        let settings = hom_walk::cullers::CullerSettings::for_scene(scene);
        let mut settings = settings;
        settings.hom.cost_model = false;
        let mut culler = hom_walk::cullers::make("masked", scene, &settings).unwrap();
        hom_walk::walk_drawn(
            scene,
            &animation,
            &path,
            culler.as_mut(),
            &renderer,
            frame_draw,
            &options,
            |_| {},
        )
        .unwrap()
    };
    let software = walk(None, &mut scene);
    let wgpu = walk(Some(&mut draw), &mut scene);
    assert_eq!(software.header.renderer, "software");
    assert!(wgpu.header.renderer.starts_with("wgpu: "));
    for (s, w) in software.frames.iter().zip(&wgpu.frames) {
        assert_eq!(s.visible_clusters, w.visible_clusters, "frame {}", s.frame);
        let o = w.oracle.as_ref().unwrap();
        assert!(o.false_culls.is_empty(), "frame {}: {:?}", w.frame, o.false_culls);
        assert!(w.stages_ms["render"] > 0.0, "frame {}", w.frame);
        assert!(w.baseline_frame_ms.is_some_and(|ms| ms > 0.0));
    }
}

/// Whether `pixel` shows object `id` as the flat shading draws it (its
/// colour times a light in [0.25, 1]), or the background where `id` is none.
fn shows(pixel: [u8; 3], id: u32) -> bool {
    if id == NO_OBJECT {
        return pixel == hom_render::DEFAULT_BACKGROUND;
    }
    let base = hom_render::id_colour(id).map(f32::from);
    let p = pixel.map(f32::from);
    let k = (0..3).map(|c| p[c] * base[c]).sum::<f32>() / (0..3).map(|c| base[c] * base[c]).sum::<f32>();
    (0.2..=1.05).contains(&k) && (0..3).all(|c| (p[c] - k * base[c]).abs() <= 6.0)
}

#[test]
fn headless_pictures_show_the_oracles_objects_up_to_edge_pixels() {
    let (mut scene, path, animation) = hom_walk::open_scene("office").unwrap();
    let mut path = path.with_viewport(320, 240);
    let n = path.frames.len();
    path.frames = path.frames.iter().copied().step_by(n.div_ceil(4)).collect();
    // Skip here where there is no adapter; `headless::run` would fail.
    if wgpu_or_skip(&scene).is_none() {
        return;
    }
    let dir = std::env::temp_dir().join(format!("hom-view-headless-{}", std::process::id()));
    let options = hom_view::headless::HeadlessOptions {
        frames: None,
        out: dir.clone(),
        viewer: hom_view::ViewerOptions {
            overlay: false,
            inset: false,
            figures: false,
        },
        frame_rate: 30.0,
    };
    let settings = hom_walk::cullers::CullerSettings::for_scene(&scene);
    let mut culler = hom_walk::cullers::make("masked", &scene, &settings).unwrap();
    let summary = hom_view::headless::run(
        &mut scene,
        &animation,
        &path,
        culler.as_mut(),
        "masked",
        &options,
        |_| {},
    )
    .unwrap();
    assert_eq!(summary.pictures.len(), path.frames.len());
    let renderer = Renderer::new(2).unwrap();
    let mut fb = Framebuffer::new(320, 240);
    let item_only = RenderOptions {
        shading: Shading::ItemOnly,
        ..RenderOptions::default()
    };
    for (i, file) in summary.pictures.iter().enumerate() {
        animation.apply(&mut scene, i as f32 / 30.0);
        let ids: Vec<u32> = scene.live_objects().map(|(id, _)| id).collect();
        renderer.render(&scene, &ids, &path.camera(i), &item_only, &mut fb);
        let picture = image::open(file).unwrap().to_rgb8();
        // The light differs (from a triangle's centroid on the CPU, from each
        // pixel on the GPU), so the test is which object a pixel shows.
        let wrong = picture
            .pixels()
            .zip(fb.items())
            .filter(|(p, &id)| !shows(p.0, id))
            .count();
        assert!(
            wrong * 200 < fb.items().len(),
            "frame {i}: {wrong} pixels show another object"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A ground cut into clusters and a sign: the figures count two objects and
/// the clusters apart.
#[test]
fn figures_count_objects_and_their_clusters() {
    use hom::glam::{Mat4, Vec3};
    let mut scene = hom::scene::Scene::new("cut ground");
    let ground = scene.add_mesh(hom_testkit::grid_mesh(30));
    let options = hom::clusters::ClusterOptions::default();
    let at = Mat4::from_translation(Vec3::new(-15.0, 0.0, -30.0));
    let clusters = scene.add_clustered_object("ground", ground, at, &options).unwrap();
    let quad = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y].to_vec();
    let sign = scene.add_mesh(hom::scene::Mesh::new("sign", quad, vec![[0, 1, 2], [0, 2, 3]]).unwrap());
    scene
        .add_object("sign", sign, Mat4::from_translation(Vec3::new(0.0, 0.0, -8.0)))
        .unwrap();
    if wgpu_or_skip(&scene).is_none() {
        return;
    }
    let path = hom_scene::CameraPath {
        width: 160,
        height: 120,
        frames: vec![hom_scene::PathFrame {
            eye: [0.0, 2.0, 4.0],
            target: [0.0, 0.0, -10.0],
        }],
        ..serde_json::from_str(r#"{"frames":[]}"#).unwrap()
    };
    let dir = std::env::temp_dir().join(format!("hom-view-figures-{}", std::process::id()));
    let options = hom_view::headless::HeadlessOptions {
        frames: None,
        out: dir.clone(),
        viewer: hom_view::ViewerOptions::default(),
        frame_rate: 30.0,
    };
    let mut culler =
        hom_walk::cullers::make("frustum", &scene, &hom_walk::cullers::CullerSettings::for_scene(&scene)).unwrap();
    let summary = hom_view::headless::run(
        &mut scene,
        &hom_scene::Animation::default(),
        &path,
        culler.as_mut(),
        "frustum",
        &options,
        |_| {},
    )
    .unwrap();
    let f = summary.figures[0];
    assert_eq!((f.objects, f.clusters), (2, clusters.len() + 1));
    assert_eq!(f.objects_drawn, 2, "the ground and the sign in view");
    assert!(f.clusters_drawn > 2 && f.clusters_drawn < f.clusters, "{f:?}");
    let _ = std::fs::remove_dir_all(&dir);
}
