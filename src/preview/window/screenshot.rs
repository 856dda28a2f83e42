//! Screenshots: P or F12 saves the next free `cuberay-<scene>-<n>.png`, and `--screenshot`
//! the last frame on exit.

use std::path::{Path, PathBuf};

use super::View;
use crate::error::{Error, Result};
use crate::output;

impl View {
    /// P or F12: the next free `cuberay-<scene>-<n>.png` in the current directory.
    pub(super) fn save_screenshot_key(&mut self) -> Result<()> {
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

    pub(in crate::preview) fn save_final_screenshot(&self) -> Result<()> {
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
