// Whitted shading and the ray trees, as the CPU reference shades (src/reference/shade.rs,
// written independently in f64). A hit sends its radiance to its point and spawns rays, each
// carrying the weight its radiance contributes with, through two hooks that, with the long
// shadow walks, are the only difference between the two kernel forms (`KernelForm`,
// src/job.rs): `spawn_ray` and `send` push into the current pass's queues and add to the
// accumulator in the wavefront kernels, and keep the rays on the invocation's own stack and
// the radiance in its own sum in the `tree` kernel (TREE, tree.wgsl); a shadow walk too long
// to trace at its hit becomes a job in the wavefront and is walked on at once in the tree.

struct Incidence {
    ok: bool,
    dir: vec3<f32>,
    positional: bool,
    radiance: vec3<f32>,
}

// How light `l` reaches point `p`; `ok` false where it contributes nothing.
fn incidence(l: Light, p: vec3r) -> Incidence {
    var inc: Incidence;
    inc.ok = false;
    inc.positional = l.kind != LIGHT_DIRECTIONAL;
    if l.kind == LIGHT_DIRECTIONAL {
        inc.dir = -l.direction;
        inc.radiance = l.radiance;
        inc.ok = max3(l.radiance) > 0.0;
        return inc;
    }
    let to = vec3<f32>(vec3r(l.position) - p);
    let d = length(to);
    if !(d > 0.0) {
        return inc;
    }
    inc.dir = to / d;
    var scale = 1.0;
    if l.inverse_square != 0u {
        scale /= d * d;
    }
    if l.range > 0.0 {
        let q = d / l.range;
        scale *= clamp(1.0 - q * q * q * q, 0.0, 1.0);
    }
    if l.kind == LIGHT_SPOT {
        let a = clamp((dot(l.direction, -inc.dir) - l.cos_outer) / l.span, 0.0, 1.0);
        scale *= a * a;
    }
    inc.radiance = l.radiance * scale;
    inc.ok = max3(inc.radiance) > 0.0;
    return inc;
}

#if TEXTURES
// Texture `r` at surface `s`; `fallback` without one (twin: reference::texture `read`).
fn surface_texture(r: TexRef, s: Surface, fallback: vec4<f32>) -> vec4<f32> {
    return read_texture(r, s.uv.uv0, s.uv.has0, s.uv.uv1, s.uv.has1, fallback);
}
#endif

// The base colour at surface `s`: the material's, times its texture and the vertex colour
// where there are (twin: reference::texture `base_color`).
fn base_color(m: Material, s: Surface) -> vec3<f32> {
    var c = m.color;
#if TEXTURES
    c *= surface_texture(m.base, s, vec4<f32>(1.0)).rgb;
#endif
#if VERTEX_COLORS
    c *= s.color;
#endif
    return c;
}

// The Whitted terms at a hit (twin: scene::Shading).
struct Shading {
    color: vec3<f32>,
    kd: f32,
    mirror: vec3<f32>,
    ks: f32,
    emission: vec3<f32>,
    shine: f32,
    transmittance: f32,
}

#if MAPS
// The reflectance at normal incidence of the dielectric with reflectance `f0` through
// KHR_materials_specular's weight `spec` and colour `tint` (twin: scene::Pbr::dielectric_f0).
fn dielectric_f0(f0: f32, spec: f32, tint: vec3<f32>) -> vec3<f32> {
    return min(max(tint, vec3<f32>(0.0)) * f0, vec3<f32>(1.0)) * clamp(spec, 0.0, 1.0);
}

// The Whitted terms for metallic-roughness inputs, clamped to [0, 1] first (twin:
// scene::Pbr::whitted).
fn whitted(base_in: vec3<f32>, metallic: f32, roughness: f32, transmission: f32, ior: f32, emission: vec3<f32>,
    spec: f32, tint: vec3<f32>) -> Shading {
    let base = clamp(base_in, vec3<f32>(0.0), vec3<f32>(1.0));
    let m = clamp(metallic, 0.0, 1.0);
    let rough = clamp(roughness, 0.0, 1.0);
    let transmittance = clamp(transmission, 0.0, 1.0) * (1.0 - m);
    let alpha = rough * rough;
    // α = 0 gives +∞, which the clamp turns into the largest exponent.
    let shine = clamp(2.0 / (alpha * alpha) - 2.0, 1.0, 10000.0);
    let smoothness = (1.0 - rough) * (1.0 - rough);
    // The opaque dielectric's F0 is 0.04 (η = 1.5) whatever the ior: metals mix it.
    let f0 = dielectric_f0(0.04, spec, tint);
    var mirror = vec3<f32>(0.0);
    if m > 0.0 {
        mirror = smoothness * mix(f0, base, m);
    } else if transmittance > 0.0 {
        let f = (ior - 1.0) / (ior + 1.0);
        mirror = smoothness * dielectric_f0(f * f, spec, tint);
    }
    // The highlight is white: its weight takes F0's largest channel.
    let f = max3(f0);
    return Shading(base, (1.0 - m) * (1.0 - transmittance), mirror, (1.0 - rough) * (f + (1.0 - f) * m),
        max(emission, vec3<f32>(0.0)), shine, transmittance);
}
#endif

// The Whitted terms of material `m` at surface `s`: its maps evaluated there, or its
// scalars (twin: reference::texture `shading`).
fn shading(m: Material, s: Surface) -> Shading {
    let base = base_color(m, s);
#if MAPS
    if (m.flags & MATERIAL_MAPS) != 0u {
        let mr = surface_texture(m.metallic_roughness, s, vec4<f32>(1.0));
        let e = surface_texture(m.emissive, s, vec4<f32>(1.0)).rgb;
        let t = surface_texture(m.transmission_map, s, vec4<f32>(1.0)).r;
        let spec = surface_texture(m.specular_map, s, vec4<f32>(1.0)).a;
        let tint = surface_texture(m.specular_color_map, s, vec4<f32>(1.0)).rgb;
        return whitted(base, m.metallic * mr.b, m.roughness * mr.g, m.transmission * t, m.ior, m.emission_factor * e,
            m.specular * spec, m.specular_color * tint);
    }
#endif
    return Shading(base, m.kd, m.mirror, m.ks, m.emission, m.shine, m.transmittance);
}

#if NORMAL_MAPS
// The normal at `s` through normal map `r` (scale `scale`), where there is one and the
// triangle a tangent frame, on the side of the geometric normal (twin: reference::texture
// `mapped`).
fn mapped_normal(r: TexRef, scale: f32, s: Surface) -> vec3<f32> {
    if r.texture == 0u || !s.has_frame {
        return s.ns;
    }
    let c = surface_texture(r, s, vec4<f32>(-1.0));
    if c.x < 0.0 {
        return s.ns;
    }
    let x = (c.x * 2.0 - 1.0) * scale;
    let y = (c.y * 2.0 - 1.0) * scale;
    let z = c.z * 2.0 - 1.0;
    let b = cross(s.frame_n, s.frame_t) * s.frame_sign;
    let v = s.frame_t * x + b * y + s.frame_n * z;
    let len = length(v);
    if !(len > 1e-12) {
        return s.ns;
    }
    let u = v / len;
    return select(u, -u, dot(u, s.ng) < 0.0);
}
#endif

#if CLEARCOAT
// Schlick's Fresnel reflectance of a clear coat (IOR 1.5) at `cos` = n·v (twin:
// scene::coat_fresnel).
fn coat_fresnel(cos: f32) -> f32 {
    let x = 1.0 - clamp(cos, 0.0, 1.0);
    let x2 = x * x;
    return 0.04 + 0.96 * (x2 * x2 * x);
}

// A clear coat at a hit: the share of the light it reflects (what the base sends is
// weighted by 1 − k), its mirror weight, and its normal facing the ray.
struct Coat {
    k: f32,
    mirror: f32,
    normal: vec3<f32>,
}

// The clear coat of material `m` at `s` (its interpolated normal, before the base's normal
// map) for a ray along `d`; k = 0 without one (twin: reference::texture `clearcoat`).
fn clearcoat_at(m: Material, s: Surface, d: vec3<f32>) -> Coat {
    if m.clearcoat <= 0.0 {
        return Coat(0.0, 0.0, s.ns);
    }
    var strength = 1.0;
    var rough = 1.0;
#if TEXTURES
    strength = surface_texture(m.clearcoat_map, s, vec4<f32>(1.0)).r;
    rough = surface_texture(m.clearcoat_roughness_map, s, vec4<f32>(1.0)).g;
#endif
    let c = clamp(m.clearcoat * strength, 0.0, 1.0);
    let r = clamp(m.clearcoat_roughness * rough, 0.0, 1.0);
    var n = s.ns;
#if NORMAL_MAPS
    n = mapped_normal(m.clearcoat_normal, m.clearcoat_normal_scale, s);
#endif
    n = select(-n, n, dot(d, s.ng) < 0.0);
    let k = c * coat_fresnel(dot(n, -d));
    return Coat(k, k * ((1.0 - r) * (1.0 - r)), n);
}
#endif

// Which primitive a ray leaving primitive `id` towards `dir` need not test: the primitive
// itself when it cannot meet it again (a triangle; a sphere whose outward normal `ng`
// the ray leaves along), else NO_ID.
fn leave_skip(id: u32, dir: vec3<f32>, ng: vec3<f32>) -> u32 {
    let p = prim_at(id);
    if p.kind == KIND_TRIANGLE || (p.kind == KIND_SPHERE && (p.flags & FLAG_INSIDE_ONLY) == 0u && dot(dir, ng) > 0.0) {
        return id;
    }
    return NO_ID;
}

// What light `li` adds at a hit on primitive `id` if nothing blocks it, along `dir`; `ok`
// false when no shadow ray is traced (the light is off or behind the surface).
struct Lit {
    ok: bool,
    dir: vec3<f32>,
    c: vec3<f32>,
}

fn light_term(li: u32, m: Shading, s: Surface, n: vec3<f32>, v: vec3<f32>, diffuse: vec3<f32>) -> Lit {
    let light = lights[li];
    let inc = incidence(light, s.p);
    let n_dot_l = dot(n, inc.dir);
    if !inc.ok || n_dot_l <= 0.0 {
        return Lit(false, vec3<f32>(0.0), vec3<f32>(0.0));
    }
    var local = diffuse * n_dot_l;
    if m.ks > 0.0 {
        let r = n * (2.0 * n_dot_l) - inc.dir;
        let r_dot_v = dot(r, v);
        if r_dot_v > 0.0 {
            local += vec3<f32>(m.ks * pow(r_dot_v, m.shine));
        }
    }
    return Lit(true, inc.dir, inc.radiance * local);
}

// Local illumination at a hit on primitive `id` without the lights that cast shadows:
// emission, ambient, and (without shadows) every light.
fn shade_local(id: u32, m: Shading, s: Surface, n: vec3<f32>, v: vec3<f32>) -> vec3<f32> {
    let diffuse = m.color * m.kd;
    var l = params.ambient * diffuse;
#if EMISSION
    l += m.emission;
#endif
#if SHADOWS
#else
    for (var i = 0u; i < params.light_count; i++) {
        count_step();
        l += light_term(i, m, s, n, v, diffuse).c;
    }
#endif
    return l;
}

#if SHADOWS
// The shadow rays of a hit on primitive `id` (reached with `weight`) of tile point `point`.
// A walk of at most `params.shadow_inline` entries (of the BVH: one ending within
// `params.bvh_inline` iterations) is traced at once; a longer one becomes a
// shadow job (kind RAY_SHADOW, `depth` the light, `weight` what it adds unless blocked) in
// the pass's shadow queue, traced by the `shadow` kernel, so that no invocation walks more
// than one long list (a job costs its write and read, so short walks stay inline); the tree
// kernel walks it on to its answer (`occluded_rest`, tree.wgsl). What the lights traced
// here add is summed into `sum`, which the caller adds once.
fn push_shadow_rays(id: u32, m: Shading, s: Surface, n: vec3<f32>, v: vec3<f32>, weight: vec3<f32>, point: u32,
    sum: ptr<function, Fixed>) {
    let diffuse = m.color * m.kd;
    for (var i = 0u; i < params.light_count; i++) {
        count_step();
        let lit = light_term(i, m, s, n, v, diffuse);
        if !lit.ok {
            continue;
        }
        let o = spawn_origin(s, lit.dir);
        let spawn = spawn_offset(s);
        let skip = leave_skip(id, lit.dir, s.ng);
        var r = occluded_short(o, lit.dir, i, id, skip);
        if r.answer == ANY_UNFINISHED {
#if TREE
            r = occluded_rest(o, lit.dir, i, id, skip, r.state);
#else
            let flags = select(0u, RAY_SKIP_FROM, skip != NO_ID);
            let ray = new_pending(o, RAY_SHADOW | flags | (i << RAY_DEPTH_SHIFT), lit.dir, spawn, weight * lit.c, id);
            push_job(pass_desc.shadow, new_job(ray, point));
            continue;
#endif
        }
        count(C_RAYS + RAY_SHADOW);
        if r.answer == ANY_BLOCKED {
            count_blocked(spawn, r.blocked_at);
        } else {
            *sum = fixed_sum(*sum, to_fixed(weight * lit.c));
        }
    }
}

// A blocked shadow ray, spawned `spawn` off its surface, its blocker `blocked_at` from its
// spawn origin: a self-hit too when that is within SELF_HIT_SPAWNS spawn offsets. The walk
// stops at the first blocker it finds, not the nearest, so a self-hit behind which another
// blocker was found first is not counted; that point is in shadow either way, so what is
// missed makes no acne.
fn count_blocked(spawn: f32, blocked_at: f32) {
    count(C_SHADOW_BLOCKED);
    if blocked_at < SELF_HIT_SPAWNS * spawn {
        count(C_SELF_HITS);
    }
}

// Traces shadow job `job` (or the next part of its walk) and, once answered, adds its light
// to its point unless blocked; an unfinished walk goes to the pass's retry queue.
fn trace_shadow(job: Job) {
    let ray = job.ray;
    let skip = select(NO_ID, ray.from_prim, (ray.kind & RAY_SKIP_FROM) != 0u);
    let r = occluded_step(ray.o, ray.d, job_depth(ray), ray.from_prim, skip, job.walking, job.walk);
    if r.answer == ANY_UNFINISHED {
        var next = job;
        next.walking = WALK_RESUME;
        next.walk = r.state;
        push_job(pass_desc.retry, next);
        return;
    }
    count(C_RAYS + RAY_SHADOW);
    if r.answer == ANY_BLOCKED {
        count_blocked(ray.spawn, r.blocked_at);
    } else {
        add_radiance(job.point, ray.weight);
    }
}
#endif

#if REFLECTION
// Mirror reflection of unit `d` about unit `n`, renormalised.
fn reflect_dir(d: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return normalize(d - n * (2.0 * dot(d, n)));
}
#endif

#if REFRACTION
struct Refracted {
    ok: bool,
    dir: vec3<f32>,
}

fn snell(d: vec3<f32>, n: vec3<f32>, eta: f32) -> Refracted {
    let cos_i = -dot(d, n);
    let k = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
    if k < 0.0 {
        return Refracted(false, vec3<f32>(0.0));
    }
    return Refracted(true, normalize(d * eta + n * (eta * cos_i - sqrt(k))));
}

// The refracted direction (normals facing the incoming ray); not ok on total internal
// reflection.
fn refract_dir(d: vec3<f32>, n: vec3<f32>, ng: vec3<f32>, entering: bool, ior: f32) -> Refracted {
    let eta = select(ior, 1.0 / ior, entering);
    let t = snell(d, n, eta);
    if !t.ok || dot(t.dir, ng) < 0.0 {
        return t;
    }
    return snell(d, ng, eta);
}
#endif

#if BLEND
// What a blended hit of material `mat` on primitive `prim` sends is weighted by its alpha,
// which this returns; the rest goes straight through it along `d`: a pass-through ray, of
// kind refraction, one depth deeper than `depth`, carrying (1 − alpha) of `w_in` for tile
// point `point`.
fn blend_through(mat: Material, s: Surface, prim: u32, d: vec3<f32>, depth: u32, w_in: vec3<f32>, point: u32) -> f32 {
    let a = hit_alpha(mat, s.uv);
    if a < 1.0 && depth < params.max_depth {
        let flags = select(0u, RAY_SKIP_FROM, leave_skip(prim, d, s.ng) != NO_ID);
        let child = new_pending(spawn_origin(s, d), RAY_REFRACT | flags | ((depth + 1u) << RAY_DEPTH_SHIFT), d,
            spawn_offset(s), w_in * (1.0 - a), prim);
        spawn_ray(child, point);
    }
    return a;
}
#endif

// Where a ray a hit of tile point `point` spawns goes: the next depth's queue, or in the
// tree kernel the invocation's own stack.
fn spawn_ray(child: Pending, point: u32) {
#if TREE
    tree_push(child);
#else
    push_job(pass_desc.next, new_job(child, point));
#endif
}

// Adds `f` to tile point `point`'s radiance: at once to the accumulator, or in the tree
// kernel to the invocation's own sum, which it adds once its tree is done.
fn send(point: u32, f: Fixed) {
#if TREE
    tree_sum = fixed_sum(tree_sum, f);
#else
    add_fixed(point, f);
#endif
}

// Shades `h`, the nearest hit of ray `pending` of tile point `point`: sends what the hit
// sends to its point and spawns the rays it spawns.
fn shade_hit(pending: Pending, h: Closest, point: u32) {
    let ray = make_ray(pending.o, pending.d);
    let prim = prim_at(h.prim);
    let mat = materials[prim.material];
    var s = surface(prim, ray, h.hit);
    let d = ray.d;
#if CLEARCOAT
    // The coat reads the interpolated normal, not the base's normal map.
    let coat = clearcoat_at(mat, s, d);
#endif
#if NORMAL_MAPS
    s.ns = mapped_normal(mat.normal, mat.normal_scale, s);
#endif
    let m = shading(mat, s);
    let entering = dot(d, s.ng) < 0.0;
    let ng = select(-s.ng, s.ng, entering);
    let n = select(-s.ns, s.ns, entering);
    var w_in = pending.weight;
#if VOLUME
    // Light reaching this hit from inside an attenuating body crossed `t` of it.
    if !entering && max3(mat.attenuation) > 0.0 {
        w_in *= exp(-mat.attenuation * h.hit.t);
    }
#endif
    var w = w_in;
#if BLEND
    if (mat.flags & MATERIAL_BLEND) != 0u {
        w *= blend_through(mat, s, h.prim, d, job_depth(pending), w_in, point);
    }
#endif
    // What the base sends: all of it, or what the clear coat lets through.
    var w_base = w;
#if CLEARCOAT
    w_base *= 1.0 - coat.k;
#endif
    // What the hit sends to its point, summed before the one addition to the accumulator.
    var sent = to_fixed(w_base * shade_local(h.prim, m, s, n, -d));
#if REFLECTION
    let depth = job_depth(pending);
    if depth < params.max_depth {
        let transmits = m.transmittance > 0.0;
        var weight = m.mirror;
        // One reflected ray: about the coat's normal where the coat reflects.
        var rn = n;
        var reflects = max3(m.mirror) > 0.0 || transmits;
#if CLEARCOAT
        weight = weight * (1.0 - coat.k) + vec3<f32>(coat.mirror);
        if coat.mirror > 0.0 {
            rn = coat.normal;
            reflects = true;
        }
#endif
#if REFRACTION
        var refracted = Refracted(false, vec3<f32>(0.0));
        var transmitted = vec3<f32>(0.0);
        if transmits {
            transmitted = vec3<f32>(m.transmittance);
            if (mat.flags & MATERIAL_TINTED_TRANSMISSION) != 0u {
                transmitted *= m.color;
            }
#if CLEARCOAT
            transmitted *= 1.0 - coat.k;
#endif
            refracted = refract_dir(d, n, ng, entering, mat.ior);
            if !refracted.ok {
                // Total internal reflection: what would have been transmitted is reflected.
                weight += transmitted;
            }
        }
        if refracted.ok {
            let flags = select(0u, RAY_SKIP_FROM, leave_skip(h.prim, refracted.dir, s.ng) != NO_ID);
            let child = new_pending(spawn_origin(s, refracted.dir),
                RAY_REFRACT | flags | ((depth + 1u) << RAY_DEPTH_SHIFT), refracted.dir, spawn_offset(s),
                w * transmitted, h.prim);
            spawn_ray(child, point);
        }
#endif
        if reflects {
            var r = reflect_dir(d, rn);
            if dot(r, ng) <= 0.0 {
                r = reflect_dir(d, ng);
            }
            let flags = select(0u, RAY_SKIP_FROM, leave_skip(h.prim, r, s.ng) != NO_ID);
            let child = new_pending(spawn_origin(s, r), RAY_REFLECT | flags | ((depth + 1u) << RAY_DEPTH_SHIFT), r,
                spawn_offset(s), w * weight, h.prim);
            spawn_ray(child, point);
        }
    }
#endif
#if SHADOWS
    push_shadow_rays(h.prim, m, s, n, -d, w_base, point, &sent);
#endif
    send(point, sent);
}
