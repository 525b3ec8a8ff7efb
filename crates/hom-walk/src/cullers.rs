//! The cullers `hom walk --culler NAME` can run, by name.

use hom::cull::{Culler, FrustumCuller, HomConfig, HomCuller, HvConfig, HvCuller, HzbConfig, HzbCuller, NoCuller};
use hom::scene::Scene;

/// Names and one-line descriptions of the available cullers.
pub const CULLERS: &[(&str, &str)] = &[
    ("none", "draw every object"),
    ("frustum", "view-frustum culling over the BVH (the baseline)"),
    ("hom", "hierarchical occlusion maps (Zhang et al. 1997), conservative"),
    (
        "hzb",
        "hierarchical Z-buffer (Greene et al. 1993) with HOM's occluder selection, conservative",
    ),
    (
        "hv",
        "hierarchical visibility (Greene et al. 1993): octree front to back against a live Z-pyramid, exact",
    ),
];

/// The best culler hom has; `hom demo` uses it.
pub const BEST: &str = "hom";

/// Builds the culler called `name` for `scene` with default settings; `None` for an unknown name.
pub fn make(name: &str, scene: &Scene) -> Option<Box<dyn Culler>> {
    make_with(name, scene, &HomConfig::for_scene(scene))
}

/// Like [`make`], with the HOM culler's settings given (the HZB culler takes
/// their occluder selection and database settings).
pub fn make_with(name: &str, scene: &Scene, hom: &HomConfig) -> Option<Box<dyn Culler>> {
    match name {
        "none" => Some(Box::new(NoCuller)),
        "frustum" => Some(Box::new(FrustumCuller::new(scene))),
        "hom" => Some(Box::new(HomCuller::new(scene, hom.clone()))),
        "hzb" => Some(Box::new(HzbCuller::new(scene, HzbConfig::from_hom(hom)))),
        "hv" => Some(Box::new(HvCuller::new(scene, HvConfig::default()))),
        _ => None,
    }
}

/// Comma-separated culler names, for error messages.
pub fn names() -> String {
    CULLERS.iter().map(|c| c.0).collect::<Vec<_>>().join(", ")
}
