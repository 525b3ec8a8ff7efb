//! The cullers `hom walk --culler NAME` can run, by name.

use hom::cull::{Culler, FrustumCuller, NoCuller};
use hom::scene::Scene;

/// Names and one-line descriptions of the available cullers.
pub const CULLERS: &[(&str, &str)] = &[
    ("none", "draw every object"),
    ("frustum", "view-frustum culling over the BVH (the baseline)"),
];

/// The best culler hom has; `hom demo` uses it.
pub const BEST: &str = "frustum";

/// Builds the culler called `name` for `scene`; `None` for an unknown name.
pub fn make(name: &str, scene: &Scene) -> Option<Box<dyn Culler>> {
    match name {
        "none" => Some(Box::new(NoCuller)),
        "frustum" => Some(Box::new(FrustumCuller::new(scene))),
        _ => None,
    }
}

/// Comma-separated culler names, for error messages.
pub fn names() -> String {
    CULLERS.iter().map(|c| c.0).collect::<Vec<_>>().join(", ")
}
