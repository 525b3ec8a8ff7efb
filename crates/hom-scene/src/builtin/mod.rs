//! Built-in generated scenes, each with a walkthrough camera path that exercises it.
//!
//! Every scene is a pure function of its seed. Objects have the granularity of real
//! models (a building, a pump, a chair), meshes are shared between instances where
//! the shape repeats, and the camera paths stay in free space (streets, aisles,
//! corridors) so no frame starts inside an object.
//!
//! | name | what | triangles |
//! |------|------|-----------|
//! | `city` | street grid of detailed buildings and street furniture, eye-level walk | ≈300k |
//! | `spheres` | ten spheres in a line seen along the line | ≈22k |
//! | `machine-room` | dense engine room: engines, pumps, tanks, pipe runs, bolts | ≈600k |
//! | `dynamic` | moving Utah teapots, tori, spheres and boxes | ≈1M |
//! | `office` | a building floor of rooms, corridors and furnished offices | ≈270k |
//! | `terrain` | rolling height-field hills with villages and forests, low flight | ≈480k |
//! | `sculpture-park` | courtyards of densely tessellated walls and high-poly statues, then a grove of small trees | ≈350k |
//!
//! [`SCALE_SCENES`] are generated the same way but too big for the walk
//! suite every test and `hom bench` runs by default:
//!
//! | name | what | triangles |
//! |------|------|-----------|
//! | `metropolis` | 40 × 40 city blocks, over 100,000 objects, shared meshes, street-level walk | ≈11M |

mod city;
mod dynamic;
mod machine_room;
mod metropolis;
mod office;
pub(crate) mod rng;
mod sculpture_park;
mod shapes;
pub(crate) mod spheres;
mod teapot;
mod terrain;

use crate::motion::Animation;
use crate::{CameraPath, LoadError};
use glam::Vec3;
use hom::scene::{Scene, SceneError};

/// A generated scene with the camera path that exercises it.
pub struct Builtin {
    /// The scene.
    pub scene: Scene,
    /// Its walkthrough.
    pub path: CameraPath,
    /// How its dynamic objects move ([`Animation::none`] for static scenes).
    pub animation: Animation,
}

/// The seed [`builtin`] uses.
pub const DEFAULT_SEED: u64 = 0x5EED_2024;

/// Names and one-line descriptions of the built-in scenes.
pub const BUILTIN_SCENES: &[(&str, &str)] = &[
    (
        "city",
        "street grid of detailed buildings, trees, lamps and cars; eye-level walk turning corners",
    ),
    (
        "spheres",
        "ten spheres in a line viewed along it (the first hides the rest); orbit then fly past",
    ),
    (
        "machine-room",
        "dense engine room: engines, pumps, tanks, pipe runs, bolts and brackets; walk the aisles",
    ),
    (
        "dynamic",
        "≈1M triangles of moving Utah teapots, tori, spheres and boxes; fly through the lanes",
    ),
    (
        "office",
        "a building floor of rooms, corridors and doorways with furniture; walk in and out of rooms",
    ),
    (
        "terrain",
        "rolling height-field hills in tiles with villages and forests; low flight over the hills",
    ),
    (
        "sculpture-park",
        "walled courtyards of densely tessellated walls, statues and monuments, then a grove of small trees; walk through",
    ),
];

/// Built-in scenes for measuring at scale, made by [`builtin`] like the others
/// but not in [`BUILTIN_SCENES`] (the walk suite the tests and `hom bench` run
/// by default).
pub const SCALE_SCENES: &[(&str, &str)] = &[(
    "metropolis",
    "40 x 40 city blocks: over 100,000 objects and 10M triangles of shared meshes; street-level walk",
)];

/// Generates the built-in scene `name` with [`DEFAULT_SEED`].
pub fn builtin(name: &str) -> Result<Builtin, LoadError> {
    builtin_with_seed(name, DEFAULT_SEED)
}

/// Generates the built-in scene `name` from `seed` (the same seed gives the same scene).
/// Names are case-insensitive and `_` may stand for `-`.
pub fn builtin_with_seed(name: &str, seed: u64) -> Result<Builtin, LoadError> {
    let key = name.trim().to_ascii_lowercase().replace('_', "-");
    let generated = match key.as_str() {
        "city" => city::generate(seed),
        "spheres" => spheres::generate(seed),
        "machine-room" => machine_room::generate(seed),
        "dynamic" => dynamic::generate(seed),
        "office" => office::generate(seed),
        "terrain" => terrain::generate(seed),
        "sculpture-park" => sculpture_park::generate(seed),
        "metropolis" => metropolis::generate(seed),
        _ => {
            return Err(LoadError::UnknownBuiltin {
                name: name.to_string(),
                known: BUILTIN_SCENES
                    .iter()
                    .chain(SCALE_SCENES)
                    .map(|(n, _)| *n)
                    .collect::<Vec<_>>()
                    .join(", "),
            })
        }
    };
    generated.map_err(|source| LoadError::Scene {
        path: format!("built-in scene '{key}'"),
        source,
    })
}

/// What a generator returns before the name is attached to errors.
type Generated = Result<Builtin, SceneError>;

/// The polyline `pts` with every interior corner replaced by a circular arc of radius
/// `radius` (at most half of either neighbouring leg), sampled every `step` metres of arc.
/// Gives camera paths that turn smoothly instead of snapping at corners.
fn round_corners(pts: &[Vec3], radius: f32, step: f32) -> Vec<Vec3> {
    if pts.len() < 3 {
        return pts.to_vec();
    }
    let mut out = vec![pts[0]];
    for k in 1..pts.len() - 1 {
        let (a, p, b) = (pts[k - 1], pts[k], pts[k + 1]);
        let (d0, d1) = ((p - a).normalize_or_zero(), (b - p).normalize_or_zero());
        let cos = d0.dot(d1).clamp(-1.0, 1.0);
        let theta = cos.acos();
        if !(1e-3..=std::f32::consts::PI - 1e-3).contains(&theta) {
            out.push(p);
            continue;
        }
        let half_tan = (theta * 0.5).tan();
        let leg = (p - a).length().min((b - p).length()) * 0.5;
        let r = radius.min(leg / half_tan);
        let t = r * half_tan;
        let start = p - d0 * t;
        let centre = start + (d1 - d0 * cos).normalize() * r;
        let axis = d0.cross(d1).normalize();
        let n = ((r * theta / step).ceil() as usize).max(2);
        for i in 0..=n {
            let q = glam::Quat::from_axis_angle(axis, theta * i as f32 / n as f32);
            out.push(centre + q * (start - centre));
        }
    }
    out.push(*pts.last().unwrap());
    out.dedup_by(|x, y| (*x - *y).length_squared() < 1e-8);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::hash::{Hash, Hasher};

    /// Triangle count the brief states for each scene (tests allow ±30%).
    const TARGETS: &[(&str, u64)] = &[
        ("city", 300_000),
        ("spheres", 22_000),
        ("machine-room", 600_000),
        ("dynamic", 1_000_000),
        ("office", 270_000),
        ("terrain", 480_000),
        ("sculpture-park", 350_000),
    ];

    fn fingerprint(b: &Builtin) -> (usize, u64, u64) {
        let mut h = std::collections::hash_map::DefaultHasher::new();
        for o in b.scene.objects() {
            o.name.hash(&mut h);
            o.mesh.hash(&mut h);
            for v in o.transform.to_cols_array() {
                v.to_bits().hash(&mut h);
            }
        }
        for f in &b.path.frames {
            for v in f.eye.iter().chain(&f.target) {
                v.to_bits().hash(&mut h);
            }
        }
        (b.scene.objects().len(), b.scene.triangle_count(), h.finish())
    }

    /// Frames whose eye lies strictly inside some static object's bounds (padded by 5 cm).
    fn eyes_inside(b: &Builtin) -> Vec<(usize, String)> {
        let mut bad = Vec::new();
        for (i, f) in b.path.frames.iter().enumerate() {
            let eye = Vec3::from(f.eye);
            for o in b.scene.objects().iter().filter(|o| !o.is_dynamic()) {
                let shrunk = hom::geom::Aabb::new(o.aabb.min - 0.05, o.aabb.max + 0.05);
                if shrunk.contains_point(eye) {
                    bad.push((i, o.name.clone()));
                }
            }
        }
        bad
    }

    #[test]
    fn every_scene_builds_to_size_with_a_valid_path() {
        for &(name, target) in TARGETS {
            let b = builtin(name).unwrap();
            let tris = b.scene.triangle_count();
            let lo = target as f64 * 0.7;
            let hi = target as f64 * 1.3;
            assert!(
                (lo..=hi).contains(&(tris as f64)),
                "{name}: {tris} triangles, want {target} ±30%"
            );
            b.path.validate(name).unwrap();
            let n = b.path.frames.len();
            assert!((100..=400).contains(&n), "{name}: {n} frames");
            assert_eq!(b.scene.name(), name);
        }
        assert_eq!(TARGETS.len(), BUILTIN_SCENES.len());
    }

    #[test]
    fn scenes_are_deterministic_and_seed_dependent() {
        for &(name, _) in BUILTIN_SCENES {
            let a = fingerprint(&builtin_with_seed(name, 11).unwrap());
            let b = fingerprint(&builtin_with_seed(name, 11).unwrap());
            assert_eq!(a, b, "{name}");
            if name != "spheres" {
                let c = fingerprint(&builtin_with_seed(name, 12).unwrap());
                assert_ne!(a.2, c.2, "{name}: seed changes nothing");
            }
        }
    }

    #[test]
    fn walks_never_start_a_frame_inside_an_object() {
        for name in ["city", "spheres", "machine-room", "office", "dynamic", "sculpture-park"] {
            let b = builtin(name).unwrap();
            let bad = eyes_inside(&b);
            assert!(bad.is_empty(), "{name}: eye inside {:?}", &bad[..bad.len().min(10)]);
        }
    }

    #[test]
    fn metropolis_is_at_scale_shares_its_meshes_and_walks_free_streets() {
        let start = std::time::Instant::now();
        let b = builtin("metropolis").unwrap();
        let made = start.elapsed();
        let s = &b.scene;
        assert!(s.objects().len() >= 100_000, "{} objects", s.objects().len());
        assert!(s.triangle_count() >= 10_000_000, "{} triangles", s.triangle_count());
        assert!(s.meshes().len() < 100, "instanced: {} meshes", s.meshes().len());
        assert!(made.as_secs() < 20, "generated in {made:?}");
        b.path.validate("metropolis").unwrap();
        assert!((300..=500).contains(&b.path.frames.len()));
        let bad = eyes_inside(&b);
        assert!(bad.is_empty(), "eye inside {:?}", &bad[..bad.len().min(10)]);
        assert_eq!(fingerprint(&b), fingerprint(&builtin("metropolis").unwrap()));
        assert_ne!(
            fingerprint(&b).2,
            fingerprint(&builtin_with_seed("metropolis", 3).unwrap()).2
        );
    }

    #[test]
    fn dynamic_objects_never_reach_the_camera_lanes() {
        let mut b = builtin("dynamic").unwrap();
        for t in [0.0, 1.7, 5.3, 9.9, 31.0] {
            b.animation.apply(&mut b.scene, t);
            for (i, f) in b.path.frames.iter().enumerate().step_by(3) {
                let eye = Vec3::from(f.eye);
                for o in b.scene.objects() {
                    assert!(
                        o.aabb.distance_squared(eye) > 0.25,
                        "t={t} frame {i}: eye in {}",
                        o.name
                    );
                }
            }
        }
    }

    #[test]
    fn dynamic_scene_moves() {
        let mut b = builtin("dynamic").unwrap();
        let s = &mut b.scene;
        assert!(s.dynamic_count() * 10 > s.objects().len() * 8, "mostly dynamic");
        assert_eq!(b.animation.tracks().len(), s.dynamic_count());
        let before: Vec<_> = s.objects().iter().map(|o| o.aabb).collect();
        b.animation.apply(s, 2.0);
        let moved = s.objects().iter().zip(&before).filter(|(o, b)| o.aabb != **b).count();
        assert_eq!(moved, s.dynamic_count());
        for name in ["city", "spheres", "machine-room", "office", "terrain", "sculpture-park"] {
            let b = builtin(name).unwrap();
            assert!(b.scene.dynamic_count() == 0 && b.animation.is_empty(), "{name}");
        }
    }

    #[test]
    fn unknown_names_list_the_known_ones() {
        let Err(LoadError::UnknownBuiltin { name, known }) = builtin("nope") else {
            panic!("expected UnknownBuiltin")
        };
        assert_eq!(name, "nope");
        assert_eq!(
            known,
            "city, spheres, machine-room, dynamic, office, terrain, sculpture-park, metropolis"
        );
        assert!(builtin("Machine_Room").is_ok());
    }

    #[test]
    fn rounded_corners_stay_near_the_polyline() {
        let pts = [Vec3::ZERO, Vec3::new(10.0, 0.0, 0.0), Vec3::new(10.0, 0.0, 10.0)];
        let r = round_corners(&pts, 3.0, 0.5);
        assert!(r.len() > 5);
        assert_eq!(r[0], pts[0]);
        assert_eq!(*r.last().unwrap(), pts[2]);
        assert!(r.iter().all(|p| p.x <= 10.0 + 1e-4 && p.z >= -1e-4));
    }
}
