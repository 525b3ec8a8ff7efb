//! Closed occluders are drawn without their back faces.
//!
//! A mesh whose triangles, with vertices matched by position, pair every
//! directed edge with its reverse exactly once is a closed, consistently
//! oriented surface. Projected, such a surface covers each sample as often
//! with front faces as with back faces (the projection of a closed surface
//! has degree 0 everywhere, and the fill rule gives a sample on a fold to
//! both triangles of the fold or to neither), so every sample it covers is
//! covered by a front face, and the front face is the nearer. Dropping the
//! back faces therefore leaves the coverage as it was where nothing of the
//! mesh is clipped, and only removes coverage where the near plane cuts it
//! (conservative either way); HOM's depth cells then keep the front face's
//! depth as the first cover, not the back face's. The orientation comes
//! from the sign of the enclosed volume; the winding to drop on screen from
//! that and the sign of the model-to-clip determinant (a mirrored placement
//! or a left-handed projection turns it).
//!
//! Only occluders drawn as their own meshes, exactly, qualify: a stand-in
//! drawn by the inner rule loses the samples along every edge of its front
//! faces that the back faces would have covered (sculpture-park, HOM
//! efficiency 83.0 → 70.9 % when its stand-ins dropped their back faces).

use crate::occlusion::FaceCull;
use crate::scene::Mesh;
use glam::Mat4;
use std::collections::HashMap;

/// The winding, by the right-hand rule in the mesh's own space, of a closed
/// mesh's outward faces: counter-clockwise when its enclosed volume is
/// positive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Outward {
    /// Outward faces wind counter-clockwise seen from outside.
    CounterClockwise,
    /// Outward faces wind clockwise seen from outside.
    Clockwise,
}

/// The winding of `mesh`'s outward faces when it is closed and consistently
/// oriented (every directed edge, vertices matched by position, has its
/// reverse exactly once; triangles with two equal corners are ignored) and
/// encloses some volume; `None` otherwise.
pub(crate) fn outward_winding(mesh: &Mesh) -> Option<Outward> {
    let p = mesh.positions();
    let mut ids: HashMap<[u32; 3], u32> = HashMap::with_capacity(p.len());
    let vertex: Vec<u32> = p
        .iter()
        .map(|q| {
            let next = ids.len() as u32;
            *ids.entry(q.to_array().map(f32::to_bits)).or_insert(next)
        })
        .collect();
    let mut edges: HashMap<(u32, u32), u32> = HashMap::with_capacity(3 * mesh.triangle_count());
    // Six times the enclosed volume, in f64: a sum of signed tetrahedra.
    let mut volume = 0.0f64;
    for t in mesh.triangles() {
        let [a, b, c] = t.map(|i| vertex[i as usize]);
        if a == b || b == c || a == c {
            continue;
        }
        for e in [(a, b), (b, c), (c, a)] {
            *edges.entry(e).or_insert(0) += 1;
        }
        let [pa, pb, pc] = t.map(|i| p[i as usize].as_dvec3());
        volume += pa.dot(pb.cross(pc));
    }
    let closed = edges
        .iter()
        .all(|(&(a, b), &n)| n == 1 && edges.get(&(b, a)) == Some(&1));
    if !closed || edges.is_empty() || !volume.is_finite() || volume == 0.0 {
        return None;
    }
    Some(if volume > 0.0 {
        Outward::CounterClockwise
    } else {
        Outward::Clockwise
    })
}

/// The faces to drop when drawing a closed mesh whose outward faces wind
/// `outward`, placed by `model_to_clip`: its back faces; none when the
/// placement is degenerate.
pub(crate) fn back_faces(outward: Outward, model_to_clip: &Mat4) -> FaceCull {
    let det = model_to_clip.determinant();
    if !det.is_finite() || det == 0.0 {
        return FaceCull::None;
    }
    // A right-handed camera's projection turns orientation (det < 0): a
    // counter-clockwise outward face then faces the eye counter-clockwise
    // in NDC, and the clockwise ones are the back faces.
    match (outward == Outward::CounterClockwise) == (det < 0.0) {
        true => FaceCull::Clockwise,
        false => FaceCull::CounterClockwise,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::Camera;
    use crate::occlusion::{BufferOptions, HomBuffer, OcclusionBuffer, Sampling};
    use glam::{Quat, Vec3};
    use hom_testkit::Rng;

    /// A unit cube, outward faces counter-clockwise; each face its own four
    /// vertices (as flat-shaded meshes come), so edges match by position only.
    fn cube() -> Mesh {
        let faces: [[usize; 4]; 6] = [
            [0, 1, 3, 2],
            [4, 6, 7, 5],
            [0, 4, 5, 1],
            [2, 3, 7, 6],
            [0, 2, 6, 4],
            [1, 5, 7, 3],
        ];
        let corner = |i: usize| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32) - 0.5;
        let (mut p, mut t) = (Vec::new(), Vec::new());
        for f in faces {
            let b = p.len() as u32;
            p.extend(f.map(corner));
            // The listed corners wind clockwise seen from outside: reversed here.
            t.extend([[b, b + 2, b + 1], [b, b + 3, b + 2]]);
        }
        Mesh::new("cube", p, t).unwrap()
    }

    fn reversed(m: &Mesh) -> Mesh {
        let t = m.triangles().iter().map(|&[a, b, c]| [a, c, b]).collect();
        Mesh::new("reversed", m.positions().to_vec(), t).unwrap()
    }

    #[test]
    fn closed_meshes_and_their_orientation() {
        let cube = cube();
        assert_eq!(outward_winding(&cube), Some(Outward::CounterClockwise));
        assert_eq!(outward_winding(&reversed(&cube)), Some(Outward::Clockwise));
        // A face short: open.
        let open = Mesh::new("open", cube.positions().to_vec(), cube.triangles()[..10].to_vec()).unwrap();
        assert_eq!(outward_winding(&open), None);
        // A quad with both sides: every edge paired, but no volume.
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        let both = Mesh::new("both", p, vec![[0, 1, 2], [0, 2, 3], [0, 2, 1], [0, 3, 2]]).unwrap();
        assert_eq!(outward_winding(&both), None);
        // A triangle used twice the same way: an edge appears twice.
        let mut t = cube.triangles().to_vec();
        t.push(t[0]);
        t.push([t[0][0], t[0][2], t[0][1]]);
        assert_eq!(
            outward_winding(&Mesh::new("twice", cube.positions().to_vec(), t).unwrap()),
            None
        );
    }

    fn draw(mesh: &Mesh, model: &Mat4, camera: &Camera, cull: FaceCull) -> (Vec<u64>, Vec<f32>) {
        let options = BufferOptions {
            sampling: Sampling::Exact,
            ..BufferOptions::default()
        };
        let mut b = HomBuffer::new(camera.width, camera.height, options).unwrap();
        let world: Vec<Vec3> = mesh.positions().iter().map(|&q| model.transform_point3(q)).collect();
        b.render_triangles(&world, mesh.triangles(), &camera.view_proj(), cull)
            .unwrap();
        b.flush();
        let bits = b.coverage().bits().to_vec();
        let cells = b.depth_cells().map_or(Vec::new(), |(c, _)| c.to_vec());
        (bits, cells)
    }

    /// Cubes in front of the camera, turned, stretched and mirrored at
    /// random: without their back faces they cover exactly the samples they
    /// cover two-sided; the depth cells hold the front faces' depth, nearer
    /// on the whole than the back faces' (the cells are bounds per run of
    /// rows, so a single cell may differ either way).
    #[test]
    fn dropping_back_faces_keeps_coverage_and_the_front_depth() {
        let mut rng = Rng::new(5);
        let camera = Camera::new(Vec3::new(0.0, 0.0, 6.0), Vec3::ZERO, Vec3::Y, 1.0, 0.1, 100.0, 160, 120);
        for mesh in [cube(), reversed(&cube())] {
            let outward = outward_winding(&mesh).unwrap();
            for case in 0..40 {
                let mirror = if case % 2 == 0 { 1.0 } else { -1.0 };
                let scale = Vec3::new(mirror * rng.range(0.5, 2.5), rng.range(0.5, 2.5), rng.range(0.5, 2.5));
                let rot = Quat::from_euler(
                    glam::EulerRot::YXZ,
                    rng.range(0.0, 6.3),
                    rng.range(0.0, 6.3),
                    rng.range(0.0, 6.3),
                );
                let at = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
                let model = Mat4::from_scale_rotation_translation(scale, rot, at);
                let mvp = camera.view_proj() * model;
                let cull = back_faces(outward, &mvp);
                let other = match cull {
                    FaceCull::Clockwise => FaceCull::CounterClockwise,
                    _ => FaceCull::Clockwise,
                };
                let (both, _) = draw(&mesh, &model, &camera, FaceCull::None);
                let (front, cells_front) = draw(&mesh, &model, &camera, cull);
                let (back, cells_back) = draw(&mesh, &model, &camera, other);
                assert!(both.iter().any(|&w| w != 0), "case {case}: the cube is in view");
                assert_eq!(front, both, "case {case}: coverage without back faces");
                assert_eq!(back, both, "case {case}: coverage without front faces");
                let sum = |cells: &[f32]| {
                    cells
                        .iter()
                        .filter(|c| c.is_finite())
                        .map(|&c| f64::from(c))
                        .sum::<f64>()
                };
                assert!(
                    sum(&cells_front) < sum(&cells_back),
                    "case {case}: the front faces are nearer ({} against {})",
                    sum(&cells_front),
                    sum(&cells_back)
                );
            }
        }
    }
}
