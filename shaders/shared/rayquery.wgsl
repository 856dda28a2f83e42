// The platform's ray queries (`--accel rayquery`, and with `--accel cube` the rays leaving
// surfaces where the adapter has them): one acceleration structure of a box per primitive
// (src/layout/rayquery.rs, over the scene re-centred on the eye as the primitives are), built
// and traversed by the driver, which only culls. Every box it hands over is a candidate that
// the kernel tests with the same intersection functions and tie rule (`consider`) as the
// other walks, so every accelerator gives the same image.
//
// A nearest-hit query keeps its answer in its own `Closest`, as the other walks do, and
// commits each narrower limit (`closest_limit`, grown by RQ_COMMIT_REL) as a generated hit
// only so that the driver culls the boxes beyond it: naga 30.0.1's guard on
// `rayQueryGenerateIntersection` compares with the candidate's t, which AABB candidates leave
// undefined, so the committed hit is never read back. A query runs to its end in one call: a
// walk is done in one pass (WGSL cannot keep a ray query between passes), and a shadow ray is
// traced at its hit. The `ray_query` variables live at function level: naga 30.0.1 writes
// invalid SPIR-V for one declared in a loop body.
//
// With RAYQUERY (an accelerator of its own) it supplies query.wgsl's protocol; with
// SURFACE_RQ walk.wgsl calls `rq_nearest` and `rq_any` for the rays leaving surfaces.

@group(0) @binding(25) var rq_scene: acceleration_structure;

// Limits handed to the driver grow by this much of themselves (2⁻¹²): its box tests are
// its own arithmetic, and a box must never be culled before its primitive's hit. The boxes
// are padded besides (layout::rayquery::RQ_PAD_REL).
const RQ_COMMIT_REL: f32 = 2.44140625e-4;
// The largest t handed to the driver: t_max may be FAR, and a query's limits must be finite.
const RQ_T_MAX: f32 = 1e37;

// The driver's ray for `ray`, with t from 0 to `t_max`: the origin rounded to f32 (in f64
// moving it by 2⁻²⁴ of its magnitude, which the boxes' padding covers).
fn rq_desc(ray: Ray, t_max: f32) -> RayDesc {
    let far = min(t_max + t_max * RQ_COMMIT_REL, RQ_T_MAX);
    return RayDesc(RAY_FLAG_NONE, 0xffu, 0.0, far, vec3<f32>(ray.o), ray.d);
}

// The nearest-hit query of `ray` to its end, taking the hits into `best` by the tie rule
// (`consider`; `skip` never tested). The driver culls beyond the limit committed last.
fn rq_nearest(best: ptr<function, Closest>, ray: Ray, t_max: f32, skip: u32, ray_kind: u32) {
    var q: ray_query;
    let desc = rq_desc(ray, t_max);
    var committed = desc.tmax;
    rayQueryInitialize(&q, rq_scene, desc);
    while rayQueryProceed(&q) {
        count_step();
        let id = rayQueryGetCandidateIntersection(&q).primitive_index;
        if id != skip {
            let limit = consider(id, best, ray, t_max, ray_kind);
            let cut = limit + limit * RQ_COMMIT_REL;
            if cut < committed {
                committed = cut;
                rayQueryGenerateIntersection(&q, cut);
            }
        }
    }
}

#if RQ_SHADOWS
// The any-hit query of `ray`: ANY_BLOCKED when some primitive other than `skip` is hit at
// 0 < t < t_max (with its t), else ANY_CLEAR.
fn rq_any(ray: Ray, t_max: f32, skip: u32) -> AnyHit {
    var q: ray_query;
    var answer = any_answer(ANY_CLEAR);
    rayQueryInitialize(&q, rq_scene, rq_desc(ray, t_max));
    while rayQueryProceed(&q) {
        count_step();
        let id = rayQueryGetCandidateIntersection(&q).primitive_index;
        if id != skip {
            let h = test_any(id, ray, t_max);
            if h.ok {
                answer = AnyHit(ANY_BLOCKED, h.t);
                rayQueryTerminate(&q);
            }
        }
    }
    return answer;
}
#endif

#if RAYQUERY
// The protocol of query.wgsl: a walk is one query (`i` 0 until it has run, then 1).
struct Walk {
    i: u32,
    iend: u32,
    j: u32,
    jend: u32,
}

fn walk_of_ray(from_prim: u32, ray: Ray) -> Walk {
    return Walk(0u, 1u, 0u, 0u);
}

// Runs the query whole, whatever `*left` (a query cannot be kept between passes).
fn walk_nearest(w: ptr<function, Walk>, best: ptr<function, Closest>, ray: Ray, t_max: f32, skip: u32,
    ray_kind: u32, left: ptr<function, u32>) -> bool {
    rq_nearest(best, ray, t_max, skip, ray_kind);
    (*w).i = 1u;
    return true;
}

fn walk_chunk(w: Walk) -> u32 {
    return WALK_CHUNK;
}

#if SHADOWS
fn walk_of_shadow(sr: ShadowRay, light: u32, from_prim: u32) -> Walk {
    return Walk(0u, 1u, 0u, 0u);
}

fn walk_any(w: ptr<function, Walk>, ray: Ray, t_max: f32, skip: u32, budget: u32) -> AnyHit {
    (*w).i = 1u;
    return rq_any(ray, t_max, skip);
}

// Every shadow ray is traced at its hit: its query runs whole wherever it runs.
fn walk_inline(w: Walk) -> u32 {
    return UNBOUNDED;
}
#endif
#endif
