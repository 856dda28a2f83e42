// Rays and primitive intersection in f32, the surface at a hit and the spawn offset. Keep in
// sync with their Rust twins of the same names in src/arith/geometry.rs, closest.rs and
// spawn.rs. The intersection tests and the hit points compute in `real`: f32, or f64 in the
// F64 variant (`--precision f64`), from the f32 scene and rays, rounding their answers to
// f32.

#if F64
alias real = f64;
#else
alias real = f32;
#endif
alias vec3r = vec3<real>;

struct Ray {
    o: vec3<f32>,
    d: vec3<f32>,
    // Watertight triangle test: axis permutation and shear (Woop, Benthin, Wald 2013).
    kx: u32,
    ky: u32,
    kz: u32,
    shear: vec3<f32>,
}

fn make_ray(o: vec3<f32>, dir: vec3<f32>) -> Ray {
    let d = normalize(dir);
    let a = abs(d);
    var kz = 2u;
    if a.x >= a.y && a.x >= a.z {
        kz = 0u;
    } else if a.y >= a.z {
        kz = 1u;
    }
    var kx = (kz + 1u) % 3u;
    var ky = (kx + 1u) % 3u;
    if d[kz] < 0.0 {
        let t = kx;
        kx = ky;
        ky = t;
    }
    let shear = vec3<f32>(d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
    return Ray(o, d, kx, ky, kz, shear);
}

// A hit: `ok` says whether there is one; then t and the barycentrics of vertices 1, 2.
struct PrimHit {
    ok: bool,
    t: f32,
    b1: f32,
    b2: f32,
}

fn no_hit() -> PrimHit {
    return PrimHit(false, 0.0, 0.0, 0.0);
}

fn hit_at(t: f32) -> PrimHit {
    return PrimHit(true, t, 0.0, 0.0);
}

// A nearest-hit answer (`closest`, query.wgsl): the primitive and its hit.
struct Closest {
    found: bool,
    prim: u32,
    hit: PrimHit,
}

fn no_closest() -> Closest {
    return Closest(false, NO_ID, no_hit());
}

// Tests primitive `id` for a nearest-hit query (table walk or brute force), keeping the
// nearest hit in `best`, ties to the lower id; every test is against t_max, so the answer
// does not depend on the order of the tests. Returns the distance to beat.
fn consider(id: u32, best: ptr<function, Closest>, ray: Ray, t_max: f32, ray_kind: u32, best_t: f32) -> f32 {
    let p = prims[id];
    count_test(ray_kind, p.kind);
    let h = intersect_prim(p, ray, t_max);
    if h.ok && (h.t < best_t || (h.t == best_t && (*best).found && id < (*best).prim)) {
        (*best).found = true;
        (*best).prim = id;
        (*best).hit = h;
        return h.t;
    }
    return best_t;
}


#if SPHERES
// Ray/sphere, Haines' precise form: the discriminant as r² − |f + b·d|².
fn intersect_sphere(center: vec3<f32>, radius: f32, inside_only: bool, ray: Ray, t_max: f32) -> PrimHit {
    let d = vec3r(ray.d);
    let f = vec3r(ray.o) - vec3r(center);
    let b = -dot(f, d);
    let r2 = real(radius) * real(radius);
    let g = f + d * b;
    let disc = r2 - dot(g, g);
    if disc < 0.0 {
        return no_hit();
    }
    let k = dot(f, f) - r2;
    let q = b + select(-sqrt(disc), sqrt(disc), b >= 0.0);
    if q == 0.0 {
        return no_hit();
    }
    let r0 = k / q;
    let t0 = min(r0, q);
    let t1 = max(r0, q);
    if !inside_only && t0 > 0.0 && t0 < real(t_max) {
        return hit_at(f32(t0));
    }
    if t1 > 0.0 && t1 < real(t_max) {
        return hit_at(f32(t1));
    }
    return no_hit();
}
#endif

#if TRIANGLES
// Ray/triangle, watertight; both sides are hit.
fn intersect_triangle(p0: vec3<f32>, p1: vec3<f32>, p2: vec3<f32>, ray: Ray, t_max: f32) -> PrimHit {
#if F64
    let dr = vec3r(ray.d);
    let s = vec3r(dr[ray.kx] / dr[ray.kz], dr[ray.ky] / dr[ray.kz], 1.0 / dr[ray.kz]);
#else
    let s = ray.shear;
#endif
    let o = vec3r(ray.o);
    let a = vec3r(p0) - o;
    let b = vec3r(p1) - o;
    let c = vec3r(p2) - o;
    let ax = a[ray.kx] - s.x * a[ray.kz];
    let ay = a[ray.ky] - s.y * a[ray.kz];
    let bx = b[ray.kx] - s.x * b[ray.kz];
    let by = b[ray.ky] - s.y * b[ray.kz];
    let cx = c[ray.kx] - s.x * c[ray.kz];
    let cy = c[ray.ky] - s.y * c[ray.kz];
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return no_hit();
    }
    let det = u + v + w;
    if det == 0.0 {
        return no_hit();
    }
    let t_scaled = s.z * (u * a[ray.kz] + v * b[ray.kz] + w * c[ray.kz]);
    let tm = real(t_max);
    if det > 0.0 {
        if t_scaled <= 0.0 || t_scaled >= tm * det {
            return no_hit();
        }
    } else if t_scaled >= 0.0 || t_scaled <= tm * det {
        return no_hit();
    }
    let inv = 1.0 / det;
    let t = t_scaled * inv;
    if !(t > 0.0 && t < tm) {
        return no_hit();
    }
    return PrimHit(true, f32(t), f32(v * inv), f32(w * inv));
}
#endif

#if CYLINDERS
// Outward unit normal of a cone; at a cone's tip any direction across the axis serves.
fn cone_normal(axis: vec3r, slope: real, radial: vec3r) -> vec3r {
    let len = length(radial);
    var radial_dir: vec3r;
    if len > 0.0 {
        radial_dir = radial / len;
    } else {
        radial_dir = any_orthonormal(axis);
    }
    return normalize(radial_dir - axis * slope);
}

// A unit vector orthogonal to unit `v` (the same construction as glam's).
fn any_orthonormal(v: vec3r) -> vec3r {
    let sign = select(real(-1.0), real(1.0), v.z >= 0.0);
    let a = -1.0 / (sign + v.z);
    let b = v.x * v.y * a;
    return vec3r(b, sign + v.y * v.y * a, -v.y);
}

// Ray/cylinder or truncated cone without caps; the discriminant as a difference of
// squared lengths.
fn intersect_cylinder(base: vec4<f32>, apex: vec4<f32>, inside_only: bool, ray: Ray, t_max: f32) -> PrimHit {
    let d = vec3r(ray.d);
    let v = vec3r(apex.xyz) - vec3r(base.xyz);
    let height = length(v);
    let axis = v / height;
    let slope = (real(apex.w) - real(base.w)) / height;
    let w = vec3r(ray.o) - vec3r(base.xyz);
    let s0 = dot(w, axis);
    let ds = dot(d, axis);
    let r_o = w - axis * s0;
    let r_d = d - axis * ds;
    let r0 = real(base.w) + slope * s0;
    let dr = slope * ds;
    let qa = dot(r_d, r_d) - dr * dr;
    let qb = dot(r_o, r_d) - r0 * dr;
    let qc = dot(r_o, r_o) - r0 * r0;
    let e = r_d * r0 - r_o * dr;
    let x = cross(r_o, r_d);
    let disc = dot(e, e) - dot(x, x);
    if disc < 0.0 {
        return no_hit();
    }
    let q = -(qb + select(-sqrt(disc), sqrt(disc), qb >= 0.0));
    if q == 0.0 {
        return no_hit();
    }
    var roots = array<real, 2>(qc / q, 0.0);
    var n_roots = 1u;
    if qa != 0.0 {
        let other = q / qa;
        if other < roots[0] {
            roots[1] = roots[0];
            roots[0] = other;
        } else {
            roots[1] = other;
        }
        n_roots = 2u;
    }
    for (var i = 0u; i < n_roots; i++) {
        let t = roots[i];
        if !(t > 0.0 && t < real(t_max)) {
            continue;
        }
        let s = s0 + t * ds;
        if !(s >= 0.0 && s <= height) {
            continue;
        }
        if inside_only {
            let n = cone_normal(axis, slope, r_o + r_d * t);
            if dot(n, d) <= 0.0 {
                continue;
            }
        }
        return hit_at(f32(t));
    }
    return no_hit();
}
#endif

// The test of `p`'s kind; the module holds the kinds of its scene only (SPHERES,
// TRIANGLES, CYLINDERS), and a kind it lacks never occurs.
fn intersect_prim(p: Prim, ray: Ray, t_max: f32) -> PrimHit {
    let inside_only = (p.flags & FLAG_INSIDE_ONLY) != 0u;
    switch p.kind {
#if SPHERES
        case KIND_SPHERE: {
            return intersect_sphere(p.a.xyz, p.a.w, inside_only, ray, t_max);
        }
#endif
#if CYLINDERS
        case KIND_CYLINDER: {
            return intersect_cylinder(p.a, p.b, inside_only, ray, t_max);
        }
#endif
        default: {
#if TRIANGLES
            return intersect_triangle(p.a.xyz, p.b.xyz, p.c.xyz, ray, t_max);
#else
            return no_hit();
#endif
        }
    }
}

// The surface at a hit.
struct Surface {
    p: vec3<f32>,
    // Unit geometric normal, outward (not flipped toward the ray).
    ng: vec3<f32>,
    // Unit shading normal on the side of `ng`.
    ns: vec3<f32>,
    uv: vec2<f32>,
    has_uv: bool,
    // Size of the numbers behind `p`, for the spawn offset.
    scale: f32,
}

fn max3(v: vec3<f32>) -> f32 {
    return max(v.x, max(v.y, v.z));
}

#if SHADOWS
// Tests primitive `id` for an any-hit query (a shadow ray): a hit at 0 < t < t_max, if any.
// The any-hit twin of `consider`.
fn test_any(id: u32, ray: Ray, t_max: f32) -> PrimHit {
    let p = prims[id];
    count_test(RAY_SHADOW, p.kind);
    return intersect_prim(p, ray, t_max);
}

// The shadow ray towards light `light` from `q`, the spawn origin of a hit (direction
// `to_light`): one ray for every accelerator, so that the tables and brute force answer
// alike. A positional light's ray is traced light-buffer style, from the light towards `q`
// (where its table is keyed), ending a relative SHADOW_END_REL before `q`; a directional
// light's leaves `q`, unbounded. `q_t`: the t of `q` along the ray; `empty`:
// nothing to trace (`q` at the light, or a zero direction).
struct ShadowRay {
    ray: Ray,
    t_max: f32,
    q_t: f32,
    empty: bool,
    from_light: bool,
}

fn shadow_ray(q: vec3<f32>, to_light: vec3<f32>, light: u32) -> ShadowRay {
    let l = lights[light];
    if l.kind != LIGHT_DIRECTIONAL {
        let v = q - l.position;
        let dist = length(v);
        if !(dist > 0.0) {
            return ShadowRay(make_ray(l.position, to_light), 0.0, 0.0, true, true);
        }
        let ray = make_ray(l.position, v);
        return ShadowRay(ray, dist * (1.0 - SHADOW_END_REL), dist, max3(abs(ray.d)) == 0.0, true);
    }
    let ray = make_ray(q, to_light);
    return ShadowRay(ray, FAR, 0.0, max3(abs(ray.d)) == 0.0, false);
}
#endif

// The surface at hit `h` of `prim` (twin: kernel::geometry::surface), for the kinds the
// module holds (see `intersect_prim`). The point comes from the primitive, not the ray:
// interpolated from the barycentrics on a triangle, `o + t·d` projected back onto a sphere
// or cone, so that its rounding error scales with the primitive's coordinates (`scale`) and
// not with how far the ray travelled.
fn surface(prim: Prim, ray: Ray, h: PrimHit) -> Surface {
    var s: Surface;
    s.has_uv = false;
    s.uv = vec2<f32>(0.0);
    let o = vec3r(ray.o);
    let d = vec3r(ray.d);
    switch prim.kind {
#if SPHERES
        case KIND_SPHERE: {
            let c = vec3r(prim.a.xyz);
            let v = o + d * real(h.t) - c;
            let ng = v / length(v);
            s.ng = vec3<f32>(ng);
            s.p = vec3<f32>(c + ng * real(prim.a.w));
            s.ns = s.ng;
            s.scale = max(max3(abs(s.p)), max3(abs(prim.a.xyz)) + prim.a.w);
        }
#endif
#if CYLINDERS
        case KIND_CYLINDER: {
            let base = vec3r(prim.a.xyz);
            let v = vec3r(prim.b.xyz) - base;
            let height = length(v);
            let axis = v / height;
            let slope = (real(prim.b.w) - real(prim.a.w)) / height;
            let w = o + d * real(h.t) - base;
            let along = dot(w, axis);
            let radial = w - axis * along;
            s.ng = vec3<f32>(cone_normal(axis, slope, radial));
            s.ns = s.ng;
            let len = length(radial);
            let radius = real(prim.a.w) + slope * along;
            if len > 0.0 {
                s.p = vec3<f32>(base + axis * along + radial * (radius / len));
            } else {
                s.p = vec3<f32>(base + w);
            }
            let extent = max(max3(abs(prim.a.xyz)), max3(abs(prim.b.xyz)));
            s.scale = max(max3(abs(s.p)), extent);
        }
#endif
        default: {
#if TRIANGLES
            let b1 = real(h.b1);
            let b2 = real(h.b2);
            let b0 = 1.0 - b1 - b2;
            s.p = vec3<f32>(vec3r(prim.a.xyz) * b0 + vec3r(prim.b.xyz) * b1 + vec3r(prim.c.xyz) * b2);
            s.ng = normalize(cross(prim.b.xyz - prim.a.xyz, prim.c.xyz - prim.a.xyz));
            s.ns = s.ng;
            if (prim.flags & FLAG_NORMALS) != 0u {
                let at = tri_attrs[prim.attr];
                let fb0 = f32(b0);
                let n = at.n0.xyz * fb0 + at.n1.xyz * h.b1 + at.n2.xyz * h.b2;
                let len = length(n);
                if len > 1e-12 {
                    let sn = n / len;
                    s.ns = select(sn, -sn, dot(sn, s.ng) < 0.0);
                }
            }
            if (prim.flags & FLAG_UVS) != 0u {
                let at = tri_attrs[prim.attr];
                s.uv = at.uv01.xy * f32(b0) + at.uv01.zw * h.b1 + at.uv2.xy * h.b2;
                s.has_uv = true;
            }
            let extent = max(max3(abs(prim.a.xyz)), max(max3(abs(prim.b.xyz)), max3(abs(prim.c.xyz))));
            s.scale = max(max3(abs(s.p)), extent);
#endif
        }
    }
    return s;
}

// The origin of a ray leaving surface `s` towards `dir`: the hit point moved along the
// geometric normal to the side `dir` goes to, by `s.scale * params.spawn_rel +
// params.spawn_abs` (the render's spawn policy; by default 2⁻²¹ of the magnitude of the
// numbers behind the hit point, 4 f32 ulps of that magnitude: kernel::spawn says why).
fn spawn_origin(s: Surface, dir: vec3<f32>) -> vec3<f32> {
    let side = select(-s.ng, s.ng, dot(dir, s.ng) >= 0.0);
    return s.p + side * spawn_offset(s);
}

// How far `spawn_origin` moves a ray's origin off surface `s`.
fn spawn_offset(s: Surface) -> f32 {
    return s.scale * params.spawn_rel + params.spawn_abs;
}
