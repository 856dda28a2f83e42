//! An open window: its state, its input (orbit, pan, zoom, fly, the effect and depth keys),
//! and its frames (camera moves, GPU steps within the frame budget, drawing); the title and
//! the frame log are in `title`, screenshots in `screenshot`.

mod screenshot;
mod title;

use std::collections::HashSet;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use glam::DVec3;
use winit::dpi::{PhysicalPosition, PhysicalSize};
use winit::event::{ElementState, KeyEvent, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::ActiveEventLoop;
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::Window;

use super::controls::Controller;
use super::display::Display;
use super::session::{self, Session, Toggles};
use super::{Config, Flow, Orbit, FRAME_BUDGET};
use crate::error::{Error, Result};
use crate::gpu::{GpuContext, GpuRenderer};
use crate::job::RenderOptions;
use crate::layout::budget::MAX_DEPTH;

/// An open window and everything that draws into it.
pub(super) struct View {
    pub(super) window: Arc<Window>,
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

impl View {
    pub(super) fn open(event_loop: &ActiveEventLoop, config: Config) -> Result<View> {
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
    pub(super) fn busy(&self) -> bool {
        !self.session.is_complete()
            || !self.held.is_empty()
            || self.camera_moved
            || self.pending_size.is_some()
            || self.orbits_in(self.frame)
            || self.session.eye_table() == session::EyeTable::Building
    }

    pub(super) fn handle(&mut self, event: WindowEvent) -> Result<Flow> {
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
}

fn is_fly_key(c: KeyCode) -> bool {
    matches!(c, KeyCode::KeyW | KeyCode::KeyA | KeyCode::KeyS | KeyCode::KeyD | KeyCode::KeyQ | KeyCode::KeyE)
}
