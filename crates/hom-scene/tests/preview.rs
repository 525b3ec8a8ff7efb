//! Debug previews of the built-in scenes (ignored by default; a throwaway z-buffer
//! rasterizer, flat-shaded by face normal, each object tinted by its id).
//!
//! `cargo test -p hom-scene --release --test preview -- --ignored` writes
//! `/tmp/preview/NAME_F.png` for the first, middle and last path frames plus
//! `NAME_top.png`, an overview from above with the camera path in red, and
//! `NAME_sheet.png` with the first three and the overview on one 2x2 sheet.
//! `PREVIEW_SCENES=city,office` limits the scenes; `PREVIEW_FRAMES=0,40` picks frames.

use glam::{Vec3, Vec4};
use hom::geom::{Camera, Containment};
use hom::scene::Scene;
use hom_scene::builtin::{builtin, BUILTIN_SCENES};

const SIDE: u32 = 512;

fn tint(id: usize) -> Vec3 {
    let mut x = (id as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    x ^= x >> 29;
    let c = |s: u32| 0.45 + 0.55 * ((x >> s) & 0xff) as f32 / 255.0;
    Vec3::new(c(0), c(8), c(16))
}

/// Clips a polygon in clip space against z >= 0 (the near plane).
fn clip_near(poly: &[Vec4]) -> Vec<Vec4> {
    let mut out = Vec::with_capacity(4);
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
        if a.z >= 0.0 {
            out.push(a);
        }
        if (a.z >= 0.0) != (b.z >= 0.0) {
            let t = a.z / (a.z - b.z);
            out.push(a + (b - a) * t);
        }
    }
    out
}

struct Target {
    w: usize,
    h: usize,
    depth: Vec<f32>,
    color: Vec<[u8; 3]>,
}

impl Target {
    fn tri(&mut self, s: [Vec3; 3], c: [u8; 3]) {
        let (w, h) = (self.w as f32, self.h as f32);
        let minx = s.iter().map(|p| p.x).fold(f32::INFINITY, f32::min).max(0.0).floor() as i64;
        let maxx = s
            .iter()
            .map(|p| p.x)
            .fold(f32::NEG_INFINITY, f32::max)
            .min(w - 1.0)
            .ceil() as i64;
        let miny = s.iter().map(|p| p.y).fold(f32::INFINITY, f32::min).max(0.0).floor() as i64;
        let maxy = s
            .iter()
            .map(|p| p.y)
            .fold(f32::NEG_INFINITY, f32::max)
            .min(h - 1.0)
            .ceil() as i64;
        if minx > maxx || miny > maxy {
            return;
        }
        let area = (s[1].x - s[0].x) * (s[2].y - s[0].y) - (s[2].x - s[0].x) * (s[1].y - s[0].y);
        if area.abs() < 1e-12 {
            return;
        }
        let edge = |a: Vec3, b: Vec3, x: f32, y: f32| (b.x - a.x) * (y - a.y) - (x - a.x) * (b.y - a.y);
        for y in miny..=maxy {
            for x in minx..=maxx {
                let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
                let w0 = edge(s[1], s[2], px, py) / area;
                let w1 = edge(s[2], s[0], px, py) / area;
                let w2 = 1.0 - w0 - w1;
                if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                    continue;
                }
                let z = w0 * s[0].z + w1 * s[1].z + w2 * s[2].z;
                let i = y as usize * self.w + x as usize;
                if z < self.depth[i] {
                    self.depth[i] = z;
                    self.color[i] = c;
                }
            }
        }
    }
}

fn render(scene: &Scene, cam: &Camera) -> Target {
    let (w, h) = (cam.width as usize, cam.height as usize);
    let mut t = Target {
        w,
        h,
        depth: vec![1.0; w * h],
        color: vec![[30, 30, 40]; w * h],
    };
    let vp = cam.view_proj();
    let frustum = cam.frustum().expect("valid camera");
    let light = Vec3::new(0.4, 0.8, 0.3).normalize();
    for (id, o) in scene.objects().iter().enumerate() {
        if frustum.test_aabb(&o.aabb) == Containment::Outside {
            continue;
        }
        let mesh = scene.mesh_of(o);
        let base = tint(id);
        let world: Vec<Vec3> = mesh
            .positions()
            .iter()
            .map(|p| o.transform.transform_point3(*p))
            .collect();
        for tri in mesh.triangles() {
            let p = tri.map(|i| world[i as usize]);
            let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
            let shade = 0.3 + 0.7 * n.dot(light).abs();
            let c = (base * shade * 255.0).min(Vec3::splat(255.0));
            let c = [c.x as u8, c.y as u8, c.z as u8];
            let clip: Vec<Vec4> = p.iter().map(|q| vp * q.extend(1.0)).collect();
            let poly = clip_near(&clip);
            if poly.len() < 3 {
                continue;
            }
            let scr: Vec<Vec3> = poly
                .iter()
                .map(|c| {
                    let ndc = c.truncate() / c.w;
                    Vec3::new((ndc.x * 0.5 + 0.5) * w as f32, (0.5 - ndc.y * 0.5) * h as f32, ndc.z)
                })
                .collect();
            for k in 1..scr.len() - 1 {
                t.tri([scr[0], scr[k], scr[k + 1]], c);
            }
        }
    }
    t
}

fn save(t: &Target, path: &str) {
    let mut img = image::RgbImage::new(t.w as u32, t.h as u32);
    for (i, c) in t.color.iter().enumerate() {
        img.put_pixel((i % t.w) as u32, (i / t.w) as u32, image::Rgb(*c));
    }
    img.save(path).unwrap();
}

/// Copies `t` into quadrant `k` (0..4) of a 2x2 contact sheet.
fn paste(sheet: &mut image::RgbImage, t: &Target, k: usize) {
    if k > 3 {
        return;
    }
    let (ox, oy) = ((k % 2) * t.w, (k / 2) * t.h);
    for (i, c) in t.color.iter().enumerate() {
        sheet.put_pixel((ox + i % t.w) as u32, (oy + i / t.w) as u32, image::Rgb(*c));
    }
}

#[test]
#[ignore = "writes preview images to /tmp/preview; run by hand"]
fn preview_builtin_scenes() {
    std::fs::create_dir_all("/tmp/preview").unwrap();
    let only = std::env::var("PREVIEW_SCENES").ok();
    let frames_env = std::env::var("PREVIEW_FRAMES").ok();
    for &(name, _) in BUILTIN_SCENES {
        if only.as_ref().is_some_and(|o| !o.split(',').any(|n| n == name)) {
            continue;
        }
        let start = std::time::Instant::now();
        let b = builtin(name).unwrap();
        let gen = start.elapsed();
        let mut scene = b.scene;
        let path = b.path.clone().with_viewport(SIDE, SIDE);
        let n = path.frames.len();
        println!(
            "{name}: {} objects, {} triangles, {} meshes, {n} frames, generated in {gen:.2?}",
            scene.objects().len(),
            scene.triangle_count(),
            scene.meshes().len()
        );
        let mut kinds: std::collections::BTreeMap<String, (usize, u64)> = Default::default();
        for o in scene.objects() {
            let kind = o
                .name
                .split(|c: char| c.is_ascii_digit())
                .next()
                .unwrap_or("")
                .trim()
                .to_string();
            let e = kinds.entry(kind).or_default();
            e.0 += 1;
            e.1 += o.triangles as u64;
        }
        for (k, (n, t)) in &kinds {
            println!("    {k:24} {n:6} objects {t:9} triangles");
        }
        let frames: Vec<usize> = match &frames_env {
            Some(f) => f.split(',').filter_map(|s| s.parse().ok()).filter(|&i| i < n).collect(),
            None => vec![0, n / 2, n - 1],
        };
        let mut sheet = image::RgbImage::new(2 * SIDE, 2 * SIDE);
        for (k, f) in frames.into_iter().enumerate() {
            b.animation.apply(&mut scene, f as f32 / 30.0);
            let t = render(&scene, &path.camera(f));
            save(&t, &format!("/tmp/preview/{name}_{f}.png"));
            paste(&mut sheet, &t, k);
        }
        // Overview from above, path eyes in red.
        b.animation.apply(&mut scene, 0.0);
        let bb = scene.bounds();
        let c = bb.center();
        let e = bb.extent();
        let eye = Vec3::new(c.x, bb.max.y + e.x.max(e.z) * 0.9, c.z + e.z * 0.35);
        let cam = Camera::new(eye, c, Vec3::Y, 60f32.to_radians(), 0.5, 1e5, SIDE, SIDE);
        let mut t = render(&scene, &cam);
        let vp = cam.view_proj();
        for fr in &path.frames {
            let q = vp * Vec3::from(fr.eye).extend(1.0);
            if q.w <= 0.0 {
                continue;
            }
            let x = ((q.x / q.w * 0.5 + 0.5) * SIDE as f32) as i64;
            let y = ((0.5 - q.y / q.w * 0.5) * SIDE as f32) as i64;
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let (px, py) = (x + dx, y + dy);
                    if (0..SIDE as i64).contains(&px) && (0..SIDE as i64).contains(&py) {
                        t.color[py as usize * t.w + px as usize] = [255, 0, 0];
                    }
                }
            }
        }
        save(&t, &format!("/tmp/preview/{name}_top.png"));
        paste(&mut sheet, &t, 3);
        sheet.save(format!("/tmp/preview/{name}_sheet.png")).unwrap();
    }
}
