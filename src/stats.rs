//! Render statistics shared by every backend: rays by kind, primitive intersection tests,
//! tests per ray, times, and the settings and effects of the render.
//!
//! Counting follows Haines' SPD procedure (`shared/scenes/README.md`, end):
//! - `rays.eye`: primary rays traced (`--sampling corners`: (W+1)×(H+1));
//!   `rays.eye_hit`: those that hit something;
//! - `rays.reflect` / `rays.refract`: secondary rays traced (a reflection ray on every hit
//!   of a reflective or transmitting surface, a refraction ray on every hit of a
//!   transmitting one without total internal reflection, while the depth limit allows);
//! - `rays.shadow`: shadow rays traced (none where the surface faces away from the light);
//!   `rays.shadow_blocked`: those that found an occluder;
//! - `rays.self_hits`: spawned rays (shadow, reflection, refraction) whose nearest hit (a
//!   shadow ray: the blocker that answered it) lies within 4 spawn offsets of their origin:
//!   self-intersection acne, 0 in a render whose offsets are large enough (not an SPD count);
//! - `tests.*`: primitive intersection tests (bounding volume tests are not counted), by
//!   primitive type, over all rays; `tests_per_ray.K` = tests made by rays of kind K
//!   divided by the number of rays of kind K;
//! - `tests.bound`, `bound_tests_per_ray.K`: the bounding-sphere tests of primitive groups
//!   that long candidate lists name (`--accel cube`), reported apart because they are not
//!   primitive tests (Haines' procedure counts none), but they are real work.
//!
//! `--stats` prints [`Stats::to_text`], `--stats json` prints [`Stats::to_json`]: one JSON
//! object with nested objects (`{"rays":{"eye":...},...}`). The GPU backend fills the same
//! structure so that both backends print the same keys.

use std::ops::AddAssign;

use serde::{Deserialize, Serialize};

/// The kinds of rays a Whitted renderer traces.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RayKind {
    Eye,
    Shadow,
    Reflect,
    Refract,
}

impl RayKind {
    pub const ALL: [RayKind; 4] = [RayKind::Eye, RayKind::Shadow, RayKind::Reflect, RayKind::Refract];

    pub fn index(self) -> usize {
        self as usize
    }

    pub fn name(self) -> &'static str {
        match self {
            RayKind::Eye => "eye",
            RayKind::Shadow => "shadow",
            RayKind::Reflect => "reflect",
            RayKind::Refract => "refract",
        }
    }
}

/// Primitive intersection tests, by primitive type.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct TestCounts {
    pub sphere: u64,
    pub triangle: u64,
    /// Cylinders and cones.
    pub cylinder: u64,
    /// Bounding-sphere tests of primitive groups named by long candidate lists (`--accel
    /// cube`); not primitive tests, so not in [`TestCounts::total`]. Brute force tests no
    /// bounds and the BVH's node visits are not counted.
    pub bound: u64,
}

impl TestCounts {
    pub fn total(&self) -> u64 {
        self.sphere + self.triangle + self.cylinder
    }
}

impl AddAssign for TestCounts {
    fn add_assign(&mut self, o: TestCounts) {
        self.sphere = self.sphere.saturating_add(o.sphere);
        self.triangle = self.triangle.saturating_add(o.triangle);
        self.cylinder = self.cylinder.saturating_add(o.cylinder);
        self.bound = self.bound.saturating_add(o.bound);
    }
}

/// Raw counters a tracer accumulates (per thread, then summed): rays by kind and the
/// primitive tests made by the rays of each kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Counters {
    /// Rays traced, indexed by [`RayKind::index`].
    pub rays: [u64; 4],
    /// Primitive tests made by rays of each kind, indexed by [`RayKind::index`].
    pub tests: [TestCounts; 4],
    pub eye_hit: u64,
    pub shadow_blocked: u64,
    pub self_hits: u64,
}

impl Counters {
    /// The test counter that rays of `kind` add to.
    pub fn tests_mut(&mut self, kind: RayKind) -> &mut TestCounts {
        &mut self.tests[kind.index()]
    }

    pub fn count_ray(&mut self, kind: RayKind) {
        self.rays[kind.index()] += 1;
    }
}

impl AddAssign for Counters {
    /// Saturating: counts read from files (`cuberay merge`) must not wrap or panic.
    fn add_assign(&mut self, o: Counters) {
        for i in 0..4 {
            self.rays[i] = self.rays[i].saturating_add(o.rays[i]);
            self.tests[i] += o.tests[i];
        }
        self.eye_hit = self.eye_hit.saturating_add(o.eye_hit);
        self.shadow_blocked = self.shadow_blocked.saturating_add(o.shadow_blocked);
        self.self_hits = self.self_hits.saturating_add(o.self_hits);
    }
}

/// Rays traced by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct RayStats {
    pub eye: u64,
    pub eye_hit: u64,
    pub reflect: u64,
    pub refract: u64,
    pub shadow: u64,
    pub shadow_blocked: u64,
    /// Spawned rays that hit within 4 spawn offsets of their origin.
    pub self_hits: u64,
    /// eye + reflect + refract + shadow.
    pub total: u64,
}

/// Mean primitive intersection tests per ray, by kind (0 when no ray of that kind was traced).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct TestsPerRay {
    pub eye: f64,
    pub shadow: f64,
    pub reflect: f64,
    pub refract: f64,
    /// All tests over all rays.
    pub all: f64,
}

/// Wall-clock times in seconds.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Times {
    /// Building the acceleration structure (BVH, candidate tables...), after loading.
    pub preprocess_s: f64,
    /// Tracing and shading every ray (wall clock, including transfers on the GPU).
    pub trace_s: f64,
    /// GPU kernel time from timestamp queries; `null` on the CPU backend or when the
    /// adapter has no timestamp queries.
    pub gpu_s: Option<f64>,
    /// The same time per kernel ([`KernelTimes`]; `null` for a kernel that did not run); all
    /// `null` where `gpu_s` is.
    pub gpu_kernel_s: KernelTimes,
    /// The wavefront kernels' time by depth ([`DepthTimes`], depths 1 to `max_depth` that
    /// ran); `null` where `gpu_s` is and for the AOV pass.
    #[serde(default)]
    pub gpu_depth_s: Option<Vec<DepthTimes>>,
    /// Wall-clock time of the kernels' compilation, done before the timed dispatches
    /// (lavapipe compiles at the first dispatch: seconds for a new variant, milliseconds once
    /// Mesa's shader cache holds it); `null` on the CPU.
    pub compile_s: Option<f64>,
    /// The longest single submission (a wave of a tile's passes), wall clock: a bound on
    /// what one dispatch costs (real GPUs kill dispatches that run for about two seconds);
    /// `null` on the CPU.
    pub longest_submit_s: Option<f64>,
    /// The longest single pass (one dispatch) from timestamp queries; `null` on the CPU or
    /// without timestamp queries.
    pub longest_dispatch_s: Option<f64>,
    /// Tiles the GPU ran again: a ray queue overflowed (then in smaller tiles), or a walk
    /// outlasted the passes planned for it (then with another pass per depth); `null` on the
    /// CPU.
    pub tiles_run_again: Option<u32>,
    /// The command's time by phase, as a user waits for it ([`crate::phases`]).
    #[serde(default)]
    pub phases: crate::phases::Phases,
}

/// The GPU kernel time of one depth of the ray trees (the eye rays: depth 1), seconds: the
/// passes of each wavefront kernel that worked on rays of that depth, from their own
/// timestamps (`resolve`, once per tile, belongs to no depth).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DepthTimes {
    pub depth: u32,
    pub nearest: f64,
    pub shade: f64,
    pub shadow: f64,
    /// The three together.
    pub all: f64,
}

/// Lane coherence of one wavefront kernel's passes at one depth: how much of what a group
/// of invocations running in lockstep pays is work. lavapipe runs 8 neighbouring
/// invocations as one SIMD vector (a real GPU's warp holds 32), and a group takes as many
/// loop iterations as its busiest lane; `max8 / steps` is what that costs over the mean.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Lanes {
    pub depth: u32,
    /// Invocations that had a job.
    pub invocations: u64,
    /// Mean loop iterations of an invocation: walk steps (entries, BVH nodes with a queued
    /// primitive, brute-force primitives); in `shade`, light iterations and the steps of the
    /// shadow walks traced inline.
    pub steps: f64,
    /// Mean over groups of 8 neighbouring invocations (with a job) of the group's largest
    /// `steps`.
    pub max8: f64,
    /// The same over groups of 32.
    pub max32: f64,
}

/// Lane coherence of each wavefront kernel, by depth (the depths whose passes had work).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LaneStats {
    pub nearest: Vec<Lanes>,
    pub shade: Vec<Lanes>,
    pub shadow: Vec<Lanes>,
}

/// GPU time per kernel, seconds: the wavefront's (`nearest` the nearest-hit passes, the
/// first of them making the eye rays; `shade` the shading of their hits, with the short
/// shadow walks; `shadow` the shadow passes; `resolve` the colours) and the AOV pass's.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct KernelTimes {
    pub nearest: Option<f64>,
    pub shade: Option<f64>,
    pub shadow: Option<f64>,
    pub resolve: Option<f64>,
    pub aov: Option<f64>,
    /// The `tree` kernel (the register form), which does all of nearest, shade and shadow.
    #[serde(default)]
    pub tree: Option<f64>,
}

/// The settings a render ran with.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Settings {
    /// `cpu` or `gpu`.
    pub backend: String,
    /// The acceleration structure actually used (`brute`, `bvh`, `cube`, `rayquery`).
    pub accel: String,
    /// With `cube` on the GPU, what the rays leaving surfaces took: `bvh` or `rayquery`
    /// (`null` where no ray left a surface, with other accelerators, and on the CPU).
    #[serde(default)]
    pub surface_walk: Option<String>,
    /// On the GPU, how the kernels traced the ray trees: `wavefront` or `tree` (`null` on
    /// the CPU and for AOVs).
    #[serde(default)]
    pub kernel_form: Option<String>,
    /// `[width, height]` of the image.
    pub size: [u32; 2],
    /// Samples per pixel (`corners`: 1, each pixel averaging its four corner rays).
    pub spp: u32,
    /// `center`, `jitter` (spp > 1) or `corners`.
    pub sampling: String,
    pub seed: u64,
    /// Maximum ray-tree depth, the eye ray being depth 1.
    pub max_depth: u32,
    /// The intersection arithmetic: `f32` or `f64` (the CPU reference: always `f64`).
    #[serde(default)]
    pub precision: String,
    /// Why `--precision auto` chose `precision` (the offset, the feature and the margin of
    /// `crate::arith::precision`); `null` where the precision was given, and on the CPU.
    #[serde(default)]
    pub precision_auto: Option<String>,
    /// Why `--accel auto` chose `accel` (each origin's predicted table build against what
    /// the table saves, `crate::cost`); `null` where the accelerator was given, and on the CPU.
    #[serde(default)]
    pub accel_auto: Option<String>,
    /// How a PNG encodes the values: `srgb` or `display` (see [`crate::scene::Transfer`]).
    pub transfer: crate::scene::Transfer,
    /// How a PNG brings radiance beyond 1 into range (`--tonemap`).
    #[serde(default)]
    pub tonemap: crate::scene::Tonemap,
    /// `--exposure`: a PNG shows the radiance times 2^exposure.
    #[serde(default)]
    pub exposure: f64,
    /// `--tile` or `--crop`: the pixels rendered, `{x0, y0, x1, y1}` (ends exclusive) of the
    /// `size` image; absent for a whole image. The counts are those of the grid points the
    /// window owns ([`crate::job::GridRegion`]), so the parts' counts add up to the whole's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub window: Option<crate::region::Region>,
}

/// Everything `--stats` reports.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Stats {
    pub settings: Settings,
    /// The effects simulated, from: shadows, reflection, refraction, textures, emission.
    pub effects: Vec<&'static str>,
    pub rays: RayStats,
    pub tests: TestCounts,
    pub tests_per_ray: TestsPerRay,
    /// Bounding-volume tests per ray, by kind: the tables' group spheres or the GPU BVH's
    /// nodes (see [`TestCounts::bound`]).
    pub bound_tests_per_ray: TestsPerRay,
    pub time: Times,
    /// Bytes of the acceleration structure on the device: the candidate tables or the BVH
    /// (0 for brute force and on the CPU).
    pub accel_bytes: u64,
    /// Bytes of the scene's textures on the device (their texels, 4 bytes each; 0 without
    /// textures and on the CPU).
    pub texture_bytes: u64,
    /// Whether the rays and tests were counted. The GPU kernels count only when asked
    /// (`RenderOptions::count`, `--stats`); uncounted, every count above is 0.
    pub counted: bool,
    /// Lane coherence of the wavefront kernels by depth ([`LaneStats`]): counted GPU renders
    /// only, else empty.
    pub lanes: LaneStats,
    /// The raw counters the report was made from (not printed: a partial render records
    /// them, so that merged parts add up exactly).
    #[serde(skip)]
    pub counters: Counters,
}

impl Stats {
    /// Assembles the report from raw counters.
    pub fn new(settings: Settings, effects: Vec<&'static str>, c: &Counters, time: Times) -> Stats {
        let rays_of = |k: RayKind| c.rays[k.index()];
        let per = |tests: u64, rays: u64| if rays == 0 { 0.0 } else { tests as f64 / rays as f64 };
        let tpr = |k: RayKind| per(c.tests[k.index()].total(), rays_of(k));
        let bpr = |k: RayKind| per(c.tests[k.index()].bound, rays_of(k));
        let mut tests = TestCounts::default();
        for t in c.tests {
            tests += t;
        }
        let total_rays: u64 = c.rays.iter().sum();
        Stats {
            settings,
            effects,
            rays: RayStats {
                eye: rays_of(RayKind::Eye),
                eye_hit: c.eye_hit,
                reflect: rays_of(RayKind::Reflect),
                refract: rays_of(RayKind::Refract),
                shadow: rays_of(RayKind::Shadow),
                shadow_blocked: c.shadow_blocked,
                self_hits: c.self_hits,
                total: total_rays,
            },
            tests,
            tests_per_ray: TestsPerRay {
                eye: tpr(RayKind::Eye),
                shadow: tpr(RayKind::Shadow),
                reflect: tpr(RayKind::Reflect),
                refract: tpr(RayKind::Refract),
                all: per(tests.total(), total_rays),
            },
            bound_tests_per_ray: TestsPerRay {
                eye: bpr(RayKind::Eye),
                shadow: bpr(RayKind::Shadow),
                reflect: bpr(RayKind::Reflect),
                refract: bpr(RayKind::Refract),
                all: per(tests.bound, total_rays),
            },
            time,
            accel_bytes: 0,
            texture_bytes: 0,
            counted: true,
            lanes: LaneStats::default(),
            counters: *c,
        }
    }

    /// One JSON object (nested objects per group), without a trailing newline.
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).expect("statistics always serialise")
    }

    /// A human-readable multi-line report.
    pub fn to_text(&self) -> String {
        let mut o = self.settings_text();
        o += &self.counts_text();
        o += &self.time_text();
        o += &self.lanes_text();
        o
    }

    /// The report's lines on what was rendered and how: `render:`, `window:` (for a part),
    /// `effects:`, `precision:` and `textures:` (when there are any), each ending in a
    /// newline.
    fn settings_text(&self) -> String {
        let s = &self.settings;
        let effects = if self.effects.is_empty() { "none".to_string() } else { self.effects.join(", ") };
        let mut o = String::new();
        o += &format!(
            "render:   {} backend, accel {}, {}x{}, sampling {}, {} spp, seed {}, max depth {}, transfer {}\n",
            s.backend,
            s.accel,
            s.size[0],
            s.size[1],
            s.sampling,
            s.spp,
            s.seed,
            s.max_depth,
            s.transfer.name()
        );
        if let Some(form) = &s.kernel_form {
            let how =
                if form == "tree" { "a point's whole ray tree per invocation" } else { "queues of rays" };
            o += &format!("kernels:  {form} form ({how})\n");
        }
        if let Some(w) = s.window {
            o += &format!("window:   pixels x {}..{}, y {}..{} of the image\n", w.x0, w.x1, w.y0, w.y1);
        }
        o += &format!("effects:  {effects}\n");
        match &s.precision_auto {
            Some(why) => o += &format!("precision: {} (auto: {why})\n", s.precision),
            None => o += &format!("precision: {}\n", s.precision),
        }
        if let Some(why) = &s.accel_auto {
            o += &format!("accel:    {} (auto: {why})\n", s.accel);
        }
        if self.texture_bytes > 0 {
            o += &format!(
                "textures: {:.1} MiB on the device\n",
                self.texture_bytes as f64 / (1u64 << 20) as f64
            );
        }
        o
    }

    /// The report's lines on rays and intersection tests: `rays:`, `tests:`, `per ray:` and
    /// `bounds:` (when there were bound tests), or the one line saying they were not
    /// counted; each ends in a newline.
    fn counts_text(&self) -> String {
        let r = &self.rays;
        let t = &self.tests;
        let p = &self.tests_per_ray;
        let mut o = String::new();
        if self.counted {
            o += &format!(
                "rays:     {} in all: {} eye ({} hit), {} reflect, {} refract, {} shadow ({} blocked); {} self-hits\n",
                r.total, r.eye, r.eye_hit, r.reflect, r.refract, r.shadow, r.shadow_blocked, r.self_hits
            );
            o += &format!(
                "tests:    {} in all: {} sphere, {} triangle, {} cylinder\n",
                t.total(),
                t.sphere,
                t.triangle,
                t.cylinder
            );
            o += &format!(
                "per ray:  {:.3} eye, {:.3} shadow, {:.3} reflect, {:.3} refract, {:.3} overall\n",
                p.eye, p.shadow, p.reflect, p.refract, p.all
            );
            if t.bound > 0 {
                let b = &self.bound_tests_per_ray;
                o += &format!(
                    "bounds:   {} bound tests (BVH nodes); per ray {:.3} eye, {:.3} shadow, {:.3} reflect, {:.3} refract\n",
                    t.bound, b.eye, b.shadow, b.reflect, b.refract
                );
            }
        } else {
            o += "rays:     not counted (the GPU kernels count for --stats)\n";
        }
        o
    }

    /// The report's `time:` line (the times that were measured, in one line) and, when the
    /// GPU kernels were timed at more than one depth, the `by depth:` table; each line ends
    /// in a newline.
    fn time_text(&self) -> String {
        let mut o =
            format!("time:     preprocess {:.3} s, trace {:.3} s", self.time.preprocess_s, self.time.trace_s);
        if let Some(g) = self.time.gpu_s {
            o += &format!(", GPU kernels {g:.3} s");
            let k = &self.time.gpu_kernel_s;
            let named = [
                ("nearest", k.nearest),
                ("shade", k.shade),
                ("shadow", k.shadow),
                ("tree", k.tree),
                ("resolve", k.resolve),
                ("aov", k.aov),
            ];
            for (name, t) in named {
                if let Some(t) = t {
                    o += &format!(" ({name} {t:.3} s)");
                }
            }
        }
        if let Some(c) = self.time.compile_s {
            o += &format!(", compile {c:.3} s");
        }
        if let Some(l) = self.time.longest_dispatch_s {
            o += &format!(", longest dispatch {:.1} ms", l * 1e3);
        }
        if let Some(l) = self.time.longest_submit_s {
            o += &format!(", longest submission {:.1} ms", l * 1e3);
        }
        if let Some(n) = self.time.tiles_run_again.filter(|&n| n > 0) {
            o += &format!(", {n} tiles run again");
        }
        o += "\n";
        if let Some(depths) = self.time.gpu_depth_s.as_ref().filter(|d| d.len() > 1) {
            o += "by depth: GPU kernels (nearest + shade + shadow)\n";
            for d in depths {
                o += &format!(
                    "  {:2}: {:.3} s ({:.3} + {:.3} + {:.3})\n",
                    d.depth, d.all, d.nearest, d.shade, d.shadow
                );
            }
        }
        if self.time.phases.total_s > 0.0 {
            o += &format!("{}\n", self.time.phases.to_text());
        }
        o
    }

    /// The report's `lanes:` table (a header and a line per kernel that has rows), or
    /// nothing when no kernel's lanes were measured.
    fn lanes_text(&self) -> String {
        let l = &self.lanes;
        let mut o = String::new();
        if !(l.nearest.is_empty() && l.shade.is_empty() && l.shadow.is_empty()) {
            o += "lanes:    mean loop iterations per invocation / per group of 8 / of 32 (its busiest lane), by depth\n";
            for (name, rows) in [("nearest", &l.nearest), ("shade", &l.shade), ("shadow", &l.shadow)] {
                if rows.is_empty() {
                    continue;
                }
                let parts: Vec<String> = rows
                    .iter()
                    .map(|r| format!("{}: {:.1} / {:.1} / {:.1}", r.depth, r.steps, r.max8, r.max32))
                    .collect();
                o += &format!("  {name:8}{}\n", parts.join(", "));
            }
        }
        o
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats_add_up() {
        let mut tests = [TestCounts::default(); 4];
        tests[0] = TestCounts { sphere: 30, triangle: 10, cylinder: 0, bound: 6 };
        tests[1] = TestCounts { sphere: 4, triangle: 0, cylinder: 4, bound: 0 };
        let c = Counters { rays: [10, 4, 2, 0], tests, eye_hit: 7, shadow_blocked: 1, self_hits: 0 };
        let s = Stats::new(Settings::default(), vec!["shadows"], &c, Times::default());
        assert_eq!(s.rays.total, 16);
        assert_eq!(s.tests.total(), 48);
        assert_eq!(s.tests_per_ray.eye, 4.0);
        assert_eq!(s.tests_per_ray.shadow, 2.0);
        assert_eq!(s.tests_per_ray.refract, 0.0);
        assert_eq!(s.bound_tests_per_ray.eye, 0.6);
        let v: serde_json::Value = serde_json::from_str(&s.to_json()).unwrap();
        for key in ["eye", "eye_hit", "reflect", "refract", "shadow", "shadow_blocked", "self_hits"] {
            assert!(v["rays"][key].is_u64(), "rays.{key} missing");
        }
        for key in ["sphere", "triangle", "cylinder", "bound"] {
            assert!(v["tests"][key].is_u64(), "tests.{key} missing");
        }
        for key in ["eye", "shadow", "reflect", "refract"] {
            assert!(v["tests_per_ray"][key].is_number(), "tests_per_ray.{key} missing");
        }
        assert!(v["time"]["preprocess_s"].is_number() && v["time"]["trace_s"].is_number());
        assert_eq!(v["rays"]["eye"], 10);
    }
}
