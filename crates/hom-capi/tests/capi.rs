//! The C ABI from Rust: answers equal the front door's on random scenes,
//! every misuse is an error code with a message (never a crash), and
//! `include/hom.h` is cbindgen's output for the source.

use hom_capi::*;
use hom_occlusion::geom::Aabb;
use hom_occlusion::glam::{Mat4, Vec3};
use hom_occlusion::{BufferOptions, ClipConvention, FaceCull, HzBuffer, MaskedBuffer, OcclusionBuffer, Visibility};
use hom_testkit::Rng;
use std::ffi::CStr;

fn last_error() -> String {
    // SAFETY: hom_last_error returns a valid C string until the next call.
    unsafe { CStr::from_ptr(hom_last_error()) }
        .to_string_lossy()
        .into_owned()
}

/// A unit cube's 8 corners (0..1 on each axis) and 36 indices, as C
/// passes them: the test kit's cube, moved off the origin.
fn cube() -> (Vec<[f32; 3]>, Vec<u32>) {
    let mesh = hom_testkit::cube();
    let p = mesh.positions().iter().map(|v| (*v + 0.5).to_array()).collect();
    let t = mesh.triangles().iter().flatten().copied().collect();
    (p, t)
}

fn view_proj(eye: Vec3, reversed: bool) -> Mat4 {
    use hom_occlusion::glam::camera::rh::{proj::directx, view::look_at_mat4};
    let proj = if reversed {
        directx::perspective_infinite_reverse(1.0, 4.0 / 3.0, 0.1)
    } else {
        directx::perspective(1.0, 4.0 / 3.0, 0.1, 200.0)
    };
    proj * look_at_mat4(eye, Vec3::new(0.0, 1.0, 0.0), Vec3::Y)
}

/// Random boxes drawn and tested through the C ABI and through the Rust
/// front door, the same buffer kind each: every answer equal (the
/// buffers' own tests check them against brute force). Positions carry a
/// fourth float, so the stride is used.
#[test]
fn answers_equal_the_front_doors() {
    let (corners, indices) = cube();
    let mut rng = Rng::new(0x9e37_79b9_7f4a_7c15);
    let mut answers = [0usize; 3];
    for case in 0..40 {
        let reversed = case % 2 == 0;
        let clip = if reversed {
            HOM_CLIP_REVERSED_Z
        } else {
            HOM_CLIP_ZERO_TO_ONE
        };
        let options = BufferOptions {
            clip: if reversed {
                ClipConvention::ReversedZ
            } else {
                ClipConvention::ZeroToOne
            },
            ..BufferOptions::default()
        };
        let kind = [HOM_KIND_HZB, HOM_KIND_MASKED][case % 2];
        let mut rust: Box<dyn OcclusionBuffer> = if kind == HOM_KIND_HZB {
            Box::new(HzBuffer::new(160, 120, options).unwrap())
        } else {
            Box::new(MaskedBuffer::new(160, 120, options).unwrap())
        };
        let c = hom_buffer_new_kind(kind, 160, 120, clip);
        assert!(!c.is_null(), "{}", last_error());
        let vp = view_proj(Vec3::new(rng.unit() * 4.0 - 2.0, 1.5, 14.0), reversed);
        // SAFETY: `c` is live; every pointer below points at what its count says.
        unsafe {
            assert_eq!(hom_buffer_clear(c), 0);
            rust.clear();
            let strided: Vec<f32> = corners.iter().flat_map(|p| [p[0], p[1], p[2], 7.0]).collect();
            let points: Vec<Vec3> = corners.iter().map(|&p| Vec3::from(p)).collect();
            let tris: Vec<[u32; 3]> = indices.chunks(3).map(|t| [t[0], t[1], t[2]]).collect();
            for _ in 0..6 {
                let at = Vec3::new(rng.unit() * 12.0 - 6.0, 0.0, rng.unit() * 8.0 - 4.0);
                let size = Vec3::new(0.5 + rng.unit() * 4.0, 0.5 + rng.unit() * 4.0, 0.2 + rng.unit());
                let m = vp * Mat4::from_translation(at) * Mat4::from_scale(size);
                let code = hom_buffer_render_triangles(
                    c,
                    strided.as_ptr(),
                    8,
                    16,
                    indices.as_ptr(),
                    36,
                    m.to_cols_array().as_ptr(),
                );
                assert_eq!(code, 0, "{}", last_error());
                rust.render_triangles(&points, &tris, &m, FaceCull::None).unwrap();
            }
            for _ in 0..60 {
                let min = Vec3::new(rng.unit() * 16.0 - 8.0, rng.unit() * 2.0, rng.unit() * 30.0 - 20.0);
                let max = min + Vec3::new(rng.unit(), rng.unit(), rng.unit());
                let got = hom_buffer_test_aabb(
                    c,
                    min.as_ref().as_ptr(),
                    max.as_ref().as_ptr(),
                    vp.to_cols_array().as_ptr(),
                );
                let want = match rust.test_aabb(&Aabb::new(min, max), &vp) {
                    Visibility::Visible => HOM_VISIBLE,
                    Visibility::Occluded => HOM_OCCLUDED,
                    Visibility::ViewCulled => HOM_VIEW_CULLED,
                };
                assert_eq!(got, want, "case {case}");
                answers[got as usize] += 1;
            }
            // The batch call gives the single calls' answers, box for box.
            let mut boxes = Vec::new();
            for _ in 0..50 {
                let min = [rng.unit() * 16.0 - 8.0, rng.unit() * 2.0, rng.unit() * 30.0 - 20.0];
                boxes.extend(min);
                boxes.extend([min[0] + rng.unit(), min[1] + rng.unit(), min[2] + rng.unit()]);
            }
            boxes[0] = f32::NAN;
            let mut batch = vec![-9; 50];
            let code = hom_buffer_test_aabbs(c, boxes.as_ptr(), 50, vp.to_cols_array().as_ptr(), batch.as_mut_ptr());
            assert_eq!(code, 0, "{}", last_error());
            for (b, &got) in boxes.chunks(6).zip(&batch) {
                let one = hom_buffer_test_aabb(c, b.as_ptr(), b[3..].as_ptr(), vp.to_cols_array().as_ptr());
                assert_eq!(got, one, "case {case}");
            }
            assert_eq!(batch[0], HOM_VISIBLE, "a NaN box");
            let mut stats = HomBufferStats::default();
            assert_eq!(hom_buffer_stats(c, &mut stats), 0);
            assert_eq!(stats.triangles_submitted, 6 * 12);
            assert_eq!(stats.tests, 60 + 49 + 49, "NaN boxes are answered before the buffer");
            hom_buffer_free(c);
        }
    }
    assert!(answers.iter().all(|&n| n > 50), "every answer occurs: {answers:?}");
}

/// Misuse: an error code and a message naming the problem, never a crash.
#[test]
fn misuse_is_an_error_not_a_crash() {
    let (corners, indices) = cube();
    let flat: Vec<f32> = corners.concat();
    let m = Mat4::IDENTITY.to_cols_array();
    let nan = [f32::NAN; 16];
    assert!(hom_buffer_new(0, 10, HOM_CLIP_ZERO_TO_ONE).is_null());
    assert!(last_error().contains("1..=16384"), "{}", last_error());
    assert!(hom_buffer_new(10, 10, 7).is_null());
    assert!(last_error().contains("clip convention 7"));
    assert!(hom_buffer_new_kind(9, 10, 10, 0).is_null());
    assert!(last_error().contains("buffer kind 9"));
    let b = hom_buffer_new(64, 48, HOM_CLIP_ZERO_TO_ONE);
    assert!(!b.is_null() && last_error().is_empty());
    // SAFETY: `b` is live; the pointers are valid or deliberately NULL, and the
    // counts match the data except where the call is meant to refuse.
    unsafe {
        let render = |p: *const f32, n, stride, i: *const u32, k, m: *const f32| {
            hom_buffer_render_triangles(b, p, n, stride, i, k, m)
        };
        let check = |got: i32, want: i32, needle: &str| {
            assert_eq!(got, want, "{needle}: {}", last_error());
            assert!(
                last_error().contains(needle),
                "expected '{needle}' in '{}'",
                last_error()
            );
        };
        let (p, i) = (flat.as_ptr(), indices.as_ptr());
        check(
            render(std::ptr::null(), 8, 12, i, 36, m.as_ptr()),
            HOM_ERROR_NULL,
            "positions is NULL",
        );
        check(
            render(p, 8, 12, std::ptr::null(), 36, m.as_ptr()),
            HOM_ERROR_NULL,
            "indices is NULL",
        );
        check(
            render(p, 8, 12, i, 36, std::ptr::null()),
            HOM_ERROR_NULL,
            "model_to_clip is NULL",
        );
        check(render(p, 8, 0, i, 36, m.as_ptr()), HOM_ERROR_INVALID, "stride_bytes 0");
        check(
            render(p, 8, 12, i, 35, m.as_ptr()),
            HOM_ERROR_INVALID,
            "not a multiple of 3",
        );
        check(render(p, 7, 12, i, 36, m.as_ptr()), HOM_ERROR_INVALID, "vertex 7");
        check(render(p, 8, 12, i, 36, nan.as_ptr()), HOM_ERROR_INVALID, "not finite");
        check(
            render(p, usize::MAX / 2, 16, i, 36, m.as_ptr()),
            HOM_ERROR_INVALID,
            "at most",
        );
        let misaligned = (flat.as_ptr() as *const u8).add(1) as *const f32;
        assert_eq!(
            render(misaligned, 8, 12, indices.as_ptr(), 36, m.as_ptr()),
            HOM_ERROR_INVALID
        );
        assert!(last_error().contains("aligned"));
        // Nothing to draw is fine; so is a NaN vertex (its triangles draw nothing).
        assert_eq!(render(std::ptr::null(), 0, 12, std::ptr::null(), 0, m.as_ptr()), 0);
        let mut with_nan = flat.clone();
        with_nan[0] = f32::NAN;
        assert_eq!(
            render(with_nan.as_ptr(), 8, 12, indices.as_ptr(), 36, m.as_ptr()),
            0,
            "{}",
            last_error()
        );
        // A NaN box is never occluded; NULL boxes and buffers are errors.
        let (lo, hi) = ([f32::NAN, 0.0, 0.0], [1.0f32, 1.0, 1.0]);
        assert_eq!(
            hom_buffer_test_aabb(b, lo.as_ptr(), hi.as_ptr(), m.as_ptr()),
            HOM_VISIBLE
        );
        assert_eq!(
            hom_buffer_test_aabb(b, std::ptr::null(), hi.as_ptr(), m.as_ptr()),
            HOM_ERROR_NULL
        );
        assert_eq!(
            hom_buffer_test_aabb(std::ptr::null_mut(), lo.as_ptr(), hi.as_ptr(), m.as_ptr()),
            HOM_ERROR_NULL
        );
        assert!(last_error().contains("buffer is NULL"));
        assert_eq!(hom_buffer_clear(std::ptr::null_mut()), HOM_ERROR_NULL);
        let mut out = [0i32; 2];
        let two = [0.0f32, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0];
        assert_eq!(
            hom_buffer_test_aabbs(b, two.as_ptr(), 2, m.as_ptr(), std::ptr::null_mut()),
            HOM_ERROR_NULL
        );
        assert!(last_error().contains("results is NULL"));
        assert_eq!(
            hom_buffer_test_aabbs(b, std::ptr::null(), 2, m.as_ptr(), out.as_mut_ptr()),
            HOM_ERROR_NULL
        );
        assert_eq!(
            hom_buffer_test_aabbs(b, two.as_ptr(), usize::MAX, m.as_ptr(), out.as_mut_ptr()),
            HOM_ERROR_INVALID
        );
        assert_eq!(
            hom_buffer_test_aabbs(b, std::ptr::null(), 0, m.as_ptr(), std::ptr::null_mut()),
            0
        );
        assert_eq!(hom_buffer_stats(b, std::ptr::null_mut()), HOM_ERROR_NULL);
        assert_eq!(hom_buffer_test_rect(b, -0.5, -0.5, 0.5, 0.5, 0.9), HOM_VISIBLE);
        hom_buffer_free(b);
        hom_buffer_free(std::ptr::null_mut());
    }
}

/// `include/hom.h` is what cbindgen (pinned in Cargo.toml) makes of the
/// source with `cbindgen.toml`; `HOM_BLESS_HEADER=1` rewrites it.
#[test]
fn the_header_is_cbindgens_output() {
    let dir = env!("CARGO_MANIFEST_DIR");
    let config = cbindgen::Config::from_file(format!("{dir}/cbindgen.toml")).expect("cbindgen.toml");
    let mut out = Vec::new();
    cbindgen::Builder::new()
        .with_src(format!("{dir}/src/lib.rs"))
        .with_config(config)
        .generate()
        .expect("cbindgen reads the source")
        .write(&mut out);
    let generated = String::from_utf8(out).expect("UTF-8");
    let path = format!("{dir}/include/hom.h");
    if std::env::var_os("HOM_BLESS_HEADER").is_some() {
        std::fs::write(&path, &generated).expect("writing include/hom.h");
    }
    let checked_in = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        generated == checked_in,
        "include/hom.h is stale: regenerate it with HOM_BLESS_HEADER=1 cargo test -p hom-capi"
    );
}

/// A scene built through the C ABI and culled there gives the same visible
/// ids as the same scene culled in Rust, frame after frame with objects
/// moving and one removed, for every culler kind, and never culls an object
/// the oracle (the reference renderer's item buffer) sees; the ids come
/// ascending and the count says when the caller's array was too short.
#[test]
fn scene_culls_equal_rusts() {
    use hom::cull::{CullOutput, Culler, FrustumCuller, HomConfig, HomCuller as Hom, HzbCuller, MaskedCuller};
    let (corners, indices) = cube();
    let flat: Vec<f32> = corners.concat();
    let mut rng = Rng::new(0x1234_5678_9abc_def1);
    let mut rust = hom::scene::Scene::new("rust");
    let points: Vec<Vec3> = corners.iter().map(|&p| Vec3::from(p)).collect();
    let tris: Vec<[u32; 3]> = indices.chunks(3).map(|t| [t[0], t[1], t[2]]).collect();
    let mesh = rust.add_mesh(hom::scene::Mesh::new("mesh", points, tris).unwrap());
    let c = hom_scene_new();
    // SAFETY: `c` and the cullers are live; every pointer points at what its count says.
    unsafe {
        assert_eq!(
            hom_scene_add_mesh(c, flat.as_ptr(), 8, 12, indices.as_ptr(), 36),
            i64::from(mesh)
        );
        let mut models = Vec::new();
        for i in 0..60 {
            let at = Vec3::new(rng.unit() * 30.0 - 15.0, 0.0, rng.unit() * 40.0 - 35.0);
            let size = if i % 6 == 0 {
                Vec3::new(8.0, 6.0, 0.5)
            } else {
                Vec3::splat(0.5 + rng.unit())
            };
            let model = Mat4::from_translation(at) * Mat4::from_scale(size);
            let dynamic = i % 10 == 1;
            let id = if dynamic {
                rust.add_dynamic_object("o", mesh, model)
            } else {
                rust.add_object("o", mesh, model)
            };
            let got = hom_scene_add_object(c, mesh, model.to_cols_array().as_ptr(), i32::from(dynamic));
            assert_eq!(got, i64::from(id.unwrap()), "{}", last_error());
            models.push(model);
        }
        let kinds = [HOM_CULLER_FRUSTUM, HOM_CULLER_HOM, HOM_CULLER_HZB, HOM_CULLER_MASKED];
        let mut rust_cullers: Vec<Box<dyn Culler>> = vec![
            Box::new(FrustumCuller::new(&rust)),
            Box::new(Hom::new(&rust, HomConfig::for_scene(&rust))),
            Box::new(HzbCuller::new(&rust, HomConfig::for_scene(&rust).with_buffer(()))),
            Box::new(MaskedCuller::new(&rust, HomConfig::for_scene(&rust).with_buffer(()))),
        ];
        let c_cullers: Vec<*mut HomCuller> = kinds.iter().map(|&k| hom_culler_new(c, k)).collect();
        assert!(c_cullers.iter().all(|p| !p.is_null()), "{}", last_error());
        let mut culled_some = false;
        let renderer = hom_render::Renderer::new(1).expect("a render thread");
        let mut fb = hom_render::Framebuffer::new(160, 120);
        for frame in 0..12 {
            if frame == 5 {
                rust.remove_object(7).unwrap();
                assert_eq!(hom_scene_remove_object(c, 7), 0);
            }
            for i in (1..60).step_by(10) {
                let model = Mat4::from_translation(Vec3::new(frame as f32 * 0.3, 0.0, 0.0)) * models[i];
                rust.set_transform(i as u32, model).unwrap();
                assert_eq!(hom_scene_set_transform(c, i as u32, model.to_cols_array().as_ptr()), 0);
            }
            let eye = Vec3::new(frame as f32 - 6.0, 1.5, 14.0);
            let camera = hom::geom::Camera::new(eye, Vec3::new(0.0, 1.0, 0.0), Vec3::Y, 1.0, 0.1, 200.0, 160, 120);
            let vp = camera.view_proj();
            // The oracle: every object owning a pixel of the full image must be drawn.
            let pixels = hom_render::oracle_pixel_counts(&renderer, &rust, &camera, &mut fb);
            for (r, &k) in rust_cullers.iter_mut().zip(&c_cullers) {
                let mut out = CullOutput::default();
                let view = hom::geom::View::new(vp, 160, 120, ClipConvention::ZeroToOne);
                r.cull(&rust, &view, &mut out).unwrap();
                let mut ids = vec![u32::MAX; 80];
                let n = hom_culler_cull(
                    k,
                    c,
                    vp.to_cols_array().as_ptr(),
                    160,
                    120,
                    HOM_CLIP_ZERO_TO_ONE,
                    ids.as_mut_ptr(),
                    80,
                );
                assert_eq!(n, out.visible.len() as i64, "{}", last_error());
                assert_eq!(&ids[..n as usize], &out.visible[..], "frame {frame}");
                for (id, &owned) in pixels.iter().enumerate() {
                    let drawn = ids[..n as usize].binary_search(&(id as u32)).is_ok();
                    assert!(
                        owned == 0 || drawn,
                        "{}: object {id} owns {owned} pixels but was culled",
                        r.name()
                    );
                }
                culled_some |= r.name() != "frustum" && !out.occluded.is_empty();
                // A short array: the count, and the first ids.
                let mut two = [0u32; 2];
                let n2 = hom_culler_cull(
                    k,
                    c,
                    vp.to_cols_array().as_ptr(),
                    160,
                    120,
                    HOM_CLIP_ZERO_TO_ONE,
                    two.as_mut_ptr(),
                    2,
                );
                assert_eq!(n2, n);
                assert_eq!(&two[..(n as usize).min(2)], &out.visible[..(n as usize).min(2)]);
                r.cull(&rust, &view, &mut out).unwrap(); // the Rust twin culls twice too
                                                         // Frame times unknown: the cost model, which also learns from the
                                                         // cull's own measured time, could rest one twin and not the other.
                r.frame_done(None);
                assert_eq!(hom_culler_frame_done(k, -1.0), 0);
            }
        }
        assert!(culled_some, "the walls hide something");
        // Misuse.
        assert_eq!(
            hom_scene_add_mesh(c, flat.as_ptr(), 8, 12, indices.as_ptr(), 0),
            i64::from(HOM_ERROR_INVALID)
        );
        assert!(last_error().contains("no triangles"), "{}", last_error());
        assert_eq!(
            hom_scene_add_object(c, 9, Mat4::IDENTITY.to_cols_array().as_ptr(), 0),
            i64::from(HOM_ERROR_INVALID)
        );
        assert!(last_error().contains("mesh 9"), "{}", last_error());
        assert_eq!(
            hom_scene_set_transform(c, 999, Mat4::IDENTITY.to_cols_array().as_ptr()),
            HOM_ERROR_INVALID
        );
        assert_eq!(hom_scene_remove_object(c, 7), HOM_ERROR_INVALID, "removed already");
        assert_eq!(hom_scene_set_occluder(std::ptr::null_mut(), 0, 0), HOM_ERROR_NULL);
        assert!(hom_culler_new(c, 17).is_null() && last_error().contains("culler kind 17"));
        let vp = view_proj(Vec3::new(0.0, 1.5, 14.0), false).to_cols_array();
        let k = c_cullers[1];
        assert_eq!(
            hom_culler_cull(k, c, vp.as_ptr(), 0, 120, 0, std::ptr::null_mut(), 0),
            i64::from(HOM_ERROR_INVALID)
        );
        assert_eq!(
            hom_culler_cull(k, c, vp.as_ptr(), 160, 120, 0, std::ptr::null_mut(), 4),
            i64::from(HOM_ERROR_NULL)
        );
        assert!(
            hom_culler_cull(k, c, vp.as_ptr(), 160, 120, 0, std::ptr::null_mut(), 0) > 0,
            "a count with no array"
        );
        for k in c_cullers {
            hom_culler_free(k);
        }
        hom_culler_free(std::ptr::null_mut());
        hom_scene_free(c);
        hom_scene_free(std::ptr::null_mut());
    }
}

/// Convex stand-ins drawn through the C ABI cover what the front door's
/// do, and a batch big enough to be tested on the pool answers box for box
/// as the front door, counted in the statistics like single tests.
#[test]
fn convex_stand_ins_and_a_pooled_batch_equal_the_front_doors() {
    let (corners, indices) = cube();
    let points: Vec<Vec3> = corners.iter().map(|&p| Vec3::from(p)).collect();
    let tris: Vec<[u32; 3]> = indices.chunks(3).map(|t| [t[0], t[1], t[2]]).collect();
    let mut rng = Rng::new(0x5eed_cafe);
    for case in 0..6 {
        let reversed = case % 2 == 0;
        let (clip, convention) = if reversed {
            (HOM_CLIP_REVERSED_Z, ClipConvention::ReversedZ)
        } else {
            (HOM_CLIP_ZERO_TO_ONE, ClipConvention::ZeroToOne)
        };
        let options = BufferOptions {
            clip: convention,
            ..BufferOptions::default()
        };
        let mut rust = HzBuffer::new(160, 120, options).unwrap();
        let c = hom_buffer_new(160, 120, clip);
        assert!(!c.is_null(), "{}", last_error());
        let vp = view_proj(Vec3::new(rng.unit() * 4.0 - 2.0, 1.5, 14.0), reversed);
        // SAFETY: `c` is live; every pointer below points at what its count says.
        unsafe {
            for _ in 0..8 {
                let at = Vec3::new(rng.unit() * 12.0 - 6.0, 0.0, rng.unit() * 8.0 - 4.0);
                let size = Vec3::new(0.5 + rng.unit() * 4.0, 0.5 + rng.unit() * 4.0, 0.2 + rng.unit());
                let m = vp * Mat4::from_translation(at) * Mat4::from_scale(size);
                let flat: Vec<f32> = corners.iter().flatten().copied().collect();
                let code = hom_buffer_render_convex_stand_in(
                    c,
                    flat.as_ptr(),
                    8,
                    12,
                    indices.as_ptr(),
                    36,
                    m.to_cols_array().as_ptr(),
                );
                assert_eq!(code, 0, "{}", last_error());
                rust.render_convex_stand_in(&points, &tris, &m).unwrap();
            }
            let n = 3000;
            let mut boxes = Vec::with_capacity(6 * n);
            for _ in 0..n {
                let min = [rng.unit() * 16.0 - 8.0, rng.unit() * 2.0, rng.unit() * 30.0 - 20.0];
                boxes.extend(min);
                boxes.extend([min[0] + rng.unit(), min[1] + rng.unit(), min[2] + rng.unit()]);
            }
            boxes[6 * 7 + 4] = f32::NAN;
            let mut got = vec![-9; n];
            let code = hom_buffer_test_aabbs(c, boxes.as_ptr(), n, vp.to_cols_array().as_ptr(), got.as_mut_ptr());
            assert_eq!(code, 0, "{}", last_error());
            let mut counts = [0u64; 3];
            for (k, (b, &g)) in boxes.chunks(6).zip(&got).enumerate() {
                let want = if k == 7 {
                    HOM_VISIBLE
                } else {
                    let aabb = Aabb::new(Vec3::from_slice(&b[..3]), Vec3::from_slice(&b[3..]));
                    match rust.test_aabb(&aabb, &vp) {
                        Visibility::Visible => HOM_VISIBLE,
                        Visibility::Occluded => HOM_OCCLUDED,
                        Visibility::ViewCulled => HOM_VIEW_CULLED,
                    }
                };
                assert_eq!(g, want, "case {case} box {k}");
                counts[g as usize] += 1;
            }
            assert!(counts.iter().all(|&k| k > 100), "every answer occurs: {counts:?}");
            let mut stats = HomBufferStats::default();
            assert_eq!(hom_buffer_stats(c, &mut stats), 0);
            // The NaN box is answered before the buffer, as in single tests.
            assert_eq!(stats.tests, n as u64 - 1, "case {case}");
            assert_eq!(
                (stats.occluded, stats.view_culled),
                (counts[1], counts[2]),
                "case {case}"
            );
            assert_eq!(hom_buffer_clear(c), 0);
            assert_eq!(hom_buffer_stats(c, &mut stats), 0);
            assert_eq!(stats.tests, 0, "a clear empties the pooled counts too");
            hom_buffer_free(c);
        }
    }
}

/// A mesh cut through the C ABI gives the front door's clusters, in order,
/// with the triangle order; a short array is cut and the count says so;
/// bad sizes and meshes are errors.
#[test]
fn clusters_equal_the_front_doors() {
    use hom_occlusion::clusters::{cluster_triangles, ClusterOptions};
    // A 40 × 30 grid of 1 m quads, gently rolling.
    let (w, h) = (40u32, 30u32);
    let mut positions = Vec::new();
    for j in 0..=h {
        for i in 0..=w {
            positions.extend([i as f32, (i as f32 * 0.3).sin() * 0.2, j as f32]);
        }
    }
    let at = |i: u32, j: u32| j * (w + 1) + i;
    let mut indices = Vec::new();
    for j in 0..h {
        for i in 0..w {
            indices.extend([
                at(i, j),
                at(i, j + 1),
                at(i + 1, j),
                at(i + 1, j),
                at(i, j + 1),
                at(i + 1, j + 1),
            ]);
        }
    }
    let points: Vec<Vec3> = positions.chunks(3).map(Vec3::from_slice).collect();
    let tris: Vec<[u32; 3]> = indices.chunks(3).map(|t| [t[0], t[1], t[2]]).collect();
    let options = ClusterOptions {
        max_triangles: 32,
        max_extent: 4.0,
    };
    let want = cluster_triangles(&points, &tris, &options).unwrap();
    let nv = points.len();
    // SAFETY: every pointer points at what its count says.
    unsafe {
        let count = hom_cluster_triangles(
            positions.as_ptr(),
            nv,
            12,
            indices.as_ptr(),
            indices.len(),
            32,
            4.0,
            std::ptr::null_mut(),
            0,
            std::ptr::null_mut(),
        );
        assert_eq!(count, want.clusters.len() as i64, "{}", last_error());
        let mut clusters = vec![HomCluster::default(); count as usize];
        let mut order = vec![u32::MAX; tris.len()];
        let again = hom_cluster_triangles(
            positions.as_ptr(),
            nv,
            12,
            indices.as_ptr(),
            indices.len(),
            32,
            4.0,
            clusters.as_mut_ptr(),
            clusters.len(),
            order.as_mut_ptr(),
        );
        assert_eq!(again, count);
        assert_eq!(order, want.order);
        for (got, c) in clusters.iter().zip(&want.clusters) {
            assert_eq!(got.min, c.bounds.min.to_array());
            assert_eq!(got.max, c.bounds.max.to_array());
            assert_eq!(got.first_triangle..got.first_triangle + got.triangle_count, c.triangles);
        }
        // Bad options and meshes: a code and a message, nothing written.
        let mut one = [HomCluster::default()];
        let mut bad = |max_triangles: u32, extent: f32, idx: &[u32], pos: &[f32]| {
            hom_cluster_triangles(
                pos.as_ptr(),
                pos.len() / 3,
                12,
                idx.as_ptr(),
                idx.len(),
                max_triangles,
                extent,
                one.as_mut_ptr(),
                1,
                std::ptr::null_mut(),
            )
        };
        assert_eq!(bad(0, 4.0, &indices, &positions), i64::from(HOM_ERROR_INVALID));
        assert!(!last_error().is_empty());
        assert_eq!(bad(32, f32::NAN, &indices, &positions), i64::from(HOM_ERROR_INVALID));
        assert_eq!(bad(32, 4.0, &[0, 1, 99_999], &positions), i64::from(HOM_ERROR_INVALID));
        assert!(last_error().contains("99999"), "{}", last_error());
        let mut nan = positions.clone();
        nan[4] = f32::NAN;
        assert_eq!(bad(32, 4.0, &indices, &nan), i64::from(HOM_ERROR_INVALID));
        assert_eq!(one[0], HomCluster::default());
    }
}

/// A 40 m ground of 1 m quads, added cut into clusters: consecutive ids,
/// the Rust twin's cut, one parent; an object added after is the next parent.
#[test]
fn a_clustered_object_is_its_clusters_under_one_parent() {
    let ground = hom_testkit::grid_mesh(40);
    let (points, tris) = (ground.positions().to_vec(), ground.triangles().to_vec());
    let flat: Vec<f32> = points.iter().flat_map(|p| p.to_array()).collect();
    let indices: Vec<u32> = tris.concat();
    let mut rust = hom::scene::Scene::new("rust");
    let mesh = rust.add_mesh(hom::scene::Mesh::new("mesh", points.clone(), tris).unwrap());
    let options = hom::clusters::ClusterOptions::default();
    let want = rust
        .add_clustered_object("ground", mesh, Mat4::IDENTITY, &options)
        .unwrap();
    let c = hom_scene_new();
    let identity = Mat4::IDENTITY.to_cols_array();
    // SAFETY: `c` is live; every pointer points at what its count says.
    unsafe {
        assert_eq!(
            hom_scene_add_mesh(c, flat.as_ptr(), points.len(), 12, indices.as_ptr(), indices.len()),
            0
        );
        let mut count = 0u32;
        let first = hom_scene_add_clustered_object(c, 0, identity.as_ptr(), 64, 3.0, &mut count);
        assert_eq!(
            (first, count),
            (i64::from(want.start), want.end - want.start),
            "{}",
            last_error()
        );
        assert!(count > 50, "3,200 triangles in clusters of at most 64: {count}");
        assert!((0..count).all(|id| hom_scene_parent_of(c, id) == 0));
        let whole = hom_scene_add_object(c, 0, identity.as_ptr(), 0);
        assert_eq!(whole, i64::from(count));
        assert_eq!(hom_scene_parent_of(c, count), 1, "the next object added");
        // Misuse.
        let bad = hom_scene_add_clustered_object(c, 0, identity.as_ptr(), 0, 3.0, std::ptr::null_mut());
        assert_eq!(bad, i64::from(HOM_ERROR_INVALID));
        assert!(last_error().contains("clusters"), "{}", last_error());
        assert_eq!(hom_scene_parent_of(c, count + 1), i64::from(HOM_ERROR_INVALID));
        assert!(last_error().contains("no object"), "{}", last_error());
        assert_eq!(hom_scene_parent_of(std::ptr::null(), 0), i64::from(HOM_ERROR_NULL));
        hom_scene_free(c);
    }
}
