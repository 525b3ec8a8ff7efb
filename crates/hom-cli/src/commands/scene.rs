//! `hom scenes`, `hom scene info` and `hom scene export`.

use crate::args::Clusters;
use anyhow::Result;
use std::path::Path;

/// `hom scenes`: the built-in scenes with their counts.
pub fn list() -> Result<()> {
    println!(
        "{:<14} {:>8} {:>10} {:>8}  description",
        "name", "objects", "triangles", "frames"
    );
    for (name, description) in hom_scene::BUILTIN_SCENES.iter().chain(hom_scene::SCALE_SCENES) {
        let b = hom_scene::builtin(name)?;
        println!(
            "{:<14} {:>8} {:>10} {:>8}  {}",
            name,
            b.scene.objects().len(),
            b.scene.triangle_count(),
            b.path.frames.len(),
            description
        );
    }
    Ok(())
}

/// `hom scene info`: counts, bounds and the walk of the scene `spec`, cut
/// into cluster-sized objects or not (`--clusters`).
pub fn info(spec: &str, clusters: Clusters) -> Result<()> {
    let opened = hom_walk::open_walk_with(spec, &clusters.load_options())?;
    let (scene, path) = (opened.scene, opened.path);
    let b = scene.bounds();
    let dynamic = scene.dynamic_count();
    let max_tris = scene.objects().iter().map(|o| o.triangles).max().unwrap_or(0);
    println!("scene:      {}", scene.name());
    println!(
        "objects:    {} in {} clusters ({dynamic} dynamic)",
        scene.parent_count(),
        scene.objects().len()
    );
    let vertices: usize = scene.meshes().iter().map(|m| m.positions().len()).sum();
    println!("meshes:     {} ({vertices} vertices)", scene.meshes().len());
    println!("triangles:  {}", scene.triangle_count());
    println!(
        "per cluster: {:.0} triangles on average, {max_tris} at most",
        scene.triangle_count() as f64 / scene.objects().len() as f64
    );
    println!("bounds:     {:?} .. {:?}", b.min.to_array(), b.max.to_array());
    println!(
        "path:       {} frames at {}x{}",
        path.frames.len(),
        path.width,
        path.height
    );
    Ok(())
}

/// `hom scene export`: the scene `spec` as OBJ in `out`, one `o` per
/// cluster in cluster-id order (`--clusters`, the default: the ids of a
/// report's `visible_clusters`), or per whole object (`--clusters off`: the
/// ids of its `visible`).
pub fn export(spec: &str, out: &Path, clusters: Clusters) -> Result<()> {
    let scene = hom_walk::open_walk_with(spec, &clusters.load_options())?.scene;
    hom_scene::export::write_obj(&scene, out)?;
    println!(
        "wrote {} ({} {}, {} triangles)",
        out.display(),
        scene.objects().len(),
        if clusters.switch == crate::args::OnOff::On {
            "clusters"
        } else {
            "objects"
        },
        scene.triangle_count()
    );
    Ok(())
}
