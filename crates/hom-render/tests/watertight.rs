//! Watertightness: triangles tiling a screen-covering surface cover every
//! pixel centre exactly once (the top-left fill rule on snapped vertices).

mod common;

use common::{scene_of, unproject};
use hom::geom::Camera;
use hom::glam::{Mat4, Vec3};
use hom_render::{Framebuffer, RenderOptions, Renderer, Shading, NO_OBJECT};
use hom_testkit::Rng;

const W: u32 = 40;
const H: u32 = 30;

fn camera() -> Camera {
    Camera::new(
        Vec3::new(0.3, 0.2, 4.0),
        Vec3::new(0.3, 0.2, 0.0),
        Vec3::Y,
        0.9,
        0.1,
        50.0,
        W,
        H,
    )
}

/// Renders each triangle (one object each) alone and counts, per pixel, how
/// many triangles cover it; also renders all together and checks no pixel is empty.
fn coverage(tris: &[[Vec3; 3]]) -> Vec<u32> {
    let camera = camera();
    let scene = scene_of(&tris.iter().map(|t| (vec![*t], Mat4::IDENTITY)).collect::<Vec<_>>());
    let renderer = Renderer::new(2).unwrap();
    let options = RenderOptions {
        shading: Shading::ItemOnly,
        ..RenderOptions::default()
    };
    let mut fb = Framebuffer::new(W, H);
    let mut counts = vec![0u32; (W * H) as usize];
    for id in 0..tris.len() as u32 {
        renderer.render(&scene, &[id], &camera, &options, &mut fb);
        for (c, &item) in counts.iter_mut().zip(fb.items()) {
            if item != NO_OBJECT {
                assert_eq!(item, id);
                *c += 1;
            }
        }
    }
    let all: Vec<u32> = (0..tris.len() as u32).collect();
    renderer.render(&scene, &all, &camera, &options, &mut fb);
    assert!(
        fb.items().iter().all(|&i| i != NO_OBJECT),
        "a pixel is empty with all triangles drawn"
    );
    counts
}

fn assert_exactly_once(counts: &[u32]) {
    for (i, &c) in counts.iter().enumerate() {
        assert_eq!(c, 1, "pixel {},{} covered {c} times", i as u32 % W, i as u32 / W);
    }
}

/// A grid of screen positions `(sx, sy)` (pixels) from `-2` to `W + 2`, with
/// the interior vertices moved by `jitter`.
fn grid(nx: usize, ny: usize, mut jitter: impl FnMut(usize, usize) -> (f64, f64)) -> Vec<Vec<(f64, f64)>> {
    (0..=ny)
        .map(|j| {
            (0..=nx)
                .map(|i| {
                    // Border vertices sit outside the screen; interior ones on pixel centres.
                    let sx = if i == 0 {
                        -2.0
                    } else if i == nx {
                        f64::from(W) + 2.0
                    } else {
                        (i * W as usize / nx) as f64 + 0.5
                    };
                    let sy = if j == 0 {
                        -2.0
                    } else if j == ny {
                        f64::from(H) + 2.0
                    } else {
                        (j * H as usize / ny) as f64 + 0.5
                    };
                    if i == 0 || j == 0 || i == nx || j == ny {
                        (sx, sy)
                    } else {
                        let (dx, dy) = jitter(i, j);
                        (sx + dx, sy + dy)
                    }
                })
                .collect()
        })
        .collect()
}

/// Triangulates a grid of world points, alternating the diagonal.
fn triangulate(p: &[Vec<Vec3>]) -> Vec<[Vec3; 3]> {
    let mut tris = Vec::new();
    for j in 0..p.len() - 1 {
        for i in 0..p[0].len() - 1 {
            let (a, b, c, d) = (p[j][i], p[j][i + 1], p[j + 1][i + 1], p[j + 1][i]);
            if (i + j) % 2 == 0 {
                tris.push([a, b, c]);
                tris.push([a, c, d]);
            } else {
                tris.push([a, b, d]);
                tris.push([b, c, d]);
            }
        }
    }
    tris
}

#[test]
fn grid_through_pixel_centres_covers_every_pixel_once() {
    // Vertices on pixel centres: horizontal, vertical and diagonal edges pass
    // exactly through samples; depth constant (plane facing the camera).
    let cam = camera();
    let g = grid(8, 6, |_, _| (0.0, 0.0));
    let pts: Vec<Vec<Vec3>> = g
        .iter()
        .map(|row| row.iter().map(|&(x, y)| unproject(&cam, x, y, 3.0)).collect())
        .collect();
    assert_exactly_once(&coverage(&triangulate(&pts)));
}

#[test]
fn jittered_tilted_grid_covers_every_pixel_once() {
    // Interior vertices moved to random pixel centres, quarter- and
    // sub-sample positions; depth varies per vertex (a bumpy surface).
    let cam = camera();
    for seed in 1..6u64 {
        let mut rng = Rng::new(seed * 0x9e37_79b9);
        let g = grid(10, 7, |_, _| {
            let q = |r: &mut Rng| f64::from((r.next_u64() % 9) as u32) * 0.25 - 1.0;
            if rng.next_u64().is_multiple_of(3) {
                (q(&mut rng), q(&mut rng))
            } else {
                (f64::from(rng.range(-1.0, 1.0)), f64::from(rng.range(-1.0, 1.0)))
            }
        });
        let pts: Vec<Vec<Vec3>> = g
            .iter()
            .map(|row| {
                row.iter()
                    .map(|&(x, y)| unproject(&cam, x, y, 2.0 + f64::from(rng.range(0.0, 1.5))))
                    .collect()
            })
            .collect();
        assert_exactly_once(&coverage(&triangulate(&pts)));
    }
}

#[test]
fn fan_around_a_pixel_centre_covers_every_pixel_once() {
    // Many triangles meeting at one vertex that sits exactly on a sample.
    let cam = camera();
    let centre = unproject(&cam, 20.5, 15.5, 3.0);
    let rim: Vec<Vec3> = (0..24)
        .map(|k| {
            let a = k as f64 / 24.0 * std::f64::consts::TAU;
            unproject(&cam, 20.5 + 60.0 * a.cos(), 15.5 + 60.0 * a.sin(), 3.0)
        })
        .collect();
    let tris: Vec<[Vec3; 3]> = (0..24).map(|k| [centre, rim[k], rim[(k + 1) % 24]]).collect();
    assert_exactly_once(&coverage(&tris));
}

#[test]
fn surface_crossing_the_near_plane_stays_watertight() {
    // A floor running from behind the camera to far ahead: clipped triangles
    // share clipped edges. Every pixel below the horizon is covered once.
    let cam = Camera::new(
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(0.0, 0.0, -10.0),
        Vec3::Y,
        1.2,
        0.1,
        100.0,
        W,
        H,
    );
    let mut rng = Rng::new(7);
    let n = 12;
    let pts: Vec<Vec<Vec3>> = (0..=n)
        .map(|j| {
            (0..=n)
                .map(|i| {
                    let inner = i > 0 && j > 0 && i < n && j < n;
                    let jit = if inner {
                        rng.vec3(-0.4, 0.4) * Vec3::new(1.0, 0.0, 1.0)
                    } else {
                        Vec3::ZERO
                    };
                    Vec3::new(-30.0 + 5.0 * i as f32, 0.0, 5.0 - 5.0 * j as f32) + jit
                })
                .collect()
        })
        .collect();
    let tris = triangulate(&pts);
    let scene = scene_of(&tris.iter().map(|t| (vec![*t], Mat4::IDENTITY)).collect::<Vec<_>>());
    let renderer = Renderer::new(1).unwrap();
    let options = RenderOptions {
        shading: Shading::ItemOnly,
        ..RenderOptions::default()
    };
    let mut fb = Framebuffer::new(W, H);
    let mut counts = vec![0u32; (W * H) as usize];
    for id in 0..tris.len() as u32 {
        renderer.render(&scene, &[id], &cam, &options, &mut fb);
        for (c, &item) in counts.iter_mut().zip(fb.items()) {
            *c += u32::from(item != NO_OBJECT);
        }
    }
    // Rows well below the horizon (row H/2) are fully covered exactly once;
    // nothing anywhere is covered twice.
    for y in 0..H {
        for x in 0..W {
            let c = counts[(y * W + x) as usize];
            assert!(c <= 1, "pixel {x},{y} covered {c} times");
            if y >= H / 2 + 2 {
                assert_eq!(c, 1, "pixel {x},{y} not covered");
            }
        }
    }
}

/// The terrain's tiles, each its own object placed by a translation, against
/// the same triangles as one world-space object: the tiles leave no sample
/// open along their seams (vertices go to the world first, so a vertex two
/// tiles share has one clip position; `view_proj · transform` per object
/// left 8 samples open over these 30 frames).
#[test]
fn tiles_sharing_world_vertices_meet_without_cracks() {
    use hom::scene::Mesh;
    let built = hom_scene::builtin("terrain").unwrap();
    let (scene, path) = (built.scene, built.path);
    let mut tiled = hom::scene::SceneBuilder::new("tiled");
    let (mut p, mut t) = (Vec::new(), Vec::new());
    for o in scene.objects().iter().filter(|o| o.name.starts_with("terrain tile")) {
        let m = scene.mesh_of(o);
        let id = tiled.add_mesh(m.clone());
        tiled.add_object(o.name.clone(), id, o.transform).unwrap();
        let base = p.len() as u32;
        p.extend(m.positions().iter().map(|&q| o.transform.transform_point3(q)));
        t.extend(m.triangles().iter().map(|tri| tri.map(|i| i + base)));
    }
    let tiled = tiled.build().unwrap();
    let mut merged = hom::scene::SceneBuilder::new("merged");
    let id = merged.add_mesh(Mesh::new("all tiles", p, t).unwrap());
    merged.add_object("all tiles", id, Mat4::IDENTITY).unwrap();
    let merged = merged.build().unwrap();
    let renderer = Renderer::new(0).unwrap();
    let (mut a, mut b) = (
        Framebuffer::new(path.width, path.height),
        Framebuffer::new(path.width, path.height),
    );
    let (mut open, mut extra, mut covered) = (0u64, 0u64, 0u64);
    for i in (0..path.frames.len()).step_by(10) {
        let camera = path.camera(i);
        hom_render::oracle_pixel_counts(&renderer, &tiled, &camera, &mut a);
        hom_render::oracle_pixel_counts(&renderer, &merged, &camera, &mut b);
        for (&x, &y) in a.depth().iter().zip(b.depth()) {
            open += u64::from(x >= 1.0 && y < 1.0);
            extra += u64::from(x < 1.0 && y >= 1.0);
            covered += u64::from(y < 1.0);
        }
    }
    assert!(covered > 1_000_000, "{covered}");
    assert_eq!((open, extra), (0, 0), "samples the tiles leave open / cover alone");
}
