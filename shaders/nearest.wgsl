// The `nearest` kernel: traces each job of queue `pass_desc.src` (SRC_EYE: the eye ray of
// sample `pass_desc.sample` of each point of the tile, made here) for its nearest hit (a long
// walk a chunk per pass, the rest through the retry queue). A miss adds the background to
// its point (`background`); a hit goes, in the job's walk state, into the hit queue, which the `shade`
// kernel works through (src/gpu/schedule.rs runs the passes). Shading here cost every
// invocation, hit or not: lavapipe runs both sides of a branch for a group of lanes that
// disagree (tetra_s6, 513² corners: 0.050 s of which 0.025 s with the shading code absent).
#include "shared/trace.wgsl"
#include "shared/primary.wgsl"

// Traces job `job` (or the next part of its walk; an unfinished walk goes to the pass's
// retry queue); once its nearest hit is known, a miss adds the background to its point and
// a hit goes to the pass's hit queue, the hit in the job's walk state (prim, t, b1, b2). A
// retried walk and a hit share one push: lavapipe (Mesa 22.3) runs the code of every
// branch for every invocation, taken or not.
fn trace_job(job: Job) {
    let pending = job.ray;
    let kind = pending.kind & RAY_KIND_MASK;
    let ray = make_ray(pending.o, pending.d);
    let skip = select(NO_ID, pending.from_prim, (pending.kind & RAY_SKIP_FROM) != 0u);
    let stepped = closest_step(ray, FAR, kind, pending.from_prim, skip, job.walking, job.walk);
    let h = stepped.c;
    if stepped.done {
        count(C_RAYS + kind);
        if !h.found {
            add_radiance(job.point, pending.weight * background(ray.d));
            return;
        }
        if kind == RAY_EYE {
            count(C_EYE_HIT);
        } else if h.hit.t < SELF_HIT_SPAWNS * pending.spawn {
            count(C_SELF_HITS);
        }
    }
    var next = job;
    next.walking = select(select(WALK_RESUME, WALK_RESUME_LOST, h.lost), WALK_START, stepped.done);
    next.walk = stepped.state;
    if stepped.done {
        next.walk = WalkState(0u, 0u, 0u, 0u, h.prim, h.hit.t, h.hit.b1, h.hit.b2, h.window, h.t_min);
    }
    push_job(select(pass_desc.retry, pass_desc.hit, stepped.done), next);
}

@compute @workgroup_size(WORKGROUP)
fn nearest(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = gid.x;
    var job: Job;
    var traced = false;
    if pass_desc.src == SRC_EYE {
        if i < params.point_count {
            job = eye_job(i);
            traced = true;
        }
    } else if i < queue_len(pass_desc.src) {
        job = jobs[queue_base(pass_desc.src) + i];
        traced = true;
    }
    if traced {
        trace_job(job);
        if (job.point & POINT_UNOWNED) != 0u {
            drop_counts();
        }
    }
    flush_counters(lid);
    flush_lanes(lid, traced, LANE_NEAREST);
}
