//! glTF 2.0 loading (`.gltf` with external `.bin` buffers or `data:` URIs, and `.glb`).
//!
//! One object per node that has a mesh, in the order of a depth-first walk of the
//! default scene's node tree (or of every scene, in order, when there is no default; or
//! of every root node when the file has no scenes at all).
//! The object's transform is the node's world matrix (parent transforms accumulated);
//! nodes instancing the same glTF mesh share one hom mesh. All primitives of a mesh with
//! mode `TRIANGLES` are merged into that mesh; other modes are skipped, and a mesh with no
//! triangles places no object. An object is named after its node, else its mesh, else
//! `node N`. glTF is already right-handed, +Y up, in metres, so no conversion is needed.
//!
//! A node whose mesh spans the level in world space ([`crate::split::spans_level`]:
//! longer than [`SplitOptions::whole_extent`], 16 m by default) becomes the
//! mesh's clusters instead, objects `NAME_0`, `NAME_1`… in the splitter's order,
//! each with the node's transform; the cut is made once per mesh, in the mesh's
//! own space with the size limit divided by that node's largest axis scale, and
//! its pieces are shared by every node that instances the mesh and spans the level
//! ([`GltfOptions::split`]; off keeps every node one object).
//!
//! Accessors are read here with checked arithmetic rather than with the `gltf` crate's
//! reader, and a `.glb` header is checked before the crate sees it, so hostile files
//! (out-of-range offsets or counts, truncated chunks) give typed errors, never a panic or
//! an allocation larger than the data in the file.

use crate::split::{spans_level, split_mesh, SplitOptions};
use crate::LoadError;
use ::gltf::accessor::{sparse::IndexType, DataType, Dimensions};
use ::gltf::buffer::View;
use ::gltf::mesh::Mode;
use ::gltf::{Accessor, Document, Gltf, Semantic};
use glam::{Mat4, Vec3};
use hom::scene::{Mesh, MeshId, Scene, SceneBuilder, SceneError};
use std::path::Path;

/// Loads a `.gltf` or `.glb` file: one object per node with a mesh, world transforms applied.
///
/// The scene is named after the file stem. Buffers named by relative URIs are read from
/// the file's directory.
pub fn load(path: &Path) -> Result<Scene, LoadError> {
    load_with(path, &GltfOptions::default())
}

/// How to load a glTF file.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GltfOptions {
    /// How a mesh that spans the level is cut into objects (on by default).
    pub split: SplitOptions,
}

/// [`load`] with options.
pub fn load_with(path: &Path, options: &GltfOptions) -> Result<Scene, LoadError> {
    let bytes = std::fs::read(path).map_err(|source| LoadError::Io {
        path: path.display().to_string(),
        source,
    })?;
    let label = path.display().to_string();
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let base = path.parent().unwrap_or(Path::new("."));
    let base = if base.as_os_str().is_empty() {
        Path::new(".")
    } else {
        base
    };
    let malformed = |message: String| LoadError::Malformed {
        path: label.clone(),
        line: None,
        message,
    };

    check_glb_header(&bytes).map_err(&malformed)?;
    check_json(&bytes).map_err(&malformed)?;
    let gltf = Gltf::from_slice(&bytes).map_err(|e| match e {
        // Already says "invalid glTF: path: problem; …".
        ::gltf::Error::Validation(_) => malformed(e.to_string()),
        _ => malformed(format!("invalid glTF: {e}")),
    })?;
    drop(bytes);
    let Gltf { document, blob } = gltf;
    let buffers = ::gltf::import_buffers(&document, Some(base), blob)
        .map_err(|e| malformed(format!("cannot load buffer data: {e}")))?;
    let buffers: Vec<&[u8]> = buffers.iter().map(|d| &d.0[..]).collect();
    convert(&document, &buffers, &label, &stem, &options.split)
}

/// Rejects a `.glb` whose header the `gltf` crate would mishandle (a declared length
/// shorter than the header itself, or longer than the file).
fn check_glb_header(bytes: &[u8]) -> Result<(), String> {
    if !bytes.starts_with(b"glTF") {
        return Ok(());
    }
    let Some(length) = bytes.get(8..12) else {
        return Err("truncated GLB header".to_owned());
    };
    let length = u32::from_le_bytes([length[0], length[1], length[2], length[3]]) as u64;
    if length < 20 || length > bytes.len() as u64 {
        return Err(format!(
            "GLB header declares {length} bytes, but the file has {} (truncated or corrupt)",
            bytes.len()
        ));
    }
    Ok(())
}

/// Rejects the JSON the `gltf` crate would panic on (both found by the mutation test).
fn check_json(bytes: &[u8]) -> Result<(), String> {
    let glb;
    let json: &[u8] = if bytes.starts_with(b"glTF") {
        glb = ::gltf::Glb::from_slice(bytes).map_err(|e| format!("invalid GLB: {e}"))?;
        &glb.json
    } else {
        bytes
    };
    let root: serde_json::Value = serde_json::from_slice(json).map_err(|e| format!("invalid glTF JSON: {e}"))?;
    check_position_accessors(&root)?;
    check_buffer_uris(&root)
}

/// gltf 1.4 percent-decodes a buffer URI without a scheme (a relative path) and
/// unwraps the result as UTF-8, so it panics on an escape such as `%e6` that
/// decodes to no text; such a URI is refused here first, by the same decoding.
fn check_buffer_uris(root: &serde_json::Value) -> Result<(), String> {
    let buffers = root.get("buffers").and_then(|b| b.as_array()).into_iter().flatten();
    for (b, buffer) in buffers.enumerate() {
        let Some(uri) = buffer.get("uri").and_then(|u| u.as_str()) else {
            continue;
        };
        if !uri.contains(':') && urlencoding::decode(uri).is_err() {
            return Err(format!(
                "buffers[{b}]: URI {uri:?} percent-decodes to bytes that are not UTF-8"
            ));
        }
    }
    Ok(())
}

/// gltf-json 1.4's validator indexes `accessors[POSITION]` without a bounds
/// check and panics on a file whose POSITION names a missing accessor, so
/// those indices are checked here first.
fn check_position_accessors(root: &serde_json::Value) -> Result<(), String> {
    let accessors = root.get("accessors").and_then(|a| a.as_array()).map_or(0, |a| a.len());
    let meshes = root.get("meshes").and_then(|m| m.as_array()).into_iter().flatten();
    for (m, mesh) in meshes.enumerate() {
        let primitives = mesh.get("primitives").and_then(|p| p.as_array()).into_iter().flatten();
        for (p, primitive) in primitives.enumerate() {
            let position = primitive.get("attributes").and_then(|a| a.get("POSITION"));
            if let Some(index) = position.and_then(|i| i.as_u64()) {
                if index >= accessors as u64 {
                    return Err(format!(
                        "meshes[{m}].primitives[{p}]: POSITION accessor {index} does not exist ({accessors} accessors)"
                    ));
                }
            }
        }
    }
    Ok(())
}

/// Builds the scene from a parsed document and its loaded buffers.
fn convert(
    document: &Document,
    buffers: &[&[u8]],
    label: &str,
    stem: &str,
    split: &SplitOptions,
) -> Result<Scene, LoadError> {
    let scene_error = |source| LoadError::Scene {
        path: label.to_owned(),
        source,
    };
    let malformed = |message: String| LoadError::Malformed {
        path: label.to_owned(),
        line: None,
        message,
    };
    // No accessor may yield more elements than there are bytes of buffer data, so an
    // accessor without a buffer view cannot make us allocate from its count alone.
    let max_count = buffers.iter().map(|b| b.len()).sum::<usize>();

    let mut builder = SceneBuilder::new(stem);
    // Per glTF mesh: None = not converted yet, Some(None) = no triangles.
    let mut meshes: Vec<Option<Option<Converted>>> = (0..document.meshes().len()).map(|_| None).collect();
    let roots: Vec<Vec<usize>> = match document.default_scene() {
        Some(scene) => vec![scene.nodes().map(|n| n.index()).collect()],
        None if document.scenes().len() > 0 => document
            .scenes()
            .map(|s| s.nodes().map(|n| n.index()).collect())
            .collect(),
        None => {
            // No scenes at all: every node that is nobody's child is a root.
            let mut is_child = vec![false; document.nodes().len()];
            for child in document.nodes().flat_map(|n| n.children()) {
                is_child[child.index()] = true;
            }
            vec![(0..is_child.len()).filter(|&i| !is_child[i]).collect()]
        }
    };
    let nodes: Vec<::gltf::Node> = document.nodes().collect();

    for scene_roots in roots {
        let mut visited = vec![false; nodes.len()];
        // Depth-first, in document order, without recursion (deep trees cannot overflow).
        let mut stack: Vec<(usize, Mat4)> = scene_roots.iter().rev().map(|&n| (n, Mat4::IDENTITY)).collect();
        while let Some((index, parent)) = stack.pop() {
            let Some(node) = nodes.get(index) else {
                return Err(malformed(format!("node {index} does not exist")));
            };
            if std::mem::replace(&mut visited[index], true) {
                return Err(malformed(format!(
                    "node {index} appears more than once in the node hierarchy (a cycle, or a node with two parents)"
                )));
            }
            let local = Mat4::from_cols_array_2d(&node.transform().matrix());
            let world = parent * local;
            if let Some(mesh) = node.mesh() {
                let slot = &mut meshes[mesh.index()];
                if slot.is_none() {
                    let converted = match convert_mesh(&mesh, buffers, max_count)
                        .map_err(|m| malformed(format!("mesh {}: {m}", mesh.index())))?
                    {
                        Some((positions, triangles)) => {
                            let name = mesh
                                .name()
                                .map(str::to_owned)
                                .unwrap_or_else(|| format!("mesh {}", mesh.index()));
                            let mesh = Mesh::new(name, positions, triangles).map_err(scene_error)?;
                            Some(Converted {
                                mesh,
                                whole: None,
                                pieces: None,
                            })
                        }
                        None => None,
                    };
                    *slot = Some(converted);
                }
                if let Some(Some(c)) = slot {
                    let name = node
                        .name()
                        .or(mesh.name())
                        .map(str::to_owned)
                        .unwrap_or_else(|| format!("node {index}"));
                    let world_box = c.mesh.bounds().transformed(&world);
                    if spans_level(&world_box, c.mesh.triangle_count(), split) {
                        if c.pieces.is_none() {
                            let scale = world.to_scale_rotation_translation().0.abs().max_element();
                            let local = SplitOptions {
                                max_extent: split.max_extent / scale.max(f32::MIN_POSITIVE),
                                ..split.clone()
                            };
                            let parts = split_mesh(&c.mesh, &local).map_err(scene_error)?;
                            c.pieces = Some(parts.into_iter().map(|m| builder.add_mesh(m)).collect());
                        }
                        let clusters = c.pieces.iter().flatten().enumerate();
                        let clusters: Vec<_> = clusters.map(|(k, &piece)| (format!("{name}_{k}"), piece)).collect();
                        builder.add_clusters(name, clusters, world).map_err(scene_error)?;
                    } else {
                        let id = *c.whole.get_or_insert_with(|| builder.add_mesh(c.mesh.clone()));
                        builder.add_object(name, id, world).map_err(scene_error)?;
                    }
                }
            }
            for child in node.children().collect::<Vec<_>>().into_iter().rev() {
                stack.push((child.index(), world));
            }
        }
    }
    if builder.object_count() == 0 {
        return Err(scene_error(SceneError::EmptyScene { scene: stem.to_owned() }));
    }
    builder.build().map_err(scene_error)
}

/// A glTF mesh converted, and the hom meshes made of it as its nodes need them.
struct Converted {
    mesh: Mesh,
    /// The whole mesh, added when a node that does not span the level instances it.
    whole: Option<MeshId>,
    /// Its clusters, cut when a node that spans the level first instances it.
    pieces: Option<Vec<MeshId>>,
}

/// Positions and triangles of a mesh's triangle primitives; `None` when it has none.
#[allow(clippy::type_complexity)]
fn convert_mesh(
    mesh: &::gltf::Mesh,
    buffers: &[&[u8]],
    max_count: usize,
) -> Result<Option<(Vec<Vec3>, Vec<[u32; 3]>)>, String> {
    let mut positions: Vec<Vec3> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    for primitive in mesh.primitives() {
        let p = primitive.index();
        if primitive.mode() != Mode::Triangles {
            continue;
        }
        let Some(accessor) = primitive.get(&Semantic::Positions) else {
            continue;
        };
        if accessor.data_type() != DataType::F32 || accessor.dimensions() != Dimensions::Vec3 || accessor.normalized() {
            return Err(format!(
                "primitive {p}: POSITION accessor {} must be VEC3 of FLOAT",
                accessor.index()
            ));
        }
        let prim_positions = read_accessor(&accessor, buffers, max_count, |b| {
            Vec3::new(
                f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
                f32::from_le_bytes([b[4], b[5], b[6], b[7]]),
                f32::from_le_bytes([b[8], b[9], b[10], b[11]]),
            )
        })
        .map_err(|m| format!("primitive {p}: POSITION accessor {}: {m}", accessor.index()))?;
        let n = prim_positions.len();
        let indices: Vec<u32> = match primitive.indices() {
            Some(acc) => {
                let decode: fn(&[u8]) -> u32 = match (acc.data_type(), acc.dimensions()) {
                    (DataType::U8, Dimensions::Scalar) => |b| u32::from(b[0]),
                    (DataType::U16, Dimensions::Scalar) => |b| u32::from(u16::from_le_bytes([b[0], b[1]])),
                    (DataType::U32, Dimensions::Scalar) => |b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
                    _ => {
                        return Err(format!(
                            "primitive {p}: index accessor {} must be SCALAR of unsigned integers",
                            acc.index()
                        ))
                    }
                };
                let indices = read_accessor(&acc, buffers, max_count, decode)
                    .map_err(|m| format!("primitive {p}: index accessor {}: {m}", acc.index()))?;
                if let Some((k, &i)) = indices.iter().enumerate().find(|(_, &i)| i as usize >= n) {
                    return Err(format!(
                        "primitive {p}: index {k} has value {i}, but POSITION has only {n} vertices"
                    ));
                }
                indices
            }
            None => {
                if n > u32::MAX as usize {
                    return Err(format!("primitive {p}: too many vertices ({n})"));
                }
                (0..n as u32).collect()
            }
        };
        let base = positions.len();
        if base + n > u32::MAX as usize {
            return Err(format!("too many vertices ({})", base + n));
        }
        let base = base as u32;
        triangles.extend(indices.chunks_exact(3).map(|t| [t[0] + base, t[1] + base, t[2] + base]));
        positions.extend(prim_positions);
    }
    Ok(if triangles.is_empty() {
        None
    } else {
        Some((positions, triangles))
    })
}

/// The bytes of a buffer view, checked against its buffer.
fn view_bytes<'b>(view: &View, buffers: &[&'b [u8]]) -> Result<&'b [u8], String> {
    let buffer = buffers
        .get(view.buffer().index())
        .ok_or_else(|| format!("buffer {} does not exist", view.buffer().index()))?;
    let start = view.offset();
    view.offset()
        .checked_add(view.length())
        .and_then(|end| buffer.get(start..end))
        .ok_or_else(|| {
            format!(
                "buffer view {} (offset {}, length {}) runs past the end of buffer {} ({} bytes)",
                view.index(),
                view.offset(),
                view.length(),
                view.buffer().index(),
                buffer.len()
            )
        })
}

/// `count` elements of `size` bytes, `stride` apart, starting at `offset` in `data`.
fn elements<'b>(
    data: &'b [u8],
    offset: usize,
    count: usize,
    size: usize,
    stride: usize,
) -> Result<impl Iterator<Item = &'b [u8]> + 'b, String> {
    if count > 0 {
        let end = (count - 1)
            .checked_mul(stride)
            .and_then(|x| x.checked_add(offset))
            .and_then(|x| x.checked_add(size));
        if end.is_none_or(|end| end > data.len()) {
            return Err(format!(
                "{count} elements of {size} bytes (stride {stride}) from offset {offset} do not fit in {} bytes",
                data.len()
            ));
        }
    }
    Ok((0..count).map(move |i| &data[offset + i * stride..offset + i * stride + size]))
}

/// Reads every element of an accessor (sparse substitution included) with `decode`,
/// which gets exactly `accessor.size()` bytes.
fn read_accessor<T: Copy + Default>(
    accessor: &Accessor,
    buffers: &[&[u8]],
    max_count: usize,
    decode: impl Fn(&[u8]) -> T,
) -> Result<Vec<T>, String> {
    let count = accessor.count();
    if count > max_count {
        return Err(format!(
            "count {count} is larger than all buffer data together ({max_count} bytes)"
        ));
    }
    let size = accessor.size();
    let mut out: Vec<T> = match accessor.view() {
        Some(view) => {
            let stride = view.stride().unwrap_or(size);
            if stride < size {
                return Err(format!(
                    "buffer view {} stride {stride} is smaller than an element ({size} bytes)",
                    view.index()
                ));
            }
            let data = view_bytes(&view, buffers)?;
            elements(data, accessor.offset(), count, size, stride)?
                .map(&decode)
                .collect()
        }
        None => vec![T::default(); count],
    };
    if let Some(sparse) = accessor.sparse() {
        let n = sparse.count();
        if n > count {
            return Err(format!("sparse count {n} is larger than the accessor count {count}"));
        }
        let indices = sparse.indices();
        let (index_size, index_decode): (usize, fn(&[u8]) -> usize) = match indices.index_type() {
            IndexType::U8 => (1, |b| b[0] as usize),
            IndexType::U16 => (2, |b| u16::from_le_bytes([b[0], b[1]]) as usize),
            IndexType::U32 => (4, |b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize),
        };
        let index_data = view_bytes(&indices.view(), buffers)?;
        let values = sparse.values();
        let value_data = view_bytes(&values.view(), buffers)?;
        let targets = elements(index_data, indices.offset(), n, index_size, index_size)?;
        let values = elements(value_data, values.offset(), n, size, size)?;
        for (target, value) in targets.zip(values) {
            let target = index_decode(target);
            let slot = out
                .get_mut(target)
                .ok_or_else(|| format!("sparse index {target} is out of range (count {count})"))?;
            *slot = decode(value);
        }
    }
    Ok(out)
}
