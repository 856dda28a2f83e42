//! The interactive preview window (`cuberay preview`): a winit window with a wgpu
//! surface that shows a scene refined progressively by the headless renderer's kernels.
//!
//! - [`session`]: the GPU side without a window — passes of one sample each, split into
//!   short steps, added to an accumulation; camera, effect and depth changes restart it;
//! - [`controls`]: orbit, pan, zoom and fly as camera geometry;
//! - [`display`]: the display pass (the accumulation's average, clamped and encoded by the
//!   render's `--transfer` like the PNG output);
//! - `window`: the open window and its input, the title (samples per pixel, milliseconds
//!   per frame, rays per second), the frame log and screenshots;
//! - this module: the configuration and the event loop.
//!
//! Each redraw spends at most [`FRAME_BUDGET`] on GPU steps before presenting, so the
//! window keeps responding on big scenes; a frame may finish several passes on small ones.
//! After `N` passes of a session with `spp = N` the picture is `cuberay render --spp N`
//! with the same seed.

pub mod controls;
pub mod display;
pub mod session;
mod window;

use std::path::PathBuf;
use std::time::Duration;

use winit::application::ApplicationHandler;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::window::WindowId;

use crate::error::{Error, Result};
use crate::job::RenderOptions;
use crate::scene::Scene;
use window::View;

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
