//! Why a course could not be loaded: [`EtrError`], carried with the file's
//! name by [`crate::LoadError::Etr`].

use hom::scene::SceneError;
use thiserror::Error;

/// What is wrong with a course's file. The file is named by the
/// [`crate::LoadError::Etr`] that carries it. A variant with a `source` does not
/// repeat it in its message.
#[derive(Debug, Error)]
pub enum EtrError {
    /// The file is missing or could not be read.
    #[error("cannot read the file")]
    Io(#[source] std::io::Error),
    /// The file is larger than a course file may be ([`super::MAX_DIM_BYTES`] for
    /// `course.dim`, [`super::MAX_PNG_BYTES`] for an image).
    #[error("larger than {max} bytes")]
    TooLarge {
        /// The limit, bytes.
        max: u64,
    },
    /// A required parameter is absent.
    #[error("no [{field}] value; a course needs [width], [length], [angle] and [scale]")]
    MissingField {
        /// The tag.
        field: &'static str,
    },
    /// A parameter is not a finite number.
    #[error("[{field}] is '{value}', not a finite number")]
    BadNumber {
        /// The tag.
        field: &'static str,
        /// The text found.
        value: String,
    },
    /// A parameter is a number outside its range.
    #[error("[{field}] is {value}, outside {range}")]
    OutOfRange {
        /// The tag.
        field: &'static str,
        /// The value found.
        value: f64,
        /// The accepted range, in words.
        range: &'static str,
    },
    /// The file does not start with the PNG signature.
    #[error("not a PNG file (no PNG signature)")]
    NotPng,
    /// The file ends before its PNG header does, or the header is malformed.
    #[error("truncated or malformed PNG header")]
    BadHeader,
    /// The PNG could not be decoded (truncated or corrupt data).
    #[error("cannot decode the PNG")]
    Image(#[source] image::ImageError),
    /// The image's size (from its header) is too small or too large.
    #[error("image is {width} × {height} samples; need at least 2 × 2 and at most {max_samples} in all")]
    ImageSize {
        /// Width, pixels.
        width: u32,
        /// Height, pixels.
        height: u32,
        /// The limit ([`super::EtrOptions::max_samples`]).
        max_samples: u64,
    },
    /// `trees.png` is not the size of `elev.png`.
    #[error("item map is {width} × {height} pixels but elev.png is {elev_width} × {elev_height}; they must match")]
    MapSize {
        /// trees.png width.
        width: u32,
        /// trees.png height.
        height: u32,
        /// elev.png width.
        elev_width: u32,
        /// elev.png height.
        elev_height: u32,
    },
    /// The geometry made from the course is invalid (should not happen for a
    /// course that passed the checks above).
    #[error("invalid geometry")]
    Geometry(#[source] SceneError),
}
