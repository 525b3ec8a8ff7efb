//! One module per subcommand, each with a `run` (or, for `scene`, one
//! function per tool); the pictures more than one command draws.

pub mod bench;
pub mod demo;
pub mod occluders;
pub mod pvs;
pub mod render;
pub mod scene;
pub mod view;
pub mod walk;

use anyhow::Result;
use hom_walk::report::FrameRecord;
use hom_walk::{pictures, WalkResult};
use std::path::Path;

/// The frame where the most triangles were culled as occluded (the earliest of
/// ties): the one that shows a culler best.
pub fn busiest_frame(frames: &[FrameRecord]) -> usize {
    frames
        .iter()
        .max_by_key(|f| (f.triangles_occlusion_culled, std::cmp::Reverse(f.frame)))
        .map_or(0, |f| f.frame)
}

/// The stage chart of walks: each culler's mean stages against its mean
/// frustum-only frame (means add up, so a bar is 1 ÷ the walk's speedup).
pub fn write_stage_chart(out: &Path, rows: &[(&str, &WalkResult)]) -> Result<()> {
    let bars: Vec<pictures::StageBar> = rows
        .iter()
        .filter_map(|(name, r)| {
            Some(pictures::StageBar {
                label: name.to_string(),
                stages_ms: r.summary.mean_stage_ms.clone(),
                baseline_ms: r.summary.mean_baseline_frame_ms?,
            })
        })
        .collect();
    pictures::plot_stage_breakdown(out, &bars)?;
    Ok(())
}
