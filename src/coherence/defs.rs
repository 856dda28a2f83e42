//! The origins a build makes direction cubes for, before building: the eye (its cells
//! clipped to the view frustum) and each positional light (its cells where objects lie),
//! each with its sphere, resolution and stored windows. (Rays leaving surfaces have no
//! origin to build for: the kernels send them to the BVH.)

use glam::DVec3;

use super::bounds::sphere_cone;
use super::cells::{cell_span, Cone};
use super::context::Ctx;
use super::flat::OriginKind;
use super::params::BuildParams;
use crate::scene::{Projection, Scene};

/// One origin before building: its kind, its sphere (already inflated), its resolution and
/// stored windows.
#[derive(Clone, Debug)]
pub struct OriginDef {
    pub kind: OriginKind,
    pub center: DVec3,
    pub radius: f64,
    /// Light origins: the light index.
    pub light: Option<usize>,
    pub n: u32,
    /// Per face, the cells searched: `[iu0, iv0, width, height]`, or `None`.
    pub window: [Option<[u32; 4]>; 6],
}

/// Light-origin targets whose bound is wider than this go to the always-test list.
pub const WIDE_THETA: f64 = 0.5;

/// Cell window `[iu0, iv0, width, height]` for a rectangle in face coordinates.
fn to_window(r: [f64; 4], n: u32) -> [u32; 4] {
    let (a, b) = cell_span(r[0], r[1], n);
    let (c, d) = cell_span(r[2], r[3], n);
    [a, c, b - a + 1, d - c + 1]
}

fn union_rect(acc: &mut Option<[f64; 4]>, r: [f64; 4]) {
    *acc = Some(match acc {
        None => r,
        Some(a) => [a[0].min(r[0]), a[1].max(r[1]), a[2].min(r[2]), a[3].max(r[3])],
    });
}

/// The face rectangles of the directions in which some target lies, seen from a point-like
/// origin sphere.
fn object_rects(c: DVec3, r: f64, ctx: &Ctx) -> [Option<[f64; 4]>; 6] {
    let mut rects: [Option<[f64; 4]>; 6] = [None; 6];
    let full = [-1.0, 1.0, -1.0, 1.0];
    let add_cone = |rects: &mut [Option<[f64; 4]>; 6], k: Option<Cone>| match k {
        Some(k) => {
            for (f, rect) in rects.iter_mut().enumerate() {
                if let Some(fr) = k.face_rect(f) {
                    union_rect(rect, fr);
                }
            }
        }
        None => {
            for rect in rects.iter_mut() {
                union_rect(rect, full);
            }
        }
    };
    if ctx.bvh.nodes.is_empty() {
        return rects;
    }
    let mut stack = vec![0u32];
    while let Some(ni) = stack.pop() {
        let node = ctx.bvh.nodes[ni as usize];
        let k = sphere_cone(c, r, node.center, node.radius + ctx.eps, ctx.delta);
        if k.is_some_and(|k| k.theta < 0.15) {
            add_cone(&mut rects, k);
            continue;
        }
        if node.count == 0 {
            stack.push(node.first);
            stack.push(node.first + 1);
            continue;
        }
        for t in &ctx.targets[node.first as usize..(node.first + node.count) as usize] {
            let k = sphere_cone(c, r, t.center, t.radius + ctx.eps, ctx.delta);
            // Wide targets go to the always-test list (see `build_origin`).
            if k.is_some_and(|k| k.theta <= WIDE_THETA) {
                add_cone(&mut rects, k);
            }
        }
    }
    rects
}

/// Face rectangles of the view frustum's directions (the cone over the four image-corner
/// directions, clipped to each face's pyramid), widened by `delta`.
fn frustum_rects(corners: &[DVec3; 4], delta: f64) -> [Option<[f64; 4]>; 6] {
    let mut out = [None; 6];
    for (f, slot) in out.iter_mut().enumerate() {
        let ax = f / 2;
        let s = if f % 2 == 1 { -1.0 } else { 1.0 };
        let (i1, i2) = ((ax + 1) % 3, (ax + 2) % 3);
        let mut poly: Vec<DVec3> = corners.to_vec();
        // Keep s·w[ax] ± w[i] ≥ 0 (Sutherland–Hodgman on the cone's cross-section).
        for (i, sign) in [(i1, 1.0), (i1, -1.0), (i2, 1.0), (i2, -1.0)] {
            let dist = |w: DVec3| s * w[ax] + sign * w[i];
            let mut next = Vec::new();
            for k in 0..poly.len() {
                let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
                let (da, db) = (dist(a), dist(b));
                if da >= 0.0 {
                    next.push(a);
                }
                if (da >= 0.0) != (db >= 0.0) {
                    next.push(a + (b - a) * (da / (da - db)));
                }
            }
            poly = next;
            if poly.is_empty() {
                break;
            }
        }
        let mut rect: Option<[f64; 4]> = None;
        for w in &poly {
            let m = s * w[ax];
            if m > 0.0 {
                let (u, v) = (w[i1] / m, w[i2] / m);
                union_rect(&mut rect, [u, u, v, v]);
            }
        }
        // Gnomonic coordinates change at most 2 per radian on a face.
        *slot =
            rect.map(|r| [r[0] - 2.0 * delta, r[1] + 2.0 * delta, r[2] - 2.0 * delta, r[3] + 2.0 * delta]);
    }
    out
}

fn rect_area(rects: &[Option<[f64; 4]>; 6]) -> f64 {
    rects.iter().flatten().map(|r| ((r[1] - r[0]).max(0.0)) * ((r[3] - r[2]).max(0.0))).sum()
}

/// The eye cube's cells per face edge for pixels `pixel_angle` radians apart (infinite for
/// an orthographic camera): about `eye_pixels_per_cell` pixels a cell.
fn eye_cells(pixel_angle: f64, params: &BuildParams) -> u32 {
    if pixel_angle.is_finite() {
        (2.0 / (pixel_angle * params.eye_pixels_per_cell)).ceil().clamp(16.0, 8192.0) as u32
    } else {
        64
    }
}

/// The eye cube's cells per face edge a build with `params` chooses for `scene` when not
/// told (`BuildParams::eye_n`).
pub fn default_eye_cells(scene: &Scene, params: &BuildParams) -> u32 {
    let (_, h) = params.eye_image(scene);
    match scene.camera.projection {
        Projection::Perspective { fov_y, .. } => eye_cells(fov_y / h as f64, params),
        Projection::Orthographic { .. } => eye_cells(f64::INFINITY, params),
    }
}

pub fn eye_def(scene: &Scene, params: &BuildParams, eps: f64) -> OriginDef {
    let cam = &scene.camera;
    let (w, h) = params.eye_image(scene);
    let corners = [
        cam.ray(0.0, 0.0, w, h),
        cam.ray(w as f64, 0.0, w, h),
        cam.ray(w as f64, h as f64, w, h),
        cam.ray(0.0, h as f64, w, h),
    ];
    let (radius, rects, pixel_angle) = match cam.projection {
        Projection::Perspective { fov_y, .. } => {
            let dirs = corners.map(|c| c.1);
            (eps, frustum_rects(&dirs, params.delta), fov_y / h as f64)
        }
        Projection::Orthographic { .. } => {
            let half_diag = corners.iter().map(|c| (c.0 - cam.eye).length()).fold(0.0, f64::max);
            let k = Cone::new(cam.forward, params.delta);
            let mut rects = [None; 6];
            for (f, r) in rects.iter_mut().enumerate() {
                *r = k.face_rect(f);
            }
            (half_diag + eps, rects, f64::INFINITY)
        }
    };
    let n = params.eye_n.unwrap_or_else(|| eye_cells(pixel_angle, params));
    OriginDef {
        kind: OriginKind::Eye,
        center: cam.eye,
        radius,
        light: None,
        n,
        window: rects.map(|r| r.map(|r| to_window(r, n))),
    }
}

pub fn light_def(i: usize, pos: DVec3, params: &BuildParams, eps: f64, ctx: &Ctx) -> OriginDef {
    let rects = object_rects(pos, eps, ctx);
    let area = rect_area(&rects).max(1e-12);
    let n = params
        .light_n
        .unwrap_or_else(|| (4.0 * params.light_cells as f64 / area).sqrt().clamp(8.0, 16384.0) as u32);
    OriginDef {
        kind: OriginKind::Light,
        center: pos,
        radius: eps,
        light: Some(i),
        n,
        window: rects.map(|r| r.map(|r| to_window(r, n))),
    }
}
