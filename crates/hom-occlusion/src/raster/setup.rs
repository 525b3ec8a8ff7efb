//! Triangle setup (clip, project, snap) and the exact fixed-point rasterizer core.
//!
//! Everything here is deterministic: a triangle's setup depends only on its clip
//! coordinates and the viewport, and the pixels it covers and the depth it
//! writes at a pixel depend only on that setup and the pixel's position.

use glam::{DVec4, Vec4};

/// Sub-pixel bits of the snapped fixed-point screen coordinates.
pub const SUBPIXEL_BITS: u32 = 8;
/// One pixel in fixed point.
pub const ONE: i64 = 1 << SUBPIXEL_BITS;
/// Half a pixel in fixed point (pixel centres).
pub(crate) const HALF: i64 = ONE / 2;

/// Guard band: after clipping, screen coordinates stay within about
/// `±GUARD_PX` pixels of the viewport centre, so snapped coordinates fit in
/// 29 bits and every edge-function product fits in an `i64`.
const GUARD_PX: f32 = (1u32 << 19) as f32;
/// Hard limit on a snapped screen coordinate in pixels (checked after projection).
pub(crate) const LIMIT_PX: f32 = (1u32 << 20) as f32;

/// Rows of a bounding box at most this wide are scanned pixel by pixel;
/// wider ones get their covered span from exact integer division.
pub const SCAN_MAX: u32 = 16;

/// A triangle ready to rasterize: exact edge functions, clamped pixel bounds,
/// the depth plane, and what to write.
#[derive(Clone, Copy, Debug)]
pub struct Tri {
    /// Edge functions `E_i(p) = a[i] * p.x + b[i] * p.y + c[i]` in fixed point
    /// (fill-rule bias folded into `c`); a sample is covered iff all are `>= 0`.
    pub a: [i64; 3],
    /// See `a`.
    pub b: [i64; 3],
    /// See `a`.
    pub c: [i64; 3],
    /// First pixel column that may be covered.
    pub x0: u16,
    /// First pixel row that may be covered.
    pub y0: u16,
    /// One past the last column.
    pub x1: u16,
    /// One past the last row.
    pub y1: u16,
    /// Depth (clip z / w) at the centre of pixel `(x0, y0)`.
    pub zref: f32,
    /// Depth change per pixel step in x.
    pub dzdx: f32,
    /// Depth change per pixel step in y.
    pub dzdy: f32,
    /// Object id written to the item buffer.
    pub item: u32,
    /// Colour written in flat shading.
    pub colour: [u8; 4],
}

impl Tri {
    /// Edge function values at the centre of pixel `(x0, py)`.
    #[inline]
    pub fn edges_at_row(&self, py: u32) -> [i64; 3] {
        let sx = i64::from(self.x0) * ONE + HALF;
        let sy = i64::from(py) * ONE + HALF;
        [0, 1, 2].map(|i| self.a[i] * sx + self.b[i] * sy + self.c[i])
    }

    /// The half-open range of columns `lo..hi` covered in row `py`
    /// (`py` within `y0..y1`); `None` when the row is empty.
    pub fn row_span(&self, py: u32) -> Option<(u32, u32)> {
        self.span_of(self.edges_at_row(py))
    }

    /// The columns `lo..hi` of the box whose samples are inside every edge,
    /// given the edge values `e` at its first column.
    #[inline]
    fn span_of(&self, e: [i64; 3]) -> Option<(u32, u32)> {
        let n = u32::from(self.x1 - self.x0);
        let step = [0, 1, 2].map(|i| self.a[i] * ONE);
        let span = if n <= SCAN_MAX {
            scan_span(e, step, n)
        } else {
            divide_span(e, step, n)
        };
        span.map(|(lo, hi)| (u32::from(self.x0) + lo, u32::from(self.x0) + hi))
    }

    /// Columns `lo..hi` (absolute, within the box) that hold every sample the
    /// triangle covers in rows `ya..yb` (within the box, `ya < yb`); empty
    /// (`lo >= hi`) when it covers none there for certain. A sloped edge's
    /// bound is linear in the row, so its loosest is at the first or the
    /// last row; `f64` quotients widened by a column each side (a bound,
    /// not the exact span: for skipping work, never for coverage).
    pub fn columns_in_rows(&self, ya: u32, yb: u32) -> (u32, u32) {
        let (ea, eb) = (self.edges_at_row(ya), self.edges_at_row(yb - 1));
        let (mut lo, mut hi) = (0i64, i64::from(self.x1 - self.x0));
        for i in 0..3 {
            // Column offset k (from x0) is inside edge i when e + k·a·ONE >= 0.
            let (e, d) = (ea[i].max(eb[i]) as f64, (self.a[i] * ONE) as f64);
            if d > 0.0 {
                lo = lo.max((-e / d) as i64 - 2); // truncation: within a column of floor
            } else if d < 0.0 {
                hi = hi.min((e / -d) as i64 + 2);
            } else if e < 0.0 {
                return (0, 0); // a horizontal edge excludes every row here
            }
        }
        let x0 = i64::from(self.x0);
        ((x0 + lo.max(0)) as u32, (x0 + hi.max(lo.max(0))) as u32)
    }

    /// The columns `lo..hi` covered in every row of `ya..yb` (within the
    /// box, `ya < yb`), exactly; `None` when no column is. Each edge function
    /// is linear in the row, so over a run of rows it is smallest at one end:
    /// a column is inside an edge in every row iff it is with that edge's
    /// smaller value of the two end rows: one row's span, at those values.
    pub fn columns_in_every_row(&self, ya: u32, yb: u32) -> Option<(u32, u32)> {
        let (ea, eb) = (self.edges_at_row(ya), self.edges_at_row(yb - 1));
        self.span_of([0, 1, 2].map(|i| ea[i].min(eb[i])))
    }

    /// Whether the sample at the centre of pixel `(px, py)` is covered (slow; tests).
    pub fn covers(&self, px: u32, py: u32) -> bool {
        let sx = i64::from(px) * ONE + HALF;
        let sy = i64::from(py) * ONE + HALF;
        (0..3).all(|i| self.a[i] * sx + self.b[i] * sy + self.c[i] >= 0)
    }

    /// The plane's depth at the centre of pixel `(x0, py)` (row `py` within
    /// `y0..y1`), before the clamp: the row part of [`Tri::depth_at`].
    #[inline]
    pub fn depth_row(&self, py: u32) -> f32 {
        self.zref + self.dzdy * (py - u32::from(self.y0)) as f32
    }

    /// The depth hom writes at the centre of pixel `(px, py)` (within the
    /// triangle's box): `max(zref + dzdy·(py − y0) + dzdx·(px − x0), 0)` in
    /// exactly these `f32` roundings. The one depth formula of hom: the
    /// reference renderer, every occluder rasterizer and HV write it, and the
    /// vector kernels reproduce it bit for bit.
    #[inline]
    pub fn depth_at(&self, px: u32, py: u32) -> f32 {
        self.depth_in_row(self.depth_row(py), px as i32 - i32::from(self.x0))
    }

    /// Bounds of [`Tri::depth_at`] over columns `xa..=xb`, rows `ya..=yb`
    /// (within the box): `(nearest, farthest)` the plane reaches there (a
    /// linear function: at corners), widened by slack for the few `f32`
    /// roundings of the formula and of the bound, and clamped at 0 as the
    /// formula is. Every sample the triangle covers there lies within them.
    #[inline]
    pub fn depth_bounds(&self, xa: u32, xb: u32, ya: u32, yb: u32) -> (f32, f32) {
        let (x0, y0) = (u32::from(self.x0), u32::from(self.y0));
        let (dxa, dxb) = ((xa - x0) as f32, (xb - x0) as f32);
        let (dya, dyb) = ((ya - y0) as f32, (yb - y0) as f32);
        let (ax, bx) = (self.dzdx * dxa, self.dzdx * dxb);
        let (ay, by) = (self.dzdy * dya, self.dzdy * dyb);
        let slack = self.depth_slack(xb, yb);
        let low = self.zref + ax.min(bx) + ay.min(by) - slack;
        let high = self.zref + ax.max(bx) + ay.max(by) + slack;
        (low.max(0.0), high.max(0.0))
    }

    /// The slack [`Tri::depth_bounds`] adds over a rectangle whose farthest
    /// corner from the box's first sample is `(xb, yb)`.
    #[inline]
    pub fn depth_slack(&self, xb: u32, yb: u32) -> f32 {
        let (dxb, dyb) = ((xb - u32::from(self.x0)) as f32, (yb - u32::from(self.y0)) as f32);
        (self.zref.abs() + self.dzdx.abs() * dxb + self.dzdy.abs() * dyb) * DEPTH_SLACK
    }

    /// [`Tri::depth_at`] given the row's `zr = depth_row(py)` and the column
    /// offset `dx = px − x0`, for loops that compute the row once.
    #[inline(always)]
    pub fn depth_in_row(&self, zr: f32, dx: i32) -> f32 {
        (zr + self.dzdx * dx as f32).max(0.0)
    }
}

/// Relative slack of [`Tri::depth_bounds`]: covers the roundings (tested
/// against the formula itself).
const DEPTH_SLACK: f32 = 1.0 / (1 << 19) as f32;

/// Covered steps `lo..hi` of a row of `n` samples with edge values `e` at
/// step 0 and increments `step`, by testing each sample (the reference for tests).
fn scan_span(mut e: [i64; 3], step: [i64; 3], n: u32) -> Option<(u32, u32)> {
    let mut lo = u32::MAX;
    let mut hi = 0;
    for k in 0..n {
        if (e[0] | e[1] | e[2]) >= 0 {
            if lo == u32::MAX {
                lo = k;
            }
            hi = k + 1;
        } else if lo != u32::MAX {
            break; // the covered samples of a row are contiguous
        }
        e[0] += step[0];
        e[1] += step[1];
        e[2] += step[2];
    }
    (lo < hi).then_some((lo, hi))
}

/// As `scan_span`, solving `e[i] + step[i] * k >= 0` exactly per edge.
#[inline]
pub fn divide_span(e: [i64; 3], step: [i64; 3], n: u32) -> Option<(u32, u32)> {
    let mut lo: i64 = 0;
    let mut hi: i64 = i64::from(n) - 1;
    for i in 0..3 {
        let (s, e0) = (step[i], e[i]);
        if s > 0 {
            if e0 < 0 {
                lo = lo.max((-e0 + s - 1) / s); // ceil(-e0 / s)
            }
        } else if e0 < 0 {
            return None;
        } else if s < 0 {
            hi = hi.min(e0 / -s);
        }
    }
    (lo <= hi).then(|| (lo as u32, hi as u32 + 1))
}

/// The viewport a triangle is set up for.
#[derive(Clone, Copy, Debug)]
pub struct Viewport {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Guard-band limit on |x / w| (NDC).
    pub(crate) gx: f32,
    /// Guard-band limit on |y / w| (NDC).
    pub(crate) gy: f32,
}

impl Viewport {
    /// A viewport of `width` x `height` pixels (each 1..=16384).
    pub fn new(width: u32, height: u32) -> Viewport {
        Viewport {
            width,
            height,
            gx: GUARD_PX / width as f32,
            gy: GUARD_PX / height as f32,
        }
    }
}

/// A projected, snapped vertex.
#[derive(Clone, Copy, Debug)]
struct ScreenVertex {
    x: i64,
    y: i64,
    z: f32,
}

/// Up to 3 + 5 vertices after clipping against the near plane and four guard planes.
const MAX_POLY: usize = 8;

/// A clipped polygon, in `f64` so that intersections of huge (but finite)
/// coordinates neither overflow nor lose the vertices that were not clipped
/// (`f32 -> f64 -> f32` is exact).
#[derive(Clone, Copy)]
struct Poly {
    v: [DVec4; MAX_POLY],
    n: usize,
}

/// Clips `inp` to `dist(v) >= 0` (Sutherland–Hodgman). Intersections are always
/// computed from the inside vertex towards the outside one, so an edge shared
/// by two triangles is cut at bit-identical points in both.
fn clip_poly(inp: &Poly, out: &mut Poly, dist: impl Fn(DVec4) -> f64, exact: impl Fn(&mut DVec4)) {
    out.n = 0;
    for i in 0..inp.n {
        let a = inp.v[i];
        let b = inp.v[if i + 1 == inp.n { 0 } else { i + 1 }];
        let (da, db) = (dist(a), dist(b));
        let (ain, bin) = (da >= 0.0, db >= 0.0);
        if ain {
            out.v[out.n] = a;
            out.n += 1;
        }
        if ain != bin {
            let (p, q, dp, dq) = if ain { (a, b, da, db) } else { (b, a, db, da) };
            let t = dp / (dp - dq);
            let mut r = p + (q - p) * t;
            exact(&mut r);
            out.v[out.n] = r;
            out.n += 1;
        }
    }
}

/// Outcode bits of a clip-space vertex: outside the frustum sides, near, far.
#[inline]
fn outcode(v: Vec4) -> u32 {
    (u32::from(v.x < -v.w))
        | (u32::from(v.x > v.w) << 1)
        | (u32::from(v.y < -v.w) << 2)
        | (u32::from(v.y > v.w) << 3)
        | (u32::from(v.z < 0.0) << 4)
        | (u32::from(v.z > v.w) << 5)
}

/// True when the vertex lies outside the guard band (needs x/y clipping).
#[inline]
fn outside_guard(v: Vec4, vp: &Viewport) -> bool {
    !(v.x.abs() <= vp.gx * v.w && v.y.abs() <= vp.gy * v.w)
}

/// [`outside_guard`] for a clipped vertex.
#[inline]
fn outside_guard_f64(v: DVec4, vp: &Viewport) -> bool {
    !(v.x.abs() <= f64::from(vp.gx) * v.w && v.y.abs() <= f64::from(vp.gy) * v.w)
}

/// Projects a clip-space vertex (w > 0, inside the guard band) to snapped screen
/// coordinates; `None` if it is not representable (never for well-formed input).
#[inline]
fn project(v: Vec4, vp: &Viewport) -> Option<ScreenVertex> {
    // Also rejects NaN.
    if v.w.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let iw = 1.0 / v.w;
    let sx = (v.x * iw * 0.5 + 0.5) * vp.width as f32;
    let sy = (0.5 - v.y * iw * 0.5) * vp.height as f32;
    let z = v.z * iw;
    if !(sx.abs() <= LIMIT_PX && sy.abs() <= LIMIT_PX && z.is_finite()) {
        return None;
    }
    Some(ScreenVertex {
        x: snap(sx),
        y: snap(sy),
        z,
    })
}

/// `floor(p * ONE + 0.5)`: the nearest fixed-point value (halves round up),
/// for `|p| <= LIMIT_PX` (a cheap, exact replacement for a libm `round`).
#[inline]
fn snap(p: f32) -> i64 {
    let f = p * ONE as f32 + 0.5;
    let i = f as i64; // truncates towards zero; exact since |f| < 2^31
    i - i64::from((i as f32) > f)
}

/// Outcode bit: in front of the near plane fails (clip z < 0).
const NEAR_BIT: u32 = 1 << 4;
/// Outcode bit: outside the guard band (needs x/y clipping).
const GUARD_BIT: u32 = 1 << 6;
/// Outcode bit: unusable (non-finite coordinates, or projection failed).
const BAD_BIT: u32 = 1 << 7;

/// A transformed vertex with everything setup needs, computed once per vertex.
#[derive(Clone, Copy, Debug)]
pub struct Vertex {
    clip: Vec4,
    /// Frustum outcode bits 0..=5, plus `GUARD_BIT` and `BAD_BIT`.
    code: u32,
    /// Snapped screen position; valid when no near/guard/bad bit is set.
    s: ScreenVertex,
}

impl Vertex {
    /// Classifies and (when it needs no clipping) projects a clip-space vertex.
    /// A pure function of `clip` and the viewport.
    #[inline]
    pub fn new(clip: Vec4, vp: &Viewport) -> Vertex {
        let s = ScreenVertex { x: 0, y: 0, z: 0.0 };
        if !clip.is_finite() {
            return Vertex { clip, code: BAD_BIT, s };
        }
        let mut code = outcode(clip);
        if outside_guard(clip, vp) {
            code |= GUARD_BIT;
        }
        if code & (NEAR_BIT | GUARD_BIT) != 0 {
            return Vertex { clip, code, s };
        }
        match project(clip, vp) {
            Some(s) => Vertex { clip, code, s },
            None => Vertex { clip, code: BAD_BIT, s },
        }
    }
}

/// Which triangles a setup keeps, by their winding in normalized device
/// coordinates (x right, y up). hom's own scenes are two-sided; the Masked
/// Occlusion Culling benchmark inputs cull one winding.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum FaceCull {
    /// Keep both windings (two-sided; the renderer's rule).
    #[default]
    None,
    /// Drop triangles that are clockwise in NDC.
    Clockwise,
    /// Drop triangles that are counter-clockwise in NDC.
    CounterClockwise,
}

/// How [`setup_triangle_with`] sets a triangle up.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct SetupRule {
    /// Which windings to drop.
    pub cull: FaceCull,
    /// Cover only samples the *unsnapped* triangle surely covers, and write
    /// depths no nearer than its own: edges move inwards by a bound on the
    /// snapping error and depth moves back by the plane's change over that
    /// distance. For truths that do not snap (the Masked Occlusion Culling
    /// reference answers); off for the renderer's own rule.
    pub inner: bool,
}

/// Extra depth, in f32 epsilons, that the inner rule pushes a triangle back:
/// the renderer's own rounding of a surface's depth. A convex part's hull
/// lies a hair inside it (a 0.6 m wall's face 0.1 mm behind the original's)
/// and the renderer drew the original up to 9 epsilons farther than it is
/// on the sculpture park's walk, so the stand-in came out nearer in ~1 % of
/// its samples; 32 epsilons (4e-6 in depth, 3 cm at 30 m with a 0.1 m near
/// plane) keeps it behind on every frame of every walk.
pub(crate) const INNER_DEPTH_SLACK: f64 = 32.0;

/// Clips, projects and sets up a two-sided triangle of prepared vertices,
/// pushing 0 or more rasterizable triangles (a fan when clipped) onto `out`.
/// Returns how many were pushed.
pub fn setup_triangle(v: [&Vertex; 3], vp: &Viewport, item: u32, colour: [u8; 4], out: &mut Vec<Tri>) -> usize {
    setup_triangle_with(v, vp, SetupRule::default(), item, colour, out)
}

/// [`setup_triangle`] under `rule`: dropping the triangles `rule.cull` names
/// (a clipped triangle's fan keeps its winding, so it is culled as a whole).
pub fn setup_triangle_with(
    v: [&Vertex; 3],
    vp: &Viewport,
    rule: SetupRule,
    item: u32,
    colour: [u8; 4],
    out: &mut Vec<Tri>,
) -> usize {
    let (c0, c1, c2) = (v[0].code, v[1].code, v[2].code);
    if (c0 | c1 | c2) & BAD_BIT != 0 || c0 & c1 & c2 & 0x3f != 0 {
        // Unusable, or wholly outside one frustum plane (behind near, beyond far, off a side).
        return 0;
    }
    let near = (c0 | c1 | c2) & NEAR_BIT != 0;
    if !near && (c0 | c1 | c2) & GUARD_BIT == 0 {
        return usize::from(setup_screen([v[0].s, v[1].s, v[2].s], vp, rule, item, colour, out));
    }
    let mut a = Poly {
        v: [DVec4::ZERO; MAX_POLY],
        n: 3,
    };
    for (d, s) in a.v.iter_mut().zip(v) {
        *d = s.clip.as_dvec4();
    }
    let mut b = a;
    if near {
        clip_poly(&a, &mut b, |v| v.z, |v| v.z = 0.0);
        std::mem::swap(&mut a, &mut b);
    }
    if a.v[..a.n].iter().any(|&v| outside_guard_f64(v, vp)) {
        let (gx, gy) = (f64::from(vp.gx), f64::from(vp.gy));
        clip_poly(&a, &mut b, |v| gx * v.w - v.x, |_| ());
        clip_poly(&b, &mut a, |v| gx * v.w + v.x, |_| ());
        clip_poly(&a, &mut b, |v| gy * v.w - v.y, |_| ());
        clip_poly(&b, &mut a, |v| gy * v.w + v.y, |_| ());
    }
    if a.n < 3 {
        return 0;
    }
    let mut s = [ScreenVertex { x: 0, y: 0, z: 0.0 }; MAX_POLY];
    for (d, v) in s.iter_mut().zip(&a.v[..a.n]) {
        let v = v.as_vec4();
        if !v.is_finite() {
            return 0;
        }
        match project(v, vp) {
            Some(p) => *d = p,
            None => return 0,
        }
    }
    let mut pushed = 0;
    for i in 1..a.n - 1 {
        pushed += usize::from(setup_screen([s[0], s[i], s[i + 1]], vp, rule, item, colour, out));
    }
    pushed
}

/// Sets up one snapped screen triangle; false if it covers no pixel centre
/// or `cull` drops it.
fn setup_screen(
    v: [ScreenVertex; 3],
    vp: &Viewport,
    rule: SetupRule,
    item: u32,
    colour: [u8; 4],
    out: &mut Vec<Tri>,
) -> bool {
    let [v0, mut v1, mut v2] = v;
    let area = (v1.x - v0.x) * (v2.y - v0.y) - (v2.x - v0.x) * (v1.y - v0.y);
    // Screen y points down, so counter-clockwise in NDC is a negative area here.
    let dropped = match rule.cull {
        FaceCull::None => false,
        FaceCull::Clockwise => area > 0,
        FaceCull::CounterClockwise => area < 0,
    };
    if area == 0 || dropped {
        return false;
    }
    if area < 0 {
        // Two-sided: reorder so the inside is where every edge function is positive.
        std::mem::swap(&mut v1, &mut v2);
    }
    // Pixel bounds: px covered needs min_x <= px * ONE + HALF <= max_x.
    let min_x = v0.x.min(v1.x).min(v2.x);
    let max_x = v0.x.max(v1.x).max(v2.x);
    let min_y = v0.y.min(v1.y).min(v2.y);
    let max_y = v0.y.max(v1.y).max(v2.y);
    let x0 = (min_x - HALF + ONE - 1).div_euclid(ONE).max(0);
    let x1 = ((max_x - HALF).div_euclid(ONE) + 1).min(i64::from(vp.width));
    let y0 = (min_y - HALF + ONE - 1).div_euclid(ONE).max(0);
    let y1 = ((max_y - HALF).div_euclid(ONE) + 1).min(i64::from(vp.height));
    if x0 >= x1 || y0 >= y1 {
        return false;
    }
    // Inner rule: each true vertex lies within one fixed-point unit (snapping
    // plus f32 projection error) of its snapped position per axis, which moves
    // an edge function by at most 3 (W + H) + 4 inside the box (W, H in units).
    let inner_bias = if rule.inner {
        3 * ((max_x - min_x) + (max_y - min_y)) + 4
    } else {
        0
    };
    let mut a = [0i64; 3];
    let mut b = [0i64; 3];
    let mut c = [0i64; 3];
    for (i, (p, q)) in [(v0, v1), (v1, v2), (v2, v0)].into_iter().enumerate() {
        // E(s) = (q.x - p.x) * (s.y - p.y) - (q.y - p.y) * (s.x - p.x), positive inside.
        let ea = p.y - q.y;
        let eb = q.x - p.x;
        // Top-left rule (y down): a left edge has the inside to its right
        // (ea > 0); a top edge is horizontal with the inside below (eb > 0).
        let top_left = ea > 0 || (ea == 0 && eb > 0);
        a[i] = ea;
        b[i] = eb;
        c[i] = -(ea * p.x + eb * p.y) - i64::from(!top_left) - inner_bias;
    }
    // Depth plane through the snapped vertices (pixel units), evaluated at pixel
    // centres relative to the first covered pixel for precision.
    let to_px = |f: i64| f as f64 / ONE as f64;
    let (x0f, y0f, z0) = (to_px(v0.x), to_px(v0.y), f64::from(v0.z));
    let (dx1, dy1, dz1) = (to_px(v1.x) - x0f, to_px(v1.y) - y0f, f64::from(v1.z) - z0);
    let (dx2, dy2, dz2) = (to_px(v2.x) - x0f, to_px(v2.y) - y0f, f64::from(v2.z) - z0);
    let inv_det = 1.0 / (dx1 * dy2 - dx2 * dy1);
    let dzdx = (dz1 * dy2 - dz2 * dy1) * inv_det;
    let dzdy = (dz2 * dx1 - dz1 * dx2) * inv_det;
    let mut zref = z0 + dzdx * (x0 as f64 + 0.5 - x0f) + dzdy * (y0 as f64 + 0.5 - y0f);
    if rule.inner {
        // The plane through the true vertices differs by at most its change over
        // a few units of vertex displacement, plus f32 rounding, plus the slack.
        zref += (dzdx.abs() + dzdy.abs()) * (4.0 / ONE as f64)
            + (zref.abs() * 4.0 + INNER_DEPTH_SLACK) * f64::from(f32::EPSILON);
    }
    out.push(Tri {
        a,
        b,
        c,
        x0: x0 as u16,
        y0: y0 as u16,
        x1: x1 as u16,
        y1: y1 as u16,
        zref: zref as f32,
        dzdx: dzdx as f32,
        dzdy: dzdy as f32,
        item,
        colour,
    });
    true
}

#[cfg(test)]
mod tests {
    use super::*;
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

    /// One random triangle set up for a `w` × `h` viewport (none, one, or a
    /// clipped fan), from slivers to far beyond the screen.
    fn random_triangle(rng: &mut Rng, w: u32, h: u32) -> Vec<Tri> {
        let scale = [3.0, 30.0, 300.0, 3.0e5][rng.below(4) as usize];
        let (cx, cy) = (rng.range(-50.0, 350.0), rng.range(-50.0, 250.0));
        let v = [0; 3].map(|_| {
            let (dx, dy) = (rng.range(-0.5, 0.5) * scale, rng.range(-0.5, 0.5) * scale);
            at(cx + dx, cy + dy, rng.unit(), w, h)
        });
        setup(v, w, h)
    }

    #[test]
    fn nan_and_infinite_vertices_are_skipped() {
        let ok = Vec4::new(0.0, 0.0, 0.5, 1.0);
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            for k in 0..4 {
                let mut v = Vec4::new(0.5, 0.5, 0.5, 1.0);
                v[k] = bad;
                assert!(setup([ok, v, Vec4::new(-0.5, 0.5, 0.5, 1.0)], 32, 32).is_empty());
            }
        }
    }

    #[test]
    fn huge_coordinates_are_clipped_not_overflowed() {
        let full = |big: f32| {
            let tris = setup(
                [
                    Vec4::new(-big, -big, 0.5, 1.0),
                    Vec4::new(big, -big, 0.5, 1.0),
                    Vec4::new(0.0, big, 0.5, 1.0),
                ],
                64,
                48,
            );
            for t in &tris {
                assert!(t.x0 < t.x1 && t.x1 <= 64 && t.y0 < t.y1 && t.y1 <= 48);
            }
            (0..48u32)
                .map(|y| (0..64).filter(|&x| tris.iter().any(|t| t.covers(x, y))).count())
                .sum::<usize>()
        };
        // Far beyond the guard band (|x / w| up to 1e7): clipped to a polygon
        // that still covers the whole screen.
        assert_eq!(full(1.0e7), 64 * 48);
        // Near f32::MAX the clip intersections lose all relative precision; the
        // requirement is only that nothing overflows or panics.
        let _ = full(3.0e38);
        // Tiny w (a vertex very close to the eye plane but in front of near).
        let tris = setup(
            [
                Vec4::new(1.0, 1.0, 1e-30, 1e-30),
                Vec4::new(1.0, -1.0, 0.5, 1.0),
                Vec4::new(-1.0, 0.0, 0.5, 1.0),
            ],
            64,
            48,
        );
        for t in &tris {
            for y in t.y0..t.y1 {
                let _ = t.row_span(u32::from(y));
            }
        }
    }

    #[test]
    fn span_matches_per_sample_test() {
        // Triangles of many sizes, both windings; row_span (scan or divide) must
        // agree with evaluating the edge functions at every sample.
        let mut rng = Rng::new(12345);
        let mut rnd = move || rng.unit();
        for _ in 0..3000 {
            let scale = [2.0, 5.0, 20.0, 80.0][(rnd() * 4.0) as usize % 4];
            let cx = rnd() * 70.0 - 3.0;
            let cy = rnd() * 50.0 - 3.0;
            let v = [0, 1, 2].map(|_| at(cx + (rnd() - 0.5) * scale, cy + (rnd() - 0.5) * scale, rnd(), 64, 48));
            for t in setup(v, 64, 48) {
                for y in u32::from(t.y0)..u32::from(t.y1) {
                    let expect: Vec<u32> = (u32::from(t.x0)..u32::from(t.x1)).filter(|&x| t.covers(x, y)).collect();
                    let got: Vec<u32> = t.row_span(y).map_or(Vec::new(), |(a, b)| (a..b).collect());
                    assert_eq!(got, expect, "row {y} of {t:?}");
                }
            }
        }
    }

    /// `columns_in_rows` holds every covered sample of the rows it is asked
    /// about, says "none" only where none is covered, and on one row is no
    /// more than three columns wider than the span on either side (the f64
    /// slack), on triangles from slivers to far beyond the screen.
    #[test]
    fn columns_in_rows_hold_every_covered_sample() {
        let mut rng = Rng::new(4242);
        let (w, h) = (300, 200);
        let mut nonempty = 0;
        for _ in 0..5000 {
            for t in random_triangle(&mut rng, w, h) {
                let (y0, y1) = (u32::from(t.y0), u32::from(t.y1));
                let ya = y0 + rng.below(u64::from(y1 - y0)) as u32;
                let one_row = rng.below(2) == 0;
                let yb = if one_row {
                    ya + 1
                } else {
                    ya + 1 + rng.below(u64::from(y1 - ya)) as u32
                };
                let (lo, hi) = t.columns_in_rows(ya, yb);
                let covered = (ya..yb)
                    .filter_map(|y| t.row_span(y))
                    .fold(None, |acc: Option<(u32, u32)>, (a, b)| {
                        Some(acc.map_or((a, b), |(p, q)| (p.min(a), q.max(b))))
                    });
                match covered {
                    None => continue,
                    Some((a, b)) => {
                        nonempty += 1;
                        assert!(
                            lo <= a && b <= hi,
                            "rows {ya}..{yb} of {t:?}: {a}..{b} not within {lo}..{hi}"
                        );
                        let tight = !one_row || (a - lo <= 3 && hi - b <= 3);
                        assert!(tight, "rows {ya}..{yb} of {t:?}: {lo}..{hi} loose around {a}..{b}");
                    }
                }
            }
        }
        assert!(nonempty > 1500, "only {nonempty} non-empty row ranges");
    }

    /// `columns_in_every_row` is the intersection of the rows' exact spans,
    /// on triangles from slivers to far beyond the screen.
    #[test]
    fn columns_in_every_row_are_the_rows_common_span() {
        let mut rng = Rng::new(777);
        let (w, h) = (300, 200);
        let (mut nonempty, mut empty) = (0, 0);
        for _ in 0..5000 {
            for t in random_triangle(&mut rng, w, h) {
                let (y0, y1) = (u32::from(t.y0), u32::from(t.y1));
                let ya = y0 + rng.below(u64::from(y1 - y0)) as u32;
                let yb = ya + 1 + rng.below(u64::from(y1 - ya).min(40)) as u32;
                let common = (ya..yb).try_fold((0, u32::MAX), |(p, q), y| {
                    t.row_span(y).map(|(a, b)| (p.max(a), q.min(b)))
                });
                let want = common.filter(|(a, b)| a < b);
                assert_eq!(t.columns_in_every_row(ya, yb), want, "rows {ya}..{yb} of {t:?}");
                if want.is_some() {
                    nonempty += 1;
                } else {
                    empty += 1;
                }
            }
        }
        assert!(nonempty > 1000 && empty > 1000, "{nonempty} non-empty, {empty} empty");
    }

    #[test]
    fn shared_edge_through_pixel_centres_is_covered_once() {
        // A quad split along its diagonal; corners on pixel centres, so the
        // diagonal passes exactly through samples.
        let (w, h) = (16, 16);
        let p = |x: f32, y: f32| at(x, y, 0.5, w, h);
        let quad = [p(0.5, 0.5), p(12.5, 0.5), p(12.5, 12.5), p(0.5, 12.5)];
        for diag in [[0, 1, 2, 0, 2, 3], [0, 1, 3, 1, 2, 3]] {
            let t1 = setup([quad[diag[0]], quad[diag[1]], quad[diag[2]]], w, h);
            let t2 = setup([quad[diag[3]], quad[diag[4]], quad[diag[5]]], w, h);
            let mut inside = 0;
            for y in 0..h {
                for x in 0..w {
                    let n = t1.iter().chain(&t2).filter(|t| t.covers(x, y)).count();
                    assert!(n <= 1, "pixel {x},{y} covered {n} times");
                    inside += n;
                }
            }
            // Top and left quad edges are covered, bottom and right are not: 12 x 12.
            assert_eq!(inside, 144);
        }
    }

    /// Random triangles and random cells of their boxes: every covered
    /// sample's depth lies within `depth_bounds` of its cell.
    #[test]
    fn depth_bounds_hold_every_covered_sample() {
        let mut rng = Rng::new(41);
        let (w, h) = (200, 120);
        let mut checked = 0;
        for _ in 0..400 {
            let clip = [0; 3].map(|_| {
                let wv = rng.range(0.2, 30.0);
                Vec4::new(
                    rng.range(-1.5, 1.5) * wv,
                    rng.range(-1.5, 1.5) * wv,
                    wv * rng.range(0.0, 1.0),
                    wv,
                )
            });
            for t in setup(clip, w, h) {
                let (x0, x1, y0, y1) = (u32::from(t.x0), u32::from(t.x1), u32::from(t.y0), u32::from(t.y1));
                let mut pick = |a: u32, b: u32| {
                    let (p, q) = (
                        a + rng.below(u64::from(b - a)) as u32,
                        a + rng.below(u64::from(b - a)) as u32,
                    );
                    (p.min(q), p.max(q))
                };
                let cols: [(u32, u32); 4] = std::array::from_fn(|_| pick(x0, x1));
                let rows: [(u32, u32); 2] = std::array::from_fn(|_| pick(y0, y1));
                for (&(xa, xb), &(ya, yb)) in (0..8).map(|k| (&cols[k % 4], &rows[k / 4])) {
                    let (near, far) = t.depth_bounds(xa, xb, ya, yb);
                    for y in ya..=yb {
                        for x in xa..=xb {
                            if t.covers(x, y) {
                                let z = t.depth_at(x, y);
                                assert!(near <= z && z <= far, "{t:?} at {x},{y}: {z} outside {near}..{far}");
                                checked += 1;
                            }
                        }
                    }
                }
            }
        }
        assert!(checked > 10_000, "only {checked} samples checked");
    }
}
