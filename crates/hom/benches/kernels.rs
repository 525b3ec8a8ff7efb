//! The HOM culler's per-frame kernels on a real frame: a 1024×1024 view of the
//! built-in city (frame 100 of its walkthrough) with the default occluder
//! selection.
//!
//! - `pyramid`: build the 256×256-base occlusion pyramid (block 4) from the
//!   frame's coverage bitmap, and the reduction of the levels above the base alone.
//! - `overlap`: the hierarchical overlap test on that pyramid for 10k screen
//!   rectangles (the frame's object footprints, then random rectangles of
//!   log-uniform size); throughput is box tests per second.
//! - `depth`: the depth estimation buffer (64×64 cells): insert 200 occluder
//!   rectangles, and 10k occludee tests.
//! - `raster`: the frame's selected occluders drawn through the front door
//!   (clear, `render_triangles` per occluder, flush): into a `HomBuffer`
//!   with a single Z plane (coverage and pyramid), with the rasterized depth
//!   estimation buffer (the default), and into an `HzBuffer`; once per raster
//!   backend the CPU supports (`[scalar]`, `[sse41]`, `[avx2]`, `[avx512]`;
//!   the ones it lacks are named on stderr and skipped).
//!
//! `cargo bench -p hom --bench kernels -- --warm-up-time 1 --measurement-time 2`
//! (append `raster` for the raster group alone)

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use hom::cull::{CullOutput, Culler, HomConfig, HomCuller};
use hom::geom::{project_box_clipped, project_points, Camera, Footprint, ScreenRect};
use hom::occlusion::details::CoverageBuffer;
use hom::occlusion::details::DepthEstimationBuffer;
use hom::occlusion::details::{rect_covered, OverlapStats, Pyramid, Thresholds};
use hom::occlusion::RasterBackend;
use hom::occlusion::{BufferOptions, DepthMode, FaceCull, HomBuffer, HzBuffer, MapOptions, OcclusionBuffer, Sampling};
use hom::scene::Scene;
use hom_testkit::Rng;
use std::hint::black_box;
use std::time::Duration;

const SIDE: u32 = 1024;
const BLOCK: u32 = 4;
const TESTS: usize = 10_000;
const OCCLUDERS: usize = 200;

/// The city at frame 100 of its walkthrough, at `SIDE`×`SIDE`, with its occluders.
struct Frame {
    scene: Scene,
    camera: Camera,
    occluders: Vec<u32>,
    coverage: CoverageBuffer,
}

fn city_frame() -> Frame {
    let b = hom_scene::builtin("city").expect("the built-in city");
    let path = b.path.with_viewport(SIDE, SIDE);
    let camera = path.camera(100);
    let scene = b.scene;
    // The HOM culler's own occluder selection for this frame (default budget).
    let mut culler = HomCuller::new(&scene, HomConfig::default());
    let mut out = CullOutput::default();
    culler
        .cull(&scene, &camera.to_view(), &mut out)
        .expect("a valid camera");
    let occluders = out.occluders;
    let mut map = HomBuffer::new(SIDE, SIDE, exact(None)).expect("a valid size");
    draw_occluders(&mut map, &scene, &occluders, &camera);
    let coverage = map.coverage().clone();
    Frame {
        scene,
        camera,
        occluders,
        coverage,
    }
}

/// Buffer options with the renderer's exact sampling (as the cullers use).
fn exact(backend: Option<RasterBackend>) -> BufferOptions {
    BufferOptions {
        sampling: Sampling::Exact,
        backend,
        ..BufferOptions::default()
    }
}

/// Clears `buf`, queues every occluder's mesh and draws them.
fn draw_occluders(buf: &mut impl OcclusionBuffer, scene: &Scene, occluders: &[u32], camera: &Camera) {
    buf.clear();
    let vp = camera.view_proj();
    for &id in occluders {
        let o = scene.object(id);
        let m = scene.mesh_of(o);
        buf.render_triangles(m.positions(), m.triangles(), &(vp * o.transform), FaceCull::None)
            .expect("scene meshes are valid");
    }
    buf.flush();
}

/// A rectangle of log-uniform side in 1..=512 pixels at a uniform position.
fn random_rect(rng: &mut Rng, z_near: f32, z_far: f32) -> ScreenRect {
    let mut side = || 512f32.powf(rng.unit()).round().max(1.0) as u32;
    let (w, h) = (side(), side());
    let x0 = (rng.unit() * SIDE as f32) as u32 % SIDE;
    let y0 = (rng.unit() * SIDE as f32) as u32 % SIDE;
    ScreenRect {
        x0,
        y0,
        x1: (x0 + w).min(SIDE),
        y1: (y0 + h).min(SIDE),
        z_near,
        z_far,
    }
}

/// The frame's object footprints, then random rectangles, `TESTS` in all.
fn test_rects(frame: &Frame) -> Vec<ScreenRect> {
    let vp = frame.camera.view_proj();
    let mut rects: Vec<ScreenRect> = frame
        .scene
        .objects()
        .iter()
        .filter_map(|o| match project_points(&o.aabb.corners(), &vp, SIDE, SIDE) {
            Footprint::Rect(r) if !r.is_empty() => Some(r),
            _ => None,
        })
        .take(TESTS)
        .collect();
    let mut rng = Rng::new(0x9E37_79B9_7F4A_7C15);
    while rects.len() < TESTS {
        let z = 0.9 + 0.1 * rng.unit();
        rects.push(random_rect(&mut rng, z, z));
    }
    rects
}

fn pyramid(c: &mut Criterion, frame: &Frame) {
    let bits = frame.coverage.bits();
    let wpr = frame.coverage.words_per_row();
    let mut p = Pyramid::new(SIDE, SIDE, BLOCK, 4);
    let base = &p.levels()[0];
    eprintln!(
        "pyramid: {} levels, base {}x{}; {} occluders cover {:.1}% of the samples",
        p.levels().len(),
        base.width,
        base.height,
        frame.occluders.len(),
        100.0 * frame.coverage.covered() as f64 / (SIDE * SIDE) as f64
    );
    let mut g = c.benchmark_group("pyramid");
    g.bench_function("build_from_coverage 1024x1024 -> 256x256 base", |b| {
        b.iter(|| {
            p.build_from_coverage(black_box(bits), wpr);
            black_box(p.levels()[1].counts[0]);
        })
    });
    g.bench_function("build_levels (above the 256x256 base)", |b| {
        b.iter(|| {
            p.build_levels();
            black_box(p.levels()[1].counts[0]);
        })
    });
    g.finish();
}

fn overlap(c: &mut Criterion, frame: &Frame) {
    let mut p = Pyramid::new(SIDE, SIDE, BLOCK, 4);
    p.build_from_coverage(frame.coverage.bits(), frame.coverage.words_per_row());
    let th = Thresholds::conservative(&p, 0.0);
    let early = Thresholds::conservative(&p, 0.5);
    let rects = test_rects(frame);
    let mut stats = OverlapStats::default();
    let covered = rects.iter().filter(|r| rect_covered(&p, &th, r, &mut stats)).count();
    eprintln!(
        "overlap: {covered} of {} rectangles covered; {:.1} pyramid pixels and {:.2} level visits per test",
        rects.len(),
        stats.pixels as f64 / rects.len() as f64,
        stats.levels as f64 / rects.len() as f64
    );
    let mut g = c.benchmark_group("overlap");
    g.throughput(Throughput::Elements(rects.len() as u64));
    for (name, th) in [
        ("rect_covered x10k, conservative", &th),
        ("rect_covered x10k, transparency 0.5", &early),
    ] {
        g.bench_function(name, |b| {
            b.iter(|| {
                let mut stats = OverlapStats::default();
                let n = rects.iter().filter(|r| rect_covered(&p, th, r, &mut stats)).count();
                black_box((n, stats))
            })
        });
    }
    g.finish();
}

fn depth(c: &mut Criterion, frame: &Frame) {
    let vp = frame.camera.view_proj();
    // The frame's occluder rectangles, padded with random ones to 200.
    let mut occluders: Vec<ScreenRect> = frame
        .occluders
        .iter()
        .filter_map(|&id| project_box_clipped(&frame.scene.object(id).aabb.corners(), &vp, SIDE, SIDE))
        .take(OCCLUDERS)
        .collect();
    let mut rng = Rng::new(0xD1B5_4A32_D192_ED03);
    while occluders.len() < OCCLUDERS {
        let z = 0.9 + 0.09 * rng.unit();
        occluders.push(random_rect(&mut rng, z - 0.01, z));
    }
    let occludees = test_rects(frame);
    let mut deb = DepthEstimationBuffer::new(SIDE, SIDE, 64, 64);
    let mut g = c.benchmark_group("depth");
    g.throughput(Throughput::Elements(OCCLUDERS as u64));
    g.bench_function("clear + insert_occluder x200", |b| {
        b.iter(|| {
            deb.clear();
            for r in &occluders {
                deb.insert_occluder(black_box(r));
            }
            black_box(deb.cells()[0])
        })
    });
    let behind = occludees.iter().filter(|r| deb.is_behind(r)).count();
    eprintln!("depth: {behind} of {} occludees behind the occluders", occludees.len());
    g.throughput(Throughput::Elements(occludees.len() as u64));
    g.bench_function("is_behind x10k", |b| {
        b.iter(|| black_box(occludees.iter().filter(|r| deb.is_behind(r)).count()))
    });
    g.finish();
}

fn raster(c: &mut Criterion, frame: &Frame) {
    let triangles: u64 = frame
        .occluders
        .iter()
        .map(|&id| frame.scene.object(id).triangles as u64)
        .sum();
    eprintln!("raster: {} occluders, {triangles} triangles", frame.occluders.len());
    let mut g = c.benchmark_group("raster");
    g.throughput(Throughput::Elements(triangles));
    // The scalar path against every vector backend this CPU supports.
    eprintln!(
        "raster: backends {:?}, detected {:?}, default {:?}",
        RasterBackend::supported(),
        RasterBackend::detect(),
        RasterBackend::active()
    );
    let skipped: Vec<&str> = RasterBackend::ALL
        .into_iter()
        .filter(|b| !b.is_supported())
        .map(|b| b.name())
        .collect();
    if !skipped.is_empty() {
        eprintln!("raster: skipped (CPU lacks them): {}", skipped.join(", "));
    }
    for backend in RasterBackend::supported() {
        let name = backend.name();
        for (label, depth) in [
            ("single Z plane", DepthMode::SingleZPlane),
            ("depth buffer", DepthMode::Rasterized(64, 64)),
        ] {
            let map = MapOptions {
                depth,
                ..MapOptions::default()
            };
            let mut buf = HomBuffer::with_map(SIDE, SIDE, exact(Some(backend)), map).expect("a valid size");
            g.bench_function(
                format!("HomBuffer, {label}, city frame 100 at 1024x1024 [{name}]"),
                |b| b.iter(|| draw_occluders(&mut buf, &frame.scene, &frame.occluders, &frame.camera)),
            );
        }
        let mut buf = HzBuffer::new(SIDE, SIDE, exact(Some(backend))).expect("a valid size");
        g.bench_function(format!("HzBuffer, city frame 100 at 1024x1024 [{name}]"), |b| {
            b.iter(|| draw_occluders(&mut buf, &frame.scene, &frame.occluders, &frame.camera))
        });
    }
    g.finish();
}

fn kernels(c: &mut Criterion) {
    let frame = city_frame();
    pyramid(c, &frame);
    overlap(c, &frame);
    depth(c, &frame);
    raster(c, &frame);
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(2))
        .sample_size(50);
    targets = kernels
}
criterion_main!(benches);
