//! The part of an image a render covers: a [`Region`] of pixels, from `--crop` or from the
//! bands of `--tile I/N`. It is plain data that the job, the statistics and the partial
//! images of `cuberay merge` share, and imports nothing but the error type.

use crate::error::{Error, Result};

/// A rectangle of pixels `x0..x1` × `y0..y1` (ends exclusive) of a `width`×`height` image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Region {
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
}

impl Region {
    /// The whole `width`×`height` image.
    pub fn full(width: u32, height: u32) -> Region {
        Region { x0: 0, y0: 0, x1: width, y1: height }
    }

    /// Band `index` of `count` (0-based) of a `height`-row image: rows
    /// `index·⌈H/N⌉ .. min((index+1)·⌈H/N⌉, H)`. A count that would leave any band empty
    /// is refused for every index (so that no task of a split render starts in vain), with
    /// the nearest counts that work.
    pub fn band(index: u32, count: u32, width: u32, height: u32) -> Result<Region> {
        if count == 0 || index >= count {
            return Err(Error::Options(format!("--tile {index}/{count}: the index must be in 0..{count}")));
        }
        if !Self::bands_fill(count, height) {
            let below = (1..count).rev().find(|&n| Self::bands_fill(n, height));
            let above = (count + 1..=height).find(|&n| Self::bands_fill(n, height));
            let near: Vec<String> = below.into_iter().chain(above).map(|n| n.to_string()).collect();
            return Err(Error::Options(format!(
                "--tile {index}/{count}: {count} bands of ⌈{height}/{count}⌉ = {} rows would leave the last \
                 ones of the {height}-row image empty; {} would not",
                height.div_ceil(count),
                near.join(" or ")
            )));
        }
        let rows = height.div_ceil(count);
        let y0 = index * rows;
        Ok(Region { x0: 0, y0, x1: width, y1: ((index + 1) * rows).min(height) })
    }

    /// Whether `count` bands of ⌈H/N⌉ rows leave none of a `height`-row image's bands empty.
    fn bands_fill(count: u32, height: u32) -> bool {
        count <= height && (count - 1) * height.div_ceil(count) < height
    }

    pub fn width(&self) -> u32 {
        self.x1 - self.x0
    }

    pub fn height(&self) -> u32 {
        self.y1 - self.y0
    }

    pub fn pixels(&self) -> u64 {
        self.width() as u64 * self.height() as u64
    }

    pub fn is_full(&self, width: u32, height: u32) -> bool {
        *self == Region::full(width, height)
    }

    /// Whether `other` shares a pixel with this window.
    pub fn overlaps(&self, other: &Region) -> bool {
        self.x0 < other.x1 && other.x0 < self.x1 && self.y0 < other.y1 && other.y0 < self.y1
    }
}

impl std::fmt::Display for Region {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{},{},{},{}", self.x0, self.y0, self.x1, self.y1)
    }
}
