//! Drawing offscreen: targets read back to memory (pictures, the item
//! buffer), and [`WgpuDraw`], the renderer `hom walk --renderer wgpu` times.

use crate::gpu::Gpu;
use crate::scene_gpu::{Pass, SceneGpu, DEPTH_FORMAT, ITEM_FORMAT};
use crate::ViewError;
use hom::geom::Camera;
use hom::scene::Scene;
use hom_walk::{DrawError, FrameDraw};
use std::time::Instant;

/// The colour format of offscreen targets: the shader's values as bytes,
/// as hom's software renderer writes them (no sRGB encoding).
pub(crate) const COLOUR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

/// Usage of a target drawn into and read back.
pub(crate) const READ_BACK: wgpu::TextureUsages =
    wgpu::TextureUsages::RENDER_ATTACHMENT.union(wgpu::TextureUsages::COPY_SRC);

/// [`WgpuDraw`]'s colour, item and depth targets, of one size.
struct Offscreen {
    size: (u32, u32),
    colour_view: wgpu::TextureView,
    item: wgpu::Texture,
    item_view: wgpu::TextureView,
    depth_view: wgpu::TextureView,
}

impl Offscreen {
    fn new(device: &wgpu::Device, size: (u32, u32)) -> Offscreen {
        let colour = texture(device, "hom-view colour", size, COLOUR_FORMAT, READ_BACK);
        let item = texture(device, "hom-view items", size, ITEM_FORMAT, READ_BACK);
        Offscreen {
            size,
            colour_view: colour.create_view(&Default::default()),
            item_view: item.create_view(&Default::default()),
            item,
            depth_view: depth_target(device, size),
        }
    }

    /// The target in `slot`, made again where its size is not `size`.
    fn fit<'s>(slot: &'s mut Option<Offscreen>, device: &wgpu::Device, size: (u32, u32)) -> &'s Offscreen {
        if slot.as_ref().is_none_or(|t| t.size != size) {
            *slot = Some(Offscreen::new(device, size));
        }
        slot.as_ref().expect("made")
    }
}

/// A two-dimensional texture of `size`, one mip level, one sample.
pub(crate) fn texture(
    device: &wgpu::Device,
    label: &str,
    (width, height): (u32, u32),
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: extent(width, height),
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

/// A depth target of `size`.
pub(crate) fn depth_target(device: &wgpu::Device, size: (u32, u32)) -> wgpu::TextureView {
    texture(
        device,
        "hom-view depth",
        size,
        DEPTH_FORMAT,
        wgpu::TextureUsages::RENDER_ATTACHMENT,
    )
    .create_view(&Default::default())
}

pub(crate) fn extent(width: u32, height: u32) -> wgpu::Extent3d {
    wgpu::Extent3d {
        width,
        height,
        depth_or_array_layers: 1,
    }
}

/// The pixels of a 4-byte-per-pixel `texture`, row-major, row 0 at the top.
pub(crate) fn read_texture(gpu: &Gpu, texture: &wgpu::Texture, width: u32, height: u32) -> Result<Vec<u8>, ViewError> {
    let row = width * 4;
    let padded = row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("hom-view read back"),
        size: padded as u64 * height as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded),
                rows_per_image: Some(height),
            },
        },
        extent(width, height),
    );
    gpu.queue.submit([encoder.finish()]);
    let bytes = gpu.read(&buffer)?;
    Ok(bytes
        .chunks_exact(padded as usize)
        .flat_map(|r| &r[..row as usize])
        .copied()
        .collect())
}

/// A render pass clearing `colour` (to `clear`) and `depth` (to 1).
pub(crate) fn begin_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    colour: &wgpu::TextureView,
    clear: wgpu::Color,
    depth: &wgpu::TextureView,
    timestamp_writes: Option<wgpu::RenderPassTimestampWrites<'_>>,
) -> wgpu::RenderPass<'e> {
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("hom-view scene"),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: colour,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load: wgpu::LoadOp::Clear(clear),
                store: wgpu::StoreOp::Store,
            },
        })],
        depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
            view: depth,
            depth_ops: Some(wgpu::Operations {
                load: wgpu::LoadOp::Clear(1.0),
                store: wgpu::StoreOp::Store,
            }),
            stencil_ops: None,
        }),
        timestamp_writes,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}

/// hom's software renderer's background, as a clear colour.
pub(crate) fn background() -> wgpu::Color {
    let [r, g, b] = hom_render::DEFAULT_BACKGROUND.map(|c| c as f64 / 255.0);
    wgpu::Color { r, g, b, a: 1.0 }
}

/// GPU timestamps around a render pass, read back after it.
struct Timer {
    queries: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    read: wgpu::Buffer,
    /// Nanoseconds a timestamp tick.
    period_ns: f64,
}

/// hom's scene drawn offscreen by wgpu, as `hom walk --renderer wgpu` times
/// its frames: one draw per object (its mesh's range of the shared vertex
/// and index buffers), flat shading, a depth buffer, at the camera's
/// viewport. A frame's time is its render pass's, by GPU timestamps where
/// the adapter has them, else from submit to the queue being done.
pub struct WgpuDraw {
    gpu: Gpu,
    scene: SceneGpu,
    target: Option<Offscreen>,
    timer: Option<Timer>,
}

impl WgpuDraw {
    /// A renderer for `scene` (its meshes uploaded now) on the first Vulkan adapter.
    pub fn new(scene: &Scene) -> Result<WgpuDraw, ViewError> {
        let gpu = Gpu::headless()?;
        let scene = SceneGpu::new(&gpu.device, scene, COLOUR_FORMAT)?;
        let timer = gpu.timestamps.then(|| Timer {
            queries: gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("hom-view frame time"),
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            }),
            resolve: gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("hom-view timestamps"),
                size: 16,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            read: gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("hom-view timestamps read"),
                size: 16,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            }),
            period_ns: gpu.queue.get_timestamp_period() as f64,
        });
        Ok(WgpuDraw {
            gpu,
            scene,
            target: None,
            timer,
        })
    }

    /// Draws `ids` as `camera` sees them and returns the item buffer: the
    /// id of the object owning each pixel ([`hom_render::NO_OBJECT`] where
    /// none), row-major, row 0 at the top — hom's oracle, drawn by wgpu.
    pub fn items(&mut self, scene: &Scene, ids: &[u32], camera: &Camera) -> Result<Vec<u32>, ViewError> {
        let (width, height) = (camera.width, camera.height);
        let target = Offscreen::fit(&mut self.target, &self.gpu.device, (width, height));
        self.scene
            .prepare(&self.gpu.device, &self.gpu.queue, scene, camera, None);
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        {
            let none = wgpu::Color {
                r: hom_render::NO_OBJECT as f64,
                g: 0.0,
                b: 0.0,
                a: 0.0,
            };
            let mut pass = begin_pass(&mut encoder, &target.item_view, none, &target.depth_view, None);
            self.scene.draw(&mut pass, Pass::Item, scene, ids, camera.eye);
        }
        self.gpu.queue.submit([encoder.finish()]);
        let bytes = read_texture(&self.gpu, &target.item, width, height)?;
        Ok(bytes
            .chunks_exact(4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect())
    }

    /// One timed frame: its milliseconds.
    fn draw_timed(&mut self, scene: &Scene, ids: &[u32], camera: &Camera) -> Result<f64, ViewError> {
        let start = Instant::now();
        let target = Offscreen::fit(&mut self.target, &self.gpu.device, (camera.width, camera.height));
        self.scene
            .prepare(&self.gpu.device, &self.gpu.queue, scene, camera, None);
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        {
            let timestamp_writes = self.timer.as_ref().map(|t| wgpu::RenderPassTimestampWrites {
                query_set: &t.queries,
                beginning_of_pass_write_index: Some(0),
                end_of_pass_write_index: Some(1),
            });
            let mut pass = begin_pass(
                &mut encoder,
                &target.colour_view,
                background(),
                &target.depth_view,
                timestamp_writes,
            );
            self.scene.draw(&mut pass, Pass::Colour, scene, ids, camera.eye);
        }
        if let Some(t) = &self.timer {
            encoder.resolve_query_set(&t.queries, 0..2, &t.resolve, 0);
            encoder.copy_buffer_to_buffer(&t.resolve, 0, &t.read, 0, 16);
        }
        self.gpu.queue.submit([encoder.finish()]);
        self.gpu.wait()?;
        let wall_ms = start.elapsed().as_secs_f64() * 1e3;
        let Some(t) = &self.timer else {
            return Ok(wall_ms);
        };
        let bytes = self.gpu.read(&t.read)?;
        let tick = |i: usize| u64::from_le_bytes(bytes[i * 8..i * 8 + 8].try_into().expect("8 bytes"));
        Ok(tick(1).saturating_sub(tick(0)) as f64 * t.period_ns / 1e6)
    }
}

impl FrameDraw for WgpuDraw {
    fn describe(&self) -> String {
        let timing = if self.timer.is_some() {
            "timed by GPU timestamps"
        } else {
            "timed from submit to done"
        };
        format!("wgpu: {}; {timing}", self.gpu.describe())
    }

    fn draw(&mut self, scene: &Scene, ids: &[u32], camera: &Camera) -> Result<f64, DrawError> {
        Ok(self.draw_timed(scene, ids, camera)?)
    }
}
