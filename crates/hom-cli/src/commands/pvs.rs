//! `hom pvs`: bake, merge, info and check precomputed visibility (Law & Tan
//! 1999, section 5).

use crate::args::{OnOff, PvsBakeArgs, PvsCheckArgs, ShardArg};
use crate::setup::progress_of;
use anyhow::{bail, Context, Result};
use hom::geom::{Aabb, Camera};
use hom::glam::Vec3;
use hom::pvs::{Pvs, PvsConfig, Shard};
use hom_render::{Framebuffer, Renderer};
use hom_scene::CameraPath;
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

/// Reads a `.pvs` file.
pub fn read(path: &Path) -> Result<Pvs> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    Pvs::from_bytes(&bytes).with_context(|| format!("reading {}", path.display()))
}

/// Reads a `.pvs` file for `scene`: an error when it was baked for another.
pub fn read_for(path: &Path, scene: &hom::scene::Scene) -> Result<Arc<Pvs>> {
    let pvs = read(path)?;
    pvs.check_scene(scene)
        .with_context(|| format!("using {}", path.display()))?;
    Ok(Arc::new(pvs))
}

/// Writes `pvs` to `path` through a temporary file, so a failed write never
/// leaves a half file where a good one was.
fn write(path: &Path, pvs: &Pvs) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let tmp = path.with_extension("pvs.tmp");
    std::fs::write(&tmp, pvs.to_bytes()).with_context(|| format!("writing {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("writing {}", path.display()))
}

/// The settings a bake uses for a path: its near plane, and a clearance
/// that covers its near rectangle at any aspect up to 2.4 (21:9), or a
/// 90° square view (what `hom pvs check` renders).
pub fn config_for(path: &CameraPath, cell_size: f32, min_polygon_area: f32, pad: f32) -> PvsConfig {
    let t = (path.fov_y_deg.to_radians() * 0.5).tan();
    let aspect = (path.width as f32 / path.height as f32).max(2.4);
    let corner = (1.0 + t * t * (1.0 + aspect * aspect)).sqrt();
    PvsConfig {
        cell_size,
        pad,
        min_polygon_area,
        near: path.near,
        near_clearance: path.near * corner.max(1.8) * 1.01,
        ..PvsConfig::default()
    }
}

/// `hom pvs bake`.
pub fn bake(a: PvsBakeArgs) -> Result<()> {
    let (scene, mut path, animation) = hom_walk::open_scene(&a.scene)?;
    if let Some(file) = &a.camera_path {
        path = CameraPath::load(file)?;
    }
    path.validate(&a.scene)?;
    let eyes: Vec<Vec3> = path.frames.iter().map(|f| Vec3::from_array(f.eye)).collect();
    let moving: Vec<u32> = animation.tracks().iter().map(|t| t.object).collect();
    let config = PvsConfig {
        fusion_spacing: a.fusion_spacing,
        ..config_for(&path, a.cell_size, a.min_polygon_area, a.pad)
    };
    let (shard, from) = match a.shard {
        None => (Shard::WHOLE, None),
        Some(ShardArg::Fixed(s)) => (s, None),
        Some(ShardArg::Auto { count }) => {
            let (s, from) = shard_from_env(count, |name| std::env::var(name).ok())?;
            (s, Some(from))
        }
    };
    let start = Instant::now();
    let bar = progress_of(0, "pvs bake", "blocks");
    let pvs = Pvs::bake(&scene, &eyes, &moving, &config, shard, &|done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    })
    .with_context(|| format!("baking the PVS of {}", a.scene))?;
    bar.finish_and_clear();
    let view_seconds = start.elapsed().as_secs_f64();
    let (pvs, portal_note) = match (a.portals, hom_walk::pvs::is_map_spec(&a.scene)) {
        (OnOff::On, true) => {
            let start = Instant::now();
            let map = hom_walk::pvs::open_map(&a.scene)?;
            let portals = crate::setup::follow_portals(&map, &path)?;
            let cells = portals.cells(&map).context("the map's portal cells")?;
            let n = cells.cell_count();
            let pvs = pvs.with_portal_cells(cells).context("adding the portal cells")?;
            let note = format!(
                "; {} portal cells ({} portals between {} leaves the path reaches; {} cells it does not, hiding nothing) in {:.1} s",
                n,
                portals.portal_count(),
                portals.leaf_count(),
                portals.unreached_clusters(),
                start.elapsed().as_secs_f64()
            );
            (pvs, note)
        }
        _ => (pvs, String::new()),
    };
    let seconds = start.elapsed().as_secs_f64();
    write(&a.out, &pvs)?;
    println!(
        "{}: {} cells of {} m, {} occluder objects, shard {}/{}{}, baked in {:.1} s (view cells {:.1} s{}), {} bytes",
        a.out.display(),
        pvs.cells().cell_count(),
        config.cell_size,
        pvs.occluder_objects().len(),
        shard.index,
        shard.count,
        from.map_or(String::new(), |f| format!(" (from {f})")),
        seconds,
        view_seconds,
        portal_note,
        std::fs::metadata(&a.out).map(|m| m.len()).unwrap_or(0)
    );
    if shard == Shard::WHOLE {
        print_sizes(&pvs, scene.objects().len());
    }
    Ok(())
}

/// The shard of `--shard auto/N` (`count` = N) and where its index came
/// from, reading the environment through `var`: `JOB_COMPLETION_INDEX`
/// (Kubernetes Indexed Jobs, from 0), else `SLURM_ARRAY_TASK_ID` −
/// `SLURM_ARRAY_TASK_MIN` (Slurm job arrays, whatever their first index).
/// An error names the variable when neither is set, one is not a number, or
/// the index is not below N.
pub fn shard_from_env(count: u32, var: impl Fn(&str) -> Option<String>) -> Result<(Shard, String)> {
    let number = |name: &str| -> Result<Option<u32>> {
        match var(name) {
            None => Ok(None),
            Some(v) => v
                .trim()
                .parse()
                .map(Some)
                .map_err(|_| anyhow::anyhow!("--shard auto/{count}: {name}='{v}' is not a whole number")),
        }
    };
    let (index, from) = if let Some(k) = number("JOB_COMPLETION_INDEX")? {
        (k, "JOB_COMPLETION_INDEX".to_string())
    } else if let Some(id) = number("SLURM_ARRAY_TASK_ID")? {
        let Some(min) = number("SLURM_ARRAY_TASK_MIN")? else {
            bail!("--shard auto/{count}: SLURM_ARRAY_TASK_ID is set but SLURM_ARRAY_TASK_MIN is not");
        };
        let Some(k) = id.checked_sub(min) else {
            bail!("--shard auto/{count}: SLURM_ARRAY_TASK_ID={id} is below SLURM_ARRAY_TASK_MIN={min}");
        };
        (k, format!("SLURM_ARRAY_TASK_ID={id} - SLURM_ARRAY_TASK_MIN={min}"))
    } else {
        bail!(
            "--shard auto/{count} takes the shard index from JOB_COMPLETION_INDEX (Kubernetes Indexed Jobs) \
             or SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN (Slurm job arrays), and neither is set"
        );
    };
    if index >= count {
        bail!(
            "--shard auto/{count}: {from} gives shard {index}, not below {count} \
             (run {count} completions, or an array of {count} tasks)"
        );
    }
    Ok((Shard { index, count }, from))
}

/// `hom pvs merge`.
pub fn merge(out: &Path, shards: &[std::path::PathBuf]) -> Result<()> {
    let parts = shards.iter().map(|p| read(p)).collect::<Result<Vec<_>>>()?;
    let whole = Pvs::merge(parts)?;
    write(out, &whole)?;
    println!(
        "{}: {} shards merged, {} cells",
        out.display(),
        shards.len(),
        whole.cells().cell_count()
    );
    Ok(())
}

fn print_sizes(pvs: &Pvs, objects: usize) {
    let mut sizes: Vec<usize> = pvs.cell_set_sizes().into_iter().map(|(_, n)| n).collect();
    sizes.sort_unstable();
    if sizes.is_empty() {
        return;
    }
    let at = |q: f64| sizes[((sizes.len() - 1) as f64 * q).round() as usize];
    println!(
        "objects hidden per cell (of {objects}): min {}, median {}, 95th percentile {}, max {}",
        at(0.0),
        at(0.5),
        at(0.95),
        at(1.0)
    );
}

/// `hom pvs info`.
pub fn info(file: &Path, picture: Option<&Path>, scene: Option<&str>) -> Result<()> {
    let pvs = read(file)?;
    let scene = match scene {
        Some(s) => {
            let (scene, _, _) = hom_walk::open_scene(s)?;
            pvs.check_scene(&scene)?;
            Some(scene)
        }
        None => None,
    };
    let c = pvs.config();
    let bytes = std::fs::metadata(file).map(|m| m.len()).unwrap_or(0);
    println!("{}: {} bytes", file.display(), bytes);
    println!(
        "scene fingerprint {:016x}, shard {}/{}",
        pvs.scene_fingerprint(),
        pvs.shard().index,
        pvs.shard().count
    );
    println!(
        "settings: cell size {} m, {} quadtree levels, pad {} m, margin {} m, near {} m, near clearance {} m, planar occluders from {} m², solids {}",
        c.cell_size, c.levels, c.pad, c.margin, c.near, c.near_clearance, c.min_polygon_area, c.solids
    );
    println!(
        "{} cells, {} occluder objects, {} moving objects left out",
        pvs.cells().cell_count(),
        pvs.occluder_objects().len(),
        pvs.moving().len()
    );
    let stored: usize = pvs.node_sets().map(|(_, s)| s.len()).sum();
    println!("{stored} ids stored over the hierarchy's nodes");
    if let Some(p) = pvs.portal_cells() {
        let ids: usize = (0..p.cell_count() as u32).map(|c| p.hidden(c).len()).sum();
        println!(
            "{} portal cells, hiding {:.0} objects each on average",
            p.cell_count(),
            ids as f64 / p.cell_count().max(1) as f64
        );
    }
    if pvs.shard() == Shard::WHOLE {
        print_sizes(&pvs, pvs.object_count());
        if let Some(p) = picture {
            write_map(&pvs, scene.as_ref(), p)?;
            println!("picture: {}", p.display());
        }
    } else if picture.is_some() {
        bail!("a shard has no cells to draw: merge the shards first");
    }
    Ok(())
}

/// A top-down map of the cells, each coloured by its set size (blue: the
/// fewest hidden, to yellow: the most), 6 pixels a cell, over the scene's
/// object footprints in grey when the scene is given.
fn write_map(pvs: &Pvs, scene: Option<&hom::scene::Scene>, path: &Path) -> Result<()> {
    let cells = pvs.cell_set_sizes();
    let mut bounds = cells.iter().fold(Aabb::EMPTY, |b, (c, _)| b.union(*c));
    if let Some(s) = scene {
        bounds = bounds.union(s.bounds());
    }
    let size = pvs.config().cell_size;
    const PX: u32 = 6;
    let w = (((bounds.max.x - bounds.min.x) / size).round() as u32).max(1) * PX;
    let h = (((bounds.max.z - bounds.min.z) / size).round() as u32).max(1) * PX;
    if w > 8192 || h > 8192 {
        bail!("the map would be {w}x{h} pixels: too many cells to draw");
    }
    let most = cells.iter().map(|c| c.1).max().unwrap_or(0);
    let least = cells.iter().map(|c| c.1).min().unwrap_or(0);
    let mut rgba = vec![[24u8, 24, 24, 255]; (w * h) as usize];
    let to_px = |x: f32, z: f32| {
        (
            ((x - bounds.min.x) / size * PX as f32).clamp(0.0, (w - 1) as f32) as u32,
            ((z - bounds.min.z) / size * PX as f32).clamp(0.0, (h - 1) as f32) as u32,
        )
    };
    // Footprints of objects standing up (not the ground or roads), grey.
    let standing = |o: &&hom::scene::Object| !o.is_removed() && o.aabb.extent().y > 0.5;
    for o in scene.iter().flat_map(|s| s.objects()).filter(standing) {
        let (x0, z0) = to_px(o.aabb.min.x, o.aabb.min.z);
        let (x1, z1) = to_px(o.aabb.max.x, o.aabb.max.z);
        for y in z0..=z1 {
            for x in x0..=x1 {
                rgba[(y * w + x) as usize] = [90, 90, 90, 255];
            }
        }
    }
    for (b, n) in &cells {
        let t = (*n - least) as f32 / (most - least).max(1) as f32;
        let colour = [
            (40.0 + 215.0 * t) as u8,
            (40.0 + 190.0 * t) as u8,
            (140.0 * (1.0 - t) + 30.0) as u8,
            255,
        ];
        let (x0, z0) = to_px(b.min.x, b.min.z);
        for y in 0..PX - 1 {
            for x in 0..PX - 1 {
                let (px, py) = (x0 + x, z0 + y);
                if px < w && py < h {
                    rgba[(py * w + px) as usize] = colour;
                }
            }
        }
    }
    hom_render::write_png(path, w, h, &rgba)?;
    Ok(())
}

/// Six 90° views from `eye` covering every direction.
fn cube_cameras(eye: Vec3, near: f32, far: f32, side: u32) -> [Camera; 6] {
    let dirs = [Vec3::X, Vec3::NEG_X, Vec3::Y, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z];
    dirs.map(|d| {
        let up = if d.y != 0.0 { Vec3::Z } else { Vec3::Y };
        Camera::new(eye, eye + d, up, 90f32.to_radians(), near, far, side, side)
    })
}

/// The objects owning a pixel of any of six views from `eye`.
fn seen_from(
    renderer: &Renderer,
    scene: &hom::scene::Scene,
    cams: &[Camera; 6],
    fb: &mut Framebuffer,
    seen: &mut [bool],
) {
    for cam in cams {
        let counts = hom_render::oracle_pixel_counts(renderer, scene, cam, fb);
        for (s, c) in seen.iter_mut().zip(counts) {
            *s |= c > 0;
        }
    }
}

/// `hom pvs check`.
pub fn check(a: PvsCheckArgs) -> Result<()> {
    // A Quake 3 map's PVS serves eyes in its open space, clear of its
    // opaque leaves by the near clearance (a camera inside a wall sees
    // through it); other scenes' eyes may be anywhere in the cells. A map
    // is loaded once, for its scene and its leaves.
    let map = hom_walk::pvs::open_map(&a.scene).ok();
    let scene = match &map {
        Some(m) => m.scene.clone(),
        None => hom_walk::open_scene(&a.scene)?.0,
    };
    let pvs = read(&a.pvs)?;
    pvs.check_scene(&scene)?;
    if pvs.shard() != Shard::WHOLE {
        bail!("{} is a shard: merge the shards first", a.pvs.display());
    }
    if a.side < 8 || a.side > 4096 {
        bail!("--side must be 8..=4096 pixels");
    }
    let cells: Vec<Aabb> = pvs.cells().cells().map(|(_, b)| b).collect();
    if cells.is_empty() {
        bail!("{} has no cells", a.pvs.display());
    }
    // A square 90° view's near corners lie sqrt(3) near-distances away.
    let near = pvs.config().near_clearance / 1.75;
    if near < pvs.config().near {
        bail!("the PVS's near clearance is too small for 90° views");
    }
    let far = scene.bounds().extent().length() * 2.0 + 1.0;
    let renderer = Renderer::new(0)?;
    let mut fb = Framebuffer::new(a.side, a.side);
    let mut look = |eye: Vec3, seen: &mut [bool]| {
        seen_from(&renderer, &scene, &cube_cameras(eye, near, far, a.side), &mut fb, seen);
    };
    let mut rng = Rng(a.seed.max(1));
    let clearance = pvs.config().near_clearance;
    let open = |eye: Vec3| map.as_ref().is_none_or(|m| m.is_open(eye, clearance));
    let mut rejected = 0usize;
    let mut point_in = |b: &Aabb| {
        for _ in 0..1000 {
            let t = Vec3::new(rng.f32(), rng.f32(), rng.f32());
            let eye = b.min + (b.max - b.min) * t;
            if open(eye) {
                return Some(eye);
            }
            rejected += 1;
        }
        None
    };
    let n = scene.objects().len();
    let (mut violations, mut bad_points) = (0usize, 0usize);
    let bar = crate::setup::progress(a.points, "pvs check");
    let mut hidden = Vec::new();
    let (mut checked, mut closed_cells) = (0usize, 0usize);
    let mut i = 0usize;
    // Cells with no open point (wholly in a wall) are passed over.
    while checked < a.points && closed_cells < cells.len() {
        let cell = &cells[i % cells.len()];
        i += 1;
        let Some(eye) = point_in(cell) else {
            closed_cells += 1;
            continue;
        };
        closed_cells = 0;
        checked += 1;
        hidden.clear();
        pvs.hidden_from(eye, &mut hidden);
        let mut seen = vec![false; n];
        look(eye, &mut seen);
        let v = hidden.iter().filter(|&&id| seen[id as usize]).count();
        if v > 0 {
            bad_points += 1;
            eprintln!(
                "viewpoint {eye}: {v} hidden objects seen, e.g. {:?}",
                hidden.iter().find(|&&id| seen[id as usize])
            );
        }
        violations += v;
        bar.inc(1);
    }
    bar.finish_and_clear();
    println!(
        "conservative: {} random viewpoints in {} cells, 6 views of {}² each: {} hidden objects seen (at {} viewpoints)",
        checked,
        cells.len(),
        a.side,
        violations,
        bad_points
    );
    if map.is_some() {
        println!(
            "({rejected} random points in the cells were in or within {clearance} m of a wall or the void, and drawn again)"
        );
    }
    // Tightness: the PVS's visible set against the union of exact visible sets.
    let picks: Vec<usize> = (0..a.cells.min(cells.len()))
        .map(|k| k * cells.len() / a.cells.min(cells.len()).max(1))
        .collect();
    let static_live = scene.objects().iter().filter(|o| !o.is_removed()).count();
    let mut ratios = Vec::new();
    let k = (a.cell_points as f64).cbrt().ceil() as usize;
    for &c in &picks {
        let b = cells[c];
        hidden.clear();
        pvs.hidden_from(b.center(), &mut hidden);
        let mut seen = vec![false; n];
        for s in 0..a.cell_points {
            let (ix, iy, iz) = (s % k, (s / k) % k, s / (k * k) % k);
            let jitter = Vec3::new(rng.f32(), rng.f32(), rng.f32());
            let t = (Vec3::new(ix as f32, iy as f32, iz as f32) + jitter) / k as f32;
            let eye = b.min + (b.max - b.min) * t;
            if open(eye) {
                look(eye, &mut seen);
            }
        }
        let exact = seen.iter().filter(|&&s| s).count().max(1);
        let pvs_visible = static_live - hidden.len();
        let ratio = pvs_visible as f64 / exact as f64;
        println!(
            "cell at ({:.1}, {:.1}, {:.1}): PVS keeps {pvs_visible} objects, {exact} seen from {} points: {ratio:.2}x",
            b.center().x,
            b.center().y,
            b.center().z,
            a.cell_points
        );
        ratios.push(ratio);
    }
    if !ratios.is_empty() {
        ratios.sort_by(f64::total_cmp);
        let at = |q: f64| ratios[((ratios.len() - 1) as f64 * q).round() as usize];
        println!(
            "tightness over {} cells: PVS set ÷ union of exact sets, median {:.2}x, 95th percentile {:.2}x",
            ratios.len(),
            at(0.5),
            at(0.95)
        );
    }
    if violations > 0 {
        bail!("{violations} objects the PVS hides were seen");
    }
    Ok(())
}

/// xorshift64: the viewpoints of a check, reproducible from its seed.
///
/// The same stream as `hom_testkit::Rng` (shifts 13, 7, 17; the top 24 bits
/// as `[0, 1)`) but kept here: the test kit is for tests (a CLI cannot
/// depend on it), and it starts from `seed | 1` where this starts from
/// `seed.max(1)`, so an even `--seed` would give other viewpoints than the
/// checks recorded with it.
struct Rng(u64);

impl Rng {
    fn f32(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env<'a>(vars: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<String> + 'a {
        move |name| vars.iter().find(|(n, _)| *n == name).map(|(_, v)| v.to_string())
    }

    #[test]
    fn auto_shards_come_from_kubernetes_or_slurm() {
        let k8s = shard_from_env(4, env(&[("JOB_COMPLETION_INDEX", "3")])).unwrap();
        assert_eq!(k8s.0, Shard { index: 3, count: 4 });
        let slurm = [("SLURM_ARRAY_TASK_ID", "12"), ("SLURM_ARRAY_TASK_MIN", "10")];
        assert_eq!(shard_from_env(4, env(&slurm)).unwrap().0, Shard { index: 2, count: 4 });
        // Kubernetes' index wins where both are set.
        let both = [("JOB_COMPLETION_INDEX", "0"), ("SLURM_ARRAY_TASK_ID", "12")];
        assert_eq!(shard_from_env(4, env(&both)).unwrap().0.index, 0);
    }

    #[test]
    fn auto_shards_refuse_what_they_cannot_use() {
        let fails = |vars: &[(&str, &str)], needle: &str| {
            let e = shard_from_env(4, env(vars)).unwrap_err().to_string();
            assert!(e.contains(needle), "expected '{needle}' in: {e}");
        };
        fails(&[], "neither is set");
        fails(&[("JOB_COMPLETION_INDEX", "4")], "gives shard 4, not below 4");
        fails(&[("JOB_COMPLETION_INDEX", "-1")], "is not a whole number");
        fails(&[("JOB_COMPLETION_INDEX", "two")], "JOB_COMPLETION_INDEX='two'");
        fails(&[("SLURM_ARRAY_TASK_ID", "3")], "SLURM_ARRAY_TASK_MIN is not");
        fails(
            &[("SLURM_ARRAY_TASK_ID", "3"), ("SLURM_ARRAY_TASK_MIN", "5")],
            "is below",
        );
        fails(
            &[("SLURM_ARRAY_TASK_ID", "9"), ("SLURM_ARRAY_TASK_MIN", "5")],
            "gives shard 4",
        );
    }
}
