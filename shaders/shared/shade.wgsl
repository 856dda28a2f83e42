// Whitted shading and the ray trees, as the CPU reference shades (src/reference/shade.rs,
// written independently in f64). The trees are traced breadth first by the wavefront
// kernels: a hit (shaded by the `shade` kernel) adds its radiance to its point and pushes
// the rays it spawns (secondary rays, and shadow rays whose walks are long) into the queues
// of the current pass, each carrying the weight its radiance contributes with.

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

// The base colour at surface `s`: the material's, times its texture and the vertex colour
// where there are (twin: reference::shade `base_color`).
fn base_color(m: Material, s: Surface) -> vec3<f32> {
    var c = m.color;
#if TEXTURES
    if m.texture != 0u && s.has_uv {
        c = m.color * sample_texture(m.texture - 1u, s.uv);
    }
#endif
#if VERTEX_COLORS
    c *= s.color;
#endif
    return c;
}

// Which primitive a ray leaving primitive `id` towards `dir` need not test: the primitive
// itself when it cannot meet it again (a triangle; a sphere whose outward normal `ng`
// the ray leaves along), else NO_ID.
fn leave_skip(id: u32, dir: vec3<f32>, ng: vec3<f32>) -> u32 {
    let p = prims[id];
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

fn light_term(li: u32, m: Material, s: Surface, n: vec3<f32>, v: vec3<f32>, diffuse: vec3<f32>) -> Lit {
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
fn shade_local(id: u32, m: Material, s: Surface, n: vec3<f32>, v: vec3<f32>) -> vec3<f32> {
    let diffuse = base_color(m, s) * m.kd;
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
// than one long list (a job costs its write and read, so short walks stay inline).
fn push_shadow_rays(id: u32, m: Material, s: Surface, n: vec3<f32>, v: vec3<f32>, weight: vec3<f32>, point: u32) {
    let diffuse = base_color(m, s) * m.kd;
    for (var i = 0u; i < params.light_count; i++) {
        count_step();
        let lit = light_term(i, m, s, n, v, diffuse);
        if !lit.ok {
            continue;
        }
        let o = spawn_origin(s, lit.dir);
        let spawn = spawn_offset(s);
        let skip = leave_skip(id, lit.dir, s.ng);
        let r = occluded_short(o, lit.dir, i, id, skip);
        if r.answer == ANY_UNFINISHED {
            let flags = select(0u, RAY_SKIP_FROM, skip != NO_ID);
            let ray = new_pending(o, RAY_SHADOW | flags | (i << RAY_DEPTH_SHIFT), lit.dir, spawn, weight * lit.c, id);
            push_job(pass_desc.shadow, new_job(ray, point));
            continue;
        }
        count(C_RAYS + RAY_SHADOW);
        if r.answer == ANY_BLOCKED {
            count_blocked(spawn, r.blocked_at);
        } else {
            add_radiance(point, weight * lit.c);
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

// Shades hit job `job` (its nearest hit in its walk state, `trace_job` in nearest.wgsl): adds
// what the hit sends to its point and pushes the rays the hit spawns into the pass's queues.
fn shade_hit(job: Job) {
    let pending = job.ray;
    let ray = make_ray(pending.o, pending.d);
    let h = restored_closest(job.walk, WALK_RESUME);
    let prim = prims[h.prim];
    let m = materials[prim.material];
    let s = surface(prim, ray, h.hit);
    let d = ray.d;
    let entering = dot(d, s.ng) < 0.0;
    let ng = select(-s.ng, s.ng, entering);
    let n = select(-s.ns, s.ns, entering);
    add_radiance(job.point, pending.weight * shade_local(h.prim, m, s, n, -d));
#if REFLECTION
    let depth = job_depth(pending);
    if depth < params.max_depth {
        let transmits = m.transmittance > 0.0;
        var weight = m.mirror;
#if REFRACTION
        var refracted = Refracted(false, vec3<f32>(0.0));
        var transmitted = vec3<f32>(0.0);
        if transmits {
            // Tinted (glTF) glass samples its base colour again, only here: other hits pay
            // nothing for it.
            transmitted = vec3<f32>(m.transmittance);
            if (m.flags & MATERIAL_TINTED_TRANSMISSION) != 0u {
                transmitted *= base_color(m, s);
            }
            refracted = refract_dir(d, n, ng, entering, m.ior);
            if !refracted.ok {
                // Total internal reflection: what would have been transmitted is reflected.
                weight += transmitted;
            }
        }
        if refracted.ok {
            let flags = select(0u, RAY_SKIP_FROM, leave_skip(h.prim, refracted.dir, s.ng) != NO_ID);
            let child = new_pending(spawn_origin(s, refracted.dir),
                RAY_REFRACT | flags | ((depth + 1u) << RAY_DEPTH_SHIFT), refracted.dir, spawn_offset(s),
                pending.weight * transmitted, h.prim);
            push_job(pass_desc.next, new_job(child, job.point));
        }
#endif
        if max3(m.mirror) > 0.0 || transmits {
            var r = reflect_dir(d, n);
            if dot(r, ng) <= 0.0 {
                r = reflect_dir(d, ng);
            }
            let flags = select(0u, RAY_SKIP_FROM, leave_skip(h.prim, r, s.ng) != NO_ID);
            let child = new_pending(spawn_origin(s, r), RAY_REFLECT | flags | ((depth + 1u) << RAY_DEPTH_SHIFT), r,
                spawn_offset(s), pending.weight * weight, h.prim);
            push_job(pass_desc.next, new_job(child, job.point));
        }
    }
#endif
#if SHADOWS
    push_shadow_rays(h.prim, m, s, n, -d, pending.weight, job.point);
#endif
}
