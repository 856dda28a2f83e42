//! What one compiled kernel module contains ([`Variant`]): the effects it simulates, the
//! queries it traces rays with ([`Queries`]), its precision, the kinds of primitive it
//! intersects, whether rays leave surfaces and which walk takes them, and whether it counts.
//! Each field is a flag of `gpu::shaders`' preprocessor ([`Variant::flag`]); the render
//! derives the variant from the scene and the options (`gpu::setup`), the tests compile
//! [`Variant::all`].

use crate::scene::{Effects, Shapes};

/// Which queries a kernel traces rays with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Queries {
    /// The direction-cube candidate tables (`--accel cube`, the default).
    #[default]
    Tables,
    /// Every primitive for every ray (`--accel brute`).
    Brute,
    /// The bounding volume hierarchy (`--accel bvh`), the baseline the tables are timed against.
    Bvh,
    /// The platform's ray queries over one structure of a box per primitive
    /// (`--accel rayquery`; `shaders/shared/rayquery.wgsl`): the driver culls, the kernels
    /// test the candidates it hands them.
    RayQuery,
}

impl Queries {
    pub const ALL: [Queries; 4] = [Queries::Tables, Queries::Bvh, Queries::Brute, Queries::RayQuery];

    /// The `--accel` name.
    pub fn name(self) -> &'static str {
        match self {
            Queries::Tables => "cube",
            Queries::Bvh => "bvh",
            Queries::Brute => "brute",
            Queries::RayQuery => "rayquery",
        }
    }
}

/// The code paths one compiled module contains.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct Variant {
    pub shadows: bool,
    pub reflection: bool,
    pub refraction: bool,
    pub textures: bool,
    pub emission: bool,
    /// Triangles carry vertex colours that multiply the base colour (`VERTEX_COLORS`).
    pub vertex_colors: bool,
    /// Materials evaluate metallic-roughness, emissive and transmission maps per hit (`MAPS`).
    pub maps: bool,
    /// Materials bend shading normals with normal maps (`NORMAL_MAPS`).
    pub normal_maps: bool,
    /// Every walk tests alpha at hits of masked materials (`ALPHA`).
    pub alpha: bool,
    /// Hits of blended materials spawn pass-through rays, and shadow walks test alpha at
    /// them (`BLEND`).
    pub blend: bool,
    /// Rays that leave the scene look up the environment map (`ENVIRONMENT`).
    pub environment: bool,
    /// How the kernels find candidates: the tables, the BVH, brute force or ray queries.
    pub queries: Queries,
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
    /// its measurements favour them (`gpu::setup::resolve_surface`).
    pub surface_rq: bool,
    /// Whether the kernels count rays and tests into the statistics counters (`COUNTERS`).
    /// On lavapipe counting costs a kernel 5–22 % of its time (a private array indexed per
    /// lane at every test, workgroup atomics at the end), so a render counts only when asked
    /// to (`RenderOptions::count`); uncounted, its counts are zero.
    pub counters: bool,
}

impl Variant {
    /// The variant for a scene's effects rendered with `max_depth` (below 2 no secondary
    /// ray is ever spawned, so neither reflection nor refraction code is needed).
    pub fn for_effects(e: Effects, max_depth: u32) -> Variant {
        let secondary = max_depth >= 2;
        let reflection = e.reflection && secondary;
        Variant {
            shadows: e.shadows,
            reflection,
            refraction: e.refraction && secondary,
            textures: e.textures,
            emission: e.emission,
            vertex_colors: e.vertex_colors,
            maps: e.maps,
            normal_maps: e.normal_maps,
            alpha: e.alpha,
            blend: e.blend,
            environment: e.environment,
            queries: Queries::Tables,
            f64: false,
            shapes: Shapes::ALL,
            surface_rays: reflection || e.shadows || (e.blend && secondary),
            bvh_shadows: e.shadows,
            surface_rq: false,
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
        self.queries == Queries::RayQuery || (self.tables() && self.surface_rays && self.surface_rq)
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

    /// The same effects traced with `queries`.
    pub fn with_queries(self, queries: Queries) -> Variant {
        Variant { queries, ..self }
    }

    /// Whether the kernels walk the candidate tables.
    pub fn tables(&self) -> bool {
        self.queries == Queries::Tables
    }

    /// The effects the kernels simulate (what their tables must serve).
    pub fn effects(&self) -> Effects {
        Effects {
            shadows: self.shadows,
            reflection: self.reflection,
            refraction: self.refraction,
            textures: self.textures,
            emission: self.emission,
            vertex_colors: self.vertex_colors,
            maps: self.maps,
            normal_maps: self.normal_maps,
            alpha: self.alpha,
            blend: self.blend,
            environment: self.environment,
        }
    }

    /// The variants the tests compile: the 32 effect sets for each of [`Queries::ALL`], in f32
    /// and in f64, with every kind of primitive (192, the effect sets in the order of their
    /// bits, the last of each 32 with every effect), then every other set of kinds (none
    /// included: a scene may hold no primitive) with every effect (42), then shadows without
    /// rays leaving surfaces (lights with tables, no mirror), with and without textures and
    /// emission (12), then every effect uncounted (6), then maps, normal maps, mask and
    /// blend each without the others, mirrors lit by point lights alone and an environment
    /// alone (36), so that
    /// each `#if` is compiled both ways. Vertex colours, maps, normal maps, alpha and blend are off in the 32 effect sets
    /// and on in the rest (each further effect is compiled on and off against a
    /// representative rest, not in the full product).
    pub fn all() -> Vec<Variant> {
        let effects = [false, true].into_iter().flat_map(|f64| {
            Queries::ALL.into_iter().flat_map(move |queries| {
                (0..32u32).map(move |b| Variant {
                    shadows: b & 1 != 0,
                    reflection: b & 2 != 0,
                    refraction: b & 4 != 0,
                    textures: b & 8 != 0,
                    emission: b & 16 != 0,
                    vertex_colors: false,
                    maps: false,
                    normal_maps: false,
                    alpha: false,
                    blend: false,
                    environment: false,
                    queries,
                    f64,
                    shapes: Shapes::ALL,
                    surface_rays: b & 3 != 0,
                    bvh_shadows: b & 1 != 0,
                    surface_rq: false,
                    counters: true,
                })
            })
        });
        let shapes = [false, true].into_iter().flat_map(|f64| {
            Queries::ALL.into_iter().flat_map(move |queries| {
                (0..7u32).map(move |b| {
                    let shapes = Shapes { spheres: b & 1 != 0, triangles: b & 2 != 0, cylinders: b & 4 != 0 };
                    Variant { f64, shapes, ..Variant::full(queries) }
                })
            })
        });
        let point_lit = [false, true].into_iter().flat_map(|f64| {
            Queries::ALL.into_iter().flat_map(move |queries| {
                [false, true].map(move |more| Variant {
                    shadows: true,
                    textures: more,
                    emission: more,
                    vertex_colors: more,
                    maps: more,
                    normal_maps: more,
                    alpha: more,
                    blend: more,
                    queries,
                    f64,
                    shapes: Shapes::ALL,
                    counters: true,
                    ..Variant::default()
                })
            })
        });
        let uncounted = [false, true].into_iter().flat_map(|f64| {
            Queries::ALL
                .into_iter()
                .map(move |queries| Variant { f64, ..Variant::full(queries) }.with_counters(false))
        });
        // The map effects apart: maps, normal maps, a mask alone, a blend alone (which needs
        // no texture), so that none leans on another's code.
        let apart = [false, true].into_iter().flat_map(|f64| {
            Queries::ALL.into_iter().flat_map(move |queries| {
                let base = Variant { shadows: true, reflection: true, queries, f64, ..Variant::default() };
                [
                    Variant { textures: true, maps: true, ..base },
                    Variant { textures: true, normal_maps: true, ..base },
                    Variant { textures: true, alpha: true, ..base },
                    Variant { blend: true, surface_rays: true, ..base },
                    Variant { surface_rays: true, bvh_shadows: false, ..base },
                    Variant { environment: true, ..base },
                ]
            })
        });
        // The tables with rays leaving surfaces sent to ray queries: every effect, without
        // directional lights' shadows, without mirrors or glass, uncounted.
        let surface_rq = [false, true].into_iter().flat_map(|f64| {
            let full = Variant { f64, ..Variant::full(Queries::Tables) }.with_surface_rq(true);
            [
                full,
                Variant { bvh_shadows: false, ..full },
                Variant { reflection: false, refraction: false, ..full },
                full.with_counters(false),
            ]
        });
        effects.chain(shapes).chain(point_lit).chain(uncounted).chain(apart).chain(surface_rq).collect()
    }

    /// Every effect with `queries`.
    pub fn full(queries: Queries) -> Variant {
        Variant { queries, ..Variant::for_effects(Effects::ALL, crate::layout::MAX_DEPTH) }
    }

    pub(super) fn flag(&self, name: &str) -> Option<bool> {
        Some(match name {
            "SHADOWS" => self.shadows,
            "REFLECTION" => self.reflection,
            "REFRACTION" => self.refraction,
            "TEXTURES" => self.textures,
            "EMISSION" => self.emission,
            "VERTEX_COLORS" => self.vertex_colors,
            "MAPS" => self.maps,
            "NORMAL_MAPS" => self.normal_maps,
            "ALPHA" => self.alpha,
            "BLEND" => self.blend,
            "ENVIRONMENT" => self.environment,
            // Shadow walks test alpha: masked or blended materials.
            "CUTOUTS" => self.alpha || self.blend,
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
            "BVH_SHADOWS" => match self.queries {
                Queries::Bvh => true,
                Queries::Tables => self.surface_rays && self.bvh_shadows,
                Queries::Brute | Queries::RayQuery => false,
            },
            "COUNTERS" => self.counters,
            "TABLES" => self.queries == Queries::Tables,
            "BVH" => self.queries == Queries::Bvh,
            "BRUTE" => self.queries == Queries::Brute,
            "RAYQUERY" => self.queries == Queries::RayQuery,
            // The tables send rays leaving surfaces to ray queries, not the BVH.
            "SURFACE_RQ" => self.tables() && self.surface_rays && self.surface_rq,
            // The module binds the acceleration structure (rayquery.wgsl).
            "RAY_QUERIES" => self.ray_queries(),
            // Shadow rays take ray queries: all of them with `--accel rayquery`, with the
            // tables those of directional lights where rays leaving surfaces take them.
            "RQ_SHADOWS" => {
                self.shadows
                    && match self.queries {
                        Queries::RayQuery => true,
                        Queries::Tables => self.surface_rays && self.surface_rq && self.bvh_shadows,
                        Queries::Bvh | Queries::Brute => false,
                    }
            }
            _ => return None,
        })
    }
}
