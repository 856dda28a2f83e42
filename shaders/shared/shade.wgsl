// Whitted shading and the ray tree of one eye ray, as the CPU reference shades
// (src/reference/shade.rs, written independently in f64).
// The ray tree is walked with an explicit stack of pending rays (secondary rays, and
// shadow rays whose walks are long), each carrying the weight its radiance contributes
// with.

struct Incidence {
    ok: bool,
    dir: vec3<f32>,
    positional: bool,
    radiance: vec3<f32>,
}

// How light `l` reaches point `p`; `ok` false where it contributes nothing.
fn incidence(l: Light, p: vec3<f32>) -> Incidence {
    var inc: Incidence;
    inc.ok = false;
    inc.positional = l.kind != LIGHT_DIRECTIONAL;
    if l.kind == LIGHT_DIRECTIONAL {
        inc.dir = -l.direction;
        inc.radiance = l.radiance;
        inc.ok = max3(l.radiance) > 0.0;
        return inc;
    }
    let to = l.position - p;
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

fn base_color(m: Material, s: Surface) -> vec3<f32> {
#if TEXTURES
    if m.texture != 0u && s.has_uv {
        return m.color * sample_texture(m.texture - 1u, s.uv);
    }
#endif
    return m.color;
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
        l += light_term(i, m, s, n, v, diffuse).c;
    }
#endif
    return l;
}

#if SHADOWS
// The shadow rays of a hit on primitive `id` (reached with `weight`). A light whose walk
// is long becomes a shadow job on the stack (kind RAY_SHADOW, `depth` the light, `weight`
// what it adds unless blocked), traced over the next steps like any other ray, so that no
// step walks more than one long list. Jobs are pushed after the hit's secondary rays, so
// they are traced first and the stack holds at most max depth + lights jobs; should it
// be full, the shadow ray is traced at once, as are walks of at most
// `params.shadow_inline` entries (a job costs a whole step, which loads and stores the
// point's state: on gears_s4, jobs for every walk over 64 entries took 52 s instead of 38).
fn push_shadow_rays(id: u32, m: Material, s: Surface, n: vec3<f32>, v: vec3<f32>, weight: vec3<f32>) {
    let diffuse = base_color(m, s) * m.kd;
    for (var i = 0u; i < params.light_count; i++) {
        let lit = light_term(i, m, s, n, v, diffuse);
        if !lit.ok {
            continue;
        }
        let o = spawn_origin(s, lit.dir);
        let spawn = spawn_offset(s);
        let skip = leave_skip(id, lit.dir, s.ng);
        // A full stack takes no job: the walk is traced at once, however long.
        var r = ANY_UNFINISHED;
        if state.sp < STACK_SIZE {
            r = occluded_short(o, lit.dir, i, id, skip);
        } else {
            r = select(ANY_CLEAR, ANY_BLOCKED, occluded(o, lit.dir, i, id, skip));
        }
        if r == ANY_UNFINISHED {
            let flags = select(0u, RAY_SKIP_FROM, skip != NO_ID);
            state.stack[state.sp] =
                Pending(o, RAY_SHADOW | flags | (i << RAY_DEPTH_SHIFT), lit.dir, spawn, weight * lit.c, id);
            state.sp += 1u;
            continue;
        }
        count(C_RAYS + RAY_SHADOW);
        if r == ANY_BLOCKED {
            count_blocked(spawn);
        } else {
            state.color += weight * lit.c;
        }
    }
}

// A blocked shadow ray, spawned `spawn` off its surface: a self-hit too when its blocker
// lies within SELF_HIT_SPAWNS spawn offsets. The walk stops at the first blocker it finds,
// not the nearest, so a self-hit behind which another blocker was found first is not
// counted; that point is in shadow either way, so what is missed makes no acne.
fn count_blocked(spawn: f32) {
    count(C_SHADOW_BLOCKED);
    if blocked_at < SELF_HIT_SPAWNS * spawn {
        count(C_SELF_HITS);
    }
}

// Traces the shadow job on top of the stack (over several calls when its walk is long)
// and, once answered, pops it and adds its light unless blocked.
fn shadow_step(job: Pending) {
    let skip = select(NO_ID, job.from_prim, (job.kind & RAY_SKIP_FROM) != 0u);
    let light = job_depth(job);
    let r = occluded_step(job.o, job.d, light, job.from_prim, skip);
    if r == ANY_UNFINISHED {
        return;
    }
    state.sp -= 1u;
    count(C_RAYS + RAY_SHADOW);
    if r == ANY_BLOCKED {
        count_blocked(job.spawn);
    } else {
        state.color += job.weight;
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

// Traces the ray on top of the stack (a long table walk over several calls) and, once its
// nearest hit is known, pops it and pushes the rays its hit spawns.
fn trace_step() {
    let job = state.stack[state.sp - 1u];
    let kind = job.kind & RAY_KIND_MASK;
#if SHADOWS
    if kind == RAY_SHADOW {
        shadow_step(job);
        return;
    }
#endif
    let ray = make_ray(job.o, job.d);
    let skip = select(NO_ID, job.from_prim, (job.kind & RAY_SKIP_FROM) != 0u);
    let stepped = closest_step(ray, FAR, kind, job.from_prim, skip);
    if !stepped.done {
        // The ray stays on the stack; its walk goes on in the next step.
        return;
    }
    let h = stepped.c;
    state.sp -= 1u;
    count(C_RAYS + kind);
    if !h.found {
        state.color += job.weight * params.background;
        return;
    }
    if kind == RAY_EYE {
        count(C_EYE_HIT);
    } else if h.hit.t < SELF_HIT_SPAWNS * job.spawn {
        count(C_SELF_HITS);
    }
    let prim = prims[h.prim];
    let m = materials[prim.material];
    let s = surface(prim, ray, h.hit);
    let d = ray.d;
    let entering = dot(d, s.ng) < 0.0;
    let ng = select(-s.ng, s.ng, entering);
    let n = select(-s.ns, s.ns, entering);
    state.color += job.weight * shade_local(h.prim, m, s, n, -d);
#if REFLECTION
    let depth = job_depth(job);
    if depth < params.max_depth {
        let transmits = m.transmittance > 0.0;
        var weight = m.mirror;
#if REFRACTION
        var refracted = Refracted(false, vec3<f32>(0.0));
        if transmits {
            refracted = refract_dir(d, n, ng, entering, m.ior);
            if !refracted.ok {
                // Total internal reflection: what would have been transmitted is reflected.
                weight += vec3<f32>(m.transmittance);
            }
        }
        if refracted.ok {
            let flags = select(0u, RAY_SKIP_FROM, leave_skip(h.prim, refracted.dir, s.ng) != NO_ID);
            state.stack[state.sp] = Pending(spawn_origin(s, refracted.dir),
                RAY_REFRACT | flags | ((depth + 1u) << RAY_DEPTH_SHIFT), refracted.dir, spawn_offset(s),
                job.weight * m.transmittance, h.prim);
            state.sp += 1u;
        }
#endif
        if max3(m.mirror) > 0.0 || transmits {
            var r = reflect_dir(d, n);
            if dot(r, ng) <= 0.0 {
                r = reflect_dir(d, ng);
            }
            let flags = select(0u, RAY_SKIP_FROM, leave_skip(h.prim, r, s.ng) != NO_ID);
            state.stack[state.sp] = Pending(spawn_origin(s, r), RAY_REFLECT | flags | ((depth + 1u) << RAY_DEPTH_SHIFT), r,
                spawn_offset(s), job.weight * weight, h.prim);
            state.sp += 1u;
        }
    }
#endif
#if SHADOWS
    push_shadow_rays(h.prim, m, s, n, -d, job.weight);
#endif
}
