//! `hom view`: a window (winit, X11) that flies through a scene with any
//! culler and shows what it hides.
//!
//! Keys: Space plays or pauses the scene's path (paused, the camera flies:
//! W A S D, Q down, E up, Shift faster, the left mouse button held to
//! look; flying or looking while it plays pauses it where it is); 1–5 choose the culler (none, frustum, hom, hzb, masked); V swaps
//! the occluders' meshes (virtual stand-ins or the originals); F the false
//! colour; I the occlusion buffer's inset; T the line of figures; R starts
//! and stops recording the camera's path to a JSON file that `hom walk
//! --camera-path` and `hom bench --camera-path` read; Escape closes.

use crate::gpu::Gpu;
use crate::offscreen::read_texture;
use crate::viewer::{status_line, Viewer, ViewerOptions};
use crate::ViewError;
use glam::Vec3;
use hom::cull::Culler;
use hom::geom::Camera;
use hom::occluders::OccluderMeshes;
use hom::scene::Scene;
use hom_scene::{Animation, CameraPath, PathFrame};
use hom_walk::cullers::CullerSettings;
use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, KeyEvent, MouseButton, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

/// How often the line of figures is written again: often enough to follow,
/// seldom enough to read.
const FIGURES_EVERY: std::time::Duration = std::time::Duration::from_millis(250);

/// The cullers keys 1 to 5 choose, in that order.
pub const KEY_CULLERS: [&str; 5] = ["none", "frustum", "hom", "hzb", "masked"];

/// How the window starts, and when it closes by itself.
#[derive(Clone, Debug)]
pub struct WindowOptions {
    /// Window width, pixels.
    pub width: u32,
    /// Window height, pixels.
    pub height: u32,
    /// What is drawn besides the scene at the start.
    pub viewer: ViewerOptions,
    /// Play the path's first `n` frames, then close (a smoke run); `None`
    /// opens paused at the path's first frame and stays until closed.
    pub frames: Option<usize>,
    /// Where the last frame is written as a PNG when the window closes.
    pub screenshot: Option<PathBuf>,
    /// Where key R writes the recorded path (a second recording gets `-2`
    /// before the extension, and so on).
    pub record: PathBuf,
    /// Frames per second of scene time (moves dynamic objects), as `hom walk`.
    pub frame_rate: f32,
}

/// What a window session did.
#[derive(Clone, Debug, Default)]
pub struct WindowSummary {
    /// The adapter that drew the frames.
    pub device: String,
    /// Milliseconds between frames, from the second frame on: the cull, the
    /// draw and presenting.
    pub frame_ms: Vec<f64>,
    /// The camera paths written by key R.
    pub recorded: Vec<PathBuf>,
    /// The screenshot written, if any.
    pub screenshot: Option<PathBuf>,
}

/// Opens the window on `scene` (moved by `animation`, its path `path`) with
/// `culler`, and runs until it is closed (or has played `options.frames`);
/// keys 1–5 and V build other cullers for the scene from `settings`. A
/// machine with no display gets [`ViewError::NoDisplay`].
pub fn run(
    scene: Scene,
    animation: Animation,
    path: CameraPath,
    culler: Box<dyn Culler>,
    settings: CullerSettings,
    options: WindowOptions,
) -> Result<WindowSummary, ViewError> {
    path.validate(scene.name())?;
    if std::env::var_os("DISPLAY").is_none_or(|d| d.is_empty()) {
        return Err(ViewError::NoDisplay("DISPLAY is not set".into()));
    }
    let event_loop = EventLoop::new().map_err(|e| ViewError::NoDisplay(e.to_string()))?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let first = path.camera(0);
    let mut app = App {
        fly: Fly::from_camera(&first),
        speed: scene.bounds().extent().length().max(1.0) * 0.08,
        scene,
        animation,
        playing: options.frames.is_some(),
        path,
        settings,
        culler_name: culler.name().to_string(),
        culler,
        options,
        window: None,
        gpu: None,
        surface: None,
        config: None,
        viewer: None,
        path_frame: 0,
        frames_drawn: 0,
        held: HashSet::new(),
        dragging: false,
        cursor: None,
        last: None,
        figures_at: None,
        recording: None,
        summary: WindowSummary::default(),
        error: None,
    };
    event_loop
        .run_app(&mut app)
        .map_err(|e| ViewError::Window(e.to_string()))?;
    match app.error {
        Some(e) => Err(e),
        None => Ok(app.summary),
    }
}

fn make_culler(name: &str, scene: &Scene, settings: &CullerSettings) -> Result<Box<dyn Culler>, ViewError> {
    hom_walk::cullers::make(name, scene, settings).map_err(|e| ViewError::Window(e.to_string()))
}

/// A free camera: where the eye is and where it looks (yaw about +Y, pitch).
#[derive(Clone, Copy, Debug)]
struct Fly {
    eye: Vec3,
    yaw: f32,
    pitch: f32,
}

impl Fly {
    fn from_camera(camera: &Camera) -> Fly {
        let d = camera.forward();
        Fly {
            eye: camera.eye,
            yaw: d.x.atan2(d.z),
            pitch: d.y.clamp(-1.0, 1.0).asin(),
        }
    }

    fn forward(&self) -> Vec3 {
        Vec3::new(
            self.pitch.cos() * self.yaw.sin(),
            self.pitch.sin(),
            self.pitch.cos() * self.yaw.cos(),
        )
    }
}

struct App {
    scene: Scene,
    animation: Animation,
    path: CameraPath,
    settings: CullerSettings,
    culler_name: String,
    culler: Box<dyn Culler>,
    options: WindowOptions,
    window: Option<Arc<Window>>,
    gpu: Option<Gpu>,
    surface: Option<wgpu::Surface<'static>>,
    config: Option<wgpu::SurfaceConfiguration>,
    viewer: Option<Viewer>,
    fly: Fly,
    /// Metres a second the free camera flies.
    speed: f32,
    playing: bool,
    path_frame: usize,
    frames_drawn: usize,
    held: HashSet<KeyCode>,
    dragging: bool,
    cursor: Option<(f64, f64)>,
    last: Option<Instant>,
    /// When the line of figures was last written.
    figures_at: Option<Instant>,
    recording: Option<Vec<PathFrame>>,
    summary: WindowSummary,
    error: Option<ViewError>,
}

impl App {
    fn fail(&mut self, event_loop: &ActiveEventLoop, e: ViewError) {
        self.error.get_or_insert(e);
        event_loop.exit();
    }

    fn start(&mut self, event_loop: &ActiveEventLoop) -> Result<(), ViewError> {
        let attributes = Window::default_attributes()
            .with_title(format!("hom view: {}", self.scene.name()))
            .with_inner_size(winit::dpi::PhysicalSize::new(self.options.width, self.options.height));
        let window = Arc::new(
            event_loop
                .create_window(attributes)
                .map_err(|e| ViewError::Window(e.to_string()))?,
        );
        let target = window.clone();
        let (gpu, surface) = Gpu::with_surface(|instance| {
            instance
                .create_surface(target)
                .map_err(|e| ViewError::Window(e.to_string()))
        })?;
        let caps = surface.get_capabilities(&gpu.adapter);
        // Unencoded formats first: the colours hom's software renderer writes.
        let format = [wgpu::TextureFormat::Bgra8Unorm, wgpu::TextureFormat::Rgba8Unorm]
            .into_iter()
            .find(|f| caps.formats.contains(f))
            .or_else(|| caps.formats.first().copied())
            .ok_or_else(|| ViewError::Window("the surface offers no format".into()))?;
        let mut usage = wgpu::TextureUsages::RENDER_ATTACHMENT;
        if caps.usages.contains(wgpu::TextureUsages::COPY_SRC) {
            usage |= wgpu::TextureUsages::COPY_SRC;
        }
        let size = window.inner_size();
        let config = wgpu::SurfaceConfiguration {
            usage,
            format,
            width: size.width.max(1),
            height: size.height.max(1),
            present_mode: wgpu::PresentMode::AutoNoVsync,
            desired_maximum_frame_latency: 2,
            alpha_mode: caps
                .alpha_modes
                .first()
                .copied()
                .unwrap_or(wgpu::CompositeAlphaMode::Auto),
            view_formats: vec![],
        };
        surface.configure(&gpu.device, &config);
        self.viewer = Some(Viewer::new(&gpu, &self.scene, format, self.options.viewer)?);
        self.summary.device = gpu.describe();
        self.gpu = Some(gpu);
        self.surface = Some(surface);
        self.config = Some(config);
        self.window = Some(window);
        Ok(())
    }

    /// The camera of this frame at the window's size.
    fn camera(&self, width: u32, height: u32) -> Camera {
        let mut camera = if self.playing {
            self.path.camera(self.path_frame)
        } else {
            let p = self.path.camera(0);
            Camera::new(
                self.fly.eye,
                self.fly.eye + self.fly.forward(),
                Vec3::Y,
                p.fov_y,
                p.near,
                p.far,
                width,
                height,
            )
        };
        camera.width = width;
        camera.height = height;
        camera
    }

    fn fly(&mut self, dt: f32) {
        let forward = self.fly.forward();
        let right = forward.cross(Vec3::Y).normalize_or_zero();
        let mut step = Vec3::ZERO;
        for (key, dir) in [
            (KeyCode::KeyW, forward),
            (KeyCode::KeyS, -forward),
            (KeyCode::KeyD, right),
            (KeyCode::KeyA, -right),
            (KeyCode::KeyE, Vec3::Y),
            (KeyCode::KeyQ, -Vec3::Y),
        ] {
            if self.held.contains(&key) {
                step += dir;
            }
        }
        let fast = self.held.contains(&KeyCode::ShiftLeft) || self.held.contains(&KeyCode::ShiftRight);
        let speed = self.speed * if fast { 4.0 } else { 1.0 };
        self.fly.eye += step.normalize_or_zero() * speed * dt;
    }

    fn redraw(&mut self, event_loop: &ActiveEventLoop) -> Result<(), ViewError> {
        if self.gpu.is_none() {
            return Ok(());
        }
        let now = Instant::now();
        let dt = self.last.map_or(0.0, |l| (now - l).as_secs_f64());
        let last_ms = self.last.map(|_| dt * 1e3);
        self.last = Some(now);
        if let Some(ms) = last_ms {
            self.summary.frame_ms.push(ms);
        }
        if !self.playing {
            self.fly(dt as f32);
        }
        let (Some(gpu), Some(surface), Some(config)) = (&self.gpu, &self.surface, &self.config) else {
            return Ok(());
        };
        let texture = match surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t) | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                surface.configure(&gpu.device, config);
                return Ok(());
            }
            wgpu::CurrentSurfaceTexture::Validation => {
                return Err(ViewError::Window("the surface refused its configuration".into()))
            }
            _ => return Ok(()), // timed out, or the window is hidden: try the next frame
        };
        let (width, height) = (config.width, config.height);
        let camera = self.camera(width, height);
        self.animation
            .apply(&mut self.scene, self.frames_drawn as f32 / self.options.frame_rate);
        let occluders = match self.settings.hom.occluders.occluder_db.meshes {
            OccluderMeshes::Virtual => "virtual",
            OccluderMeshes::Original => "original",
        };
        let name = format!("{} ({occluders} occluders)", self.culler_name);
        let frame = if self.playing {
            self.path_frame
        } else {
            self.frames_drawn
        };
        let last_frame = self.options.frames.is_some_and(|n| self.frames_drawn + 1 >= n);
        let refresh = last_frame || self.figures_at.is_none_or(|t| now - t >= FIGURES_EVERY);
        let status = refresh.then(|| status_line(self.scene.name(), &name, frame, last_ms));
        if refresh {
            self.figures_at = Some(now);
        }
        let view = texture.texture.create_view(&Default::default());
        let viewer = self.viewer.as_mut().expect("started");
        viewer.frame(
            gpu,
            &self.scene,
            &camera,
            self.culler.as_mut(),
            &view,
            self.frames_drawn,
            status.as_deref(),
        )?;
        if let Some(frames) = &mut self.recording {
            frames.push(PathFrame {
                eye: camera.eye.to_array(),
                target: camera.target.to_array(),
            });
        }
        self.frames_drawn += 1;
        if last_frame {
            if let Some(file) = self.options.screenshot.clone() {
                screenshot(gpu, &texture.texture, config, &file)?;
                self.summary.screenshot = Some(file);
            }
        }
        texture.present();
        if self.playing {
            self.path_frame = (self.path_frame + 1) % self.path.frames.len();
        }
        if last_frame {
            self.stop_recording()?;
            event_loop.exit();
        }
        Ok(())
    }

    fn key(&mut self, event_loop: &ActiveEventLoop, code: KeyCode) -> Result<(), ViewError> {
        let viewer = self.viewer.as_mut().map(|v| &mut v.options);
        match code {
            KeyCode::Escape => {
                self.stop_recording()?;
                event_loop.exit();
            }
            KeyCode::Space if self.playing => self.take_over(),
            KeyCode::Space => self.playing = true,
            // Flying while the path plays takes the camera where it is.
            KeyCode::KeyW | KeyCode::KeyA | KeyCode::KeyS | KeyCode::KeyD | KeyCode::KeyQ | KeyCode::KeyE
                if self.playing =>
            {
                self.take_over()
            }
            KeyCode::KeyF => viewer.into_iter().for_each(|o| o.overlay = !o.overlay),
            KeyCode::KeyI => viewer.into_iter().for_each(|o| o.inset = !o.inset),
            KeyCode::KeyT => viewer.into_iter().for_each(|o| o.figures = !o.figures),
            KeyCode::KeyR => match self.recording {
                Some(_) => self.stop_recording()?,
                None => self.recording = Some(Vec::new()),
            },
            KeyCode::KeyV => {
                let meshes = &mut self.settings.hom.occluders.occluder_db.meshes;
                *meshes = match meshes {
                    OccluderMeshes::Virtual => OccluderMeshes::Original,
                    OccluderMeshes::Original => OccluderMeshes::Virtual,
                };
                self.culler = make_culler(&self.culler_name, &self.scene, &self.settings)?;
            }
            KeyCode::Digit1 | KeyCode::Digit2 | KeyCode::Digit3 | KeyCode::Digit4 | KeyCode::Digit5 => {
                let i = match code {
                    KeyCode::Digit1 => 0,
                    KeyCode::Digit2 => 1,
                    KeyCode::Digit3 => 2,
                    KeyCode::Digit4 => 3,
                    _ => 4,
                };
                self.culler_name = KEY_CULLERS[i].to_string();
                self.culler = make_culler(&self.culler_name, &self.scene, &self.settings)?;
            }
            _ => {}
        }
        Ok(())
    }

    /// Pauses the path and hands its camera to the free one.
    fn take_over(&mut self) {
        self.fly = Fly::from_camera(&self.path.camera(self.path_frame));
        self.playing = false;
    }

    /// Writes the path recorded so far, if recording.
    fn stop_recording(&mut self) -> Result<(), ViewError> {
        let Some(frames) = self.recording.take() else {
            return Ok(());
        };
        if frames.is_empty() {
            return Ok(());
        }
        let size = self
            .config
            .as_ref()
            .map_or((self.path.width, self.path.height), |c| (c.width, c.height));
        let recorded = recorded_path(&self.path, frames, size);
        let file = numbered(&self.options.record, self.summary.recorded.len());
        let json = serde_json::to_string_pretty(&recorded).map_err(|e| ViewError::Write {
            path: file.clone(),
            source: e.into(),
        })?;
        std::fs::write(&file, json).map_err(|e| ViewError::Write {
            path: file.clone(),
            source: e.into(),
        })?;
        eprintln!(
            "hom view: recorded {} frames to {}",
            recorded.frames.len(),
            file.display()
        );
        self.summary.recorded.push(file);
        Ok(())
    }
}

/// The path of the recorded `frames`: the scene's path's lens, the
/// window's viewport, +Y up (the free camera's).
fn recorded_path(scene_path: &CameraPath, frames: Vec<PathFrame>, (width, height): (u32, u32)) -> CameraPath {
    CameraPath {
        up: [0.0, 1.0, 0.0],
        width,
        height,
        frames,
        ..scene_path.clone()
    }
}

/// `file` for the first recording, then `stem-2.ext`, `stem-3.ext`, ….
fn numbered(file: &Path, earlier: usize) -> PathBuf {
    if earlier == 0 {
        return file.to_path_buf();
    }
    let stem = file
        .file_stem()
        .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
    let name = match file.extension() {
        Some(ext) => format!("{stem}-{}.{}", earlier + 1, ext.to_string_lossy()),
        None => format!("{stem}-{}", earlier + 1),
    };
    file.with_file_name(name)
}

/// The surface's picture as a PNG (its format's channels put in RGBA order).
fn screenshot(
    gpu: &Gpu,
    texture: &wgpu::Texture,
    config: &wgpu::SurfaceConfiguration,
    file: &Path,
) -> Result<(), ViewError> {
    if !config.usage.contains(wgpu::TextureUsages::COPY_SRC) {
        return Err(ViewError::Window(
            "this surface cannot be read back for a screenshot (no COPY_SRC); use --headless".into(),
        ));
    }
    let bytes = read_texture(gpu, texture, config.width, config.height)?;
    let bgra = matches!(
        config.format,
        wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Bgra8UnormSrgb
    );
    let pixels: Vec<[u8; 4]> = bytes
        .chunks_exact(4)
        .map(|p| {
            if bgra {
                [p[2], p[1], p[0], 255]
            } else {
                [p[0], p[1], p[2], 255]
            }
        })
        .collect();
    if let Some(dir) = file.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| ViewError::Write {
            path: dir.to_path_buf(),
            source: e.into(),
        })?;
    }
    hom_render::write_png(file, config.width, config.height, &pixels).map_err(|e| ViewError::Write {
        path: file.to_path_buf(),
        source: e.into(),
    })
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_none() {
            if let Err(e) = self.start(event_loop) {
                self.fail(event_loop, e);
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let result = match event {
            WindowEvent::CloseRequested => {
                let r = self.stop_recording();
                event_loop.exit();
                r
            }
            WindowEvent::Resized(size) => {
                if let (Some(gpu), Some(surface), Some(config)) = (&self.gpu, &self.surface, &mut self.config) {
                    config.width = size.width.max(1);
                    config.height = size.height.max(1);
                    surface.configure(&gpu.device, config);
                }
                Ok(())
            }
            WindowEvent::KeyboardInput {
                event:
                    KeyEvent {
                        physical_key: PhysicalKey::Code(code),
                        state,
                        repeat,
                        ..
                    },
                ..
            } => match state {
                ElementState::Pressed => {
                    self.held.insert(code);
                    if repeat {
                        Ok(())
                    } else {
                        self.key(event_loop, code)
                    }
                }
                ElementState::Released => {
                    self.held.remove(&code);
                    Ok(())
                }
            },
            WindowEvent::MouseInput {
                state,
                button: MouseButton::Left,
                ..
            } => {
                self.dragging = state == ElementState::Pressed;
                if self.dragging && self.playing {
                    self.take_over();
                }
                Ok(())
            }
            WindowEvent::CursorMoved { position, .. } => {
                if let (true, Some((x, y))) = (self.dragging, self.cursor) {
                    self.fly.yaw -= (position.x - x) as f32 * 0.004;
                    self.fly.pitch = (self.fly.pitch - (position.y - y) as f32 * 0.004).clamp(-1.5, 1.5);
                }
                self.cursor = Some((position.x, position.y));
                Ok(())
            }
            WindowEvent::RedrawRequested => self.redraw(event_loop),
            _ => Ok(()),
        };
        if let Err(e) = result {
            self.fail(event_loop, e);
        }
    }

    fn about_to_wait(&mut self, _event_loop: &ActiveEventLoop) {
        if let Some(w) = &self.window {
            w.request_redraw();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_recorded_path_loads_as_a_camera_path_with_the_windows_viewport() {
        let scene_path = CameraPath {
            fov_y_deg: 75.0,
            near: 0.5,
            far: 900.0,
            ..CameraPath::new(vec![PathFrame {
                eye: [0.0, 1.0, 0.0],
                target: [0.0, 1.0, 1.0],
            }])
        };
        let frames: Vec<PathFrame> = (0..5)
            .map(|i| PathFrame {
                eye: [i as f32, 2.0, 0.0],
                target: [i as f32, 2.0, 5.0],
            })
            .collect();
        let recorded = recorded_path(&scene_path, frames.clone(), (640, 360));
        let dir = std::env::temp_dir().join(format!("hom-view-record-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("path.json");
        std::fs::write(&file, serde_json::to_string_pretty(&recorded).unwrap()).unwrap();
        let loaded = CameraPath::load(&file).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(loaded.frames, frames);
        assert_eq!((loaded.width, loaded.height), (640, 360));
        assert_eq!((loaded.fov_y_deg, loaded.near, loaded.far), (75.0, 0.5, 900.0));
        assert_eq!(loaded.camera(4).eye, Vec3::new(4.0, 2.0, 0.0));
    }

    #[test]
    fn later_recordings_are_numbered() {
        let file = Path::new("out/walk.json");
        assert_eq!(numbered(file, 0), PathBuf::from("out/walk.json"));
        assert_eq!(numbered(file, 1), PathBuf::from("out/walk-2.json"));
        assert_eq!(numbered(Path::new("walk"), 2), PathBuf::from("walk-3"));
    }

    #[test]
    fn the_free_camera_starts_looking_where_the_path_looks() {
        let camera = Camera::new(Vec3::ZERO, Vec3::new(1.0, 0.5, -2.0), Vec3::Y, 1.0, 0.1, 100.0, 64, 64);
        let fly = Fly::from_camera(&camera);
        assert!(fly.forward().distance(camera.forward()) < 1e-5);
    }
}
