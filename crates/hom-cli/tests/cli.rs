//! The `hom` command as a user meets it: exit codes, messages, reports.

use std::process::{Command, Output};

fn hom(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_hom"))
        .args(args)
        .output()
        .expect("the hom binary runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Bad input: exit code 2, one line naming the problem, no panic or backtrace.
fn assert_clean_failure(o: &Output, needle: &str) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(2), "stderr: {err}");
    assert!(err.contains(needle), "expected '{needle}' in: {err}");
    assert!(!err.contains("panicked") && !err.contains("RUST_BACKTRACE"), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line expected: {err}");
}

#[test]
fn unknown_scene_is_a_one_line_error() {
    let o = hom(&["walk", "--scene", "no-such-scene", "--culler", "frustum"]);
    assert_clean_failure(&o, "no-such-scene");
}

#[test]
fn unknown_culler_names_the_choices() {
    let o = hom(&["walk", "--scene", "spheres", "--culler", "magic", "--frames", "1"]);
    assert_clean_failure(&o, "frustum");
}

#[test]
fn absurd_viewport_and_frames_are_rejected() {
    let o = hom(&["walk", "--scene", "spheres", "--width", "0"]);
    assert_clean_failure(&o, "viewport");
    let o = hom(&["walk", "--scene", "spheres", "--width", "100000"]);
    assert_clean_failure(&o, "viewport");
    let o = hom(&["walk", "--scene", "spheres", "--frames", "0"]);
    assert_clean_failure(&o, "--frames");
}

#[test]
fn malformed_camera_path_and_scene_files_are_rejected() {
    let dir = std::env::temp_dir().join(format!("hom-cli-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad_json = dir.join("path.json");
    std::fs::write(&bad_json, "{\"frames\": [ {\"eye\": [0,0,0]} ]").unwrap();
    let o = hom(&[
        "walk",
        "--scene",
        "spheres",
        "--camera-path",
        bad_json.to_str().unwrap(),
    ]);
    assert_clean_failure(&o, "path.json");
    let nan_path = dir.join("nan.json");
    std::fs::write(&nan_path, r#"{"frames":[{"eye":[0,0,0],"target":[0,0,0]}]}"#).unwrap();
    let o = hom(&[
        "walk",
        "--scene",
        "spheres",
        "--camera-path",
        nan_path.to_str().unwrap(),
    ]);
    assert_clean_failure(&o, "frame 0");
    let missing = dir.join("missing.obj");
    let o = hom(&["scene", "info", "--scene", missing.to_str().unwrap()]);
    assert_clean_failure(&o, "missing.obj");
    let bad_obj = dir.join("bad.obj");
    std::fs::write(&bad_obj, "v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n").unwrap();
    let o = hom(&["scene", "info", "--scene", bad_obj.to_str().unwrap()]);
    assert_clean_failure(&o, "bad.obj");
    let empty = dir.join("empty.obj");
    std::fs::write(&empty, "# nothing\n").unwrap();
    let o = hom(&["scene", "info", "--scene", empty.to_str().unwrap()]);
    assert_clean_failure(&o, "empty.obj");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn walk_report_has_header_frames_and_summary_with_no_false_culls() {
    let dir = std::env::temp_dir().join(format!("hom-cli-walk-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let report = dir.join("r.jsonl");
    let o = hom(&[
        "walk",
        "--scene",
        "spheres",
        "--culler",
        "frustum",
        "--oracle",
        "--frames",
        "6",
        "--width",
        "160",
        "--height",
        "120",
        "--report",
        report.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&report).unwrap();
    let lines: Vec<serde_json::Value> = text.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(lines.len(), 8);
    assert_eq!(lines[0]["type"], "header");
    assert_eq!(lines[0]["culler"], "frustum");
    assert_eq!(lines[0]["width"], 160);
    for f in &lines[1..7] {
        assert_eq!(f["type"], "frame");
        assert_eq!(f["false_culls"].as_array().unwrap().len(), 0);
        assert_eq!(f["view_proj"].as_array().unwrap().len(), 16);
        assert!(!f["oracle_visible"].as_array().unwrap().is_empty());
    }
    assert_eq!(lines[7]["type"], "summary");
    assert_eq!(lines[7]["false_culls"], 0);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn pvs_needs_a_quake_map() {
    let o = hom(&["walk", "--scene", "spheres", "--pvs", "--frames", "1"]);
    assert_clean_failure(&o, "--pvs needs a Quake 3 map");
}

/// OpenArena's maps, or `None` (saying so) when `scripts/fetch-scenes.sh
/// --tests-only` has not fetched them.
fn openarena_maps() -> Option<std::path::PathBuf> {
    let pk3 = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../.cache/scenes/debian/usr/share/games/openarena/baseoa/pak1-maps.pk3");
    if !pk3.exists() {
        eprintln!(
            "skipping: {} is missing; run scripts/fetch-scenes.sh --tests-only",
            pk3.display()
        );
        return None;
    }
    Some(pk3)
}

/// `--pvs` on a real map (skips when `scripts/fetch-scenes.sh --tests-only` has not run):
/// frame and summary lines keep their fields and gain the yardstick's.
#[test]
fn walk_pvs_adds_pvs_fields_to_the_report() {
    let Some(pk3) = openarena_maps() else { return };
    let dir = std::env::temp_dir().join(format!("hom-cli-pvs-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let report = dir.join("r.jsonl");
    let spec = format!("{}:oa_dm1", pk3.display());
    let o = hom(&[
        "walk",
        "--scene",
        &spec,
        "--pvs",
        "--frames",
        "4",
        "--width",
        "96",
        "--height",
        "96",
        "--report",
        report.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("PVS then HOM"), "{stdout}");
    let text = std::fs::read_to_string(&report).unwrap();
    let lines: Vec<serde_json::Value> = text.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(lines.len(), 6);
    for f in &lines[1..5] {
        assert_eq!(f["type"], "frame");
        assert_eq!(f["false_culls"].as_array().unwrap().len(), 0);
        assert_eq!(f["pvs_violations"].as_array().unwrap().len(), 0);
        assert!(f["pvs_camera_cluster"].is_i64(), "{f}");
        let t = |k: &str| f[k].as_u64().unwrap();
        assert_eq!(t("pvs_triangles_hom"), t("triangles_drawn"));
        assert!(t("pvs_triangles_oracle") <= t("pvs_triangles_pvs_hom"));
        assert!(t("pvs_triangles_pvs") <= t("pvs_triangles_frustum"));
    }
    assert_eq!(lines[5]["type"], "summary");
    assert_eq!(lines[5]["false_culls"], 0);
    assert_eq!(lines[5]["pvs_violations"], 0);
    assert_eq!(lines[5]["pvs_frames"], 4);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn raster_bench_without_inputs_is_a_one_line_error() {
    let dir = std::env::temp_dir().join(format!("hom-cli-raster-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let o = hom(&["bench", "raster", "--data", dir.to_str().unwrap()]);
    assert_clean_failure(&o, "no .mocscene");
    let o = hom(&["bench", "raster", "--data", "/no/such/folder"]);
    assert_clean_failure(&o, "/no/such/folder");
    std::fs::remove_dir_all(&dir).unwrap();
    // The walk's flags are named, not ignored.
    let o = hom(&["bench", "raster", "--scenes", "city"]);
    assert_clean_failure(&o, "does not take --scenes");
}

/// A one-triangle `.mocscene` with one rectangle behind it (the format of
/// `hom_scene::moc`; hom-walk's raster bench test has a richer one).
fn tiny_mocscene() -> Vec<u8> {
    let v: [[f32; 4]; 3] = [[-2.0, -2.0, 0.0, 2.0], [6.0, -2.0, 0.0, 2.0], [-2.0, 6.0, 0.0, 2.0]];
    let t: [[u32; 3]; 1] = [[0, 1, 2]];
    let r: [[f32; 5]; 1] = [[-0.5, -0.5, 0.5, 0.5, 10.0]];
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
fn raster_bench_json_writes_exactly_the_file_named() {
    let dir = std::env::temp_dir().join(format!("hom-cli-raster-json-{}", std::process::id()));
    let data = dir.join("data");
    std::fs::create_dir_all(&data).unwrap();
    std::fs::write(data.join("tiny.mocscene"), tiny_mocscene()).unwrap();
    let json = dir.join("X").join("y.json");
    let o = hom(&[
        "bench",
        "raster",
        "--data",
        data.to_str().unwrap(),
        "--runs",
        "1",
        "--raster-threads",
        "1",
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert!(report.is_object(), "{report}");
    let written: Vec<_> = std::fs::read_dir(dir.join("X"))
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(written, ["y.json"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// [`assert_clean_failure`] whose message says `cause` exactly once: errors
/// print their source in the chain, not also in their own message.
fn assert_cause_once(o: &Output, cause: &str) {
    assert_clean_failure(o, cause);
    let err = stderr(o);
    assert_eq!(err.matches(cause).count(), 1, "cause said more than once: {err}");
}

#[test]
fn writing_into_a_missing_folder_names_the_cause_once() {
    let small = ["--scene", "spheres", "--width", "32", "--height", "24"];
    let png = "/nonexistent-hom-dir/x.png";
    let o = hom(&[&["render", "--out", png][..], &small].concat());
    assert_cause_once(&o, "os error 2");
    assert!(stderr(&o).contains("could not write PNG '/nonexistent-hom-dir/x.png'"));
    let o = hom(&[&["render", "--out", png, "--false-colour"][..], &small].concat());
    assert_cause_once(&o, "os error 2");
    let o = hom(&[
        "scene",
        "export",
        "--scene",
        "spheres",
        "--out",
        "/nonexistent-hom-dir/x.obj",
    ]);
    assert_cause_once(&o, "os error 2");
}

#[test]
fn a_bad_viewport_names_the_cause_once() {
    let o = hom(&["walk", "--scene", "spheres", "--width", "0"]);
    assert_cause_once(&o, "viewport must be");
    let o = hom(&["render", "--scene", "spheres", "--height", "0", "--out", "x.png"]);
    assert_cause_once(&o, "viewport must be");
    let o = hom(&["bench", "--scenes", "spheres", "--width", "0"]);
    assert_cause_once(&o, "viewport must be");
}

#[test]
fn bad_camera_path_files_name_the_cause_once() {
    let dir = std::env::temp_dir().join(format!("hom-cli-path-once-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let walk = |path: &std::path::Path| hom(&["walk", "--scene", "spheres", "--camera-path", path.to_str().unwrap()]);
    let bad_json = dir.join("path.json");
    std::fs::write(&bad_json, "{\"frames\": [ {\"eye\": [0,0,0]} ]").unwrap();
    assert_cause_once(&walk(&bad_json), "missing field `target`");
    let no_view = dir.join("no-view.json");
    std::fs::write(&no_view, r#"{"frames":[{"eye":[0,0,0],"target":[0,0,0]}]}"#).unwrap();
    assert_cause_once(&walk(&no_view), "no view direction");
    assert_cause_once(&walk(&dir.join("missing.json")), "os error 2");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn unreadable_and_missing_scene_files_name_the_cause_once() {
    let dir = std::env::temp_dir().join(format!("hom-cli-scene-once-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // A folder with a scene's name exists but cannot be read as a file.
    for name in ["folder.obj", "folder.bsp", "folder.pk3"] {
        let folder = dir.join(name);
        std::fs::create_dir_all(&folder).unwrap();
        let o = hom(&["scene", "info", "--scene", folder.to_str().unwrap()]);
        assert_cause_once(&o, "os error 21");
    }
    let empty = dir.join("empty.obj");
    std::fs::write(&empty, "# nothing\n").unwrap();
    let o = hom(&["scene", "info", "--scene", empty.to_str().unwrap()]);
    assert_cause_once(&o, "has no objects");
    // --pvs opens the map file itself: a missing one is an I/O error.
    let missing = dir.join("missing.pk3");
    let o = hom(&["walk", "--scene", &format!("{}:x", missing.display()), "--pvs"]);
    assert_cause_once(&o, "os error 2");
    let o = hom(&["bench", "--scenes", missing.to_str().unwrap()]);
    assert_cause_once(&o, "no built-in scene or file named");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn occluders_info_checks_the_walk_frames_it_is_asked_for() {
    let o = hom(&[
        "occluders",
        "info",
        "--scene",
        "spheres",
        "--summary",
        "--walk-frames",
        "3",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    let walk = out.lines().find(|l| l.starts_with("walk:")).expect("a walk line");
    assert!(walk.contains("3 of 260 frames"), "{walk}");
    assert!(walk.contains("violations 0 samples"), "{walk}");
    // Without the flag there is no walk line; a bad side is a one-line error.
    let o = hom(&["occluders", "info", "--scene", "spheres", "--summary"]);
    assert!(!String::from_utf8_lossy(&o.stdout).contains("walk:"));
    assert_clean_failure(
        &hom(&["occluders", "info", "--scene", "spheres", "--side", "2"]),
        "--side",
    );
}

/// A real map's PVS with portal cells (skips without the fetched maps):
/// the bake and `info` say so, the walk with it culls nothing the oracle
/// sees, and without `--portals on` they are left out.
#[test]
fn pvs_bake_adds_a_maps_portal_cells() {
    let Some(pk3) = openarena_maps() else { return };
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("pvs_portals_cli");
    std::fs::create_dir_all(&dir).unwrap();
    let spec = format!("{}:oa_dm1", pk3.display());
    let (with, without) = (dir.join("with.pvs"), dir.join("without.pvs"));
    let o = hom(&[
        "pvs",
        "bake",
        "--scene",
        &spec,
        "--out",
        with.to_str().unwrap(),
        "--portals",
        "on",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        String::from_utf8_lossy(&o.stdout).contains("portal cells"),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    let o = hom(&["pvs", "bake", "--scene", &spec, "--out", without.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!String::from_utf8_lossy(&o.stdout).contains("portal cells"));
    let o = hom(&["pvs", "info", with.to_str().unwrap()]);
    assert!(
        String::from_utf8_lossy(&o.stdout).contains("portal cells, hiding"),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    let o = hom(&[
        "walk",
        "--scene",
        &spec,
        "--culler",
        "frustum",
        "--pvs-file",
        with.to_str().unwrap(),
        "--oracle",
        "--frames",
        "6",
        "--width",
        "96",
        "--height",
        "96",
    ]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(text.contains(", 0 oracle-visible objects outside the PVS"), "{text}");
}

/// A map's portal cells hide nothing a camera in the cells sees (skips
/// without the fetched maps): oa_dm2 has pockets sealed inside its walls
/// and walls its drawn faces leave open, where random viewpoints in the
/// cells saw objects the portals hid until sight was followed from the
/// space the path reaches and into the solid space behind open walls.
#[test]
fn pvs_portal_cells_pass_the_check_on_a_real_map() {
    let Some(pk3) = openarena_maps() else { return };
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("pvs_portals_check");
    std::fs::create_dir_all(&dir).unwrap();
    let spec = format!("{}:oa_dm2", pk3.display());
    let pvs = dir.join("oa_dm2.pvs");
    let pvs = pvs.to_str().unwrap();
    let o = hom(&["pvs", "bake", "--scene", &spec, "--out", pvs, "--portals", "on"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = hom(&[
        "pvs", "check", "--scene", &spec, "--pvs", pvs, "--points", "1000", "--cells", "1",
    ]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{text}{}", stderr(&o));
    assert!(text.contains("0 hidden objects seen"), "{text}");
}

#[test]
fn pvs_bake_shards_merge_info_walk_and_refusals() {
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("pvs_cli");
    std::fs::create_dir_all(&dir).unwrap();
    let path = |name: &str| dir.join(name).to_string_lossy().into_owned();
    let (whole, s0, s1, merged) = (path("whole.pvs"), path("s0.pvs"), path("s1.pvs"), path("merged.pvs"));
    for (out, shard) in [(&whole, None), (&s0, Some("0/2")), (&s1, Some("1/2"))] {
        let mut args = vec![
            "pvs",
            "bake",
            "--scene",
            "spheres",
            "--out",
            out.as_str(),
            "--cell-size",
            "8",
        ];
        if let Some(s) = shard {
            args.extend(["--shard", s]);
        }
        let o = hom(&args);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let o = hom(&["pvs", "merge", "--out", &merged, &s1, &s0]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(&merged).unwrap(), std::fs::read(&whole).unwrap());
    let o = hom(&["pvs", "info", &whole]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success() && text.contains("cells") && text.contains("cell size 8 m"),
        "{text}"
    );
    let o = hom(&[
        "walk",
        "--scene",
        "spheres",
        "--culler",
        "frustum",
        "--pvs-file",
        &whole,
        "--frames",
        "3",
        "--oracle",
    ]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        text.contains("pvs ") && text.contains("oracle-visible objects outside the PVS"),
        "{text}"
    );
    // Refusals: another scene, a shard, a file that is no PVS, a shard missing.
    let o = hom(&["walk", "--scene", "office", "--pvs-file", &whole, "--frames", "1"]);
    assert_clean_failure(&o, "baked for another scene");
    let o = hom(&["walk", "--scene", "spheres", "--pvs-file", &s0, "--frames", "1"]);
    assert_clean_failure(&o, "merge the shards first");
    let junk = path("junk.pvs");
    std::fs::write(&junk, b"hello").unwrap();
    assert_clean_failure(&hom(&["pvs", "info", &junk]), "not a hom PVS file");
    assert_clean_failure(&hom(&["pvs", "merge", "--out", &merged, &s0]), "shard 1/2 is missing");
}

/// `--shard auto/N` as a batch system runs it: Kubernetes' index for one
/// shard, a Slurm array (first index 1) for the other; merged they are the
/// whole bake, byte for byte. Without an index, or past N, a one-line error.
#[test]
fn pvs_bake_auto_shards_from_kubernetes_and_slurm() {
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("pvs_auto");
    std::fs::create_dir_all(&dir).unwrap();
    let path = |name: &str| dir.join(name).to_string_lossy().into_owned();
    let (whole, s0, s1, merged) = (path("whole.pvs"), path("s0.pvs"), path("s1.pvs"), path("merged.pvs"));
    let bake = |out: &str, shard: &str, env: &[(&str, &str)]| {
        Command::new(env!("CARGO_BIN_EXE_hom"))
            .args(["pvs", "bake", "--scene", "spheres", "--cell-size", "8", "--out", out])
            .args(["--shard", shard])
            .env_remove("JOB_COMPLETION_INDEX")
            .env_remove("SLURM_ARRAY_TASK_ID")
            .env_remove("SLURM_ARRAY_TASK_MIN")
            .envs(env.iter().copied())
            .output()
            .expect("the hom binary runs")
    };
    let o = bake(&whole, "0/1", &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = bake(&s0, "auto/2", &[("JOB_COMPLETION_INDEX", "0")]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("shard 0/2 (from JOB_COMPLETION_INDEX)"));
    let o = bake(
        &s1,
        "auto/2",
        &[("SLURM_ARRAY_TASK_ID", "2"), ("SLURM_ARRAY_TASK_MIN", "1")],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let o = hom(&["pvs", "merge", "--out", &merged, &s0, &s1]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(&merged).unwrap(), std::fs::read(&whole).unwrap());
    assert_clean_failure(&bake(&s0, "auto/2", &[]), "neither is set");
    assert_clean_failure(&bake(&s0, "auto/2", &[("JOB_COMPLETION_INDEX", "2")]), "not below 2");
    // Malformed values are refused by the argument parser (its usage hint follows).
    for (bad, needle) in [("auto/0", "at least 1"), ("some/2", "not a shard index")] {
        let o = bake(&s0, bad, &[]);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(
            stderr(&o).contains(needle) && !stderr(&o).contains("panicked"),
            "{}",
            stderr(&o)
        );
    }
}

#[test]
fn walk_lod_adds_lod_fields_render_lod_writes_two_pictures_and_bad_lod_flags_are_refused() {
    let dir = std::env::temp_dir().join(format!("hom-cli-lod-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let report = dir.join("lod.jsonl");
    let view = ["--scene", "spheres", "--width", "160", "--height", "120"];
    let walk = |extra: &[&str]| {
        let mut args = vec!["walk"];
        args.extend_from_slice(&view);
        args.extend_from_slice(&["--frames", "4", "--culler", "hom", "--lod"]);
        args.extend_from_slice(extra);
        hom(&args)
    };
    let o = walk(&["--oracle", "--report", report.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&report).unwrap();
    let lines: Vec<serde_json::Value> = text.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(lines.len(), 6);
    for f in &lines[1..5] {
        assert!(f["lod_triangles"].as_u64().unwrap() > 0);
        assert!(f["lod_max_error_px"].as_f64().unwrap() <= 1.0);
        assert_eq!(f["lod_guidance_pixels_changed"], 0);
        assert!(f["stages_ms"]["lod"].as_f64().is_some());
    }
    assert!(lines[5]["lod_triangles"].as_u64().unwrap() > 0);
    assert!(lines[5]["lod_view_only_triangles"].as_u64().is_some());

    let out = dir.join("frame.png");
    let mut args = vec!["render"];
    args.extend_from_slice(&view);
    args.extend_from_slice(&["--frame", "2", "--lod", "--out", out.to_str().unwrap()]);
    let o = hom(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(out.exists() && dir.join("frame-above.png").exists());

    assert_clean_failure(&walk(&["--lod-error", "0"]), "error threshold");
    assert_clean_failure(&walk(&["--lod-error", "NaN"]), "error threshold");
    assert_clean_failure(&walk(&["--lod-budget", "0"]), "budget");
    let mut args = vec!["walk"];
    args.extend_from_slice(&view);
    args.extend_from_slice(&["--lod-budget", "100"]);
    assert_clean_failure(&hom(&args), "--lod-budget needs --lod");
    std::fs::remove_dir_all(&dir).ok();
}

/// A reader that leaves early (`hom scenes | head -1`) ends hom quietly, not with a panic.
#[test]
fn a_closed_output_pipe_is_not_a_panic() {
    use std::process::Stdio;
    let mut child = Command::new(env!("CARGO_BIN_EXE_hom"))
        .arg("scenes")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the hom binary runs");
    // Close the read end before hom has built the scenes it lists.
    drop(child.stdout.take());
    let out = child.wait_with_output().expect("hom ends");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert!(out.status.success(), "{:?}: {err}", out.status);
}

#[test]
fn bench_camera_path_walks_one_scene() {
    let o = hom(&[
        "bench",
        "--scenes",
        "spheres,office",
        "--camera-path",
        "path.json",
        "--frames",
        "1",
    ]);
    assert_clean_failure(&o, "--camera-path walks one scene; 2 were given");
}

#[test]
fn clusters_off_keeps_whole_objects_in_info_export_and_bench() {
    let dir = tempfile::tempdir().unwrap();
    // A 40 m ground of 3,200 triangles in an OBJ file of its own.
    let obj = dir.path().join("ground.obj");
    std::fs::write(&obj, hom_testkit::grid_obj(40)).unwrap();
    let obj = obj.to_str().unwrap();
    // "objects:    N in M clusters (D dynamic)": (N, M).
    let objects = |o: &Output| {
        assert!(o.status.success(), "{}", stderr(o));
        let out = String::from_utf8_lossy(&o.stdout).into_owned();
        let line = out
            .lines()
            .find(|l| l.starts_with("objects:"))
            .expect("an objects line")
            .to_owned();
        let n = |k: usize| line.split_whitespace().nth(k).unwrap().parse::<usize>().unwrap();
        (n(1), n(3))
    };
    let (one, on) = objects(&hom(&["scene", "info", "--scene", obj]));
    assert!(on >= 50, "3,200 triangles in clusters of at most 64: {on} clusters");
    assert_eq!(one, 1, "the clusters are of one object, the file's");
    assert_eq!(
        objects(&hom(&["scene", "info", "--scene", obj, "--clusters", "off"])),
        (1, 1)
    );
    // `--clusters` alone is `on`.
    assert_eq!(objects(&hom(&["scene", "info", "--scene", obj, "--clusters"])), (1, on));

    // Export writes one `o` per cluster, or per object with `--clusters off`.
    let out = dir.path().join("out.obj");
    let count_o = |args: &[&str]| {
        let o = hom(args);
        assert!(o.status.success(), "{}", stderr(&o));
        let text = std::fs::read_to_string(&out).unwrap();
        text.lines().filter(|l| l.starts_with("o ")).count()
    };
    let out_s = out.to_str().unwrap();
    assert_eq!(
        count_o(&["scene", "export", "--scene", obj, "--out", out_s, "--clusters"]),
        on
    );
    assert_eq!(
        count_o(&["scene", "export", "--scene", obj, "--out", out_s, "--clusters", "off"]),
        1
    );

    // Bench records the choice per scene.
    let json = dir.path().join("bench.json");
    let o = hom(&[
        "bench",
        "--scenes",
        obj,
        "--cullers",
        "frustum",
        "--frames",
        "2",
        "--width",
        "64",
        "--height",
        "64",
        "--clusters",
        "off",
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(report["scenes"][0]["clusters"], serde_json::json!(false));
    assert_eq!(report["scenes"][0]["objects"], serde_json::json!(1));
    assert_eq!(report["scenes"][0]["cluster_count"], serde_json::json!(1));
}
