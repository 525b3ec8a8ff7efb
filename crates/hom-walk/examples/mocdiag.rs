//! Scratch tool (not committed).
use hom::depth::TiledZBuffer;
use hom::raster::TiledRasterizer;
use std::path::Path;
fn main() {
    let d = Path::new("../shared/bench-data/moc");
    let s = hom_scene::moc::read_scene(&d.join("small_100k.mocscene")).unwrap();
    let (w, h) = (256u32, 256u32);
    let exact = hom_scene::moc::read_answers(&d.join("small_100k_exact_256x256.res")).unwrap();
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
    for (i, q) in s.rects.iter().enumerate() {
        let f = q.footprint(w, h, s.near_w);
        if zb.is_behind(&f) && !exact[i] {
            println!("rect {i} {:?} {:?}", q, f);
            // exact per pixel: max over covering triangles of 1/w (f64, unsnapped)
            for y in f.y0..f.y1 {
                for x in f.x0..f.x1 {
                    let (px, py) = (
                        (x as f64 + 0.5) / w as f64 * 2.0 - 1.0,
                        1.0 - (y as f64 + 0.5) / h as f64 * 2.0,
                    );
                    let mut best = 0.0f64;
                    let mut cnt = 0;
                    for t in &s.triangles {
                        let v = t.map(|k| s.vertices[k as usize]);
                        let p = v.map(|c| (c.x as f64 / c.w as f64, c.y as f64 / c.w as f64, 1.0 / c.w as f64));
                        let e = |a: (f64, f64, f64), b: (f64, f64, f64)| {
                            (b.0 - a.0) * (py - a.1) - (b.1 - a.1) * (px - a.0)
                        };
                        let (e0, e1, e2) = (e(p[0], p[1]), e(p[1], p[2]), e(p[2], p[0]));
                        if e0 >= 0.0 && e1 >= 0.0 && e2 >= 0.0 {
                            let area = e0 + e1 + e2;
                            let iw = (e1 * p[0].2 + e2 * p[1].2 + e0 * p[2].2) / area;
                            best = best.max(iw);
                            cnt += 1;
                        }
                    }
                    let ours = zb.depth(x, y);
                    let ok = best > 1.0 / q.wmin as f64;
                    if !ok {
                        println!("  px {x},{y}: exact 1/w {best:.7} (n {cnt}) vs rect 1/wmin {:.7}; ours d {ours} = 1/w {:.7}, rect d {}", 1.0 / q.wmin, (1.0 - ours) / s.near_w, f.z_near);
                    }
                }
            }
        }
    }
}
