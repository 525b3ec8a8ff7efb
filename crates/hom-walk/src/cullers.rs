//! The cullers `hom walk --culler NAME` can run, by name: the one factory
//! every caller builds cullers with.

use hom::cull::{
    Culler, FrustumCuller, HomConfig, HomCuller, HvConfig, HvCuller, HzbCuller, MaskedCuller, NoCuller, OtreeCuller,
    TreeOptions,
};
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
        "masked",
        "masked occlusion culling (Hasselgren et al. 2016): HOM's occluders as coverage masks and two depth layers per tile, conservative",
    ),
    (
        "otree",
        "occlusion trees (Bittner et al. 1998): HOM's occluders' shadow frusta merged into a BSP tree, conservative",
    ),
    (
        "hv",
        "hierarchical visibility (Greene et al. 1993): octree front to back against a live Z-pyramid, exact",
    ),
];

/// The best culler hom has, the default `--culler`; `hom demo` uses it.
/// Masked with the per-sample depth check: on the Quake 3 maps 1.09–1.48×
/// frustum-only where HOM gives 1.05–1.30 (two runs, 7 of 8 rows ahead), a
/// tie on the built-in scenes (geometric mean 1.37 against HOM's 1.35) and
/// the outdoor levels (`docs/decisions/occluders.md`).
pub const BEST: &str = "masked";

/// Settings of every culler [`make`] can build; each culler reads its own.
#[derive(Clone, Debug, PartialEq)]
pub struct CullerSettings {
    /// The HOM culler's; the HZB, masked and occlusion-tree cullers take
    /// its shared settings (occluders, coherence, cost model, hierarchy)
    /// over their own buffers.
    pub hom: HomConfig,
    /// The HV culler's.
    pub hv: HvConfig,
}

impl CullerSettings {
    /// The defaults for `scene` (HOM's budget depends on its triangle count).
    pub fn for_scene(scene: &Scene) -> CullerSettings {
        CullerSettings {
            hom: HomConfig::for_scene(scene),
            hv: HvConfig::default(),
        }
    }
}

/// A culler name that is not in [`CULLERS`]; the message lists the known ones.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown culler '{name}'; available: {}", names())]
pub struct UnknownCuller {
    /// The name asked for.
    pub name: String,
}

/// Builds the culler called `name` (one of [`CULLERS`]) for `scene` with `settings`.
pub fn make(name: &str, scene: &Scene, settings: &CullerSettings) -> Result<Box<dyn Culler>, UnknownCuller> {
    Ok(match name {
        "none" => Box::new(NoCuller),
        "frustum" => Box::new(FrustumCuller::new(scene)),
        "hom" => Box::new(HomCuller::new(scene, settings.hom.clone())),
        "hzb" => Box::new(HzbCuller::new(scene, settings.hom.with_buffer(()))),
        "masked" => Box::new(MaskedCuller::new(scene, settings.hom.with_buffer(()))),
        "otree" => Box::new(OtreeCuller::new(
            scene,
            settings.hom.with_buffer(TreeOptions::default()),
        )),
        "hv" => Box::new(HvCuller::new(scene, settings.hv.clone())),
        _ => return Err(UnknownCuller { name: name.to_string() }),
    })
}

/// Comma-separated culler names, for error messages.
pub fn names() -> String {
    CULLERS.iter().map(|c| c.0).collect::<Vec<_>>().join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn make_builds_every_listed_culler_and_names_the_choices_otherwise() {
        let scene = hom_scene::builtin("spheres").unwrap().scene;
        let settings = CullerSettings::for_scene(&scene);
        for (name, _) in CULLERS {
            assert!(make(name, &scene, &settings).is_ok(), "{name}");
        }
        let err = make("magic", &scene, &settings).err().expect("unknown name");
        assert_eq!(err.name, "magic");
        assert_eq!(
            err.to_string(),
            "unknown culler 'magic'; available: none, frustum, hom, hzb, masked, otree, hv"
        );
    }
}
