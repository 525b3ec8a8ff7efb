use hom::scene::SceneError;
use thiserror::Error;

/// Why a scene could not be loaded, generated or exported. Each variant names the file.
///
/// A variant with a `source` does not repeat it in its message: print the
/// chain (`{:#}` with anyhow) to see the cause.
#[derive(Debug, Error)]
pub enum LoadError {
    /// The file could not be opened, read or written.
    #[error("{path}")]
    Io {
        /// File.
        path: String,
        /// Cause.
        source: std::io::Error,
    },
    /// The extension names no supported format.
    #[error("{path}: unknown scene format; use .obj, .gltf, .glb, .bsp or .pk3 (FILE.pk3:MAP), an Extreme Tux Racer course.dim, or a built-in scene name (see `hom scenes`)")]
    UnknownFormat {
        /// File.
        path: String,
    },
    /// The file's syntax or structure is malformed.
    #[error("{path}{}: {message}", line.map(|l| format!(":{l}")).unwrap_or_default())]
    Malformed {
        /// File.
        path: String,
        /// 1-based line, where the format has lines and it is known.
        line: Option<usize>,
        /// What is wrong.
        message: String,
    },
    /// The geometry was parsed but is invalid (NaN vertex, index out of range, empty…).
    #[error("{path}")]
    Scene {
        /// File.
        path: String,
        /// Cause.
        source: SceneError,
    },
    /// A Quake 3 map (`.bsp`, or a map in a `.pk3`) is malformed or cannot be read.
    #[error("{path}")]
    Bsp {
        /// File (`FILE.pk3:maps/NAME.bsp` for a map inside a pk3).
        path: String,
        /// Cause.
        source: crate::bsp::BspError,
    },
    /// An Extreme Tux Racer course (its `course.dim`, `elev.png` or
    /// `trees.png`) is malformed or cannot be read.
    #[error("{path}")]
    Etr {
        /// The course's file with the problem.
        path: String,
        /// Cause.
        source: crate::etr::EtrError,
    },
    /// No built-in scene has this name.
    #[error("no built-in scene or file named '{name}'; built-in scenes: {known}")]
    UnknownBuiltin {
        /// The name asked for.
        name: String,
        /// Comma-separated known names.
        known: String,
    },
    /// The camera path file that comes with the scene (`NAME.path.json`
    /// beside `NAME.obj`) is unusable.
    #[error(transparent)]
    CameraPath(#[from] crate::CameraPathError),
}
