//! `OcclusionTree` against the exact per-sample z-buffer of the same
//! occluders (`HzBuffer` with exact sampling, read back sample by sample):
//! whenever the tree calls a rectangle occluded, every sample of it holds an
//! occluder nearer than the rectangle's depth by the depth margin. And it
//! finds a fair share of what the z-buffer can prove hidden, so the property
//! is not met by calling nothing occluded.

use hom_occlusion::glam::{Vec2, Vec4};
use hom_occlusion::{FaceCull, HzBuffer, OcclusionBuffer, OcclusionTree, Visibility};
use hom_testkit::{draw_objects, exact, occluder_raster_case, Rng};
use proptest::prelude::*;

const DEPTH_MARGIN: f32 = 1e-6;

/// Pixels `x0..x1` × `y0..y1` that `test_rect` covers for an NDC rectangle
/// (every pixel it touches), as `hom::occlusion` documents it.
fn pixels(min: Vec2, max: Vec2, w: u32, h: u32) -> (u32, u32, u32, u32) {
    let col = |x: f32| ((x + 1.0) * 0.5 * w as f32).clamp(0.0, w as f32 - 1.0) as u32;
    let row = |y: f32| ((1.0 - y) * 0.5 * h as f32).clamp(0.0, h as f32 - 1.0) as u32;
    (col(min.x), row(max.y), col(max.x) + 1, row(min.y) + 1)
}

/// Random clip-space occluder triangles (some through the near plane, some
/// sharing edges in strips) and random rectangles: returns (tree said
/// occluded, z-buffer proves hidden) counts after checking the property.
fn check(seed: u64, w: u32, h: u32) -> (usize, usize) {
    let mut rng = Rng::new(seed ^ 0x5bd1_e995);
    let mut verts = Vec::new();
    let mut tris = Vec::new();
    for _ in 0..1 + rng.below(12) {
        // A strip of quads at one depth plane: edges shared inside it.
        let (x, y) = (rng.range(-1.2, 0.8), rng.range(-1.2, 0.8));
        let (dx, dy) = (rng.range(0.05, 0.6), rng.range(0.05, 0.6));
        let (z, slope) = (rng.range(0.05, 0.9), rng.range(-0.2, 0.2));
        let n = 1 + rng.below(4) as u32;
        let base = verts.len() as u32;
        for i in 0..=n {
            for j in 0..2 {
                let (px, py) = (x + dx * i as f32, y + dy * j as f32);
                let w = rng.range(0.8, 1.2);
                let depth = (z + slope * px).clamp(-0.3, 1.0);
                verts.push(Vec4::new(px * w, py * w, depth * w, w));
            }
        }
        for i in 0..n {
            let (a, b, c, d) = (base + 2 * i, base + 2 * i + 2, base + 2 * i + 3, base + 2 * i + 1);
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
    }
    check_occluders(&verts, &tris, &mut rng, seed, w, h)
}

/// The property for occluders `verts`/`tris` and 200 random rectangles:
/// (tree said occluded, z-buffer proves hidden).
fn check_occluders(verts: &[Vec4], tris: &[[u32; 3]], rng: &mut Rng, seed: u64, w: u32, h: u32) -> (usize, usize) {
    let mut tree = OcclusionTree::new(w, h, exact()).unwrap();
    let mut hz = HzBuffer::new(w, h, exact()).unwrap();
    for b in [&mut tree as &mut dyn OcclusionBuffer, &mut hz] {
        b.render_clip_triangles(verts, tris, FaceCull::None).unwrap();
        b.flush();
    }
    tree.assert_well_formed();
    let mut depth = Vec::new();
    hz.zbuffer().to_row_major(&mut depth);
    let (mut said, mut provable) = (0, 0);
    for _ in 0..200 {
        let (x, y) = (rng.range(-1.1, 1.0), rng.range(-1.1, 1.0));
        let min = Vec2::new(x, y);
        let max = min + Vec2::new(rng.range(0.0, 0.5), rng.range(0.0, 0.5));
        let z = rng.range(0.0, 1.0);
        if max.x < -1.0 || max.y < -1.0 {
            continue; // wholly off screen: view-culled
        }
        let (x0, y0, x1, y1) = pixels(min, max, w, h);
        let hidden = (y0..y1).all(|py| (x0..x1).all(|px| z > depth[(py * w + px) as usize] + DEPTH_MARGIN));
        let v = tree.test_rect(min, max, z);
        assert_ne!(v, Visibility::ViewCulled, "{min} {max} {z}");
        if v == Visibility::Occluded {
            assert!(
                hidden,
                "seed {seed} {w}x{h}: {min}..{max} at {z} called occluded, a sample is not hidden"
            );
            said += 1;
        }
        // The brute force agrees with the z-buffer's own test.
        assert_eq!(hz.test_rect(min, max, z) == Visibility::Occluded, hidden);
        provable += usize::from(hidden);
    }
    (said, provable)
}

/// A jittered grid of `n` × `n` quads over NDC `[-0.6, 0.6]²` (two
/// triangles each, sharing every edge), depth `z` tilted a little.
fn tiny_grid(rng: &mut Rng, n: u32, z: f32) -> (Vec<Vec4>, Vec<[u32; 3]>) {
    let step = 1.2 / n as f32;
    let mut verts = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let inner = i > 0 && i < n && j > 0 && j < n;
            let jit = |rng: &mut Rng| if inner { rng.range(-0.3, 0.3) * step } else { 0.0 };
            let (x, y) = (-0.6 + step * i as f32 + jit(rng), -0.6 + step * j as f32 + jit(rng));
            let w = rng.range(0.9, 1.1);
            verts.push(Vec4::new(x * w, y * w, (z + 0.05 * x) * w, w));
        }
    }
    let mut tris = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let v = j * (n + 1) + i;
            let (a, b, c, d) = (v, v + 1, v + n + 2, v + n + 1);
            if rng.below(2) == 0 {
                tris.extend([[a, b, c], [a, c, d]]);
            } else {
                tris.extend([[a, b, d], [b, c, d]]);
            }
        }
    }
    (verts, tris)
}

/// A mesh of triangles about a pixel or two across hides a box behind it:
/// the search follows the rectangle's exact region, so it reaches only the
/// leaves its samples lie in (all *in*), not the *out* leaves between the
/// triangles that its bounding box would reach. And the property holds there.
#[test]
fn a_mesh_of_tiny_triangles_hides_what_is_behind_it() {
    for seed in 0..8u64 {
        let mut rng = Rng::new(seed ^ 0x7f4a_7c15);
        let (w, h) = (64 + 16 * seed as u32, 48 + 8 * seed as u32);
        let (verts, tris) = tiny_grid(&mut rng, 40 + 4 * seed as u32, 0.3);
        let mut tree = OcclusionTree::new(w, h, exact()).unwrap();
        tree.render_clip_triangles(&verts, &tris, FaceCull::None).unwrap();
        tree.assert_well_formed();
        let stats = tree.tree_stats();
        assert_eq!(stats.leaves_dropped, 0, "{stats:?}");
        for (min, max) in [
            (Vec2::new(-0.5, -0.5), Vec2::new(0.5, 0.5)),
            (Vec2::new(-0.55, -0.2), Vec2::new(0.1, 0.55)),
            (Vec2::new(0.0, 0.0), Vec2::new(0.05, 0.05)),
        ] {
            assert_eq!(
                tree.test_rect(min, max, 0.9),
                Visibility::Occluded,
                "seed {seed} {min}..{max}"
            );
        }
        // Past the mesh's edge: visible; in front of it: visible.
        assert_eq!(
            tree.test_rect(Vec2::new(0.3, 0.3), Vec2::new(0.7, 0.5), 0.9),
            Visibility::Visible
        );
        assert_eq!(
            tree.test_rect(Vec2::new(-0.2, -0.2), Vec2::new(0.2, 0.2), 0.2),
            Visibility::Visible
        );
        let (said, provable) = check_occluders(&verts, &tris, &mut rng, seed, w, h);
        assert!(said * 10 >= provable * 9, "seed {seed}: found {said} of {provable}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]
    #[test]
    fn occluded_rectangles_are_hidden_at_every_sample(seed in any::<u64>(), w in 1u32..80, h in 1u32..60) {
        check(seed, w, h);
    }
}

/// Of the rectangles the exact z-buffer proves hidden, the tree finds most
/// (it may lose some to depth bounds over a leaf's box of samples, and to a
/// leaf whose nearer cover came later but did not lie nearer over the box).
#[test]
fn the_tree_finds_most_hidden_rectangles() {
    let (mut said, mut provable) = (0, 0);
    for seed in 0..60 {
        let (s, p) = check(seed, 64, 48);
        said += s;
        provable += p;
    }
    eprintln!("tree found {said} of {provable} provably hidden rectangles");
    assert!(provable > 500, "the cases hide something: {provable}");
    assert!(said * 10 > provable * 7, "found {said} of {provable}");
}

/// Scene objects drawn as an engine does: every box the tree calls occluded
/// is hidden at every sample of the exact z-buffer.
#[test]
fn scene_occluders_hide_only_what_the_zbuffer_hides() {
    let mut found = 0;
    for seed in 0..20u64 {
        let (scene, camera, ids) = occluder_raster_case(seed);
        let mut tree = OcclusionTree::new(camera.width, camera.height, exact()).unwrap();
        let mut hz = HzBuffer::new(camera.width, camera.height, exact()).unwrap();
        draw_objects(&mut tree, &scene, &ids, &camera);
        draw_objects(&mut hz, &scene, &ids, &camera);
        tree.assert_well_formed();
        let vp = camera.view_proj();
        for (id, o) in scene.objects().iter().enumerate() {
            if ids.contains(&(id as u32)) {
                continue;
            }
            let t = tree.test_aabb(&o.aabb, &vp);
            if t == Visibility::Occluded {
                assert_eq!(
                    hz.test_aabb(&o.aabb, &vp),
                    Visibility::Occluded,
                    "seed {seed} object {id}"
                );
                found += 1;
            }
        }
    }
    assert!(found > 10, "the tree hides some objects: {found}");
}
