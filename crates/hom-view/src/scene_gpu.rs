//! A hom scene on the GPU: every mesh in one vertex and one index buffer
//! (a range each), every object's transform and colour in a storage buffer
//! indexed by its id, and the pipelines that draw them — one draw per
//! object, its id as the instance index.

use crate::ViewError;
use glam::Mat4;
use hom::geom::Camera;
use hom::scene::Scene;
use wgpu::util::DeviceExt;

/// The depth format of every target (clip z / w, cleared to 1, nearer wins).
pub(crate) const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// The item target's format: the object id per pixel.
pub(crate) const ITEM_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;

/// Bytes of one object's record: its model matrix and colour.
const OBJECT_BYTES: u64 = 80;
/// Bytes of the frame's uniform: view-projection, eye, flags.
const FRAME_BYTES: u64 = 96;

/// A mesh's range of the shared buffers.
#[derive(Clone, Copy, Debug)]
struct MeshRange {
    first_index: u32,
    index_count: u32,
    base_vertex: i32,
}

/// How a draw writes its target.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Pass {
    /// Flat-shaded colour with depth (occluders tinted when the overlay is on).
    Colour,
    /// Objects drawn translucent with no depth test: the culled ones, seen
    /// through what hides them.
    Ghost,
    /// The object id per pixel (hom's item buffer), with depth.
    Item,
}

/// The scene's buffers and the pipelines that draw them into a colour
/// target of one format.
pub(crate) struct SceneGpu {
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    meshes: Vec<MeshRange>,
    frame: wgpu::Buffer,
    objects: wgpu::Buffer,
    roles: wgpu::Buffer,
    layout: wgpu::BindGroupLayout,
    bind_group: wgpu::BindGroup,
    /// Objects the object and role buffers hold.
    capacity: usize,
    /// The scene's revision the object buffer was written at.
    written: Option<hom::scene::Revision>,
    colour: wgpu::RenderPipeline,
    ghost: wgpu::RenderPipeline,
    item: wgpu::RenderPipeline,
    /// Scratch: the roles this frame.
    role_bytes: Vec<u8>,
}

impl SceneGpu {
    /// Uploads `scene`'s meshes; pipelines draw into `colour_format`.
    pub(crate) fn new(
        device: &wgpu::Device,
        scene: &Scene,
        colour_format: wgpu::TextureFormat,
    ) -> Result<SceneGpu, ViewError> {
        let (mut positions, mut indices, mut meshes) = (Vec::new(), Vec::new(), Vec::new());
        for mesh in scene.meshes() {
            let base_vertex = i32::try_from(positions.len() / 12).map_err(|_| ViewError::SceneTooBig)?;
            let first_index = u32::try_from(indices.len() / 4).map_err(|_| ViewError::SceneTooBig)?;
            for p in mesh.positions() {
                positions.extend(p.to_array().iter().flat_map(|c| c.to_le_bytes()));
            }
            for t in mesh.triangles() {
                indices.extend(t.iter().flat_map(|i| i.to_le_bytes()));
            }
            let index_count = u32::try_from(mesh.triangles().len() * 3).map_err(|_| ViewError::SceneTooBig)?;
            meshes.push(MeshRange {
                first_index,
                index_count,
                base_vertex,
            });
        }
        let limit = device.limits().max_buffer_size;
        if positions.len() as u64 > limit || indices.len() as u64 > limit {
            return Err(ViewError::SceneTooBig);
        }
        // wgpu refuses empty buffers: an empty scene still gets 4 bytes.
        positions.resize(positions.len().max(4), 0);
        indices.resize(indices.len().max(4), 0);
        let vertices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("hom-view vertices"),
            contents: &positions,
            usage: wgpu::BufferUsages::VERTEX,
        });
        let index_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("hom-view indices"),
            contents: &indices,
            usage: wgpu::BufferUsages::INDEX,
        });
        let frame = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("hom-view frame"),
            size: FRAME_BYTES,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let buffer = |binding, ty| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
            ty: wgpu::BindingType::Buffer {
                ty,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let storage = wgpu::BufferBindingType::Storage { read_only: true };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hom-view scene"),
            entries: &[
                buffer(0, wgpu::BufferBindingType::Uniform),
                buffer(1, storage),
                buffer(2, storage),
            ],
        });
        let capacity = scene.objects().len().max(1);
        let (objects, roles) = object_buffers(device, capacity);
        let bind_group = bind_group(device, &layout, &frame, &objects, &roles);
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("hom-view scene"),
            source: wgpu::ShaderSource::Wgsl(include_str!("shaders/scene.wgsl").into()),
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("hom-view scene"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = |pass: Pass| pipeline(device, &pipeline_layout, &shader, pass, colour_format);
        Ok(SceneGpu {
            vertices,
            indices: index_buffer,
            meshes,
            frame,
            objects,
            roles,
            bind_group,
            layout,
            capacity,
            written: None,
            colour: pipeline(Pass::Colour),
            ghost: pipeline(Pass::Ghost),
            item: pipeline(Pass::Item),
            role_bytes: Vec::new(),
        })
    }

    /// Writes this frame's camera and overlay switch, the objects' records
    /// where the scene changed since the last frame, and, with the overlay,
    /// which objects are this frame's `occluders` (ascending ids).
    pub(crate) fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &Scene,
        camera: &Camera,
        occluders: Option<&[u32]>,
    ) {
        let mut frame = Vec::with_capacity(FRAME_BYTES as usize);
        push_mat4(&mut frame, &camera.view_proj());
        push_f32s(&mut frame, &camera.eye.extend(1.0).to_array());
        for flag in [u32::from(occluders.is_some()), 0, 0, 0] {
            frame.extend(flag.to_le_bytes());
        }
        queue.write_buffer(&self.frame, 0, &frame);

        let count = scene.objects().len();
        if count > self.capacity {
            self.capacity = count.next_power_of_two();
            (self.objects, self.roles) = object_buffers(device, self.capacity);
            self.bind_group = bind_group(device, &self.layout, &self.frame, &self.objects, &self.roles);
            self.written = None;
        }
        if self.written != Some(scene.revision()) {
            let mut records = Vec::with_capacity(count * OBJECT_BYTES as usize);
            for (id, o) in scene.objects().iter().enumerate() {
                push_mat4(&mut records, &o.transform);
                let [r, g, b] = hom_render::id_colour(id as u32).map(|c| c as f32 / 255.0);
                push_f32s(&mut records, &[r, g, b, 1.0]);
            }
            if !records.is_empty() {
                queue.write_buffer(&self.objects, 0, &records);
            }
            self.written = Some(scene.revision());
        }
        if let Some(occluders) = occluders {
            self.role_bytes.clear();
            self.role_bytes.resize(count.max(1) * 4, 0);
            for &id in occluders {
                if let Some(role) = self.role_bytes.get_mut(id as usize * 4) {
                    *role = 1;
                }
            }
            queue.write_buffer(&self.roles, 0, &self.role_bytes);
        }
    }

    /// Draws objects `ids` (removed ones draw nothing): the item pass in
    /// that order (on equal depth the first drawn keeps the pixel, as in the
    /// oracle), the colour pass nearest box first from `eye`, as an engine
    /// sorts its opaque draws (the depth test then spares the fragment
    /// shading of what lies behind).
    pub(crate) fn draw(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        kind: Pass,
        scene: &Scene,
        ids: &[u32],
        eye: glam::Vec3,
    ) {
        let objects = scene.objects();
        let sorted: Vec<u32>;
        let ids = if kind == Pass::Colour {
            let mut by_distance: Vec<(f32, u32)> = ids
                .iter()
                .filter_map(|&id| Some((objects.get(id as usize)?.aabb.distance_squared(eye), id)))
                .collect();
            by_distance.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            sorted = by_distance.into_iter().map(|(_, id)| id).collect();
            &sorted
        } else {
            ids
        };
        let pipeline = match kind {
            Pass::Colour => &self.colour,
            Pass::Ghost => &self.ghost,
            Pass::Item => &self.item,
        };
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.set_vertex_buffer(0, self.vertices.slice(..));
        pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
        for &id in ids {
            let Some(o) = objects.get(id as usize).filter(|o| !o.is_removed()) else {
                continue;
            };
            let Some(m) = self.meshes.get(o.mesh as usize) else {
                continue;
            };
            pass.draw_indexed(m.first_index..m.first_index + m.index_count, m.base_vertex, id..id + 1);
        }
    }
}

fn object_buffers(device: &wgpu::Device, capacity: usize) -> (wgpu::Buffer, wgpu::Buffer) {
    let buffer = |label, size| {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    };
    (
        buffer("hom-view objects", capacity as u64 * OBJECT_BYTES),
        buffer("hom-view roles", capacity as u64 * 4),
    )
}

fn bind_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    frame: &wgpu::Buffer,
    objects: &wgpu::Buffer,
    roles: &wgpu::Buffer,
) -> wgpu::BindGroup {
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("hom-view scene"),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: frame.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: objects.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: roles.as_entire_binding(),
            },
        ],
    })
}

fn pipeline(
    device: &wgpu::Device,
    layout: &wgpu::PipelineLayout,
    shader: &wgpu::ShaderModule,
    pass: Pass,
    colour_format: wgpu::TextureFormat,
) -> wgpu::RenderPipeline {
    let (entry, format, blend) = match pass {
        Pass::Colour => ("fs_colour", colour_format, None),
        Pass::Ghost => ("fs_ghost", colour_format, Some(wgpu::BlendState::ALPHA_BLENDING)),
        Pass::Item => ("fs_item", ITEM_FORMAT, None),
    };
    let ghost = pass == Pass::Ghost;
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(entry),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module: shader,
            entry_point: Some("vs"),
            compilation_options: Default::default(),
            buffers: &[wgpu::VertexBufferLayout {
                array_stride: 12,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &[wgpu::VertexAttribute {
                    format: wgpu::VertexFormat::Float32x3,
                    offset: 0,
                    shader_location: 0,
                }],
            }],
        },
        // Two-sided, as hom's renderer, oracle and cullers.
        primitive: wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleList,
            cull_mode: None,
            ..Default::default()
        },
        depth_stencil: Some(wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(!ghost),
            depth_compare: Some(if ghost {
                wgpu::CompareFunction::Always
            } else {
                wgpu::CompareFunction::Less
            }),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: shader,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState {
                format,
                blend,
                write_mask: wgpu::ColorWrites::ALL,
            })],
        }),
        multiview_mask: None,
        cache: None,
    })
}

fn push_f32s(out: &mut Vec<u8>, values: &[f32]) {
    out.extend(values.iter().flat_map(|v| v.to_le_bytes()));
}

fn push_mat4(out: &mut Vec<u8>, m: &Mat4) {
    push_f32s(out, &m.to_cols_array());
}
