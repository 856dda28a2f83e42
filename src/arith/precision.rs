//! The precision a scene calls for (`--precision auto`): whether the f32 kernels can
//! resolve the scene as the image shows it, decided from the scene and the image size
//! alone, before anything is built.
//!
//! **The rule.** A ray leaving primitive `p` starts [`SPAWN_OFFSET_REL`] (4 f32 ulps) of the
//! magnitude of `p`'s coordinates, re-centred on the eye, off its surface: that offset `e_p`
//! is the f32 kernels' positional uncertainty on `p` (its hit points are good to about as
//! much, see [`super::geometry::surface`]). The rule compares `e_p` with the *features* it
//! could blur, each the size of a primitive (a sphere's radius, a triangle's shortest
//! altitude, a cylinder's smaller of radius and length) but never less than a pixel's
//! footprint at the primitive's distance from the eye: a detail the image cannot show needs
//! no more precision than the pixel it falls in (so sliver triangles in a mesh never ask
//! for f64). Two comparisons:
//!
//! - `p`'s own feature: `e_p / size_p` at most [`OWN_LIMIT`], `2⁻⁴`. The surface is then
//!   where f32 puts it to within a sixty-fourth of its size, and rays leaving it start
//!   within a sixteenth of it.
//! - the feature of each primitive `q` whose bounding sphere comes within `e_p` of `p`'s
//!   surface, such as a ball resting on the ground: `e_p / size_q` at most
//!   [`CONTACT_LIMIT`], `2⁻⁷`. Around a contact, rays leaving `p` start inside `q`
//!   wherever `q` is nearer `p` than `e_p`: a zone about `√(2·e_p/size_q)` of `q`'s size
//!   across, an eighth of it at the limit. A unit ball on a ground sphere of radius 10⁵ (`e`
//!   0.1) has its shadow and shading wrong within 0.44 of the contact.
//!
//! The scene needs f64 where a comparison is over its limit. The *margin* is the smallest
//! limit-to-ratio quotient: above 1 f32 is enough, by that factor; `info` and `--stats`
//! print it with the comparison that set it. Primitives whose offset is far below the
//! smallest feature anywhere in the scene (under [`CONTACT_LIMIT`] / 4 of it) are not
//! searched for what they touch: the scene's largest offset over its smallest feature
//! bounds them, and the margin printed is then a lower bound ("at least").

use glam::DVec3;

use super::spawn::SPAWN_OFFSET_REL;
use crate::bvh;
use crate::scene::{Aabb, Primitive, Projection, Scene};

/// The largest offset-to-size ratio f32 is trusted with on a primitive's own size, `2⁻⁴`:
/// a sphere of radius 5·10⁻⁵ one unit from the eye is at `2⁻⁶·⁷` (6.6× under it; f32 covers
/// its pixels exactly, `hard::scale::tiny_spheres`).
pub const OWN_LIMIT: f64 = 1.0 / 16.0;

/// The largest offset-to-size ratio f32 is trusted with on the size of what touches a
/// primitive, `2⁻⁷`: a unit ball on a ground sphere of radius 10⁵ is at 0.095 (12× over; f32
/// misses the contact, `hard::scale::contact_on_huge_geometry`); the SPD scenes and the glTF sample
/// models are at least 7× under (`docs/accuracy.md`, "Precision chosen per scene").
pub const CONTACT_LIMIT: f64 = 1.0 / 128.0;

/// What f32 can resolve of a scene, and the one comparison that decided it.
#[derive(Clone, Debug, PartialEq)]
pub struct F32Need {
    /// The limit over the ratio of the comparison with the smallest such quotient (see the
    /// module doc): f32 resolves the scene where it is at least 1. Infinite without
    /// geometry.
    pub margin: f64,
    /// That comparison's `offset / feature`, and its limit ([`OWN_LIMIT`] or
    /// [`CONTACT_LIMIT`]).
    pub ratio: f64,
    pub limit: f64,
    /// Whether the comparison was with what touches the primitive or its own size (`true`),
    /// or the bound of the scene's largest offset over its smallest feature (`false`: the
    /// margin is then at least `margin`).
    pub exact: bool,
    /// The primitive whose spawn offset was compared, and that offset.
    pub offset_prim: Option<usize>,
    pub offset: f64,
    /// The primitive whose feature it was compared with, and that feature.
    pub feature_prim: Option<usize>,
    pub feature: f64,
}

impl F32Need {
    /// Whether the scene needs f64: a comparison is over its limit.
    pub fn needs_f64(&self) -> bool {
        self.margin < 1.0
    }

    /// One line saying why: the offset, the feature and the margin.
    pub fn reason(&self) -> String {
        let (Some(p), Some(q)) = (self.offset_prim, self.feature_prim) else {
            return "no geometry".into();
        };
        let whose = match (self.exact, p == q) {
            (false, _) => format!("the scene's smallest feature (primitive {q})"),
            (true, true) => "its own size".to_string(),
            (true, false) => format!("the size of primitive {q}, which touches it"),
        };
        let at_least = if self.exact { "" } else { "at least " };
        format!(
            "f32's spawn offset on primitive {p} ({:.3e}) is {:.2e} of {whose} ({:.3e}), limit {}: margin {at_least}{:.3}",
            self.offset,
            self.ratio,
            self.feature,
            self.limit,
            self.margin
        )
    }
}

/// One primitive, re-centred on the eye, as the rule sees it.
struct Probe {
    /// The spawn offset of a ray leaving it in f32.
    offset: f64,
    /// Its feature: its size, at least a pixel's footprint at its distance.
    feature: f64,
    /// Its bounding sphere.
    centre: DVec3,
    radius: f64,
}

/// The size of `p` the image could show: a sphere's radius, a triangle's shortest altitude,
/// a cylinder's or cone's smaller of largest radius and length.
fn size(p: &Primitive) -> f64 {
    match p {
        Primitive::Sphere(s) => s.radius,
        Primitive::Triangle(t) => {
            let longest = (0..3).map(|i| (t.p[(i + 1) % 3] - t.p[i]).length()).fold(0.0, f64::max);
            t.cross().length() / longest
        }
        Primitive::Cylinder(c) => c.base_radius.max(c.apex_radius).min((c.apex - c.base).length()),
    }
}

/// How far point `c` is from the surface of `p` (both re-centred alike), at most: exact
/// for spheres and triangles, the distance to the box for cylinders.
fn surface_distance(p: &Primitive, eye: DVec3, c: DVec3) -> f64 {
    match p {
        Primitive::Sphere(s) => ((c - (s.center - eye)).length() - s.radius).abs(),
        Primitive::Triangle(t) => point_triangle_distance(c, [t.p[0] - eye, t.p[1] - eye, t.p[2] - eye]),
        Primitive::Cylinder(_) => {
            let b = p.bounds();
            let (lo, hi) = (b.min - eye, b.max - eye);
            (lo - c).max(c - hi).max(DVec3::ZERO).length()
        }
    }
}

/// The distance from `x` to triangle `v`: to its plane where `x` projects inside it, else
/// to the nearest edge.
fn point_triangle_distance(x: DVec3, v: [DVec3; 3]) -> f64 {
    let n = (v[1] - v[0]).cross(v[2] - v[0]);
    let inside = (0..3).all(|i| (v[(i + 1) % 3] - v[i]).cross(x - v[i]).dot(n) >= 0.0);
    if inside {
        return (x - v[0]).dot(n).abs() / n.length();
    }
    (0..3)
        .map(|i| {
            let (a, b) = (v[i], v[(i + 1) % 3]);
            let ab = b - a;
            let s = ((x - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
            (x - (a + ab * s)).length()
        })
        .fold(f64::INFINITY, f64::min)
}

/// World units a pixel spans per unit of distance from the eye (perspective), or in all
/// (orthographic: `per_distance` false).
fn pixel_span(scene: &Scene, height: u32) -> (f64, bool) {
    let h = height.max(1) as f64;
    match scene.camera.projection {
        Projection::Perspective { fov_y, .. } => (2.0 * (fov_y * 0.5).tan() / h, true),
        Projection::Orthographic { half_height } => (2.0 * half_height / h, false),
    }
}

/// What f32 resolves of `scene` rendered `height` pixels high (see the module doc).
pub fn f32_need(scene: &Scene, height: u32) -> F32Need {
    let eye = scene.camera.eye;
    let (span, per_distance) = pixel_span(scene, height);
    let probes: Vec<Probe> = scene
        .primitives
        .iter()
        .map(|p| {
            let b = p.bounds();
            let magnitude = (b.min - eye).abs().max_element().max((b.max - eye).abs().max_element());
            let (c, r) = p.bounding_sphere();
            let centre = c - eye;
            let footprint = if per_distance { span * (centre.length() - r).max(0.0) } else { span };
            Probe {
                offset: SPAWN_OFFSET_REL as f64 * magnitude,
                feature: size(p).max(footprint),
                centre,
                radius: r,
            }
        })
        .collect();
    let mut need = F32Need {
        margin: f64::INFINITY,
        ratio: 0.0,
        limit: CONTACT_LIMIT,
        exact: true,
        offset_prim: None,
        offset: 0.0,
        feature_prim: None,
        feature: 0.0,
    };
    let Some(smallest) = (0..probes.len()).min_by(|&a, &b| probes[a].feature.total_cmp(&probes[b].feature))
    else {
        return need;
    };
    let take = |need: &mut F32Need, p: usize, q: usize, limit: f64, exact: bool| {
        let ratio = probes[p].offset / probes[q].feature;
        if limit / ratio < need.margin {
            *need = F32Need {
                margin: limit / ratio,
                ratio,
                limit,
                exact,
                offset_prim: Some(p),
                offset: probes[p].offset,
                feature_prim: Some(q),
                feature: probes[q].feature,
            };
        }
    };
    // Primitives whose offset could come near the limit against the smallest feature
    // anywhere are searched for the features they touch; the others are bounded by it.
    let floor = probes[smallest].feature * CONTACT_LIMIT / 4.0;
    let near: Vec<usize> = (0..probes.len()).filter(|&p| probes[p].offset > floor).collect();
    let far = (0..probes.len()).filter(|&p| probes[p].offset <= floor);
    if let Some(largest) = far.max_by(|&a, &b| probes[a].offset.total_cmp(&probes[b].offset)) {
        take(&mut need, largest, smallest, CONTACT_LIMIT, false);
    }
    if near.is_empty() {
        return need;
    }
    let boxes: Vec<_> = probes
        .iter()
        .map(|pr| {
            let r = DVec3::splat(pr.radius);
            bvh::outward_box(&Aabb { min: pr.centre - r, max: pr.centre + r }, 0.0)
        })
        .collect();
    let tree = bvh::build(&boxes);
    for &p in &near {
        take(&mut need, p, p, OWN_LIMIT, true);
        let pr = &probes[p];
        // Bounding spheres within `offset` of p's surface overlap p's box grown by it.
        let reach = pr.radius + pr.offset;
        let (lo, hi) = (pr.centre - DVec3::splat(reach), pr.centre + DVec3::splat(reach));
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let n = tree.nodes[i];
            if (0..3).any(|k| n.min[k] as f64 > hi[k] || (n.max[k] as f64) < lo[k]) {
                continue;
            }
            if !n.is_leaf() {
                stack.extend([n.first as usize, n.first as usize + 1]);
                continue;
            }
            for &q in &tree.order[n.first as usize..(n.first + n.count) as usize] {
                let (q, pq) = (q as usize, &probes[q as usize]);
                if q != p && surface_distance(&scene.primitives[p], eye, pq.centre) <= pq.radius + pr.offset {
                    take(&mut need, p, q, CONTACT_LIMIT, true);
                }
            }
        }
    }
    need
}
