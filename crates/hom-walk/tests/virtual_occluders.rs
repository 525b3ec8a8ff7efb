//! Virtual occluders (Law & Tan 1999, section 4) against their originals:
//! from every view they may be used from, a stand-in covers no sample the
//! original leaves open and is never nearer (as the cullers draw it, against
//! the renderer's original); holes stay open; hostile meshes get a stand-in
//! or a reason, never a panic. (Walks with virtual occluders against the
//! oracle: `builtin_walks.rs`, every built-in scene and occlusion culler.)

use glam::{Mat4, Quat, Vec3};
use hom::geom::{Camera, Eye, Frustum};
use hom::occluders::{NoVirtual, VirtualConfig, VirtualOccluder};
use hom::scene::Mesh;
use hom_render::stand_in::compare_virtual_occluder;
use hom_render::Renderer;
use hom_testkit::Rng;
use proptest::prelude::*;

/// A mesh under construction: positions and triangles.
#[derive(Default)]
struct Soup {
    p: Vec<Vec3>,
    t: Vec<[u32; 3]>,
}

impl Soup {
    fn quad(&mut self, a: u32, b: u32, c: u32, d: u32) {
        self.t.push([a, b, c]);
        self.t.push([a, c, d]);
    }

    /// A closed box `lo..hi` placed by `xf`.
    fn closed_box(&mut self, lo: Vec3, hi: Vec3, xf: Mat4) {
        let b = self.p.len() as u32;
        for i in 0..8 {
            let c = Vec3::select(glam::BVec3::new(i & 1 != 0, i & 2 != 0, i & 4 != 0), hi, lo);
            self.p.push(xf.transform_point3(c));
        }
        for f in [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ] {
            self.quad(b + f[0], b + f[1], b + f[2], b + f[3]);
        }
    }

    /// A cylinder of `seg` sides along `a..b`, capped or open.
    fn cylinder(&mut self, a: Vec3, b: Vec3, r: f32, seg: u32, caps: bool) {
        let d = (b - a).normalize();
        let u = d.any_orthonormal_vector();
        let v = d.cross(u);
        let base = self.p.len() as u32;
        for i in 0..seg {
            let t = i as f32 / seg as f32 * std::f32::consts::TAU;
            let o = (u * t.cos() + v * t.sin()) * r;
            self.p.extend([a + o, b + o]);
        }
        for i in 0..seg {
            let j = (i + 1) % seg;
            self.quad(base + 2 * i, base + 2 * j, base + 2 * j + 1, base + 2 * i + 1);
        }
        if caps {
            for off in 0..2 {
                for i in 1..seg - 1 {
                    self.t.push([base + off, base + 2 * i + off, base + 2 * (i + 1) + off]);
                }
            }
        }
    }

    /// A UV sphere.
    fn sphere(&mut self, c: Vec3, r: f32, n: u32) {
        let base = self.p.len() as u32;
        self.p.push(c + Vec3::Y * r);
        for s in 1..n {
            let phi = s as f32 / n as f32 * std::f32::consts::PI;
            for i in 0..2 * n {
                let th = i as f32 / (2 * n) as f32 * std::f32::consts::TAU;
                self.p
                    .push(c + Vec3::new(phi.sin() * th.cos(), phi.cos(), phi.sin() * th.sin()) * r);
            }
        }
        self.p.push(c - Vec3::Y * r);
        let south = self.p.len() as u32 - 1;
        let ring = |s: u32, i: u32| base + 1 + (s - 1) * 2 * n + i % (2 * n);
        for i in 0..2 * n {
            self.t.push([base, ring(1, i + 1), ring(1, i)]);
            self.t.push([south, ring(n - 1, i), ring(n - 1, i + 1)]);
            for s in 1..n - 1 {
                self.quad(ring(s, i), ring(s, i + 1), ring(s + 1, i + 1), ring(s + 1, i));
            }
        }
    }

    /// An open height-field sheet over `lo..hi` (x, z) at heights from `h`.
    fn sheet(&mut self, lo: Vec3, hi: Vec3, n: u32, h: impl Fn(f32, f32) -> f32) {
        let base = self.p.len() as u32;
        for j in 0..=n {
            for i in 0..=n {
                let (x, z) = (
                    lo.x + (hi.x - lo.x) * i as f32 / n as f32,
                    lo.z + (hi.z - lo.z) * j as f32 / n as f32,
                );
                self.p.push(Vec3::new(x, h(x, z), z));
            }
        }
        for j in 0..n {
            for i in 0..n {
                let a = base + j * (n + 1) + i;
                self.quad(a, a + 1, a + n + 2, a + n + 1);
            }
        }
    }

    fn mesh(self) -> Mesh {
        Mesh::new("test mesh", self.p, self.t).unwrap()
    }
}

/// A random assembly: rotated boxes, capped and open cylinders, spheres,
/// sometimes an open sheet.
fn random_mesh(rng: &mut Rng) -> Mesh {
    let mut s = Soup::default();
    for _ in 0..1 + rng.below(6) {
        let c = rng.vec3(-2.0, 2.0);
        match rng.below(4) {
            0 => {
                let xf = Mat4::from_rotation_translation(
                    Quat::from_euler(glam::EulerRot::XYZ, rng.range(0.0, 3.0), rng.range(0.0, 3.0), 0.0),
                    c,
                );
                let half = rng.vec3(0.05, 1.5);
                s.closed_box(-half, half, xf);
            }
            1 => {
                let d = rng.vec3(-1.0, 1.0).normalize_or(Vec3::X) * rng.range(0.5, 3.0);
                s.cylinder(
                    c,
                    c + d,
                    rng.range(0.1, 1.0),
                    8 + rng.below(24) as u32,
                    rng.below(3) > 0,
                );
            }
            2 => s.sphere(c, rng.range(0.2, 1.5), 6 + rng.below(12) as u32),
            _ => {
                let lo = c - Vec3::new(1.0, 0.0, 1.0);
                let (a, b) = (rng.range(0.1, 2.0), rng.range(0.1, 2.0));
                s.sheet(lo, lo + Vec3::new(2.0, 0.0, 2.0), 4, |x, z| {
                    c.y + (x * a).sin() * (z * b).cos()
                });
            }
        }
    }
    // Dense enough that the budget allows boxes.
    while s.t.len() < 300 {
        s.sphere(Vec3::new(9.0, 9.0, 9.0), 0.5, 8);
    }
    s.mesh()
}

/// Views of the object from outside: eyes on shells around it.
fn views(rng: &mut Rng, centre: Vec3, radius: f32, count: usize) -> Vec<Camera> {
    (0..count)
        .filter_map(|_| {
            let dir = rng.vec3(-1.0, 1.0).normalize_or(Vec3::Z);
            let eye = centre + dir * radius * rng.range(1.1, 4.0);
            let target = centre + rng.vec3(-0.5, 0.5) * radius;
            let camera = Camera::new(eye, target, Vec3::Y, rng.range(0.4, 1.4), 0.05, 200.0, 64, 48);
            camera.validate().ok().map(|_| camera)
        })
        .collect()
}

/// Violations over `cameras` from which `v` may stand in, and how many such views.
fn violations(original: &Mesh, v: &VirtualOccluder, transform: Mat4, cameras: &[Camera]) -> (u64, usize) {
    let renderer = Renderer::new(1).unwrap();
    let world = original.bounds();
    let corners: Vec<Vec3> = (0..8)
        .map(|i| {
            transform.transform_point3(Vec3::select(
                glam::BVec3::new(i & 1 != 0, i & 2 != 0, i & 4 != 0),
                world.max,
                world.min,
            ))
        })
        .collect();
    let world_box = hom::geom::Aabb::from_points(corners);
    let (mut bad, mut used) = (0, 0);
    for camera in cameras {
        let frustum = Frustum::from_view_proj(&camera.view_proj()).unwrap();
        if !v.usable(&transform, &world_box, &Eye::Point(camera.eye), &frustum) {
            continue;
        }
        used += 1;
        bad += compare_virtual_occluder(&renderer, original, v, transform, camera).violations;
    }
    (bad, used)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn virtual_occluders_never_cover_what_the_original_leaves_open(seed in any::<u64>()) {
        let mut rng = Rng::new(seed);
        let original = random_mesh(&mut rng);
        let transform = Mat4::from_scale_rotation_translation(
            rng.vec3(0.5, 2.0),
            Quat::from_rotation_y(rng.range(0.0, 6.0)),
            rng.vec3(-5.0, 5.0),
        );
        if let Ok(v) = VirtualOccluder::bake(&original, &VirtualConfig::default()) {
            prop_assert!(v.mesh().triangle_count() < original.triangle_count());
            // Deterministic: a second bake (other hash seeds) gives the same stand-in.
            let again = VirtualOccluder::bake(&original, &VirtualConfig::default()).unwrap();
            prop_assert_eq!(again.mesh().positions(), v.mesh().positions());
            prop_assert_eq!(again.mesh().triangles(), v.mesh().triangles());
            let b = original.bounds();
            let centre = transform.transform_point3(b.center());
            let radius = b.half_extent().length() * 2.0;
            let cameras = views(&mut rng, centre, radius, 24);
            let (bad, _) = violations(&original, &v, transform, &cameras);
            prop_assert_eq!(bad, 0);
        }
    }
}

#[test]
fn dense_solids_get_small_stand_ins_that_hold_from_ten_thousand_views() {
    // A machine-like assembly: a block, a capped drum, a sphere; ~2,700 triangles.
    let mut s = Soup::default();
    s.closed_box(Vec3::new(-2.0, 0.0, -1.0), Vec3::new(2.0, 1.5, 1.0), Mat4::IDENTITY);
    s.cylinder(Vec3::new(-1.5, 1.5, 0.0), Vec3::new(1.5, 1.5, 0.0), 0.7, 48, true);
    s.sphere(Vec3::new(0.0, 2.4, 0.0), 0.6, 24);
    let original = s.mesh();
    let v = VirtualOccluder::bake(&original, &VirtualConfig::default()).unwrap();
    assert!(v.mesh().triangle_count() * 20 <= original.triangle_count().max(64 * 20));
    assert!(v.coverage() >= 0.8, "{}", v.coverage());
    let mut rng = Rng::new(5);
    let cameras = views(&mut rng, original.bounds().center(), 3.0, 10_000);
    let (bad, used) = violations(&original, &v, Mat4::IDENTITY, &cameras);
    assert!(used > 9_000, "{used} views");
    assert_eq!(bad, 0);
}

#[test]
fn a_one_pixel_window_through_a_wall_stays_open() {
    // A wall 4 x 4 x 0.5 built of four boxes around a 0.04 m window at its centre.
    let (w, h) = (2.0, 0.02);
    let mut s = Soup::default();
    for (lo, hi) in [
        (Vec3::new(-w, -w, 0.0), Vec3::new(-h, w, 0.5)),
        (Vec3::new(h, -w, 0.0), Vec3::new(w, w, 0.5)),
        (Vec3::new(-h, -w, 0.0), Vec3::new(h, -h, 0.5)),
        (Vec3::new(-h, h, 0.0), Vec3::new(h, w, 0.5)),
    ] {
        s.closed_box(lo, hi, Mat4::IDENTITY);
    }
    // Padding far away, so the budget allows boxes.
    s.sphere(Vec3::new(30.0, 30.0, 40.0), 0.1, 12);
    let original = s.mesh();
    let v = VirtualOccluder::bake(&original, &VirtualConfig::default()).unwrap();
    // Looking straight through the window from 10 m, a pixel is ~0.04 m wide.
    let camera = Camera::new(
        Vec3::new(0.0, 0.0, -10.0),
        Vec3::ZERO,
        Vec3::Y,
        2.0 * (0.02f32 * 63.0 / 10.0).atan(),
        0.1,
        100.0,
        63,
        63,
    );
    let renderer = Renderer::new(1).unwrap();
    let c = compare_virtual_occluder(&renderer, &original, &v, Mat4::IDENTITY, &camera);
    assert_eq!(c.violations, 0);
    assert!(c.original < 63 * 63, "the window shows through the original");
    assert!(c.stand_in > 0);
}

#[test]
fn open_sheets_and_terrain_give_no_stand_in_or_stay_themselves() {
    // A big height field: open, too many triangles to keep whole: no solid.
    let mut s = Soup::default();
    s.sheet(Vec3::new(-50.0, 0.0, -50.0), Vec3::new(50.0, 0.0, 50.0), 40, |x, z| {
        (x * 0.1).sin() * (z * 0.1).cos() * 5.0
    });
    let terrain = s.mesh();
    assert!(matches!(
        VirtualOccluder::bake(&terrain, &VirtualConfig::default()),
        Err(NoVirtual::NoSolid { .. })
    ));
    // A terrain tile with a hole smaller than a triangle: one missing quad
    // leaves the sheet open, so nothing is kept and the hole stays open.
    let mut s = Soup::default();
    s.sheet(Vec3::new(0.0, 0.0, 0.0), Vec3::new(10.0, 0.0, 10.0), 30, |x, _| x * 0.1);
    s.t.drain(400..402);
    assert!(VirtualOccluder::bake(&s.mesh(), &VirtualConfig::default()).is_err());
}

#[test]
fn hostile_meshes_get_a_stand_in_or_a_reason() {
    let config = VirtualConfig::default();
    let bake = |p: Vec<Vec3>, t: Vec<[u32; 3]>| VirtualOccluder::bake(&Mesh::new("hostile", p, t).unwrap(), &config);
    // One triangle.
    assert!(bake(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).is_err());
    // Degenerate triangles only.
    assert!(bake(vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.0], vec![[0, 1, 2]; 500]).is_err());
    assert!(bake(vec![Vec3::ONE], vec![[0, 0, 0]; 500]).is_err());
    // Non-manifold: three boxes' worth of faces on one edge, and a fin.
    let mut s = Soup::default();
    for k in 0..40 {
        s.closed_box(Vec3::ZERO, Vec3::ONE + Vec3::X * k as f32 * 0.01, Mat4::IDENTITY);
    }
    s.t.push([0, 1, 3]);
    let _ = bake(s.p, s.t);
    // Absurd scales, tiny and huge.
    for scale in [1e-30f32, 1e-12, 1e12, 1e30] {
        let mut s = Soup::default();
        s.sphere(Vec3::ZERO, scale, 16);
        if let Ok(v) = bake(s.p.clone(), s.t.clone()) {
            let b = v.mesh().bounds();
            assert!(b.is_finite() && b.max.length() <= scale * 1.01, "{scale}: {b:?}");
        }
    }
    // A million coplanar slivers.
    let n = 1_000_000u32;
    let p: Vec<Vec3> = (0..=n)
        .flat_map(|i| {
            [
                Vec3::new(i as f32 * 1e-3, 0.0, 0.0),
                Vec3::new(i as f32 * 1e-3, 0.0, 1e-6),
            ]
        })
        .collect();
    let t: Vec<[u32; 3]> = (0..n).map(|i| [2 * i, 2 * i + 2, 2 * i + 1]).collect();
    assert!(bake(p, t).is_err());
    // Bad settings.
    let mut s = Soup::default();
    s.sphere(Vec3::ZERO, 1.0, 16);
    let bad = VirtualConfig {
        max_share: f32::NAN,
        ..VirtualConfig::default()
    };
    assert!(matches!(
        VirtualOccluder::bake(&s.mesh(), &bad),
        Err(NoVirtual::BadConfig(_))
    ));
}

/// The spheres' walk: `(frames drawing some original for its virtual
/// occluder, triangles HOM culled by occlusion)`, with or without the
/// budget left over buying originals back.
fn spheres_walk(originals_from_leftover: bool) -> (usize, u64) {
    let built = hom_scene::builtin("spheres").unwrap();
    let (mut scene, animation) = (built.scene, built.animation);
    let mut path = built.path.with_viewport(320, 240);
    path.frames = path.frames.iter().copied().step_by(4).collect();
    let mut settings = hom_walk::cullers::CullerSettings::for_scene(&scene);
    settings.hom.occluders.selection.originals_from_leftover = originals_from_leftover;
    // Every frame culls (no resting), so every frame selects.
    settings.hom.cost_model = false;
    let mut culler = hom_walk::cullers::make("hom", &scene, &settings).unwrap();
    let options = hom_walk::WalkOptions {
        oracle: true,
        baseline: false,
        ..hom_walk::WalkOptions::default()
    };
    let renderer = Renderer::new(0).unwrap();
    let result = hom_walk::walk(
        &mut scene,
        &animation,
        &path,
        culler.as_mut(),
        &renderer,
        &options,
        |_| {},
    )
    .unwrap();
    let mut with_originals = 0;
    for f in &result.frames {
        assert!(f.oracle.as_ref().unwrap().false_culls.is_empty(), "frame {}", f.frame);
        let occluders = f.stats.occluders.expect("an occluder culler's frame");
        // Stand-ins count their own triangles; originals bought back fit the budget.
        if occluders.originals > 0 {
            with_originals += 1;
            assert!(
                occluders.triangles <= occluders.budget,
                "frame {}: {:?}",
                f.frame,
                occluders
            );
        }
    }
    let culled = result.frames.iter().map(|f| f.triangles_occlusion_culled).sum();
    (with_originals, culled)
}

#[test]
fn budget_left_over_buys_originals_back_and_culls_more() {
    // Ten 2,208-triangle spheres, a 3,000-triangle budget: ten 48-triangle
    // hulls leave room for one original.
    let (on, culled_on) = spheres_walk(true);
    let (off, culled_off) = spheres_walk(false);
    assert!(on > 0, "no frame drew an original");
    assert_eq!(off, 0);
    assert!(culled_on > culled_off, "{culled_on} <= {culled_off}");
}

#[test]
fn stand_ins_hold_and_keep_their_coverage_on_the_walks_they_were_built_for() {
    for name in ["machine-room", "sculpture-park", "spheres"] {
        let built = hom_scene::builtin(name).unwrap();
        let (mut scene, animation) = (built.scene, built.animation);
        let path = built.path.with_viewport(320, 240);
        let db = hom_walk::virtual_occluders::virtual_db(&scene);
        let w = hom_walk::virtual_occluders::walk_comparison(&mut scene, &animation, &path, &db, 24, |_| {});
        assert_eq!(w.frames, 24);
        assert!(w.compared >= 24, "{name}: {w:?}");
        assert_eq!(w.total.violations, 0, "{name}: {w:?}");
        assert!(w.mean_kept > 0.85 && w.mean_kept <= 1.0, "{name}: {w:?}");
    }
}
