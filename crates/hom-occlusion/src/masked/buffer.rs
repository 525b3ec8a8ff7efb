//! [`MaskedBuffer`]: masked software occlusion culling (Hasselgren, Andersson
//! and Akenine-Möller, HPG 2016) as an occlusion buffer — per 32×8-sample
//! tile a coverage mask, and per 8×4 subtile two conservative depth layers
//! ([`MaskedZBuffer`]), drawn by the masked rasterizer (exact coverage from
//! scan-line edge events, one far depth per triangle and subtile). Much less
//! work per sample than [`super::HzBuffer`]'s per-sample depth; it finds
//! fewer hidden boxes where small occluders at mixed depths share a subtile.

use crate::geom::ScreenRect;
use crate::masked::raster::MaskedRasterizer;
use crate::masked::MaskedZBuffer;
use crate::{occlusion_buffer, BufferOptions, Front, OcclusionError};

/// The masked occlusion buffer; see the [crate docs](crate).
#[derive(Clone, Debug)]
pub struct MaskedBuffer {
    front: Front,
    raster: MaskedRasterizer,
    zbuffer: MaskedZBuffer,
    /// Cleared since the last draw (see [`MaskedBuffer::settle`]).
    cleared: bool,
}

impl MaskedBuffer {
    /// An empty `width` × `height` buffer (each side 1..=16384).
    pub fn new(width: u32, height: u32, options: BufferOptions) -> Result<MaskedBuffer, OcclusionError> {
        let front = Front::new(width, height, options)?;
        let mut zbuffer = MaskedZBuffer::default();
        zbuffer.clear(width, height);
        zbuffer.build_blocks();
        Ok(MaskedBuffer {
            raster: MaskedRasterizer::with_backend(front.backend),
            front,
            zbuffer,
            cleared: false,
        })
    }

    /// The masked depth drawn so far (draws what is queued first).
    pub fn zbuffer(&mut self) -> &MaskedZBuffer {
        <Self as crate::OcclusionBuffer>::flush(self);
        &self.zbuffer
    }

    /// The buffer as it stands, without drawing what is queued (the culler's hole search).
    pub fn last_zbuffer(&self) -> &MaskedZBuffer {
        &self.zbuffer
    }

    /// Empties the buffer lazily: the first draw (or a settle) does the work.
    fn reset(&mut self) {
        self.cleared = true;
    }

    /// After a flush: a buffer cleared and never drawn since is emptied.
    #[inline]
    fn settle(&mut self) {
        if self.cleared {
            self.zbuffer.clear(self.front.width, self.front.height);
            self.zbuffer.build_blocks();
            self.cleared = false;
        }
    }

    /// Sets the queue up and draws it, each chunk of it set up on a thread
    /// of its own and drawn from where it lies.
    fn draw_queue(&mut self) {
        if self.cleared {
            self.zbuffer.clear(self.front.width, self.front.height);
            self.cleared = false;
        }
        let setup = self.front.queue_setup();
        let r = self
            .raster
            .set_up_and_render(&self.front.queue, &setup, &mut self.zbuffer);
        let stats = &mut self.front.stats;
        stats.triangles_drawn += r.triangles as u64;
        stats.setup_ms += r.set_up_ms;
        stats.raster_ms += r.draw_ms;
        stats.tiles_drawn += r.stats.tiles_drawn;
        stats.tiles_rejected += r.stats.tiles_rejected + r.stats.rows_rejected;
    }

    fn is_behind(&self, r: &ScreenRect) -> bool {
        self.zbuffer.is_behind(r)
    }

    /// [`Self::is_behind`], for [`crate::SharedBuffer`].
    fn is_behind_shared(&self, r: &ScreenRect) -> bool {
        self.is_behind(r)
    }
}

occlusion_buffer!(MaskedBuffer, draw_queue);
