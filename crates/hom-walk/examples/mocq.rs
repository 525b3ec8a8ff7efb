//! Scratch tool (not committed).
use hom::depth::TiledZBuffer;
use hom::raster::TiledRasterizer;
use std::path::Path;
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let s = hom_scene::moc::read_scene(Path::new(&a[1])).unwrap();
    let (w, h) = (1920, 1080);
    let mut r = TiledRasterizer::new();
    r.setup(
        &s.vertices,
        &s.triangles,
        hom::raster::setup::SetupRule {
            cull: hom_scene::moc::MocScene::CULL,
            inner: true,
        },
        w,
        h,
    );
    let mut zb = TiledZBuffer::default();
    zb.clear(w, h);
    r.render(&mut zb);
    let t0 = std::time::Instant::now();
    let n = s
        .rects
        .iter()
        .filter(|q| zb.is_behind(&q.footprint(w, h, s.near_w)))
        .count();
    println!("{n} {:?}", t0.elapsed());
}
