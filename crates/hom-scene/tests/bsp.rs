//! Quake 3 BSP loader tests on maps built here, byte by byte: what a tiny valid map
//! loads to, a typed error for each malformed field, and no panic on thousands of
//! mutated maps and pk3 archives.

use glam::Vec3;
use hom_scene::bsp::{self, BspError, BspOptions, INCH};
use hom_scene::LoadError;
use proptest::prelude::*;
use std::io::{Cursor, Write};

// ---------------------------------------------------------------- a tiny map

/// The lumps of a map, before the header is written.
#[derive(Clone)]
struct Map {
    lumps: Vec<Vec<u8>>,
}

fn i32s(v: &[i32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

fn f32s(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

fn texture(name: &str, flags: i32, contents: i32) -> Vec<u8> {
    let mut r = vec![0u8; 64];
    r[..name.len()].copy_from_slice(name.as_bytes());
    r.extend(i32s(&[flags, contents]));
    r
}

fn vertex(p: [f32; 3]) -> Vec<u8> {
    let mut r = f32s(&p);
    r.extend(vec![0u8; 44 - 12]);
    r
}

/// A face record: texture, type, vertex range, meshvert range, patch size.
fn face(texture: i32, kind: i32, vertex: [i32; 2], meshvert: [i32; 2], size: [i32; 2]) -> Vec<u8> {
    let mut r = i32s(&[texture, -1, kind, vertex[0], vertex[1], meshvert[0], meshvert[1]]);
    r.extend(vec![0u8; 96 - r.len()]);
    r.extend(i32s(&size));
    assert_eq!(r.len(), 104);
    r
}

fn leaf(cluster: i32, leafface: [i32; 2]) -> Vec<u8> {
    let mut r = i32s(&[cluster, 0, 0, 0, 0, 0, 0, 0, leafface[0], leafface[1], 0, 0]);
    r.truncate(48);
    r
}

const ENTITIES: &str = "{\n\"classname\" \"worldspawn\"\n}\n\
{\n\"classname\" \"info_player_deathmatch\"\n\"origin\" \"100 -200 24\"\n\"angle\" \"90\"\n}\n\
{\n\"classname\" \"light\"\n\"origin\" \"0 0 0\"\n}\n\
{\n\"classname\" \"team_CTF_redspawn\"\n\"origin\" \"-300 0 24\"\n}\n";

impl Map {
    /// One polygon face (2 triangles), one mesh face (1), one 3 × 3 patch, a sky
    /// face, a glass face (1), a billboard, and a face of model 1; two clusters (0
    /// sees only itself, 1 sees both) split by the plane x = 0, and a solid leaf above z = 1000.
    fn tiny() -> Map {
        let mut lumps = vec![Vec::new(); 17];
        lumps[0] = ENTITIES.as_bytes().to_vec();
        lumps[0].push(0);
        lumps[1] = [
            texture("textures/base/wall", 0, 1),
            texture("textures/skies/blue", 0x4 | 0x80, 1),
            texture("textures/base/glass", 0, 0x2000_0000),
            texture("textures/common/caulk", 0, 1),
        ]
        .concat();
        lumps[2] = f32s(&[1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1000.0]);
        // node 0: x >= 0 → leaf 0, else node 1; node 1: z >= 1000 → leaf 2 (solid), else leaf 1.
        let mut nodes = i32s(&[0, -1, 1, 0, 0, 0, 0, 0, 0]);
        nodes.extend(i32s(&[1, -3, -2, 0, 0, 0, 0, 0, 0]));
        lumps[3] = nodes;
        lumps[4] = [leaf(0, [0, 2]), leaf(1, [2, 3]), leaf(-1, [5, 0])].concat();
        lumps[5] = i32s(&[0, 1, 2, 4, 3]);
        let mut models = f32s(&[0.0; 6]);
        models.extend(i32s(&[0, 6, 0, 0]));
        models.extend(f32s(&[0.0; 6]));
        models.extend(i32s(&[6, 1, 0, 0]));
        lumps[7] = models;
        let mut v = Vec::new();
        // 0..4: polygon quad at x 10..50 (Quake), z = 0.
        for p in [[10.0, 0.0, 0.0], [50.0, 0.0, 0.0], [50.0, 40.0, 0.0], [10.0, 40.0, 0.0]] {
            v.push(vertex(p));
        }
        // 4..7: mesh triangle.
        for p in [[20.0, 0.0, 10.0], [30.0, 0.0, 10.0], [20.0, 10.0, 20.0]] {
            v.push(vertex(p));
        }
        // 7..16: 3 × 3 patch at x -100..0.
        for r in 0..3 {
            for c in 0..3 {
                v.push(vertex([-100.0 + 50.0 * c as f32, 50.0 * r as f32, 8.0]));
            }
        }
        // 16..19: glass triangle.
        for p in [[-50.0, 0.0, 0.0], [-40.0, 0.0, 0.0], [-50.0, 10.0, 0.0]] {
            v.push(vertex(p));
        }
        lumps[10] = v.concat();
        lumps[11] = i32s(&[0, 1, 2, 0, 2, 3, 0, 1, 2]);
        lumps[13] = [
            face(0, 1, [0, 4], [0, 6], [0, 0]),
            face(0, 3, [4, 3], [6, 3], [0, 0]),
            face(0, 2, [7, 9], [0, 0], [3, 3]),
            face(1, 1, [0, 4], [0, 6], [0, 0]),
            face(2, 1, [16, 3], [6, 3], [0, 0]),
            face(0, 4, [0, 1], [0, 0], [0, 0]),
            face(0, 1, [0, 4], [0, 6], [0, 0]),
        ]
        .concat();
        let mut vis = i32s(&[2, 1]);
        vis.extend([0b01, 0b11]);
        lumps[16] = vis;
        Map { lumps }
    }

    fn bytes(&self) -> Vec<u8> {
        let mut out = b"IBSP".to_vec();
        out.extend(46i32.to_le_bytes());
        let mut body = Vec::new();
        for l in &self.lumps {
            // Pad before each lump, so the last one ends the file.
            while body.len() % 4 != 0 {
                body.push(0);
            }
            let offset = 8 + 17 * 8 + body.len();
            out.extend(i32s(&[offset as i32, l.len() as i32]));
            body.extend(l);
        }
        out.extend(body);
        out
    }

    /// Overwrites an i32 at `at` in lump `lump`.
    fn set(&mut self, lump: usize, at: usize, value: i32) -> &mut Map {
        self.lumps[lump][at..at + 4].copy_from_slice(&value.to_le_bytes());
        self
    }
}

/// An error and its causes, as `{:#}` prints them (messages omit their source).
fn chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        s.push_str(&format!(": {c}"));
        cause = c.source();
    }
    s
}

fn parse(bytes: &[u8]) -> Result<bsp::BspMap, BspError> {
    bsp::parse(bytes, "tiny", &BspOptions::default())
}

fn tiny() -> bsp::BspMap {
    parse(&Map::tiny().bytes()).unwrap()
}

// ---------------------------------------------------------------- what it loads

#[test]
fn tiny_map_geometry_flags_and_units() {
    let m = tiny();
    let s = &m.scene;
    // Opaque: 2 (polygon) + 1 (mesh) + 2 × 5² (patch); glass: 1; sky, billboard, model 1: none.
    assert_eq!(s.objects().len(), 2);
    assert_eq!(s.object(0).triangles, 2 + 1 + 50);
    assert!(s.object(0).occluder);
    assert_eq!(s.object(1).triangles, 1);
    assert!(!s.object(1).occluder, "glass must never be an occluder");
    assert_eq!(s.object(0).name, "world_0");
    assert_eq!(s.object(1).name, "see_through_1");
    // (x, y, z) inches → (x, z, −y) metres.
    let world = s.mesh_of(s.object(0)).positions();
    for q in [[10.0, 0.0, 0.0], [50.0, 40.0, 0.0], [20.0, 10.0, 20.0]] {
        let want = Vec3::new(q[0], q[2], -q[1]) * INCH;
        assert!(world.iter().any(|p| (*p - want).length() < 1e-6), "{want} missing");
    }
    // The flat patch: corners kept, tessellated points on its plane (Quake z = 8).
    let patch_y = 8.0 * INCH;
    assert_eq!(world.iter().filter(|p| (p.y - patch_y).abs() < 1e-6).count(), 36);
    assert!(world
        .iter()
        .any(|p| (*p - Vec3::new(-100.0, 8.0, -100.0) * INCH).length() < 1e-5));
    let glass = s.mesh_of(s.object(1)).positions();
    assert!(glass.iter().all(|p| p.x < 0.0 && p.y.abs() < 1e-6));
    // Pieces of one face are never split; clusters follow the leaves.
    assert_eq!(m.object_clusters, vec![vec![0, 1], vec![1]]);
}

/// Cut finer than its faces, the tiny map's world is several clusters of one
/// parent, `world_0`, and its glass keeps parent 1: the ids it has whole.
#[test]
fn a_maps_clusters_keep_the_ids_it_has_whole() {
    let bytes = Map::tiny().bytes();
    let with = |split| {
        bsp::parse(
            &bytes,
            "tiny",
            &BspOptions {
                split,
                ..BspOptions::default()
            },
        )
        .unwrap()
    };
    let fine = with(hom_scene::split::SplitOptions {
        max_triangles: 2,
        ..Default::default()
    });
    let whole = with(hom_scene::split::SplitOptions {
        enabled: false,
        ..Default::default()
    });
    assert!(fine.scene.objects().len() > 2, "{}", fine.scene.objects().len());
    hom_testkit::assert_clusters_of_whole_objects(&fine.scene, &whole.scene);
    let names: Vec<&str> = (0..2).filter_map(|p| fine.scene.parent_name(p)).collect();
    assert_eq!(names, vec!["world_0", "see_through_1"]);
}

/// A sky face (`SURF_SKY`, not nodraw) is an opaque wall in an object of its
/// own after the others, as the player sees it; with `SkyFaces::Open` it is
/// not drawn. A sky shader that is also nodraw is never drawn.
#[test]
fn sky_faces_are_opaque_walls_unless_open() {
    let mut map = Map::tiny();
    map.set(1, 72 + 64, 0x4); // the sky shader, without its nodraw flag
    let bytes = map.bytes();
    let m = parse(&bytes).unwrap();
    let s = &m.scene;
    assert_eq!(s.objects().len(), 3);
    assert_eq!(s.object(0).triangles, 2 + 1 + 50, "the world's objects keep their ids");
    assert_eq!(s.object(1).name, "see_through_1");
    assert_eq!(s.object(2).name, "sky_2");
    assert_eq!(s.object(2).triangles, 2);
    assert!(s.object(2).occluder, "sky is a wall");
    assert_eq!(m.object_clusters[2], vec![1], "the sky face lies in leaf 1's list");
    let open = BspOptions {
        sky: bsp::SkyFaces::Open,
        ..BspOptions::default()
    };
    let m = bsp::parse(&bytes, "tiny", &open).unwrap();
    assert_eq!(m.scene.objects().len(), 2);
    // The tiny map's own sky shader is nodraw too: never drawn.
    assert_eq!(tiny().scene.objects().len(), 2);
}

#[test]
fn patch_tessellation_level_sets_the_triangle_count() {
    for level in [1u32, 3, 8] {
        // Objects big enough to hold the face and the whole patch together.
        let options = BspOptions {
            tessellation: level,
            split: hom_scene::split::SplitOptions {
                max_triangles: 512,
                ..Default::default()
            },
            ..BspOptions::default()
        };
        let m = bsp::parse(&Map::tiny().bytes(), "t", &options).unwrap();
        assert_eq!(m.scene.object(0).triangles, 3 + 2 * level * level);
    }
    let zero = BspOptions {
        tessellation: 0,
        ..BspOptions::default()
    };
    assert!(matches!(
        bsp::parse(&Map::tiny().bytes(), "t", &zero),
        Err(BspError::BadOptions { .. })
    ));
}

#[test]
fn patch_interpolates_a_curved_grid() {
    // Lift the middle control point: the surface's centre rises by a quarter of it
    // (the quadratic basis weights the middle point by 1/2 × 1/2 at t = 1/2).
    let mut map = Map::tiny();
    let middle = (7 + 4) * 44 + 8;
    map.lumps[10][middle..middle + 4].copy_from_slice(&(8.0f32 + 40.0).to_le_bytes());
    let options = BspOptions {
        tessellation: 2,
        ..BspOptions::default()
    };
    let m = bsp::parse(&map.bytes(), "t", &options).unwrap();
    // The patch's centre, Quake (−50, 50, 18).
    let centre = Vec3::new(-50.0, 18.0, -50.0) * INCH;
    let positions = m.scene.mesh_of(m.scene.object(0)).positions();
    assert!(
        positions.iter().any(|p| (*p - centre).length() < 1e-5),
        "{centre} missing"
    );
    assert!(!positions
        .iter()
        .any(|p| (*p - Vec3::new(-50.0, 8.0, -50.0) * INCH).length() < 1e-5));
}

#[test]
fn clusters_and_visibility() {
    let m = tiny();
    assert_eq!(m.cluster_count(), 2);
    let hom = |q: [f32; 3]| bsp::to_hom(q);
    assert_eq!(m.cluster_of(hom([20.0, 5.0, 5.0])), Some(0));
    assert_eq!(m.cluster_of(hom([-20.0, 5.0, 5.0])), Some(1));
    assert_eq!(m.cluster_of(hom([-20.0, 5.0, 2000.0])), None, "solid leaf");
    // Clear of solid space by 0.1 m (3.9 inches): the boundary between two
    // clustered leaves is no wall, the solid leaf above z = 1000 at x < 0 is.
    assert!(m.is_open(hom([-20.0, 5.0, 5.0]), 0.1));
    assert!(m.is_open(hom([-0.5, 5.0, 5.0]), 0.1));
    assert!(m.is_open(hom([20.0, 5.0, 998.0]), 0.1));
    assert!(!m.is_open(hom([-20.0, 5.0, 998.0]), 0.1));
    assert!(!m.is_open(hom([-20.0, 5.0, 2000.0]), 0.1));
    assert!(!m.is_open(hom([f32::NAN, 5.0, 5.0]), 0.1));
    assert!(m.cluster_visible(0, 0));
    assert!(!m.cluster_visible(0, 1));
    assert!(m.cluster_visible(1, 0) && m.cluster_visible(1, 1));
    assert!(!m.cluster_visible(0, 7) && !m.cluster_visible(-1, 0));
    assert!(m.object_visible_from(0, 0) && !m.object_visible_from(1, 0) && m.object_visible_from(1, 1));
    // No visdata: everything visible.
    let mut map = Map::tiny();
    map.lumps[16].clear();
    let m = parse(&map.bytes()).unwrap();
    assert_eq!(m.cluster_count(), 0);
    assert!(m.cluster_visible(0, 1));
}

#[test]
fn spawns_and_their_walkthrough() {
    let m = tiny();
    assert_eq!(m.spawns.len(), 2);
    assert_eq!(m.spawns[0].classname, "info_player_deathmatch");
    assert_eq!(m.spawns[1].classname, "team_CTF_redspawn");
    assert!((m.spawns[0].origin - Vec3::new(100.0, 24.0, 200.0) * INCH).length() < 1e-5);
    assert_eq!(m.spawns[0].angle_deg, 90.0);
    // Angle 90 faces Quake +Y, which is hom −Z.
    assert!((m.spawns[0].direction() - Vec3::NEG_Z).length() < 1e-6);
    let path = m.camera_path().unwrap();
    path.validate("tiny").unwrap();
    let first = Vec3::from(path.frames[0].eye);
    let last = Vec3::from(path.frames.last().unwrap().eye);
    assert!((first - (m.spawns[0].origin + Vec3::Y * m.eye_height)).length() < 1e-5);
    assert!((last - (m.spawns[1].origin + Vec3::Y * m.eye_height)).length() < 1e-5);
    // √(400² + 200²) inches at 8 m/s, 30 frames a second.
    let expected = (447.2136 * INCH / (8.0 / 30.0)).ceil() as usize + 1;
    assert_eq!(path.frames.len(), expected);
    // Looking along the direction of travel (−X).
    let f = &path.frames[3];
    assert!(f.target[0] < f.eye[0] && (f.target[1] - f.eye[1]).abs() < 1e-5);
}

#[test]
fn nearest_neighbour_tour_is_deterministic() {
    let mut map = Map::tiny();
    let ents = "{ \"classname\" \"info_player_start\" \"origin\" \"0 0 0\" }\
                { \"classname\" \"info_player_deathmatch\" \"origin\" \"1000 0 0\" }\
                { \"classname\" \"info_player_deathmatch\" \"origin\" \"100 0 0\" }\
                { \"classname\" \"info_player_intermission\" \"origin\" \"50 0 0\" }";
    map.lumps[0] = ents.as_bytes().to_vec();
    let m = parse(&map.bytes()).unwrap();
    assert_eq!(m.spawns.len(), 3, "intermission is not a spawn");
    let path = m.camera_path().unwrap();
    // 0 → 100 → 1000: x never decreases.
    assert!(path.frames.windows(2).all(|w| w[1].eye[0] >= w[0].eye[0] - 1e-6));
    // One spawn: a turn on the spot.
    map.lumps[0] = b"{ \"classname\" \"info_player_start\" \"origin\" \"0 0 0\" }".to_vec();
    let one = parse(&map.bytes()).unwrap().camera_path().unwrap();
    one.validate("one").unwrap();
    assert!(one.frames.iter().all(|f| f.eye == one.frames[0].eye));
    // Frames in solid space (Quake z ≥ 1000 at x < 0 is a solid leaf) are dropped.
    map.lumps[0] = b"{ \"classname\" \"info_player_start\" \"origin\" \"-10 0 0\" }\
                     { \"classname\" \"info_player_start\" \"origin\" \"-3000 0 3000\" }"
        .to_vec();
    let m = parse(&map.bytes()).unwrap();
    let path = m.camera_path().unwrap();
    path.validate("solid").unwrap();
    assert!(path.frames.iter().all(|f| m.cluster_of(Vec3::from(f.eye)).is_some()));
    // Nor does the near plane poke into a wall: the space just ahead is clear too.
    for f in &path.frames {
        let (eye, target) = (Vec3::from(f.eye), Vec3::from(f.target));
        let ahead = eye + (target - eye).normalize() * 2.5 * bsp::CLEARANCE;
        assert!(m.cluster_of(ahead).is_some(), "{f:?}");
    }
    // The walk up the wall toward Quake z = 1000 stops short of it by the clearance.
    let top = path.frames.iter().map(|f| f.eye[1]).fold(f32::MIN, f32::max);
    assert!(top < 1000.0 * INCH && top > 900.0 * INCH, "{top}");
    // Spawns absurdly far apart: a bounded path, or none when distances overflow.
    for x in ["1e15", "1e30"] {
        let text = format!(
            "{{ \"classname\" \"info_player_start\" \"origin\" \"0 0 0\" }}\
             {{ \"classname\" \"info_player_start\" \"origin\" \"{x} 0 0\" }}"
        );
        map.lumps[0] = text.into_bytes();
        match parse(&map.bytes()).unwrap().camera_path() {
            Some(far) => assert!(far.frames.len() <= bsp::MAX_PATH_FRAMES + 2, "{}", far.frames.len()),
            None => assert_eq!(x, "1e30"),
        }
    }
    // The worldspawn's _farplanedist (Quake units) is the far plane; a bad value is ignored.
    let two = "{ \"classname\" \"info_player_start\" \"origin\" \"0 0 0\" }\
               { \"classname\" \"info_player_start\" \"origin\" \"100 0 0\" }";
    let default_far = {
        map.lumps[0] = two.as_bytes().to_vec();
        let m = parse(&map.bytes()).unwrap();
        assert_eq!(m.far_plane(), None);
        m.camera_path().unwrap().far
    };
    for (value, want) in [("100", Some(100.0 * INCH)), ("nan", None), ("-5", None), ("x", None)] {
        map.lumps[0] = format!("{{ \"classname\" \"worldspawn\" \"_farplanedist\" \"{value}\" }}{two}").into_bytes();
        let m = parse(&map.bytes()).unwrap();
        assert_eq!(m.far_plane(), want, "{value}");
        let far = m.camera_path().unwrap().far;
        match want {
            // 100 units = 2.54 m: under the default (the scene's diagonal × 1.5), kept.
            Some(w) => assert!((far - w).abs() < 1e-5, "{value}: {far}"),
            None => assert_eq!(far, default_far, "{value}"),
        }
    }
    // None: no path.
    map.lumps[0].clear();
    assert!(parse(&map.bytes()).unwrap().camera_path().is_none());
}

// ---------------------------------------------------------------- malformed maps

#[test]
fn every_truncation_is_a_typed_error() {
    let bytes = Map::tiny().bytes();
    for len in 0..bytes.len() {
        match parse(&bytes[..len]) {
            Err(BspError::Truncated { len: l }) => assert!(l < 144 && l == len),
            Err(BspError::LumpOutOfBounds { .. }) => assert!(len >= 144),
            other => panic!("truncated at {len}: {:?}", other.map(|m| m.scene.triangle_count())),
        }
    }
}

#[test]
fn header_errors() {
    let mut b = Map::tiny().bytes();
    b[0] = b'V';
    assert!(matches!(parse(&b), Err(BspError::BadMagic { found }) if &found == b"VBSP"));
    let mut b = Map::tiny().bytes();
    b[4] = 47;
    assert!(matches!(parse(&b), Err(BspError::UnsupportedVersion { version: 47 })));
    assert!(parse(&b).unwrap_err().to_string().contains("unsupported version 47"));
    for lump in 0..17 {
        let mut b = Map::tiny().bytes();
        let len = b.len() as i32;
        b[8 + lump * 8..12 + lump * 8].copy_from_slice(&len.to_le_bytes());
        b[12 + lump * 8..16 + lump * 8].copy_from_slice(&4i32.to_le_bytes());
        assert!(
            matches!(parse(&b), Err(BspError::LumpOutOfBounds { .. })),
            "lump {lump}"
        );
        let mut b = Map::tiny().bytes();
        b[12 + lump * 8..16 + lump * 8].copy_from_slice(&i32::MAX.to_le_bytes());
        assert!(
            matches!(parse(&b), Err(BspError::LumpOutOfBounds { .. })),
            "lump {lump}"
        );
        let mut b = Map::tiny().bytes();
        b[8 + lump * 8..12 + lump * 8].copy_from_slice(&(-8i32).to_le_bytes());
        assert!(
            matches!(parse(&b), Err(BspError::LumpOutOfBounds { .. })),
            "lump {lump}"
        );
    }
}

/// Applies `edit` to the tiny map and returns the error.
fn broken(edit: impl FnOnce(&mut Map)) -> BspError {
    let mut map = Map::tiny();
    edit(&mut map);
    match parse(&map.bytes()) {
        Err(e) => e,
        Ok(_) => panic!("the edited map loaded"),
    }
}

#[test]
fn each_malformed_field_gives_its_error() {
    use BspError::*;
    // Lump sizes that are not whole records.
    for (lump, record) in [
        (1, 72),
        (2, 16),
        (3, 36),
        (4, 48),
        (5, 4),
        (7, 40),
        (10, 44),
        (11, 4),
        (13, 104),
    ] {
        let e = broken(|m| {
            m.lumps[lump].push(0);
        });
        assert!(
            matches!(e, LumpSize { record: r, .. } if r == record),
            "lump {lump}: {e}"
        );
    }
    // Face fields (face 0 unless said).
    assert!(matches!(
        broken(|m| {
            m.set(13, 0, 99);
        }),
        IndexOutOfRange {
            field: "shader",
            value: 99,
            ..
        }
    ));
    assert!(matches!(
        broken(|m| {
            m.set(13, 0, -1);
        }),
        IndexOutOfRange { value: -1, .. }
    ));
    assert!(matches!(
        broken(|m| {
            m.set(13, 8, 7);
        }),
        BadFaceType { face: 0, kind: 7 }
    ));
    assert!(matches!(
        broken(|m| {
            m.set(13, 16, i32::MAX);
        }),
        RangeOutOfBounds { field: "vertices", .. }
    ));
    assert!(matches!(
        broken(|m| {
            m.set(13, 12, -5);
        }),
        RangeOutOfBounds { field: "vertices", .. }
    ));
    assert!(matches!(
        broken(|m| {
            m.set(13, 24, i32::MAX);
        }),
        RangeOutOfBounds { field: "meshverts", .. }
    ));
    assert!(matches!(
        broken(|m| {
            m.set(13, 20, 8);
        }),
        RangeOutOfBounds { field: "meshverts", .. }
    ));
    assert!(matches!(
        broken(|m| {
            m.set(13, 24, 4);
        }),
        BadMeshverts { face: 0, count: 4 }
    ));
    assert!(matches!(
        broken(|m| {
            m.set(11, 4, 50);
        }),
        IndexOutOfRange {
            field: "meshvert (vertex offset)",
            value: 50,
            ..
        }
    ));
    assert!(matches!(
        broken(|m| {
            m.set(11, 4, -1);
        }),
        IndexOutOfRange { value: -1, .. }
    ));
    // Patch grids.
    assert!(matches!(
        broken(|m| {
            m.set(13, 2 * 104 + 96, 2);
        }),
        BadPatch { face: 2, .. }
    ));
    assert!(matches!(
        broken(|m| {
            m.set(13, 2 * 104 + 96, 5);
        }),
        BadPatch { face: 2, .. }
    ));
    assert!(matches!(
        broken(|m| {
            m.set(13, 2 * 104 + 100, i32::MIN);
        }),
        BadPatch { face: 2, .. }
    ));
    // Models.
    assert!(matches!(
        broken(|m| {
            m.set(7, 28, 1_000_000);
        }),
        RangeOutOfBounds { field: "faces", .. }
    ));
    assert!(matches!(
        broken(|m| {
            m.lumps[7].clear();
        }),
        IndexOutOfRange { what: "map", .. }
    ));
    // NaN and infinity.
    assert!(matches!(
        broken(|m| {
            m.lumps[10][44 + 4..44 + 8].copy_from_slice(&f32::NAN.to_le_bytes());
        }),
        NonFinite {
            what: "vertex",
            record: 1
        }
    ));
    assert!(matches!(
        broken(|m| {
            m.lumps[2][12..16].copy_from_slice(&f32::INFINITY.to_le_bytes());
        }),
        NonFinite {
            what: "plane",
            record: 0
        }
    ));
    // Tree.
    assert!(matches!(
        broken(|m| {
            m.set(3, 0, 9);
        }),
        IndexOutOfRange {
            what: "node",
            field: "plane",
            ..
        }
    ));
    assert!(matches!(
        broken(|m| {
            m.set(3, 8, 5);
        }),
        IndexOutOfRange {
            what: "node",
            field: "child node",
            ..
        }
    ));
    assert!(matches!(
        broken(|m| {
            m.set(3, 4, -10);
        }),
        IndexOutOfRange {
            what: "node",
            field: "child leaf",
            ..
        }
    ));
    assert!(matches!(
        broken(|m| {
            m.set(3, 4, i32::MIN);
        }),
        IndexOutOfRange { what: "node", .. }
    ));
    // Leaves.
    assert!(matches!(
        broken(|m| {
            m.set(4, 0, 2);
        }),
        BadLeafCluster {
            leaf: 0,
            cluster: 2,
            clusters: 2
        }
    ));
    assert!(matches!(
        broken(|m| {
            m.set(4, 0, -2);
        }),
        BadLeafCluster { leaf: 0, .. }
    ));
    assert!(matches!(
        broken(|m| {
            m.set(4, 36, i32::MAX);
        }),
        RangeOutOfBounds { what: "leaf", .. }
    ));
    assert!(matches!(
        broken(|m| {
            m.set(5, 0, 70);
        }),
        IndexOutOfRange {
            field: "face",
            value: 70,
            ..
        }
    ));
    // Visdata.
    assert!(matches!(
        broken(|m| {
            m.set(16, 0, i32::MAX);
        }),
        BadVisdata { .. }
    ));
    assert!(matches!(
        broken(|m| {
            m.set(16, 4, -1);
        }),
        BadVisdata { .. }
    ));
    assert!(matches!(
        broken(|m| {
            m.set(16, 0, 9).set(16, 4, 0);
        }),
        BadVisdata { .. }
    ));
    assert!(matches!(
        broken(|m| {
            m.lumps[16].truncate(5);
        }),
        BadVisdata { .. }
    ));
    // Entities.
    assert!(matches!(
        broken(|m| {
            m.lumps[0] = b"{ \"classname\" ".to_vec();
        }),
        Entities { .. }
    ));
    assert!(matches!(
        broken(|m| {
            m.lumps[0] = b"junk".to_vec();
        }),
        Entities { offset: 0, .. }
    ));
    let e = broken(|m| {
        m.lumps[0] = b"{ \"classname\" \"info_player_start\" \"origin\" \"1 2\" }".to_vec();
    });
    assert!(
        matches!(&e, BadSpawn { entity: 0, message, .. } if message.contains("origin")),
        "{e}"
    );
    let e = broken(|m| {
        m.lumps[0] = b"{ \"classname\" \"info_player_start\" \"origin\" \"1 2 nan\" }".to_vec();
    });
    assert!(matches!(e, BadSpawn { .. }));
    let e = broken(|m| {
        m.lumps[0] = b"{ \"classname\" \"info_player_start\" \"origin\" \"1 2 3\" \"angle\" \"x\" }".to_vec();
    });
    assert!(
        matches!(&e, BadSpawn { message, .. } if message.contains("angle")),
        "{e}"
    );
    // Nothing left to draw.
    let e = broken(|m| {
        for f in 0..3 {
            m.set(13, f * 104, 1);
        }
        m.set(13, 4 * 104, 1);
    });
    assert!(matches!(e, NoGeometry), "{e}");
}

#[test]
fn output_is_capped() {
    let options = BspOptions {
        max_triangles: 10,
        ..BspOptions::default()
    };
    assert!(matches!(
        bsp::parse(&Map::tiny().bytes(), "t", &options),
        Err(BspError::TooBig { limit: 10 })
    ));
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 10_000, failure_persistence: None, ..ProptestConfig::default() })]

    /// Byte flips, truncations and huge u32 values anywhere: an error or a map, never a panic.
    #[test]
    fn mutated_maps_never_panic(
        flips in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 0..8),
        words in prop::collection::vec((any::<prop::sample::Index>(), prop_oneof![Just(u32::MAX), Just(0x7fff_ffff), Just(0x8000_0000), any::<u32>()]), 0..4),
        cut in prop::option::of(any::<prop::sample::Index>()),
    ) {
        let mut b = Map::tiny().bytes();
        for (at, v) in flips {
            let i = at.index(b.len());
            b[i] ^= v;
        }
        for (at, v) in words {
            let i = at.index(b.len() / 4) * 4;
            b[i..i + 4].copy_from_slice(&v.to_le_bytes());
        }
        if let Some(c) = cut {
            let len = c.index(b.len() + 1);
            b.truncate(len);
        }
        if let Ok(m) = parse(&b) {
            // Whatever loads is usable.
            let _ = m.camera_path();
            let _ = m.cluster_of(Vec3::ZERO);
            prop_assert_eq!(m.object_clusters.len(), m.scene.objects().len());
        }
    }
}

// ---------------------------------------------------------------- pk3 archives

fn pk3(entries: &[(&str, &[u8])]) -> Vec<u8> {
    let mut zip = zip::ZipWriter::new(Cursor::new(Vec::new()));
    let options = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
    for (name, data) in entries {
        zip.start_file(*name, options).unwrap();
        zip.write_all(data).unwrap();
    }
    zip.finish().unwrap().into_inner()
}

fn read(bytes: Vec<u8>, map: Option<&str>, max_bytes: u64) -> Result<(String, Vec<u8>), BspError> {
    let options = BspOptions {
        map: map.map(str::to_owned),
        max_bytes,
        ..BspOptions::default()
    };
    bsp::read_pk3(Cursor::new(bytes), &options)
}

#[test]
fn pk3_chooses_the_map() {
    let map = Map::tiny().bytes();
    let one = pk3(&[("scripts/x.shader", b"x"), ("maps/tiny.bsp", &map)]);
    let (entry, bytes) = read(one.clone(), None, 1 << 20).unwrap();
    assert_eq!((entry.as_str(), &bytes), ("maps/tiny.bsp", &map));
    let two = pk3(&[("maps/a.bsp", &map), ("maps/B.bsp", &map), ("maps/sub/c.bsp", &map)]);
    assert!(
        matches!(read(two.clone(), None, 1 << 20), Err(BspError::SeveralMaps { available }) if available == "B, a")
    );
    assert_eq!(read(two.clone(), Some("b"), 1 << 20).unwrap().0, "maps/B.bsp");
    let e = read(two, Some("zzz"), 1 << 20).unwrap_err();
    assert!(
        matches!(&e, BspError::MapNotFound { available, .. } if available == "B, a"),
        "{e}"
    );
    assert!(matches!(
        read(pk3(&[("readme.txt", b"hi")]), None, 1 << 20),
        Err(BspError::NoMaps)
    ));
    assert!(matches!(
        read(b"PK\x03\x04 not a zip".to_vec(), None, 1 << 20),
        Err(BspError::Zip { .. })
    ));
}

/// `FILE.pk3:*` names every map of the archive; anything else only itself.
#[test]
fn pk3_star_expands_to_every_map() {
    let dir = std::env::temp_dir().join(format!("hom-pk3-star-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let map = Map::tiny().bytes();
    let two = dir.join("two.pk3");
    std::fs::write(
        &two,
        pk3(&[("maps/b.bsp", &map), ("maps/a.bsp", &map), ("maps/sub/c.bsp", &map)]),
    )
    .unwrap();
    let none = dir.join("none.pk3");
    std::fs::write(&none, pk3(&[("readme.txt", b"hi")])).unwrap();
    let t = two.display().to_string();
    assert_eq!(
        hom_scene::expand_map_specs(&format!("{t}:*")).unwrap(),
        vec![format!("{t}:a"), format!("{t}:b")]
    );
    for plain in ["city", "x.obj", &format!("{t}:a")] {
        assert_eq!(hom_scene::expand_map_specs(plain).unwrap(), vec![plain.to_owned()]);
    }
    let e = hom_scene::expand_map_specs(&format!("{}:*", none.display())).unwrap_err();
    assert!(
        matches!(&e, hom_scene::LoadError::Bsp { path, source: BspError::NoMaps } if *path == none.display().to_string()),
        "{e}"
    );
    let e = hom_scene::expand_map_specs("level.obj:*").unwrap_err();
    assert!(e.to_string().contains(".pk3 archive only"), "{e}");
    assert!(hom_scene::expand_map_specs(&format!("{}:*", dir.join("missing.pk3").display())).is_err());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn pk3_zip_bombs_are_capped() {
    // Honest declared size above the cap.
    let zeros = vec![0u8; 1 << 20];
    let bomb = pk3(&[("maps/bomb.bsp", &zeros)]);
    assert!(bomb.len() < 10_000, "deflate squeezes zeros");
    assert!(
        matches!(read(bomb.clone(), None, 4096), Err(BspError::TooLarge { size, cap: 4096, .. }) if size == 1 << 20)
    );
    // An end record claiming far more entries than its central directory can hold.
    let mut many = pk3(&[("maps/tiny.bsp", &Map::tiny().bytes())]);
    let end = many.windows(4).rposition(|w| w == b"PK\x05\x06").unwrap();
    many[end + 8..end + 12].copy_from_slice(&[0xfe, 0xff, 0xfe, 0xff]);
    let e = read(many, None, 1 << 20).unwrap_err();
    assert!(
        matches!(&e, BspError::Zip { message } if message.contains("claims 65534 entries")),
        "{e}"
    );
    // Lying sizes: the local and central headers claim 100 bytes.
    let mut liar = bomb;
    for (sig, at) in [(b"PK\x03\x04", 22), (b"PK\x01\x02", 24)] {
        let i = liar.windows(4).position(|w| w == sig).unwrap();
        liar[i + at..i + at + 4].copy_from_slice(&100u32.to_le_bytes());
    }
    match read(liar, None, 4096) {
        Ok((_, bytes)) => assert!(bytes.len() <= 4096),
        Err(e) => assert!(matches!(e, BspError::TooLarge { .. } | BspError::Zip { .. }), "{e}"),
    }
}

#[test]
fn load_reads_pk3_specs_and_loose_files() {
    let dir = tempfile::tempdir().unwrap();
    let map = Map::tiny().bytes();
    let file = dir.path().join("maps.pk3");
    std::fs::write(&file, pk3(&[("maps/one.bsp", &map), ("maps/two.bsp", &map)])).unwrap();
    let spec = dir.path().join("maps.pk3:two");
    let loaded = hom_scene::load_with_path(&spec).unwrap();
    assert_eq!(loaded.scene.name(), "two");
    assert_eq!(loaded.scene.triangle_count(), 54);
    assert!(loaded.path.is_some());
    assert!(matches!(
        hom_scene::load(&file),
        Err(LoadError::Bsp {
            source: BspError::SeveralMaps { .. },
            ..
        })
    ));
    let e = chain(&hom_scene::load(&dir.path().join("maps.pk3:three")).unwrap_err());
    assert!(e.contains("no map 'three'") && e.contains("one, two"), "{e}");
    let loose = dir.path().join("tiny.bsp");
    std::fs::write(&loose, &map).unwrap();
    assert_eq!(hom_scene::load(&loose).unwrap().objects().len(), 2);
    std::fs::write(&loose, &map[..100]).unwrap();
    let e = hom_scene::load(&loose).unwrap_err();
    assert!(matches!(
        e,
        LoadError::Bsp {
            source: BspError::Truncated { len: 100 },
            ..
        }
    ));
    assert!(e.to_string().contains("tiny.bsp"), "{e}");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 10_000, failure_persistence: None, ..ProptestConfig::default() })]

    /// Mutated pk3 archives: an error or a map, never a panic, never more than the cap.
    #[test]
    fn mutated_pk3s_never_panic(
        flips in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..6),
        words in prop::collection::vec((any::<prop::sample::Index>(), prop_oneof![Just(u32::MAX), Just(0x7fff_ffff), any::<u32>()]), 0..3),
        cut in prop::option::of(any::<prop::sample::Index>()),
    ) {
        let map = Map::tiny().bytes();
        let mut b = pk3(&[("maps/tiny.bsp", &map)]);
        for (at, v) in flips {
            let i = at.index(b.len());
            b[i] ^= v;
        }
        for (at, v) in words {
            let i = at.index(b.len() - 3);
            b[i..i + 4].copy_from_slice(&v.to_le_bytes());
        }
        if let Some(c) = cut {
            let len = c.index(b.len() + 1);
            b.truncate(len);
        }
        if let Ok((_, bytes)) = read(b, None, 1 << 16) {
            prop_assert!(bytes.len() <= 1 << 16);
            let _ = parse(&bytes);
        }
    }
}
