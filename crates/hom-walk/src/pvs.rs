//! The map's own PVS as a yardstick (Quake 3 maps).
//!
//! A Quake 3 map carries a precomputed potentially visible set: the cluster of
//! the camera's leaf marks which clusters may be seen from it. For each frame of
//! a walkthrough this module
//!
//! - checks the loader and the oracle against it: every object the oracle sees
//!   must lie in a cluster the PVS marks visible from the camera's cluster (a
//!   **violation** is one that does not; there must be none), and
//! - counts the triangles each approach would draw: the view **frustum** alone,
//!   the **PVS** alone (objects in the frustum whose clusters are PVS-visible),
//!   **HOM** alone (the culler's visible set), **PVS then HOM** (the
//!   intersection) and the **oracle**'s visible set (the least any conservative
//!   culler can draw).
//!
//! Frames whose eye lies in no cluster (solid space) say nothing about the PVS:
//! there the PVS keeps everything in the frustum and no violation is counted.
//! Report fields are prefixed `pvs_` and added to the walk's frame and summary
//! lines ([`FrameWithPvs`], [`SummaryWithPvs`]), never renaming theirs.

use crate::report::{median, FrameRecord, Summary};
use glam::Vec3;
use hom::geom::{Camera, Containment, Frustum};
use hom::scene::Scene;
use hom_scene::bsp::{BspMap, BspOptions};
use hom_scene::LoadError;
use serde::Serialize;
use std::path::Path;

/// Loads the Quake 3 map a scene spec names (`FILE.bsp`, `FILE.pk3` or
/// `FILE.pk3:MAP`, see [`hom_scene::split_map_spec`]) with default options, the
/// same scene [`crate::open_scene`] loads. Any other spec is
/// [`LoadError::UnknownFormat`]: only these maps carry a PVS.
pub fn open_map(spec: &str) -> Result<BspMap, LoadError> {
    open_map_with(spec, &hom_scene::LoadOptions::default())
}

/// Does a scene spec name a Quake 3 map (`FILE.bsp`, `FILE.pk3` or
/// `FILE.pk3:MAP`), the scenes that carry a PVS and leaf portals?
pub fn is_map_spec(spec: &str) -> bool {
    let (file, _) = hom_scene::split_map_spec(Path::new(spec));
    let ext = file.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    matches!(ext.as_deref(), Some("bsp") | Some("pk3"))
}

/// [`open_map`] with the loaders' options (`--clusters`).
pub fn open_map_with(spec: &str, load: &hom_scene::LoadOptions) -> Result<BspMap, LoadError> {
    if !is_map_spec(spec) {
        return Err(LoadError::UnknownFormat { path: spec.to_string() });
    }
    let (file, map) = hom_scene::split_map_spec(Path::new(spec));
    let options = BspOptions {
        map,
        split: load.split.clone(),
        ..BspOptions::default()
    };
    hom_scene::bsp::load(&file, &options)
}

/// A map's cluster visibility, as the yardstick needs it.
pub trait ClusterPvs {
    /// The cluster holding `eye` (hom coordinates), `None` in solid space.
    fn camera_cluster(&self, eye: Vec3) -> Option<i32>;
    /// Does the PVS mark object `id` potentially visible from cluster `from`?
    fn object_visible_from(&self, id: u32, from: i32) -> bool;
}

impl ClusterPvs for BspMap {
    fn camera_cluster(&self, eye: Vec3) -> Option<i32> {
        self.cluster_of(eye)
    }

    fn object_visible_from(&self, id: u32, from: i32) -> bool {
        BspMap::object_visible_from(self, id, from)
    }
}

/// The PVS a map's leaf portals give ([`BspMap::portal_pvs`]: object by
/// object, per cluster), as the yardstick's cluster visibility.
pub struct PortalPvsView<'a> {
    /// The map (its tree finds the eye's cluster).
    pub map: &'a BspMap,
    /// What each cluster sees through the portals.
    pub portals: &'a hom_scene::bsp::PortalPvs,
}

impl ClusterPvs for PortalPvsView<'_> {
    fn camera_cluster(&self, eye: Vec3) -> Option<i32> {
        self.map.cluster_of(eye)
    }

    fn object_visible_from(&self, id: u32, from: i32) -> bool {
        self.portals.object_visible_from(id, from)
    }
}

/// A PVS baked by hom ([`hom::pvs::Pvs`]) as the yardstick's cluster
/// visibility, for one frame's view: its "cluster" is the eye's cell (a node
/// id), `None` where the PVS does not serve the view. Objects that have
/// become dynamic are never hidden, as [`hom::cull::PvsCuller`] does.
pub struct BakedPvsView {
    cell: Option<i32>,
    hidden: Vec<u32>,
}

impl BakedPvsView {
    /// What `pvs` hides from `view` in `scene`.
    pub fn new(pvs: &hom::pvs::Pvs, scene: &Scene, view: &hom::geom::View) -> BakedPvsView {
        let mut hidden = Vec::new();
        let cell = pvs.hidden_in(scene, view, &mut hidden);
        BakedPvsView {
            cell: cell.map(|c| c as i32),
            hidden,
        }
    }
}

impl ClusterPvs for BakedPvsView {
    fn camera_cluster(&self, _eye: Vec3) -> Option<i32> {
        self.cell
    }

    fn object_visible_from(&self, id: u32, _from: i32) -> bool {
        self.hidden.binary_search(&id).is_err()
    }
}

/// What the PVS says about one frame (all triangle counts are of whole objects).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct PvsFrame {
    /// The cluster of the camera's eye; `None` in solid space (the PVS then keeps everything).
    pub pvs_camera_cluster: Option<i32>,
    /// Triangles of the objects whose boxes are not outside the view frustum.
    pub pvs_triangles_frustum: u64,
    /// Triangles of the objects in the frustum that the PVS marks visible.
    pub pvs_triangles_pvs: u64,
    /// Triangles of the culler's visible set.
    pub pvs_triangles_hom: u64,
    /// Triangles of the culler's visible set that the PVS also marks visible.
    pub pvs_triangles_pvs_hom: u64,
    /// Triangles of the objects owning at least one pixel.
    pub pvs_triangles_oracle: u64,
    /// Sorted ids the oracle sees that the PVS hides from the camera's cluster (must be empty).
    pub pvs_violations: Vec<u32>,
}

/// The yardstick for one frame: `visible` is the culler's visible set,
/// `oracle_visible` the objects owning a pixel (ids of `scene`, which must be
/// the scene `pvs` describes).
pub fn pvs_frame(
    pvs: &impl ClusterPvs,
    scene: &Scene,
    camera: &Camera,
    visible: &[u32],
    oracle_visible: &[u32],
) -> PvsFrame {
    let objects = scene.objects();
    let tris = |id: u32| objects[id as usize].triangles as u64;
    let cluster = pvs.camera_cluster(camera.eye);
    let pvs_keeps = |id: u32| cluster.is_none_or(|c| pvs.object_visible_from(id, c));
    let mut f = PvsFrame {
        pvs_camera_cluster: cluster,
        ..PvsFrame::default()
    };
    if let Some(frustum) = Frustum::from_view_proj(&camera.view_proj()) {
        for (id, o) in objects.iter().enumerate() {
            if frustum.test_aabb(&o.aabb) != Containment::Outside {
                f.pvs_triangles_frustum += o.triangles as u64;
                if pvs_keeps(id as u32) {
                    f.pvs_triangles_pvs += o.triangles as u64;
                }
            }
        }
    }
    for &id in visible {
        f.pvs_triangles_hom += tris(id);
        if pvs_keeps(id) {
            f.pvs_triangles_pvs_hom += tris(id);
        }
    }
    for &id in oracle_visible {
        f.pvs_triangles_oracle += tris(id);
        if !pvs_keeps(id) {
            f.pvs_violations.push(id);
        }
    }
    f.pvs_violations.sort_unstable();
    f
}

/// The yardstick for a walked frame record (needs the oracle: without it the
/// oracle count is 0 and no violation can be found).
pub fn pvs_for_record(pvs: &impl ClusterPvs, scene: &Scene, camera: &Camera, record: &FrameRecord) -> PvsFrame {
    let oracle: &[u32] = record.oracle.as_ref().map_or(&[], |o| &o.oracle_visible);
    pvs_frame(pvs, scene, camera, &record.visible_clusters, oracle)
}

/// The yardstick over a walk.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct PvsSummary {
    /// Frames measured.
    pub pvs_frames: usize,
    /// Frames whose eye lies in no cluster (the PVS kept everything there).
    pub pvs_frames_in_solid: usize,
    /// Oracle-visible objects hidden by the PVS, summed over frames (must be 0).
    pub pvs_violations: u64,
    /// Median triangles per frame: frustum alone.
    pub pvs_median_triangles_frustum: f64,
    /// Median triangles per frame: PVS alone (within the frustum).
    pub pvs_median_triangles_pvs: f64,
    /// Median triangles per frame: HOM alone.
    pub pvs_median_triangles_hom: f64,
    /// Median triangles per frame: PVS then HOM.
    pub pvs_median_triangles_pvs_hom: f64,
    /// Median triangles per frame: the oracle's visible set.
    pub pvs_median_triangles_oracle: f64,
    /// Triangles over all frames: frustum, PVS, HOM, PVS then HOM, oracle.
    pub pvs_total_triangles: [u64; 5],
}

/// Medians and totals of a walk's [`PvsFrame`]s.
pub fn summarize_pvs(frames: &[PvsFrame]) -> PvsSummary {
    let counts = |f: &PvsFrame| {
        [
            f.pvs_triangles_frustum,
            f.pvs_triangles_pvs,
            f.pvs_triangles_hom,
            f.pvs_triangles_pvs_hom,
            f.pvs_triangles_oracle,
        ]
    };
    let med = |k: usize| median(frames.iter().map(|f| counts(f)[k] as f64));
    let mut total = [0u64; 5];
    for f in frames {
        for (t, c) in total.iter_mut().zip(counts(f)) {
            *t += c;
        }
    }
    PvsSummary {
        pvs_frames: frames.len(),
        pvs_frames_in_solid: frames.iter().filter(|f| f.pvs_camera_cluster.is_none()).count(),
        pvs_violations: frames.iter().map(|f| f.pvs_violations.len() as u64).sum(),
        pvs_median_triangles_frustum: med(0),
        pvs_median_triangles_pvs: med(1),
        pvs_median_triangles_hom: med(2),
        pvs_median_triangles_pvs_hom: med(3),
        pvs_median_triangles_oracle: med(4),
        pvs_total_triangles: total,
    }
}

impl PvsSummary {
    /// A small table: per approach, median triangles per frame and the share of
    /// the frustum's triangles it draws over the walk.
    pub fn table(&self) -> String {
        let mut s = format!(
            "PVS yardstick: {} frames ({} with the eye in solid space), {} oracle-visible objects outside the PVS\n",
            self.pvs_frames, self.pvs_frames_in_solid, self.pvs_violations
        );
        s += &format!("{:<14} {:>14} {:>12}\n", "approach", "median tris", "% of frustum");
        let names = ["frustum", "PVS", "HOM", "PVS then HOM", "oracle"];
        let medians = [
            self.pvs_median_triangles_frustum,
            self.pvs_median_triangles_pvs,
            self.pvs_median_triangles_hom,
            self.pvs_median_triangles_pvs_hom,
            self.pvs_median_triangles_oracle,
        ];
        let frustum = self.pvs_total_triangles[0].max(1) as f64;
        for ((name, m), t) in names.iter().zip(medians).zip(self.pvs_total_triangles) {
            s += &format!("{name:<14} {m:>14.0} {:>12.1}\n", 100.0 * t as f64 / frustum);
        }
        s
    }
}

/// A frame line with the yardstick's fields added.
#[derive(Serialize)]
pub struct FrameWithPvs<'a> {
    /// The walk's frame record, fields unchanged.
    #[serde(flatten)]
    pub record: &'a FrameRecord,
    /// The yardstick's `pvs_` fields.
    #[serde(flatten)]
    pub pvs: &'a PvsFrame,
}

/// The summary line with the yardstick's fields added.
#[derive(Serialize)]
pub struct SummaryWithPvs<'a> {
    /// The walk's summary, fields unchanged.
    #[serde(flatten)]
    pub summary: &'a Summary,
    /// The yardstick's `pvs_` fields.
    #[serde(flatten)]
    pub pvs: &'a PvsSummary,
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Mat4;
    use hom::scene::{Mesh, SceneBuilder};

    /// Two rooms of a hand-made map: x < 0 is cluster 0, x ≥ 0 cluster 1; the
    /// PVS marks 1 visible from 0 but not 0 from 1 (asymmetric, to tell them apart).
    struct TwoRooms {
        object_cluster: Vec<i32>,
    }

    impl ClusterPvs for TwoRooms {
        fn camera_cluster(&self, eye: Vec3) -> Option<i32> {
            if eye.y > 10.0 {
                None
            } else {
                Some(if eye.x < 0.0 { 0 } else { 1 })
            }
        }
        fn object_visible_from(&self, id: u32, from: i32) -> bool {
            let to = self.object_cluster[id as usize];
            from == to || (from == 0 && to == 1)
        }
    }

    fn quad_mesh(triangles: usize) -> Mesh {
        let mut p = Vec::new();
        let mut t = Vec::new();
        for k in 0..triangles {
            let z = k as f32 * 0.01;
            let b = p.len() as u32;
            p.extend([Vec3::new(0.0, 0.0, z), Vec3::new(1.0, 0.0, z), Vec3::new(0.0, 1.0, z)]);
            t.push([b, b + 1, b + 2]);
        }
        Mesh::new("m", p, t).unwrap()
    }

    /// Objects along −Z from the origin: 0 (1 tri, cluster 0), 1 (10 tris,
    /// cluster 1), 2 (100 tris, cluster 0), and 3 (1000 tris, cluster 1) behind the camera.
    fn scene() -> (Scene, TwoRooms) {
        let mut b = SceneBuilder::new("two rooms");
        for (k, (tris, z)) in [(1, -5.0), (10, -10.0), (100, -15.0), (1000, 20.0)]
            .into_iter()
            .enumerate()
        {
            let m = b.add_mesh(quad_mesh(tris));
            b.add_object(format!("o{k}"), m, Mat4::from_translation(Vec3::new(0.0, 0.0, z)))
                .unwrap();
        }
        let pvs = TwoRooms {
            object_cluster: vec![0, 1, 0, 1],
        };
        (b.build().unwrap(), pvs)
    }

    fn camera(eye: Vec3) -> Camera {
        Camera::new(eye, eye - Vec3::Z, Vec3::Y, 1.0, 0.1, 100.0, 64, 64)
    }

    #[test]
    fn counts_each_approach_and_finds_violations() {
        let (scene, pvs) = scene();
        // From cluster 1 (x ≥ 0) the PVS hides objects 0 and 2 (cluster 0).
        let cam = camera(Vec3::new(0.5, 0.5, 0.0));
        let f = pvs_frame(&pvs, &scene, &cam, &[1, 2], &[1, 2]);
        assert_eq!(f.pvs_camera_cluster, Some(1));
        assert_eq!(f.pvs_triangles_frustum, 111, "object 3 is behind the camera");
        assert_eq!(f.pvs_triangles_pvs, 10);
        assert_eq!(f.pvs_triangles_hom, 110);
        assert_eq!(f.pvs_triangles_pvs_hom, 10);
        assert_eq!(f.pvs_triangles_oracle, 110);
        assert_eq!(f.pvs_violations, vec![2], "the oracle sees 2, the PVS hides it");

        // From cluster 0 everything is potentially visible: no violation.
        let cam = camera(Vec3::new(-0.5, 0.5, 0.0));
        let g = pvs_frame(&pvs, &scene, &cam, &[0, 1, 2], &[0, 1]);
        assert_eq!(g.pvs_camera_cluster, Some(0));
        assert_eq!(g.pvs_triangles_pvs, g.pvs_triangles_frustum);
        assert_eq!(g.pvs_triangles_pvs_hom, 111);
        assert_eq!(g.pvs_triangles_oracle, 11);
        assert!(g.pvs_violations.is_empty());

        // In solid space the PVS keeps everything and proves nothing.
        let cam = camera(Vec3::new(0.5, 20.0, 0.0));
        let h = pvs_frame(&pvs, &scene, &cam, &[2], &[2]);
        assert_eq!(h.pvs_camera_cluster, None);
        assert_eq!(h.pvs_triangles_pvs, h.pvs_triangles_frustum);
        assert_eq!(h.pvs_triangles_pvs_hom, 100);
        assert!(h.pvs_violations.is_empty());

        let s = summarize_pvs(&[f, g, h]);
        assert_eq!(s.pvs_frames, 3);
        assert_eq!(s.pvs_frames_in_solid, 1);
        assert_eq!(s.pvs_violations, 1);
        assert_eq!(s.pvs_median_triangles_hom, 110.0);
        assert_eq!(s.pvs_total_triangles[3], 10 + 111 + 100);
        let table = s.table();
        assert!(table.contains("PVS then HOM"), "{table}");
        assert!(table.contains("1 oracle-visible objects outside the PVS"), "{table}");
    }
}
