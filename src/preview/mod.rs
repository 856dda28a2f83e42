//! The interactive preview window (`cuberay preview`): a winit window with a wgpu
//! surface that shows a scene refined progressively by the headless renderer's kernels.
//!
//! - [`session`]: the GPU side without a window — passes of one sample each, split into
//!   short steps, added to an accumulation; camera, effect and depth changes restart it;
//! - [`controls`]: orbit, pan, zoom and fly as camera geometry;
//! - [`display`]: the display pass (the accumulation's average, clamped and encoded by the
//!   render's `--transfer` like the PNG output);
//! - this module: the window, input, the title (samples per pixel, milliseconds per frame,
//!   rays per second) and screenshots.
//!
//! Each redraw spends at most [`FRAME_BUDGET`] on GPU steps before presenting, so the
//! window keeps responding on big scenes; a frame may finish several passes on small ones.
//! After `N` passes of a session with `spp = N` the picture is `cuberay render --spp N`
//! with the same seed.

pub mod controls;
pub mod display;
pub mod session;

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use glam::DVec3;
use winit::application::ApplicationHandler;
use winit::dpi::{PhysicalPosition, PhysicalSize};
use winit::event::{ElementState, KeyEvent, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

use crate::error::{Error, Result};
use crate::gpu::{GpuContext, GpuRenderer};
use crate::job::RenderOptions;
use crate::layout::budget::MAX_DEPTH;
use crate::output;
use crate::scene::Scene;
use controls::Controller;
use display::Display;
use session::{Session, Toggles};

/// GPU time a redraw may spend on steps before it presents.
pub const FRAME_BUDGET: Duration = Duration::from_millis(40);

/// What to preview and how.
pub struct Config {
    pub scene: Scene,
    /// Shown in the title and used for screenshot names.
    pub name: String,
    /// The initial image (window) size, the sample lattice (`spp`) and seed, the depth.
    pub opts: RenderOptions,
    /// Exit after this many passes (samples per pixel).
    pub frames: Option<u32>,
    /// Save the last frame here on exit.
    pub screenshot: Option<PathBuf>,
    /// Scripted motion (`--orbit`), for tests and measurement.
    pub orbit: Option<Orbit>,
    /// One JSON object per frame goes here (`--frame-log`).
    pub frame_log: Option<PathBuf>,
}

/// Scripted motion: `degrees` about the look-at point every frame, as a left drag would,
/// from the second frame (whose kernels are compiled and warm) for `frames` frames.
#[derive(Clone, Copy, Debug)]
pub struct Orbit {
    pub degrees: f64,
    pub frames: u32,
}

/// Opens the window and runs until it is closed, Escape is pressed or `--frames` passes
/// are done.
pub fn run(config: Config) -> Result<()> {
    let set = |v: &str| std::env::var_os(v).is_some_and(|s| !s.is_empty());
    if !set("DISPLAY") && !set("WAYLAND_DISPLAY") && !set("WAYLAND_SOCKET") {
        return Err(Error::NoDisplay("neither DISPLAY nor WAYLAND_DISPLAY is set".into()));
    }
    let event_loop = EventLoop::new().map_err(|e| {
        // winit says "os error at <source file>:<line>: <reason>"; keep the reason.
        let text = e.to_string();
        let reason = match text.strip_prefix("os error at ").and_then(|t| t.split_once(": ")) {
            Some((_, reason)) => reason.to_string(),
            None => text,
        };
        Error::NoDisplay(reason)
    })?;
    let mut app = App { config: Some(config), view: None, error: None };
    event_loop.run_app(&mut app).map_err(|e| Error::Window(e.to_string()))?;
    match app.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

struct App {
    /// Taken when the window opens.
    config: Option<Config>,
    view: Option<View>,
    error: Option<Error>,
}

/// An open window and everything that draws into it.
struct View {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    surface_config: wgpu::SurfaceConfiguration,
    gpu: Arc<GpuRenderer>,
    session: Session,
    display: Display,
    controller: Controller,
    name: String,
    frames: Option<u32>,
    screenshot: Option<PathBuf>,
    /// A resize waiting for the next redraw (resizes come in bursts).
    pending_size: Option<PhysicalSize<u32>>,
    camera_moved: bool,
    drag: Option<MouseButton>,
    cursor: Option<PhysicalPosition<f64>>,
    held: HashSet<KeyCode>,
    last_frame: Instant,
    stats: FrameStats,
    screenshots_saved: u32,
    orbit: Option<Orbit>,
    /// Frames drawn so far.
    frame: u64,
    frame_log: Option<std::io::BufWriter<std::fs::File>>,
    /// Grid points traced when the last frame ended.
    points_at: u64,
}

/// Frame times and ray throughput for the title, over about half a second.
struct FrameStats {
    since: Instant,
    frames: u32,
    /// Time spent in those frames (idle time between frames excluded).
    busy: Duration,
    rays_at: u64,
    ms_per_frame: f64,
    rays_per_s: f64,
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        let Some(config) = self.config.take() else { return };
        match View::open(event_loop, config) {
            Ok(v) => {
                v.window.request_redraw();
                self.view = Some(v);
            }
            Err(e) => {
                self.error = Some(e);
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let Some(view) = self.view.as_mut() else { return };
        match view.handle(event) {
            Ok(Flow::Continue) => {}
            Ok(Flow::Exit) => {
                if let Err(e) = view.save_final_screenshot() {
                    self.error = Some(e);
                }
                event_loop.exit();
            }
            Err(e) => {
                self.error = Some(e);
                event_loop.exit();
            }
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        let Some(view) = self.view.as_ref() else { return };
        if view.busy() {
            view.window.request_redraw();
            event_loop.set_control_flow(ControlFlow::Poll);
        } else {
            event_loop.set_control_flow(ControlFlow::Wait);
        }
    }
}

enum Flow {
    Continue,
    Exit,
}

impl View {
    fn open(event_loop: &ActiveEventLoop, config: Config) -> Result<View> {
        let Config { scene, name, opts, frames, screenshot, orbit, frame_log } = config;
        let frame_log = match frame_log {
            Some(path) => Some(std::io::BufWriter::new(
                std::fs::File::create(&path).map_err(|source| Error::Io { path, source })?,
            )),
            None => None,
        };
        let attrs = Window::default_attributes()
            .with_title(format!("cuberay preview: {name}"))
            .with_inner_size(PhysicalSize::new(opts.width, opts.height));
        let window = Arc::new(event_loop.create_window(attrs).map_err(|e| Error::Window(e.to_string()))?);
        let instance = GpuContext::instance(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let surface = instance
            .create_surface(window.clone())
            .map_err(|e| Error::Window(format!("cannot create a GPU surface for the window: {e}")))?;
        let ctx = pollster::block_on(GpuContext::open(&instance, Some(&surface)))?;
        let caps = surface.get_capabilities(&ctx.adapter);
        // The shader encodes sRGB itself on a plain format (as the PNG writer does).
        let format = caps
            .formats
            .iter()
            .copied()
            .find(|f| {
                !f.is_srgb() && matches!(f, wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Rgba8Unorm)
            })
            .or_else(|| caps.formats.first().copied())
            .ok_or_else(|| Error::Window("the GPU cannot present to this window".into()))?;
        let size = window.inner_size();
        let surface_config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            format,
            width: size.width.max(1),
            height: size.height.max(1),
            present_mode: wgpu::PresentMode::AutoVsync,
            desired_maximum_frame_latency: 2,
            alpha_mode: caps.alpha_modes.first().copied().unwrap_or(wgpu::CompositeAlphaMode::Auto),
            view_formats: vec![],
            color_space: wgpu::SurfaceColorSpace::Auto,
        };
        surface.configure(&ctx.device, &surface_config);
        let gpu = Arc::new(GpuRenderer::with_context(ctx));
        let mut opts = opts;
        // The window manager may not grant the size asked for: render what is shown.
        if size.width > 0 && size.height > 0 {
            (opts.width, opts.height) = (size.width, size.height);
        }
        let limit = frames.unwrap_or(opts.spp);
        let controller = Controller::new(&scene);
        let session = Session::new(gpu.clone(), scene, opts, Toggles::default(), limit)?;
        let display = Display::new(&gpu.ctx, format)?;
        log::info!("preview on {} ({:?}), surface {format:?}", gpu.ctx.info.name, gpu.ctx.info.backend);
        Ok(View {
            window,
            surface,
            surface_config,
            gpu,
            session,
            display,
            controller,
            name,
            frames,
            screenshot,
            pending_size: None,
            camera_moved: false,
            drag: None,
            cursor: None,
            held: HashSet::new(),
            last_frame: Instant::now(),
            stats: FrameStats {
                since: Instant::now(),
                frames: 0,
                busy: Duration::ZERO,
                rays_at: 0,
                ms_per_frame: 0.0,
                rays_per_s: 0.0,
            },
            screenshots_saved: 0,
            orbit,
            frame: 0,
            frame_log,
            points_at: 0,
        })
    }

    /// Whether the scripted orbit turns the camera in frame `frame` (0: the first).
    fn orbits_in(&self, frame: u64) -> bool {
        self.orbit.is_some_and(|o| frame >= 1 && frame <= o.frames as u64)
    }

    /// Whether redraws are needed without new input.
    fn busy(&self) -> bool {
        !self.session.is_complete()
            || !self.held.is_empty()
            || self.camera_moved
            || self.pending_size.is_some()
            || self.orbits_in(self.frame)
            || self.session.eye_table() == session::EyeTable::Building
    }

    fn handle(&mut self, event: WindowEvent) -> Result<Flow> {
        match event {
            WindowEvent::CloseRequested => return Ok(Flow::Exit),
            WindowEvent::Resized(size) => {
                self.pending_size = Some(size);
                self.window.request_redraw();
            }
            WindowEvent::RedrawRequested => return self.redraw(),
            WindowEvent::KeyboardInput { event, .. } => return self.key(event),
            WindowEvent::MouseInput { state, button, .. } => {
                self.drag = match state {
                    ElementState::Pressed => Some(button),
                    ElementState::Released => None,
                };
            }
            WindowEvent::CursorMoved { position, .. } => {
                if let (Some(button), Some(last)) = (self.drag, self.cursor) {
                    let (dx, dy) = (position.x - last.x, position.y - last.y);
                    match button {
                        MouseButton::Left => self.controller.orbit(dx, dy),
                        MouseButton::Right | MouseButton::Middle => {
                            self.controller.pan(dx, dy, self.session.options().height)
                        }
                        _ => {}
                    }
                    self.moved();
                }
                self.cursor = Some(position);
            }
            WindowEvent::CursorLeft { .. } => self.cursor = None,
            // Keys released while another window has the focus are never reported.
            WindowEvent::Focused(false) => {
                self.held.clear();
                self.drag = None;
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y as f64,
                    MouseScrollDelta::PixelDelta(p) => p.y / 40.0,
                };
                self.controller.zoom(lines);
                self.moved();
            }
            _ => {}
        }
        Ok(Flow::Continue)
    }

    fn moved(&mut self) {
        self.camera_moved = true;
        self.window.request_redraw();
    }

    fn key(&mut self, event: KeyEvent) -> Result<Flow> {
        let PhysicalKey::Code(code) = event.physical_key else { return Ok(Flow::Continue) };
        if event.state == ElementState::Released {
            self.held.remove(&code);
            return Ok(Flow::Continue);
        }
        if is_fly_key(code) {
            if self.held.insert(code) {
                self.last_frame = Instant::now();
            }
            self.window.request_redraw();
            return Ok(Flow::Continue);
        }
        if event.repeat {
            return Ok(Flow::Continue);
        }
        let mut toggles = self.session.toggles();
        let mut depth = self.session.options().max_depth;
        let effects = self.session.scene().effects();
        match code {
            KeyCode::Escape => return Ok(Flow::Exit),
            KeyCode::KeyR => {
                self.controller.reset();
                self.moved();
                return Ok(Flow::Continue);
            }
            KeyCode::KeyP | KeyCode::F12 => {
                self.save_screenshot_key()?;
                return Ok(Flow::Continue);
            }
            KeyCode::Digit1 if effects.shadows => toggles.shadows ^= true,
            KeyCode::Digit2 if effects.reflection => toggles.reflection ^= true,
            KeyCode::Digit3 if effects.refraction => toggles.refraction ^= true,
            KeyCode::Equal | KeyCode::NumpadAdd => depth = (depth + 1).min(MAX_DEPTH),
            KeyCode::Minus | KeyCode::NumpadSubtract => depth = depth.saturating_sub(1).max(1),
            _ => return Ok(Flow::Continue),
        }
        if toggles != self.session.toggles() || depth != self.session.options().max_depth {
            self.session.set_effects(toggles, depth)?;
            self.update_title();
            self.window.request_redraw();
        }
        Ok(Flow::Continue)
    }

    fn redraw(&mut self) -> Result<Flow> {
        let frame_start = Instant::now();
        if let Some(size) = self.pending_size.take() {
            self.resize(size)?;
        }
        let dt = frame_start.duration_since(self.last_frame).as_secs_f64().min(0.1);
        self.last_frame = frame_start;
        let fly = self.fly_direction();
        if fly != DVec3::ZERO {
            self.controller.fly(fly, dt);
            self.camera_moved = true;
        }
        if let Some(o) = self.orbit.filter(|_| self.orbits_in(self.frame)) {
            self.controller.orbit_degrees(o.degrees);
            self.camera_moved = true;
        }
        let moved = self.camera_moved;
        let t_advance = Instant::now();
        let (mut block, mut depth) = (1, self.session.options().max_depth);
        if self.camera_moved {
            // A moving camera shows a complete coarse image of every view; the full image
            // starts when it rests.
            self.camera_moved = false;
            let took = self.session.set_camera(self.controller.camera().clone());
            log::debug!("eye-dependent update: {:.3} ms", took.as_secs_f64() * 1e3);
            (block, depth) = self.session.trace_coarse()?;
            self.update_title();
        } else {
            self.session.advance(FRAME_BUDGET)?;
        }
        let t_draw = Instant::now();
        self.draw()?;
        log::debug!(
            "frame: advance {:.1} ms, draw {:.1} ms, passes {}",
            (t_draw - t_advance).as_secs_f64() * 1e3,
            t_draw.elapsed().as_secs_f64() * 1e3,
            self.session.passes()
        );
        self.log_frame(frame_start.elapsed(), moved, block, depth)?;
        self.frame += 1;
        self.stats.frames += 1;
        self.stats.busy += frame_start.elapsed();
        let elapsed = self.stats.since.elapsed();
        if elapsed > Duration::from_millis(500) || self.session.is_complete() {
            let rays = self.session.rays()?;
            self.stats.rays_per_s = rays.saturating_sub(self.stats.rays_at) as f64 / elapsed.as_secs_f64();
            self.stats.ms_per_frame = self.stats.busy.as_secs_f64() * 1e3 / self.stats.frames as f64;
            self.stats.rays_at = rays;
            self.stats.since = Instant::now();
            self.stats.frames = 0;
            self.stats.busy = Duration::ZERO;
            self.update_title();
        }
        // A scripted run ends once the camera rests, its samples are in, and the eye's
        // table (if any) is back.
        let orbit_done = self.orbit.is_none_or(|o| self.frame > o.frames as u64);
        let settled = self.session.eye_table() != session::EyeTable::Building;
        if orbit_done && settled && self.frames.is_some_and(|f| self.session.passes() >= f) {
            return Ok(Flow::Exit);
        }
        Ok(Flow::Continue)
    }

    /// One line of `--frame-log` for the frame that took `took`.
    fn log_frame(&mut self, took: Duration, moved: bool, block: u32, depth: u32) -> Result<()> {
        let points = self.session.points_traced();
        // A resize starts a new session, and its count again.
        let traced = points.saturating_sub(self.points_at);
        self.points_at = points;
        let Some(log) = self.frame_log.as_mut() else { return Ok(()) };
        let line = serde_json::json!({
            "frame": self.frame,
            "ms": took.as_secs_f64() * 1e3,
            "moved": moved,
            "block": block,
            "points_traced": traced,
            "passes": self.session.passes(),
            "depth": depth,
            "eye_table": self.session.eye_table().name(),
        });
        use std::io::Write;
        writeln!(log, "{line}")
            .and_then(|_| log.flush())
            .map_err(|e| Error::Window(format!("cannot write the frame log: {e}")))
    }

    fn fly_direction(&self) -> DVec3 {
        let k = |c: KeyCode| if self.held.contains(&c) { 1.0 } else { 0.0 };
        DVec3::new(
            k(KeyCode::KeyD) - k(KeyCode::KeyA),
            k(KeyCode::KeyE) - k(KeyCode::KeyQ),
            k(KeyCode::KeyW) - k(KeyCode::KeyS),
        )
    }

    /// Renders the image at the window's new size (a new session on the same device).
    fn resize(&mut self, size: PhysicalSize<u32>) -> Result<()> {
        if size.width == 0 || size.height == 0 {
            return Ok(());
        }
        self.surface_config.width = size.width;
        self.surface_config.height = size.height;
        self.surface.configure(&self.gpu.ctx.device, &self.surface_config);
        let opts = self.session.options();
        if (opts.width, opts.height) == (size.width, size.height) {
            return Ok(());
        }
        let opts = RenderOptions { width: size.width, height: size.height, ..opts.clone() };
        let mut scene = self.session.scene().clone();
        scene.camera = self.controller.camera().clone();
        let (toggles, limit) = (self.session.toggles(), self.session.limit());
        self.session = Session::new(self.gpu.clone(), scene, opts, toggles, limit)?;
        self.points_at = 0;
        Ok(())
    }

    fn draw(&mut self) -> Result<()> {
        let texture = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t) | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                self.surface.configure(&self.gpu.ctx.device, &self.surface_config);
                return Ok(());
            }
            wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => return Ok(()),
            other => return Err(Error::Window(format!("cannot draw into the window: {other:?}"))),
        };
        let target = texture.texture.create_view(&Default::default());
        self.display.draw(&self.gpu.ctx, &self.session, &target);
        self.window.pre_present_notify();
        self.gpu.ctx.queue.present(texture);
        Ok(())
    }

    fn update_title(&self) {
        let o = self.session.options();
        let t = self.session.toggles();
        let e = self.session.scene().effects();
        let mut flags = Vec::new();
        for (has, on, name) in [
            (e.shadows, t.shadows, "1 shadows"),
            (e.reflection, t.reflection, "2 reflection"),
            (e.refraction, t.refraction && t.reflection, "3 refraction"),
        ] {
            if has {
                flags.push(format!("{name} {}", if on { "on" } else { "off" }));
            }
        }
        let shown = self.session.shown();
        if shown.block > 1 {
            flags.push(format!("moving: {0}x{0} blocks", shown.block));
        }
        if self.session.eye_table() == session::EyeTable::Building {
            flags.push("eye table building (BVH meanwhile)".into());
        }
        let title = format!(
            "cuberay preview: {} | {}/{} spp | {:.1} ms/frame | {} rays/s | depth {} | {}x{}{}{}",
            self.name,
            self.session.passes(),
            self.session.limit(),
            self.stats.ms_per_frame,
            si(self.stats.rays_per_s),
            o.max_depth,
            o.width,
            o.height,
            if flags.is_empty() { "" } else { " | " },
            flags.join(", "),
        );
        self.window.set_title(&title);
    }

    /// P or F12: the next free `cuberay-<scene>-<n>.png` in the current directory.
    fn save_screenshot_key(&mut self) -> Result<()> {
        if self.session.passes() == 0 {
            log::warn!("no sample accumulated yet: no screenshot");
            return Ok(());
        }
        let stem =
            Path::new(&self.name).file_stem().map_or("scene".into(), |s| s.to_string_lossy().to_string());
        let path = loop {
            self.screenshots_saved += 1;
            let p = PathBuf::from(format!("cuberay-{stem}-{}.png", self.screenshots_saved));
            if !p.exists() {
                break p;
            }
        };
        self.write_image(&path)?;
        eprintln!("saved {} ({} spp)", path.display(), self.session.passes());
        Ok(())
    }

    fn save_final_screenshot(&self) -> Result<()> {
        match &self.screenshot {
            Some(path) => self.write_image(path),
            None => Ok(()),
        }
    }

    fn write_image(&self, path: &Path) -> Result<()> {
        let image = self.session.image()?;
        if !image.is_finite() {
            return Err(Error::Gpu(
                "the render produced a non-finite pixel; nothing written (this is a renderer bug)".into(),
            ));
        }
        output::write(&image, path)?;
        Ok(())
    }
}

fn is_fly_key(c: KeyCode) -> bool {
    matches!(c, KeyCode::KeyW | KeyCode::KeyA | KeyCode::KeyS | KeyCode::KeyD | KeyCode::KeyQ | KeyCode::KeyE)
}

/// 1234567 as "1.23 M".
fn si(v: f64) -> String {
    let (v, unit) = if v >= 1e9 {
        (v / 1e9, "G")
    } else if v >= 1e6 {
        (v / 1e6, "M")
    } else if v >= 1e3 {
        (v / 1e3, "k")
    } else {
        (v, "")
    };
    format!("{v:.2} {unit}")
}
