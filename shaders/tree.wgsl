// The `tree` kernel, the register form of the kernels (`KernelForm::Tree`, src/job.rs): each
// invocation traces the whole ray tree of one sample of one tile point, depth first, its
// pending rays on a private stack and its radiance in a private sum, which it adds to the
// point once. The walks, the shading, the spawned rays and the tie rule are the wavefront's
// own (shade.wgsl's hooks `spawn_ray` and `send` keep rays and radiance here under TREE,
// instead of in the queues and the accumulator), so both forms add the same fixed-point
// values and write the same image. No job moves through memory and a sample is one dispatch;
// the walks are not cut into passes, so this form runs only on drivers without a loop limit
// (`gpu::choose`: lavapipe before Mesa 24 ends every loop of a group after 65535 iterations).
#include "shared/trace.wgsl"
#include "shared/primary.wgsl"
#if TEXTURES
#include "shared/texture.wgsl"
#endif
#include "shared/shade.wgsl"

// Room for the rays a tree leaves pending. A ray spawns at most three rays one depth deeper
// (a pass-through, a refraction, a reflection) and none at params.max_depth (at most
// MAX_DEPTH); depth first, the stack holds at most two unexplored siblings of each depth
// above the ray being traced, and three of the deepest. Twin: src/layout/structs.rs.
const TREE_STACK: u32 = 2u * MAX_DEPTH + 1u;

var<private> tree_stack: array<Pending, TREE_STACK>;
var<private> tree_len: u32;
// What the tree has sent its point so far, in the accumulator's units.
var<private> tree_sum: Fixed;

// Pushes a ray the tree spawned (shade.wgsl's `spawn_ray`). The stack's bound makes a full
// stack impossible; were it reached, the tile would be run again rather than lose a ray.
fn tree_push(ray: Pending) {
    if tree_len < TREE_STACK {
        tree_stack[tree_len] = ray;
        tree_len += 1u;
    } else {
        atomicOr(&queues[QUEUE_OVERFLOW], OVERFLOW_FULL);
    }
}

#if SHADOWS
// The answer of a shadow walk too long to trace at its hit in the wavefront, walked on from
// `state`, where `occluded_short` left it, to its end.
fn occluded_rest(q: vec3r, to_light: vec3<f32>, light: u32, from_prim: u32, skip: u32, state: WalkState)
    -> Occlusion {
    var r = Occlusion(ANY_UNFINISHED, 0.0, state);
    loop {
        r = occluded_step(q, to_light, light, from_prim, skip, WALK_RESUME, r.state);
        if r.answer != ANY_UNFINISHED {
            break;
        }
    }
    return r;
}
#endif

// Traces `ray` of tile point `point` to its nearest hit and shades it: a miss sends the
// background, a hit what shade.wgsl makes of it (the counts are `trace_job`'s).
fn trace_tree_ray(ray: Pending, point: u32) {
    let kind = ray.kind & RAY_KIND_MASK;
    let r = make_ray(ray.o, ray.d);
    let skip = select(NO_ID, ray.from_prim, (ray.kind & RAY_SKIP_FROM) != 0u);
    let h = closest(r, FAR, kind, ray.from_prim, skip);
    count(C_RAYS + kind);
    if !h.found {
        send(point, to_fixed(ray.weight * background(r.d)));
        return;
    }
    if kind == RAY_EYE {
        count(C_EYE_HIT);
    } else if h.hit.t < SELF_HIT_SPAWNS * ray.spawn {
        count(C_SELF_HITS);
    }
    shade_hit(ray, h, point);
}

@compute @workgroup_size(WORKGROUP)
fn tree(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let k = gid.x;
    if k < params.point_count {
        let eye = eye_job(k);
        tree_len = 0u;
        tree_sum = Fixed(vec3<u32>(0u), vec3<u32>(0u));
        tree_push(eye.ray);
        loop {
            if tree_len == 0u {
                break;
            }
            tree_len -= 1u;
            trace_tree_ray(tree_stack[tree_len], eye.point);
        }
        add_fixed(eye.point, tree_sum);
        if (eye.point & POINT_UNOWNED) != 0u {
            drop_counts();
        }
    }
    flush_counters(lid);
}
