//! Loader and exporter tests: OBJ round trips, OBJ grouping and errors, glTF/GLB
//! loading with instancing and world transforms, and hostile input (no panics).
//!
//! Every fixture is generated here at run time into a temporary directory.

use glam::{Mat4, Quat, Vec3};
use hom::scene::{Mesh, Scene, SceneBuilder, SceneError};
use hom_scene::{export, gltf, obj, LoadError};
use hom_testkit::{grid_obj, Rng};
use proptest::prelude::*;
use serde_json::json;
use std::path::{Path, PathBuf};

// ---------------------------------------------------------------- helpers

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

fn load_obj_text(text: &str) -> Result<Scene, LoadError> {
    obj::parse(text.as_bytes(), Path::new("test.obj"))
}

fn names(scene: &Scene) -> Vec<&str> {
    scene.objects().iter().map(|o| o.name.as_str()).collect()
}

fn tri_counts(scene: &Scene) -> Vec<u32> {
    scene.objects().iter().map(|o| o.triangles).collect()
}

/// World-space corners of every triangle of object `id`.
fn world_triangles(scene: &Scene, id: u32) -> Vec<[Vec3; 3]> {
    let o = scene.object(id);
    let m = scene.mesh_of(o);
    m.triangles()
        .iter()
        .map(|t| t.map(|i| o.transform.transform_point3(m.positions()[i as usize])))
        .collect()
}

/// Object-space corners of every triangle of object `id` (no transform applied).
fn local_triangles(scene: &Scene, id: u32) -> Vec<[Vec3; 3]> {
    let m = scene.mesh_of(scene.object(id));
    m.triangles()
        .iter()
        .map(|t| t.map(|i| m.positions()[i as usize]))
        .collect()
}

fn bits(t: &[Vec3; 3]) -> [[u32; 3]; 3] {
    t.map(|v| v.to_array().map(f32::to_bits))
}

fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in bytes.chunks(3) {
        let n =
            (u32::from(c[0]) << 16) | (u32::from(*c.get(1).unwrap_or(&0)) << 8) | u32::from(*c.get(2).unwrap_or(&0));
        for k in 0..4 {
            if k <= c.len() {
                s.push(A[(n >> (18 - 6 * k)) as usize & 63] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

const VALID_OBJ: &str = "# a small valid file\n\
mtllib none.mtl\n\
v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
vt 0 0\nvn 0 0 1\n\
o box\n\
usemtl red\n\
f 1/1/1 2/1/1 3/1/1 4/1/1\n\
g inner\n\
f -4 -2 -1\n\
o other thing\n\
v 0 0 1 2\n\
f 1//1 2//1 5//1\n";

// ---------------------------------------------------------------- OBJ round trip

/// A random small scene: a few meshes, objects sharing them, non-identity transforms.
fn arb_scene() -> impl Strategy<Value = Scene> {
    let coord = -1000.0f32..1000.0;
    let mesh = (3usize..8)
        .prop_flat_map(move |n| {
            (
                prop::collection::vec((coord.clone(), coord.clone(), coord.clone()), n),
                prop::collection::vec((0..n as u32, 0..n as u32, 0..n as u32), 1..6),
            )
        })
        .prop_map(|(p, t)| {
            (
                p.into_iter().map(|(x, y, z)| Vec3::new(x, y, z)).collect::<Vec<_>>(),
                t.into_iter().map(|(a, b, c)| [a, b, c]).collect::<Vec<_>>(),
            )
        });
    let name = prop_oneof!["[a-zA-Z0-9_.-]{1,8}", "[a-z]{1,4} [a-z]{1,4}", Just(String::new()),];
    let object = (
        name,
        0usize..4,
        (-3.0f32..3.0, -3.0f32..3.0, -3.0f32..3.0, 0.0f32..6.3),
        (0.25f32..4.0, 0.25f32..4.0, 0.25f32..4.0),
        (-500.0f32..500.0, -500.0f32..500.0, -500.0f32..500.0),
    );
    (prop::collection::vec(mesh, 1..4), prop::collection::vec(object, 1..7)).prop_map(|(meshes, objects)| {
        let mut b = SceneBuilder::new("random");
        for (k, (p, t)) in meshes.iter().enumerate() {
            b.add_mesh(Mesh::new(format!("m{k}"), p.clone(), t.clone()).unwrap());
        }
        for (name, mesh, (ax, ay, az, angle), (sx, sy, sz), (tx, ty, tz)) in objects {
            let axis = Vec3::new(ax, ay, az).try_normalize().unwrap_or(Vec3::Y);
            let transform = Mat4::from_scale_rotation_translation(
                Vec3::new(sx, sy, sz),
                Quat::from_axis_angle(axis, angle),
                Vec3::new(tx, ty, tz),
            );
            b.add_object(name, (mesh % meshes.len()) as u32, transform).unwrap();
        }
        b.build().unwrap()
    })
}

fn expected_name(name: &str, id: usize) -> String {
    if name.is_empty() {
        format!("object_{id}")
    } else {
        name.replace(' ', "_")
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn obj_round_trip_preserves_world_triangles(scene in arb_scene()) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("round trip.obj");
        export::write_obj(&scene, &path).unwrap();
        let back = hom_scene::load(&path).unwrap();
        prop_assert_eq!(back.name(), "round trip");
        prop_assert_eq!(back.objects().len(), scene.objects().len());
        for (id, (a, b)) in scene.objects().iter().zip(back.objects()).enumerate() {
            prop_assert_eq!(&b.name, &expected_name(&a.name, id));
            prop_assert_eq!(b.triangles, a.triangles);
            prop_assert_eq!(b.transform, Mat4::IDENTITY);
            let ta = world_triangles(&scene, id as u32);
            // Identity transform: compare the stored positions (x * 1.0 + 0.0 would turn -0 into +0).
            let tb = local_triangles(&back, id as u32);
            prop_assert_eq!(ta.len(), tb.len());
            for (x, y) in ta.iter().zip(&tb) {
                prop_assert_eq!(bits(x), bits(y));
            }
        }
        // Nothing but the output file is left in the directory.
        let entries: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        prop_assert_eq!(entries.len(), 1);
    }
}

#[test]
fn export_writes_o_v_f_lines_in_id_order() {
    let mut b = SceneBuilder::new("s");
    let m = b.add_mesh(Mesh::new("tri", vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap());
    b.add_object("first one", m, Mat4::from_translation(Vec3::new(0.1, 0.0, 0.0)))
        .unwrap();
    b.add_object("", m, Mat4::from_scale(Vec3::splat(2.0))).unwrap();
    let scene = b.build().unwrap();
    let mut out = Vec::new();
    export::write_obj_to(&scene, &mut out).unwrap();
    let text = String::from_utf8(out).unwrap();
    let body: Vec<&str> = text.lines().filter(|l| !l.starts_with('#')).collect();
    assert_eq!(
        body,
        [
            "o first_one",
            "v 0.1 0 0",
            "v 1.1 0 0",
            "v 0.1 1 0",
            "f 1 2 3",
            "o object_1",
            "v 0 0 0",
            "v 2 0 0",
            "v 0 2 0",
            "f 4 5 6",
        ]
    );
}

#[test]
fn export_failure_keeps_existing_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "keep.obj", b"precious");
    let mut b = SceneBuilder::new("s");
    let m = b.add_mesh(Mesh::new("tri", vec![Vec3::ZERO, Vec3::X * 1e10, Vec3::Y], vec![[0, 1, 2]]).unwrap());
    // Finite and invertible, but a vertex overflows to infinity in world space.
    b.add_object("huge", m, Mat4::from_scale(Vec3::new(1e30, 1e-30, 1.0)))
        .unwrap();
    let scene = b.build().unwrap();
    let err = export::write_obj(&scene, &path).unwrap_err();
    assert!(matches!(err, LoadError::Io { .. }), "{err}");
    assert_eq!(std::fs::read(&path).unwrap(), b"precious");
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        1,
        "temporary file left behind"
    );
    // A directory that does not exist: an I/O error naming the file.
    let missing = dir.path().join("no such dir").join("x.obj");
    let err = export::write_obj(&scene, &missing).unwrap_err();
    assert!(err.to_string().contains("x.obj"), "{err}");
}

// ---------------------------------------------------------------- OBJ grouping

#[test]
fn obj_valid_file_loads_with_o_groups() {
    let s = load_obj_text(VALID_OBJ).unwrap();
    assert_eq!(s.name(), "test");
    assert_eq!(names(&s), ["box", "other thing"]);
    // Quad -> 2 triangles, plus the triangle under `g inner` stays in `box`.
    assert_eq!(tri_counts(&s), [3, 1]);
    // `v 0 0 1 2`: w divides.
    let t = world_triangles(&s, 1);
    assert_eq!(t[0], [Vec3::ZERO, Vec3::X, Vec3::new(0.0, 0.0, 0.5)]);
    for o in s.objects() {
        assert_eq!(o.transform, Mat4::IDENTITY);
    }
}

#[test]
fn obj_only_g_groups_make_one_object_each() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n\
                g first\nf 1 2 3\nf 1 3 4\n\
                g second\nf 2 3 4\n";
    let s = load_obj_text(text).unwrap();
    assert_eq!(names(&s), ["first", "second"]);
    assert_eq!(tri_counts(&s), [2, 1]);
    // Each object has its own mesh with only the vertices it uses.
    assert_eq!(s.meshes().len(), 2);
    assert_eq!(s.mesh_of(s.object(1)).positions().len(), 3);
}

#[test]
fn obj_g_inside_o_does_not_split_objects() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n\
                o A\ng x\nf 1 2 3\ng y\nf 1 3 4\n\
                o B\ng x\nf 2 3 4\n";
    let s = load_obj_text(text).unwrap();
    assert_eq!(names(&s), ["A", "B"]);
    assert_eq!(tri_counts(&s), [2, 1]);
}

#[test]
fn obj_groups_without_faces_are_skipped() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\n\
                o empty\no\no full\nf 1 2 3\no trailing\n";
    let s = load_obj_text(text).unwrap();
    assert_eq!(names(&s), ["full"]);
    let g = "v 0 0 0\nv 1 0 0\nv 0 1 0\ng nothing\ng real\nf 1 2 3\ng\n";
    assert_eq!(names(&load_obj_text(g).unwrap()), ["real"]);
}

#[test]
fn obj_faces_before_any_group_and_unnamed_groups() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\no\nf 3 2 1\n";
    let s = load_obj_text(text).unwrap();
    assert_eq!(names(&s), ["test", "object_1"]);
}

#[test]
fn obj_polygons_are_fan_triangulated_and_degenerate_faces_ignored() {
    let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv -1 1 0\n\
                f 1 2 3 4 5\nf 1 2\nf 3\nl 1 2 3\np 1\n";
    let s = load_obj_text(text).unwrap();
    assert_eq!(tri_counts(&s), [3]);
    let t = world_triangles(&s, 0);
    assert_eq!(t[2], [Vec3::ZERO, Vec3::new(0.0, 1.0, 0.0), Vec3::new(-1.0, 1.0, 0.0)]);
}

#[test]
fn obj_crlf_comments_and_non_utf8_names() {
    let mut bytes =
        b"# \xff\xfe comment\r\nv 0 0 0 # trailing\r\nv 1 0 0\r\nv 0 1 0\r\no caf\xe9\r\nf 1 2 3\r\n".to_vec();
    bytes.extend_from_slice(b"\t\n");
    let s = obj::parse(&bytes, Path::new("x.obj")).unwrap();
    assert_eq!(names(&s), ["caf\u{fffd}"]);
}

// ---------------------------------------------------------------- OBJ errors

fn malformed_line(err: &LoadError) -> Option<usize> {
    match err {
        LoadError::Malformed { line, .. } => *line,
        _ => None,
    }
}

#[test]
fn obj_nan_vertex_is_an_error_naming_the_line() {
    for bad in ["nan", "NaN", "inf", "-infinity", "1e39"] {
        let text = format!("v 0 0 0\nv 1 {bad} 0\nv 0 1 0\nf 1 2 3\n");
        let err = load_obj_text(&text).unwrap_err();
        assert_eq!(malformed_line(&err), Some(2), "{err}");
        let msg = err.to_string();
        assert!(msg.contains("test.obj:2:") && msg.contains("non-finite"), "{msg}");
    }
    let err = load_obj_text("v 1 2 3 0\n").unwrap_err();
    assert_eq!(malformed_line(&err), Some(1), "{err}");
}

#[test]
fn obj_index_out_of_range_is_an_error_naming_the_line() {
    let cases = [
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", 4),
        // Only vertices declared *before* the face count.
        ("v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\n", 3),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf -1 -2 -4\n", 5),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", 4),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999999\n", 4),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -9223372036854775808\n", 4),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4294967297\n", 4),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/1 3/1\n", 4),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//2 2//1 3//1\n", 5),
    ];
    for (text, line) in cases {
        let err = load_obj_text(text).unwrap_err();
        assert_eq!(malformed_line(&err), Some(line), "{text:?}: {err}");
    }
    let err = load_obj_text(cases[0].0).unwrap_err().to_string();
    assert!(err.contains("vertex 4") && err.contains("only 3"), "{err}");
}

#[test]
fn obj_malformed_numbers_are_errors_naming_the_line() {
    let cases = [
        ("v 0 0 zero\n", 1),
        ("v 0 0\n", 1),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n", 4),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3/4/5/6\n", 4),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf\n", 4),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf /1 2 3\n", 4),
        ("v 0 0 0 1 2 3 4 5\n", 1),
    ];
    for (text, line) in cases {
        let err = load_obj_text(text).unwrap_err();
        assert_eq!(malformed_line(&err), Some(line), "{text:?}: {err}");
    }
}

#[test]
fn obj_empty_inputs_are_errors() {
    for text in ["", "\n\n", "# only a comment\n", "v 0 0 0\nv 1 0 0\n", "o a\ng b\n"] {
        let err = load_obj_text(text).unwrap_err();
        assert!(
            matches!(
                err,
                LoadError::Scene {
                    source: SceneError::EmptyScene { .. },
                    ..
                }
            ),
            "{text:?}: {err}"
        );
    }
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "empty.obj", b"");
    let err = hom_scene::load(&p).unwrap_err();
    assert!(err.to_string().contains("empty.obj"), "{err}");
    let err = hom_scene::load(&dir.path().join("missing.obj")).unwrap_err();
    assert!(matches!(err, LoadError::Io { .. }), "{err}");
}

#[test]
fn obj_garbage_bytes_are_errors() {
    let mut rng = Rng::new(0x1234_5678_9abc_def0);
    let garbage: Vec<u8> = (0..4096).map(|_| (rng.next_u64() >> 24) as u8).collect();
    assert!(obj::parse(&garbage, Path::new("g.obj")).is_err());
    let no_nul: Vec<u8> = garbage.iter().map(|&b| b.max(1)).collect();
    assert!(obj::parse(&no_nul, Path::new("g.obj")).is_err());
    assert!(obj::parse(b"\xff\xfe\xfd\n\x00\x01", Path::new("g.obj")).is_err());
    assert!(obj::parse(b"v \xff 0 0\n", Path::new("g.obj")).is_err());
}

const NASTY: &[&[u8]] = &[
    b"-99999999999999999999",
    b"9223372036854775807",
    b"-9223372036854775808",
    b"4294967295",
    b"nan",
    b"1e40",
    b"0",
    b"-1",
    b"\xff\xfe",
    b"/",
    b"//",
    b" ",
    b"\n",
    b"\r",
    b"\0",
    b"f",
    b"v",
    b"#",
    b"o",
    b"g",
    b"usemtl x\n",
    b"f 1 2 3 4 5 6 7\n",
];

fn mutate(base: &[u8], ops: &[(u8, usize, u8)]) -> Vec<u8> {
    let mut bytes = base.to_vec();
    for &(kind, pos, byte) in ops {
        let at = if bytes.is_empty() { 0 } else { pos % (bytes.len() + 1) };
        match kind % 4 {
            0 if at < bytes.len() => bytes[at] = byte,
            1 => bytes.insert(at, byte),
            2 if at < bytes.len() => {
                bytes.remove(at);
            }
            _ => {
                let token = NASTY[byte as usize % NASTY.len()];
                bytes.splice(at..at, token.iter().copied());
            }
        }
    }
    bytes
}

proptest! {
    // 10,000 mutated OBJ files (issue 5: hostile files); small inputs, well under a second.
    #![proptest_config(ProptestConfig::with_cases(10_000))]

    #[test]
    fn obj_random_mutations_never_panic(
        ops in prop::collection::vec((any::<u8>(), any::<usize>(), any::<u8>()), 1..12)
    ) {
        let bytes = mutate(VALID_OBJ.as_bytes(), &ops);
        if let Ok(scene) = obj::parse(&bytes, Path::new("m.obj")) {
            prop_assert!(!scene.objects().is_empty());
            for o in scene.objects() {
                prop_assert!(scene.mesh_of(o).positions().iter().all(|p| p.is_finite()));
            }
        }
    }
}

// ---------------------------------------------------------------- glTF

/// Four vertices of a unit quad in the XY plane, then six u16 indices.
fn quad_buffer() -> Vec<u8> {
    let mut b = Vec::new();
    for v in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]] {
        for c in v {
            b.extend_from_slice(&c.to_le_bytes());
        }
    }
    for i in [0u16, 1, 2, 0, 2, 3] {
        b.extend_from_slice(&i.to_le_bytes());
    }
    b
}

/// A document with a parent node (translated) whose two children instance one quad mesh,
/// plus a node whose mesh has only a POINTS primitive. `uri` = None for GLB.
fn quad_document(uri: Option<String>, buffer_len: usize) -> serde_json::Value {
    let mut buffer = json!({ "byteLength": buffer_len });
    if let Some(uri) = uri {
        buffer["uri"] = json!(uri);
    }
    json!({
        "asset": { "version": "2.0" },
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [
            { "name": "root", "translation": [10.0, 0.0, 0.0], "children": [1, 2, 3] },
            { "name": "left", "mesh": 0, "translation": [0.0, 0.0, -5.0] },
            { "mesh": 0, "scale": [2.0, 2.0, 2.0] },
            { "name": "points", "mesh": 1 }
        ],
        "meshes": [
            { "name": "quad", "primitives": [{ "attributes": { "POSITION": 0 }, "indices": 1 }] },
            { "name": "dots", "primitives": [{ "attributes": { "POSITION": 0 }, "mode": 0 }] }
        ],
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
              "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0] },
            { "bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR" }
        ],
        "bufferViews": [
            { "buffer": 0, "byteOffset": 0, "byteLength": 48, "target": 34962 },
            { "buffer": 0, "byteOffset": 48, "byteLength": 12, "target": 34963 }
        ],
        "buffers": [buffer]
    })
}

fn data_uri(bytes: &[u8]) -> String {
    format!("data:application/octet-stream;base64,{}", base64(bytes))
}

fn glb(doc: &serde_json::Value, bin: &[u8]) -> Vec<u8> {
    let mut json = serde_json::to_vec(doc).unwrap();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let mut bin = bin.to_vec();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

fn check_quad_scene(s: &Scene, name: &str) {
    assert_eq!(s.name(), name);
    assert_eq!(names(s), ["left", "quad"]);
    assert_eq!(tri_counts(s), [2, 2]);
    assert_eq!(s.meshes().len(), 1, "both nodes share one mesh");
    assert_eq!(s.object(0).mesh, s.object(1).mesh);
    let expect = |p: Vec3, q: Vec3| assert!((p - q).abs().max_element() < 1e-5, "{p} vs {q}");
    let left = world_triangles(s, 0);
    expect(left[0][1], Vec3::new(11.0, 0.0, -5.0));
    expect(left[1][2], Vec3::new(10.0, 1.0, -5.0));
    let scaled = world_triangles(s, 1);
    expect(scaled[0][2], Vec3::new(12.0, 2.0, 0.0));
    expect(scaled[1][2], Vec3::new(10.0, 2.0, 0.0));
}

fn load_gltf_doc(dir: &Path, name: &str, doc: &serde_json::Value) -> Result<Scene, LoadError> {
    let p = write(dir, name, &serde_json::to_vec_pretty(doc).unwrap());
    hom_scene::load(&p)
}

#[test]
fn gltf_data_uri_instances_share_mesh_with_world_transforms() {
    let dir = tempfile::tempdir().unwrap();
    let buf = quad_buffer();
    let doc = quad_document(Some(data_uri(&buf)), buf.len());
    let s = load_gltf_doc(dir.path(), "quads.gltf", &doc).unwrap();
    check_quad_scene(&s, "quads");
}

#[test]
fn gltf_external_bin_buffer() {
    let dir = tempfile::tempdir().unwrap();
    let buf = quad_buffer();
    write(dir.path(), "quads.bin", &buf);
    let doc = quad_document(Some("quads.bin".into()), buf.len());
    let p = write(dir.path(), "ext.gltf", &serde_json::to_vec(&doc).unwrap());
    check_quad_scene(&gltf::load(&p).unwrap(), "ext");
    // The .bin missing: a typed error, no panic.
    std::fs::remove_file(dir.path().join("quads.bin")).unwrap();
    let err = gltf::load(&p).unwrap_err();
    assert!(matches!(err, LoadError::Malformed { .. }), "{err}");
}

#[test]
fn glb_loads_like_gltf() {
    let dir = tempfile::tempdir().unwrap();
    let buf = quad_buffer();
    let bytes = glb(&quad_document(None, buf.len()), &buf);
    let p = write(dir.path(), "quads.glb", &bytes);
    check_quad_scene(&hom_scene::load(&p).unwrap(), "quads");
}

#[test]
fn gltf_without_default_scene_walks_all_scenes_and_names_fall_back() {
    let dir = tempfile::tempdir().unwrap();
    let buf = quad_buffer();
    let mut doc = quad_document(Some(data_uri(&buf)), buf.len());
    doc.as_object_mut().unwrap().remove("scene");
    doc["scenes"] = json!([{ "nodes": [0] }, { "nodes": [4] }]);
    doc["nodes"].as_array_mut().unwrap().push(json!({ "mesh": 0 }));
    doc["meshes"][0].as_object_mut().unwrap().remove("name");
    let s = load_gltf_doc(dir.path(), "all.gltf", &doc).unwrap();
    assert_eq!(names(&s), ["left", "node 2", "node 4"]);
    assert_eq!(s.meshes().len(), 1);
    // No scenes at all: every root node is walked.
    doc.as_object_mut().unwrap().remove("scenes");
    let s = load_gltf_doc(dir.path(), "none.gltf", &doc).unwrap();
    assert_eq!(names(&s), ["left", "node 2", "node 4"]);
}

#[test]
fn gltf_bad_indices_and_ranges_are_typed_errors() {
    let dir = tempfile::tempdir().unwrap();
    let buf = quad_buffer();
    let good = || quad_document(Some(data_uri(&buf)), buf.len());

    // An index value beyond the vertices.
    let mut bad = buf.clone();
    bad[48 + 4..48 + 6].copy_from_slice(&7u16.to_le_bytes());
    let doc = quad_document(Some(data_uri(&bad)), bad.len());
    let err = load_gltf_doc(dir.path(), "idx.gltf", &doc).unwrap_err();
    assert!(matches!(err, LoadError::Malformed { .. }), "{err}");
    assert!(err.to_string().contains("index"), "{err}");

    let mut cases: Vec<(&str, serde_json::Value)> = Vec::new();
    let mut d = good();
    d["accessors"][0]["count"] = json!(5);
    cases.push(("count past view", d));
    let mut d = good();
    d["accessors"][0]["count"] = json!(u64::MAX / 2);
    cases.push(("huge count", d));
    let mut d = good();
    d["accessors"][0]["count"] = json!(0);
    cases.push(("zero count", d));
    let mut d = good();
    d["accessors"][1]["byteOffset"] = json!(u64::MAX / 2);
    cases.push(("huge offset", d));
    let mut d = good();
    d["bufferViews"][0]["byteLength"] = json!(u64::MAX - 8);
    cases.push(("huge view", d));
    let mut d = good();
    d["bufferViews"][1]["byteOffset"] = json!(100);
    cases.push(("view past buffer", d));
    let mut d = good();
    d["buffers"][0]["byteLength"] = json!(1000);
    cases.push(("buffer shorter than declared", d));
    let mut d = good();
    d["accessors"][1]["bufferView"] = json!(9);
    cases.push(("missing view", d));
    // Regression (found by glb_random_mutations_never_panic): gltf-json's validator
    // panicked on a POSITION accessor index past the end of `accessors`.
    let mut d = good();
    d["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(7);
    cases.push(("POSITION accessor missing", d));
    let mut d = good();
    d["accessors"][0]["componentType"] = json!(5123);
    cases.push(("positions not float", d));
    let mut d = good();
    d["nodes"][1]["children"] = json!([0]);
    cases.push(("cycle", d));
    let mut d = good();
    d["nodes"][1]["children"] = json!([2]);
    cases.push(("two parents", d));
    let mut d = good();
    d["accessors"][0].as_object_mut().unwrap().remove("bufferView");
    d["accessors"][0]["count"] = json!(1u64 << 40);
    d["accessors"][0]["sparse"] = json!({
        "count": 1,
        "indices": { "bufferView": 1, "componentType": 5123 },
        "values": { "bufferView": 0 }
    });
    cases.push(("sparse huge count", d));
    for (what, doc) in cases {
        let err = load_gltf_doc(dir.path(), "bad.gltf", &doc).unwrap_err();
        assert!(matches!(err, LoadError::Malformed { .. }), "{what}: {err}");
        assert!(err.to_string().contains("bad.gltf"), "{what}: {err}");
    }

    // Degenerate transform and NaN position: the scene validation, wrapped.
    let mut d = good();
    d["nodes"][2]["scale"] = json!([0.0, 1.0, 1.0]);
    let err = load_gltf_doc(dir.path(), "t.gltf", &d).unwrap_err();
    assert!(
        matches!(
            err,
            LoadError::Scene {
                source: SceneError::BadTransform { .. },
                ..
            }
        ),
        "{err}"
    );
    let mut nan = buf.clone();
    nan[4..8].copy_from_slice(&f32::NAN.to_le_bytes());
    let doc = quad_document(Some(data_uri(&nan)), nan.len());
    let err = load_gltf_doc(dir.path(), "n.gltf", &doc).unwrap_err();
    assert!(
        matches!(
            err,
            LoadError::Scene {
                source: SceneError::NonFiniteVertex { .. },
                ..
            }
        ),
        "{err}"
    );

    // Nothing with triangles: empty.
    let mut d = good();
    d["scenes"][0]["nodes"] = json!([3]);
    let err = load_gltf_doc(dir.path(), "e.gltf", &d).unwrap_err();
    assert!(
        matches!(
            err,
            LoadError::Scene {
                source: SceneError::EmptyScene { .. },
                ..
            }
        ),
        "{err}"
    );

    // Not JSON at all.
    let p = write(dir.path(), "junk.gltf", b"{\"asset\": ");
    assert!(matches!(gltf::load(&p), Err(LoadError::Malformed { .. })));
}

/// A relative buffer URI whose percent-escapes decode to no UTF-8 text (which
/// gltf 1.4 unwraps: found by the mutation test) is a typed error naming the
/// buffer; a well-formed escape still names the file.
#[test]
fn gltf_buffer_uri_escapes_that_are_not_text_are_typed_errors() {
    let dir = tempfile::tempdir().unwrap();
    let buf = quad_buffer();
    let doc = quad_document(Some("quad%e6.bin".to_owned()), buf.len());
    let err = load_gltf_doc(dir.path(), "bad_uri.gltf", &doc).unwrap_err();
    assert!(matches!(err, LoadError::Malformed { .. }), "{err}");
    assert!(err.to_string().contains("buffers[0]"), "{err}");

    write(dir.path(), "quad one.bin", &buf);
    let doc = quad_document(Some("quad%20one.bin".to_owned()), buf.len());
    let scene = load_gltf_doc(dir.path(), "good_uri.gltf", &doc).unwrap();
    let inline = load_gltf_doc(
        dir.path(),
        "inline.gltf",
        &quad_document(Some(data_uri(&buf)), buf.len()),
    )
    .unwrap();
    assert!(scene.triangle_count() > 0);
    assert_eq!(scene.triangle_count(), inline.triangle_count());
}

#[test]
fn gltf_sparse_accessor_substitutes_values() {
    let dir = tempfile::tempdir().unwrap();
    let mut buf = quad_buffer();
    // Sparse: vertex 2 moves to (5, 5, 0). Indices (u16 + pad) at 60, value at 64.
    buf.extend_from_slice(&2u16.to_le_bytes());
    buf.extend_from_slice(&[0, 0]);
    for c in [5.0f32, 5.0, 0.0] {
        buf.extend_from_slice(&c.to_le_bytes());
    }
    let mut d = quad_document(Some(data_uri(&buf)), buf.len());
    d["bufferViews"]
        .as_array_mut()
        .unwrap()
        .push(json!({ "buffer": 0, "byteOffset": 60, "byteLength": 2 }));
    d["bufferViews"]
        .as_array_mut()
        .unwrap()
        .push(json!({ "buffer": 0, "byteOffset": 64, "byteLength": 12 }));
    d["accessors"][0]["sparse"] = json!({
        "count": 1,
        "indices": { "bufferView": 2, "componentType": 5123 },
        "values": { "bufferView": 3 }
    });
    let s = load_gltf_doc(dir.path(), "sparse.gltf", &d).unwrap();
    assert_eq!(s.mesh_of(s.object(0)).positions()[2], Vec3::new(5.0, 5.0, 0.0));
}

#[test]
fn glb_truncated_or_corrupt_never_panics() {
    let dir = tempfile::tempdir().unwrap();
    let buf = quad_buffer();
    let bytes = glb(&quad_document(None, buf.len()), &buf);
    let p = dir.path().join("t.glb");
    for len in 0..bytes.len() {
        std::fs::write(&p, &bytes[..len]).unwrap();
        let err = gltf::load(&p).unwrap_err();
        assert!(matches!(err, LoadError::Malformed { .. }), "len {len}: {err}");
    }
    // Header lengths shorter than the header, and absurdly long.
    for declared in [0u32, 4, 11, 12, 19, u32::MAX] {
        let mut b = bytes.clone();
        b[8..12].copy_from_slice(&declared.to_le_bytes());
        std::fs::write(&p, &b).unwrap();
        assert!(gltf::load(&p).is_err(), "declared {declared}");
    }
    // Chunk lengths past the end.
    let mut b = bytes.clone();
    b[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
    std::fs::write(&p, &b).unwrap();
    assert!(gltf::load(&p).is_err());
}

/// One scratch folder for the mutation tests (10,000 files each, written in turn).
fn scratch() -> &'static Path {
    static DIR: std::sync::OnceLock<tempfile::TempDir> = std::sync::OnceLock::new();
    DIR.get_or_init(|| tempfile::tempdir().unwrap()).path()
}

proptest! {
    // 10,000 mutated glb files and 10,000 mutated glTF JSON files (issue 5: hostile files).
    #![proptest_config(ProptestConfig::with_cases(10_000))]

    #[test]
    fn glb_random_mutations_never_panic(
        ops in prop::collection::vec((any::<u8>(), any::<usize>(), any::<u8>()), 1..8)
    ) {
        let buf = quad_buffer();
        let bytes = mutate(&glb(&quad_document(None, buf.len()), &buf), &ops);
        let p = write(scratch(), &format!("m{}.glb", std::process::id()), &bytes);
        if let Ok(scene) = gltf::load(&p) {
            for o in scene.objects() {
                prop_assert!(scene.mesh_of(o).positions().iter().all(|p| p.is_finite()));
            }
        }
    }

    #[test]
    fn gltf_json_random_mutations_never_panic(
        ops in prop::collection::vec((any::<u8>(), any::<usize>(), any::<u8>()), 1..8)
    ) {
        let buf = quad_buffer();
        let doc = quad_document(Some(data_uri(&buf)), buf.len());
        let bytes = mutate(serde_json::to_string(&doc).unwrap().as_bytes(), &ops);
        let p = write(scratch(), &format!("m{}.gltf", std::process::id()), &bytes);
        if let Ok(scene) = gltf::load(&p) {
            for o in scene.objects() {
                prop_assert!(scene.mesh_of(o).positions().iter().all(|p| p.is_finite()));
            }
        }
    }
}

// ---------------------------------------------------------------- splitting one big mesh

#[test]
fn a_single_big_obj_object_is_split_unless_turned_off() {
    let text = grid_obj(40); // 3200 triangles, 40 m across
    let scene = load_obj_text(&text).unwrap();
    assert_eq!(scene.triangle_count(), 3200);
    assert!(scene.objects().len() >= 7, "{}", scene.objects().len());
    assert!(scene.objects().iter().all(|o| o.triangles <= 512));
    // Centroids within 16 m, so boxes within 17 m for unit quads.
    assert!(scene.objects().iter().all(|o| o.aabb.extent().max_element() <= 17.0));
    assert_eq!(names(&scene)[0], "ground_0");
    // Same file, same objects.
    let again = load_obj_text(&text).unwrap();
    assert_eq!(tri_counts(&scene), tri_counts(&again));

    let off = obj::ObjOptions {
        split: hom_scene::split::SplitOptions {
            enabled: false,
            ..Default::default()
        },
    };
    let whole = obj::parse_with(text.as_bytes(), Path::new("test.obj"), &off).unwrap();
    assert_eq!(names(&whole), vec!["ground"]);
    // A file with objects of its own keeps them, but one that spans the level
    // (40 m, over `whole_extent`) is cut in its place, the same way.
    let other = "o other\nv 0 1 0\nv 1 1 0\nv 0 1 1\nf -1 -2 -3\n";
    let two = load_obj_text(&format!("{text}{other}")).unwrap();
    assert_eq!(two.objects().len(), scene.objects().len() + 1);
    assert_eq!(&tri_counts(&two)[..scene.objects().len()], &tri_counts(&scene)[..]);
    assert_eq!(names(&two)[0], "ground_0");
    assert_eq!(names(&two).last(), Some(&"other"));
    // A 10 m ground of 200 triangles is a house's size: whole.
    let small = load_obj_text(&format!("{}{other}", grid_obj(10))).unwrap();
    assert_eq!(names(&small), vec!["ground", "other"]);
    let whole = obj::parse_with(format!("{text}{other}").as_bytes(), Path::new("test.obj"), &off).unwrap();
    assert_eq!(names(&whole), vec!["ground", "other"]);
    // The cut ground's clusters keep its id (parent 0), "other" keeps 1.
    hom_testkit::assert_clusters_of_whole_objects(&two, &whole);
    assert_eq!(two.object(two.objects().len() as u32 - 1).parent(), 1);
    let unnamed = format!("{text}o\nv 0 1 0\nv 1 1 0\nv 0 1 1\nf -1 -2 -3\n");
    let (cut, whole) = (
        load_obj_text(&unnamed).unwrap(),
        obj::parse_with(unnamed.as_bytes(), Path::new("u.obj"), &off).unwrap(),
    );
    hom_testkit::assert_clusters_of_whole_objects(&cut, &whole);
    assert_eq!(
        cut.parent_name(1),
        Some("object_1"),
        "an unnamed object is named by its id, not its clusters'"
    );
}

/// A glTF strip of `n` unit quads along +X (one mesh, "strip") instanced by
/// two nodes: "long" as is (n m) and "short" scaled by `short_scale`.
fn strip_document(n: usize, short_scale: f32) -> serde_json::Value {
    let mut b = Vec::new();
    for i in 0..=n {
        for y in [0.0f32, 1.0] {
            for c in [i as f32, y, 0.0] {
                b.extend_from_slice(&c.to_le_bytes());
            }
        }
    }
    let vertex_bytes = b.len();
    for i in 0..n as u32 {
        let a = 2 * i;
        for k in [a, a + 2, a + 3, a, a + 3, a + 1] {
            b.extend_from_slice(&k.to_le_bytes());
        }
    }
    json!({
        "asset": { "version": "2.0" },
        "scene": 0,
        "scenes": [{ "nodes": [0, 1] }],
        "nodes": [
            { "name": "long", "mesh": 0 },
            { "name": "short", "mesh": 0, "scale": [short_scale, short_scale, short_scale], "translation": [0.0, 5.0, 0.0] }
        ],
        "meshes": [{ "name": "strip", "primitives": [{ "attributes": { "POSITION": 0 }, "indices": 1 }] }],
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": 2 * (n + 1), "type": "VEC3",
              "min": [0.0, 0.0, 0.0], "max": [n as f32, 1.0, 0.0] },
            { "bufferView": 1, "componentType": 5125, "count": 6 * n, "type": "SCALAR" }
        ],
        "bufferViews": [
            { "buffer": 0, "byteOffset": 0, "byteLength": vertex_bytes },
            { "buffer": 0, "byteOffset": vertex_bytes, "byteLength": b.len() - vertex_bytes }
        ],
        "buffers": [{ "byteLength": b.len(), "uri": data_uri(&b) }]
    })
}

/// Every world-space triangle of a scene, as sorted bit patterns (for set equality).
fn all_world_triangles(scene: &Scene) -> Vec<[[u32; 3]; 3]> {
    let mut all: Vec<[[u32; 3]; 3]> = (0..scene.objects().len() as u32)
        .flat_map(|id| world_triangles(scene, id))
        .map(|t| bits(&t))
        .collect();
    all.sort_unstable();
    all
}

#[test]
fn a_gltf_mesh_that_spans_the_level_is_cut_per_node() {
    let dir = tempfile::tempdir().unwrap();
    let doc = strip_document(40, 0.25);
    let cut = load_gltf_doc(dir.path(), "strip.gltf", &doc).unwrap();
    // "long" is 40 m: its clusters, 3 m each; "short" is 10 m: whole, last.
    let n = cut.objects().len();
    assert!(n >= 14, "{n} objects");
    assert_eq!(names(&cut)[0], "long_0");
    assert_eq!(names(&cut)[n - 1], "short");
    assert!(cut.objects()[..n - 1]
        .iter()
        .all(|o| o.aabb.extent().max_element() <= 4.0));
    assert_eq!(cut.object(n as u32 - 1).triangles, 80);
    // The same triangles in the world, cut or not.
    let off = hom_scene::gltf::GltfOptions {
        split: hom_scene::split::SplitOptions {
            enabled: false,
            ..Default::default()
        },
    };
    let whole = hom_scene::gltf::load_with(&dir.path().join("strip.gltf"), &off).unwrap();
    assert_eq!(names(&whole), vec!["long", "short"]);
    assert_eq!(all_world_triangles(&cut), all_world_triangles(&whole));
    hom_testkit::assert_clusters_of_whole_objects(&cut, &whole);
    // Scaled up 4×, "short" spans too: it shares the cut "long" made (pieces of
    // 3 m in the mesh's space, so 12 m of centroids in its world) and names them.
    let both = load_gltf_doc(dir.path(), "both.gltf", &strip_document(40, 4.0)).unwrap();
    let shorts: Vec<_> = both.objects().iter().filter(|o| o.name.starts_with("short_")).collect();
    assert_eq!(shorts.len(), n - 1);
    assert_eq!(both.objects().len(), 2 * (n - 1));
    assert!(shorts.iter().all(|o| o.aabb.extent().max_element() <= 4.0 * 4.0 + 0.01));
    let both_whole = hom_scene::gltf::load_with(&dir.path().join("both.gltf"), &off).unwrap();
    hom_testkit::assert_clusters_of_whole_objects(&both, &both_whole);
    assert_eq!(both.meshes().len(), n - 1, "the two nodes share the pieces' meshes");
}
