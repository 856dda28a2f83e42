//! What `cuberay info` reports about a scene: primitive counts, lights, materials, bounds,
//! the effects the scene calls for, what a render of it resolves (the precision, the
//! accelerator, what rays leaving surfaces take: the same choices a render makes, handed in
//! resolved), and a glTF file's extensions with what the loader does with each, as text or
//! as one JSON object.

use serde::Serialize;

use crate::job::RenderOptions;
use crate::load::gltf::extensions::ExtensionInfo;
use crate::scene::{Camera, LightSource, Projection, Scene};

/// The scene summary. Serialised as-is by `cuberay info --json`.
#[derive(Clone, Debug, Serialize)]
pub struct SceneInfo {
    pub spheres: usize,
    /// After triangulation, counted per instance.
    pub triangles: usize,
    /// Cylinders and cones.
    pub cylinders: usize,
    pub primitives: usize,
    /// Lights in the file (not the loader's default light or the environment's).
    pub lights: usize,
    /// True when the file has no light and the default headlight was added.
    pub default_light: bool,
    /// The environment around the scene (`--env`): `null` for none (the background colour).
    pub environment: Option<EnvironmentInfo>,
    pub materials: usize,
    pub textures: usize,
    /// World-space box of the geometry, `[[min x,y,z],[max x,y,z]]`, in the file's axes.
    pub bounds: Option<[[f64; 3]; 2]>,
    /// The effects the scene calls for, from: shadows, reflection, refraction, textures,
    /// emission.
    pub effects: Vec<&'static str>,
    pub camera: CameraInfo,
    /// The resolution the file asks for, if any.
    pub resolution: Option<[u32; 2]>,
    /// The GPU kernels' arithmetic a render at the default image size resolves (`--precision
    /// auto`): `f32` or `f64` ([`crate::arith::precision`]).
    pub precision: &'static str,
    /// Why, where `auto` chose: the comparison that decided it.
    pub precision_auto: Option<PrecisionInfo>,
    /// The accelerator a render resolves (`--accel auto`).
    pub accel: &'static str,
    /// Why, where `auto` chose: each origin's predicted build against what its table saves
    /// ([`crate::cost`]); `null` without an adapter or where the accelerator was given.
    pub accel_auto: Option<String>,
    /// Whether the scene sends rays from surfaces (mirrors, glass, blended surfaces, shadow
    /// rays towards directional lights): under `--accel cube` they take the BVH or the
    /// platform's ray queries (`surface_walk`), while eye rays and shadow rays towards point
    /// lights take the tables.
    pub surface_rays: bool,
    /// What those rays take on this adapter: `bvh` or `rayquery` (`auto` without an adapter).
    pub surface_walk: &'static str,
    /// How the GPU kernels trace the ray trees on this adapter: `wavefront` or `tree`
    /// (`auto` without an adapter; `--kernel-form`).
    pub kernel_form: &'static str,
    /// The GPU adapter the choices were made for (`null`: none found).
    pub adapter: Option<String>,
    /// Why a GPU render of the scene would be refused (`null`: it would not be).
    pub gpu_refuses: Option<String>,
    /// A glTF file's extensions (used or required), each with its status: `read`,
    /// `approximated`, `ignored` or `refused` ([`SceneInfo::with_extensions`]; empty for NFF).
    pub extensions: Vec<ExtensionInfo>,
}

/// The comparison `--precision auto` makes ([`crate::arith::precision::F32Need`]).
#[derive(Clone, Debug, Serialize)]
pub struct PrecisionInfo {
    /// The image height it was decided for (the file's, else the default 512).
    pub height: u32,
    /// The ratio of f32's spawn offset to a feature of the comparison that set the margin.
    pub ratio: f64,
    /// That comparison's limit, beyond which the render is in f64.
    pub limit: f64,
    /// `limit / ratio`: above 1, f32 resolves the scene by that factor (`null`: no
    /// geometry).
    pub margin: Option<f64>,
    /// False when `margin` is a lower bound (no primitive came near the limit).
    pub exact: bool,
    /// The same in words.
    pub reason: String,
}

/// What `--env` set up.
#[derive(Clone, Debug, Serialize)]
pub struct EnvironmentInfo {
    /// `studio`, or the map's file name.
    pub name: String,
    pub width: u32,
    pub height: u32,
    pub intensity: f64,
    /// The directional lights standing in for it.
    pub lights: usize,
}

#[derive(Clone, Debug, Serialize)]
pub struct CameraInfo {
    pub projection: &'static str,
    pub eye: [f64; 3],
    pub forward: [f64; 3],
    pub up: [f64; 3],
    /// Full vertical field of view in degrees (perspective cameras).
    pub fov_y_degrees: Option<f64>,
    /// Half height of the view volume (orthographic cameras).
    pub half_height: Option<f64>,
    /// The point at the image's centre (`--look-at`).
    pub look_at: [f64; 3],
    /// The camera as the command line's flags give it (perspective cameras: `--fov` between
    /// the image's edges at the default height), to copy and adjust.
    pub flags: String,
}

impl SceneInfo {
    /// The summary of `scene`, with what a render of it with `resolved` options (resolved by
    /// `gpu::choose::resolve` on `adapter`, or without one) does.
    pub fn of(scene: &Scene, resolved: &RenderOptions, adapter: Option<String>) -> SceneInfo {
        let counts = scene.counts();
        let height = resolved.height;
        let b = scene.bounds();
        let cam = &scene.camera;
        let (projection, fov, half) = match cam.projection {
            Projection::Perspective { fov_y, .. } => ("perspective", Some(fov_y.to_degrees()), None),
            Projection::Orthographic { half_height } => ("orthographic", None, Some(half_height)),
        };
        SceneInfo {
            spheres: counts.spheres,
            triangles: counts.triangles,
            cylinders: counts.cylinders,
            primitives: scene.primitives.len(),
            lights: scene.file_lights().count(),
            default_light: scene.lights.iter().any(|l| l.source == LightSource::Default),
            environment: scene.environment.as_ref().map(|e| EnvironmentInfo {
                name: e.name.clone(),
                width: e.width,
                height: e.height,
                intensity: e.intensity,
                lights: scene.lights.iter().filter(|l| l.source == LightSource::Environment).count(),
            }),
            materials: scene.materials.len(),
            textures: scene.textures.len(),
            bounds: (!b.is_empty()).then(|| [b.min.to_array(), b.max.to_array()]),
            effects: scene.effects().names(),
            camera: CameraInfo {
                projection,
                eye: cam.eye.to_array(),
                forward: cam.forward.to_array(),
                up: cam.up.to_array(),
                fov_y_degrees: fov,
                half_height: half,
                look_at: cam.target.to_array(),
                flags: camera_flags(scene, height),
            },
            resolution: scene.resolution.map(|(w, h)| [w, h]),
            precision: resolved.precision.name(),
            precision_auto: resolved.auto_precision.as_ref().map(|need| PrecisionInfo {
                height,
                ratio: need.ratio,
                limit: need.limit,
                margin: Some(need.margin).filter(|m| m.is_finite()),
                exact: need.exact,
                reason: need.reason(),
            }),
            accel: resolved.accel.name(),
            accel_auto: resolved.auto_accel.as_ref().map(|a| a.reason()),
            surface_rays: crate::coherence::traces_surface_rays(scene, &Default::default()),
            surface_walk: resolved.surface.name(),
            kernel_form: resolved.form.name(),
            adapter,
            gpu_refuses: None,
            extensions: Vec::new(),
        }
    }

    /// The same, with the extensions of the glTF file at `path` listed.
    pub fn with_extensions(mut self, path: &std::path::Path) -> SceneInfo {
        self.extensions = crate::load::gltf::extensions::of_file(path);
        self
    }

    /// A human-readable multi-line summary.
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        let f3 = |v: [f64; 3]| format!("({:.6}, {:.6}, {:.6})", v[0], v[1], v[2]);
        s += &format!(
            "primitives: {} ({} spheres, {} triangles, {} cylinders/cones)\n",
            self.primitives, self.spheres, self.triangles, self.cylinders
        );
        s += &format!(
            "lights:     {}{}\n",
            self.lights,
            if self.default_light { " (none in the file: using the default headlight)" } else { "" }
        );
        s += &format!("materials:  {}\n", self.materials);
        s += &format!("textures:   {}\n", self.textures);
        match self.bounds {
            Some([lo, hi]) => s += &format!("bounds:     {} .. {}\n", f3(lo), f3(hi)),
            None => s += "bounds:     (empty)\n",
        }
        let effects = if self.effects.is_empty() { "none".to_string() } else { self.effects.join(", ") };
        s += &format!("effects:    {effects}\n");
        let c = &self.camera;
        s += &format!("camera:     {} at {} looking along {}", c.projection, f3(c.eye), f3(c.forward));
        if let Some(f) = c.fov_y_degrees {
            s += &format!(", vertical field of view {f:.3} degrees");
        }
        if let Some(h) = c.half_height {
            s += &format!(", half height {h}");
        }
        s += "\n";
        s += &format!("            {}\n", c.flags);
        match &self.environment {
            Some(e) => {
                s += &format!(
                    "environment: {} ({}x{}, intensity {}), {} directional lights standing in for it\n",
                    e.name, e.width, e.height, e.intensity, e.lights
                )
            }
            None => s += "environment: none (the background colour)\n",
        }
        if let Some([w, h]) = self.resolution {
            s += &format!("resolution: {w}x{h}\n");
        }
        match &self.precision_auto {
            Some(p) => {
                s += &format!(
                    "precision:  {} (auto, {} pixels high: {})\n",
                    self.precision, p.height, p.reason
                )
            }
            None => s += &format!("precision:  {} (given)\n", self.precision),
        }
        s += &format!(
            "adapter:    {}\n",
            self.adapter.as_deref().unwrap_or("none found (a GPU render would fail)")
        );
        s += &format!("accel:      {}", self.accel);
        match &self.accel_auto {
            Some(why) => s += &format!(" (auto: {why})"),
            None if self.accel == "cube" => {
                s += ": eye rays and shadow rays towards point lights take the candidate tables"
            }
            None => {}
        }
        s += "\n";
        s += &format!("rays:       {}\n", self.surface_text());
        s += &format!("kernels:    {}\n", self.form_text());
        if let Some(why) = &self.gpu_refuses {
            s += &format!("GPU:        refuses this scene: {why}\n");
        }
        for (i, e) in self.extensions.iter().enumerate() {
            s += if i == 0 { "extensions: " } else { "            " };
            let required = if e.required { ", required" } else { "" };
            s += &format!("{} ({}{required}): {}\n", e.name, e.status.name(), e.how);
        }
        s
    }
}

impl SceneInfo {
    /// How the kernels trace the ray trees, in words.
    fn form_text(&self) -> String {
        let how = match self.kernel_form {
            "tree" => "the tree form, each invocation tracing its point's whole ray tree depth first",
            "wavefront" => "the wavefront form, breadth first over queues of rays (this driver limits loops)",
            _ => "the tree form where the driver allows it, else the wavefront",
        };
        format!("{how} (--kernel-form)")
    }

    /// What the rays leaving surfaces take, in words.
    fn surface_text(&self) -> String {
        if !self.surface_rays {
            return "no ray leaves a surface".into();
        }
        let takes = match self.surface_walk {
            "rayquery" => "the platform's ray queries",
            "bvh" => "the BVH",
            _ => "ray queries on a GPU with them (lavapipe's are slower than its BVH), else the BVH",
        };
        match self.accel {
            "cube" => format!("rays leaving surfaces take {takes} (--surface-walk)"),
            a => format!("every ray takes --accel {a}"),
        }
    }
}

/// The camera of `scene` as `--look-from`, `--look-at`, `--up` and `--fov` flags (the field
/// of view between the image's edges at an image `height` pixels high).
pub fn camera_flags(scene: &Scene, height: u32) -> String {
    let c = &scene.camera;
    let v = |p: glam::DVec3| format!("{},{},{}", fmt(p.x), fmt(p.y), fmt(p.z));
    // The scene's up where it gives this camera (no roll about the view), else the camera's.
    let level =
        Camera::look_at(c.eye, c.target, scene.up, c.projection).is_ok_and(|l| l.up.abs_diff_eq(c.up, 1e-9));
    let up = if level { scene.up } else { c.up };
    let mut s = format!("--look-from {} --look-at {} --up {}", v(c.eye), v(c.target), v(up));
    if let Some(f) = c.fov_edges_degrees(height) {
        s += &format!(" --fov {}", fmt(f));
    }
    s
}

/// A number as short as it reads back the same to 1e-9 of itself.
fn fmt(x: f64) -> String {
    for digits in 0..=12 {
        let t = format!("{x:.digits$}");
        if t.parse::<f64>().is_ok_and(|y| (y - x).abs() <= 1e-9 * x.abs().max(1e-3)) {
            return if t == "-0" { "0".into() } else { t };
        }
    }
    format!("{x}")
}
