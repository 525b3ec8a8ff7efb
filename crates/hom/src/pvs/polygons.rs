//! Adjacent coplanar triangles joined into convex polygons, the larger
//! planar occluders the bake tests one at a time (Law & Tan 1999, section
//! 5.2: "adjacent occluders are joined to form larger occluders").
//!
//! A wall quad is two triangles, and a box's face too; alone, neither half
//! hides what lies behind the diagonal from a whole cell. Joined, the quad
//! does: a ray through its interior meets one of the two triangles, since
//! the renderer draws triangles that share an edge (the same two vertex
//! indices) without a crack. So only triangles of one mesh that share an
//! edge by index, wound consistently and coplanar, are joined, and only
//! while the polygon stays convex.

use crate::scene::Mesh;
use glam::{DVec3, Vec3};
use std::collections::HashMap;

/// Coplanar within this share of the triangles' size.
const FLAT: f64 = 1e-7;

/// The mesh's triangles joined into convex polygons (object space, corners
/// in order); every triangle is in exactly one polygon, degenerate ones in
/// none.
pub(crate) fn convex_polygons(mesh: &Mesh) -> Vec<Vec<Vec3>> {
    let p: Vec<DVec3> = mesh.positions().iter().map(|v| v.as_dvec3()).collect();
    let tris = mesh.triangles();
    // Directed edge -> the triangle that has it.
    let mut edge_of: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
    for (t, tri) in tris.iter().enumerate() {
        for k in 0..3 {
            edge_of.entry((tri[k], tri[(k + 1) % 3])).or_default().push(t as u32);
        }
    }
    let normal = |t: &[u32; 3]| (p[t[1] as usize] - p[t[0] as usize]).cross(p[t[2] as usize] - p[t[0] as usize]);
    let mut used = vec![false; tris.len()];
    let mut out = Vec::new();
    for start in 0..tris.len() {
        if used[start] {
            continue;
        }
        used[start] = true;
        let n = normal(&tris[start]);
        if n.length().is_nan() || n.length() <= 0.0 {
            continue;
        }
        let n = n.normalize();
        let mut ring: Vec<u32> = tris[start].to_vec();
        let size = |ring: &[u32]| {
            let c = p[ring[0] as usize];
            ring.iter().map(|&i| p[i as usize].distance(c)).fold(0.0, f64::max)
        };
        'grow: loop {
            for k in 0..ring.len() {
                let (a, b) = (ring[k], ring[(k + 1) % ring.len()]);
                // The neighbour across (a, b) runs it the other way; only a
                // manifold edge (one triangle each way) is joined across.
                let (Some(ab), Some(ba)) = (edge_of.get(&(a, b)), edge_of.get(&(b, a))) else {
                    continue;
                };
                if ab.len() != 1 || ba.len() != 1 || used[ba[0] as usize] {
                    continue;
                }
                let u = &tris[ba[0] as usize];
                let c = *u
                    .iter()
                    .find(|&&v| v != a && v != b)
                    .expect("a triangle has a third corner");
                let scale = size(&ring).max(1e-30);
                let un = normal(u);
                let flat = un.length() > 0.0
                    && un.normalize().dot(n) > 1.0 - FLAT
                    && (p[c as usize] - p[a as usize]).dot(n).abs() <= FLAT * scale;
                if !flat || ring.contains(&c) {
                    continue;
                }
                let mut grown = ring.clone();
                grown.insert(k + 1, c);
                if convex(&grown, &p, n) {
                    used[ba[0] as usize] = true;
                    ring = grown;
                    continue 'grow;
                }
            }
            break;
        }
        out.push(ring.iter().map(|&i| mesh.positions()[i as usize]).collect());
    }
    out
}

/// Is the ring (wound counter-clockwise about `n`) convex: every corner
/// turning left or straight on?
fn convex(ring: &[u32], p: &[DVec3], n: DVec3) -> bool {
    let m = ring.len();
    (0..m).all(|k| {
        let (a, b, c) = (
            p[ring[k] as usize],
            p[ring[(k + 1) % m] as usize],
            p[ring[(k + 2) % m] as usize],
        );
        let turn = (b - a).cross(c - b).dot(n);
        turn >= -1e-9 * (b - a).length() * (c - b).length()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cube_gives_its_six_faces_and_an_l_stays_two_pieces() {
        let (mut p, mut t) = (Vec::new(), Vec::new());
        crate::occluders::push_box(&mut p, &mut t, Vec3::ZERO, Vec3::ONE);
        let cube = Mesh::new("cube", p, t).unwrap();
        let faces = convex_polygons(&cube);
        assert_eq!(faces.len(), 6);
        assert!(faces.iter().all(|f| f.len() == 4));
        // An L of three unit squares: not convex, so more than one polygon,
        // each convex, covering the three squares.
        let p = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(2.0, 1.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
            Vec3::new(1.0, 2.0, 0.0),
        ];
        let sq = |a: u32, b: u32, c: u32, d: u32| [[a, b, c], [a, c, d]];
        let t: Vec<[u32; 3]> = [sq(0, 1, 4, 3), sq(1, 2, 5, 4), sq(3, 4, 7, 6)].concat();
        let l = Mesh::new("L", p, t).unwrap();
        let pieces = convex_polygons(&l);
        assert!(pieces.len() >= 2);
        let area: f32 = pieces
            .iter()
            .map(|f| {
                (1..f.len() - 1)
                    .map(|i| 0.5 * (f[i] - f[0]).cross(f[i + 1] - f[0]).length())
                    .sum::<f32>()
            })
            .sum();
        assert!((area - 3.0).abs() < 1e-5, "{area}");
        for f in &pieces {
            assert!(
                super::super::region::ConvexOccluder::polygon(0, f).is_some(),
                "{f:?} is not convex"
            );
        }
    }
}
