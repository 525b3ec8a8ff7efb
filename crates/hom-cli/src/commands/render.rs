//! `hom render`: one frame of a scene's path to a PNG, plain or in false colour.

use crate::args::{HomArgs, RenderArgs};
use crate::setup::{culler_settings, make_culler, open, Walkthrough};
use anyhow::{bail, Result};
use hom::cull::{CullOutput, Culler, HomCuller, PvsCuller};
use hom::pvs::Pvs;
use hom_render::{Framebuffer, RenderOptions, Renderer};
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
    if a.false_colour {
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
        let mut culler = make_culler(&a.view.culler, &w.scene, &a.view.hom)?;
        if let Some(p) = &pvs {
            culler = Box::new(PvsCuller::new(&w.scene, p.clone(), culler)?);
        }
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
) -> Result<Option<hom::map::Pyramid>> {
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
