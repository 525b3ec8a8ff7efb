//! Readers for the occluder benchmark inputs of Intel's Masked Occlusion
//! Culling (MOC): synthetic `.mocscene` files with rectangle queries, recorded
//! game frames (`.mocrec`), and per-rectangle answers (`.res`). The formats are
//! described in `bench-data/moc/README.md` of the shared data.
//!
//! MOC's depth is `1/w` (nearer is larger); hom's is clip `z / w` (nearer is
//! smaller). The readers convert: every vertex gets clip `z = w − near_w`, so
//! `z / w = 1 − near_w / w`, a decreasing affine function of `1/w` that is 0
//! at the near plane and tends to 1 far away. The order of depths, and so
//! every occlusion answer, is MOC's.

use crate::LoadError;
use glam::{Mat4, Vec4};
use hom::geom::ScreenRect;
use hom::occlusion::FaceCull;
use std::path::Path;

/// A `.mocscene`: clip-space occluder triangles and rectangle queries.
#[derive(Clone, Debug)]
pub struct MocScene {
    /// Clip-space w of the near plane.
    pub near_w: f32,
    /// Clip-space vertices, `z` converted to hom's depth (see the module docs).
    pub vertices: Vec<Vec4>,
    /// Vertex indices; counter-clockwise in NDC is front-facing.
    pub triangles: Vec<[u32; 3]>,
    /// The rectangle queries, in file order.
    pub rects: Vec<MocRect>,
}

impl MocScene {
    /// The faces the benchmark culls: clockwise in NDC.
    pub const CULL: FaceCull = FaceCull::Clockwise;
}

/// A rectangle query: an object's screen bounds in NDC and its nearest clip w.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MocRect {
    /// Left edge (NDC).
    pub xmin: f32,
    /// Bottom edge (NDC, y up).
    pub ymin: f32,
    /// Right edge (NDC).
    pub xmax: f32,
    /// Top edge (NDC, y up).
    pub ymax: f32,
    /// Nearest clip-space w of the object.
    pub wmin: f32,
}

impl MocRect {
    /// The rectangle's pixel footprint at `width` × `height` as the reference
    /// answers define it — columns `trunc((xmin + 1) / 2 · W)` to
    /// `trunc((xmax + 1) / 2 · W)` and rows `trunc((1 − ymax) / 2 · H)` to
    /// `trunc((1 − ymin) / 2 · H)`, inclusive, clamped to the screen — with
    /// its depth in hom's convention (`1 − near_w / wmin`).
    pub fn footprint(&self, width: u32, height: u32, near_w: f32) -> ScreenRect {
        let col = |x: f32| ((x + 1.0) * 0.5 * width as f32) as i64;
        let row = |y: f32| ((1.0 - y) * 0.5 * height as f32) as i64;
        let clamp = |v: i64, n: u32| v.clamp(0, i64::from(n) - 1) as u32;
        let (x0, x1) = (clamp(col(self.xmin), width), clamp(col(self.xmax), width));
        let (y0, y1) = (clamp(row(self.ymax), height), clamp(row(self.ymin), height));
        let z = 1.0 - near_w / self.wmin;
        ScreenRect {
            x0,
            y0,
            x1: x1 + 1,
            y1: y1 + 1,
            z_near: z,
            z_far: z,
        }
    }
}

/// A recorded frame (`.mocrec`): the occluder draws of one game frame.
#[derive(Clone, Debug)]
pub struct MocRecording {
    /// Clip-space w of the near plane.
    pub near_w: f32,
    /// Width the frame was recorded at.
    pub width: u32,
    /// Height the frame was recorded at.
    pub height: u32,
    /// The occluder draws (render records), in order; test records are skipped.
    pub draws: Vec<MocDraw>,
}

impl MocRecording {
    /// Triangles over all draws.
    pub fn triangle_count(&self) -> usize {
        self.draws.iter().map(|d| d.triangles.len()).sum()
    }
}

/// One recorded occluder draw, transformed to clip space.
#[derive(Clone, Debug)]
pub struct MocDraw {
    /// Clip-space vertices, `z` converted to hom's depth (see the module docs).
    pub vertices: Vec<Vec4>,
    /// Vertex indices.
    pub triangles: Vec<[u32; 3]>,
    /// The faces this draw culls.
    pub cull: FaceCull,
}

/// Reads a `.mocscene` file.
pub fn read_scene(path: &Path) -> Result<MocScene, LoadError> {
    let bytes = read(path)?;
    parse_scene(&bytes).map_err(|e| e.at(path))
}

/// Reads a `.mocrec` file.
pub fn read_recording(path: &Path) -> Result<MocRecording, LoadError> {
    let bytes = read(path)?;
    parse_recording(&bytes).map_err(|e| e.at(path))
}

/// Reads a `.res` answer file: one byte per rectangle, 1 = occluded, 0 = visible.
pub fn read_answers(path: &Path) -> Result<Vec<bool>, LoadError> {
    let bytes = read(path)?;
    bytes
        .iter()
        .enumerate()
        .map(|(i, &b)| match b {
            0 => Ok(false),
            1 => Ok(true),
            _ => Err(Malformed {
                offset: i,
                message: format!("answer byte {b}, expected 0 (visible) or 1 (occluded)"),
            }
            .at(path)),
        })
        .collect()
}

fn read(path: &Path) -> Result<Vec<u8>, LoadError> {
    std::fs::read(path).map_err(|source| LoadError::Io {
        path: path.display().to_string(),
        source,
    })
}

/// A parse failure at a byte offset, before the file name is known.
#[derive(Debug)]
struct Malformed {
    offset: usize,
    message: String,
}

impl Malformed {
    fn at(self, path: &Path) -> LoadError {
        LoadError::Malformed {
            path: path.display().to_string(),
            line: None,
            message: format!("at byte {}: {}", self.offset, self.message),
        }
    }
}

/// A little-endian cursor that never reads past the end.
struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    fn fail(&self, message: impl Into<String>) -> Malformed {
        Malformed {
            offset: self.pos,
            message: message.into(),
        }
    }

    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], Malformed> {
        match self.bytes.len().checked_sub(self.pos) {
            Some(left) if left >= n => {
                let s = &self.bytes[self.pos..self.pos + n];
                self.pos += n;
                Ok(s)
            }
            _ => Err(self.fail(format!(
                "file ends inside {what} ({n} bytes needed, {} left)",
                self.bytes.len() - self.pos
            ))),
        }
    }

    fn u32(&mut self, what: &str) -> Result<u32, Malformed> {
        Ok(u32::from_le_bytes(self.take(4, what)?.try_into().expect("4 bytes")))
    }

    fn i32(&mut self, what: &str) -> Result<i32, Malformed> {
        Ok(self.u32(what)? as i32)
    }

    fn f32(&mut self, what: &str) -> Result<f32, Malformed> {
        Ok(f32::from_bits(self.u32(what)?))
    }

    fn f32s<const N: usize>(&mut self, what: &str) -> Result<[f32; N], Malformed> {
        let mut v = [0.0; N];
        for f in &mut v {
            *f = self.f32(what)?;
        }
        Ok(v)
    }

    fn u8(&mut self, what: &str) -> Result<u8, Malformed> {
        Ok(self.take(1, what)?[0])
    }

    /// A count of items of `size` bytes each that must fit in the rest of the file
    /// (so a hostile count never allocates more than the file holds).
    fn count(&mut self, raw: i64, size: usize, what: &str) -> Result<usize, Malformed> {
        let left = (self.bytes.len() - self.pos) as i64;
        if raw < 0 || raw.saturating_mul(size as i64) > left {
            return Err(self.fail(format!("{what} count {raw} does not fit in the {left} bytes left")));
        }
        Ok(raw as usize)
    }

    fn triangles(&mut self, n: usize, n_verts: usize) -> Result<Vec<[u32; 3]>, Malformed> {
        let mut tris = Vec::with_capacity(n);
        for _ in 0..n {
            let mut t = [0u32; 3];
            for i in &mut t {
                *i = self.u32("a triangle")?;
            }
            if let Some(&bad) = t.iter().find(|&&i| i as usize >= n_verts) {
                return Err(self.fail(format!("vertex index {bad} out of range ({n_verts} vertices)")));
            }
            tris.push(t);
        }
        Ok(tris)
    }
}

/// The clip vertex with hom's depth (see the module docs); rejects non-finite values.
fn clip_vertex(x: f32, y: f32, w: f32, near_w: f32) -> Option<Vec4> {
    let v = Vec4::new(x, y, w - near_w, w);
    v.is_finite().then_some(v)
}

fn near_plane(r: &mut Reader) -> Result<f32, Malformed> {
    let near_w = r.f32("near_w")?;
    if !(near_w.is_finite() && near_w > 0.0) {
        return Err(r.fail(format!("near_w {near_w} must be finite and positive")));
    }
    Ok(near_w)
}

fn parse_scene(bytes: &[u8]) -> Result<MocScene, Malformed> {
    let mut r = Reader { bytes, pos: 0 };
    if r.take(8, "the magic")? != b"MOCSCN01" {
        return Err(Malformed {
            offset: 0,
            message: "not a .mocscene file (magic is not \"MOCSCN01\")".into(),
        });
    }
    let (nv, nt, nr) = (r.u32("n_verts")?, r.u32("n_tris")?, r.u32("n_rects")?);
    let near_w = near_plane(&mut r)?;
    let need = 16 * u64::from(nv) + 12 * u64::from(nt) + 20 * u64::from(nr);
    if need != (bytes.len() - r.pos) as u64 {
        return Err(r.fail(format!(
            "{nv} vertices, {nt} triangles and {nr} rectangles need {need} bytes after the header, the file has {}",
            bytes.len() - r.pos
        )));
    }
    let mut vertices = Vec::with_capacity(nv as usize);
    for i in 0..nv {
        let [x, y, _z, w] = r.f32s("a vertex")?;
        let v = clip_vertex(x, y, w, near_w).ok_or_else(|| r.fail(format!("vertex {i} is not finite")))?;
        vertices.push(v);
    }
    let triangles = r.triangles(nt as usize, nv as usize)?;
    let mut rects = Vec::with_capacity(nr as usize);
    for i in 0..nr {
        let v: [f32; 5] = r.f32s("a rectangle")?;
        let [xmin, ymin, xmax, ymax, wmin] = v;
        if !v.iter().all(|c| c.is_finite()) || wmin <= 0.0 {
            return Err(r.fail(format!("rectangle {i} is not finite or has wmin <= 0")));
        }
        rects.push(MocRect {
            xmin,
            ymin,
            xmax,
            ymax,
            wmin,
        });
    }
    Ok(MocScene {
        near_w,
        vertices,
        triangles,
        rects,
    })
}

/// Record types of a `.mocrec` stream.
const RENDER: u8 = 0;
const TEST_RECT: u8 = 1;
const TEST_TRIANGLES: u8 = 2;
const CLEAR: u8 = 3;
const END: u8 = 0x7f;

fn parse_recording(bytes: &[u8]) -> Result<MocRecording, Malformed> {
    let mut r = Reader { bytes, pos: 0 };
    if r.u32("the magic")? != 0xA701_B600 {
        return Err(Malformed {
            offset: 0,
            message: "not a .mocrec file (magic is not 0xA701B600)".into(),
        });
    }
    let near_w = near_plane(&mut r)?;
    let (width, height) = (r.u32("width")?, r.u32("height")?);
    if !(1..=16384).contains(&width) || !(1..=16384).contains(&height) {
        return Err(r.fail(format!("resolution {width}x{height} is outside 1..=16384")));
    }
    let mut draws = Vec::new();
    loop {
        match r.u8("a record type")? {
            END => break,
            CLEAR => {}
            TEST_RECT => {
                r.take(24, "a rectangle test record")?;
            }
            kind @ (RENDER | TEST_TRIANGLES) => {
                if let Some(draw) = parse_draw(&mut r, near_w)? {
                    if kind == RENDER {
                        draws.push(draw);
                    }
                }
            }
            other => return Err(r.fail(format!("unknown record type {other}"))),
        }
    }
    Ok(MocRecording {
        near_w,
        width,
        height,
        draws,
    })
}

fn parse_draw(r: &mut Reader, near_w: f32) -> Result<Option<MocDraw>, Malformed> {
    let _cull_result = r.i32("cull_result")?;
    let raw_count = r.i32("vtx_count")?;
    if raw_count <= 0 {
        return Ok(None);
    }
    let vtx_size = r.i32("vtx_size")?;
    if !(1..=4096).contains(&vtx_size) {
        return Err(r.fail(format!("vertex size {vtx_size} is outside 1..=4096 bytes")));
    }
    let n_verts = r.count(i64::from(raw_count), vtx_size as usize, "vertex")?;
    let vertex_bytes = r.take(n_verts * vtx_size as usize, "the vertices")?;
    let n_tris = r.i32("tri_count")?;
    let n_tris = r.count(i64::from(n_tris), 12, "triangle")?;
    let triangles = r.triangles(n_tris, n_verts)?;
    let matrix = match r.u8("has_matrix")? {
        0 => None,
        1 => {
            let m: [f32; 16] = r.f32s("the matrix")?;
            if !m.iter().all(|c| c.is_finite()) {
                return Err(r.fail("the model-to-clip matrix is not finite"));
            }
            Some(Mat4::from_cols_array(&m))
        }
        b => return Err(r.fail(format!("has_matrix byte {b}, expected 0 or 1"))),
    };
    let _clip_planes = r.i32("clip_plane_mask")?;
    let cull = match r.i32("backface_winding")? {
        0 => FaceCull::None,
        1 => FaceCull::Clockwise,
        2 => FaceCull::CounterClockwise,
        b => return Err(r.fail(format!("backface_winding {b}, expected 0, 1 or 2"))),
    };
    let (stride, y_off, w_off) = (r.i32("stride")?, r.i32("y offset")?, r.i32("w offset")?);
    let stride = if stride == 0 { vtx_size } else { stride };
    let fits = |off: i32| off >= 0 && off as usize + 4 <= stride as usize;
    if stride != vtx_size || !fits(y_off) || !fits(w_off) {
        return Err(r.fail(format!(
            "vertex layout (stride {stride}, y at {y_off}, w at {w_off}) does not fit vertices of {vtx_size} bytes"
        )));
    }
    let float = |v: &[u8], off: i32| f32::from_le_bytes(v[off as usize..off as usize + 4].try_into().expect("4 bytes"));
    let mut vertices = Vec::with_capacity(n_verts);
    for (i, v) in vertex_bytes.chunks_exact(stride as usize).enumerate() {
        let (x, y, zw) = (float(v, 0), float(v, y_off), float(v, w_off));
        let clip = match matrix {
            // With a matrix the third float is model-space z.
            Some(m) => m * Vec4::new(x, y, zw, 1.0),
            None => Vec4::new(x, y, 0.0, zw),
        };
        let v =
            clip_vertex(clip.x, clip.y, clip.w, near_w).ok_or_else(|| r.fail(format!("vertex {i} is not finite")))?;
        vertices.push(v);
    }
    Ok(Some(MocDraw {
        vertices,
        triangles,
        cull,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene_bytes(verts: &[[f32; 4]], tris: &[[u32; 3]], rects: &[[f32; 5]]) -> Vec<u8> {
        let mut b = b"MOCSCN01".to_vec();
        for n in [verts.len(), tris.len(), rects.len()] {
            b.extend((n as u32).to_le_bytes());
        }
        b.extend(0.5f32.to_le_bytes());
        for f in verts.iter().flatten() {
            b.extend(f.to_le_bytes());
        }
        for i in tris.iter().flatten() {
            b.extend(i.to_le_bytes());
        }
        for f in rects.iter().flatten() {
            b.extend(f.to_le_bytes());
        }
        b
    }

    #[test]
    fn a_scene_round_trips_with_hom_depth() {
        let b = scene_bytes(
            &[[0.0, 0.0, 0.0, 2.0], [1.0, 0.0, 0.0, 4.0], [0.0, 1.0, 0.0, 1.0]],
            &[[0, 1, 2]],
            &[[-0.5, -0.5, 0.5, 0.5, 2.0]],
        );
        let s = parse_scene(&b).unwrap();
        assert_eq!(s.near_w, 0.5);
        assert_eq!(s.vertices[1], Vec4::new(1.0, 0.0, 3.5, 4.0));
        assert_eq!(s.triangles, vec![[0, 1, 2]]);
        // Depth 1 - near / w: nearer (smaller w) is smaller, as in hom.
        let r = s.rects[0].footprint(100, 50, s.near_w);
        assert_eq!((r.x0, r.x1, r.y0, r.y1), (25, 76, 12, 38));
        assert_eq!(r.z_near, 0.75);
    }

    #[test]
    fn footprints_are_clamped_to_the_screen() {
        let r = MocRect {
            xmin: -1.5,
            ymin: 0.9,
            xmax: -1.2,
            ymax: 1.3,
            wmin: 1.0,
        };
        let f = r.footprint(64, 32, 1.0);
        assert_eq!((f.x0, f.x1, f.y0, f.y1), (0, 1, 0, 2));
    }

    #[test]
    fn malformed_scenes_are_errors_not_panics() {
        let good = scene_bytes(&[[0.0, 0.0, 0.0, 2.0]; 3], &[[0, 1, 2]], &[[0.0, 0.0, 0.1, 0.1, 2.0]]);
        for n in 0..good.len() {
            assert!(parse_scene(&good[..n]).is_err(), "truncated at {n}");
        }
        let mut bad_index = good.clone();
        bad_index[24 + 48..24 + 52].copy_from_slice(&7u32.to_le_bytes());
        assert!(parse_scene(&bad_index).unwrap_err().message.contains("out of range"));
        let mut huge = good.clone();
        huge[8..12].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(parse_scene(&huge).unwrap_err().message.contains("need"));
        let mut nan = good;
        nan[24..28].copy_from_slice(&f32::NAN.to_le_bytes());
        assert!(parse_scene(&nan).unwrap_err().message.contains("not finite"));
    }

    #[test]
    fn malformed_recordings_are_errors_not_panics() {
        let mut b = 0xA701_B600u32.to_le_bytes().to_vec();
        b.extend(1.0f32.to_le_bytes());
        b.extend(64u32.to_le_bytes());
        b.extend(32u32.to_le_bytes());
        b.push(RENDER);
        for v in [0i32, 3, 12] {
            b.extend(v.to_le_bytes());
        }
        for f in [[-1.0f32, -1.0, 2.0], [1.0, -1.0, 2.0], [0.0, 1.0, 2.0]]
            .iter()
            .flatten()
        {
            b.extend(f.to_le_bytes());
        }
        b.extend(1i32.to_le_bytes());
        for i in [0u32, 1, 2] {
            b.extend(i.to_le_bytes());
        }
        b.push(0);
        for v in [0i32, 2, 12, 4, 8] {
            b.extend(v.to_le_bytes());
        }
        b.push(END);
        let rec = parse_recording(&b).unwrap();
        assert_eq!(rec.draws.len(), 1);
        assert_eq!(rec.draws[0].cull, FaceCull::CounterClockwise);
        assert_eq!(rec.draws[0].vertices[2], Vec4::new(0.0, 1.0, 1.0, 2.0));
        for n in 0..b.len() {
            assert!(parse_recording(&b[..n]).is_err(), "truncated at {n}");
        }
        // A hostile vertex count must not allocate: it is checked against the file length.
        let mut huge = b.clone();
        huge[21..25].copy_from_slice(&i32::MAX.to_le_bytes());
        assert!(parse_recording(&huge).unwrap_err().message.contains("does not fit"));
    }
}
