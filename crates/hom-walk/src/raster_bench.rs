//! `hom bench raster`: hom's occluder rasterizer and rectangle tests on the
//! inputs Intel's Masked Occlusion Culling (MOC) was measured on
//! (`bench-data/moc/`, formats in its README), next to MOC's own figures.
//!
//! Everything goes through hom's front door, [`hom::occlusion`], as an
//! engine would use it: for each `.mocscene` and resolution, the occluders
//! are drawn into an [`HzBuffer`] (the hierarchical z-buffer, exact per
//! sample) with one thread and with two, then the 100,000 rectangle queries
//! are answered with [`OcclusionBuffer::test_rect`] and every answer is
//! compared with the exact ones (`*_exact_*.res`) and MOC's (`*_moc_*.res`);
//! the same for a [`HomBuffer`] (occlusion map + depth estimation buffer)
//! and a [`MaskedBuffer`] (coverage masks and two depth layers per tile).
//! Recorded game frames (`.mocrec`) are rendered at their own resolution and
//! at 256×256. Times are medians over the runs ([`median`]: the mean of the
//! middle two for an even number).
//!
//! The reference answers come from a rasterizer that does not snap vertices,
//! so the buffers use [`hom::occlusion::Sampling::Conservative`] (their default), and MOC's
//! rectangles cover every pixel they touch, as `test_rect` does.

use crate::report::median;
use glam::{Vec2, Vec4};
use hom::occlusion::{BufferOptions, FaceCull, HomBuffer, HzBuffer, MaskedBuffer, OcclusionBuffer, Visibility};
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
    /// Median setup time (submission, clip, snap, edge functions), ms.
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
    /// Median time to draw the same triangles, nearest first, into a
    /// [`HomBuffer`] (submission, setup, coverage, pyramid, depth estimation cells), ms.
    pub map_ms: f64,
    /// Median time to draw the same triangles, in file order, into a
    /// [`MaskedBuffer`] (submission, setup, masks and depth layers), ms.
    pub masked_ms: f64,
    /// MOC AVX2 and AVX-512 single-thread render times, ms (README), where measured.
    pub peer_ms: Option<(f64, f64)>,
    /// Query answers on the tiled z-buffer (scenes only, first thread count only).
    pub queries: Option<QueryScore>,
    /// Query answers on the occlusion map and depth estimation buffer (HOM).
    pub map_queries: Option<QueryScore>,
    /// Query answers on the masked buffer.
    pub masked_queries: Option<QueryScore>,
}

/// The whole run.
#[derive(Clone, Debug, Serialize)]
pub struct RasterBenchReport {
    /// Options used.
    pub options: RasterBenchOptions,
    /// One row per input, resolution and thread count.
    pub rows: Vec<RasterRow>,
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// What one input renders: `(vertices, triangles, cull)` batches.
type Batches<'a> = Vec<(&'a [Vec4], &'a [[u32; 3]], FaceCull)>;

/// The same triangles nearest first (by their nearest vertex), as an engine
/// would submit occluders to the HOM buffer, whose depth cells keep the first
/// cover: runs of one face-culling mode, each with its own vertices.
fn nearest_first(batches: &Batches) -> Vec<(Vec<Vec4>, Vec<[u32; 3]>, FaceCull)> {
    let depth = |v: Vec4| if v.w > 0.0 { v.z / v.w } else { f32::NEG_INFINITY };
    let mut tris: Vec<(f32, Vec4, Vec4, Vec4, FaceCull)> = Vec::new();
    for (v, t, cull) in batches {
        for &[a, b, c] in t.iter() {
            let [a, b, c] = [a, b, c].map(|i| v[i as usize]);
            tris.push((depth(a).min(depth(b)).min(depth(c)), a, b, c, *cull));
        }
    }
    tris.sort_by(|x, y| x.0.total_cmp(&y.0));
    let mut runs: Vec<(Vec<Vec4>, Vec<[u32; 3]>, FaceCull)> = Vec::new();
    for (_, a, b, c, cull) in tris {
        if runs.last().is_none_or(|r| r.2 != cull) {
            runs.push((Vec::new(), Vec::new(), cull));
        }
        let run = runs.last_mut().expect("pushed");
        let k = run.0.len() as u32;
        run.0.extend([a, b, c]);
        run.1.push([k, k + 1, k + 2]);
    }
    runs
}

/// Clears `buf`, draws `batches` and flushes; returns (setup ms, raster ms, total ms).
fn draw(buf: &mut impl OcclusionBuffer, batches: &Batches) -> Result<(f64, f64, f64), RasterBenchError> {
    let t0 = Instant::now();
    buf.clear();
    for &(v, t, cull) in batches.iter() {
        buf.render_clip_triangles(v, t, cull)
            .map_err(|e| RasterBenchError::Options(e.to_string()))?;
    }
    buf.flush();
    let total = ms(t0);
    let raster = buf.stats().raster_ms;
    Ok((total - raster, raster, total))
}

/// Times setup and render of `batches` at `width` × `height`; returns the row
/// (without queries) and the rendered buffers.
fn time_render(
    input: &str,
    batches: &Batches,
    (width, height): (u32, u32),
    threads: usize,
    runs: usize,
) -> Result<(RasterRow, HzBuffer, HomBuffer, MaskedBuffer), RasterBenchError> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| RasterBenchError::Options(format!("thread pool of {threads}: {e}")))?;
    let buffer_error = |e: hom::occlusion::OcclusionError| RasterBenchError::Options(e.to_string());
    let mut zb = HzBuffer::new(width, height, BufferOptions::default()).map_err(buffer_error)?;
    let mut map = HomBuffer::new(width, height, BufferOptions::default()).map_err(buffer_error)?;
    let mut masked = MaskedBuffer::new(width, height, BufferOptions::default()).map_err(buffer_error)?;
    let (mut setup, mut render, mut total, mut map_times) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut masked_times = Vec::new();
    let sorted = nearest_first(batches);
    let sorted: Batches = sorted.iter().map(|(v, t, c)| (&v[..], &t[..], *c)).collect();
    pool.install(|| {
        for _ in 0..runs {
            let (s, r, t) = draw(&mut zb, batches)?;
            setup.push(s);
            render.push(r);
            total.push(t);
        }
        for _ in 0..runs {
            map_times.push(draw(&mut map, &sorted)?.2);
        }
        for _ in 0..runs {
            masked_times.push(draw(&mut masked, batches)?.2);
        }
        Ok::<(), RasterBenchError>(())
    })?;
    let stats = zb.stats();
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
        rejected: stats.tiles_rejected,
        map_ms: median(map_times),
        masked_ms: median(masked_times),
        peer_ms: peer,
        queries: None,
        map_queries: None,
        masked_queries: None,
    };
    Ok((row, zb, map, masked))
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

/// Answers the scene's rectangle queries with `buf.test_rect`, timed, and scores them.
fn score_queries(
    data: &Path,
    input: &str,
    scene: &MocScene,
    (w, h): (u32, u32),
    buf: &mut impl OcclusionBuffer,
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
        ours.extend(scene.rects.iter().map(|r| {
            let depth = 1.0 - scene.near_w / r.wmin; // the readers' z / w (see hom_scene::moc)
            let v = buf.test_rect(Vec2::new(r.xmin, r.ymin), Vec2::new(r.xmax, r.ymax), depth);
            v == Visibility::Occluded
        }));
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
                let (mut row, mut zb, mut map, mut masked) = time_render(&input, &batches, res, threads, options.runs)?;
                if let (Some(s), 0) = (&scene, k) {
                    let (data, runs) = (&options.data, options.runs);
                    row.queries = score_queries(data, &input, s, res, &mut zb, runs)?;
                    row.map_queries = score_queries(data, &input, s, res, &mut map, runs)?;
                    row.masked_queries = score_queries(data, &input, s, res, &mut masked, runs)?;
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
            "| input | resolution | triangles | threads | setup ms | z render ms | z total ms | Mtri/s | map ms | MOC AVX2 ms | MOC AVX-512 ms | z total ÷ AVX-512 | masked ms | masked ÷ AVX-512 |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
        for r in &self.rows {
            let (p2, p5, ratio, masked_ratio) = match r.peer_ms {
                Some((a, b)) if r.threads == 1 => (
                    format!("{a:.2}"),
                    format!("{b:.2}"),
                    format!("{:.2}", r.total_ms / b),
                    format!("{:.2}", r.masked_ms / b),
                ),
                _ => (String::new(), String::new(), String::new(), String::new()),
            };
            let _ = writeln!(
                s,
                "| {} | {}×{} | {} | {} | {:.2} | {:.2} | {:.2} | {:.1} | {:.2} | {p2} | {p5} | {ratio} | {:.2} | {masked_ratio} |",
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
                r.masked_ms,
            );
        }
        let _ = writeln!(s);
        let _ = writeln!(
            s,
            "| input | resolution | hidden (exact) | z wrong occluded | z found | map wrong occluded | map found | MOC wrong occluded | MOC found | z query ms | map query ms | MOC query ms | masked wrong occluded | masked found | masked query ms |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
        for r in &self.rows {
            let (Some(q), Some(m), Some(k)) = (&r.queries, &r.map_queries, &r.masked_queries) else {
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
                "| {} | {}×{} | {} | {} | {} | {} | {} | {} | {} | {:.2} | {:.2} | {} | {} | {} | {:.2} |",
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
                k.wrong_occluded,
                pct(k.found),
                k.ms,
            );
        }
        s
    }
}
