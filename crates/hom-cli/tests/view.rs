//! `hom view` and `hom walk --renderer wgpu` as a user meets them: the
//! window under Xvfb plays a path and writes a screenshot, headless frames
//! land as PNGs, a machine with no display gets a one-line error and exit 2.
//! The window and wgpu need Xvfb and a Vulkan driver (lavapipe): where they
//! are missing these tests say so and skip, unless `HOM_VIEW_REQUIRE_GPU`
//! is set (CI sets it, after `scripts/install-graphics.sh`).
#![cfg(feature = "view")]

use std::path::Path;
use std::process::{Command, Output};

fn hom() -> Command {
    Command::new(env!("CARGO_BIN_EXE_hom"))
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A folder for a test that draws, with Mesa's runtime folder in it, where
/// the graphics it needs are here; `None` skips (and says why).
fn graphics(what: &str) -> Option<tempfile::TempDir> {
    let xvfb = Command::new("xvfb-run").arg("--help").output().is_ok();
    let vulkan = Path::new("/usr/share/vulkan/icd.d").is_dir();
    if xvfb && vulkan {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join("xdg")).unwrap();
        return Some(dir);
    }
    assert!(
        std::env::var_os("HOM_VIEW_REQUIRE_GPU").is_none(),
        "{what}: Xvfb or a Vulkan driver is missing (run scripts/install-graphics.sh)"
    );
    eprintln!("skipped {what}: Xvfb or a Vulkan driver is missing (scripts/install-graphics.sh installs them)");
    None
}

/// Runs `command` with `dir`'s runtime folder (Mesa's window-system code wants one).
fn run_drawing(dir: &tempfile::TempDir, command: &mut Command) -> Output {
    command.env("XDG_RUNTIME_DIR", dir.path().join("xdg")).output().unwrap()
}

#[test]
fn with_no_display_the_window_says_so_and_exits_2() {
    let o = hom()
        .args(["view", "--scene", "spheres"])
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("no display") && err.contains("--headless"), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
}

#[test]
fn the_window_plays_a_path_under_xvfb_and_writes_a_screenshot() {
    let Some(dir) = graphics("the window test") else {
        return;
    };
    let shot = dir.path().join("office.png");
    let o = run_drawing(
        &dir,
        Command::new("xvfb-run")
            .args(["-a", "-s", "-screen 0 800x600x24"])
            .arg(env!("CARGO_BIN_EXE_hom"))
            .args([
                "view", "--scene", "office", "--width", "320", "--height", "240", "--frames", "8",
            ])
            .arg("--screenshot")
            .arg(&shot),
    );
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("frames per second"), "{err}");
    let image = image::open(&shot).unwrap().to_rgba8();
    assert_eq!(image.dimensions(), (320, 240));
    // Drawn, not cleared: more than a handful of colours.
    let colours: std::collections::HashSet<[u8; 4]> = image.pixels().map(|p| p.0).collect();
    assert!(colours.len() > 20, "{} colours", colours.len());
}

#[test]
fn headless_frames_land_as_pngs() {
    let Some(dir) = graphics("the headless test") else {
        return;
    };
    let out = dir.path().join("frames");
    let o = run_drawing(
        &dir,
        hom()
            .args([
                "view",
                "--headless",
                "--scene",
                "city",
                "--width",
                "256",
                "--height",
                "160",
                "--frames",
                "3",
            ])
            .args(["--false-colour", "--out"])
            .arg(&out),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    for i in 0..3 {
        let image = image::open(out.join(format!("frame_{i:05}.png"))).unwrap().to_rgba8();
        assert_eq!(image.dimensions(), (256, 160));
    }
    assert!(!out.join("frame_00003.png").exists());
}

#[test]
fn headless_needs_a_folder() {
    let o = hom()
        .args(["view", "--headless", "--scene", "spheres"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--out"), "{}", stderr(&o));
}

#[test]
fn a_walk_drawn_by_wgpu_reports_its_renderer() {
    let Some(dir) = graphics("the wgpu walk test") else {
        return;
    };
    let report = dir.path().join("walk.jsonl");
    let o = run_drawing(
        &dir,
        hom()
            .args([
                "walk", "--scene", "spheres", "--frames", "4", "--width", "160", "--height", "120",
            ])
            .args(["--renderer", "wgpu", "--oracle", "--report"])
            .arg(&report),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&report).unwrap();
    let header: serde_json::Value = serde_json::from_str(text.lines().next().unwrap()).unwrap();
    let renderer = header["renderer"].as_str().unwrap();
    assert!(renderer.starts_with("wgpu: "), "{renderer}");
    let o = hom()
        .args([
            "walk",
            "--scene",
            "spheres",
            "--frames",
            "1",
            "--renderer",
            "wgpu",
            "--lod",
        ])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--renderer software"), "{}", stderr(&o));
}

#[test]
fn a_bench_drawn_by_wgpu_says_so() {
    let Some(dir) = graphics("the wgpu bench test") else {
        return;
    };
    let json = dir.path().join("bench.json");
    let o = run_drawing(
        &dir,
        hom()
            .args([
                "bench",
                "--scenes",
                "spheres",
                "--cullers",
                "frustum,masked",
                "--frames",
                "3",
            ])
            .args(["--width", "128", "--height", "96", "--renderer", "wgpu", "--json"])
            .arg(&json),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).starts_with("frames drawn by wgpu: "));
    let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert!(
        report["renderer"].as_str().unwrap().starts_with("wgpu: "),
        "{}",
        report["renderer"]
    );
}
