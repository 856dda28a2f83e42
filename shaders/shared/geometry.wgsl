// Rays, the surface at a hit and the spawn offset, in f32 (the primitive tests are in
// intersect.wgsl, the nearest-hit rule in closest.wgsl). Keep in sync with their Rust twins
// of the same names in src/arith/geometry.rs and spawn.rs. Positions (the primitives, ray
// origins, hit points) are `real` (layout.wgsl): f32, or f64 in the F64 variant
// (`--precision f64`); directions are f32.

struct Ray {
    o: vec3r,
    d: vec3<f32>,
    // Watertight triangle test: axis permutation and shear (Woop, Benthin, Wald 2013).
    kx: u32,
    ky: u32,
    kz: u32,
    shear: vec3<f32>,
}

fn make_ray(o: vec3r, dir: vec3<f32>) -> Ray {
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

// The texture coordinates of a triangle's sets 0 and 1 at barycentrics (`b1`, `b2`), and
// whether it has them.
struct UvSets {
    uv0: vec2<f32>,
    has0: bool,
    uv1: vec2<f32>,
    has1: bool,
}

fn uv_sets(p: Prim, b1: f32, b2: f32) -> UvSets {
    var u: UvSets;
    u.has0 = (p.flags & FLAG_UVS) != 0u;
    u.has1 = (p.flags & FLAG_UV1) != 0u;
    if u.has0 || u.has1 {
        let at = tri_attrs[p.attr];
        let b0 = 1.0 - b1 - b2;
        u.uv0 = at.uv01.xy * b0 + at.uv01.zw * b1 + at.uv2_1.xy * b2;
        if u.has1 {
            let more = tri_attrs[p.attr + 1u];
            u.uv1 = at.uv2_1.zw * b0 + more.uv01.xy * b1 + more.uv01.zw * b2;
        }
    }
    return u;
}

// The surface at a hit.
struct Surface {
    p: vec3r,
    // Unit geometric normal, outward (not flipped toward the ray).
    ng: vec3<f32>,
    // Unit shading normal on the side of `ng`.
    ns: vec3<f32>,
    // Texture coordinates of sets 0 and 1.
    uv: UvSets,
    // The vertex colour (white without one; VERTEX_COLORS).
    color: vec3<f32>,
    // A triangle's tangent frame (NORMAL_MAPS, FLAG_TANGENTS): the interpolated unit vertex
    // normal (not turned to `ng`'s side), the unit tangent orthogonal to it, the bitangent's
    // sign; `has_frame` false without one.
    frame_n: vec3<f32>,
    frame_t: vec3<f32>,
    frame_sign: f32,
    has_frame: bool,
    // Size of the numbers behind `p`, for the spawn offset.
    scale: f32,
}

fn max3(v: vec3<f32>) -> f32 {
    return max(v.x, max(v.y, v.z));
}

// The largest magnitude of a position's coordinates, as f32.
fn magnitude(v: vec3r) -> f32 {
    let a = abs(v);
    return f32(max(a.x, max(a.y, a.z)));
}

#if SHADOWS
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

fn shadow_ray(q: vec3r, to_light: vec3<f32>, light: u32) -> ShadowRay {
    let l = lights[light];
    if l.kind != LIGHT_DIRECTIONAL {
        let lp = vec3r(l.position);
        let v = vec3<f32>(q - lp);
        let dist = length(v);
        if !(dist > 0.0) {
            return ShadowRay(make_ray(lp, to_light), 0.0, 0.0, true, true);
        }
        let ray = make_ray(lp, v);
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
    s.uv.has0 = false;
    s.uv.has1 = false;
    s.color = vec3<f32>(1.0);
    s.has_frame = false;
    let o = ray.o;
    let d = vec3r(ray.d);
    switch prim.kind {
#if SPHERES
        case KIND_SPHERE: {
            let c = prim.a.xyz;
            let v = o + d * real(h.t) - c;
            let ng = v / length(v);
            s.ng = vec3<f32>(ng);
            s.p = c + ng * prim.a.w;
            s.ns = s.ng;
            s.scale = max(magnitude(s.p), magnitude(c) + f32(prim.a.w));
        }
#endif
#if CYLINDERS
        case KIND_CYLINDER: {
            let base = prim.a.xyz;
            let v = prim.b.xyz - base;
            let height = length(v);
            let axis = v / height;
            let slope = (prim.b.w - prim.a.w) / height;
            let w = o + d * real(h.t) - base;
            let along = dot(w, axis);
            let radial = w - axis * along;
            s.ng = vec3<f32>(cone_normal(axis, slope, radial));
            s.ns = s.ng;
            let len = length(radial);
            let radius = prim.a.w + slope * along;
            if len > 0.0 {
                s.p = base + axis * along + radial * (radius / len);
            } else {
                s.p = base + w;
            }
            let extent = max(magnitude(prim.a.xyz), magnitude(prim.b.xyz));
            s.scale = max(magnitude(s.p), extent);
        }
#endif
        default: {
#if TRIANGLES
            let b1 = real(h.b1);
            let b2 = real(h.b2);
            let b0 = 1.0 - b1 - b2;
            s.p = prim.a.xyz * b0 + prim.b.xyz * b1 + prim.c.xyz * b2;
            s.ng = vec3<f32>(normalize(cross(prim.b.xyz - prim.a.xyz, prim.c.xyz - prim.a.xyz)));
            s.ns = s.ng;
            // The interpolated vertex normal, unit, on its own side.
            var vn = s.ng;
            if (prim.flags & FLAG_NORMALS) != 0u {
                let at = tri_attrs[prim.attr];
                let fb0 = f32(b0);
                let n = at.n0.xyz * fb0 + at.n1.xyz * h.b1 + at.n2.xyz * h.b2;
                let len = length(n);
                if len > 1e-12 {
                    vn = n / len;
                    s.ns = select(vn, -vn, dot(vn, s.ng) < 0.0);
                }
            }
#if NORMAL_MAPS
            if (prim.flags & FLAG_TANGENTS) != 0u {
                let more = tri_attrs[prim.attr + 1u];
                let v = more.n0.xyz * f32(b0) + more.n1.xyz * h.b1 + more.n2.xyz * h.b2;
                let w = v - vn * dot(vn, v);
                let len = length(w);
                if len > 1e-12 {
                    s.frame_n = vn;
                    s.frame_t = w / len;
                    s.frame_sign = more.n0.w;
                    s.has_frame = true;
                }
            }
#endif
#if VERTEX_COLORS
            if (prim.flags & FLAG_COLORS) != 0u {
                let c = tri_attrs[prim.attr + 2u];
                s.color = c.n0.xyz * f32(b0) + c.n1.xyz * h.b1 + c.n2.xyz * h.b2;
            }
#endif
            s.uv = uv_sets(prim, h.b1, h.b2);
            let extent = max(magnitude(prim.a.xyz), max(magnitude(prim.b.xyz), magnitude(prim.c.xyz)));
            s.scale = max(magnitude(s.p), extent);
#endif
        }
    }
    return s;
}

// The origin of a ray leaving surface `s` towards `dir`: the hit point moved along the
// geometric normal to the side `dir` goes to, by `s.scale * params.spawn_rel +
// params.spawn_abs` (the render's spawn policy; by default 2⁻²¹ of the magnitude of the
// numbers behind the hit point, 4 f32 ulps of that magnitude: kernel::spawn says why).
fn spawn_origin(s: Surface, dir: vec3<f32>) -> vec3r {
    let side = select(-s.ng, s.ng, dot(dir, s.ng) >= 0.0);
    return s.p + vec3r(side) * real(spawn_offset(s));
}

// How far `spawn_origin` moves a ray's origin off surface `s`.
fn spawn_offset(s: Surface) -> f32 {
    return s.scale * params.spawn_rel + params.spawn_abs;
}
