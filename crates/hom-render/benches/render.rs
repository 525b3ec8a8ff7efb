//! Frame time of the reference renderer on a synthetic ~300k-triangle scene at 1024x1024.
//!
//! `cargo bench -p hom-render --bench render -- --warm-up-time 1 --measurement-time 3`

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use hom::geom::Camera;
use hom::glam::{Mat4, Vec3};
use hom::scene::{Mesh, Scene, SceneBuilder};
use hom_render::{Framebuffer, RenderOptions, Renderer, Shading};
use std::hint::black_box;

/// A unit cube centred at the origin with each face split into `n` x `n` quads.
fn tessellated_box(n: u32) -> Mesh {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    let axes = [
        (Vec3::X, Vec3::Y, Vec3::Z),
        (Vec3::Y, Vec3::Z, Vec3::X),
        (Vec3::Z, Vec3::X, Vec3::Y),
    ];
    for (u, v, w) in axes {
        for side in [-0.5f32, 0.5] {
            let base = positions.len() as u32;
            for j in 0..=n {
                for i in 0..=n {
                    let (a, b) = (i as f32 / n as f32 - 0.5, j as f32 / n as f32 - 0.5);
                    positions.push(u * a + v * b + w * side);
                }
            }
            for j in 0..n {
                for i in 0..n {
                    let k = base + j * (n + 1) + i;
                    triangles.push([k, k + 1, k + n + 2]);
                    triangles.push([k, k + n + 2, k + n + 1]);
                }
            }
        }
    }
    Mesh::new("tessellated box", positions, triangles).unwrap()
}

/// 40 x 40 boxes of 192 triangles (307,200 triangles) on a grid, varied heights.
fn scene() -> Scene {
    let mut b = SceneBuilder::new("bench boxes");
    let m = b.add_mesh(tessellated_box(4));
    for j in 0..40 {
        for i in 0..40 {
            let h = 1.0 + ((i * 7 + j * 13) % 5) as f32;
            let t = Mat4::from_translation(Vec3::new(i as f32 * 2.0 - 40.0, h * 0.5, j as f32 * 2.0 - 40.0))
                * Mat4::from_scale(Vec3::new(1.2, h, 1.2));
            b.add_object(format!("box {i},{j}"), m, t).unwrap();
        }
    }
    b.build().unwrap()
}

fn bench(c: &mut Criterion) {
    let scene = scene();
    let ids: Vec<u32> = (0..scene.objects().len() as u32).collect();
    // Above one corner of the grid, looking across it: every box in view.
    let camera = Camera::new(
        Vec3::new(-50.0, 25.0, -50.0),
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::Y,
        60f32.to_radians(),
        0.5,
        500.0,
        1024,
        1024,
    );
    let mut group = c.benchmark_group("render 307k tris 1024x1024");
    group.sample_size(10);
    group.throughput(Throughput::Elements(scene.triangle_count()));
    for threads in [1, 2] {
        let renderer = Renderer::new(threads).unwrap();
        let mut fb = Framebuffer::new(1024, 1024);
        for (name, shading) in [("item-only", Shading::ItemOnly), ("flat", Shading::Flat)] {
            let options = RenderOptions {
                shading,
                ..RenderOptions::default()
            };
            let stats = renderer.render(&scene, &ids, &camera, &options, &mut fb);
            eprintln!("{name}, {threads} thread(s): {stats:?}");
            group.bench_with_input(
                BenchmarkId::new(name, format!("{threads} threads")),
                &threads,
                |b, _| b.iter(|| black_box(renderer.render(&scene, &ids, &camera, &options, &mut fb))),
            );
        }
        if std::env::var_os("HOM_RENDER_BENCH_PNG").is_some() {
            let path = std::env::temp_dir().join("hom-render-bench.png");
            fb.save_png(&path).unwrap();
            eprintln!("wrote {}", path.display());
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
