//! What one compiled kernel module contains ([`Variant`]): the effects it simulates, the
//! accelerator it traces rays with ([`Accel`]), its precision, the kinds of primitive it
//! intersects, whether rays leave surfaces and which walk takes them, and whether it counts.
//! Each field is a flag of `gpu::shaders`' preprocessor ([`Variant::flag`]); a render
//! derives its variant from the scene and the options in one place
//! ([`super::prepare::variant`]), the tests compile [`Variant::all`].

pub use crate::job::Accel;
use crate::scene::{Effects, Shapes};

/// The code paths one compiled module contains.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Variant {
    /// The effects the module simulates (`SHADOWS`, `REFLECTION`, ... `ENVIRONMENT`): what
    /// its tables must serve.
    pub effects: Effects,
    /// How the kernels find candidates: the tables, the BVH, brute force or ray queries
    /// (never [`Accel::Auto`]: a render resolves it first).
    pub accel: Accel,
    /// Intersection tests and hit points in f64 (`--precision f64`; `SHADER_F64`).
    pub f64: bool,
    /// The kinds of primitive whose intersection and surface code the module holds (default:
    /// all). On lavapipe a kernel pays for the branches it does not take, so a scene of
    /// triangles alone traces faster without the sphere and cylinder tests in its loops.
    pub shapes: Shapes,
    /// Whether rays leave surfaces (`SURFACE_RAYS`), so that the table kernels hold the walk
    /// of the BVH that takes such rays. [`Variant::for_effects`] assumes so
    /// wherever reflection or shadows may spawn them; a render narrows it to what its tables
    /// trace (`GpuRenderer::for_scene`): a scene whose shadow rays all leave point lights and
    /// that has no mirror or glass traces none, and its kernels would otherwise run a BVH loop
    /// for every eye and shadow ray on lavapipe, where a loop no invocation enters still
    /// runs once.
    pub surface_rays: bool,
    /// Whether shadow rays may walk the BVH (`BVH_SHADOWS`): with the tables, the rays of
    /// directional lights, which have no table. A render narrows it to scenes with such a
    /// light (`GpuRenderer::for_scene`): on lavapipe (Mesa 22.3) the `shade` kernel ran the
    /// BVH's shadow walk once for every light of every hit where no shadow ray took it, 10 %
    /// of the eye's `shade` time on balls_s4 and gears_s4.
    pub bvh_shadows: bool,
    /// With the tables, whether the rays leaving surfaces take the platform's ray queries
    /// (`SURFACE_RQ`) instead of the BVH walk: the default where the adapter offers them and
    /// its measurements favour them (`gpu::choose::resolve`).
    pub surface_rq: bool,
    /// Whether the primitives are split over several bindings (`SPLIT_PRIMS`): more than one
    /// binding holds (lavapipe: 128 MiB, two million primitives in f32). Every read of a
    /// primitive then picks its binding, which lavapipe pays in every lane, so only a scene
    /// that needs it gets it.
    pub split_prims: bool,
    /// Whether the kernels count rays and tests into the statistics counters (`COUNTERS`).
    /// On lavapipe counting costs a kernel 5–22 % of its time (a private array indexed per
    /// lane at every test, workgroup atomics at the end), so a render counts only when asked
    /// to (`RenderOptions::count`); uncounted, its counts are zero.
    pub counters: bool,
}

impl Default for Variant {
    /// No effect, the tables, f32, every kind of primitive, uncounted: the variant of the
    /// kernels that trace nothing.
    fn default() -> Variant {
        Variant {
            effects: Effects::default(),
            accel: Accel::Cube,
            f64: false,
            shapes: Shapes::ALL,
            surface_rays: false,
            bvh_shadows: false,
            surface_rq: false,
            split_prims: false,
            counters: false,
        }
    }
}

impl Variant {
    /// The variant for a scene's effects rendered with `max_depth` (below 2 no secondary
    /// ray is ever spawned, so neither reflection nor refraction code is needed).
    pub fn for_effects(e: Effects, max_depth: u32) -> Variant {
        let secondary = max_depth >= 2;
        let reflection = e.reflection && secondary;
        Variant {
            effects: Effects {
                reflection,
                refraction: e.refraction && secondary,
                // Attenuation applies on the way out of a body, which only refraction enters.
                volume: e.volume && e.refraction && secondary,
                ..e
            },
            accel: Accel::Cube,
            f64: false,
            shapes: Shapes::ALL,
            surface_rays: reflection || e.shadows || (e.blend && secondary),
            bvh_shadows: e.shadows,
            surface_rq: false,
            split_prims: false,
            counters: true,
        }
    }

    /// The same effects with rays leaving surfaces taking ray queries (`true`) or the BVH.
    pub fn with_surface_rq(self, surface_rq: bool) -> Variant {
        Variant { surface_rq, ..self }
    }

    /// Whether the module traces with the platform's ray queries (it binds the acceleration
    /// structure and needs `EXPERIMENTAL_RAY_QUERY`): `--accel rayquery`, or the tables with
    /// rays leaving surfaces sent to ray queries.
    pub fn ray_queries(&self) -> bool {
        self.accel == Accel::RayQuery || (self.cube() && self.surface_rays && self.surface_rq)
    }

    /// The same effects for a scene of `shapes` only.
    pub fn with_shapes(self, shapes: Shapes) -> Variant {
        Variant { shapes, ..self }
    }

    /// The same effects where rays leave surfaces only if `surface_rays` (and the effects
    /// may spawn them).
    pub fn with_surface_rays(self, surface_rays: bool) -> Variant {
        Variant { surface_rays: self.surface_rays && surface_rays, ..self }
    }

    /// The same effects where shadow rays walk the BVH only if `bvh_shadows` (and the effects
    /// say they may).
    pub fn with_bvh_shadows(self, bvh_shadows: bool) -> Variant {
        Variant { bvh_shadows: self.bvh_shadows && bvh_shadows, ..self }
    }

    /// The same effects, counted (`true`) or not.
    pub fn with_counters(self, counters: bool) -> Variant {
        Variant { counters, ..self }
    }

    /// The same effects with intersections in f64 (`true`) or f32.
    pub fn with_f64(self, f64: bool) -> Variant {
        Variant { f64, ..self }
    }

    /// The same effects traced with `accel`.
    pub fn with_accel(self, accel: Accel) -> Variant {
        Variant { accel, ..self }
    }

    /// Whether the kernels walk the direction-cube tables.
    pub fn cube(&self) -> bool {
        self.accel == Accel::Cube
    }

    /// The variants the tests compile: the 32 effect sets for each of [`Accel::GPU`], in f32
    /// and in f64, with every kind of primitive (192, the effect sets in the order of their
    /// bits, the last of each 32 with every effect), then every other set of kinds (none
    /// included: a scene may hold no primitive) with every effect (42), then shadows without
    /// rays leaving surfaces (lights with tables, no mirror), with and without textures and
    /// emission (12), then every effect uncounted (6), then the map and layer effects each
    /// without the others (`Variant::apart`, 54), so that
    /// each `#if` is compiled both ways. Vertex colours, maps, normal maps, alpha and blend are off in the 32 effect sets
    /// and on in the rest (each further effect is compiled on and off against a
    /// representative rest, not in the full product); last, every effect with the
    /// primitives split over bindings, for each accelerator (4).
    pub fn all() -> Vec<Variant> {
        let none = Effects::default();
        let effects = [false, true].into_iter().flat_map(move |f64| {
            Accel::GPU.into_iter().flat_map(move |accel| {
                (0..32u32).map(move |b| Variant {
                    effects: Effects {
                        shadows: b & 1 != 0,
                        reflection: b & 2 != 0,
                        refraction: b & 4 != 0,
                        textures: b & 8 != 0,
                        emission: b & 16 != 0,
                        ..none
                    },
                    accel,
                    f64,
                    shapes: Shapes::ALL,
                    surface_rays: b & 3 != 0,
                    bvh_shadows: b & 1 != 0,
                    surface_rq: false,
                    split_prims: false,
                    counters: true,
                })
            })
        });
        let shapes = [false, true].into_iter().flat_map(|f64| {
            Accel::GPU.into_iter().flat_map(move |accel| {
                (0..7u32).map(move |b| {
                    let shapes = Shapes { spheres: b & 1 != 0, triangles: b & 2 != 0, cylinders: b & 4 != 0 };
                    Variant { f64, shapes, ..Variant::full(accel) }
                })
            })
        });
        let point_lit = [false, true].into_iter().flat_map(move |f64| {
            Accel::GPU.into_iter().flat_map(move |accel| {
                [false, true].map(move |more| Variant {
                    effects: Effects {
                        shadows: true,
                        textures: more,
                        emission: more,
                        vertex_colors: more,
                        maps: more,
                        normal_maps: more,
                        alpha: more,
                        blend: more,
                        ..none
                    },
                    accel,
                    f64,
                    counters: true,
                    ..Variant::default()
                })
            })
        });
        let uncounted = [false, true].into_iter().flat_map(|f64| {
            Accel::GPU
                .into_iter()
                .map(move |accel| Variant { f64, ..Variant::full(accel) }.with_counters(false))
        });
        let apart = [false, true]
            .into_iter()
            .flat_map(move |f64| Accel::GPU.into_iter().flat_map(move |accel| Variant::apart(accel, f64)));
        // The tables with rays leaving surfaces sent to ray queries: every effect, without
        // directional lights' shadows, without mirrors or glass, uncounted.
        let surface_rq = [false, true].into_iter().flat_map(|f64| {
            let full = Variant { f64, ..Variant::full(Accel::Cube) }.with_surface_rq(true);
            let dry = Effects { reflection: false, refraction: false, ..full.effects };
            [
                full,
                Variant { bvh_shadows: false, ..full },
                Variant { effects: dry, ..full },
                full.with_counters(false),
            ]
        });
        // The primitives split over bindings, with every accelerator.
        let split = Accel::GPU.into_iter().map(|accel| Variant { split_prims: true, ..Variant::full(accel) });
        effects
            .chain(shapes)
            .chain(point_lit)
            .chain(uncounted)
            .chain(apart)
            .chain(surface_rq)
            .chain(split)
            .collect()
    }

    /// The map and layer effects apart, with `accel` in `f64` or not: maps, normal maps, a
    /// mask alone, a blend alone (which needs no texture), rays leaving surfaces without BVH
    /// shadows, an environment, a clear coat alone and over normal maps, a volume, so that
    /// none leans on another's code.
    fn apart(accel: Accel, f64: bool) -> [Variant; 9] {
        let lit = Effects { shadows: true, reflection: true, ..Effects::default() };
        let base = Variant { effects: lit, accel, f64, ..Variant::default() };
        let with = |effects: Effects| Variant { effects, ..base };
        [
            with(Effects { textures: true, maps: true, ..lit }),
            with(Effects { textures: true, normal_maps: true, ..lit }),
            with(Effects { textures: true, alpha: true, ..lit }),
            Variant { surface_rays: true, ..with(Effects { blend: true, ..lit }) },
            Variant { surface_rays: true, bvh_shadows: false, ..base },
            with(Effects { environment: true, ..lit }),
            with(Effects { clearcoat: true, ..lit }),
            with(Effects { textures: true, normal_maps: true, clearcoat: true, ..lit }),
            with(Effects { refraction: true, volume: true, ..lit }),
        ]
    }

    /// Every effect with `accel`.
    pub fn full(accel: Accel) -> Variant {
        Variant { accel, ..Variant::for_effects(Effects::ALL, crate::layout::MAX_DEPTH) }
    }

    pub(super) fn flag(&self, name: &str) -> Option<bool> {
        Some(match name {
            "SHADOWS" => self.effects.shadows,
            "REFLECTION" => self.effects.reflection,
            "REFRACTION" => self.effects.refraction,
            "TEXTURES" => self.effects.textures,
            "EMISSION" => self.effects.emission,
            "VERTEX_COLORS" => self.effects.vertex_colors,
            "MAPS" => self.effects.maps,
            "NORMAL_MAPS" => self.effects.normal_maps,
            "ALPHA" => self.effects.alpha,
            "BLEND" => self.effects.blend,
            "ENVIRONMENT" => self.effects.environment,
            "VOLUME" => self.effects.volume,
            "CLEARCOAT" => self.effects.clearcoat,
            // Shadow walks test alpha: masked or blended materials.
            "CUTOUTS" => self.effects.alpha || self.effects.blend,
            "F64" => self.f64,
            "SPHERES" => self.shapes.spheres,
            "TRIANGLES" => self.shapes.triangles,
            "CYLINDERS" => self.shapes.cylinders,
            // Rays leave surfaces: reflection and refraction rays, and shadow rays towards
            // directional lights (which have no table).
            "SURFACE_RAYS" => self.surface_rays,
            // Shadow rays take the walk of rays leaving surfaces: all of them with the BVH,
            // with the tables those towards directional lights (the BVH's walk or, with
            // SURFACE_RQ, ray queries).
            "BVH_SHADOWS" => match self.accel {
                Accel::Bvh => true,
                Accel::Cube => self.surface_rays && self.bvh_shadows,
                Accel::Auto | Accel::Brute | Accel::RayQuery => false,
            },
            "COUNTERS" => self.counters,
            "SPLIT_PRIMS" => self.split_prims,
            "CUBE" => self.accel == Accel::Cube,
            "BVH" => self.accel == Accel::Bvh,
            "BRUTE" => self.accel == Accel::Brute,
            "RAYQUERY" => self.accel == Accel::RayQuery,
            // The tables send rays leaving surfaces to ray queries, not the BVH.
            "SURFACE_RQ" => self.cube() && self.surface_rays && self.surface_rq,
            // The module binds the acceleration structure (rayquery.wgsl).
            "RAY_QUERIES" => self.ray_queries(),
            // Shadow rays take ray queries: all of them with `--accel rayquery`, with the
            // tables those of directional lights where rays leaving surfaces take them.
            "RQ_SHADOWS" => {
                self.effects.shadows
                    && match self.accel {
                        Accel::RayQuery => true,
                        Accel::Cube => self.surface_rays && self.surface_rq && self.bvh_shadows,
                        Accel::Auto | Accel::Bvh | Accel::Brute => false,
                    }
            }
            _ => return None,
        })
    }
}
