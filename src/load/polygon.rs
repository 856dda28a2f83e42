//! Triangulating the NFF loader's planar polygons (possibly concave, as the gears' 144-vertex
//! faces are) by ear clipping in the polygon's plane.

use glam::{DVec2, DVec3};

/// Ear clipping of a planar polygon, with reusable buffers.
///
/// The polygon is projected onto the coordinate plane that drops the dominant axis of its
/// Newell normal, oriented so that it turns counter-clockwise. An ear is a strictly convex
/// vertex whose triangle holds no other vertex (boundary included). A vertex whose two
/// edges are collinear (or of zero length: repeated vertices) is clipped at once: its
/// triangle has no area and removing it leaves the outline unchanged. Every polygon of n
/// vertices gives exactly n − 2 triangles, in the polygon's winding; the caller drops the
/// degenerate ones.
#[derive(Default)]
pub struct Triangulator {
    points: Vec<DVec2>,
    prev: Vec<usize>,
    next: Vec<usize>,
    /// The result: vertex indices into the polygon, counter-clockwise like the polygon.
    pub triangles: Vec<[usize; 3]>,
}

impl Triangulator {
    /// Fills `self.triangles`. Returns false when the polygon is not simple, i.e. some step
    /// found no ear and had to clip a vertex regardless.
    pub fn triangulate(&mut self, polygon: &[DVec3]) -> bool {
        let n = polygon.len();
        self.triangles.clear();
        if n < 3 {
            return true;
        }
        if n == 3 {
            self.triangles.push([0, 1, 2]);
            return true;
        }
        // Newell normal, relative to the first vertex for precision.
        let origin = polygon[0];
        let mut normal = DVec3::ZERO;
        for i in 1..n - 1 {
            normal += (polygon[i] - origin).cross(polygon[i + 1] - origin);
        }
        let a = normal.abs();
        let (u, v, w) = if a.x >= a.y && a.x >= a.z {
            (1, 2, 0)
        } else if a.y >= a.z {
            (2, 0, 1)
        } else {
            (0, 1, 2)
        };
        let flip = if normal[w] < 0.0 { -1.0 } else { 1.0 };
        self.points.clear();
        self.points.extend(polygon.iter().map(|p| DVec2::new(p[u] - origin[u], (p[v] - origin[v]) * flip)));
        self.prev.clear();
        self.prev.extend((0..n).map(|i| (i + n - 1) % n));
        self.next.clear();
        self.next.extend((0..n).map(|i| (i + 1) % n));

        let mut simple = true;
        let mut remaining = n;
        let mut i = 0;
        // Vertices examined since the last clip: a whole round without an ear means the
        // polygon is not simple.
        let mut misses = 0;
        while remaining > 3 {
            let (a, c) = (self.prev[i], self.next[i]);
            let clip = match self.corner(a, i, c) {
                Corner::Flat => true,
                Corner::Convex => !self.holds_vertex(a, i, c),
                Corner::Reflex => false,
            };
            if clip || misses >= remaining {
                if !clip {
                    simple = false;
                    i = self.most_convex(i);
                }
                i = self.clip(i);
                remaining -= 1;
                misses = 0;
            } else {
                i = self.next[i];
                misses += 1;
            }
        }
        self.triangles.push([self.prev[i], i, self.next[i]]);
        simple
    }

    fn corner(&self, a: usize, b: usize, c: usize) -> Corner {
        let (pa, pb, pc) = (self.points[a], self.points[b], self.points[c]);
        let (e0, e1) = (pb - pa, pc - pb);
        let cross = e0.perp_dot(e1);
        if cross.abs() <= 1e-12 * e0.length() * e1.length() {
            Corner::Flat
        } else if cross > 0.0 {
            Corner::Convex
        } else {
            Corner::Reflex
        }
    }

    /// Whether any other remaining vertex lies in the counter-clockwise triangle (a, b, c),
    /// boundary included. Vertices at the same place as a, b or c do not count.
    fn holds_vertex(&self, a: usize, b: usize, c: usize) -> bool {
        let (pa, pb, pc) = (self.points[a], self.points[b], self.points[c]);
        let mut j = self.next[c];
        while j != a {
            let p = self.points[j];
            if p != pa
                && p != pb
                && p != pc
                && (pb - pa).perp_dot(p - pa) >= 0.0
                && (pc - pb).perp_dot(p - pb) >= 0.0
                && (pa - pc).perp_dot(p - pc) >= 0.0
            {
                return true;
            }
            j = self.next[j];
        }
        false
    }

    /// The remaining vertex with the most convex corner, starting the search at `start`.
    fn most_convex(&self, start: usize) -> usize {
        let mut best = (f64::NEG_INFINITY, start);
        let mut i = start;
        loop {
            let (pa, pb, pc) = (self.points[self.prev[i]], self.points[i], self.points[self.next[i]]);
            let (e0, e1) = (pb - pa, pc - pb);
            let sine = e0.perp_dot(e1) / (e0.length() * e1.length());
            if sine > best.0 {
                best = (sine, i);
            }
            i = self.next[i];
            if i == start {
                return best.1;
            }
        }
    }

    /// Emits the triangle at vertex `b`, unlinks it and returns the vertex to look at next.
    fn clip(&mut self, b: usize) -> usize {
        let (a, c) = (self.prev[b], self.next[b]);
        self.triangles.push([a, b, c]);
        self.next[a] = c;
        self.prev[c] = a;
        c
    }
}

enum Corner {
    /// Collinear edges or a zero-length edge: no area.
    Flat,
    Convex,
    Reflex,
}
