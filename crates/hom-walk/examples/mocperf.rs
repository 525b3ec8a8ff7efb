//! Scratch tool (not committed).
use hom::depth::TiledZBuffer;
use hom::raster::TiledRasterizer;
use std::path::Path;
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let s = hom_scene::moc::read_scene(Path::new(&a[1])).unwrap();
    let (w, h): (u32, u32) = (a[2].parse().unwrap(), a[3].parse().unwrap());
    let runs: usize = a[4].parse().unwrap();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    pool.install(|| {
        let mut r = TiledRasterizer::new();
        let mut zb = TiledZBuffer::default();
        let (mut ts, mut tr) = (vec![], vec![]);
        let mut st = Default::default();
        for _ in 0..runs {
            let t0 = std::time::Instant::now();
            r.clear();
            zb.clear(w, h);
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
            let t1 = std::time::Instant::now();
            st = r.render(&mut zb);
            ts.push(t1.duration_since(t0).as_secs_f64() * 1e3);
            tr.push(t1.elapsed().as_secs_f64() * 1e3);
        }
        ts.sort_by(f64::total_cmp);
        tr.sort_by(f64::total_cmp);
        println!(
            "setup {:.2} ms render {:.2} ms (min {:.2}/{:.2}) {:?}",
            ts[runs / 2],
            tr[runs / 2],
            ts[0],
            tr[0],
            st
        );
    });
}
