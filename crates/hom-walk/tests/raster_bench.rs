//! `hom bench raster` end to end on a hand-made `.mocscene` whose answers are obvious.

use hom_walk::raster_bench::{run_raster_bench, RasterBenchOptions, SCENE_RESOLUTIONS};

/// One counter-clockwise (front-facing) triangle over the whole screen at
/// w = 2, and a clockwise one at w = 1.5 over the left half (culled as a back
/// face), with three rectangles: behind the first, in front of it, and behind
/// it but reaching past the screen's right edge (clamped: still hidden). (One
/// triangle, not a quad: the inner setup rule leaves a shared edge's samples
/// uncovered when the edge runs exactly through pixel centres.)
fn scene_bytes() -> Vec<u8> {
    let v: [[f32; 4]; 6] = [
        [-2.0, -2.0, 0.0, 2.0],
        [6.0, -2.0, 0.0, 2.0],
        [-2.0, 6.0, 0.0, 2.0],
        [-1.5, -1.5, 0.0, 1.5],
        [0.0, 1.5, 0.0, 1.5],
        [0.0, -1.5, 0.0, 1.5],
    ];
    let t: [[u32; 3]; 2] = [[0, 1, 2], [3, 4, 5]];
    let r: [[f32; 5]; 4] = [
        [-0.5, -0.5, 0.5, 0.5, 10.0],
        [-0.2, -0.2, 0.2, 0.2, 1.2],
        [0.5, -0.1, 1.4, 0.1, 3.0],
        // Behind the back face, in front of the big triangle: visible.
        [-0.4, -0.1, -0.1, 0.1, 1.8],
    ];
    let mut b = b"MOCSCN01".to_vec();
    for n in [v.len(), t.len(), r.len()] {
        b.extend((n as u32).to_le_bytes());
    }
    b.extend(1.0f32.to_le_bytes());
    b.extend(v.iter().flatten().flat_map(|f| f.to_le_bytes()));
    b.extend(t.iter().flatten().flat_map(|i| i.to_le_bytes()));
    b.extend(r.iter().flatten().flat_map(|f| f.to_le_bytes()));
    b
}

#[test]
fn answers_match_the_obvious_truth_at_every_resolution() {
    let dir = std::env::temp_dir().join(format!("hom-raster-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("quad.mocscene"), scene_bytes()).unwrap();
    for (w, h) in SCENE_RESOLUTIONS {
        std::fs::write(dir.join(format!("quad_exact_{w}x{h}.res")), [1u8, 0, 1, 0]).unwrap();
        // A "peer" that missed the third rectangle.
        std::fs::write(dir.join(format!("quad_moc_{w}x{h}.res")), [1u8, 0, 0, 0]).unwrap();
    }
    let options = RasterBenchOptions {
        data: dir.clone(),
        runs: 1,
        threads: vec![1, 2],
    };
    let report = run_raster_bench(&options, |_| {}).unwrap();
    assert_eq!(report.rows.len(), SCENE_RESOLUTIONS.len() * 2);
    for row in &report.rows {
        assert_eq!(row.triangles, 2);
        if row.threads != 1 {
            assert!(row.queries.is_none());
            continue;
        }
        let q = row.queries.as_ref().expect("answers exist");
        assert_eq!((q.hidden, q.wrong_occluded, q.found), (2, 0, 2), "{row:?}");
        assert_eq!((q.peer_found, q.peer_wrong_occluded), (Some(1), Some(0)));
        let m = row.map_queries.as_ref().expect("answers exist");
        assert_eq!(m.wrong_occluded, 0, "{row:?}");
        let k = row.masked_queries.as_ref().expect("answers exist");
        assert_eq!(
            (k.wrong_occluded, k.found),
            (0, 2),
            "{row:?}: a full-screen quad hides both"
        );
    }
    let table = report.table();
    assert!(table.contains("| quad | 256×256 | 2 | 1 |"), "{table}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_empty_folder_and_bad_answers_are_errors() {
    let dir = std::env::temp_dir().join(format!("hom-raster-bench-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let options = RasterBenchOptions {
        data: dir.clone(),
        runs: 1,
        threads: vec![1],
    };
    let e = run_raster_bench(&options, |_| {}).unwrap_err();
    assert!(e.to_string().contains("no .mocscene"), "{e}");
    std::fs::write(dir.join("quad.mocscene"), scene_bytes()).unwrap();
    std::fs::write(dir.join("quad_exact_1920x1080.res"), [1u8, 0]).unwrap();
    let e = run_raster_bench(&options, |_| {}).unwrap_err();
    assert!(e.to_string().contains("2 answers for 4 rectangles"), "{e}");
    let zero_runs = RasterBenchOptions { runs: 0, ..options };
    assert!(run_raster_bench(&zero_runs, |_| {}).is_err());
    std::fs::remove_dir_all(&dir).unwrap();
}
