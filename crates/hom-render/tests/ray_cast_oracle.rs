//! The item buffer agrees with a brute-force ray cast at every pixel where the
//! ray cast is unambiguous.

mod common;

use common::{compare_with_ray_cast, scene_of};
use hom::geom::Camera;
use hom::glam::{Mat4, Quat, Vec3};
use hom::scene::Scene;
use hom_render::{Framebuffer, RenderOptions, Renderer, Shading};
use hom_testkit::Rng;
use proptest::prelude::*;
use std::sync::OnceLock;

const W: u32 = 37;
const H: u32 = 29;

fn renderer() -> &'static Renderer {
    static R: OnceLock<Renderer> = OnceLock::new();
    R.get_or_init(|| Renderer::new(2).unwrap())
}

fn render_items(scene: &Scene, ids: &[u32], camera: &Camera, shading: Shading) -> Vec<u32> {
    let mut fb = Framebuffer::new(1, 1);
    let options = RenderOptions {
        shading,
        ..RenderOptions::default()
    };
    renderer().render(scene, ids, camera, &options, &mut fb);
    assert_eq!((fb.width(), fb.height()), (W, H));
    fb.items().to_vec()
}

/// A random small scene: objects of 1..=3 triangles near the origin, some
/// with a rotation/scale/translation transform; and a random camera that may
/// sit among the triangles (so some cross the near plane or lie behind it).
fn random_case(rng: &mut Rng) -> (Scene, Camera) {
    let objects = 1 + (rng.next_u64() % 5) as usize;
    let mut list = Vec::new();
    for _ in 0..objects {
        let n = 1 + (rng.next_u64() % 3) as usize;
        let tris: Vec<[Vec3; 3]> = (0..n)
            .map(|_| {
                let c = rng.vec3(-2.0, 2.0);
                [
                    c + rng.vec3(-1.5, 1.5),
                    c + rng.vec3(-1.5, 1.5),
                    c + rng.vec3(-1.5, 1.5),
                ]
            })
            .collect();
        let transform = if rng.next_u64().is_multiple_of(2) {
            Mat4::IDENTITY
        } else {
            let axis = rng.vec3(-1.0, 1.0).try_normalize().unwrap_or(Vec3::Y);
            Mat4::from_scale_rotation_translation(
                Vec3::splat(rng.range(0.5, 1.5)),
                Quat::from_axis_angle(axis, rng.range(0.0, 6.0)),
                rng.vec3(-1.0, 1.0),
            )
        };
        list.push((tris, transform));
    }
    let scene = scene_of(&list);
    loop {
        let eye = rng.vec3(-6.0, 6.0);
        let target = rng.vec3(-1.0, 1.0);
        let near = rng.range(0.05, 1.0);
        let camera = Camera::new(
            eye,
            target,
            Vec3::Y,
            rng.range(30.0, 110.0).to_radians(),
            near,
            near + rng.range(2.0, 15.0),
            W,
            H,
        );
        if camera.validate().is_ok() {
            return (scene, camera);
        }
    }
}

fn check_case(seed: u64, shading: Shading) -> usize {
    let mut rng = Rng::new(seed);
    let (scene, camera) = random_case(&mut rng);
    check(&scene, &camera, shading, &format!("seed {seed}"))
}

/// Renders every object of `scene` and compares each pixel with the ray
/// cast: no unambiguous mismatch. The number of ambiguous pixels.
fn check(scene: &Scene, camera: &Camera, shading: Shading, case: &str) -> usize {
    let ids: Vec<u32> = (0..scene.objects().len() as u32).collect();
    let items = render_items(scene, &ids, camera, shading);
    let (ambiguous, bad) = compare_with_ray_cast(scene, &ids, camera, &items);
    assert!(
        bad.is_empty(),
        "{case}: {} mismatches (x, y, rendered, ray cast): {:?}",
        bad.len(),
        &bad[..bad.len().min(10)]
    );
    ambiguous
}

/// An object's triangles, then its transform's columns (`None`: the identity).
type PinnedObject = (&'static [[[f32; 3]; 3]], Option<[[f32; 4]; 4]>);

/// A case kept by its numbers: it was found by seed with an earlier test
/// generator (xorshift64*), whose seeds no longer reproduce it: its objects and
/// camera, as `random_case` built them.
struct PinnedCase {
    objects: &'static [PinnedObject],
    eye: [f32; 3],
    target: [f32; 3],
    fov_y: f32,
    near: f32,
    far: f32,
}

impl PinnedCase {
    fn build(&self) -> (Scene, Camera) {
        let list: Vec<(Vec<[Vec3; 3]>, Mat4)> = self
            .objects
            .iter()
            .map(|(tris, m)| {
                let tris = tris.iter().map(|t| t.map(Vec3::from_array)).collect();
                (tris, m.map_or(Mat4::IDENTITY, |m| Mat4::from_cols_array_2d(&m)))
            })
            .collect();
        let (eye, target) = (Vec3::from_array(self.eye), Vec3::from_array(self.target));
        let camera = Camera::new(eye, target, Vec3::Y, self.fov_y, self.near, self.far, W, H);
        (scene_of(&list), camera)
    }
}

/// Seed 4220291595848445930 of the earlier generator: a 0.015-pixel sliver.
const SLIVER: PinnedCase = PinnedCase {
    objects: &[
        (
            &[[
                [-2.2651424, -0.8309717, 0.5166321],
                [-0.03286004, -2.1107223, 1.6214213],
                [-1.6447985, -2.206139, 0.21718264],
            ]],
            None,
        ),
        (
            &[
                [
                    [0.75873744, 2.6594048, 0.4715721],
                    [0.0368039, 0.94835764, 2.621355],
                    [-0.057239175, 1.3455014, 1.4742815],
                ],
                [
                    [1.478322, 2.3639889, -1.9445333],
                    [0.990536, -0.35440445, -1.1189024],
                    [0.96376586, 1.158602, -0.7794349],
                ],
            ],
            Some([
                [-0.5108592, 0.21771708, -0.04328349, 0.0],
                [-0.21734995, -0.51266915, -0.013437543, 0.0],
                [-0.045090847, 0.00456546, 0.5551552, 0.0],
                [0.9133116, -0.6130731, -0.090663195, 1.0],
            ]),
        ),
        (
            &[[
                [2.1565855, 0.8354063, 0.18331742],
                [1.3747283, 1.6937466, 1.3948758],
                [3.1701012, 1.2914051, 0.48923707],
            ]],
            Some([
                [0.5406619, 0.09654108, 0.26335338, 0.0],
                [0.15117058, 0.38141996, -0.4501741, 0.0],
                [-0.23626816, 0.46496138, 0.31460884, 0.0],
                [0.99583447, -0.23035324, 0.10134959, 1.0],
            ]),
        ),
        (
            &[
                [
                    [-0.75995874, 0.9468603, -2.7123218],
                    [-1.5756838, 0.87605095, -1.1575567],
                    [-0.1370039, 0.53268456, -2.700231],
                ],
                [
                    [2.9150095, 1.2304773, -2.3130927],
                    [0.78723836, -0.6073564, -0.78292453],
                    [1.8750072, 0.37886095, -1.5146523],
                ],
                [
                    [-0.3637824, 2.6121492, 1.1205581],
                    [0.1997788, 0.39003545, 0.10870767],
                    [-1.895361, 2.4480984, 1.2163429],
                ],
            ],
            None,
        ),
    ],
    eye: [3.1282272, -0.7413583, -5.208561],
    target: [-0.778558, -0.84049344, 0.6930262],
    fov_y: 1.7173679,
    near: 0.3977262,
    far: 14.995756,
};

/// Seed 7753184023046314728 of the earlier generator, the other case proptest
/// recorded in `ray_cast_oracle.proptest-regressions` (which the property test,
/// run without failure persistence, does not read).
const RECORDED: PinnedCase = PinnedCase {
    objects: &[
        (
            &[
                [
                    [0.28507817, 1.6943326, -0.41676474],
                    [0.30991757, 0.7649325, 0.675483],
                    [0.369241, 1.088487, -1.496238],
                ],
                [
                    [-0.041505575, 1.2840843, 0.26858616],
                    [-0.14400601, 2.0172644, -1.8886538],
                    [-0.3215425, 0.111416936, -1.614501],
                ],
            ],
            Some([
                [0.34532946, -0.0972228, 0.90735734, 0.0],
                [-0.5754193, -0.7761729, 0.1358312, 0.0],
                [0.7082671, -0.5831853, -0.33204585, 0.0],
                [-0.14559424, 0.77580166, 0.6933161, 1.0],
            ]),
        ),
        (
            &[
                [
                    [-1.1639689, 1.2801958, 1.406349],
                    [0.86400604, 2.4545035, 0.8457769],
                    [-0.79230404, 0.36187774, 2.0024102],
                ],
                [
                    [-2.6751685, 2.0693498, 0.71848917],
                    [-1.4607261, 1.5035948, -0.5859735],
                    [-1.2545408, 0.06880534, 0.6504731],
                ],
            ],
            None,
        ),
        (
            &[
                [
                    [0.29585886, -0.26004052, -0.91825527],
                    [-1.1469419, -0.82062066, 1.2796745],
                    [-1.4126148, -1.4803369, 0.72971106],
                ],
                [
                    [2.6912796, -2.873537, -0.54901445],
                    [0.54504395, -2.507855, -1.1915573],
                    [1.7604426, -2.0241823, -0.51917124],
                ],
                [
                    [1.7237847, -2.9374468, 0.4558239],
                    [1.9838793, -0.34140062, 2.126717],
                    [2.8789792, -0.2567308, 0.20595121],
                ],
            ],
            Some([
                [0.68141496, 0.026090315, 0.038660895, 0.0],
                [-0.023843637, 0.6814424, -0.039617155, 0.0],
                [-0.04008554, 0.03817503, 0.68076247, 0.0],
                [-0.7877799, -0.4244516, -0.37832677, 1.0],
            ]),
        ),
        (
            &[[
                [2.9408617, -1.1445997, -2.2006285],
                [1.0195742, 0.69587517, -2.7123797],
                [1.1487424, -0.16665494, -2.2047777],
            ]],
            None,
        ),
        (
            &[
                [
                    [-1.8221868, 2.81004, 2.3707285],
                    [-1.8567295, 2.2119837, 0.31003428],
                    [-1.3444159, 2.0094347, 2.944171],
                ],
                [
                    [-0.21128738, 1.3845334, -0.15937066],
                    [0.73177314, 0.9064746, -1.2499497],
                    [-0.83884406, 0.4178939, -2.0101314],
                ],
            ],
            None,
        ),
    ],
    eye: [-1.180522, 0.84110785, 1.7028217],
    target: [0.7753458, 0.012636304, -0.38860655],
    fov_y: 0.93181556,
    near: 0.40385666,
    far: 7.012331,
};

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, failure_persistence: None, ..ProptestConfig::default() })]

    /// Random scenes and cameras: every unambiguous pixel matches the ray
    /// cast exactly, and ambiguous pixels are a minority of any image.
    #[test]
    fn item_buffer_matches_ray_cast(seed in any::<u64>(), flat in any::<bool>()) {
        let shading = if flat { Shading::Flat } else { Shading::ItemOnly };
        let ambiguous = check_case(seed, shading);
        prop_assert!(ambiguous * 4 <= (W * H) as usize, "seed {seed}: {ambiguous} ambiguous pixels");
    }
}

/// Over many fixed random cases, ambiguous pixels are rare overall.
#[test]
fn ambiguous_pixels_are_rare() {
    let cases = 400u64;
    let ambiguous: usize = (0..cases).map(|s| check_case(s * 7919 + 17, Shading::ItemOnly)).sum();
    let fraction = ambiguous as f64 / (cases as f64 * f64::from(W * H));
    eprintln!("ambiguous fraction {fraction:.4}");
    assert!(fraction < 0.03, "ambiguous fraction {fraction}");
}

/// Denser scenes of many interpenetrating triangles in one view.
#[test]
fn dense_scene_matches_ray_cast() {
    let mut rng = Rng::new(99);
    let mut list = Vec::new();
    for _ in 0..40 {
        let c = rng.vec3(-3.0, 3.0);
        list.push((
            vec![[
                c + rng.vec3(-1.0, 1.0),
                c + rng.vec3(-1.0, 1.0),
                c + rng.vec3(-1.0, 1.0),
            ]],
            Mat4::IDENTITY,
        ));
    }
    let scene = scene_of(&list);
    let camera = Camera::new(Vec3::new(0.5, 1.0, 7.0), Vec3::ZERO, Vec3::Y, 1.0, 0.1, 20.0, W, H);
    let ids: Vec<u32> = (0..40).collect();
    let items = render_items(&scene, &ids, &camera, Shading::ItemOnly);
    let (ambiguous, bad) = compare_with_ray_cast(&scene, &ids, &camera, &items);
    assert!(bad.is_empty(), "{bad:?}");
    assert!(ambiguous * 4 <= (W * H) as usize, "{ambiguous} ambiguous");
}

/// Regression: a 0.015-pixel sliver whose edge passes within a thousandth of a
/// pixel of a sample (the ray caster must call that pixel ambiguous).
#[test]
fn sub_pixel_sliver_case() {
    let (scene, camera) = SLIVER.build();
    check(&scene, &camera, Shading::ItemOnly, "the sliver case");
}

/// Regression: the other recorded case, kept by its numbers.
#[test]
fn recorded_regression_case() {
    let (scene, camera) = RECORDED.build();
    check(&scene, &camera, Shading::ItemOnly, "the recorded case");
}
