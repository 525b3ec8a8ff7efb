//! # hom-walk — the walkthrough harness
//!
//! Runs a [`hom::cull::Culler`] along a camera path through a scene: per frame
//! it culls, renders what the culler keeps with the reference renderer, times
//! every stage, optionally runs the oracle (the item buffer of a full render),
//! and computes the metrics every result in hom is measured with:
//!
//! - **false cull**: an object culled as occluded that owns at least one pixel.
//! - **culling efficiency**: triangles culled as occluded ÷ triangles in the
//!   frustum that the oracle finds invisible.
//! - **speedup**: frame time with frustum culling only ÷ frame time with the
//!   culler (culling included), same renderer, same path, same run.
//! - **oracle speedup**: frame time with frustum culling only ÷ time to render
//!   just the oracle's visible set.
//!
//! Results are [`report`] records, written as JSON lines; [`pictures`] draws
//! false-colour frames and plots; [`pvs`] measures a walk through a Quake 3 map
//! against the map's own potentially visible sets.

#![forbid(unsafe_code)]

pub mod bench;
pub mod cullers;
pub mod lod;
pub mod pictures;
pub mod pvs;
pub mod raster_bench;
pub mod report;
mod stats;
pub mod virtual_occluders;
mod walk;
pub use walk::summarize;

pub use walk::{walk, WalkError, WalkOptions, WalkResult};

use hom::scene::Scene;
use hom_scene::{Animation, CameraPath, LoadError};
use std::path::Path;

/// A scene, the camera path to walk it and how its objects move: a built-in
/// scene name or a file (files do not move).
///
/// Files get their own walkthrough where they have one (a Quake 3 map: spawn to
/// spawn, see [`hom_scene::load_with_path`]; `FILE.pk3:MAP` names a map in a pk3),
/// else [`CameraPath::orbit`] around their bounds.
pub fn open_scene(spec: &str) -> Result<(Scene, CameraPath, Animation), LoadError> {
    let builtins = || hom_scene::BUILTIN_SCENES.iter().chain(hom_scene::SCALE_SCENES);
    if builtins().any(|(n, _)| *n == spec) {
        let b = hom_scene::builtin(spec)?;
        return Ok((b.scene, b.path, b.animation));
    }
    let path = Path::new(spec);
    if !hom_scene::split_map_spec(path).0.exists() {
        let known: Vec<&str> = builtins().map(|(n, _)| *n).collect();
        return Err(LoadError::UnknownBuiltin {
            name: spec.to_string(),
            known: known.join(", "),
        });
    }
    let loaded = hom_scene::load_with_path(path)?;
    let walk = match loaded.path {
        Some(p) => p,
        None => CameraPath::orbit(&loaded.scene.bounds(), 120),
    };
    Ok((loaded.scene, walk, Animation::none()))
}

/// The README's Rust examples, compiled as doc tests.
#[doc = include_str!("../../../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;
