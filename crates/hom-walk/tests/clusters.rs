//! Clusters inside objects that keep their ids: a level whose ground and
//! long wall span it is walked cut into clusters and whole. Each frame's
//! `visible` lists objects by the ids they have whole, `visible_clusters`
//! the clusters drawn; the oracle works per cluster and, mapped to objects,
//! sees what it sees in the whole level.

use hom_render::Renderer;
use hom_walk::{cullers, load_options, open_walk_with, path_file_of, walk, WalkOptions, WalkResult};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Object `name`: a grid of `n × m` unit quads from `origin` along `u` and `v`.
fn grid(obj: &mut String, name: &str, origin: [f32; 3], u: [f32; 3], v: [f32; 3], n: usize, m: usize) {
    let _ = writeln!(obj, "o {name}");
    for j in 0..=m {
        for i in 0..=n {
            let p: Vec<f32> = (0..3).map(|k| origin[k] + u[k] * i as f32 + v[k] * j as f32).collect();
            let _ = writeln!(obj, "v {} {} {}", p[0], p[1], p[2]);
        }
    }
    let corner = |i: usize, j: usize| -(((m - j) * (n + 1) + (n - i)) as i64) - 1;
    for j in 0..m {
        for i in 0..n {
            let (a, b, c, d) = (corner(i, j), corner(i + 1, j), corner(i + 1, j + 1), corner(i, j + 1));
            let _ = writeln!(obj, "f {a} {b} {c} {d}");
        }
    }
}

/// A 40 m ground and a 24 m wall (both span the level: cut), a box behind
/// the wall and one beside it (whole), and a path along the wall.
fn write_level(dir: &Path) -> PathBuf {
    let mut obj = String::new();
    grid(
        &mut obj,
        "ground",
        [-20.0, 0.0, -20.0],
        [1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
        40,
        40,
    );
    grid(
        &mut obj,
        "wall",
        [-12.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        24,
        4,
    );
    grid(
        &mut obj,
        "hidden_box",
        [-1.0, 0.0, -5.0],
        [2.0, 0.0, 0.0],
        [0.0, 2.0, 0.0],
        1,
        1,
    );
    grid(
        &mut obj,
        "side_box",
        [15.0, 0.0, 0.0],
        [2.0, 0.0, 0.0],
        [0.0, 2.0, 0.0],
        1,
        1,
    );
    let file = dir.join("level.obj");
    std::fs::write(&file, obj).unwrap();
    let frames: Vec<String> = (0..6)
        .map(|i| {
            let x = -6.0 + 2.5 * i as f32;
            format!(r#"{{"eye":[{x},1.7,12.0],"target":[{},1.0,-10.0]}}"#, x * 0.5)
        })
        .collect();
    let path = format!(r#"{{"width":96,"height":64,"frames":[{}]}}"#, frames.join(","));
    std::fs::write(path_file_of(&file), path).unwrap();
    file
}

fn walk_level(file: &Path, clusters: bool, culler: &str) -> (hom::scene::Scene, WalkResult) {
    let opened = open_walk_with(file.to_str().unwrap(), &load_options(clusters)).unwrap();
    let mut scene = opened.scene;
    let settings = cullers::CullerSettings::for_scene(&scene);
    let mut culler = cullers::make(culler, &scene, &settings).unwrap();
    let options = WalkOptions {
        oracle: true,
        ..WalkOptions::default()
    };
    let renderer = Renderer::new(1).unwrap();
    let result = walk(
        &mut scene,
        &opened.animation,
        &opened.path,
        culler.as_mut(),
        &renderer,
        &options,
        |_| {},
    )
    .unwrap();
    (scene, result)
}

#[test]
fn a_cut_objects_clusters_are_drawn_and_reported_under_its_own_id() {
    let dir = std::env::temp_dir().join(format!("hom-clusters-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = write_level(&dir);
    for culler in ["frustum", "masked"] {
        let (cut, on) = walk_level(&file, true, culler);
        let (_, off) = walk_level(&file, false, culler);
        assert_eq!((off.header.objects, off.header.cluster_count), (4, 4));
        assert_eq!(on.header.objects, 4, "the ids are the whole level's");
        assert!(on.header.cluster_count > 20, "{} clusters", on.header.cluster_count);
        let mut clusters_seen = 0;
        for (a, b) in on.frames.iter().zip(&off.frames) {
            let frame = a.frame;
            assert_eq!(a.visible, cut.parents_of(&a.visible_clusters), "{culler} frame {frame}");
            assert_eq!(
                (a.objects_drawn, a.clusters_drawn),
                (a.visible.len() as u64, a.visible_clusters.len() as u64)
            );
            assert_eq!(b.visible, b.visible_clusters, "uncut: one cluster each");
            let (oa, ob) = (a.oracle.as_ref().unwrap(), b.oracle.as_ref().unwrap());
            assert!(
                oa.false_culls.is_empty() && ob.false_culls.is_empty(),
                "{culler} frame {frame}"
            );
            assert_eq!(
                cut.parents_of(&oa.oracle_visible),
                ob.oracle_visible,
                "{culler} frame {frame}: the oracle per cluster sees the same objects"
            );
            assert!(
                ob.oracle_visible.contains(&0) && !ob.oracle_visible.contains(&2),
                "ground seen, box hidden"
            );
            clusters_seen = clusters_seen.max(oa.oracle_visible.len());
        }
        assert!(clusters_seen > 4, "several clusters of the ground and wall are seen");
        assert!(on.summary.median_clusters_drawn >= on.summary.median_objects_drawn);
    }
    let _ = std::fs::remove_dir_all(&dir);
}
