//! # hom-view — hom's frames through a real graphics API
//!
//! Everyone who evaluates an occlusion culler first flies through a scene
//! and watches what disappears; and a speedup measured with hom's software
//! renderer says what a software renderer gains, not what a renderer on a
//! graphics API gains. This crate draws hom's scenes with wgpu (Vulkan:
//! a GPU, or Mesa's lavapipe where there is none):
//!
//! - [`window::run`], `hom view`: a window that flies through a scene with
//!   any culler, a false-colour overlay (occluders blue, culled objects red
//!   through what hides them), the occlusion buffer as an inset, a line of
//!   figures, and a key that records the camera's path.
//! - [`headless::run`], `hom view --headless`: the same frames into PNGs.
//! - [`WgpuDraw`], `hom walk --renderer wgpu`: the walk's timed frames drawn
//!   by wgpu ([`hom_walk::FrameDraw`]), and the item buffer drawn by wgpu
//!   ([`WgpuDraw::items`]), checked against hom's oracle.
//!
//! ## Conventions
//!
//! hom's clip space is wgpu's (z / w in `[0, 1]`, NDC y up, pixel (0, 0) at
//! the top left, samples at pixel centres, the top-left fill rule), so a
//! [`hom::geom::Camera`]'s `view_proj` goes to the shader as it is. Every
//! mesh lies in one vertex and one index buffer, a range each; an object is
//! one draw of its mesh's range with its id as the instance index, which
//! reads its transform and colour from a storage buffer. Triangles are
//! two-sided and flat shaded as the software renderer shades them
//! (`colour × (0.25 + 0.75 |n · v|)`), depth is cleared to 1 and nearer
//! wins.

#![forbid(unsafe_code)]

mod gpu;
pub mod headless;
mod offscreen;
mod overlay;
mod scene_gpu;
mod viewer;
pub mod window;

pub use gpu::Gpu;
pub use offscreen::WgpuDraw;
pub use viewer::{Viewer, ViewerOptions};

use std::path::PathBuf;

/// Why the viewer or the wgpu renderer could not go on.
#[derive(Debug, thiserror::Error)]
pub enum ViewError {
    /// No Vulkan adapter: no GPU driver, and no lavapipe.
    #[error(
        "no Vulkan adapter ({0}); install a GPU's Vulkan driver, or Mesa's lavapipe \
         (Debian: mesa-vulkan-drivers, as scripts/install-graphics.sh does)"
    )]
    NoAdapter(String),
    /// The adapter refused a device, or the device failed.
    #[error("the Vulkan device failed: {0}")]
    Device(String),
    /// No display to open a window on.
    #[error("no display to open a window on ({0}); set DISPLAY, or use --headless")]
    NoDisplay(String),
    /// The window or its surface could not be made.
    #[error("the window failed: {0}")]
    Window(String),
    /// The scene's meshes do not fit the device's buffers.
    #[error("the scene's meshes do not fit one vertex and one index buffer of this device")]
    SceneTooBig,
    /// The culler refused a frame.
    #[error("frame {frame}: the culler refused it")]
    Cull {
        /// Frame index.
        frame: usize,
        /// Cause.
        #[source]
        source: hom::cull::CullError,
    },
    /// A picture or a path file could not be written.
    #[error("could not write '{}'", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// Cause.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// The path's frames do not make valid cameras.
    #[error(transparent)]
    Path(#[from] hom_scene::CameraPathError),
}
