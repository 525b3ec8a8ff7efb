//! [`HzBuffer`]: the hierarchical Z-buffer (Greene, Kass and Miller 1993;
//! RTR section 7.2) as an occlusion buffer — occluder depth per sample in a
//! [`TiledZBuffer`] (8×8 tiles, each with its farthest depth, a max-pyramid
//! above), drawn by [`TiledRasterizer`], which skips blocks and tiles that
//! are already nearer than the triangle.
//!
//! A rectangle is occluded when every sample under it holds an occluder
//! nearer than the rectangle's nearest depth by [`crate::DEPTH_MARGIN`]
//! (coarse to fine through the pyramid: [`TiledZBuffer::is_behind`]).

use crate::geom::ScreenRect;
use crate::hzb::raster::TiledRasterizer;
use crate::hzb::TiledZBuffer;
use crate::{occlusion_buffer, BufferOptions, Front, OcclusionError};

/// The hierarchical Z-buffer occlusion buffer; see the [crate docs](crate).
#[derive(Clone, Debug)]
pub struct HzBuffer {
    front: Front,
    raster: TiledRasterizer,
    zbuffer: TiledZBuffer,
    /// Cleared since the last draw: the z-buffer still holds the old frame
    /// until the next draw or settle empties it.
    cleared: bool,
}

impl HzBuffer {
    /// An empty `width` × `height` buffer (each side 1..=16384).
    pub fn new(width: u32, height: u32, options: BufferOptions) -> Result<HzBuffer, OcclusionError> {
        let front = Front::new(width, height, options)?;
        let mut zbuffer = TiledZBuffer::default();
        zbuffer.clear(width, height);
        zbuffer.build_pyramid();
        Ok(HzBuffer {
            raster: TiledRasterizer::with_backend(front.backend),
            front,
            zbuffer,
            cleared: false,
        })
    }

    /// The occluder depth drawn so far and its pyramid (draws what is queued first).
    pub fn zbuffer(&mut self) -> &TiledZBuffer {
        <Self as crate::OcclusionBuffer>::flush(self);
        &self.zbuffer
    }

    /// The z-buffer as it stands, without drawing what is queued (the culler's hole search).
    pub fn last_zbuffer(&self) -> &TiledZBuffer {
        &self.zbuffer
    }

    /// Empties the buffer lazily (see [`HzBuffer::settle`]): a cleared frame
    /// builds its pyramid once, when drawn.
    fn reset(&mut self) {
        self.cleared = true;
    }

    /// After a flush: a buffer cleared and never drawn since is emptied.
    #[inline]
    fn settle(&mut self) {
        if self.cleared {
            self.zbuffer.clear(self.front.width, self.front.height);
            self.zbuffer.build_pyramid();
            self.cleared = false;
        }
    }

    fn draw(&mut self) {
        if self.cleared {
            self.zbuffer.clear(self.front.width, self.front.height);
            self.cleared = false;
        }
        let parallel = self.front.options.threads == crate::Threads::Pool;
        let s = self.raster.render_with(&self.front.tris, &mut self.zbuffer, parallel);
        self.front.stats.tiles_drawn += s.tiles_drawn;
        self.front.stats.tiles_rejected += s.tiles_rejected + s.blocks_rejected;
    }

    fn is_behind(&self, r: &ScreenRect) -> bool {
        self.zbuffer.is_behind(r)
    }

    /// [`Self::is_behind`], for [`crate::SharedBuffer`].
    fn is_behind_shared(&self, r: &ScreenRect) -> bool {
        self.is_behind(r)
    }
}

occlusion_buffer!(HzBuffer);
