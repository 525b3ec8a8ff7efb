//! Drawing set-up triangles into the framebuffer's depth, item and colour
//! buffers. Triangle setup and the sampling rule live in [`hom::occlusion::details::setup`],
//! shared with the occluder rasterizer, so both cover exactly the same samples.

use hom::occlusion::details::setup::{divide_span, Tri, ONE, SCAN_MAX};

/// Draws the rows `band_y0..band_y1` of `t` into a band of the framebuffer
/// (`depth`, `item`, `colour` hold those rows, `width` pixels each).
/// Returns the number of fragments written.
///
/// Coverage is exactly that of [`Tri::covers`]; the depth at a pixel is
/// `depth_row(py) + dzdx * (px - x0)`, independent of the band.
#[inline]
#[allow(clippy::too_many_arguments)]
pub(crate) fn raster_tri<const COLOUR: bool>(
    t: &Tri,
    band_y0: u32,
    band_y1: u32,
    width: usize,
    depth: &mut [f32],
    item: &mut [u32],
    colour: &mut [[u8; 4]],
) -> u64 {
    let ya = u32::from(t.y0).max(band_y0);
    let yb = u32::from(t.y1).min(band_y1);
    if ya >= yb {
        return 0;
    }
    let n = u32::from(t.x1 - t.x0);
    let x0 = usize::from(t.x0);
    let step_x = [t.a[0] * ONE, t.a[1] * ONE, t.a[2] * ONE];
    let step_y = [t.b[0] * ONE, t.b[1] * ONE, t.b[2] * ONE];
    let mut e = t.edges_at_row(ya);
    let mut written = 0u64;
    let mut row = (ya - band_y0) as usize * width + x0;
    for py in ya..yb {
        let zr = t.depth_row(py);
        if n <= SCAN_MAX {
            // Coverage and depth in one pass over the bounding-box row.
            let mut f = e;
            let mut seen = false;
            for k in 0..n {
                if (f[0] | f[1] | f[2]) >= 0 {
                    seen = true;
                    let idx = row + k as usize;
                    let z = t.depth_in_row(zr, k as i32);
                    if z < depth[idx] {
                        depth[idx] = z;
                        item[idx] = t.item;
                        if COLOUR {
                            colour[idx] = t.colour;
                        }
                        written += 1;
                    }
                } else if seen {
                    break;
                }
                f[0] += step_x[0];
                f[1] += step_x[1];
                f[2] += step_x[2];
            }
        } else if let Some((lo, hi)) = divide_span(e, step_x, n) {
            let r = row + lo as usize..row + hi as usize;
            written += u64::from(fill_span::<COLOUR>(
                t,
                zr,
                lo,
                &mut depth[r.clone()],
                &mut item[r.clone()],
                &mut colour[r],
            ));
        }
        e[0] += step_y[0];
        e[1] += step_y[1];
        e[2] += step_y[2];
        row += width;
    }
    written
}

/// Lanes [`fill_span`] handles at once.
const LANES: usize = 8;

/// Depth-tests and writes one covered span: `depth`, `item` and `colour` hold
/// its pixels, the first at column offset `k0` from the triangle's `x0`, and
/// `zr` is the depth at offset 0 of the row. The depth of each pixel is
/// [`Tri::depth_in_row`] (hom's one depth formula); groups of [`LANES`] pixels
/// are tested and blended branch-free (bit masks), so this vectorizes.
/// Returns the number of fragments written.
#[inline(always)]
fn fill_span<const COLOUR: bool>(
    t: &Tri,
    zr: f32,
    k0: u32,
    depth: &mut [f32],
    item: &mut [u32],
    colour: &mut [[u8; 4]],
) -> u32 {
    let (id, c) = (t.item, u32::from_ne_bytes(t.colour));
    let len = depth.len();
    let (item, colour) = (&mut item[..len], &mut colour[..len]);
    let mut k = k0 as i32;
    let mut written = 0u32;
    let mut dc = depth.chunks_exact_mut(LANES);
    let mut ic = item.chunks_exact_mut(LANES);
    let mut cc = colour.chunks_exact_mut(LANES);
    for ((d, i), o) in (&mut dc).zip(&mut ic).zip(&mut cc) {
        let mut m = [0u32; LANES];
        for l in 0..LANES {
            let z = t.depth_in_row(zr, k + l as i32);
            m[l] = 0u32.wrapping_sub(u32::from(z < d[l]));
            d[l] = f32::from_bits((z.to_bits() & m[l]) | (d[l].to_bits() & !m[l]));
        }
        for l in 0..LANES {
            i[l] = (id & m[l]) | (i[l] & !m[l]);
            written += m[l] & 1;
        }
        if COLOUR {
            for l in 0..LANES {
                o[l] = ((c & m[l]) | (u32::from_ne_bytes(o[l]) & !m[l])).to_ne_bytes();
            }
        }
        k += LANES as i32;
    }
    let (d, i, o) = (dc.into_remainder(), ic.into_remainder(), cc.into_remainder());
    for l in 0..d.len() {
        let z = t.depth_in_row(zr, k + l as i32);
        if z < d[l] {
            d[l] = z;
            i[l] = id;
            if COLOUR {
                o[l] = t.colour;
            }
            written += 1;
        }
    }
    written
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec4;
    use hom::occlusion::details::setup::{setup_triangle, Vertex, Viewport};
    use hom_testkit::Rng;

    fn setup(clip: [Vec4; 3], w: u32, h: u32) -> Vec<Tri> {
        let vp = Viewport::new(w, h);
        let v = clip.map(|c| Vertex::new(c, &vp));
        let mut out = Vec::new();
        setup_triangle([&v[0], &v[1], &v[2]], &vp, 7, [1, 2, 3, 255], &mut out);
        out
    }

    /// Clip coordinates of a screen point at depth z (w = 1).
    fn at(sx: f32, sy: f32, z: f32, w: u32, h: u32) -> Vec4 {
        Vec4::new(sx / w as f32 * 2.0 - 1.0, 1.0 - sy / h as f32 * 2.0, z, 1.0)
    }

    #[test]
    fn raster_matches_coverage_and_plane_depth_in_any_band() {
        // raster_tri (fused scan for narrow rows, exact division for wide ones)
        // writes exactly the covered samples, with the plane depth, whatever
        // band split is used.
        let (w, h) = (70u32, 50u32);
        let mut rng = Rng::new(777);
        let mut rnd = move || rng.unit();
        for _ in 0..2000 {
            let scale = [3.0, 10.0, 30.0, 120.0][(rnd() * 4.0) as usize % 4];
            let (cx, cy) = (rnd() * 80.0 - 5.0, rnd() * 60.0 - 5.0);
            let v = [0, 1, 2].map(|_| at(cx + (rnd() - 0.5) * scale, cy + (rnd() - 0.5) * scale, rnd(), w, h));
            for t in setup(v, w, h) {
                for band in [1u32, 7, 16, 50] {
                    let n = (w * h) as usize;
                    let (mut depth, mut item, mut colour) = (vec![1.0f32; n], vec![u32::MAX; n], vec![[0u8; 4]; n]);
                    let mut written = 0;
                    for y0 in (0..h).step_by(band as usize) {
                        let y1 = (y0 + band).min(h);
                        let r = (y0 * w) as usize..(y1 * w) as usize;
                        written += raster_tri::<true>(
                            &t,
                            y0,
                            y1,
                            w as usize,
                            &mut depth[r.clone()],
                            &mut item[r.clone()],
                            &mut colour[r],
                        );
                    }
                    let mut expect = 0;
                    for y in 0..h {
                        for x in 0..w {
                            let i = (y * w + x) as usize;
                            let inside = x >= u32::from(t.x0)
                                && x < u32::from(t.x1)
                                && y >= u32::from(t.y0)
                                && y < u32::from(t.y1);
                            let z = |t: &Tri| t.depth_at(x, y);
                            if inside && t.covers(x, y) && z(&t) < 1.0 {
                                let z = z(&t);
                                expect += 1;
                                assert_eq!(
                                    (item[i], depth[i].to_bits(), colour[i]),
                                    (7, z.to_bits(), [1, 2, 3, 255])
                                );
                            } else {
                                assert_eq!(item[i], u32::MAX, "pixel {x},{y} of {t:?}");
                            }
                        }
                    }
                    assert_eq!(written, expect);
                }
            }
        }
    }
}
