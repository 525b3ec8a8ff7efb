//! `hom occluders info` and `hom occluders export`: the virtual occluders of
//! a scene, counted, checked and written out.

use anyhow::{bail, Context, Result};
use hom_walk::virtual_occluders::{virtual_db, virtual_rows, virtual_scene, walk_comparison, write_pictures};
use std::path::Path;
use std::time::Instant;

/// `hom occluders info`: a line per kept occluder, then the totals; with
/// `walk_frames`, the comparison over that many frames of the camera path.
pub fn info(spec: &str, side: u32, summary_only: bool, pictures: Option<&Path>, walk_frames: usize) -> Result<()> {
    if !(8..=1024).contains(&side) {
        bail!("--side must be 8..=1024 samples, got {side}");
    }
    let (mut scene, path, animation) = hom_walk::open_scene(spec)?;
    let start = Instant::now();
    let db = virtual_db(&scene);
    let bake_s = start.elapsed().as_secs_f64();
    let rows = virtual_rows(&scene, &db, side);
    if !summary_only {
        println!(
            "{:>6}  {:<32} {:>9} {:>8} {:>7} {:>10}  note",
            "object", "name", "original", "virtual", "kept", "violations"
        );
        for r in &rows {
            let name: String = r.name.chars().take(32).collect();
            match &r.outcome {
                Ok(t) => println!(
                    "{:>6}  {:<32} {:>9} {:>8} {:>6.1}% {:>10}",
                    r.object,
                    name,
                    r.original_triangles,
                    t,
                    100.0 * r.views.kept(),
                    r.views.violations
                ),
                Err(why) => println!(
                    "{:>6}  {:<32} {:>9} {:>8} {:>7} {:>10}  {why}",
                    r.object, name, r.original_triangles, "-", "-", "-"
                ),
            }
        }
    }
    let with: Vec<_> = rows.iter().filter(|r| r.outcome.is_ok()).collect();
    let mut sizes: Vec<u32> = with.iter().filter_map(|r| r.outcome.clone().ok()).collect();
    sizes.sort_unstable();
    let original: u64 = with.iter().map(|r| u64::from(r.original_triangles)).sum();
    let virtual_tris: u64 = sizes.iter().map(|&t| u64::from(t)).sum();
    let (mut kept, mut violations) = (0.0, 0);
    for r in &with {
        kept += r.views.kept();
        violations += r.views.violations;
    }
    let baked_tris: u64 = scene.meshes().iter().map(|m| m.triangle_count() as u64).sum();
    println!("scene:          {}", scene.name());
    println!("occluders:      {}", db.report());
    println!(
        "with virtual:   {} of {} occluders; {} -> {} triangles ({:.1} %); median {} triangles",
        with.len(),
        rows.len(),
        original,
        virtual_tris,
        100.0 * virtual_tris as f64 / original.max(1) as f64,
        sizes.get(sizes.len() / 2).copied().unwrap_or(0)
    );
    println!(
        "coverage kept:  {:.1} % on average over six axis views at {side}x{side} (virtual / original samples)",
        100.0 * kept / with.len().max(1) as f64
    );
    println!("violations:     {violations} samples (0 is the guarantee)");
    println!(
        "bake:           {:.2} s for {} meshes, {} triangles, on {} threads",
        bake_s,
        scene.meshes().len(),
        baked_tris,
        rayon::current_num_threads()
    );
    if walk_frames > 0 {
        let bar = crate::setup::progress(walk_frames.min(path.frames.len()), "comparing");
        let w = walk_comparison(&mut scene, &animation, &path, &db, walk_frames, |_| bar.inc(1));
        bar.finish_and_clear();
        println!(
            "walk:           {} of {} frames at {}x{}: {} stand-ins in view compared; coverage kept {:.1} % \
             (mean over frames), {:.1} % of all samples; violations {} samples (0 is the guarantee)",
            w.frames,
            path.frames.len(),
            path.width,
            path.height,
            w.compared,
            100.0 * w.mean_kept,
            100.0 * w.total.kept(),
            w.total.violations
        );
    }
    if let Some(dir) = pictures {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let files = write_pictures(&scene, &db, dir, 4, 256)?;
        println!(
            "pictures:       {} in {} (grey: original, blue: covered by its stand-in too, red: a violation)",
            files.len(),
            dir.display()
        );
    }
    Ok(())
}

/// `hom occluders export`: the virtual occluders in world space as OBJ.
pub fn export(spec: &str, out: &Path) -> Result<()> {
    let (scene, _, _) = hom_walk::open_scene(spec)?;
    let db = virtual_db(&scene);
    let virtual_occluders = match virtual_scene(&scene, &db) {
        Ok(s) => s,
        Err(hom::scene::SceneError::EmptyScene { .. }) => {
            bail!("scene '{}' has no virtual occluders: {}", scene.name(), db.report())
        }
        Err(e) => return Err(e.into()),
    };
    hom_scene::export::write_obj(&virtual_occluders, out)?;
    println!(
        "wrote {} ({} virtual occluders, {} triangles)",
        out.display(),
        virtual_occluders.objects().len(),
        virtual_occluders.triangle_count()
    );
    Ok(())
}
