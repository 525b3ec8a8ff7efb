//! Extreme Tux Racer courses: small synthetic courses written to a temporary
//! directory (the format's semantics, hostile files), and the real courses
//! from the fetched cache (`scripts/fetch-scenes.sh`), skipped, saying why,
//! when it is missing.

use glam::Vec3;
use hom_scene::etr::{self, EtrError, EtrOptions, ItemKind};
use hom_scene::LoadError;
use image::{GrayImage, Luma, Rgb, RgbImage};
use std::path::{Path, PathBuf};

const DIM: &str = "*[width]30[length]20[play_width]30[play_length]20\n[startx]15.00[starty]2.00[angle]30.00[scale]10.00\n[env]etr\n[author]test\n*[desc] a test course [with brackets]\n";

/// A course directory with `course.dim` = `dim`, `elev.png` from `elev`
/// (grey of pixel (px, py)), `w × h`, and no item map.
fn course(dim: &str, w: u32, h: u32, elev: impl Fn(u32, u32) -> u8) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("course.dim"), dim).unwrap();
    GrayImage::from_fn(w, h, |x, y| Luma([elev(x, y)]))
        .save(dir.path().join("elev.png"))
        .unwrap();
    dir
}

fn dim_file(dir: &tempfile::TempDir) -> PathBuf {
    dir.path().join("course.dim")
}

fn write_trees(dir: &Path, w: u32, h: u32, items: &[(u32, u32, [u8; 3])]) {
    let mut img = RgbImage::new(w, h);
    for &(x, y, c) in items {
        img.put_pixel(x, y, Rgb(c));
    }
    img.save(dir.join("trees.png")).unwrap();
}

/// Grey of pixel (px, py) in the synthetic height fields: distinct per pixel.
fn grey(px: u32, py: u32) -> u8 {
    (10 + 40 * py + 7 * px) as u8
}

/// Every world-space terrain vertex (terrain objects are untransformed).
fn terrain_vertices(c: &etr::EtrCourse) -> Vec<Vec3> {
    let s = &c.scene;
    s.objects()[..c.terrain_objects]
        .iter()
        .flat_map(|o| s.mesh_of(o).positions().iter().copied())
        .collect()
}

#[test]
fn vertex_heights_follow_etr_flip_scale_and_slope() {
    let (nx, ny) = (4u32, 3u32);
    let dir = course(DIM, nx, ny, grey);
    let c = etr::load(&dim_file(&dir), &EtrOptions::default()).unwrap();
    let verts = terrain_vertices(&c);
    let (w, l, scale) = (30.0f32, 20.0f32, 10.0f32);
    let slope = 30f32.to_radians().tan();
    for j in 0..ny {
        for i in 0..nx {
            // Node (i, j) holds pixel (nx − 1 − i, j): x mirrored, rows from the top.
            let x = i as f32 / (nx - 1) as f32 * w;
            let z = -(j as f32) / (ny - 1) as f32 * l;
            let g = f32::from(grey(nx - 1 - i, j));
            let y = (g - 127.0) / 255.0 * scale - j as f32 / ny as f32 * l * slope;
            let v = verts
                .iter()
                .find(|v| (v.x - x).abs() < 1e-4 && (v.z - z).abs() < 1e-4)
                .unwrap_or_else(|| panic!("no vertex at ({x}, {z})"));
            assert!((v.y - y).abs() < 1e-4, "node ({i}, {j}): {} vs {y}", v.y);
            assert!((c.terrain.height_at(x, z) - y).abs() < 1e-4);
        }
    }
    // Pixel (0, 0) (top left of the image) is at the top right of the course.
    let top_right = verts.iter().find(|v| v.x == w && v.z == 0.0).unwrap();
    assert!((top_right.y - (f32::from(grey(0, 0)) - 127.0) / 255.0 * scale).abs() < 1e-4);
    // The surface between nodes is the triangles': mid-cell on ETR's diagonal.
    let mid = c.terrain.height_at(0.5 * w / 3.0, -0.5 * l / 2.0);
    let diag = (c.terrain.node(0, 0).y + c.terrain.node(1, 1).y) / 2.0;
    assert!((mid - diag).abs() < 1e-4, "{mid} vs {diag}");
    assert!(c.items.is_empty(), "no trees.png: no items");
    assert_eq!(c.scene.name(), dir.path().file_name().unwrap().to_string_lossy());
}

#[test]
fn terrain_is_two_triangles_per_cell_cut_into_cluster_sized_occluders() {
    let (nx, ny) = (40u32, 30u32);
    let dir = course(DIM, nx, ny, |x, y| ((x * 5 + y * 3) % 200) as u8);
    let c = etr::load(&dim_file(&dir), &EtrOptions::default()).unwrap();
    let s = &c.scene;
    assert_eq!(c.terrain_objects, s.objects().len());
    assert_eq!(s.triangle_count(), 2 * 39 * 29);
    assert!(c.terrain_objects > 10, "{}", c.terrain_objects);
    for (k, o) in s.objects().iter().enumerate() {
        assert_eq!(o.name, format!("terrain_{k}"));
        assert!(o.occluder);
        assert!(
            o.triangles <= 64 && o.triangles.is_multiple_of(2),
            "a cell's two triangles stay together"
        );
    }
    // Unsplit: one object.
    let options = EtrOptions {
        split: hom_scene::split::SplitOptions {
            enabled: false,
            ..Default::default()
        },
        ..EtrOptions::default()
    };
    let whole = etr::load(&dim_file(&dir), &options).unwrap();
    assert_eq!(whole.scene.objects().len(), 1);
    assert_eq!(whole.scene.triangle_count(), 2 * 39 * 29);
    hom_testkit::assert_clusters_of_whole_objects(s, &whole.scene);
}

#[test]
fn items_become_non_occluder_billboards_where_etr_puts_them() {
    let (nx, ny) = (8u32, 6u32);
    let dir = course(DIM, nx, ny, grey);
    let items = [
        (1, 0, [255, 255, 255]), // tree
        (2, 1, [20, 240, 30]),   // shrub
        (0, 2, [240, 96, 10]),   // tree_barren
        (3, 3, [0, 0, 255]),     // herring
        (4, 3, [194, 40, 40]),   // flag
        (5, 4, [128, 128, 0]),   // start
        (6, 4, [255, 255, 0]),   // finish
        (7, 5, [255, 128, 255]), // float: not drawn
        (6, 5, [100, 50, 50]),   // no item
        (5, 5, [200, 200, 200]), // no item
    ];
    write_trees(dir.path(), nx, ny, &items);
    let c = etr::load(&dim_file(&dir), &EtrOptions::default()).unwrap();
    let kinds: Vec<ItemKind> = c.items.iter().map(|i| i.kind).collect();
    use ItemKind::*;
    assert_eq!(kinds, [Tree, Shrub, BarrenTree, Herring, Flag, Start, Finish, Float]);
    let s = &c.scene;
    assert_eq!(s.objects().len(), c.terrain_objects + 7, "the float is not drawn");
    let (w, l) = (30.0f32, 20.0f32);
    for it in &c.items {
        let [px, py] = it.pixel;
        let x = (nx - px) as f32 / (nx - 1) as f32 * w;
        let z = -(py as f32 + 1.0) / (ny - 1) as f32 * l;
        assert!(
            (it.position.x - x).abs() < 1e-4 && (it.position.z - z).abs() < 1e-4,
            "{it:?}"
        );
        assert!((it.position.y - c.terrain.height_at(x, z)).abs() < 1e-5);
        let Some(id) = it.object else {
            assert_eq!(it.kind, Float);
            continue;
        };
        let o = s.object(id);
        assert_eq!(o.name, format!("{}_{px}_{py}", it.kind.name()));
        assert!(!o.occluder, "{}: billboards are see-through", o.name);
        let b = o.aabb;
        assert!((b.min.y - it.position.y).abs() < 1e-3, "stands on the terrain");
        assert!((b.max.y - b.min.y - it.height).abs() < 1e-3);
        assert!((b.center().x - x).abs() < 1e-3 && (b.center().z - z).abs() < 1e-3);
        let (lo, hi) = match it.kind {
            Tree => (2.5 / 1.41, 2.5 * 1.41),
            BarrenTree => (3.0 / 1.41, 3.0 * 1.41),
            Shrub => (1.2 / 1.41, 1.2 * 1.41),
            Start | Finish => (6.0, 6.0),
            _ => (1.0, 1.0),
        };
        assert!(it.height >= lo - 1e-4 && it.height <= hi + 1e-4, "{it:?}");
        if it.kind.is_plant() {
            assert_eq!(o.triangles, 4, "two crossed quads");
            assert!(it.diameter >= it.height / 1.4 - 1e-4 && it.diameter <= it.height + 1e-4);
            assert!((b.max.x - b.min.x - it.diameter).abs() < 1e-3);
            assert!((b.max.z - b.min.z - it.diameter).abs() < 1e-3);
        } else {
            assert_eq!(o.triangles, 2, "one quad");
            assert!((b.max.x - b.min.x - it.diameter).abs() < 1e-3);
            assert!(b.max.z - b.min.z < 1e-3, "faces down the course");
        }
    }
    // Deterministic sizes (a hash of the pixel, not rand()).
    let again = etr::load(&dim_file(&dir), &EtrOptions::default()).unwrap();
    assert_eq!(again.items, c.items);
    // Without items.
    let bare = EtrOptions {
        items: false,
        ..EtrOptions::default()
    };
    assert!(etr::load(&dim_file(&dir), &bare).unwrap().items.is_empty());
}

#[test]
fn path_runs_down_the_valley_above_the_terrain_and_never_looks_straight_down() {
    // 60 × 200 m, a valley at image column 15 of 60 (x = 44 m, mirrored), a
    // tree grove across the top rows away from it.
    let (nx, ny) = (60u32, 200u32);
    let dim = "*[width]60[length]200[play_width]56[play_length]190[startx]30[starty]3[angle]40[scale]30\n";
    let dir = course(dim, nx, ny, |x, _| (100 + 3 * x.abs_diff(15)).min(255) as u8);
    let grove: Vec<(u32, u32, [u8; 3])> = (30..50).map(|x| (x, 20, [255, 255, 255])).collect();
    write_trees(dir.path(), nx, ny, &grove);
    let c = etr::load(&dim_file(&dir), &EtrOptions::default()).unwrap();
    let p = &c.path;
    p.validate("valley").unwrap();
    assert_eq!(p.frames.len(), 600);
    let first = Vec3::from(p.frames[0].eye);
    assert!(
        (first.x - 30.0).abs() < 12.0 && (first.z + 3.0).abs() < 1.0,
        "starts near the start: {first}"
    );
    let mut last_z = f32::INFINITY;
    for (k, f) in p.frames.iter().enumerate() {
        let eye = Vec3::from(f.eye);
        let ground = c.terrain.height_at(eye.x, eye.z);
        assert!(
            (eye.y - ground - 1.7).abs() < 1e-3,
            "frame {k}: eye {eye}, ground {ground}"
        );
        assert!(eye.z <= last_z, "frame {k} goes downhill");
        last_z = eye.z;
        let dir = (Vec3::from(f.target) - eye).normalize();
        assert!(
            dir.y.abs() <= 60f32.to_radians().sin() + 1e-4,
            "frame {k} looks too steeply: {dir}"
        );
        assert!(dir.z < 0.0, "frame {k} looks down the course");
        assert!(
            eye.x >= 2.0 - 1e-3 && eye.x <= 58.0 + 1e-3,
            "frame {k} inside the play area: {eye}"
        );
    }
    assert!(last_z < -180.0, "reaches the end of the play area: {last_z}");
    // After the start, the line follows the valley floor (x = 44 m).
    let valley = p.frames[150..].iter().filter(|f| (f.eye[0] - 44.0).abs() < 3.0).count();
    assert!(valley > 400, "{valley} frames in the valley");
    // The path is the loaded scene's own.
    let loaded = hom_scene::load_with_path(&dim_file(&dir)).unwrap();
    assert_eq!(loaded.path.as_ref(), Some(p));
    assert_eq!(loaded.scene.objects().len(), c.scene.objects().len());
}

/// Loads `dir`'s course, expecting an ETR error from the file `file`; checks
/// that the message names it and returns the cause.
fn expect_error(dir: &Path, file: &str, options: &EtrOptions) -> EtrError {
    let err = etr::load(&dir.join("course.dim"), options).expect_err("a hostile course loads");
    let message = format!("{err}");
    assert!(message.contains(file), "'{message}' does not name {file}");
    match err {
        LoadError::Etr { path, source } => {
            assert!(path.ends_with(file), "{path}");
            source
        }
        other => panic!("not an ETR error: {other:?}"),
    }
}

fn dim_error(dim: &str) -> EtrError {
    let dir = course(dim, 4, 4, grey);
    expect_error(dir.path(), "course.dim", &EtrOptions::default())
}

#[test]
fn a_missing_course_dim_is_an_io_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    assert!(matches!(
        expect_error(dir.path(), "course.dim", &EtrOptions::default()),
        EtrError::Io(_)
    ));
    // Through the dispatcher too.
    let err = hom_scene::load(&dir.path().join("course.dim")).unwrap_err();
    assert!(
        matches!(
            err,
            LoadError::Etr {
                source: EtrError::Io(_),
                ..
            }
        ),
        "{err:?}"
    );
}

#[test]
fn a_missing_parameter_is_named() {
    for field in ["width", "length", "angle", "scale"] {
        let dim = DIM.replace(&format!("[{field}]"), "[other]");
        let e = dim_error(&dim);
        assert!(
            matches!(e, EtrError::MissingField { field: f } if f == field),
            "{field}: {e:?}"
        );
        assert!(e.to_string().contains(field));
    }
    // The parameters must be in the first record.
    let e = dim_error("*[author] x\n*[width]30[length]20[angle]30[scale]10\n");
    assert!(matches!(e, EtrError::MissingField { field: "width" }), "{e:?}");
    assert!(matches!(dim_error(""), EtrError::MissingField { .. }));
}

/// A course.dim with the required parameters, `field` set to `value`.
fn dim_with(field: &str, value: &str) -> String {
    let mut fields = vec![("width", "30"), ("length", "20"), ("angle", "30"), ("scale", "10")];
    match fields.iter_mut().find(|f| f.0 == field) {
        Some(f) => f.1 = value,
        None => fields.push((field, value)),
    }
    let record: String = fields.iter().map(|(k, v)| format!("[{k}]{v}")).collect();
    format!("*{record}\n")
}

#[test]
fn a_non_numeric_parameter_is_rejected() {
    for (field, bad) in [
        ("width", "wide"),
        ("scale", "10m"),
        ("angle", "30 deg"),
        ("startx", "left"),
        ("play_width", "1,5"),
    ] {
        let e = dim_error(&dim_with(field, bad));
        assert!(
            matches!(&e, EtrError::BadNumber { field: f, value } if *f == field && value == bad),
            "{field}: {e:?}"
        );
        assert!(e.to_string().contains(bad));
    }
    // A well-formed one loads (the helper is right).
    let dir = course(&dim_with("startx", "3"), 4, 4, grey);
    etr::load(&dim_file(&dir), &EtrOptions::default()).unwrap();
}

#[test]
fn a_non_finite_parameter_is_rejected() {
    for bad in ["nan", "inf", "-inf", "NaN", "1e999"] {
        let e = dim_error(&DIM.replace("[length]20", &format!("[length]{bad}")));
        assert!(
            matches!(&e, EtrError::BadNumber { field: "length", .. }),
            "{bad}: {e:?}"
        );
    }
}

#[test]
fn a_non_positive_or_absurd_parameter_is_out_of_range() {
    for (from, to, field) in [
        ("[scale]10.00", "[scale]0", "scale"),
        ("[scale]10.00", "[scale]-3", "scale"),
        ("[width]30", "[width]-30", "width"),
        ("[width]30", "[width]1e9", "width"),
        ("[length]20", "[length]0", "length"),
        ("[length]20", "[length]200000", "length"),
        ("[scale]10.00", "[scale]50000", "scale"),
        ("[angle]30.00", "[angle]0", "angle"),
        ("[angle]30.00", "[angle]-10", "angle"),
        ("[angle]30.00", "[angle]80", "angle"),
        ("[angle]30.00", "[angle]89.9", "angle"),
        ("[play_width]30", "[play_width]0", "play_width"),
        ("[play_length]20", "[play_length]-1", "play_length"),
    ] {
        let e = dim_error(&DIM.replace(from, to));
        assert!(
            matches!(&e, EtrError::OutOfRange { field: f, .. } if *f == field),
            "{to}: {e:?}"
        );
    }
}

#[test]
fn an_oversized_course_dim_is_refused() {
    let dim = format!("{DIM}#{}\n", "x".repeat(2 << 20));
    assert!(matches!(dim_error(&dim), EtrError::TooLarge { max } if max == etr::MAX_DIM_BYTES));
}

#[test]
fn a_missing_elevation_map_is_an_io_error_naming_it() {
    let dir = course(DIM, 4, 4, grey);
    std::fs::remove_file(dir.path().join("elev.png")).unwrap();
    assert!(matches!(
        expect_error(dir.path(), "elev.png", &EtrOptions::default()),
        EtrError::Io(_)
    ));
}

#[test]
fn an_elevation_map_that_is_not_a_png_is_refused() {
    let dir = course(DIM, 4, 4, grey);
    std::fs::write(dir.path().join("elev.png"), b"P5 4 4 255\n0123456789abcdef").unwrap();
    assert!(matches!(
        expect_error(dir.path(), "elev.png", &EtrOptions::default()),
        EtrError::NotPng
    ));
    std::fs::write(dir.path().join("elev.png"), b"").unwrap();
    assert!(matches!(
        expect_error(dir.path(), "elev.png", &EtrOptions::default()),
        EtrError::NotPng
    ));
}

#[test]
fn a_truncated_elevation_map_is_refused() {
    let dir = course(DIM, 64, 64, |x, y| (x * 7 + y * 13) as u8);
    let path = dir.path().join("elev.png");
    let bytes = std::fs::read(&path).unwrap();
    // Cut in the header, then in the image data.
    std::fs::write(&path, &bytes[..20]).unwrap();
    assert!(matches!(
        expect_error(dir.path(), "elev.png", &EtrOptions::default()),
        EtrError::BadHeader
    ));
    std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
    let e = expect_error(dir.path(), "elev.png", &EtrOptions::default());
    assert!(matches!(e, EtrError::Image(_)), "{e:?}");
}

/// A PNG signature and IHDR chunk claiming `w × h` 8-bit grey, and nothing else.
fn png_header(w: u32, h: u32) -> Vec<u8> {
    let mut b = vec![0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, b'\n', 0, 0, 0, 13];
    let mut chunk = b"IHDR".to_vec();
    chunk.extend(w.to_be_bytes());
    chunk.extend(h.to_be_bytes());
    chunk.extend([8, 0, 0, 0, 0]);
    let mut crc = flate2::Crc::new();
    crc.update(&chunk);
    b.extend(&chunk);
    b.extend(crc.sum().to_be_bytes());
    b
}

#[test]
fn absurd_or_tiny_image_sizes_are_refused_from_the_header() {
    let dir = course(DIM, 4, 4, grey);
    let path = dir.path().join("elev.png");
    // 100 000 × 100 000 samples: refused before any decoding (the file has no data).
    std::fs::write(&path, png_header(100_000, 100_000)).unwrap();
    let e = expect_error(dir.path(), "elev.png", &EtrOptions::default());
    assert!(
        matches!(e, EtrError::ImageSize { width: 100_000, height: 100_000, max_samples } if max_samples == etr::DEFAULT_MAX_SAMPLES),
        "{e:?}"
    );
    std::fs::write(&path, png_header(u32::MAX, u32::MAX)).unwrap();
    assert!(matches!(
        expect_error(dir.path(), "elev.png", &EtrOptions::default()),
        EtrError::ImageSize { .. }
    ));
    // Fewer than 2 × 2.
    for (w, h) in [(1, 5), (5, 1), (0, 0)] {
        if w == 0 {
            std::fs::write(&path, png_header(0, 0)).unwrap();
        } else {
            GrayImage::new(w, h).save(&path).unwrap();
        }
        let e = expect_error(dir.path(), "elev.png", &EtrOptions::default());
        assert!(matches!(e, EtrError::ImageSize { .. }), "{w} × {h}: {e:?}");
    }
    // The limit is an option.
    GrayImage::new(10, 10).save(&path).unwrap();
    let small = EtrOptions {
        max_samples: 99,
        ..EtrOptions::default()
    };
    assert!(matches!(
        expect_error(dir.path(), "elev.png", &small),
        EtrError::ImageSize { max_samples: 99, .. }
    ));
    let enough = EtrOptions {
        max_samples: 100,
        ..EtrOptions::default()
    };
    etr::load(&dir.path().join("course.dim"), &enough).unwrap();
}

#[test]
fn an_item_map_of_another_size_is_refused() {
    let dir = course(DIM, 8, 6, grey);
    write_trees(dir.path(), 8, 7, &[(1, 1, [255, 255, 255])]);
    let e = expect_error(dir.path(), "trees.png", &EtrOptions::default());
    assert!(
        matches!(
            e,
            EtrError::MapSize {
                width: 8,
                height: 7,
                elev_width: 8,
                elev_height: 6
            }
        ),
        "{e:?}"
    );
    std::fs::write(dir.path().join("trees.png"), b"GIF89a").unwrap();
    assert!(matches!(
        expect_error(dir.path(), "trees.png", &EtrOptions::default()),
        EtrError::NotPng
    ));
}

#[test]
fn start_outside_the_course_is_clamped() {
    let dim = "*[width]30[length]20[startx]-100[starty]500[angle]30[scale]10\n";
    let dir = course(dim, 6, 6, grey);
    let c = etr::load(&dim_file(&dir), &EtrOptions::default()).unwrap();
    assert_eq!((c.dim.start_x, c.dim.start_y), (0.0, 20.0));
    c.path.validate("clamped").unwrap();
    assert!(c.path.frames.iter().all(|f| f.eye[2] <= 0.0 && f.eye[2] >= -20.0));
}

fn cache() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../.cache/scenes/debian/usr/share/games/etr/courses")
}

#[test]
fn real_courses_load_with_sane_counts_and_paths() {
    let root = cache();
    if !root.exists() {
        eprintln!("skipping: {} is missing; run scripts/fetch-scenes.sh", root.display());
        return;
    }
    for name in ["default/bunny_hill", "extras/wild_ride", "default/path_of_daggers"] {
        let file = root.join(name).join("course.dim");
        let t = std::time::Instant::now();
        let c = etr::load(&file, &EtrOptions::default()).unwrap_or_else(|e| panic!("{name}: {e:#?}"));
        let s = &c.scene;
        let plants = c.items.iter().filter(|i| i.kind.is_plant()).count();
        let b = s.bounds();
        println!(
            "{name}: {} objects ({} terrain, {} items, {plants} plants), {} triangles, bounds {:?}..{:?} ({:.2} s)",
            s.objects().len(),
            c.terrain_objects,
            c.items.len(),
            s.triangle_count(),
            b.min,
            b.max,
            t.elapsed().as_secs_f32()
        );
        let (nx, ny) = (c.terrain.nx as u64, c.terrain.ny as u64);
        let items_tris: u64 = c
            .items
            .iter()
            .filter_map(|i| i.object)
            .map(|id| u64::from(s.object(id).triangles))
            .sum();
        assert_eq!(s.triangle_count(), 2 * (nx - 1) * (ny - 1) + items_tris);
        assert!(plants > 50, "{name}: {plants} plants");
        assert!(s.objects()[c.terrain_objects..].iter().all(|o| !o.occluder));
        // Metres: the course's own size, sloping down.
        let size = b.extent();
        assert!(
            (size.x - c.dim.width).abs() < 2.0 * c.terrain.dx() + 5.0,
            "{name}: {size}"
        );
        assert!(size.z > c.dim.length * 0.99, "{name}: {size}");
        assert!(b.max.y - b.min.y > c.dim.length * 0.2, "{name}: a slope");
        c.path.validate(name).unwrap();
        for f in &c.path.frames {
            let eye = Vec3::from(f.eye);
            assert!(eye.y > c.terrain.height_at(eye.x, eye.z) + 1.0, "{name}: {eye}");
        }
    }
    // Every course of the package loads.
    let mut count = 0;
    for set in ["default", "extras"] {
        let Ok(dirs) = std::fs::read_dir(root.join(set)) else {
            continue;
        };
        for d in dirs.flatten() {
            let file = d.path().join("course.dim");
            if file.exists() {
                let options = EtrOptions {
                    split: hom_scene::split::SplitOptions {
                        enabled: false,
                        ..Default::default()
                    },
                    ..EtrOptions::default()
                };
                etr::load(&file, &options).unwrap_or_else(|e| panic!("{}: {e:#?}", file.display()));
                count += 1;
            }
        }
    }
    println!("{count} courses load");
    assert!(count >= 40, "{count}");
}
