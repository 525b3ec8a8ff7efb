//! The ground's walls (`hom/src/occluders/ground.rs`) against the renderer:
//! from every eye the cullers draw them for, the walls of every piece, as
//! the cullers draw them (by the inner rule, into an exactly sampled
//! z-buffer), cover no sample that the renderer's ground leaves open and
//! are never nearer than it. The eyes are over random, hilly ground, at
//! grazing heights and looking across its crests. (The built-in terrain's
//! walk, whose tiles make a ground, is checked against the oracle with
//! every culler in `builtin_walks.rs`.)

use glam::{Mat4, Vec3};
use hom::geom::{Camera, Eye};
use hom::occluders::{OccluderDb, OccluderDbConfig};
use hom::occlusion::{BufferOptions, FaceCull, HzBuffer, OcclusionBuffer, Sampling};
use hom::scene::{Mesh, Scene, SceneBuilder};
use hom_render::{oracle_pixel_counts, Framebuffer, Renderer};
use hom_testkit::Rng;
use proptest::prelude::*;

/// A `cells` × `cells` grid of 1 m cells with random heights (ridges of up
/// to `relief` metres), cut into `pieces` × `pieces` objects.
fn ground(rng: &mut Rng, cells: u32, pieces: u32, relief: f32) -> (Scene, Vec<f32>) {
    let heights: Vec<f32> = (0..(cells + 1) * (cells + 1))
        .map(|k| {
            let (i, j) = ((k % (cells + 1)) as f32, (k / (cells + 1)) as f32);
            relief * (0.5 + 0.5 * (i * 0.7).sin() * (j * 0.45).cos()) + rng.range(0.0, 0.3)
        })
        .collect();
    let mut b = SceneBuilder::new("ground");
    for (p, t) in hom_testkit::height_field_pieces(&heights, cells, pieces, None) {
        let mesh = b.add_mesh(Mesh::new("piece", p, t).unwrap());
        b.add_object("piece", mesh, Mat4::IDENTITY).unwrap();
    }
    (b.build().unwrap(), heights)
}

/// Six views over a random ground from `seed`: the samples the walls
/// cover, and the first that breaks the guarantee, if any.
fn walls_against_ground(seed: u64) -> Result<u64, String> {
    let mut rng = Rng::new(seed);
    let cells = 24;
    let relief = rng.range(1.0, 6.0);
    let (scene, heights) = ground(&mut rng, cells, 4, relief);
    let db = OccluderDb::build(&scene, &OccluderDbConfig::default());
    if db.ground_pieces() != 16 {
        return Err(format!("{} ground pieces, not 16", db.ground_pieces()));
    }
    let renderer = Renderer::new(1).unwrap();
    let mut fb = Framebuffer::new(96, 96);
    let mut covered = 0;
    for _ in 0..6 {
        // An eye low over the ground, looking across it, a little down or up.
        let (x, z) = (rng.range(0.5, cells as f32 - 0.5), rng.range(0.5, cells as f32 - 0.5));
        let highest = heights.iter().copied().fold(f32::MIN, f32::max);
        let eye = Vec3::new(x, highest * rng.range(0.3, 1.1) + 0.3, z);
        let angle = rng.range(0.0, std::f32::consts::TAU);
        let target = eye + Vec3::new(angle.cos() * 10.0, rng.range(-3.0, 1.0), angle.sin() * 10.0);
        let camera = Camera::new(eye, target, Vec3::Y, 1.2, 0.1, 200.0, 96, 96);
        let view = camera.view_proj();
        oracle_pixel_counts(&renderer, &scene, &camera, &mut fb);
        let exact = BufferOptions {
            sampling: Sampling::Exact,
            ..BufferOptions::default()
        };
        let mut buffer = HzBuffer::new(96, 96, exact).unwrap();
        for id in 0..scene.objects().len() as u32 {
            let (p, t) = db.ground_walls(&scene, id, &Eye::Point(eye), &view);
            buffer.render_stand_in_triangles(&p, &t, &view, FaceCull::None).unwrap();
        }
        let mut depth = Vec::new();
        buffer.zbuffer().to_row_major(&mut depth);
        for (k, (&wall, &truth)) in depth.iter().zip(fb.depth()).enumerate() {
            if wall.is_finite() && wall < 1.0 {
                covered += 1;
                if !(truth < 1.0 && truth <= wall) {
                    return Err(format!(
                        "sample ({}, {}): a wall at depth {wall} where the ground is at {truth} (eye {eye}, target {target})",
                        k % 96,
                        k / 96
                    ));
                }
            }
        }
    }
    Ok(covered)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn walls_never_cover_what_the_ground_leaves_open(seed in any::<u64>()) {
        if let Err(e) = walls_against_ground(seed) {
            prop_assert!(false, "{}", e);
        }
    }
}

/// The check above is not empty: over a few grounds the walls cover
/// thousands of samples.
#[test]
fn walls_cover_samples() {
    let covered: u64 = (0..4).map(|seed| walls_against_ground(seed).unwrap()).sum();
    assert!(covered > 1_000, "{covered}");
}
