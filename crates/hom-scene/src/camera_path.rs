//! Camera paths: the frames of a walkthrough, as JSON files or built in.
//!
//! File format (all fields but `frames` optional, defaults shown):
//! ```json
//! {"up":[0,1,0],"fov_y_deg":60,"near":0.1,"far":2000,"width":1024,"height":1024,
//!  "frames":[{"eye":[0,1.7,0],"target":[0,1.7,-1]}]}
//! ```

use glam::Vec3;
use hom::geom::Camera;
use serde::{Deserialize, Serialize};
use std::path::Path;
use thiserror::Error;

/// Most frames a path may hold (a path file is read whole).
pub const MAX_FRAMES: usize = 1_000_000;

/// Why a camera path could not be read or used. A variant with a `source`
/// does not repeat it in its message (print the chain to see it).
#[derive(Debug, Error)]
pub enum CameraPathError {
    /// The file could not be read.
    #[error("cannot read camera path {path}")]
    Io {
        /// File.
        path: String,
        /// Cause.
        source: std::io::Error,
    },
    /// The JSON is malformed or has the wrong shape.
    #[error("camera path {path}")]
    Json {
        /// File.
        path: String,
        /// Cause (with line and column).
        source: serde_json::Error,
    },
    /// A frame or setting makes no valid camera.
    #[error("camera path {path}: frame {frame}")]
    BadFrame {
        /// File.
        path: String,
        /// Frame index.
        frame: usize,
        /// Cause.
        source: hom::geom::CameraError,
    },
    /// No frames, or too many.
    #[error("camera path {path}: has {count} frames; need 1..={max}", max = MAX_FRAMES)]
    FrameCount {
        /// File.
        path: String,
        /// Frames found.
        count: usize,
    },
}

/// One frame: where the eye is and what it looks at.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PathFrame {
    /// Eye position.
    pub eye: [f32; 3],
    /// Point looked at.
    pub target: [f32; 3],
}

fn default_up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}
fn default_fov() -> f32 {
    60.0
}
fn default_near() -> f32 {
    0.1
}
fn default_far() -> f32 {
    2000.0
}
fn default_side() -> u32 {
    1024
}

/// A camera path: shared lens and viewport, one eye/target per frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraPath {
    /// Up direction.
    #[serde(default = "default_up")]
    pub up: [f32; 3],
    /// Vertical field of view, degrees.
    #[serde(default = "default_fov")]
    pub fov_y_deg: f32,
    /// Near clip distance.
    #[serde(default = "default_near")]
    pub near: f32,
    /// Far clip distance.
    #[serde(default = "default_far")]
    pub far: f32,
    /// Image width.
    #[serde(default = "default_side")]
    pub width: u32,
    /// Image height.
    #[serde(default = "default_side")]
    pub height: u32,
    /// The frames.
    pub frames: Vec<PathFrame>,
}

impl CameraPath {
    /// A path with default lens and viewport through the given frames.
    pub fn new(frames: Vec<PathFrame>) -> CameraPath {
        CameraPath {
            up: default_up(),
            fov_y_deg: default_fov(),
            near: default_near(),
            far: default_far(),
            width: default_side(),
            height: default_side(),
            frames,
        }
    }

    /// Reads and validates a path file.
    pub fn load(path: &Path) -> Result<CameraPath, CameraPathError> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| CameraPathError::Io {
            path: name.clone(),
            source,
        })?;
        let p: CameraPath = serde_json::from_str(&text).map_err(|source| CameraPathError::Json {
            path: name.clone(),
            source,
        })?;
        p.validate(&name)?;
        Ok(p)
    }

    /// Checks that there are frames and that every frame makes a valid camera.
    /// `name` is used in the error (a file name, or a scene name for built-in paths).
    pub fn validate(&self, name: &str) -> Result<(), CameraPathError> {
        if self.frames.is_empty() || self.frames.len() > MAX_FRAMES {
            return Err(CameraPathError::FrameCount {
                path: name.to_string(),
                count: self.frames.len(),
            });
        }
        for frame in 0..self.frames.len() {
            self.camera(frame)
                .validate()
                .map_err(|source| CameraPathError::BadFrame {
                    path: name.to_string(),
                    frame,
                    source,
                })?;
        }
        Ok(())
    }

    /// The same path walked `speed` times as fast: frame `i` of the result is
    /// the original at `i × speed`, interpolated linearly between frames
    /// (`0.25` and `0.5` walk slower, `2` and `8` skip frames). The last
    /// original frame ends it. A speed that is not finite and positive gives
    /// the path unchanged.
    pub fn at_speed(&self, speed: f32) -> CameraPath {
        let n = self.frames.len();
        if !(speed.is_finite() && speed > 0.0) || n < 2 {
            return self.clone();
        }
        let last = (n - 1) as f64;
        let count = (last / speed as f64).floor() as usize + 1;
        let lerp = |a: [f32; 3], b: [f32; 3], t: f32| std::array::from_fn(|k| a[k] + (b[k] - a[k]) * t);
        let frames = (0..count)
            .map(|i| {
                let at = (i as f64 * speed as f64).min(last);
                let (k, t) = (at.floor() as usize, (at - at.floor()) as f32);
                let (a, b) = (&self.frames[k], &self.frames[(k + 1).min(n - 1)]);
                PathFrame {
                    eye: lerp(a.eye, b.eye, t),
                    target: lerp(a.target, b.target, t),
                }
            })
            .collect();
        CameraPath { frames, ..self.clone() }
    }

    /// The same number of frames with a cut every `every` frames: at the
    /// `k`-th cut the walk jumps `k` thirds of the path ahead (wrapping), and
    /// at every other cut it also turns 180° (looks back the way it came).
    /// The stress for per-frame state reused from the last frame. `every` 0
    /// gives the path unchanged.
    pub fn with_cuts(&self, every: usize) -> CameraPath {
        let n = self.frames.len();
        if every == 0 || n == 0 {
            return self.clone();
        }
        let frames = (0..n)
            .map(|i| {
                let cut = i / every;
                let f = &self.frames[(i + cut * n.div_ceil(3)) % n];
                if cut % 2 == 1 {
                    // Look the other way: the target mirrored through the eye.
                    let target = std::array::from_fn(|k| 2.0 * f.eye[k] - f.target[k]);
                    PathFrame { eye: f.eye, target }
                } else {
                    *f
                }
            })
            .collect();
        CameraPath { frames, ..self.clone() }
    }

    /// The same path at another viewport size.
    pub fn with_viewport(mut self, width: u32, height: u32) -> CameraPath {
        self.width = width;
        self.height = height;
        self
    }

    /// The camera of frame `i`.
    ///
    /// # Panics
    /// If `i >= self.frames.len()`.
    pub fn camera(&self, i: usize) -> Camera {
        let f = &self.frames[i];
        Camera::new(
            Vec3::from(f.eye),
            Vec3::from(f.target),
            Vec3::from(self.up),
            self.fov_y_deg.to_radians(),
            self.near,
            self.far,
            self.width,
            self.height,
        )
    }

    /// `frames` frames circling `bounds` once, looking at its centre from outside:
    /// the default walkthrough for a scene file that comes without a path.
    pub fn orbit(bounds: &hom::geom::Aabb, frames: usize) -> CameraPath {
        let centre = bounds.center();
        let diag = bounds.extent().length().max(1e-3);
        let radius = diag * 0.75;
        let height = bounds.extent().y * 0.25;
        let frames_v = (0..frames.max(1))
            .map(|i| {
                let a = i as f32 / frames.max(1) as f32 * std::f32::consts::TAU;
                let eye = centre + Vec3::new(a.cos() * radius, height, a.sin() * radius);
                PathFrame {
                    eye: eye.to_array(),
                    target: centre.to_array(),
                }
            })
            .collect();
        CameraPath {
            near: (diag * 1e-4).max(1e-3),
            far: diag * 4.0,
            ..CameraPath::new(frames_v)
        }
    }

    /// Frames sampled along a polyline of eye points at `step` metres, each
    /// looking `look_ahead` metres further along the polyline (waypoints at eye height).
    /// Where the polyline runs within about 8° of straight up or down (spawn
    /// points above one another), a frame keeps the last heading that was
    /// not, level (−z before any): a view along the up axis has no camera.
    ///
    /// # Panics
    /// If `waypoints` has fewer than two points or `step <= 0`.
    pub fn along(waypoints: &[Vec3], step: f32, look_ahead: f32) -> CameraPath {
        assert!(waypoints.len() >= 2 && step > 0.0);
        let mut eyes = Vec::new();
        for w in waypoints.windows(2) {
            let len = (w[1] - w[0]).length();
            let n = (len / step).ceil().max(1.0) as usize;
            eyes.extend((0..n).map(|i| w[0].lerp(w[1], i as f32 / n as f32)));
        }
        eyes.push(*waypoints.last().unwrap());
        let ahead = |i: usize| -> Vec3 {
            // Walk forward along the sampled eyes until look_ahead metres are covered.
            let mut d = 0.0;
            let mut j = i;
            while j + 1 < eyes.len() && d < look_ahead {
                d += (eyes[j + 1] - eyes[j]).length();
                j += 1;
            }
            let dir = if j > i {
                eyes[j] - eyes[i]
            } else {
                eyes[i] - eyes[i.saturating_sub(1)]
            };
            dir.normalize_or(Vec3::NEG_Z)
        };
        let mut heading = Vec3::NEG_Z;
        let frames = (0..eyes.len())
            .map(|i| {
                let mut dir = ahead(i);
                if dir.y.abs() > 0.99 {
                    dir = heading;
                } else {
                    heading = Vec3::new(dir.x, 0.0, dir.z).normalize();
                }
                PathFrame {
                    eye: eyes[i].to_array(),
                    target: (eyes[i] + dir * look_ahead.max(1.0)).to_array(),
                }
            })
            .collect();
        CameraPath::new(frames)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_documented_format_and_rejects_bad_frames() {
        let ok = r#"{"up":[0,1,0],"fov_y_deg":60,"near":0.1,"far":2000,"width":1024,"height":1024,
                     "frames":[{"eye":[0,1.7,0],"target":[0,1.7,-1]}]}"#;
        let p: CameraPath = serde_json::from_str(ok).unwrap();
        p.validate("x").unwrap();
        assert_eq!(p.camera(0).eye, Vec3::new(0.0, 1.7, 0.0));
        let same: CameraPath = serde_json::from_str(r#"{"frames":[{"eye":[1,1,1],"target":[1,1,1]}]}"#).unwrap();
        assert!(matches!(
            same.validate("x"),
            Err(CameraPathError::BadFrame { frame: 0, .. })
        ));
        // The cause is the source, not repeated in the message.
        let e = same.validate("x").unwrap_err();
        let cause = std::error::Error::source(&e).expect("a camera error").to_string();
        assert_eq!(e.to_string(), "camera path x: frame 0");
        assert!(cause.contains("no view direction"), "{cause}");
        let none: CameraPath = serde_json::from_str(r#"{"frames":[]}"#).unwrap();
        assert!(matches!(none.validate("x"), Err(CameraPathError::FrameCount { .. })));
        assert!(serde_json::from_str::<CameraPath>(r#"{"frames":[], "fov":3}"#).is_err());
    }

    #[test]
    fn along_samples_the_polyline_and_looks_ahead() {
        let p = CameraPath::along(&[Vec3::ZERO, Vec3::new(10.0, 0.0, 0.0)], 1.0, 5.0);
        assert_eq!(p.frames.len(), 11);
        p.validate("line").unwrap();
        assert!(p
            .frames
            .iter()
            .all(|f| f.target[0] > f.eye[0] - 1e-3 || f.eye[0] >= 10.0));
    }

    /// Spawn points above one another (a shaft, a jump pad): the frames on
    /// the vertical stretch look level, along the last heading (−z before
    /// any), so every frame is a camera.
    #[test]
    fn along_a_vertical_stretch_keeps_a_level_heading() {
        let p = CameraPath::along(&[Vec3::ZERO, Vec3::new(0.0, 8.0, 0.0)], 1.0, 2.0);
        p.validate("shaft").unwrap();
        assert!(p
            .frames
            .iter()
            .all(|f| f.target[1] == f.eye[1] && f.target[2] < f.eye[2]));
        let p = CameraPath::along(
            &[
                Vec3::ZERO,
                Vec3::new(4.0, 0.0, 0.0),
                Vec3::new(4.0, 9.0, 0.0),
                Vec3::new(4.0, 9.0, 6.0),
            ],
            1.0,
            2.0,
        );
        p.validate("up the shaft").unwrap();
        let up = p
            .frames
            .iter()
            .filter(|f| f.eye[0] == 4.0 && f.eye[1] > 0.0 && f.eye[1] < 7.0);
        assert!(up.clone().count() >= 6);
        assert!(up
            .into_iter()
            .all(|f| f.target[0] > f.eye[0] && f.target[1] == f.eye[1]));
    }

    fn straight(n: usize) -> CameraPath {
        CameraPath::new(
            (0..n)
                .map(|i| PathFrame {
                    eye: [i as f32, 0.0, 0.0],
                    target: [i as f32, 0.0, -1.0],
                })
                .collect(),
        )
    }

    #[test]
    fn speed_subsamples_or_interpolates_and_ends_on_the_last_frame() {
        let p = straight(9);
        let eyes = |q: &CameraPath| q.frames.iter().map(|f| f.eye[0]).collect::<Vec<_>>();
        assert_eq!(eyes(&p.at_speed(2.0)), [0.0, 2.0, 4.0, 6.0, 8.0]);
        assert_eq!(eyes(&p.at_speed(8.0)), [0.0, 8.0]);
        assert_eq!(p.at_speed(0.25).frames.len(), 33);
        assert_eq!(eyes(&p.at_speed(0.5))[..4], [0.0, 0.5, 1.0, 1.5]);
        assert_eq!(p.at_speed(1.0), p);
        assert_eq!(p.at_speed(f32::NAN), p);
        assert_eq!(p.at_speed(0.25).width, p.width, "the lens and viewport stay");
    }

    #[test]
    fn cuts_jump_a_third_ahead_and_turn_at_every_other_cut() {
        let p = straight(9).with_cuts(4);
        assert_eq!(p.frames.len(), 9);
        let eyes: Vec<f32> = p.frames.iter().map(|f| f.eye[0]).collect();
        assert_eq!(eyes, [0.0, 1.0, 2.0, 3.0, 7.0, 8.0, 0.0, 1.0, 5.0]);
        // Cut 1 looks back (+z), cuts 0 and 2 ahead (-z).
        let z: Vec<f32> = p.frames.iter().map(|f| f.target[2]).collect();
        assert_eq!(z, [-1.0, -1.0, -1.0, -1.0, 1.0, 1.0, 1.0, 1.0, -1.0]);
        assert_eq!(straight(9).with_cuts(0), straight(9));
    }
}
