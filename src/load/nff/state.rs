//! What the NFF parse gathers: the view, background, lights, materials, primitives and the
//! tallies behind the warnings; how the states of consecutive chunks join into the state a
//! serial parse of the whole file would have; and the final checks that make a [`Scene`].

use std::path::Path;

use glam::DVec3;

use super::super::polygon::Triangulator;
use super::super::{Loaded, SceneFormat};
use crate::error::Error;
use crate::scene::{Camera, Light, Material, Primitive, Scene, Transfer};

/// The material index a chunk after the first gives to primitives before its first `f`:
/// whatever material is current at the chunk's start, known only when the chunks are joined.
const INHERITED: u32 = u32::MAX;

/// What the parse has gathered so far (of the whole file, or of one chunk of it).
#[derive(Default)]
pub(super) struct State {
    pub view: Option<View>,
    /// The line of the first `v` keyword met, even one whose entity failed: the joining
    /// needs it to report a second `v` where a serial parse would.
    pub first_view: Option<usize>,
    /// The colour of the last `b`.
    pub background: Option<DVec3>,
    pub lights: Vec<Light>,
    pub materials: Vec<Material>,
    /// The material of the last `f`, or the default material once a primitive needed it.
    current: Option<u32>,
    /// Whether this is a chunk after the first, whose primitives before its first `f` take
    /// the material current at its start ([`INHERITED`]).
    inherit: bool,
    /// Whether some primitive got [`INHERITED`].
    inherited: bool,
    pub primitives: Vec<Primitive>,
    pub triangulator: Triangulator,
    /// Reused buffers of a polygon's vertices and `pp` normals.
    pub points: Vec<DVec3>,
    pub normals: Vec<DVec3>,
    /// Degenerate triangles dropped, and the line of the first polygon that had one.
    pub dropped: Tally,
    /// Polygons that are not simple (ear clipping found no ear somewhere).
    pub not_simple: Tally,
    /// `pp` vertex normals that were zero and replaced by the geometric normal.
    pub fixed_normals: Tally,
}

/// What the `v` entity gave.
pub(super) struct View {
    pub camera: Camera,
    /// The viewpoint's `up`, normalised: the world's up.
    pub up: DVec3,
    /// The line of the `v`.
    pub line: usize,
    pub resolution: Option<(u32, u32)>,
}

#[derive(Default)]
pub(super) struct Tally {
    count: usize,
    first_line: usize,
}

impl Tally {
    pub fn add(&mut self, n: usize, line: usize) {
        if n > 0 && self.count == 0 {
            self.first_line = line;
        }
        self.count += n;
    }
}

/// The error for a `v` on `line` when the file already had one on `first`.
pub(super) fn second_view(path: &Path, line: usize, first: usize) -> Error {
    Error::Nff {
        path: path.to_owned(),
        line,
        token: Some("v".into()),
        message: format!("a second 'v' entity (the first is on line {first})"),
    }
}

impl State {
    /// The state at the start of a chunk; `inherit` for every chunk but the first.
    pub fn new(inherit: bool) -> State {
        State { inherit, ..State::default() }
    }

    /// The material index for the next primitive.
    pub fn material(&mut self) -> u32 {
        if let Some(m) = self.current {
            return m;
        }
        let m = if self.inherit {
            self.inherited = true;
            INHERITED
        } else {
            self.materials.push(Material::default());
            (self.materials.len() - 1) as u32
        };
        self.current = Some(m);
        m
    }

    /// Adds a material from an `f`; it is current from now on.
    pub fn push_material(&mut self, material: Material) {
        self.materials.push(material);
        self.current = Some((self.materials.len() - 1) as u32);
    }

    /// Appends the state of the chunk that follows this one, as if the parse had gone on
    /// through it. The caller has checked that the two do not both have a `v`. Returns the
    /// chunk's emptied primitive buffer, for another chunk to reuse.
    pub fn append(&mut self, mut next: State) -> Vec<Primitive> {
        // The default material, if the chunk's first primitives need it, comes before the
        // chunk's own materials, as it would in a serial parse.
        let inherited = if next.inherited { self.material() } else { INHERITED };
        let offset = self.materials.len() as u32;
        if offset > 0 || next.inherited {
            // Remapped as they are moved: one pass over the chunk's primitives.
            let remap = |m: &mut u32| *m = if *m == INHERITED { inherited } else { *m + offset };
            self.primitives.extend(next.primitives.drain(..).map(|mut primitive| {
                match &mut primitive {
                    Primitive::Sphere(s) => remap(&mut s.material),
                    Primitive::Triangle(t) => remap(&mut t.material),
                    Primitive::Cylinder(c) => remap(&mut c.material),
                }
                primitive
            }));
        } else {
            self.primitives.append(&mut next.primitives);
        }
        match next.current {
            Some(INHERITED) | None => {}
            Some(m) => self.current = Some(m + offset),
        }
        self.materials.append(&mut next.materials);
        self.lights.append(&mut next.lights);
        self.background = next.background.or(self.background);
        self.view = self.view.take().or(next.view);
        self.first_view = self.first_view.or(next.first_view);
        for (tally, more) in [
            (&mut self.dropped, &next.dropped),
            (&mut self.not_simple, &next.not_simple),
            (&mut self.fixed_normals, &next.fixed_normals),
        ] {
            tally.add(more.count, more.first_line);
        }
        next.primitives
    }

    /// The warnings about the tallies, in a fixed order.
    fn tally_warnings(&self) -> Vec<String> {
        let mut warnings = Vec::new();
        if self.dropped.count > 0 {
            warnings.push(format!(
                "dropped {} degenerate triangle(s) without area (repeated or collinear polygon vertices), \
                 the first in the polygon on line {}",
                self.dropped.count, self.dropped.first_line
            ));
        }
        if self.not_simple.count > 0 {
            warnings.push(format!(
                "{} polygon(s) are not simple (their edges cross), the first on line {}: their \
                 triangulation may cover a different area than intended",
                self.not_simple.count, self.not_simple.first_line
            ));
        }
        if self.fixed_normals.count > 0 {
            warnings.push(format!(
                "replaced {} zero 'pp' vertex normal(s) by the geometric normal, the first in the \
                 patch on line {}",
                self.fixed_normals.count, self.fixed_normals.first_line
            ));
        }
        warnings
    }

    /// The scene of the whole file's state.
    pub fn finish(mut self, path: &Path) -> Result<Loaded, Error> {
        let invalid = |message: String| Error::Invalid { path: path.to_owned(), message };
        let Some(View { camera, up, resolution, .. }) = self.view.take() else {
            return Err(invalid("no 'v' (viewpoint) entity: an NFF file must say where the eye is".into()));
        };
        let mut warnings = self.tally_warnings();
        if self.primitives.is_empty() {
            let why = if self.dropped.count > 0 { " (all its polygons are degenerate)" } else { "" };
            return Err(invalid(format!("the scene has no primitives (s, c, p or pp){why}")));
        }
        // SPD: each of L lights, and the ambient term, get sqrt(L)/(2L) = 1/(2·sqrt(L)).
        let share = 0.5 / (self.lights.len().max(1) as f64).sqrt();
        for light in &mut self.lights {
            light.intensity = share;
        }
        if self.lights.is_empty() {
            let light = Light::default_for(&camera);
            warnings.push(format!(
                "the file has no light: added a white headlight at the eye {} (intensity {})",
                light.position, light.intensity
            ));
            self.lights.push(light);
        }
        let scene = Scene {
            camera,
            lights: self.lights,
            ambient: DVec3::splat(share),
            background: self.background.unwrap_or(DVec3::ZERO),
            materials: self.materials,
            textures: Vec::new(),
            primitives: self.primitives,
            resolution,
            up,
            environment: None,
            transfer: Transfer::Display,
        };
        scene.validate().map_err(|e| invalid(e.into_message()))?;
        Ok(Loaded { scene, warnings, format: SceneFormat::Nff })
    }
}
