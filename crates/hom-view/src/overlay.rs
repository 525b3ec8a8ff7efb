//! Pictures on top of the frame: the line of figures (text drawn on the
//! CPU with a font shipped in a crate, so no system font is needed) and
//! the occlusion buffer's inset.

use ab_glyph::{Font, FontRef, ScaleFont};

/// Where a picture sits on the frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Corner {
    TopRight,
    BottomLeft,
}

/// Pixels between a picture and the frame's edge.
const MARGIN: u32 = 8;

struct Picture {
    corner: Corner,
    width: u32,
    height: u32,
    texture: wgpu::Texture,
    rect: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
}

/// The pictures, each in a slot, and the pipeline that draws them.
pub(crate) struct Overlay {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    pictures: Vec<Option<Picture>>,
}

impl Overlay {
    pub(crate) fn new(device: &wgpu::Device, format: wgpu::TextureFormat) -> Overlay {
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hom-view overlay"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::VERTEX,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: true },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
            ],
        });
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("hom-view overlay"),
            source: wgpu::ShaderSource::Wgsl(include_str!("shaders/overlay.wgsl").into()),
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("hom-view overlay"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("hom-view overlay"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &shader,
                entry_point: Some("vs"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleStrip,
                ..Default::default()
            },
            depth_stencil: None,
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &shader,
                entry_point: Some("fs"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format,
                    blend: Some(wgpu::BlendState::ALPHA_BLENDING),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("hom-view overlay"),
            ..Default::default()
        });
        Overlay {
            pipeline,
            layout,
            sampler,
            pictures: Vec::new(),
        }
    }

    /// Puts the RGBA picture `rgba` (`width` × `height`, row 0 at the top)
    /// in `slot`, at `corner` of the frame.
    pub(crate) fn set(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        slot: usize,
        corner: Corner,
        (width, height): (u32, u32),
        rgba: &[u8],
    ) {
        if self.pictures.len() <= slot {
            self.pictures.resize_with(slot + 1, || None);
        }
        let fits = self.pictures[slot]
            .as_ref()
            .is_some_and(|p| (p.width, p.height) == (width, height));
        if !fits {
            self.pictures[slot] = Some(self.picture(device, corner, width, height));
        }
        let picture = self.pictures[slot].as_mut().expect("made");
        picture.corner = corner;
        queue.write_texture(
            picture.texture.as_image_copy(),
            rgba,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(width * 4),
                rows_per_image: Some(height),
            },
            crate::offscreen::extent(width, height),
        );
    }

    /// Takes the picture out of `slot`.
    pub(crate) fn clear(&mut self, slot: usize) {
        if let Some(p) = self.pictures.get_mut(slot) {
            *p = None;
        }
    }

    fn picture(&self, device: &wgpu::Device, corner: Corner, width: u32, height: u32) -> Picture {
        let texture = crate::offscreen::texture(
            device,
            "hom-view overlay picture",
            (width, height),
            wgpu::TextureFormat::Rgba8Unorm,
            wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        );
        let rect = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("hom-view overlay rectangle"),
            size: 16,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let view = texture.create_view(&Default::default());
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("hom-view overlay picture"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: rect.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&view),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::Sampler(&self.sampler),
                },
            ],
        });
        Picture {
            corner,
            width,
            height,
            texture,
            rect,
            bind_group,
        }
    }

    /// Draws the pictures on `target` (`width` × `height`) over what is there.
    pub(crate) fn draw(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        (width, height): (u32, u32),
    ) {
        let pictures: Vec<&Picture> = self.pictures.iter().flatten().collect();
        if pictures.is_empty() {
            return;
        }
        for p in &pictures {
            let (x0, y0) = match p.corner {
                Corner::TopRight => (width.saturating_sub(MARGIN + p.width), MARGIN),
                Corner::BottomLeft => (MARGIN, height.saturating_sub(MARGIN + p.height)),
            };
            let (x1, y1) = (x0 + p.width, y0 + p.height);
            let ndc_x = |x: u32| x as f32 / width as f32 * 2.0 - 1.0;
            let ndc_y = |y: u32| 1.0 - y as f32 / height as f32 * 2.0;
            let rect = [ndc_x(x0), ndc_y(y0), ndc_x(x1), ndc_y(y1)];
            queue.write_buffer(
                &p.rect,
                0,
                &rect.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<_>>(),
            );
        }
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("hom-view overlay"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Load,
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipeline);
        for p in pictures {
            pass.set_bind_group(0, &p.bind_group, &[]);
            pass.draw(0..4, 0..1);
        }
    }
}

/// `text`'s lines in white on a translucent dark panel, letters `px`
/// pixels high: its size and RGBA pixels.
pub(crate) fn text_picture(text: &str, px: f32) -> ((u32, u32), Vec<u8>) {
    let font = FontRef::try_from_slice(epaint_default_fonts::HACK_REGULAR).expect("the crate's own font parses");
    let scaled = font.as_scaled(px);
    let pad = 6.0;
    let line_height = scaled.height() + scaled.line_gap();
    let lines: Vec<&str> = text.lines().collect();
    let advance = |line: &str| -> f32 { line.chars().map(|c| scaled.h_advance(scaled.glyph_id(c))).sum() };
    let widest = lines.iter().map(|l| advance(l)).fold(0.0, f32::max);
    let width = (widest + 2.0 * pad).ceil() as u32;
    let height = (line_height * lines.len() as f32 + pad).ceil() as u32;
    let mut rgba = [16u8, 18, 24, 190].repeat(width as usize * height as usize);
    for (row, line) in lines.iter().enumerate() {
        let baseline = pad / 2.0 + scaled.ascent() + line_height * row as f32;
        let mut x = pad;
        for c in line.chars() {
            let id = scaled.glyph_id(c);
            let glyph = id.with_scale_and_position(px, ab_glyph::point(x, baseline));
            x += scaled.h_advance(id);
            let Some(outline) = font.outline_glyph(glyph) else {
                continue;
            };
            let bounds = outline.px_bounds();
            outline.draw(|gx, gy, coverage| {
                let (px_x, px_y) = (bounds.min.x as i64 + gx as i64, bounds.min.y as i64 + gy as i64);
                if px_x < 0 || px_y < 0 || px_x >= width as i64 || px_y >= height as i64 {
                    return;
                }
                let i = (px_y as usize * width as usize + px_x as usize) * 4;
                let a = coverage.clamp(0.0, 1.0);
                for c in &mut rgba[i..i + 3] {
                    *c = (*c as f32 * (1.0 - a) + 245.0 * a) as u8;
                }
                rgba[i + 3] = rgba[i + 3].max((255.0 * a) as u8);
            });
        }
    }
    ((width, height), rgba)
}

/// The occlusion buffer's coverage as a picture: white where covered, dark
/// elsewhere, mostly opaque.
pub(crate) fn coverage_picture(coverage: &[u8]) -> Vec<u8> {
    coverage
        .iter()
        .flat_map(|&v| if v > 0 { [235, 235, 235, 230] } else { [20, 22, 30, 200] })
        .collect()
}
