//! The front door (`hom::occlusion`) as an engine meets it, written only
//! against its contract: random occluders in `HzBuffer`, `HomBuffer`, `MaskedBuffer` and `OcclusionTree`
//! under every clip convention, perspective and orthographic, every
//! `Occluded` answer checked by brute-force ray casting (no ray from the eye
//! through a sample may reach a box called occluded, and a fair share of the
//! hidden boxes must be found; solid boxes among the occluders go in as
//! convex stand-ins, drawn as their silhouettes); every convention answers as `ZeroToOne` does
//! on the same geometry; bad input gets its typed error.

use hom_occlusion::geom::Aabb;
use hom_occlusion::glam::camera::rh::proj::{directx, opengl};
use hom_occlusion::glam::camera::rh::view::look_at_mat4;
use hom_occlusion::glam::{DVec3, Mat4, Vec2, Vec3, Vec4};
use hom_occlusion::{
    BufferOptions, ClipConvention, FaceCull, HomBuffer, HzBuffer, MaskedBuffer, OcclusionBuffer, OcclusionError,
    OcclusionTree, Sampling, Threads, Visibility,
};
use hom_testkit::Rng;
use proptest::prelude::*;

/// A pinhole or parallel camera looking from `eye` at `target`.
#[derive(Clone, Copy, Debug)]
struct Cam {
    eye: Vec3,
    target: Vec3,
    ortho: bool,
    width: u32,
    height: u32,
}

const NEAR: f32 = 0.5;
const FAR: f32 = 60.0;
const FOV: f32 = 1.1;
/// Half extent of the orthographic view, metres (vertical).
const ORTHO_HALF: f32 = 8.0;

impl Cam {
    fn aspect(&self) -> f32 {
        self.width as f32 / self.height as f32
    }

    /// The projection of `clip` (reversed Z has an infinite far plane for
    /// perspective, as engines use it; a finite one for orthographic).
    fn view_proj(&self, clip: ClipConvention) -> Mat4 {
        let view = look_at_mat4(self.eye, self.target, Vec3::Y);
        let (a, h) = (self.aspect(), ORTHO_HALF);
        let proj = match (clip, self.ortho) {
            (ClipConvention::ZeroToOne, false) => directx::perspective(FOV, a, NEAR, FAR),
            (ClipConvention::NegOneToOne, false) => opengl::perspective(FOV, a, NEAR, FAR),
            (ClipConvention::ReversedZ, false) => directx::perspective_infinite_reverse(FOV, a, NEAR),
            (ClipConvention::ZeroToOne, true) => directx::orthographic(-h * a, h * a, -h, h, NEAR, FAR),
            (ClipConvention::NegOneToOne, true) => opengl::orthographic(-h * a, h * a, -h, h, NEAR, FAR),
            // Reversed: z' = w − z of the directx one.
            (ClipConvention::ReversedZ, true) => {
                let flip = Mat4::from_cols(
                    Vec4::X,
                    Vec4::Y,
                    Vec4::new(0.0, 0.0, -1.0, 0.0),
                    Vec4::new(0.0, 0.0, 1.0, 1.0),
                );
                flip * directx::orthographic(-h * a, h * a, -h, h, NEAR, FAR)
            }
        };
        proj * view
    }

    /// The ray through the centre of pixel `(px, py)`: origin, unit direction,
    /// and the range of ray parameters inside the near and far planes.
    fn ray(&self, px: u32, py: u32, infinite_far: bool) -> (DVec3, DVec3, f64, f64) {
        let e = self.eye.as_dvec3();
        let f = (self.target.as_dvec3() - e).normalize();
        let r = f.cross(DVec3::Y).normalize();
        let u = r.cross(f);
        let nx = (f64::from(px) + 0.5) / f64::from(self.width) * 2.0 - 1.0;
        let ny = 1.0 - (f64::from(py) + 0.5) / f64::from(self.height) * 2.0;
        let far = if infinite_far { f64::INFINITY } else { f64::from(FAR) };
        if self.ortho {
            let h = f64::from(ORTHO_HALF);
            let o = e + r * (nx * h * f64::from(self.aspect())) + u * (ny * h);
            (o, f, f64::from(NEAR), far)
        } else {
            let t = (f64::from(FOV) * 0.5).tan();
            let d = f + r * (nx * t * f64::from(self.aspect())) + u * (ny * t);
            let along = 1.0 / d.length(); // forward distance per unit of ray length
            (e, d.normalize(), f64::from(NEAR) / along, far / along)
        }
    }
}

/// Random occluder quads (two triangles each) and test boxes in front of the camera.
struct World {
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    /// Solid boxes among `triangles` (after the quads), 12 triangles each,
    /// drawn as convex stand-ins.
    solids: usize,
    boxes: Vec<Aabb>,
}

fn world(seed: u64, quads: usize, solids: usize, boxes: usize, cam: &Cam) -> World {
    let mut rng = Rng::new(seed);
    let f = (cam.target - cam.eye).normalize();
    let (mut positions, mut triangles) = (Vec::new(), Vec::new());
    for q in 0..quads {
        let c = cam.eye
            + f * rng.range(2.0, 25.0)
            + Vec3::new(rng.range(-7.0, 7.0), rng.range(-4.0, 4.0), rng.range(-7.0, 7.0));
        let a = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)).normalize_or(Vec3::X)
            * rng.range(0.5, 5.0);
        let b = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)).normalize_or(Vec3::Y)
            * rng.range(0.5, 5.0);
        positions.extend([c - a - b, c + a - b, c + a + b, c - a + b]);
        let k = 4 * q as u32;
        triangles.extend([[k, k + 1, k + 2], [k, k + 2, k + 3]]);
    }
    let cube = hom_testkit::cube();
    for _ in 0..solids {
        let c = cam.eye
            + f * rng.range(3.0, 25.0)
            + Vec3::new(rng.range(-7.0, 7.0), rng.range(-4.0, 4.0), rng.range(-7.0, 7.0));
        let size = Vec3::new(rng.range(0.3, 4.0), rng.range(0.3, 4.0), rng.range(0.3, 4.0));
        let k = positions.len() as u32;
        positions.extend(cube.positions().iter().map(|&p| c + p * size));
        triangles.extend(cube.triangles().iter().map(|t| t.map(|i| k + i)));
    }
    let boxes = (0..boxes)
        .map(|_| {
            let c = cam.eye
                + f * rng.range(0.0, 40.0)
                + Vec3::new(rng.range(-9.0, 9.0), rng.range(-5.0, 5.0), rng.range(-9.0, 9.0));
            let h = Vec3::new(rng.range(0.05, 1.5), rng.range(0.05, 1.5), rng.range(0.05, 1.5));
            Aabb::new(c - h, c + h)
        })
        .collect();
    World {
        positions,
        triangles,
        solids,
        boxes,
    }
}

/// Ray parameter of the nearest hit of `(o, d)` on triangle `abc` (Möller–Trumbore), if any.
fn hit_triangle(o: DVec3, d: DVec3, [a, b, c]: [DVec3; 3]) -> Option<f64> {
    let (e1, e2) = (b - a, c - a);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-15 {
        return None;
    }
    let s = o - a;
    let u = s.dot(p) / det;
    let q = s.cross(e1);
    let v = d.dot(q) / det;
    if u < 0.0 || v < 0.0 || u + v > 1.0 {
        return None;
    }
    Some(e2.dot(q) / det)
}

/// The first ray parameter in `[lo, hi]` at which `(o, d)` is inside `b`, if any (slabs).
fn hit_box(o: DVec3, d: DVec3, b: &Aabb, lo: f64, hi: f64) -> Option<f64> {
    let (mut t0, mut t1) = (lo, hi);
    for k in 0..3 {
        let (min, max) = (f64::from(b.min[k]), f64::from(b.max[k]));
        if d[k].abs() < 1e-300 {
            if o[k] < min || o[k] > max {
                return None;
            }
            continue;
        }
        let (a, c) = ((min - o[k]) / d[k], (max - o[k]) / d[k]);
        t0 = t0.max(a.min(c));
        t1 = t1.min(a.max(c));
    }
    (t0 <= t1).then_some(t0)
}

/// For each box: does some pixel-centre ray reach it (hit it within the view
/// before any occluder)? And does some pixel-centre ray hit it at all?
fn ray_cast(w: &World, cam: &Cam, infinite_far: bool) -> Vec<(bool, bool)> {
    let tris: Vec<[DVec3; 3]> = w
        .triangles
        .iter()
        .map(|t| t.map(|i| w.positions[i as usize].as_dvec3()))
        .collect();
    let mut out = vec![(false, false); w.boxes.len()];
    for py in 0..cam.height {
        for px in 0..cam.width {
            let (o, d, lo, hi) = cam.ray(px, py, infinite_far);
            let occluder = tris
                .iter()
                .filter_map(|&t| hit_triangle(o, d, t))
                .filter(|&t| t >= lo && t <= hi)
                .fold(f64::INFINITY, f64::min);
            for (k, b) in w.boxes.iter().enumerate() {
                if let Some(t) = hit_box(o, d, b, lo, hi) {
                    out[k].1 = true;
                    if t <= occluder {
                        out[k].0 = true;
                    }
                }
            }
        }
    }
    out
}

const CONVENTIONS: [ClipConvention; 3] = [
    ClipConvention::ZeroToOne,
    ClipConvention::NegOneToOne,
    ClipConvention::ReversedZ,
];

fn options(clip: ClipConvention) -> BufferOptions {
    BufferOptions {
        clip,
        ..BufferOptions::default()
    }
}

/// Every answer of `buf` for the world's boxes.
fn answers(buf: &mut impl OcclusionBuffer, w: &World, view_proj: &Mat4) -> Vec<Visibility> {
    buf.clear();
    let quads = w.triangles.len() - 12 * w.solids;
    buf.render_triangles(&w.positions, &w.triangles[..quads], view_proj, FaceCull::None)
        .unwrap();
    for solid in w.triangles[quads..].chunks(12) {
        buf.render_convex_stand_in(&w.positions, solid, view_proj).unwrap();
    }
    w.boxes.iter().map(|b| buf.test_aabb(b, view_proj)).collect()
}

/// Hidden boxes found and wrongly occluded ones, over random worlds, for one
/// camera kind and convention.
fn check_against_rays(seed: u64, ortho: bool, clip: ClipConvention) -> (usize, usize, usize) {
    let mut rng = Rng::new(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15));
    let eye = Vec3::new(rng.range(-3.0, 3.0), rng.range(-1.0, 2.0), rng.range(-3.0, 3.0));
    let target = eye + Vec3::new(rng.range(-0.5, 0.5), rng.range(-0.2, 0.2), -1.0);
    let cam = Cam {
        eye,
        target,
        ortho,
        width: 48 + (seed % 5) as u32 * 7,
        height: 36 + (seed % 3) as u32 * 5,
    };
    let w = world(seed, 14, 6, 40, &cam);
    let vp = cam.view_proj(clip);
    let truth = ray_cast(&w, &cam, clip == ClipConvention::ReversedZ && !ortho);
    let (mut hidden, mut found, mut wrong) = (0, 0, 0);
    let mut hz = HzBuffer::new(cam.width, cam.height, options(clip)).unwrap();
    let mut hom = HomBuffer::new(cam.width, cam.height, options(clip)).unwrap();
    let mut masked = MaskedBuffer::new(cam.width, cam.height, options(clip)).unwrap();
    let a = answers(&mut hz, &w, &vp);
    let b = answers(&mut hom, &w, &vp);
    let c = answers(&mut masked, &w, &vp);
    let mut tree = OcclusionTree::new(cam.width, cam.height, options(clip)).unwrap();
    let d = answers(&mut tree, &w, &vp);
    for (k, &(reached, seen_anywhere)) in truth.iter().enumerate() {
        for v in [a[k], b[k], c[k], d[k]] {
            if v == Visibility::Occluded && reached {
                wrong += 1;
                eprintln!(
                    "{clip:?} ortho {ortho} seed {seed}: box {k} {:?} called occluded but a ray reaches it",
                    w.boxes[k]
                );
            }
        }
        // Hidden: some pixel-centre ray hits it, and none reaches it.
        if seen_anywhere && !reached {
            hidden += 1;
            found += usize::from(a[k] == Visibility::Occluded);
        }
    }
    (hidden, found, wrong)
}

#[test]
fn no_box_called_occluded_is_reached_by_a_ray_and_hidden_ones_are_found() {
    for ortho in [false, true] {
        for clip in CONVENTIONS {
            let (mut hidden, mut found, mut wrong) = (0, 0, 0);
            for seed in 0..12 {
                let (h, f, w) = check_against_rays(seed, ortho, clip);
                hidden += h;
                found += f;
                wrong += w;
            }
            assert_eq!(wrong, 0, "{clip:?} ortho {ortho}: occluded boxes a ray reaches");
            // Conservative sampling loses samples along edges and the boxes' rectangles
            // overstate them, so not every hidden box is provably hidden; most are.
            assert!(
                hidden > 20 && found * 2 > hidden,
                "{clip:?} ortho {ortho}: HzBuffer found {found} of {hidden} hidden boxes"
            );
        }
    }
}

/// A dyadic value: exactly representable, so conversions between conventions are exact.
fn dyadic(rng: &mut Rng, lo: f32, hi: f32) -> f32 {
    (rng.range(lo, hi) * 256.0).round() / 256.0
}

/// An NDC rectangle (min, max) and its nearest depth.
type Rect = (Vec2, Vec2, f32);

/// Clip-space vertices (hom's convention) and NDC rectangles with depths, all dyadic.
fn clip_world(seed: u64) -> (Vec<Vec4>, Vec<[u32; 3]>, Vec<Rect>) {
    let mut rng = Rng::new(seed);
    let mut v = Vec::new();
    let mut t = Vec::new();
    for i in 0..20u32 {
        let w = dyadic(&mut rng, 1.0, 8.0);
        for _ in 0..3 {
            let (x, y) = (dyadic(&mut rng, -1.3, 1.3) * w, dyadic(&mut rng, -1.3, 1.3) * w);
            // Depth z / w in [-0.05, 1.05]: some vertices before the near plane or past the far one.
            let z = dyadic(&mut rng, -0.05, 1.05) * w;
            v.push(Vec4::new(x, y, z, w));
        }
        t.push([3 * i, 3 * i + 1, 3 * i + 2]);
    }
    let rects = (0..200)
        .map(|_| {
            let (x0, x1) = (dyadic(&mut rng, -1.2, 1.2), dyadic(&mut rng, -1.2, 1.2));
            let (y0, y1) = (dyadic(&mut rng, -1.2, 1.2), dyadic(&mut rng, -1.2, 1.2));
            let d = dyadic(&mut rng, -0.05, 1.05);
            (Vec2::new(x0.min(x1), y0.min(y1)), Vec2::new(x0.max(x1), y0.max(y1)), d)
        })
        .collect();
    (v, t, rects)
}

/// hom's clip coordinates and depths in another convention (exact for dyadic values).
fn from_zero_to_one(clip: ClipConvention, v: Vec4) -> Vec4 {
    match clip {
        ClipConvention::ZeroToOne => v,
        ClipConvention::NegOneToOne => Vec4::new(v.x, v.y, 2.0 * v.z - v.w, v.w),
        ClipConvention::ReversedZ => Vec4::new(v.x, v.y, v.w - v.z, v.w),
    }
}

fn depth_from_zero_to_one(clip: ClipConvention, d: f32) -> f32 {
    match clip {
        ClipConvention::ZeroToOne => d,
        ClipConvention::NegOneToOne => 2.0 * d - 1.0,
        ClipConvention::ReversedZ => 1.0 - d,
    }
}

fn rect_answers(buf: &mut impl OcclusionBuffer, clip: ClipConvention, seed: u64) -> Vec<Visibility> {
    let (v, t, rects) = clip_world(seed);
    let v: Vec<Vec4> = v.into_iter().map(|v| from_zero_to_one(clip, v)).collect();
    buf.clear();
    buf.render_clip_triangles(&v, &t, FaceCull::None).unwrap();
    rects
        .iter()
        .map(|&(a, b, d)| buf.test_rect(a, b, depth_from_zero_to_one(clip, d)))
        .collect()
}

/// A dyadic perspective-like matrix: exact through every conversion.
fn dyadic_matrix() -> Mat4 {
    Mat4::from_cols(
        Vec4::new(1.25, 0.0, 0.0, 0.0),
        Vec4::new(0.0, 1.5, 0.0, 0.0),
        Vec4::new(0.125, -0.0625, -1.0, -1.0),
        Vec4::new(0.25, -0.5, -0.5, 0.0),
    )
}

fn from_zero_to_one_matrix(clip: ClipConvention) -> Mat4 {
    match clip {
        ClipConvention::ZeroToOne => Mat4::IDENTITY,
        ClipConvention::NegOneToOne => Mat4::from_cols(
            Vec4::X,
            Vec4::Y,
            Vec4::new(0.0, 0.0, 2.0, 0.0),
            Vec4::new(0.0, 0.0, -1.0, 1.0),
        ),
        ClipConvention::ReversedZ => Mat4::from_cols(
            Vec4::X,
            Vec4::Y,
            Vec4::new(0.0, 0.0, -1.0, 0.0),
            Vec4::new(0.0, 0.0, 1.0, 1.0),
        ),
    }
}

fn box_answers(buf: &mut impl OcclusionBuffer, clip: ClipConvention, seed: u64) -> Vec<Visibility> {
    let mut rng = Rng::new(seed);
    let m = from_zero_to_one_matrix(clip) * dyadic_matrix();
    let mut positions = Vec::new();
    let mut tris = Vec::new();
    for i in 0..12u32 {
        let c = Vec3::new(
            dyadic(&mut rng, -3.0, 3.0),
            dyadic(&mut rng, -3.0, 3.0),
            dyadic(&mut rng, -12.0, -2.0),
        );
        for _ in 0..3 {
            positions.push(
                c + Vec3::new(
                    dyadic(&mut rng, -2.0, 2.0),
                    dyadic(&mut rng, -2.0, 2.0),
                    dyadic(&mut rng, -0.5, 0.5),
                ),
            );
        }
        tris.push([3 * i, 3 * i + 1, 3 * i + 2]);
    }
    buf.clear();
    buf.render_triangles(&positions, &tris, &m, FaceCull::None).unwrap();
    (0..100)
        .map(|_| {
            let c = Vec3::new(
                dyadic(&mut rng, -4.0, 4.0),
                dyadic(&mut rng, -4.0, 4.0),
                dyadic(&mut rng, -20.0, 0.0),
            );
            let h = Vec3::new(
                dyadic(&mut rng, 0.0, 1.0),
                dyadic(&mut rng, 0.0, 1.0),
                dyadic(&mut rng, 0.0, 1.0),
            );
            buf.test_aabb(&Aabb::new(c - h, c + h), &m)
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]
    /// Every convention answers exactly as `ZeroToOne` on the same geometry.
    #[test]
    fn every_convention_answers_as_zero_to_one(seed in any::<u64>(), w in 1u32..90, h in 1u32..70) {
        let mut want = None;
        for clip in CONVENTIONS {
            let mut hz = HzBuffer::new(w, h, options(clip)).unwrap();
            let mut hom = HomBuffer::new(w, h, options(clip)).unwrap();
            let mut masked = MaskedBuffer::new(w, h, options(clip)).unwrap();
            let mut tree = OcclusionTree::new(w, h, options(clip)).unwrap();
            let got = (
                rect_answers(&mut hz, clip, seed),
                rect_answers(&mut hom, clip, seed),
                box_answers(&mut hz, clip, seed),
                box_answers(&mut hom, clip, seed),
                [
                    rect_answers(&mut masked, clip, seed),
                    box_answers(&mut masked, clip, seed),
                    rect_answers(&mut tree, clip, seed),
                    box_answers(&mut tree, clip, seed),
                ],
            );
            match &want {
                None => want = Some(got),
                Some(want) => prop_assert!(&got == want, "{:?} differs from ZeroToOne", clip),
            }
        }
        // The comparison is only meaningful if the answers vary.
        let (r, _, b, _, _) = want.unwrap();
        prop_assume!(r.iter().chain(&b).any(|&v| v != r[0]));
    }
}

#[test]
fn answers_vary_across_the_conventions_case() {
    // The property above compares something: occluded, visible and view-culled all occur.
    let mut seen = [false; 3];
    for seed in 1..40 {
        let mut hz = HzBuffer::new(64, 48, BufferOptions::default()).unwrap();
        for v in rect_answers(&mut hz, ClipConvention::ZeroToOne, seed)
            .into_iter()
            .chain(box_answers(&mut hz, ClipConvention::ZeroToOne, seed))
        {
            seen[v as usize] = true;
        }
    }
    assert_eq!(seen, [true; 3]);
}

/// A 20 m × 10 m wall at z = 0 and a camera 10 m in front of it.
fn wall() -> (Vec<Vec3>, Vec<[u32; 3]>) {
    (
        vec![
            Vec3::new(-10.0, -5.0, 0.0),
            Vec3::new(10.0, -5.0, 0.0),
            Vec3::new(10.0, 5.0, 0.0),
            Vec3::new(-10.0, 5.0, 0.0),
        ],
        vec![[0, 1, 2], [0, 2, 3]],
    )
}

#[test]
fn orthographic_views_cull_like_perspective_ones() {
    let view = look_at_mat4(Vec3::new(0.0, 0.0, 10.0), Vec3::ZERO, Vec3::Y);
    let (p, t) = wall();
    let behind = Aabb::new(Vec3::new(-1.0, -1.0, -5.0), Vec3::new(1.0, 1.0, -3.0));
    let front = Aabb::new(Vec3::new(-1.0, -1.0, 3.0), Vec3::new(1.0, 1.0, 5.0));
    let beside = Aabb::new(Vec3::new(30.0, -1.0, -5.0), Vec3::new(31.0, 1.0, -3.0));
    for (clip, proj) in [
        (
            ClipConvention::ZeroToOne,
            directx::orthographic(-6.0, 6.0, -4.0, 4.0, 0.5, 40.0),
        ),
        (
            ClipConvention::NegOneToOne,
            opengl::orthographic(-6.0, 6.0, -4.0, 4.0, 0.5, 40.0),
        ),
    ] {
        let vp = proj * view;
        let mut hz = HzBuffer::new(96, 64, options(clip)).unwrap();
        hz.render_triangles(&p, &t, &vp, FaceCull::None).unwrap();
        assert_eq!(hz.test_aabb(&behind, &vp), Visibility::Occluded, "{clip:?}");
        assert_eq!(hz.test_aabb(&front, &vp), Visibility::Visible, "{clip:?}");
        assert_eq!(hz.test_aabb(&beside, &vp), Visibility::ViewCulled, "{clip:?}");
        let mut hom = HomBuffer::new(96, 64, options(clip)).unwrap();
        hom.render_triangles(&p, &t, &vp, FaceCull::None).unwrap();
        assert_eq!(hom.test_aabb(&behind, &vp), Visibility::Occluded, "{clip:?}");
        assert_eq!(hom.test_aabb(&front, &vp), Visibility::Visible, "{clip:?}");
        let mut masked = MaskedBuffer::new(96, 64, options(clip)).unwrap();
        masked.render_triangles(&p, &t, &vp, FaceCull::None).unwrap();
        assert_eq!(masked.test_aabb(&behind, &vp), Visibility::Occluded, "{clip:?}");
        assert_eq!(masked.test_aabb(&front, &vp), Visibility::Visible, "{clip:?}");
    }
}

#[test]
fn a_box_through_the_near_plane_is_never_occluded() {
    // The wall covers the whole view; a box around the eye reaches through the near plane.
    let vp = directx::perspective(1.0, 1.0, 0.5, 100.0) * look_at_mat4(Vec3::new(0.0, 0.0, 1.0), Vec3::ZERO, Vec3::Y);
    let (p, t) = wall();
    let around_eye = Aabb::new(Vec3::new(-0.2, -0.2, -1.0), Vec3::new(0.2, 0.2, 1.2));
    let mut hz = HzBuffer::new(32, 32, BufferOptions::default()).unwrap();
    hz.render_triangles(&p, &t, &vp, FaceCull::None).unwrap();
    assert_eq!(hz.test_aabb(&around_eye, &vp), Visibility::Visible);
    // A rectangle nearer than the near plane is visible too; beyond the far plane, view-culled.
    assert_eq!(
        hz.test_rect(Vec2::splat(-0.1), Vec2::splat(0.1), -0.5),
        Visibility::Visible
    );
    assert_eq!(
        hz.test_rect(Vec2::splat(-0.1), Vec2::splat(0.1), 1.5),
        Visibility::ViewCulled
    );
    assert_eq!(
        hz.test_rect(Vec2::splat(-0.1), Vec2::splat(0.1), 0.999),
        Visibility::Occluded
    );
}

#[test]
fn rendering_after_a_test_adds_to_what_is_drawn() {
    let vp = directx::perspective(1.0, 1.0, 0.5, 100.0) * look_at_mat4(Vec3::new(0.0, 0.0, 10.0), Vec3::ZERO, Vec3::Y);
    let (p, t) = wall();
    let behind = Aabb::new(Vec3::new(-1.0, -1.0, -5.0), Vec3::new(1.0, 1.0, -3.0));
    let mut hz = HzBuffer::new(40, 40, BufferOptions::default()).unwrap();
    assert_eq!(
        hz.test_aabb(&behind, &vp),
        Visibility::Visible,
        "an empty buffer hides nothing"
    );
    hz.render_triangles(&p, &t, &vp, FaceCull::None).unwrap();
    assert_eq!(hz.test_aabb(&behind, &vp), Visibility::Occluded);
    hz.clear();
    assert_eq!(
        hz.test_aabb(&behind, &vp),
        Visibility::Visible,
        "clear forgets the wall"
    );
    let s = hz.stats();
    assert_eq!(
        (s.tests, s.occluded, s.triangles_submitted),
        (1, 0, 0),
        "clear resets the statistics"
    );
}

#[test]
fn face_culling_drops_one_winding() {
    let vp = directx::perspective(1.0, 1.0, 0.5, 100.0) * look_at_mat4(Vec3::new(0.0, 0.0, 10.0), Vec3::ZERO, Vec3::Y);
    let (p, t) = wall(); // counter-clockwise as seen from the camera
    let behind = Aabb::new(Vec3::new(-1.0, -1.0, -5.0), Vec3::new(1.0, 1.0, -3.0));
    for (cull, hidden) in [
        (FaceCull::None, true),
        (FaceCull::Clockwise, true),
        (FaceCull::CounterClockwise, false),
    ] {
        let mut hz = HzBuffer::new(40, 40, BufferOptions::default()).unwrap();
        hz.render_triangles(&p, &t, &vp, cull).unwrap();
        assert_eq!(hz.test_aabb(&behind, &vp) == Visibility::Occluded, hidden, "{cull:?}");
    }
}

#[test]
fn bad_input_gets_a_typed_error_and_never_a_panic() {
    for (w, h) in [(0, 10), (10, 0), (20_000, 10), (10, u32::MAX)] {
        assert!(matches!(
            HzBuffer::new(w, h, BufferOptions::default()),
            Err(OcclusionError::Size { .. })
        ));
        assert!(matches!(
            HomBuffer::new(w, h, BufferOptions::default()),
            Err(OcclusionError::Size { .. })
        ));
    }
    let mut hz = HzBuffer::new(16, 16, BufferOptions::default()).unwrap();
    assert!(matches!(hz.resize(0, 3), Err(OcclusionError::Size { .. })));
    let (p, _) = wall();
    let vp = directx::perspective(1.0, 1.0, 0.5, 100.0) * look_at_mat4(Vec3::new(0.0, 0.0, 10.0), Vec3::ZERO, Vec3::Y);
    assert_eq!(
        hz.render_triangles(&p, &[[0, 1, 2], [0, 2, 4]], &vp, FaceCull::None),
        Err(OcclusionError::IndexOutOfRange {
            triangle: 1,
            index: 4,
            vertex_count: 4
        })
    );
    let mut nan = vp;
    nan.z_axis.w = f32::NAN;
    assert!(matches!(
        hz.render_triangles(&p, &[[0, 1, 2]], &nan, FaceCull::None),
        Err(OcclusionError::NonFiniteMatrix)
    ));
    assert!(matches!(
        hz.render_clip_triangles(&[Vec4::ONE], &[[0, 0, 1]], FaceCull::None),
        Err(OcclusionError::IndexOutOfRange { .. })
    ));
    // Non-finite vertices are skipped; the rest still occludes.
    let mut bad = p.clone();
    bad.push(Vec3::NAN);
    hz.render_triangles(&bad, &[[0, 1, 4], [0, 1, 2], [0, 2, 3]], &vp, FaceCull::None)
        .unwrap();
    let behind = Aabb::new(Vec3::new(-1.0, -1.0, -5.0), Vec3::new(1.0, 1.0, -3.0));
    assert_eq!(hz.test_aabb(&behind, &vp), Visibility::Occluded);
    assert_eq!(hz.stats().triangles_submitted, 3);
    // A NaN box or matrix is visible, never occluded.
    let nan_box = Aabb {
        min: Vec3::NAN,
        max: Vec3::ONE,
    };
    assert_eq!(hz.test_aabb(&nan_box, &vp), Visibility::Visible);
    assert_eq!(hz.test_aabb(&behind, &nan), Visibility::Visible);
    assert_eq!(hz.test_rect(Vec2::NAN, Vec2::ONE, 0.5), Visibility::Visible);
    // A backend the CPU lacks is refused by name.
    if let Some(b) = hom_occlusion::RasterBackend::ALL
        .into_iter()
        .find(|b| !b.is_supported())
    {
        let o = BufferOptions {
            backend: Some(b),
            ..BufferOptions::default()
        };
        assert!(matches!(
            HzBuffer::new(8, 8, o),
            Err(OcclusionError::UnsupportedBackend(..))
        ));
    }
}

#[test]
fn statistics_count_what_was_done() {
    let vp = directx::perspective(1.0, 1.0, 0.5, 100.0) * look_at_mat4(Vec3::new(0.0, 0.0, 10.0), Vec3::ZERO, Vec3::Y);
    let (p, t) = wall();
    let mut hz = HzBuffer::new(64, 64, BufferOptions::default()).unwrap();
    hz.render_triangles(&p, &t, &vp, FaceCull::None).unwrap();
    let behind = Aabb::new(Vec3::new(-1.0, -1.0, -5.0), Vec3::new(1.0, 1.0, -3.0));
    let away = Aabb::new(Vec3::new(-1.0, -1.0, 20.0), Vec3::new(1.0, 1.0, 22.0));
    hz.test_aabb(&behind, &vp);
    hz.test_aabb(&away, &vp);
    let s = hz.stats();
    assert_eq!((s.triangles_submitted, s.triangles_drawn), (2, 2));
    assert_eq!((s.tests, s.occluded, s.view_culled), (2, 1, 1));
    assert!(s.tiles_drawn > 0 && s.setup_ms >= 0.0 && s.raster_ms >= 0.0);
}

/// Stand-in triangles go in conservatively whatever the buffer's sampling:
/// into an exact buffer they answer as the same triangles do in a
/// conservative one.
#[test]
fn stand_in_triangles_are_sampled_conservatively_in_every_buffer() {
    fn check(mut make: impl FnMut(BufferOptions) -> Box<dyn OcclusionBuffer>) -> usize {
        let exact = BufferOptions {
            sampling: Sampling::Exact,
            ..BufferOptions::default()
        };
        let conservative = BufferOptions {
            sampling: Sampling::Conservative,
            ..BufferOptions::default()
        };
        let mut differs = 0;
        for seed in 0..12 {
            let cam = forward_cam(61, 43);
            let w = world(seed, 14, 0, 60, &cam);
            let vp = cam.view_proj(ClipConvention::ZeroToOne);
            let run = |buf: &mut Box<dyn OcclusionBuffer>, stand_in: bool| -> Vec<Visibility> {
                buf.clear();
                if stand_in {
                    buf.render_stand_in_triangles(&w.positions, &w.triangles, &vp, FaceCull::None)
                } else {
                    buf.render_triangles(&w.positions, &w.triangles, &vp, FaceCull::None)
                }
                .unwrap();
                w.boxes.iter().map(|b| buf.test_aabb(b, &vp)).collect()
            };
            let stand_in = run(&mut make(exact), true);
            assert_eq!(stand_in, run(&mut make(conservative), false), "seed {seed}");
            let exactly = run(&mut make(exact), false);
            differs += stand_in.iter().zip(&exactly).filter(|(s, e)| s != e).count();
        }
        differs
    }
    // Drawn exactly, some answers differ: the check can tell the rules apart.
    let differs = check(|o| Box::new(HzBuffer::new(61, 43, o).unwrap()))
        + check(|o| Box::new(HomBuffer::new(61, 43, o).unwrap()))
        + check(|o| Box::new(MaskedBuffer::new(61, 43, o).unwrap()))
        + check(|o| Box::new(OcclusionTree::new(61, 43, o).unwrap()));
    assert!(differs > 0);
}

/// The world's boxes answered through [`OcclusionBuffer::share`] by `threads`
/// threads at once, each taking every `threads`-th box, in the boxes' order.
fn shared_answers(buf: &mut impl OcclusionBuffer, w: &World, view_proj: &Mat4, threads: usize) -> Vec<Visibility> {
    let shared = buf.share();
    let mut out = vec![Visibility::Visible; w.boxes.len()];
    std::thread::scope(|s| {
        let jobs: Vec<_> = (0..threads)
            .map(|k| {
                s.spawn(move || {
                    let mine = w.boxes.iter().enumerate().skip(k).step_by(threads);
                    mine.map(|(i, b)| (i, shared.test_aabb(b, view_proj)))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        for job in jobs {
            for (i, v) in job.join().expect("a test thread panicked") {
                out[i] = v;
            }
        }
    });
    out
}

/// The world's answers through the buffer's own `test_aabb`, checked equal
/// to those through a [`OcclusionBuffer::share`] of it from one and from
/// four threads.
fn own_and_shared_agree(name: &str, buf: &mut impl OcclusionBuffer, w: &World, vp: &Mat4) -> Vec<Visibility> {
    let own = answers(buf, w, vp);
    for threads in [1, 4] {
        answers(buf, w, vp);
        assert_eq!(shared_answers(buf, w, vp, threads), own, "{name}, {threads} threads");
    }
    own
}

#[test]
fn tests_through_a_shared_buffer_answer_as_the_buffer_does() {
    let (mut occluded, mut total) = (0, 0);
    let clip = ClipConvention::ZeroToOne;
    for seed in 0..6 {
        let cam = forward_cam(96, 64);
        let (w, vp) = (world(seed, 14, 6, 200, &cam), cam.view_proj(clip));
        let (width, height, o) = (cam.width, cam.height, options(clip));
        for own in [
            own_and_shared_agree("hzb", &mut HzBuffer::new(width, height, o).unwrap(), &w, &vp),
            own_and_shared_agree("hom", &mut HomBuffer::new(width, height, o).unwrap(), &w, &vp),
            own_and_shared_agree("masked", &mut MaskedBuffer::new(width, height, o).unwrap(), &w, &vp),
            own_and_shared_agree("otree", &mut OcclusionTree::new(width, height, o).unwrap(), &w, &vp),
        ] {
            occluded += own.iter().filter(|&&v| v == Visibility::Occluded).count();
            total += own.len();
        }
    }
    // The answers compared include occluded ones, not only visible ones.
    assert!(occluded * 20 > total, "{occluded} of {total} answers occluded");
}

/// A perspective camera near the origin looking down −z, a little down.
fn forward_cam(width: u32, height: u32) -> Cam {
    Cam {
        eye: Vec3::new(0.0, 0.5, 0.0),
        target: Vec3::new(0.1, 0.4, -1.0),
        ortho: false,
        width,
        height,
    }
}

/// A world and a camera for the thread tests: enough triangles to make
/// several setup chunks (512 triangles each) and several bands.
fn busy_world(seed: u64) -> (World, Mat4, Cam) {
    let cam = forward_cam(160, 120);
    let w = world(seed, 700, 20, 300, &cam);
    let vp = cam.view_proj(ClipConvention::ZeroToOne);
    (w, vp, cam)
}

/// The world's answers from every buffer made with `threads`.
fn all_answers(cam: &Cam, threads: Threads, w: &World, vp: &Mat4) -> [Vec<Visibility>; 4] {
    let o = BufferOptions {
        threads,
        ..options(ClipConvention::ZeroToOne)
    };
    let (width, height) = (cam.width, cam.height);
    [
        answers(&mut HzBuffer::new(width, height, o).unwrap(), w, vp),
        answers(&mut HomBuffer::new(width, height, o).unwrap(), w, vp),
        answers(&mut MaskedBuffer::new(width, height, o).unwrap(), w, vp),
        answers(&mut OcclusionTree::new(width, height, o).unwrap(), w, vp),
    ]
}

#[test]
fn the_calling_thread_alone_draws_what_the_pool_draws() {
    for seed in 0..3 {
        let (w, vp, cam) = busy_world(seed);
        let pool = all_answers(&cam, Threads::Pool, &w, &vp);
        let alone = all_answers(&cam, Threads::CallingThread, &w, &vp);
        assert_eq!(alone, pool, "seed {seed}");
        assert!(pool[0].contains(&Visibility::Occluded), "seed {seed}: nothing occluded");
    }
}

/// With every thread of rayon's global pool blocked, buffers made with
/// `Threads::CallingThread` still set up, draw and answer: nothing of theirs
/// waits for a pool thread. (With `Threads::Pool` the draw would wait until
/// the pool is released.)
#[test]
fn the_calling_thread_alone_needs_no_pool_thread() {
    use std::sync::{mpsc, Arc, Barrier};
    use std::time::Duration;
    let (w, vp, cam) = busy_world(7);
    let n = rayon::current_num_threads();
    let release = Arc::new(Barrier::new(n + 1));
    let (started, all_started) = mpsc::channel();
    for _ in 0..n {
        let (release, started) = (Arc::clone(&release), started.clone());
        rayon::spawn(move || {
            started.send(()).unwrap();
            release.wait();
        });
    }
    for _ in 0..n {
        all_started.recv().unwrap();
    }
    let (done, answered) = mpsc::channel();
    let drawer = std::thread::spawn(move || {
        let got = all_answers(&cam, Threads::CallingThread, &w, &vp);
        done.send(got.iter().map(Vec::len).sum::<usize>()).unwrap();
    });
    let got = answered.recv_timeout(Duration::from_secs(60));
    release.wait();
    drawer.join().unwrap();
    assert_eq!(got, Ok(4 * 300), "the buffers waited for the blocked pool");
}
