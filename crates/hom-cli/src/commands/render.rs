//! `hom render`: one frame of a scene's path to a PNG, plain or in false colour.

use crate::args::{HomArgs, RenderArgs};
use crate::setup::{culler_settings, make_culler, make_culler_after_pvs, open, Walkthrough};
use anyhow::{bail, Context, Result};
use hom::cull::{CullOutput, Culler, HomCuller, PvsCuller};
use hom::geom::Aabb;
use hom::glam::Vec3;
use hom::lod::{LodSelector, LodView};
use hom::pvs::Pvs;
use hom_render::stand_in::view_from;
use hom_render::{Colouring, Framebuffer, RenderOptions, Renderer};
use hom_walk::lod::{coarseness_colours, draw_parts};
use hom_walk::{pictures, WalkOptions};
use std::path::Path;
use std::sync::Arc;

/// Runs `hom render`.
pub fn run(a: RenderArgs) -> Result<()> {
    let mut w = open(&a.view)?;
    if a.frame >= w.path.frames.len() {
        bail!(
            "--frame {} is past the end of the path ({} frames)",
            a.frame,
            w.path.frames.len()
        );
    }
    let renderer = Renderer::new(a.view.threads)?;
    let frame_rate = WalkOptions::default().frame_rate;
    let pvs = a
        .pvs_file
        .as_deref()
        .map(|p| super::pvs::read_for(p, &w.scene))
        .transpose()?;
    if a.lod.lod {
        if a.false_colour {
            bail!("--lod colours by level of detail; --false-colour by fate: give one");
        }
        write_lod_pictures(&mut w, &a, &renderer, pvs.as_ref(), frame_rate)?;
    } else if a.false_colour {
        write_false_colour(
            &mut w,
            &a.view.culler,
            &a.view.hom,
            a.frame,
            &renderer,
            &a.out,
            frame_rate,
            pvs.as_ref(),
        )?;
    } else {
        w.go_to(a.frame, frame_rate);
        let camera = w.path.camera(a.frame);
        let mut culler = make_culler_after_pvs(&a.view.culler, &w.scene, &a.view.hom, pvs.as_ref())?;
        let mut cull = CullOutput::default();
        culler.cull(&w.scene, &camera.to_view(), &mut cull)?;
        let mut fb = Framebuffer::new(camera.width, camera.height);
        renderer.render(&w.scene, &cull.visible, &camera, &RenderOptions::default(), &mut fb);
        fb.save_png(&a.out)?;
    }
    println!("wrote {}", a.out.display());
    Ok(())
}

/// Culls frame `frame` with the named culler and writes it in false colour to
/// `out`. With HOM, also returns that frame's occlusion pyramid (for pictures).
#[allow(clippy::too_many_arguments)]
pub fn write_false_colour(
    w: &mut Walkthrough,
    culler_name: &str,
    hom: &HomArgs,
    frame: usize,
    renderer: &Renderer,
    out: &Path,
    frame_rate: f32,
    pvs: Option<&Arc<Pvs>>,
) -> Result<Option<hom::occlusion::details::Pyramid>> {
    w.go_to(frame, frame_rate);
    let (scene, camera) = (&w.scene, w.path.camera(frame));
    let view = camera.to_view();
    let mut cull = CullOutput::default();
    let pyramid = if let Some(pvs) = pvs {
        // What the PVS hides is occlusion-culled: red, seen through the rest.
        let inner = make_culler(culler_name, scene, hom)?;
        let mut culler = PvsCuller::new(scene, pvs.clone(), inner)?;
        renderer.install(|| culler.cull(scene, &view, &mut cull))?;
        None
    } else if culler_name == "hom" {
        // The concrete type, not a `dyn Culler`: the pyramid is HOM's own.
        let mut culler = HomCuller::new(scene, culler_settings(hom, scene)?.hom);
        renderer.install(|| culler.cull(scene, &view, &mut cull))?;
        culler.pyramid().cloned()
    } else {
        let mut culler = make_culler(culler_name, scene, hom)?;
        renderer.install(|| culler.cull(scene, &view, &mut cull))?;
        None
    };
    let mut fb = Framebuffer::new(camera.width, camera.height);
    let image = pictures::render_false_colour(renderer, scene, &camera, &cull, &mut fb);
    hom_render::write_png(out, camera.width, camera.height, &image)?;
    Ok(pyramid)
}

/// `hom render --lod`: the frame coloured by coarseness, and the same cut from
/// above and behind the eye.
fn write_lod_pictures(
    w: &mut Walkthrough,
    a: &RenderArgs,
    renderer: &Renderer,
    pvs: Option<&Arc<Pvs>>,
    frame_rate: f32,
) -> Result<()> {
    let lod = crate::setup::lod_for(&a.lod, &w.scene)?.expect("--lod given");
    w.go_to(a.frame, frame_rate);
    let (scene, camera) = (&w.scene, w.path.camera(a.frame));
    let view = camera.to_view();
    let mut culler = make_culler_after_pvs(&a.view.culler, scene, &a.view.hom, pvs)?;
    culler.set_occluder_lod(lod.occluder_lod());
    let mut cull = CullOutput::default();
    renderer.install(|| culler.cull(scene, &view, &mut cull))?;
    let lod_view = LodView::new(&view).context("the frame's view has no frustum")?;
    let mut parts = Vec::new();
    let stats = LodSelector::default().select(
        scene,
        &lod.hierarchies,
        &cull.visible,
        &lod_view,
        &lod.options,
        &mut |corners| culler.box_hidden(corners),
        &mut parts,
    )?;
    let colours = coarseness_colours(scene, &lod.hierarchies, &parts);
    let draw = RenderOptions {
        colouring: Colouring::PerPart(&colours),
        ..RenderOptions::default()
    };
    let drawn = draw_parts(scene, &lod.hierarchies, &parts);
    let mut fb = Framebuffer::new(camera.width, camera.height);
    renderer.render_parts(scene, &drawn, &camera, &draw, &mut fb);
    fb.save_png(&a.out)?;
    // From above and behind: the eye's surroundings out to the drawn objects' reach.
    let reach = cull
        .visible
        .iter()
        .map(|&id| scene.object(id).aabb.distance_squared(camera.eye).sqrt())
        .fold(0.0f32, f32::max)
        .clamp(20.0, 400.0);
    let forward = (camera.target - camera.eye).normalize_or(Vec3::Z);
    let centre = camera.eye + forward * reach * 0.5;
    let around = Aabb::new(centre - Vec3::splat(reach * 0.5), centre + Vec3::splat(reach * 0.5));
    let mut above = view_from(&around, Vec3::Y * 2.0 - forward, camera.width.max(camera.height));
    above.far = above.far.max(4.0 * reach);
    renderer.render_parts(scene, &drawn, &above, &draw, &mut fb);
    let stem = a.out.with_extension("");
    let above_path = Path::new(&format!("{}-above.png", stem.display())).to_path_buf();
    fb.save_png(&above_path)?;
    println!(
        "lod: {} triangles in {} nodes ({} kept coarse as hidden), max error {:.2} px; wrote {}",
        stats.triangles,
        stats.nodes_drawn,
        stats.nodes_occluded,
        stats.max_error_px,
        above_path.display()
    );
    Ok(())
}
