//! The hierarchy and the selection against slow, obvious references:
//! edge counts for watertight cuts, brute-force distances for the error
//! bound, the top-down cut for the moved front.

use super::*;
use crate::geom::Camera;
use crate::scene::{Mesh, Scene};
use glam::{Mat4, Vec3};
use hom_testkit::Rng;
use std::collections::BTreeMap;

/// An `n` × `n` quad height field of rolling hills with noise, open border.
pub(super) fn height_field(n: usize, seed: u64, bump: f32) -> Mesh {
    let mut s = Rng::new(seed);
    let v = n + 1;
    let positions: Vec<Vec3> = (0..v * v)
        .map(|i| {
            let (x, z) = ((i % v) as f32, (i / v) as f32);
            let y = 3.0 * (x * 0.21).sin() * (z * 0.17).cos() + bump * s.unit_f64() as f32;
            Vec3::new(x, y, z)
        })
        .collect();
    let mut triangles = Vec::new();
    for z in 0..n {
        for x in 0..n {
            let i = (z * v + x) as u32;
            let (r, d) = (1, v as u32);
            triangles.push([i, i + d, i + r]);
            triangles.push([i + r, i + d, i + d + r]);
        }
    }
    Mesh::new("hills", positions, triangles).expect("valid grid")
}

/// A closed UV sphere with single poles.
fn sphere(rings: u32, segments: u32) -> Mesh {
    let mut positions = vec![Vec3::Y];
    for r in 1..rings {
        let phi = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..segments {
            let theta = std::f32::consts::TAU * s as f32 / segments as f32;
            positions.push(Vec3::new(phi.sin() * theta.cos(), phi.cos(), phi.sin() * theta.sin()) * 5.0);
        }
    }
    positions.push(-Vec3::Y * 5.0);
    positions[0] *= 5.0;
    let ring = |r: u32, s: u32| 1 + (r - 1) * segments + s % segments;
    let south = positions.len() as u32 - 1;
    let mut triangles = Vec::new();
    for s in 0..segments {
        triangles.push([0, ring(1, s + 1), ring(1, s)]);
        triangles.push([south, ring(rings - 1, s), ring(rings - 1, s + 1)]);
        for r in 1..rings - 1 {
            let (a, b, c, d) = (ring(r, s), ring(r, s + 1), ring(r + 1, s), ring(r + 1, s + 1));
            triangles.push([a, b, c]);
            triangles.push([b, d, c]);
        }
    }
    Mesh::new("sphere", positions, triangles).expect("valid sphere")
}

/// Undirected edges (welded) of `triangles` and how many triangles use each.
fn edge_counts<'a>(triangles: impl Iterator<Item = &'a [u32; 3]>, canonical: &[u32]) -> BTreeMap<(u32, u32), u32> {
    let mut edges = BTreeMap::new();
    for t in triangles {
        let t = t.map(|i| canonical[i as usize]);
        for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
            *edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    edges
}

fn border(edges: &BTreeMap<(u32, u32), u32>) -> Vec<(u32, u32)> {
    edges.iter().filter(|e| *e.1 == 1).map(|e| *e.0).collect()
}

/// A cut refining each inner node with probability `p`.
fn random_cut(h: &LodHierarchy, p: f64, seed: &mut Rng) -> Vec<u32> {
    top_down_cut(h, |_| seed.unit_f64() < p)
}

#[test]
fn hierarchies_are_well_formed_deterministic_and_coarser_towards_the_root() {
    let config = LodConfig::default();
    for mesh in [height_field(40, 7, 0.3), sphere(24, 40), height_field(5, 1, 0.2)] {
        let h = LodHierarchy::build(&mesh, &config);
        h.assert_well_formed(&mesh);
        assert_eq!(
            h,
            LodHierarchy::build(&mesh, &config),
            "{}: not deterministic",
            mesh.name()
        );
        let root = h.nodes()[0].triangle_count() as usize;
        if mesh.triangle_count() > 4 * config.leaf_triangles as usize {
            assert!(
                root * 16 < mesh.triangle_count(),
                "{}: root keeps {root} triangles",
                mesh.name()
            );
            assert!(h.nodes()[0].error > 0.0);
        } else {
            // One leaf, with a chain of coarser levels above it.
            assert!(h
                .nodes()
                .iter()
                .enumerate()
                .all(|(i, _)| h.children(i as u32).count() <= 1));
            assert!(root < mesh.triangle_count(), "{}: no coarser level", mesh.name());
        }
    }
}

#[test]
fn every_cut_is_watertight_where_the_mesh_is() {
    let mut seed = Rng::new(0x5EED);
    let config = LodConfig { leaf_triangles: 64 };
    for mesh in [height_field(48, 3, 0.5), sphere(20, 36)] {
        let canonical = crate::occlusion::details::weld(mesh.positions());
        let original = edge_counts(mesh.triangles().iter(), &canonical);
        let h = LodHierarchy::build(&mesh, &config);
        for round in 0..40 {
            let p = [0.2, 0.5, 0.8, 1.0][round % 4];
            let cut = random_cut(&h, p, &mut seed);
            let edges = edge_counts(cut.iter().flat_map(|&n| h.triangles(n)), &canonical);
            for (e, c) in &edges {
                if *c > 2 {
                    for &n in &cut {
                        let own = edge_counts(h.triangles(n).iter(), &canonical);
                        eprintln!("edge {e:?}: node {n} uses it {:?} times; node locked? ", own.get(e));
                    }
                }
            }
            assert!(
                edges.values().all(|&c| c <= 2),
                "{}: an edge shared by three triangles in cut {cut:?}",
                mesh.name()
            );
            assert_eq!(
                border(&edges),
                border(&original),
                "{}: cut {cut:?} opens a crack",
                mesh.name()
            );
        }
    }
}

/// Points on triangle `t`: a barycentric grid of `k` steps.
fn samples(t: [Vec3; 3], k: u32) -> impl Iterator<Item = Vec3> {
    (0..=k).flat_map(move |i| {
        (0..=k - i).map(move |j| {
            let (a, b) = (i as f32 / k as f32, j as f32 / k as f32);
            t[0] * (1.0 - a - b) + t[1] * a + t[2] * b
        })
    })
}

#[test]
fn node_errors_bound_the_distance_to_the_originals() {
    let mesh = height_field(32, 11, 0.8);
    let h = LodHierarchy::build(&mesh, &LodConfig { leaf_triangles: 64 });
    let p = mesh.positions();
    let tri = |t: &[u32; 3]| t.map(|i| p[i as usize]);
    let leaves: Vec<u32> = (0..h.nodes().len() as u32)
        .filter(|&n| h.nodes()[n as usize].is_leaf(n))
        .collect();
    for (id, node) in h.nodes().iter().enumerate() {
        let id = id as u32;
        if node.is_leaf(id) {
            continue;
        }
        let originals: Vec<[Vec3; 3]> = leaves
            .iter()
            .filter(|&&l| h.is_within(l, id))
            .flat_map(|&l| h.triangles(l).iter().map(tri))
            .collect();
        let coarse: Vec<[Vec3; 3]> = h.triangles(id).iter().map(tri).collect();
        let distance = |q: Vec3, surface: &[[Vec3; 3]]| {
            surface
                .iter()
                .map(|t| hierarchy::point_triangle_distance_squared(q, t))
                .fold(f32::INFINITY, f32::min)
                .sqrt()
        };
        let mut worst = 0.0f32;
        for t in &coarse {
            for q in samples(*t, 6) {
                worst = worst.max(distance(q, &originals));
            }
        }
        for t in &originals {
            for &q in t {
                worst = worst.max(distance(q, &coarse));
            }
        }
        // The bake measures at fewer points; between them the surfaces are
        // planar pieces, so denser samples may only add a little.
        assert!(
            worst <= node.error * 1.25 + 1e-4,
            "node {id}: distance {worst} beyond its error {}",
            node.error
        );
    }
}

pub(super) fn ground_scene(objects: usize) -> Scene {
    let mut scene = Scene::new("hills");
    let mesh = scene.add_mesh(height_field(32, 5, 0.4));
    for k in 0..objects {
        let t = Mat4::from_translation(Vec3::new(32.0 * (k % 3) as f32, 0.0, 32.0 * (k / 3) as f32))
            * Mat4::from_scale(Vec3::splat(1.0 + 0.25 * (k % 2) as f32));
        scene.add_object(format!("tile {k}"), mesh, t).expect("valid object");
    }
    scene
}

pub(super) fn camera(seed: &mut Rng) -> Camera {
    let r = |s: &mut Rng| s.unit_f64() as f32;
    let eye = Vec3::new(-20.0 + 140.0 * r(seed), 2.0 + 30.0 * r(seed), -20.0 + 140.0 * r(seed));
    let target = Vec3::new(100.0 * r(seed), 0.0, 100.0 * r(seed));
    Camera::new(eye, target, Vec3::Y, 1.0, 0.1, 500.0, 320, 200)
}

#[test]
fn selection_stays_within_the_threshold_and_guidance_only_keeps_hidden_nodes_coarse() {
    let scene = ground_scene(6);
    let lod = SceneLod::build(&scene, &LodConfig { leaf_triangles: 64 }, &|_, _| {}).expect("built");
    let ids: Vec<u32> = (0..6).collect();
    let (mut guided, mut unguided) = (LodSelector::default(), LodSelector::default());
    let (mut parts, mut parts_unguided) = (Vec::new(), Vec::new());
    let mut seed = Rng::new(99);
    let mut fewer = 0;
    for frame in 0..60 {
        let cam = camera(&mut seed);
        let view = LodView::new(&cam.to_view()).expect("valid view");
        // Hidden: boxes wholly beyond x = 40 (a wall's worth of occlusion).
        let mut hidden = |c: &[Vec3; 8]| c.iter().all(|p| p.x > 40.0);
        let options = LodOptions::default();
        let g = lod_select(
            &mut guided,
            &scene,
            &lod,
            &ids,
            &view,
            &options,
            &mut hidden,
            &mut parts,
        );
        let off = LodOptions {
            guidance: false,
            ..options
        };
        let u = lod_select(
            &mut unguided,
            &scene,
            &lod,
            &ids,
            &view,
            &off,
            &mut |_| false,
            &mut parts_unguided,
        );
        assert!(g.max_error_px <= 1.0 && u.max_error_px <= 1.0, "frame {frame}");
        assert!(g.triangles <= u.triangles, "frame {frame}: guidance drew more");
        fewer += usize::from(g.triangles < u.triangles);
        // The cuts differ only below hidden nodes.
        for &id in &ids {
            let h = lod.hierarchy(scene.object(id).mesh);
            for &n in guided.front(id) {
                let shared = unguided.front(id).contains(&n);
                let coarse_over = unguided.front(id).iter().any(|&m| h.is_within(m, n) && m != n);
                assert!(
                    shared || coarse_over,
                    "frame {frame}: node {n} of {id} is finer with guidance"
                );
            }
        }
    }
    assert!(fewer > 10, "guidance saved triangles on only {fewer} of 60 frames");
}

#[allow(clippy::too_many_arguments)]
fn lod_select(
    selector: &mut LodSelector,
    scene: &Scene,
    lod: &SceneLod,
    ids: &[u32],
    view: &LodView,
    options: &LodOptions,
    hidden: &mut dyn FnMut(&[Vec3; 8]) -> bool,
    parts: &mut Vec<LodPart>,
) -> LodStats {
    selector
        .select(scene, lod, ids, view, options, hidden, parts)
        .expect("valid selection")
}

#[test]
fn the_budget_is_held() {
    let scene = ground_scene(9);
    let lod = SceneLod::build(&scene, &LodConfig { leaf_triangles: 64 }, &|_, _| {}).expect("built");
    let ids: Vec<u32> = (0..9).collect();
    let mut selector = LodSelector::default();
    let mut parts = Vec::new();
    let mut seed = Rng::new(3);
    for frame in 0..30 {
        let view = LodView::new(&camera(&mut seed).to_view()).expect("valid view");
        let budget = 2_000 + 400 * frame as u64;
        let options = LodOptions {
            budget: Some(budget),
            ..LodOptions::default()
        };
        let s = lod_select(
            &mut selector,
            &scene,
            &lod,
            &ids,
            &view,
            &options,
            &mut |_| false,
            &mut parts,
        );
        assert!(s.triangles <= budget, "frame {frame}: {} over {budget}", s.triangles);
        let full: u64 = ids.iter().map(|&i| scene.object(i).triangles as u64).sum();
        if s.max_error_px > 0.0 && full > budget {
            assert!(
                s.triangles as f64 >= 0.95 * budget as f64,
                "frame {frame}: {} of {budget} with errors left",
                s.triangles
            );
        }
        // The parts are the fronts, and every front is a cut.
        for &id in &ids {
            let h = lod.hierarchy(scene.object(id).mesh);
            let covered: u32 = selector
                .front(id)
                .iter()
                .map(|&n| h.nodes()[n as usize].original_count())
                .sum();
            assert_eq!(covered as usize, scene.mesh_of(scene.object(id)).triangle_count());
        }
    }
}

#[test]
fn bad_options_and_another_scene_are_refused() {
    let scene = ground_scene(1);
    let lod = SceneLod::build(&scene, &LodConfig::default(), &|_, _| {}).expect("built");
    let view = LodView::new(&camera(&mut Rng::new(5)).to_view()).expect("valid view");
    let mut selector = LodSelector::default();
    let mut parts = Vec::new();
    for (options, want) in [
        (
            LodOptions {
                error_px: 0.0,
                ..LodOptions::default()
            },
            LodError::BadErrorThreshold(0.0),
        ),
        (
            LodOptions {
                budget: Some(0),
                ..LodOptions::default()
            },
            LodError::BadBudget,
        ),
    ] {
        let got = selector.select(&scene, &lod, &[0], &view, &options, &mut |_| false, &mut parts);
        assert_eq!(got, Err(want));
    }
    let nan = LodOptions {
        error_px: f32::NAN,
        ..LodOptions::default()
    };
    assert!(nan.validate().is_err());
    let other = ground_scene(1);
    let mut bigger = other.clone();
    bigger.add_mesh(sphere(6, 8));
    assert!(matches!(
        selector.select(
            &bigger,
            &lod,
            &[0],
            &view,
            &LodOptions::default(),
            &mut |_| false,
            &mut parts
        ),
        Err(LodError::WrongScene { .. })
    ));
    assert_eq!(
        SceneLod::build(&scene, &LodConfig { leaf_triangles: 0 }, &|_, _| {}).err(),
        Some(LodError::BadLeafSize)
    );
}

/// Occluders at the level of detail: with the scene's own hierarchies some
/// occluder is drawn as its cut; hierarchies built for another scene are
/// not used (no panic, the same answer as without).
#[test]
fn occluder_cuts_follow_the_scene_they_were_built_for() {
    use crate::cull::{CullOutput, Culler, HomConfig, HomCuller};
    let scene = ground_scene(6);
    let own = std::sync::Arc::new(SceneLod::build(&scene, &LodConfig::default(), &|_, _| {}).expect("built"));
    let mut other_scene = ground_scene(1);
    other_scene.add_mesh(height_field(4, 9, 0.1));
    let other = std::sync::Arc::new(SceneLod::build(&other_scene, &LodConfig::default(), &|_, _| {}).expect("built"));
    let config = HomConfig {
        cost_model: false,
        ..HomConfig::for_scene(&scene)
    };
    let (mut plain, mut cut, mut wrong) = (
        HomCuller::new(&scene, config.clone()),
        HomCuller::new(&scene, config.clone()),
        HomCuller::new(&scene, config),
    );
    let lod = |hierarchies| {
        Some(OccluderLod {
            hierarchies,
            error_px: 1.0,
        })
    };
    assert!(cut.set_occluder_lod(lod(own)));
    assert!(wrong.set_occluder_lod(lod(other)));
    let mut seed = Rng::new(3);
    let mut cuts = 0;
    for _ in 0..30 {
        let view = camera(&mut seed).to_view();
        let (mut a, mut b, mut c) = (CullOutput::default(), CullOutput::default(), CullOutput::default());
        plain.cull(&scene, &view, &mut a).expect("culled");
        cut.cull(&scene, &view, &mut b).expect("culled");
        wrong.cull(&scene, &view, &mut c).expect("culled");
        assert_eq!(a.visible, c.visible);
        assert_eq!(c.stats.occluders.and_then(|o| o.cuts), Some(0));
        cuts += b.stats.occluders.and_then(|o| o.cuts).unwrap_or(0);
    }
    assert!(cuts > 0, "no occluder was drawn as its cut");
}
