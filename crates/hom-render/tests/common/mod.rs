//! Shared helpers of the integration tests: scene builders and a brute-force ray caster.
#![allow(dead_code, missing_docs)]

use hom::geom::Camera;
use hom::glam::{DVec3, Mat4, Vec3};
use hom::scene::{Mesh, Scene, SceneBuilder};
use hom_render::NO_OBJECT;

/// A scene with one object per entry; each object is a mesh of world-space
/// triangles placed with the given transform.
pub fn scene_of(objects: &[(Vec<[Vec3; 3]>, Mat4)]) -> Scene {
    let mut b = SceneBuilder::new("test");
    for (i, (tris, transform)) in objects.iter().enumerate() {
        let positions: Vec<Vec3> = tris.iter().flatten().copied().collect();
        let triangles: Vec<[u32; 3]> = (0..tris.len() as u32).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
        let m = b.add_mesh(Mesh::new(format!("m{i}"), positions, triangles).unwrap());
        b.add_object(format!("o{i}"), m, *transform).unwrap();
    }
    b.build().unwrap()
}

/// What a pixel shows according to the ray caster.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Truth {
    /// The pixel must show this object (or `NO_OBJECT`).
    Exactly(u32),
    /// Too close to an edge, a depth tie or a clip plane to be decided.
    Ambiguous,
}

/// Ray through screen point `(sx, sy)`: origin and a direction whose
/// component along the view axis is 1, so the ray parameter is view depth.
fn ray(camera: &Camera, sx: f64, sy: f64) -> (DVec3, DVec3) {
    let eye = camera.eye.as_dvec3();
    let f = (camera.target.as_dvec3() - eye).normalize();
    let r = f.cross(camera.up.as_dvec3()).normalize();
    let u = r.cross(f);
    let th = (f64::from(camera.fov_y) * 0.5).tan();
    let aspect = f64::from(camera.width) / f64::from(camera.height);
    let nx = sx / f64::from(camera.width) * 2.0 - 1.0;
    let ny = 1.0 - sy / f64::from(camera.height) * 2.0;
    (eye, f + r * (nx * th * aspect) + u * (ny * th))
}

/// Möller–Trumbore; the ray parameter of the hit (any sign), if any.
fn intersect(o: DVec3, d: DVec3, t: [DVec3; 3]) -> Option<f64> {
    let e1 = t[1] - t[0];
    let e2 = t[2] - t[0];
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-300 {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - t[0];
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    Some(e2.dot(q) * inv)
}

/// World-space triangles of every object, with their object id.
pub fn world_triangles(scene: &Scene, ids: &[u32]) -> Vec<(u32, [DVec3; 3])> {
    let mut out = Vec::new();
    for &id in ids {
        let o = scene.object(id);
        let mesh = scene.mesh_of(o);
        for t in mesh.triangles() {
            let w = t.map(|i| o.transform.transform_point3(mesh.positions()[i as usize]).as_dvec3());
            out.push((id, w));
        }
    }
    out
}

/// Relative tolerance on view depth for ties and for the near/far planes.
const DEPTH_EPS: f64 = 1e-3;
/// Screen-space perturbation (pixels) that decides whether a pixel is near an edge.
const EDGE_EPS: f64 = 0.05;

/// Nearest object along the ray through screen point `(sx, sy)`, and whether
/// that answer is fragile (a depth tie or a hit near a clip plane).
fn nearest(camera: &Camera, tris: &[(u32, [DVec3; 3])], sx: f64, sy: f64) -> (u32, bool) {
    let (o, d) = ray(camera, sx, sy);
    let (near, far) = (f64::from(camera.near), f64::from(camera.far));
    let mut hits: Vec<(f64, u32)> = Vec::new();
    let mut fragile = false;
    for &(id, t) in tris {
        if let Some(depth) = intersect(o, d, t) {
            if (depth - near).abs() <= DEPTH_EPS * near || (depth - far).abs() <= DEPTH_EPS * far {
                fragile = true;
            }
            if depth >= near && depth <= far {
                hits.push((depth, id));
            }
        }
    }
    hits.sort_by(|a, b| a.0.total_cmp(&b.0));
    let Some(&(t0, id0)) = hits.first() else {
        return (NO_OBJECT, fragile);
    };
    if hits.iter().any(|&(t, id)| id != id0 && t - t0 <= DEPTH_EPS * t0) {
        fragile = true;
    }
    (id0, fragile)
}

/// Screen distance (pixels) within which a pixel centre counts as on a
/// triangle's edge: covers vertex snapping (1/512 px) and float rounding.
const EDGE_DIST: f64 = 0.02;

/// Each triangle's screen-space outline (f64): the triangle clipped to view
/// depth >= near, projected. Sub-pixel slivers are outlines too.
pub fn outlines(camera: &Camera, tris: &[(u32, [DVec3; 3])]) -> Vec<Vec<(f64, f64)>> {
    let eye = camera.eye.as_dvec3();
    let f = (camera.target.as_dvec3() - eye).normalize();
    let r = f.cross(camera.up.as_dvec3()).normalize();
    let u = r.cross(f);
    let th = (f64::from(camera.fov_y) * 0.5).tan();
    let aspect = f64::from(camera.width) / f64::from(camera.height);
    let near = f64::from(camera.near);
    let (w, h) = (f64::from(camera.width), f64::from(camera.height));
    tris.iter()
        .map(|(_, t)| {
            let v: Vec<DVec3> = t
                .iter()
                .map(|p| DVec3::new((*p - eye).dot(r), (*p - eye).dot(u), (*p - eye).dot(f)))
                .collect();
            let mut poly = Vec::new();
            for i in 0..3 {
                let (a, b) = (v[i], v[(i + 1) % 3]);
                if a.z >= near {
                    poly.push(a);
                }
                if (a.z >= near) != (b.z >= near) {
                    poly.push(a + (b - a) * ((near - a.z) / (b.z - a.z)));
                }
            }
            poly.iter()
                .map(|p| {
                    (
                        (p.x / (p.z * th * aspect) * 0.5 + 0.5) * w,
                        (0.5 - p.y / (p.z * th) * 0.5) * h,
                    )
                })
                .collect()
        })
        .collect()
}

/// True when `(x, y)` is within `EDGE_DIST` of an edge of the outline.
fn near_outline(outline: &[(f64, f64)], x: f64, y: f64) -> bool {
    let n = outline.len();
    (0..n).any(|i| {
        let (a, b) = (outline[i], outline[(i + 1) % n]);
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let len2 = dx * dx + dy * dy;
        let t = if len2 > 0.0 {
            (((x - a.0) * dx + (y - a.1) * dy) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let (ex, ey) = (a.0 + t * dx - x, a.1 + t * dy - y);
        ex * ex + ey * ey <= EDGE_DIST * EDGE_DIST
    })
}

/// The ray-cast truth at pixel `(px, py)`: the nearest object through the
/// pixel centre, unless the centre lies within `EDGE_DIST` of a triangle's
/// outline, the answer changes within `EDGE_EPS` pixels, or it is a near tie
/// in depth or near a clip plane.
pub fn truth(camera: &Camera, tris: &[(u32, [DVec3; 3])], outlines: &[Vec<(f64, f64)>], px: u32, py: u32) -> Truth {
    let (cx, cy) = (f64::from(px) + 0.5, f64::from(py) + 0.5);
    let (id, mut fragile) = nearest(camera, tris, cx, cy);
    fragile |= outlines.iter().any(|o| near_outline(o, cx, cy));
    for (dx, dy) in [(EDGE_EPS, 0.0), (-EDGE_EPS, 0.0), (0.0, EDGE_EPS), (0.0, -EDGE_EPS)] {
        let (other, f) = nearest(camera, tris, cx + dx, cy + dy);
        fragile |= f || other != id;
    }
    if fragile {
        Truth::Ambiguous
    } else {
        Truth::Exactly(id)
    }
}

/// Compares an item buffer with the ray caster: returns (ambiguous pixels,
/// mismatches at unambiguous pixels as (x, y, rendered, truth)).
pub fn compare_with_ray_cast(
    scene: &Scene,
    ids: &[u32],
    camera: &Camera,
    items: &[u32],
) -> (usize, Vec<(u32, u32, u32, u32)>) {
    let tris = world_triangles(scene, ids);
    let outlines = outlines(camera, &tris);
    let mut ambiguous = 0;
    let mut bad = Vec::new();
    for py in 0..camera.height {
        for px in 0..camera.width {
            let got = items[(py * camera.width + px) as usize];
            match truth(camera, &tris, &outlines, px, py) {
                Truth::Ambiguous => ambiguous += 1,
                Truth::Exactly(id) if id != got => bad.push((px, py, got, id)),
                Truth::Exactly(_) => {}
            }
        }
    }
    (ambiguous, bad)
}

/// World point that projects to screen point `(sx, sy)` at view depth `depth`.
pub fn unproject(camera: &Camera, sx: f64, sy: f64, depth: f64) -> Vec3 {
    let (o, d) = ray(camera, sx, sy);
    (o + d * depth).as_vec3()
}
