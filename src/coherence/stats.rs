//! Table statistics for `cuberay info --tables`: sizes, counts and list lengths per origin
//! kind.

use serde::Serialize;

use super::tables::Tables;

/// List-length statistics over the stored cells of one origin kind. A cell's list length
/// counts its own entries plus its origin's always-test entries (what one walk can scan).
#[derive(Clone, Debug, Default, Serialize)]
pub struct KindStats {
    pub origins: usize,
    /// Cells per face edge (the largest, for lights of different resolutions).
    pub n: u32,
    /// Stored cells (windows only).
    pub cells: usize,
    /// Entries in cell lists plus always lists.
    pub entries: usize,
    pub always_entries: usize,
    pub mean_list: f64,
    pub max_list: usize,
}

/// What `info --tables` prints.
#[derive(Clone, Debug, Serialize)]
pub struct TableStats {
    pub build_s: f64,
    pub bytes: usize,
    pub largest_buffer_bytes: usize,
    pub origins: usize,
    pub cells: usize,
    pub entries: usize,
    /// The spawn offset the origins are inflated by.
    pub spawn_offset: f64,
    /// The image size the eye table covers.
    pub eye_image: [u32; 2],
    pub eye: KindStats,
    pub light: KindStats,
}

impl TableStats {
    pub fn of(t: &Tables) -> TableStats {
        let f = &t.flat;
        let mut kinds = [KindStats::default(), KindStats::default()];
        for (o, org) in f.origins.iter().enumerate() {
            // The fallback origin is not a table: its list is every primitive.
            let Some(k) = kinds.get_mut(org.kind as usize) else { continue };
            k.origins += 1;
            k.n = k.n.max(org.n);
            k.always_entries += org.always_count as usize;
            k.entries += org.always_count as usize;
            let mut sum = 0usize;
            let mut cells = 0usize;
            for w in &f.faces[o * 6..o * 6 + 6] {
                for c in w.cell_base..w.cell_base + w.width * w.height {
                    let len = (f.cell_start[c as usize + 1] - f.cell_start[c as usize]) as usize;
                    k.entries += len;
                    sum += len + org.always_count as usize;
                    k.max_list = k.max_list.max(len + org.always_count as usize);
                    cells += 1;
                }
            }
            if cells == 0 {
                k.max_list = k.max_list.max(org.always_count as usize);
            }
            k.cells += cells;
            k.mean_list += sum as f64;
        }
        for k in &mut kinds {
            k.mean_list = if k.cells > 0 { k.mean_list / k.cells as f64 } else { 0.0 };
        }
        let [eye, light] = kinds;
        TableStats {
            build_s: t.build_s,
            bytes: f.bytes(),
            largest_buffer_bytes: f.largest_buffer_bytes(),
            origins: f.origins.len(),
            cells: f.cells(),
            entries: f.entries.len(),
            spawn_offset: t.eps,
            eye_image: [t.eye_image.0, t.eye_image.1],
            eye,
            light,
        }
    }

    /// A few human-readable lines.
    pub fn to_text(&self) -> String {
        let mut s = format!(
            "tables:     {} origins, {} cells, {} entries, {:.1} MiB, built in {:.3} s\n",
            self.origins,
            self.cells,
            self.entries,
            self.bytes as f64 / (1 << 20) as f64,
            self.build_s
        );
        for (name, k) in [("eye", &self.eye), ("light", &self.light)] {
            if k.origins > 0 {
                s += &format!(
                    "  {name:8} {} origins, N = {}, {} cells, {} entries, list length mean {:.2} max {}\n",
                    k.origins, k.n, k.cells, k.entries, k.mean_list, k.max_list
                );
            }
        }
        s
    }
}
