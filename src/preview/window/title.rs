//! The window's title (samples per pixel, milliseconds per frame, rays per second, the
//! toggles, a moving camera's blocks, the eye table) and the frame log (`--frame-log`).

use std::time::Duration;

use super::View;
use crate::error::{Error, Result};
use crate::preview::session;

impl View {
    /// One line of `--frame-log` for the frame that took `took`.
    pub(super) fn log_frame(&mut self, took: Duration, moved: bool, block: u32, depth: u32) -> Result<()> {
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

    pub(super) fn update_title(&self) {
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
