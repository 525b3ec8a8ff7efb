//! Scratch tool (not committed).
use hom::depth::TiledZBuffer;
use hom::raster::setup::{FaceCull, SetupRule};
use hom::raster::TiledRasterizer;
use std::path::Path;
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let r = hom_scene::moc::read_recording(Path::new(&a[1])).unwrap();
    let (w, h) = (r.width / 2, r.height / 2);
    for (name, flip) in [("asis", false), ("flipped", true)] {
        let mut ras = TiledRasterizer::new();
        for d in &r.draws {
            let cull = if flip {
                match d.cull {
                    FaceCull::Clockwise => FaceCull::CounterClockwise,
                    FaceCull::CounterClockwise => FaceCull::Clockwise,
                    c => c,
                }
            } else {
                d.cull
            };
            ras.setup(&d.vertices, &d.triangles, SetupRule { cull, inner: false }, w, h);
        }
        let mut zb = TiledZBuffer::default();
        zb.clear(w, h);
        ras.render(&mut zb);
        let mut px = Vec::new();
        let mut cov = 0;
        let mut sum = 0.0f64;
        for y in 0..h {
            for x in 0..w {
                let d = zb.depth(x, y);
                if d.is_finite() {
                    cov += 1;
                    let wv = r.near_w / (1.0 - d);
                    sum += wv as f64;
                    let v = (255.0 * (wv.ln() / 1000f32.ln()).clamp(0.0, 1.0)) as u8;
                    px.push([v, v, v, 255]);
                } else {
                    px.push([80, 0, 0, 255]);
                }
            }
        }
        println!("{name}: covered {cov} mean w {}", sum / cov as f64);
        hom_render::write_png(Path::new(&format!("/tmp/moc_{name}.png")), w, h, &px).unwrap();
    }
}
