//! A scene file's camera path: `NAME.path.json` beside `NAME.obj` is its
//! default walk in `hom walk`, `hom render` and `hom bench`, and the bench's
//! rows say which path they walked.

use hom::glam::{Mat4, Vec3};
use hom::scene::SceneBuilder;
use hom_walk::bench::{run_bench, BenchError, BenchOptions};
use hom_walk::{open_walk, path_file_of, PathSource};
use std::path::{Path, PathBuf};

/// A fresh folder under the system's temporary one, named for the test.
fn scratch(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hom-scene-paths-{test}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Two unit cubes side by side, as OBJ.
fn write_cubes(file: &Path) {
    let mut b = SceneBuilder::new("cubes");
    let cube = b.add_mesh(hom_testkit::cube());
    for (o, x) in [0.0f32, 3.0].into_iter().enumerate() {
        b.add_object(format!("cube{o}"), cube, Mat4::from_translation(Vec3::new(x, 0.0, 0.0)))
            .unwrap();
    }
    hom_scene::export::write_obj(&b.build().unwrap(), file).unwrap();
}

/// A path of `n` frames looking at the cubes from in front.
fn write_path(file: &Path, n: usize) {
    let frames: Vec<String> = (0..n)
        .map(|i| format!(r#"{{"eye":[{},0.5,8.0],"target":[2.0,0.5,0.0]}}"#, i as f32 * 0.1))
        .collect();
    let json = format!(r#"{{"width":64,"height":48,"frames":[{}]}}"#, frames.join(","));
    std::fs::write(file, json).unwrap();
}

#[test]
fn the_path_file_beside_a_scene_file_is_its_walk() {
    let dir = scratch("beside");
    let obj = dir.join("level.obj");
    write_cubes(&obj);
    let spec = obj.to_str().unwrap();

    // No path file: an orbit around the bounds.
    let opened = open_walk(spec).unwrap();
    assert_eq!(opened.path_source, PathSource::Orbit);
    assert_eq!(opened.path.frames.len(), 120);

    // level.path.json beside level.obj: that path.
    let beside = path_file_of(&obj);
    assert_eq!(beside, dir.join("level.path.json"));
    write_path(&beside, 5);
    let opened = open_walk(spec).unwrap();
    assert_eq!(opened.path_source, PathSource::File(beside.clone()));
    assert_eq!(opened.path.frames.len(), 5);
    assert_eq!((opened.path.width, opened.path.height), (64, 48));

    // An unusable one is an error that names it, not an orbit.
    std::fs::write(&beside, "{ not json").unwrap();
    let err = open_walk(spec).err().expect("a malformed path file is an error");
    assert!(err.to_string().contains("level.path.json"), "{err}");

    // Built-in scenes keep their own walk.
    assert_eq!(open_walk("spheres").unwrap().path_source, PathSource::Builtin);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bench_rows_say_which_path_they_walked() {
    let dir = scratch("bench");
    let obj = dir.join("level.obj");
    write_cubes(&obj);
    write_path(&path_file_of(&obj), 3);
    let other = dir.join("other.json");
    write_path(&other, 2);
    let spec = obj.to_str().unwrap();
    let options = BenchOptions {
        threads: 1,
        ..BenchOptions::default()
    };

    let report = run_bench(&[spec], &["frustum"], &options, |_| {}).unwrap();
    let beside = path_file_of(&obj).display().to_string();
    assert_eq!(report.scenes[0].path, beside);
    assert_eq!(report.scenes[0].frames, 3);
    assert!(report.rows.iter().all(|r| r.path == beside));
    assert!(report.table().contains(&format!("path {beside}")));

    // --camera-path replaces it for the one scene.
    let given = BenchOptions {
        camera_path: Some(other.clone()),
        ..options.clone()
    };
    let report = run_bench(&[spec], &["frustum"], &given, |_| {}).unwrap();
    assert_eq!(report.scenes[0].frames, 2);
    assert!(report.rows.iter().all(|r| r.path == other.display().to_string()));

    // ... and is refused with several scenes, before anything is walked.
    let err = run_bench(&[spec, "spheres"], &["frustum"], &given, |_| {}).unwrap_err();
    assert!(matches!(err, BenchError::CameraPathForSeveralScenes(2)), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}
