//! Wavefront OBJ loading.
//!
//! One object per `o` statement; when the file has no `o` statements, one object per
//! `g` statement (so `g` groups inside `o` objects do not split them). Faces before the
//! first group form an object named after the file stem. Groups without faces are
//! skipped. Every object gets the identity transform and its own mesh holding the
//! positions it uses, exactly as written in the file (after the optional `w` divide).
//!
//! Only positions matter: texture coordinates, normals, vertex colours, materials,
//! smoothing groups, lines (`l`) and points (`p`) are ignored. Faces with more than three
//! vertices are fan-triangulated; faces with one or two vertices are ignored.
//!
//! A file that yields a single object with more triangles than
//! [`SplitOptions::max_triangles`] is split into spatially coherent objects by
//! [`crate::split::split_mesh`] (on by default; [`ObjOptions::split`] turns it off):
//! objects `NAME_0`, `NAME_1`… in the splitter's documented order. In a file
//! with several objects, an object that spans the level
//! ([`crate::split::spans_level`]: longer than
//! [`SplitOptions::whole_extent`], 16 m by default) is split the same way, in
//! its place; the others stay whole.
//!
//! The text is first checked line by line, so every syntax or range error names its
//! 1-based line: malformed numbers, NaN or infinite coordinates, face indices (absolute or
//! negative relative) outside the vertices declared so far, index 0. The validated,
//! normalised geometry is then triangulated by the `tobj` crate. Hostile input (binary
//! garbage, non-UTF-8 text, gigantic index values) gives an error, never a panic, and
//! memory stays proportional to the file size.

use crate::split::{spans_level, split_mesh, SplitOptions};
use crate::LoadError;
use glam::{Mat4, Vec3};
use hom::scene::{Mesh, Scene, SceneBuilder, SceneError};
use std::fmt::Write as _;
use std::path::Path;

/// Loads an OBJ file: one object per `o` group (or per `g` group when there is no `o`).
///
/// The scene is named after the file stem. Errors name the file and, for syntax and
/// range errors, the 1-based line.
pub fn load(path: &Path) -> Result<Scene, LoadError> {
    load_with(path, &ObjOptions::default())
}

/// How to load an OBJ file.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ObjOptions {
    /// How a file that yields a single object is split (on by default).
    pub split: SplitOptions,
}

/// [`load`] with options.
pub fn load_with(path: &Path, options: &ObjOptions) -> Result<Scene, LoadError> {
    let bytes = std::fs::read(path).map_err(|source| LoadError::Io {
        path: path.display().to_string(),
        source,
    })?;
    parse_with(&bytes, path, options)
}

/// Parses OBJ text already in memory, exactly as [`load`] would parse the file at `path`.
///
/// `path` is used only to name the scene (its stem) and in error messages; nothing is read
/// from it.
pub fn parse(bytes: &[u8], path: &Path) -> Result<Scene, LoadError> {
    parse_with(bytes, path, &ObjOptions::default())
}

/// [`parse`] with options.
pub fn parse_with(bytes: &[u8], path: &Path, options: &ObjOptions) -> Result<Scene, LoadError> {
    let label = path.display().to_string();
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let parsed = scan(bytes, &label, &stem)?;
    build(parsed, &label, &stem, &options.split)
}

/// A group of faces that becomes one object.
struct Group {
    name: String,
    /// Polygon vertex indices (0-based, absolute), all polygons concatenated.
    indices: Vec<u32>,
    /// Vertex count of each polygon (each at least 3).
    arities: Vec<u32>,
}

/// The validated content of an OBJ file.
struct Parsed {
    positions: Vec<Vec3>,
    groups: Vec<Group>,
}

fn malformed(label: &str, line: usize, message: impl Into<String>) -> LoadError {
    LoadError::Malformed {
        path: label.to_owned(),
        line: Some(line),
        message: message.into(),
    }
}

/// Tokens of a line, split on ASCII whitespace.
fn tokens(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(|b| b.is_ascii_whitespace()).filter(|t| !t.is_empty())
}

/// A token for an error message (shortened, lossy UTF-8).
fn show(token: &[u8]) -> String {
    const MAX: usize = 40;
    let s = String::from_utf8_lossy(&token[..token.len().min(MAX)]).into_owned();
    if token.len() > MAX {
        format!("{s}…")
    } else {
        s
    }
}

fn parse_f32(token: &[u8]) -> Option<f32> {
    std::str::from_utf8(token).ok()?.parse::<f32>().ok()
}

/// The text after the keyword, trimmed, as a (lossy) UTF-8 name.
fn rest_name(line: &[u8], keyword_len: usize) -> String {
    let start = line.iter().position(|b| !b.is_ascii_whitespace()).unwrap_or(line.len());
    let rest = &line[(start + keyword_len).min(line.len())..];
    String::from_utf8_lossy(rest).trim().to_owned()
}

/// Resolves one OBJ index (1-based, or negative relative) against `count` declared items.
fn resolve(token: &[u8], count: usize, what: &str, label: &str, line: usize) -> Result<u32, LoadError> {
    let value = std::str::from_utf8(token)
        .ok()
        .and_then(|s| s.parse::<i64>().ok())
        .ok_or_else(|| malformed(label, line, format!("malformed {what} index '{}'", show(token))))?;
    let resolved = match value {
        0 => {
            return Err(malformed(
                label,
                line,
                format!("{what} index 0 is invalid (OBJ indices start at 1)"),
            ))
        }
        v if v > 0 => (v - 1) as u64,
        v => match (count as i64).checked_add(v) {
            Some(r) if r >= 0 => r as u64,
            _ => u64::MAX,
        },
    };
    if resolved >= count as u64 {
        return Err(malformed(
            label,
            line,
            format!(
                "face refers to {what} {value}, but only {count} {} are declared before this line",
                match what {
                    "vertex" => "vertices",
                    "normal" => "normals",
                    _ => "texture coordinates",
                }
            ),
        ));
    }
    Ok(resolved as u32)
}

/// Checks every line and collects positions and groups.
fn scan(bytes: &[u8], label: &str, stem: &str) -> Result<Parsed, LoadError> {
    let lines = || {
        bytes.split(|&b| b == b'\n').map(|l| {
            // Strip a comment and a trailing carriage return.
            let l = match l.iter().position(|&b| b == b'#') {
                Some(i) => &l[..i],
                None => l,
            };
            l.strip_suffix(b"\r").unwrap_or(l)
        })
    };
    // One object per `o` when the file has any, else one per `g`.
    let has_o = lines().any(|l| tokens(l).next() == Some(b"o"));
    let group_keyword: &[u8] = if has_o { b"o" } else { b"g" };

    let default_name = if stem.is_empty() { "object" } else { stem };
    let mut positions: Vec<Vec3> = Vec::new();
    let mut texcoords = 0usize;
    let mut normals = 0usize;
    let mut groups = vec![Group {
        name: default_name.to_owned(),
        indices: Vec::new(),
        arities: Vec::new(),
    }];
    let mut face: Vec<u32> = Vec::new();

    for (i, line) in lines().enumerate() {
        let n = i + 1;
        if line.contains(&0) {
            return Err(malformed(label, n, "contains a NUL byte; this is not an OBJ text file"));
        }
        let mut words = tokens(line);
        let Some(keyword) = words.next() else {
            continue;
        };
        match keyword {
            b"v" => {
                let mut xyz = [0.0f32; 3];
                for c in xyz.iter_mut() {
                    let Some(t) = words.next() else {
                        return Err(malformed(label, n, "vertex needs 3 coordinates"));
                    };
                    let v =
                        parse_f32(t).ok_or_else(|| malformed(label, n, format!("malformed number '{}'", show(t))))?;
                    if !v.is_finite() {
                        return Err(malformed(
                            label,
                            n,
                            format!("vertex has non-finite coordinate {}", show(t)),
                        ));
                    }
                    *c = v;
                }
                let extra: Vec<&[u8]> = words.take(5).collect();
                if extra.len() > 4 {
                    return Err(malformed(label, n, "vertex has too many values"));
                }
                let mut extra_values = [0.0f32; 4];
                for (slot, t) in extra_values.iter_mut().zip(&extra) {
                    *slot =
                        parse_f32(t).ok_or_else(|| malformed(label, n, format!("malformed number '{}'", show(t))))?;
                }
                let mut p = Vec3::from(xyz);
                if extra.len() == 1 {
                    // x y z w: homogeneous weight.
                    let w = extra_values[0];
                    if !w.is_finite() || w == 0.0 {
                        return Err(malformed(
                            label,
                            n,
                            format!("vertex weight w = {} must be finite and non-zero", show(extra[0])),
                        ));
                    }
                    // The same f32 divide tobj would do.
                    p = Vec3::new(p.x / w, p.y / w, p.z / w);
                    if !p.is_finite() {
                        return Err(malformed(
                            label,
                            n,
                            "vertex has non-finite coordinate after dividing by w",
                        ));
                    }
                }
                // 2 to 4 extra values are colours (and w); positions ignore them.
                if positions.len() >= u32::MAX as usize {
                    return Err(malformed(label, n, "too many vertices"));
                }
                positions.push(p);
            }
            b"vt" => texcoords += 1,
            b"vn" => normals += 1,
            b"f" => {
                face.clear();
                for t in words {
                    let mut parts = t.split(|&b| b == b'/');
                    let v = parts.next().unwrap_or_default();
                    if v.is_empty() {
                        return Err(malformed(
                            label,
                            n,
                            format!("face vertex '{}' has no position index", show(t)),
                        ));
                    }
                    face.push(resolve(v, positions.len(), "vertex", label, n)?);
                    if let Some(vt) = parts.next().filter(|p| !p.is_empty()) {
                        resolve(vt, texcoords, "texture coordinate", label, n)?;
                    }
                    if let Some(vn) = parts.next().filter(|p| !p.is_empty()) {
                        resolve(vn, normals, "normal", label, n)?;
                    }
                    if parts.next().is_some() {
                        return Err(malformed(
                            label,
                            n,
                            format!("face vertex '{}' has more than 3 indices", show(t)),
                        ));
                    }
                }
                if face.is_empty() {
                    return Err(malformed(label, n, "face has no vertices"));
                }
                if face.len() >= 3 {
                    let group = groups.last_mut().expect("there is always a group");
                    group.indices.extend_from_slice(&face);
                    group.arities.push(face.len() as u32);
                }
            }
            k if k == group_keyword => groups.push(Group {
                name: rest_name(line, k.len()),
                indices: Vec::new(),
                arities: Vec::new(),
            }),
            // Everything else (vp, l, p, s, usemtl, mtllib, the other keyword of o/g, …)
            // does not change the geometry.
            _ => {}
        }
    }
    groups.retain(|g| !g.arities.is_empty());
    Ok(Parsed { positions, groups })
}

/// Triangulates the validated groups with tobj and builds the scene.
fn build(parsed: Parsed, label: &str, stem: &str, split: &SplitOptions) -> Result<Scene, LoadError> {
    let scene_error = |source| LoadError::Scene {
        path: label.to_owned(),
        source,
    };
    let mut builder = SceneBuilder::new(stem);
    if parsed.groups.is_empty() {
        return Err(scene_error(SceneError::EmptyScene { scene: stem.to_owned() }));
    }

    // A normalised OBJ: absolute indices, positions only, one `o` per group, so tobj's
    // models map one-to-one onto our groups (tobj treats `o` and `g` alike, splits models
    // at `usemtl`, and treats `l` lines as faces — none of which reach it here).
    let mut text = String::new();
    for p in &parsed.positions {
        // `{}` of f32 is the shortest text that parses back to the same value.
        let _ = writeln!(text, "v {} {} {}", p.x, p.y, p.z);
    }
    for (k, g) in parsed.groups.iter().enumerate() {
        let _ = writeln!(text, "o g{k}");
        let mut rest = &g.indices[..];
        for &arity in &g.arities {
            let (polygon, tail) = rest.split_at(arity as usize);
            rest = tail;
            text.push('f');
            for i in polygon {
                let _ = write!(text, " {}", u64::from(*i) + 1);
            }
            text.push('\n');
        }
    }
    drop(parsed.positions);
    // The update keeps this compiling if tobj's optional features add fields.
    #[allow(clippy::needless_update)]
    let options = tobj::LoadOptions {
        single_index: false,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    };
    let (models, _materials) = tobj::load_obj_buf(&mut text.as_bytes(), &options, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|e| LoadError::Malformed {
        path: label.to_owned(),
        line: None,
        message: format!("OBJ triangulation failed: {e}"),
    })?;
    if models.len() != parsed.groups.len() {
        return Err(LoadError::Malformed {
            path: label.to_owned(),
            line: None,
            message: format!(
                "internal error: {} groups but tobj returned {} models",
                parsed.groups.len(),
                models.len()
            ),
        });
    }

    let single = parsed.groups.len() == 1;
    for (group, model) in parsed.groups.into_iter().zip(models) {
        let id = builder.parent_count();
        let name = if group.name.is_empty() {
            format!("object_{id}")
        } else {
            group.name
        };
        let positions: Vec<Vec3> = model
            .mesh
            .positions
            .chunks_exact(3)
            .map(|c| Vec3::new(c[0], c[1], c[2]))
            .collect();
        let triangles: Vec<[u32; 3]> = model.mesh.indices.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        if triangles.is_empty() {
            continue;
        }
        let mesh = Mesh::new(name.clone(), positions, triangles).map_err(scene_error)?;
        let n = mesh.triangle_count();
        let parts = if (single && n > split.max_triangles) || spans_level(&mesh.bounds(), n, split) {
            split_mesh(&mesh, split).map_err(scene_error)?
        } else {
            vec![mesh]
        };
        let clusters: Vec<(String, u32)> = parts
            .into_iter()
            .map(|part| (part.name().to_owned(), builder.add_mesh(part)))
            .collect();
        builder
            .add_clusters(name, clusters, Mat4::IDENTITY)
            .map_err(scene_error)?;
    }
    builder.build().map_err(scene_error)
}
