//! Quake 3 maps from the fetched cache (`scripts/fetch-scenes.sh --tests-only`).
//! Skips, saying why, when the cache is missing.

use hom_scene::bsp::{self, BspOptions};
use std::path::PathBuf;

fn cache() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../.cache/scenes/debian/usr/share/games")
}

#[test]
fn openarena_maps_load_with_sane_counts_and_spawns_in_clusters() {
    let pk3 = cache().join("openarena/baseoa/pak1-maps.pk3");
    if !pk3.exists() {
        eprintln!(
            "skipping: {} is missing; run scripts/fetch-scenes.sh --tests-only",
            pk3.display()
        );
        return;
    }
    let maps = bsp::pk3_maps(&pk3).unwrap();
    assert!(maps.len() >= 5, "{maps:?}");
    for name in [
        "oa_dm1",
        "oa_dm2",
        "oa_dm4",
        "oa_ctf2",
        "aggressor",
        "oa_dm5",
        "ctf_inyard",
    ] {
        let options = BspOptions {
            map: Some(name.into()),
            ..BspOptions::default()
        };
        let t = std::time::Instant::now();
        let m = bsp::load(&pk3, &options).unwrap_or_else(|e| panic!("{e}"));
        let s = &m.scene;
        let see_through = s.objects().iter().filter(|o| !o.occluder).count();
        let b = s.bounds();
        println!(
            "{name}: {} objects ({see_through} see-through), {} triangles, {} spawns, {} clusters, bounds {:?}..{:?} ({:.2} s)",
            s.objects().len(),
            s.triangle_count(),
            m.spawns.len(),
            m.cluster_count(),
            b.min,
            b.max,
            t.elapsed().as_secs_f32()
        );
        assert!(s.objects().len() >= 5 && s.objects().len() < 5000, "{name}");
        assert!(s.triangle_count() > 2_000 && s.triangle_count() < 2_000_000, "{name}");
        // Metres: a deathmatch arena is tens of metres across, not thousands.
        let size = b.extent().max_element();
        assert!(size > 10.0 && size < 500.0, "{name}: {size} m");
        assert!(m.spawns.len() >= 2, "{name}");
        if m.cluster_count() == 0 {
            println!("{name}: no visibility data (everything visible)");
        }
        for sp in &m.spawns {
            let eye = sp.origin + glam::Vec3::Y * m.eye_height;
            assert!(m.cluster_of(sp.origin).is_some(), "{name}: spawn {sp:?} in no cluster");
            assert!(m.cluster_of(eye).is_some(), "{name}: eye above {sp:?} in no cluster");
        }
        let path = m.camera_path().unwrap();
        path.validate(name).unwrap();
        assert!(path.frames.len() > 30);
        assert_eq!(m.object_clusters.len(), s.objects().len());
        assert!(m.object_clusters.iter().filter(|c| !c.is_empty()).count() * 10 >= s.objects().len() * 9);
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig { cases: 300, failure_persistence: None, ..Default::default() })]

    /// A real map with flipped bytes and huge u32 values: an error or a map, never a panic.
    #[test]
    fn mutated_real_map_never_panics(
        flips in proptest::collection::vec((proptest::prelude::any::<proptest::sample::Index>(), 1u8..), 1..16),
        words in proptest::collection::vec((proptest::prelude::any::<proptest::sample::Index>(), proptest::prelude::any::<u32>()), 0..4),
    ) {
        let Some(original) = real_map() else { return Ok(()); };
        let mut b = original.clone();
        for (at, v) in flips {
            let i = at.index(b.len());
            b[i] ^= v;
        }
        for (at, v) in words {
            let i = at.index(b.len() / 4) * 4;
            b[i..i + 4].copy_from_slice(&v.to_le_bytes());
        }
        let _ = bsp::parse(&b, "mutant", &BspOptions::default());
    }
}

/// oa_dm4's bytes, read once; `None` (with a message) when the cache is missing.
fn real_map() -> Option<&'static Vec<u8>> {
    static MAP: std::sync::OnceLock<Option<Vec<u8>>> = std::sync::OnceLock::new();
    MAP.get_or_init(|| {
        let pk3 = cache().join("openarena/baseoa/pak1-maps.pk3");
        if !pk3.exists() {
            eprintln!(
                "skipping: {} is missing; run scripts/fetch-scenes.sh --tests-only",
                pk3.display()
            );
            return None;
        }
        let file = std::fs::File::open(&pk3).unwrap();
        let options = BspOptions {
            map: Some("oa_dm4".into()),
            ..BspOptions::default()
        };
        Some(bsp::read_pk3(std::io::BufReader::new(file), &options).unwrap().1)
    })
    .as_ref()
}

/// Every map of every fetched pk3 (the full fetch: 140 maps, OpenArena and Nexuiz)
/// loads, with every spawn point in a cluster. Run with `--nocapture` for the table.
#[test]
fn every_fetched_map_loads_or_says_why() {
    let pk3s = [
        "openarena/baseoa/pak1-maps.pk3",
        "openarena/baseoa/pak6-patch088.pk3",
        "openarena/baseoa/z_oacmp-volume1-v3.pk3",
        "nexuiz/data/data.pk3",
    ];
    let mut failures = Vec::new();
    for rel in pk3s {
        let pk3 = cache().join(rel);
        if !pk3.exists() {
            eprintln!("skipping {rel}: missing; run scripts/fetch-scenes.sh");
            continue;
        }
        for name in bsp::pk3_maps(&pk3).unwrap() {
            let options = BspOptions {
                map: Some(name.clone()),
                ..BspOptions::default()
            };
            match bsp::load(&pk3, &options) {
                Ok(m) => {
                    let lost = m.spawns.iter().filter(|s| m.cluster_of(s.origin).is_none()).count();
                    if lost > 0 {
                        failures.push(format!("{rel}:{name}: {lost} spawn points in no cluster"));
                    }
                    println!(
                        "{rel}:{name}: {} objects, {} triangles, {} spawns, {} clusters, {} spawns outside clusters",
                        m.scene.objects().len(),
                        m.scene.triangle_count(),
                        m.spawns.len(),
                        m.cluster_count(),
                        lost
                    )
                }
                Err(e) => {
                    println!("{rel}:{name}: ERROR {e}");
                    failures.push(e.to_string());
                }
            }
        }
    }
    println!("{} failures", failures.len());
    assert!(failures.is_empty(), "{failures:#?}");
}
