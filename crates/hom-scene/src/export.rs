//! OBJ export of a scene's world-space triangles.
//!
//! Each object becomes one `o NAME` group, in id order, with its mesh's vertices
//! transformed by the object's current transform and written with the shortest text
//! that parses back to the same `f32`, so [`crate::obj::load`] gives back bit-identical
//! world-space positions (on identity-transformed objects).
//!
//! Names are sanitised so they survive the trip: whitespace, control characters and `#`
//! (which starts an OBJ comment) become `_`; an empty name becomes `object_ID`.

use crate::LoadError;
use hom::scene::Scene;
use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};

/// Writes the scene's world-space triangles as an OBJ file at `path`.
///
/// The file is written to a temporary file in the same directory and renamed over `path`
/// only once complete, so a failure never leaves a half-written file in place of an
/// existing one.
pub fn write_obj(scene: &Scene, path: &Path) -> Result<(), LoadError> {
    let io_error = |source| LoadError::Io {
        path: path.display().to_string(),
        source,
    };
    let (tmp_path, file) = create_temp_beside(path).map_err(io_error)?;
    let result = (|| {
        let mut writer = BufWriter::new(file);
        write_obj_to(scene, &mut writer)?;
        let file = writer.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        drop(file);
        fs::rename(&tmp_path, path)
    })();
    if let Err(e) = result {
        let _ = fs::remove_file(&tmp_path);
        return Err(io_error(e));
    }
    Ok(())
}

/// Writes the scene's world-space triangles as OBJ text to `writer`.
///
/// One `o NAME` per object in id order, then its vertices (`v x y z`, world space) and
/// triangles (`f a b c`, 1-based, counting vertices from the start of the file). Fails
/// with [`io::ErrorKind::InvalidData`] if a transformed vertex is not finite.
pub fn write_obj_to(scene: &Scene, mut writer: impl Write) -> io::Result<()> {
    writeln!(
        writer,
        "# {} — world-space triangles exported by hom-scene",
        sanitise(scene.name(), "scene")
    )?;
    let mut base: u64 = 1;
    for (id, object) in scene.objects().iter().enumerate() {
        let mesh = scene.mesh_of(object);
        writeln!(writer, "o {}", sanitise(&object.name, &format!("object_{id}")))?;
        for &p in mesh.positions() {
            let w = object.transform.transform_point3(p);
            if !w.is_finite() {
                return Err(io::Error::new(
                    io::ErrorKind::InvalidData,
                    format!(
                        "object {id} '{}': a vertex transforms to the non-finite point {w}",
                        object.name
                    ),
                ));
            }
            writeln!(writer, "v {} {} {}", w.x, w.y, w.z)?;
        }
        for t in mesh.triangles() {
            writeln!(
                writer,
                "f {} {} {}",
                base + u64::from(t[0]),
                base + u64::from(t[1]),
                base + u64::from(t[2])
            )?;
        }
        base += mesh.positions().len() as u64;
    }
    writer.flush()
}

/// `name` with whitespace, control characters and `#` replaced by `_`; `empty` if empty.
fn sanitise(name: &str, empty: &str) -> String {
    if name.is_empty() {
        return empty.to_owned();
    }
    name.chars()
        .map(|c| {
            if c.is_whitespace() || c.is_control() || c == '#' {
                '_'
            } else {
                c
            }
        })
        .collect()
}

/// Creates a new, uniquely named temporary file in `path`'s directory.
fn create_temp_beside(path: &Path) -> io::Result<(PathBuf, File)> {
    static COUNTER: AtomicU32 = AtomicU32::new(0);
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let file_name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene.obj".to_owned());
    let mut last_error = None;
    for _ in 0..100 {
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let tmp = dir.join(format!(".{file_name}.{}.{n}.tmp", std::process::id()));
        match OpenOptions::new().write(true).create_new(true).open(&tmp) {
            Ok(file) => return Ok((tmp, file)),
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists => last_error = Some(e),
            Err(e) => return Err(e),
        }
    }
    Err(last_error.unwrap_or_else(|| io::Error::other("cannot create a temporary file")))
}
