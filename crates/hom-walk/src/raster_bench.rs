//! `hom bench raster`: hom's occluder rasterizer and rectangle tests on the
//! inputs Intel's Masked Occlusion Culling (MOC) was measured on
//! (`bench-data/moc/`, formats in its README), next to MOC's own figures.
//!
//! For each `.mocscene` and resolution: set up and render the occluders into
//! hom's tiled hierarchical z-buffer ([`hom::depth::TiledZBuffer`], exact per
//! sample) with one thread and with two, then answer the 100,000 rectangle
//! queries and compare every answer with the exact ones (`*_exact_*.res`)
//! and MOC's (`*_moc_*.res`). Recorded game frames (`.mocrec`) are rendered
//! at their own resolution and at 256×256. Times are medians over the runs.

use hom::cull::HomConfig;
use hom::depth::{DepthEstimationBuffer, TiledZBuffer};
use hom::geom::ScreenRect;
use hom::map::{rect_covered, OverlapStats, Pyramid, Thresholds};
use hom::raster::setup::{SetupRule, Tri};
use hom::raster::{CoverageBuffer, OccluderRasterizer, TiledRasterizer};
use hom_scene::moc::{self, MocRecording, MocScene};
use hom_scene::LoadError;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;
use thiserror::Error;

/// MOC's single-thread render times in ms (AVX2, AVX-512), from the README
/// of `bench-data/moc/`: (input, width, height, avx2, avx512).
const PEER_RENDER_MS: [(&str, u32, u32, f64, f64); 12] = [
    ("small_10k", 1920, 1080, 0.37, 0.31),
    ("small_100k", 1920, 1080, 4.30, 3.73),
    ("large_10k", 1920, 1080, 2.21, 1.61),
    ("large_100k", 1920, 1080, 17.7, 13.2),
    ("large_100k", 1024, 1024, 15.4, 10.8),
    ("large_100k", 256, 256, 6.59, 5.30),
    ("OcclusionCulling_0", 1920, 1080, 0.22, 0.18),
    ("OcclusionCulling_1", 1920, 1080, 0.57, 0.44),
    ("OcclusionCulling_2", 1920, 1080, 0.38, 0.32),
    ("OcclusionCulling_0", 256, 256, 0.17, 0.14),
    ("OcclusionCulling_1", 256, 256, 0.41, 0.38),
    ("OcclusionCulling_2", 256, 256, 0.35, 0.32),
];

/// MOC's time for the 100k rectangle tests in ms at 1920×1080, same source.
const PEER_QUERY_MS: [(&str, f64); 4] = [
    ("small_10k", 0.74),
    ("small_100k", 1.14),
    ("large_10k", 4.42),
    ("large_100k", 4.48),
];

/// The resolutions every `.mocscene` is rendered at.
pub const SCENE_RESOLUTIONS: [(u32, u32); 3] = [(1920, 1080), (1024, 1024), (256, 256)];

/// How to run the raster bench.
#[derive(Clone, Debug, Serialize)]
pub struct RasterBenchOptions {
    /// The folder with the `.mocscene`, `.mocrec` and `.res` files.
    pub data: PathBuf,
    /// Runs per measurement (the median is reported); at least 1.
    pub runs: usize,
    /// Thread counts to render with.
    pub threads: Vec<usize>,
}

/// Why the raster bench could not run.
#[derive(Debug, Error)]
pub enum RasterBenchError {
    /// The data folder holds no inputs.
    #[error("{0}: no .mocscene or .mocrec files; pass --data with the bench-data/moc folder")]
    NoInputs(String),
    /// An input could not be read.
    #[error(transparent)]
    Load(#[from] LoadError),
    /// An answer file has the wrong number of entries.
    #[error("{path}: {found} answers for {expected} rectangles")]
    AnswerCount {
        /// File.
        path: String,
        /// Entries found.
        found: usize,
        /// Rectangles in the scene.
        expected: usize,
    },
    /// A thread pool could not be built, or the options are absurd.
    #[error("{0}")]
    Options(String),
}

/// Answers to one query set compared with the truth.
#[derive(Clone, Debug, Default, Serialize)]
pub struct QueryScore {
    /// Rectangles the truth says are occluded.
    pub hidden: usize,
    /// hom: occluded answers where the truth says visible (must be 0).
    pub wrong_occluded: usize,
    /// hom: hidden rectangles found occluded.
    pub found: usize,
    /// MOC: hidden rectangles it found (absent without its answer file).
    pub peer_found: Option<usize>,
    /// MOC: occluded answers where the truth says visible.
    pub peer_wrong_occluded: Option<usize>,
    /// Median time for all queries, ms (one thread).
    pub ms: f64,
    /// MOC's time for the same queries at 1920×1080 (README), ms.
    pub peer_ms: Option<f64>,
}

/// One input at one resolution and thread count.
#[derive(Clone, Debug, Serialize)]
pub struct RasterRow {
    /// Input name (file stem).
    pub input: String,
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Triangles submitted.
    pub triangles: usize,
    /// Threads.
    pub threads: usize,
    /// Median setup time (clip, snap, edge functions), ms.
    pub setup_ms: f64,
    /// Median render time (binning, tiles, pyramid), ms.
    pub render_ms: f64,
    /// Median of setup + render, ms.
    pub total_ms: f64,
    /// Triangles submitted per second at the median total.
    pub triangles_per_s: f64,
    /// Tiles whose samples were tested / skipped by depth, last run.
    pub tiles_drawn: u64,
    /// Tiles and blocks of tiles skipped by depth, last run.
    pub rejected: u64,
    /// Median time to render the occlusion map from the same set-up
    /// triangles (coverage, pyramid, depth estimation cells), ms.
    pub map_ms: f64,
    /// MOC AVX2 and AVX-512 single-thread render times, ms (README), where measured.
    pub peer_ms: Option<(f64, f64)>,
    /// Query answers on the tiled z-buffer (scenes only, first thread count only).
    pub queries: Option<QueryScore>,
    /// Query answers on the occlusion map and depth estimation buffer (HOM).
    pub map_queries: Option<QueryScore>,
}

/// HOM's representation of the same occluders: an occlusion map (exact
/// coverage counts, conservative thresholds) and a depth estimation buffer
/// whose cells hold the farthest first-cover depth (`hom::cull::hom`'s default).
pub struct OcclusionMap {
    pyramid: Pyramid,
    thresholds: Thresholds,
    depth: DepthEstimationBuffer,
}

/// The nearest depth of `t`'s plane over its bounding box.
fn nearest(t: &Tri) -> f32 {
    let (w, h) = (f32::from(t.x1 - t.x0 - 1), f32::from(t.y1 - t.y0 - 1));
    t.zref + (t.dzdx * w).min(0.0) + (t.dzdy * h).min(0.0)
}

impl OcclusionMap {
    /// Renders the set-up triangles `tris` at `width` × `height`, nearest
    /// first as HOM draws its occluders (so that a depth cell's first cover is
    /// mostly the nearest).
    pub fn render(raster: &mut OccluderRasterizer, tris: &[Tri], width: u32, height: u32) -> OcclusionMap {
        let mut coverage = CoverageBuffer::default();
        let mut depth = DepthEstimationBuffer::new(width, height, 64, 64);
        let mut order: Vec<(f32, u32)> = tris.iter().zip(0..).map(|(t, i)| (nearest(t), i)).collect();
        order.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        let sorted: Vec<Tri> = order.iter().map(|&(_, i)| tris[i as usize]).collect();
        raster.rasterize_triangles(&mut coverage, &sorted, width, height, Some(&mut depth));
        let mut pyramid = HomConfig::default().new_pyramid(width, height);
        pyramid.build_from_coverage(coverage.bits(), coverage.words_per_row());
        let thresholds = Thresholds::conservative(&pyramid, 0.0);
        OcclusionMap {
            pyramid,
            thresholds,
            depth,
        }
    }

    /// HOM's test: behind every depth cell under `r`, and `r` wholly opaque in the map.
    pub fn is_behind(&self, r: &ScreenRect) -> bool {
        self.depth.is_behind(r) && rect_covered(&self.pyramid, &self.thresholds, r, &mut OverlapStats::default())
    }
}

/// The whole run.
#[derive(Clone, Debug, Serialize)]
pub struct RasterBenchReport {
    /// Options used.
    pub options: RasterBenchOptions,
    /// One row per input, resolution and thread count.
    pub rows: Vec<RasterRow>,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// What one input renders: `(vertices, triangles, cull)` batches.
type Batches<'a> = Vec<(&'a [glam::Vec4], &'a [[u32; 3]], hom::raster::setup::FaceCull)>;

/// The truth of these inputs does not snap vertices, so hom sets up with the
/// inner rule to stay conservative against it.
fn rule(cull: hom::raster::setup::FaceCull) -> SetupRule {
    SetupRule { cull, inner: true }
}

/// Times setup and render of `batches` at `width` × `height`; returns the row
/// (without queries) and the rendered buffer.
fn time_render(
    input: &str,
    batches: &Batches,
    (width, height): (u32, u32),
    threads: usize,
    runs: usize,
) -> Result<(RasterRow, TiledZBuffer, OcclusionMap), RasterBenchError> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| RasterBenchError::Options(format!("thread pool of {threads}: {e}")))?;
    let mut raster = TiledRasterizer::new();
    let mut zb = TiledZBuffer::default();
    let (mut setup, mut render, mut total) = (Vec::new(), Vec::new(), Vec::new());
    let mut stats = Default::default();
    pool.install(|| {
        for _ in 0..runs {
            let t0 = Instant::now();
            zb.clear(width, height);
            raster.clear();
            for (v, t, cull) in batches {
                raster.setup(v, t, rule(*cull), width, height);
            }
            let s = ms(t0);
            let t1 = Instant::now();
            stats = raster.render(&mut zb);
            render.push(ms(t1));
            setup.push(s);
            total.push(ms(t0));
        }
    });
    let mut occ = OccluderRasterizer::new();
    let mut map_times = Vec::new();
    let map = pool.install(|| {
        let mut map = None;
        for _ in 0..runs {
            let t0 = Instant::now();
            map = Some(OcclusionMap::render(&mut occ, raster.triangles(), width, height));
            map_times.push(ms(t0));
        }
        map.expect("at least one run")
    });
    let triangles = batches.iter().map(|b| b.1.len()).sum();
    let total_ms = median(total);
    let peer = PEER_RENDER_MS
        .iter()
        .find(|p| p.0 == input && p.1 == width && p.2 == height)
        .map(|p| (p.3, p.4));
    let row = RasterRow {
        input: input.to_string(),
        width,
        height,
        triangles,
        threads,
        setup_ms: median(setup),
        render_ms: median(render),
        total_ms,
        triangles_per_s: triangles as f64 / (total_ms / 1e3),
        tiles_drawn: stats.tiles_drawn,
        rejected: stats.tiles_rejected + stats.blocks_rejected,
        map_ms: median(map_times),
        peer_ms: peer,
        queries: None,
        map_queries: None,
    };
    Ok((row, zb, map))
}

fn answers(path: &Path, expected: usize) -> Result<Option<Vec<bool>>, RasterBenchError> {
    if !path.exists() {
        return Ok(None);
    }
    let a = moc::read_answers(path)?;
    if a.len() != expected {
        return Err(RasterBenchError::AnswerCount {
            path: path.display().to_string(),
            found: a.len(),
            expected,
        });
    }
    Ok(Some(a))
}

/// Answers the scene's rectangle queries on `zb`, timed, and scores them.
fn score_queries(
    data: &Path,
    input: &str,
    scene: &MocScene,
    (w, h): (u32, u32),
    is_behind: impl Fn(&ScreenRect) -> bool,
    runs: usize,
) -> Result<Option<QueryScore>, RasterBenchError> {
    let Some(exact) = answers(&data.join(format!("{input}_exact_{w}x{h}.res")), scene.rects.len())? else {
        return Ok(None);
    };
    let peer = answers(&data.join(format!("{input}_moc_{w}x{h}.res")), scene.rects.len())?;
    let mut ours = Vec::with_capacity(scene.rects.len());
    let mut times = Vec::new();
    for _ in 0..runs {
        ours.clear();
        let t0 = Instant::now();
        ours.extend(scene.rects.iter().map(|r| is_behind(&r.footprint(w, h, scene.near_w))));
        times.push(ms(t0));
    }
    let count =
        |got: &[bool], want_hidden: bool| got.iter().zip(&exact).filter(|&(&g, &e)| g && e == want_hidden).count();
    let peer_ms = (w, h) == (1920, 1080);
    Ok(Some(QueryScore {
        hidden: exact.iter().filter(|&&e| e).count(),
        wrong_occluded: count(&ours, false),
        found: count(&ours, true),
        peer_found: peer.as_deref().map(|p| count(p, true)),
        peer_wrong_occluded: peer.as_deref().map(|p| count(p, false)),
        ms: median(times),
        peer_ms: PEER_QUERY_MS.iter().find(|p| peer_ms && p.0 == input).map(|p| p.1),
    }))
}

/// Runs the raster bench over every input in `options.data`; `progress` gets
/// a line per measurement.
pub fn run_raster_bench(
    options: &RasterBenchOptions,
    mut progress: impl FnMut(&str),
) -> Result<RasterBenchReport, RasterBenchError> {
    if options.runs == 0 || options.threads.is_empty() || options.threads.iter().any(|&t| t == 0 || t > 256) {
        return Err(RasterBenchError::Options(
            "need at least one run and thread counts in 1..=256".into(),
        ));
    }
    let mut files: Vec<PathBuf> = std::fs::read_dir(&options.data)
        .map_err(|source| LoadError::Io {
            path: options.data.display().to_string(),
            source,
        })?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "mocscene" || e == "mocrec"))
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(RasterBenchError::NoInputs(options.data.display().to_string()));
    }
    let mut rows = Vec::new();
    for file in &files {
        let input = file.file_stem().unwrap_or_default().to_string_lossy().into_owned();
        let (scene, recording): (Option<MocScene>, Option<MocRecording>) =
            if file.extension().is_some_and(|e| e == "mocscene") {
                (Some(moc::read_scene(file)?), None)
            } else {
                (None, Some(moc::read_recording(file)?))
            };
        let (batches, resolutions): (Batches, Vec<(u32, u32)>) = match (&scene, &recording) {
            (Some(s), _) => (
                vec![(&s.vertices[..], &s.triangles[..], MocScene::CULL)],
                SCENE_RESOLUTIONS.to_vec(),
            ),
            (_, Some(r)) => (
                r.draws
                    .iter()
                    .map(|d| (&d.vertices[..], &d.triangles[..], d.cull))
                    .collect(),
                vec![(r.width, r.height), (256, 256)],
            ),
            _ => unreachable!("one of the two was read"),
        };
        for &res in &resolutions {
            for (k, &threads) in options.threads.iter().enumerate() {
                let (mut row, zb, map) = time_render(&input, &batches, res, threads, options.runs)?;
                if let (Some(s), 0) = (&scene, k) {
                    let (data, runs) = (&options.data, options.runs);
                    row.queries = score_queries(data, &input, s, res, |r| zb.is_behind(r), runs)?;
                    row.map_queries = score_queries(data, &input, s, res, |r| map.is_behind(r), runs)?;
                }
                progress(&format!(
                    "{input} {}x{} {} thread(s): {:.2} ms",
                    res.0, res.1, threads, row.total_ms
                ));
                rows.push(row);
            }
        }
    }
    Ok(RasterBenchReport {
        options: options.clone(),
        rows,
    })
}

impl RasterBenchReport {
    /// The results as a Markdown table, then the query scores.
    pub fn table(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "| input | resolution | triangles | threads | setup ms | z render ms | z total ms | Mtri/s | map ms | MOC AVX2 ms | MOC AVX-512 ms | z total ÷ AVX-512 |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|---|---|");
        for r in &self.rows {
            let (p2, p5, ratio) = match r.peer_ms {
                Some((a, b)) if r.threads == 1 => {
                    (format!("{a:.2}"), format!("{b:.2}"), format!("{:.2}", r.total_ms / b))
                }
                _ => (String::new(), String::new(), String::new()),
            };
            let _ = writeln!(
                s,
                "| {} | {}×{} | {} | {} | {:.2} | {:.2} | {:.2} | {:.1} | {:.2} | {p2} | {p5} | {ratio} |",
                r.input,
                r.width,
                r.height,
                r.triangles,
                r.threads,
                r.setup_ms,
                r.render_ms,
                r.total_ms,
                r.triangles_per_s / 1e6,
                r.map_ms,
            );
        }
        let _ = writeln!(s);
        let _ = writeln!(
            s,
            "| input | resolution | hidden (exact) | z wrong occluded | z found | map wrong occluded | map found | MOC wrong occluded | MOC found | z query ms | map query ms | MOC query ms |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|---|---|");
        for r in &self.rows {
            let (Some(q), Some(m)) = (&r.queries, &r.map_queries) else {
                continue;
            };
            let pct = |n: usize| {
                if q.hidden == 0 {
                    "-".to_string()
                } else {
                    format!("{:.1} %", 100.0 * n as f64 / q.hidden as f64)
                }
            };
            let _ = writeln!(
                s,
                "| {} | {}×{} | {} | {} | {} | {} | {} | {} | {} | {:.2} | {:.2} | {} |",
                r.input,
                r.width,
                r.height,
                q.hidden,
                q.wrong_occluded,
                pct(q.found),
                m.wrong_occluded,
                pct(m.found),
                q.peer_wrong_occluded.map_or(String::new(), |n| n.to_string()),
                q.peer_found.map_or(String::new(), pct),
                q.ms,
                m.ms,
                q.peer_ms.map_or(String::new(), |m| format!("{m:.2}")),
            );
        }
        s
    }
}
