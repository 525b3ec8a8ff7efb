//! The workload of `c/example.c` (a street of box buildings and props, a
//! reversed-Z camera walking down it: clear, draw the buildings within 60 m,
//! test every building and prop), written against the Rust front door, to
//! measure what the C ABI costs: run both, release builds, and compare their
//! milliseconds a frame (`scripts/c-api-check.sh --bench`).
//!
//! `cargo run --release -p hom-capi --example street`

use hom_occlusion::geom::Aabb;
use hom_occlusion::glam::{Mat4, Vec3, Vec4};
use hom_occlusion::{BufferOptions, ClipConvention, FaceCull, HzBuffer, OcclusionBuffer, Visibility};
use std::time::Instant;

const ROWS: usize = 60;
const PROPS_PER_ROW: usize = 20;

fn main() {
    let cube: Vec<Vec3> = (0..8)
        .map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32))
        .collect();
    let flat = [
        0, 1, 3, 0, 3, 2, 4, 6, 7, 4, 7, 5, 0, 4, 5, 0, 5, 1, 2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4, 1, 5, 7, 1, 7, 3,
    ];
    let tris: Vec<[u32; 3]> = flat.chunks(3).map(|t| [t[0], t[1], t[2]]).collect();
    let (mut buildings, mut props) = (Vec::new(), Vec::new());
    let mut seed: u32 = 12345;
    for r in 0..ROWS {
        for side in [-1.0f32, 1.0] {
            let (z0, x0) = (-12.0 * r as f32, if side < 0.0 { -26.0 } else { 6.0 });
            seed = seed.wrapping_mul(1_103_515_245).wrapping_add(12345);
            let h = 8.0 + ((seed >> 16) & 31) as f32;
            buildings.push(Aabb::new(Vec3::new(x0, 0.0, z0 - 10.0), Vec3::new(x0 + 20.0, h, z0)));
            for k in 0..PROPS_PER_ROW {
                let x = if side < 0.0 { -40.0 } else { 28.0 } + (k % 5) as f32 * 2.5;
                let z = z0 - 2.0 * (k / 5) as f32;
                props.push(Aabb::new(Vec3::new(x, 0.0, z - 1.0), Vec3::new(x + 1.0, 2.0, z)));
            }
        }
    }
    let options = BufferOptions {
        clip: ClipConvention::ReversedZ,
        ..BufferOptions::default()
    };
    let mut buffer = HzBuffer::new(1024, 768, options).expect("a valid size");
    // The C example's matrices, built the same way.
    let f = 1.0 / (0.5f32).tan();
    let proj = Mat4::from_cols(
        Vec4::new(f / (1024.0 / 768.0), 0.0, 0.0, 0.0),
        Vec4::new(0.0, f, 0.0, 0.0),
        Vec4::new(0.0, 0.0, 0.0, -1.0),
        Vec4::new(0.0, 0.0, 0.1, 0.0),
    );
    let (mut culled, mut tested) = (0u64, 0u64);
    let frames = 120;
    let start = Instant::now();
    for frame in 0..frames {
        let eye = Vec3::new(0.0, 1.7, 5.0 - 4.0 * frame as f32);
        let view_proj = proj * Mat4::from_translation(-eye);
        buffer.clear();
        for b in &buildings {
            let dz = eye.z - b.max.z;
            if !(-10.0..=60.0).contains(&dz) {
                continue;
            }
            let model = Mat4::from_translation(b.min) * Mat4::from_scale(b.max - b.min);
            buffer
                .render_triangles(&cube, &tris, &(view_proj * model), FaceCull::None)
                .expect("valid triangles");
        }
        for b in buildings.iter().chain(&props) {
            culled += u64::from(buffer.test_aabb(b, &view_proj) != Visibility::Visible);
            tested += 1;
        }
    }
    let ms = start.elapsed().as_secs_f64() * 1e3;
    println!(
        "hom Rust street: {frames} frames, {} buildings and {} props, {:.1} % not drawn (occluded or out of view), {:.3} ms a frame",
        buildings.len(),
        props.len(),
        100.0 * culled as f64 / tested as f64,
        ms / frames as f64
    );
}
