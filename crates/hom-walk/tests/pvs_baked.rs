//! A baked PVS (`hom::pvs`) against the oracle: nothing it hides is seen from
//! random viewpoints in its cells or along the walk it was baked for, it
//! hides a fair share, its bytes survive a round trip and 10,000 mutations,
//! and shards merge into the bytes of a one-machine bake.

use hom::cull::{Culler, FrustumCuller, PvsCuller};
use hom::geom::{Aabb, Camera};
use hom::glam::{Mat4, Vec3};
use hom::pvs::{PortalCells, Pvs, PvsConfig, PvsError, Shard};
use hom::scene::{Scene, SceneBuilder};
use hom_render::{Framebuffer, Renderer};
use hom_testkit::{assert_no_false_culls, cube, Rng};
use std::sync::Arc;

/// A street: two rows of tall buildings (closed boxes) with small boxes
/// (crates, kiosks) in front of, between and behind them, and an eye path
/// down the middle.
fn street(seed: u64) -> (Scene, Vec<Vec3>) {
    let mut rng = Rng::new(seed);
    let mut b = SceneBuilder::new("street");
    let unit = b.add_mesh(cube());
    let place = |b: &mut SceneBuilder, name: &str, centre: Vec3, size: Vec3| {
        b.add_object(name, unit, Mat4::from_translation(centre) * Mat4::from_scale(size))
            .unwrap()
    };
    for i in 0..8 {
        let z = -40.0 + i as f32 * 11.0;
        for side in [-1.0f32, 1.0] {
            let h = rng.range(8.0, 20.0);
            place(
                &mut b,
                "building",
                Vec3::new(side * 12.0, h * 0.5, z),
                Vec3::new(8.0, h, 9.0),
            );
        }
    }
    for _ in 0..160 {
        let p = Vec3::new(rng.range(-40.0, 40.0), 0.0, rng.range(-50.0, 50.0));
        let s = rng.range(0.5, 2.5);
        place(&mut b, "crate", p + Vec3::Y * s * 0.5, Vec3::splat(s));
    }
    let eyes = (0..40)
        .map(|i| Vec3::new(rng.range(-2.0, 2.0), 1.7, -40.0 + i as f32 * 2.0))
        .collect();
    (b.build().unwrap(), eyes)
}

fn config() -> PvsConfig {
    PvsConfig {
        cell_size: 4.0,
        levels: 2,
        near: 0.1,
        near_clearance: 0.2,
        ..PvsConfig::default()
    }
}

fn bake(scene: &Scene, eyes: &[Vec3], shard: Shard) -> Pvs {
    Pvs::bake(scene, eyes, &[], &config(), shard, &|_, _| {}).unwrap()
}

/// Six 90° views (near 0.1: the near rectangle's corners lie 0.17 away,
/// inside the bake's 0.2 clearance).
fn seen_around(renderer: &Renderer, scene: &Scene, eye: Vec3, fb: &mut Framebuffer) -> Vec<bool> {
    let mut seen = vec![false; scene.objects().len()];
    for d in [Vec3::X, Vec3::NEG_X, Vec3::Y, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z] {
        let up = if d.y != 0.0 { Vec3::Z } else { Vec3::Y };
        let cam = Camera::new(eye, eye + d, up, 90f32.to_radians(), 0.1, 500.0, 96, 96);
        let counts = hom_render::oracle_pixel_counts(renderer, scene, &cam, fb);
        for (s, c) in seen.iter_mut().zip(counts) {
            *s |= c > 0;
        }
    }
    seen
}

#[test]
fn nothing_hidden_is_seen_from_random_viewpoints_in_the_cells() {
    let renderer = Renderer::new(1).unwrap();
    let mut fb = Framebuffer::new(96, 96);
    let mut total_hidden = 0;
    for seed in [2, 4] {
        let (scene, eyes) = street(seed);
        let pvs = bake(&scene, &eyes, Shard::WHOLE);
        let cells: Vec<Aabb> = pvs.cells().cells().map(|(_, b)| b).collect();
        assert!(cells.len() > 10);
        let mut rng = Rng::new(seed * 77);
        let mut hidden = Vec::new();
        for i in 0..60 {
            let c = cells[i % cells.len()];
            let eye = c.min + (c.max - c.min) * Vec3::new(rng.unit(), rng.unit(), rng.unit());
            hidden.clear();
            assert!(pvs.hidden_from(eye, &mut hidden).is_some(), "{eye} lies in a cell");
            let seen = seen_around(&renderer, &scene, eye, &mut fb);
            for &id in &hidden {
                assert!(
                    !seen[id as usize],
                    "seed {seed}: object {id} is hidden from the cell of {eye} but seen"
                );
            }
            total_hidden += hidden.len();
        }
    }
    // The check can fail: the PVS hides plenty (a fifth of the objects on average).
    assert!(
        total_hidden > 120 * 176 / 5,
        "{total_hidden} hidden over 120 viewpoints"
    );
}

#[test]
fn the_pvs_culler_culls_without_false_culls_along_the_walk() {
    let (scene, eyes) = street(3);
    let pvs = Arc::new(bake(&scene, &eyes, Shard::WHOLE));
    let mut culler = PvsCuller::new(&scene, pvs, Box::new(FrustumCuller::new(&scene))).unwrap();
    assert_eq!(culler.name(), "pvs");
    let mut culled = 0;
    for w in eyes.windows(2) {
        let cam = Camera::new(w[0], w[1], Vec3::Y, 60f32.to_radians(), 0.1, 500.0, 160, 90);
        let out = assert_no_false_culls(&scene, &cam, &mut culler);
        culled += out.occluded.len();
    }
    assert!(culled > 100, "{culled} objects culled over the walk");
    // A view whose near plane is nearer than the bake allowed for is not served.
    let near = Camera::new(eyes[0], eyes[1], Vec3::Y, 60f32.to_radians(), 0.01, 500.0, 160, 90);
    let out = assert_no_false_culls(&scene, &near, &mut culler);
    assert!(out.occluded.is_empty());
}

#[test]
fn another_scene_is_refused() {
    let (scene, eyes) = street(4);
    let pvs = Arc::new(bake(&scene, &eyes, Shard::WHOLE));
    let (other, _) = street(8);
    let err = PvsCuller::new(&other, pvs, Box::new(FrustumCuller::new(&other)))
        .err()
        .unwrap();
    assert!(matches!(err, PvsError::WrongScene { .. }), "{err}");
}

#[test]
fn shards_merge_into_the_bytes_of_one_bake() {
    let (scene, eyes) = street(6);
    let whole = bake(&scene, &eyes, Shard::WHOLE);
    let shards: Vec<Pvs> = (0..3)
        .rev()
        .map(|k| bake(&scene, &eyes, Shard { index: k, count: 3 }))
        .collect();
    let merged = Pvs::merge(shards.clone()).unwrap();
    assert_eq!(merged.to_bytes(), whole.to_bytes());
    // A shard missing, or given twice, is an error that says so.
    let err = Pvs::merge(shards[..2].to_vec()).unwrap_err().to_string();
    assert!(err.contains("missing"), "{err}");
    let err = Pvs::merge(vec![shards[0].clone(), shards[0].clone(), shards[1].clone()]).unwrap_err();
    assert!(err.to_string().contains("twice"), "{err}");
}

#[test]
fn bytes_round_trip_and_hostile_bytes_are_errors() {
    let (scene, eyes) = street(7);
    let pvs = bake(&scene, &eyes, Shard::WHOLE);
    let bytes = pvs.to_bytes();
    assert_eq!(Pvs::from_bytes(&bytes).unwrap(), pvs);
    // Every truncation.
    for n in 0..bytes.len() {
        assert!(Pvs::from_bytes(&bytes[..n]).is_err(), "cut at {n}");
    }
    // 10,000 mutations: flipped bytes (checksum caught), and the same with
    // the checksum rewritten so the parser itself must refuse or accept
    // cleanly; never a panic.
    let mut rng = Rng::new(99);
    let mut parsed_clean = 0;
    for i in 0..10_000 {
        let mut m = bytes.clone();
        for _ in 0..1 + rng.below(4) {
            let at = rng.below(m.len() as u64) as usize;
            m[at] = rng.next_u64() as u8;
        }
        if i % 2 == 1 {
            let body = m.len() - 8;
            let sum = fnv(&m[..body]);
            m[body..].copy_from_slice(&sum.to_le_bytes());
        }
        if Pvs::from_bytes(&m).is_ok() {
            parsed_clean += 1;
        }
    }
    // Mutated bytes that still parse are possible (a changed height), but rare.
    assert!(parsed_clean < 5_000, "{parsed_clean}");
    let err = Pvs::from_bytes(b"not a pvs file at all").unwrap_err();
    assert!(err.to_string().contains("not a hom PVS"), "{err}");
}

/// Portal cells beside the view cells: the eye's portal cell hides its set
/// too, only clear of solid space; the cells survive the bytes (and every
/// truncation is an error) and shards carrying them merge into one bake.
#[test]
fn portal_cells_hide_beside_the_view_cells() {
    let (scene, eyes) = street(8);
    // x < 0: cell 0; 0 ≤ x < 1.5: cell 1; x ≥ 1.5: solid.
    let cells = || {
        PortalCells::new(
            vec![(Vec3::X, 0.0), (Vec3::X, 1.5)],
            vec![(0, 1, -1), (1, -3, -2)],
            vec![Some(0), Some(1), None],
            vec![vec![0, 5, 9], vec![7]],
        )
        .unwrap()
    };
    let plain = bake(&scene, &eyes, Shard::WHOLE);
    let with = plain.clone().with_portal_cells(cells()).unwrap();
    let hidden = |pvs: &Pvs, eye: Vec3| {
        let mut out = Vec::new();
        pvs.hidden_from(eye, &mut out).map(|_| out)
    };
    let union = |mut a: Vec<u32>, b: &[u32]| {
        a.extend_from_slice(b);
        a.sort_unstable();
        a.dedup();
        a
    };
    let west = Vec3::new(-1.0, 1.7, eyes[20].z);
    assert_eq!(hidden(&with, west), hidden(&plain, west).map(|h| union(h, &[0, 5, 9])));
    let east = Vec3::new(0.5, 1.7, eyes[20].z);
    assert_eq!(hidden(&with, east), hidden(&plain, east).map(|h| union(h, &[7])));
    let near_solid = Vec3::new(1.4, 1.7, eyes[20].z);
    assert_eq!(
        hidden(&with, near_solid),
        hidden(&plain, near_solid),
        "the near plane could cut into solid space"
    );

    let bytes = with.to_bytes();
    assert_eq!(Pvs::from_bytes(&bytes).unwrap(), with);
    assert_ne!(bytes, plain.to_bytes());
    for n in 0..bytes.len() {
        assert!(Pvs::from_bytes(&bytes[..n]).is_err(), "cut at {n}");
    }
    let shards: Vec<Pvs> = (0..2)
        .map(|k| {
            bake(&scene, &eyes, Shard { index: k, count: 2 })
                .with_portal_cells(cells())
                .unwrap()
        })
        .collect();
    assert_eq!(Pvs::merge(shards.clone()).unwrap().to_bytes(), bytes);
    let err = Pvs::merge(vec![
        shards[0].clone(),
        bake(&scene, &eyes, Shard { index: 1, count: 2 }),
    ])
    .unwrap_err();
    assert!(err.to_string().contains("other settings"), "{err}");

    let beyond = PortalCells::new(vec![], vec![], vec![Some(0)], vec![vec![scene.objects().len() as u32]]).unwrap();
    let err = plain.with_portal_cells(beyond).unwrap_err().to_string();
    assert!(err.contains("does not have"), "{err}");
}

fn fnv(bytes: &[u8]) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

#[test]
fn bad_settings_and_regions_are_errors() {
    let (scene, eyes) = street(8);
    let bad = |c: PvsConfig| Pvs::bake(&scene, &eyes, &[], &c, Shard::WHOLE, &|_, _| {}).unwrap_err();
    assert!(matches!(
        bad(PvsConfig {
            cell_size: 0.0,
            ..config()
        }),
        PvsError::BadConfig(_)
    ));
    assert!(matches!(
        bad(PvsConfig {
            near_clearance: 0.01,
            ..config()
        }),
        PvsError::BadConfig(_)
    ));
    let run = |eyes: &[Vec3], shard| Pvs::bake(&scene, eyes, &[], &config(), shard, &|_, _| {}).unwrap_err();
    assert_eq!(run(&[], Shard::WHOLE), PvsError::NoViewpoints);
    assert!(matches!(
        run(&[Vec3::NAN], Shard::WHOLE),
        PvsError::BadViewpoint { index: 0, .. }
    ));
    assert!(matches!(
        run(&eyes, Shard { index: 2, count: 2 }),
        PvsError::BadShard { .. }
    ));
    let far = [Vec3::ZERO, Vec3::new(1e6, 0.0, 1e6)];
    assert!(matches!(run(&far, Shard::WHOLE), PvsError::TooManyCells { .. }));
}
