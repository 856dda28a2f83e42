//! NFF loader: Eric Haines' Neutral File Format (the Standard Procedural Databases) into a
//! [`Scene`]. The specification is `spd/doc/NFF.TXT` (v3.9) of the shared scenes.
//!
//! # Reading
//! The file is split into whitespace-separated tokens, each remembering its 1-based line;
//! `#` starts a comment that runs to the end of its line. Entities are read token by token,
//! not line by line: the SPD generators write a whole cylinder on one line where the
//! specification shows three. Entities may come in any order (`b` before `v`, lights after
//! objects), but there must be exactly one `v`.
//!
//! # Mapping onto the scene model
//! - `v`: [`Camera::look_at`] with a perspective projection whose `angle` is the full field
//!   of view between the centres of the edge pixels ([`FovSpan::EdgePixelCenters`]);
//!   `from`, `at`, `up` and `angle` are required, `hither` (default 0) becomes
//!   [`Camera::near`], `resolution` becomes [`Scene::resolution`].
//! - `b`: the background colour (black without one).
//! - `l X Y Z [R G B]`: a point light without distance falloff, white unless coloured. NFF
//!   leaves the intensity open; following the SPD suggestion every one of the L lights gets
//!   intensity `sqrt(L)/(2L)` and the ambient light is white with the same scalar. A file
//!   without lights gets [`Light::default_for`] the camera (with a warning) and the ambient
//!   of a single light, 0.5.
//! - `f`: one [`Material`] per entity, mapped as [`crate::scene`] documents. `ior <= 0` (the
//!   SPD files write 0 for opaque surfaces) is stored as 1 when T = 0 and is an error when the
//!   surface transmits. Primitives before the first `f` get [`Material::default`], which is
//!   added to the materials only when used.
//! - `s`: a sphere; a negative radius means only the inside is visible (`inside_only`).
//! - `c`: a cylinder or cone without caps. Both radii negative means inside only; one radius
//!   may be zero (a cone ending in a point).
//! - `p` and `pp`: polygons, triangulated by ear clipping in the polygon's plane (they may be
//!   concave: the gears have 144-vertex faces). A polygon of n vertices always accounts for
//!   n − 2 triangles: those without area (repeated or collinear vertices) are dropped and
//!   counted in one warning. `pp` keeps its vertex normals, normalised; a zero normal is
//!   replaced by the triangle's geometric normal, with a warning.
//!
//! # Errors
//! Unknown keywords, missing or non-numeric or non-finite numbers, bad vertex counts, zero
//! sphere radii, coincident cylinder ends and impossible views are [`Error::Nff`] naming
//! the line and the token. A file without `v` or without any primitive is
//! [`Error::Invalid`]. The loader never panics.

use std::path::Path;

use glam::DVec3;

use super::polygon::Triangulator;
use super::Loaded;
use crate::error::Error;
use crate::scene::{
    Camera, Cylinder, FovSpan, Light, Material, Primitive, Projection, Scene, Sphere, Transfer, Triangle,
};

/// Loads an NFF file.
pub fn load(path: &Path) -> Result<Loaded, Error> {
    let bytes = std::fs::read(path).map_err(|source| Error::Io { path: path.to_owned(), source })?;
    match std::str::from_utf8(&bytes) {
        Ok(text) => parse(text, path),
        Err(e) => {
            let line = bytes[..e.valid_up_to()].iter().filter(|&&b| b == b'\n').count() + 1;
            Err(Error::Nff {
                path: path.to_owned(),
                line,
                token: None,
                message: "the file is not text: it holds a byte that is not UTF-8".into(),
            })
        }
    }
}

/// Parses NFF text; `path` is only used in error messages.
pub fn parse(text: &str, path: &Path) -> Result<Loaded, Error> {
    let mut parser = Parser { path, tokens: tokenize(text), pos: 0, entity: ("", 0) };
    let mut state = State::default();
    parser.entities(&mut state)?;
    state.finish(path)
}

const KEYWORDS: [&str; 8] = ["v", "b", "l", "f", "c", "s", "p", "pp"];
const VIEW_KEYWORDS: [&str; 6] = ["from", "at", "up", "angle", "hither", "resolution"];
const AXES: [&str; 3] = ["x", "y", "z"];

#[derive(Clone, Copy, Debug)]
struct Token<'a> {
    text: &'a str,
    /// 1-based line number.
    line: usize,
}

fn tokenize(text: &str) -> Vec<Token<'_>> {
    let mut tokens = Vec::with_capacity(text.len() / 8);
    for (i, line) in text.lines().enumerate() {
        let code = line.split('#').next().unwrap_or("");
        tokens.extend(code.split_whitespace().map(|text| Token { text, line: i + 1 }));
    }
    tokens
}

/// What the parse has gathered so far.
#[derive(Default)]
struct State {
    view: Option<View>,
    background: DVec3,
    lights: Vec<Light>,
    materials: Vec<Material>,
    /// The material of the last `f`, or the default material once a primitive needed it.
    current: Option<u32>,
    primitives: Vec<Primitive>,
    triangulator: Triangulator,
    /// Degenerate triangles dropped, and the line of the first polygon that had one.
    dropped: Tally,
    /// Polygons that are not simple (ear clipping found no ear somewhere).
    not_simple: Tally,
    /// `pp` vertex normals that were zero and replaced by the geometric normal.
    fixed_normals: Tally,
}

/// What the `v` entity gave.
struct View {
    camera: Camera,
    /// The viewpoint's `up`, normalised: the world's up.
    up: DVec3,
    /// The line of the `v`.
    line: usize,
    resolution: Option<(u32, u32)>,
}

#[derive(Default)]
struct Tally {
    count: usize,
    first_line: usize,
}

impl Tally {
    fn add(&mut self, n: usize, line: usize) {
        if n > 0 && self.count == 0 {
            self.first_line = line;
        }
        self.count += n;
    }
}

impl State {
    /// The material index for the next primitive.
    fn material(&mut self) -> u32 {
        *self.current.get_or_insert_with(|| {
            self.materials.push(Material::default());
            (self.materials.len() - 1) as u32
        })
    }

    fn finish(mut self, path: &Path) -> Result<Loaded, Error> {
        let invalid = |message: String| Error::Invalid { path: path.to_owned(), message };
        let Some(View { camera, up, resolution, .. }) = self.view else {
            return Err(invalid("no 'v' (viewpoint) entity: an NFF file must say where the eye is".into()));
        };
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
            background: self.background,
            materials: self.materials,
            textures: Vec::new(),
            primitives: self.primitives,
            resolution,
            up,
            environment: None,
            transfer: Transfer::Display,
        };
        scene.validate().map_err(|e| invalid(e.into_message()))?;
        Ok(Loaded { scene, warnings, format: super::SceneFormat::Nff })
    }
}

struct Parser<'a> {
    path: &'a Path,
    tokens: Vec<Token<'a>>,
    pos: usize,
    /// The entity being read: its keyword and the line it starts on.
    entity: (&'static str, usize),
}

impl<'a> Parser<'a> {
    fn error(&self, line: usize, token: Option<&str>, message: String) -> Error {
        Error::Nff { path: self.path.to_owned(), line, token: token.map(str::to_owned), message }
    }

    fn error_at(&self, token: Token<'_>, message: String) -> Error {
        self.error(token.line, Some(token.text), message)
    }

    fn peek(&self) -> Option<Token<'a>> {
        self.tokens.get(self.pos).copied()
    }

    /// The token most recently consumed.
    fn last(&self) -> Token<'a> {
        self.tokens[self.pos - 1]
    }

    /// The next token, or an end-of-file error saying what was expected.
    fn expect(&mut self, what: &impl Fn() -> String) -> Result<Token<'a>, Error> {
        let token = self.peek().ok_or_else(|| {
            let (keyword, line) = self.entity;
            self.error(
                line,
                None,
                format!("the file ends inside this '{keyword}' entity: {} is missing", what()),
            )
        })?;
        self.pos += 1;
        Ok(token)
    }

    /// Error for a token that should have been `what` (`kind` says what that is).
    fn not_a(&self, token: Token<'_>, what: String, kind: &str) -> Error {
        let (keyword, line) = self.entity;
        let message = if KEYWORDS.contains(&token.text) || VIEW_KEYWORDS.contains(&token.text) {
            format!(
                "{what} is missing: a keyword comes first (the '{keyword}' entity on line {line} has \
                 too few numbers)"
            )
        } else {
            format!("{what} must be {kind}")
        };
        self.error_at(token, message)
    }

    /// A finite number.
    fn number(&mut self, what: impl Fn() -> String) -> Result<f64, Error> {
        let token = self.expect(&what)?;
        match token.text.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(_) => Err(self.error_at(token, format!("{} must be a finite number", what()))),
            Err(_) => Err(self.not_a(token, what(), "a number")),
        }
    }

    fn vec3(&mut self, what: impl Fn() -> String) -> Result<DVec3, Error> {
        let mut v = [0.0; 3];
        for (k, axis) in AXES.iter().enumerate() {
            v[k] = self.number(|| format!("{axis} of {}", what()))?;
        }
        Ok(DVec3::from_array(v))
    }

    fn colour(&mut self, what: &str) -> Result<DVec3, Error> {
        let mut v = [0.0; 3];
        for (k, channel) in ["red", "green", "blue"].iter().enumerate() {
            v[k] = self.number(|| format!("{channel} of {what}"))?;
        }
        Ok(DVec3::from_array(v))
    }

    /// A non-negative whole number.
    fn whole(&mut self, what: impl Fn() -> String) -> Result<usize, Error> {
        let token = self.expect(&what)?;
        token.text.parse::<usize>().map_err(|_| self.not_a(token, what(), "a whole number"))
    }

    fn entities(&mut self, state: &mut State) -> Result<(), Error> {
        while let Some(token) = self.peek() {
            self.pos += 1;
            let keyword = KEYWORDS.iter().find(|k| **k == token.text).copied();
            self.entity = (keyword.unwrap_or(""), token.line);
            match keyword {
                Some("v") => self.view(state)?,
                Some("b") => state.background = self.colour("the background colour")?,
                Some("l") => self.light(state)?,
                Some("f") => self.fill(state)?,
                Some("c") => self.cylinder(state)?,
                Some("s") => self.sphere(state)?,
                Some("p") => self.polygon(state, false)?,
                Some("pp") => self.polygon(state, true)?,
                _ => {
                    let message = if token.text.parse::<f64>().is_ok() {
                        "a number where an entity keyword should start: does the entity before it \
                         have more numbers than it should, or a polygon more vertices than its count?"
                    } else {
                        "unknown keyword (NFF has v, b, l, f, c, s, p, pp and # comments)"
                    };
                    return Err(self.error_at(token, message.into()));
                }
            }
        }
        Ok(())
    }

    /// `v` followed by its sub-keywords, in any order.
    fn view(&mut self, state: &mut State) -> Result<(), Error> {
        let line = self.entity.1;
        if let Some(View { line: first, .. }) = &state.view {
            return Err(self.error(
                line,
                Some("v"),
                format!("a second 'v' entity (the first is on line {first})"),
            ));
        }
        let (mut from, mut at, mut up, mut angle, mut hither, mut resolution) =
            (None, None, None, None, None, None);
        while let Some(token) = self.peek() {
            if !VIEW_KEYWORDS.contains(&token.text) {
                break;
            }
            self.pos += 1;
            let given = match token.text {
                "from" => from.is_some(),
                "at" => at.is_some(),
                "up" => up.is_some(),
                "angle" => angle.is_some(),
                "hither" => hither.is_some(),
                _ => resolution.is_some(),
            };
            if given {
                return Err(
                    self.error_at(token, format!("'{}' is given twice in this 'v' entity", token.text))
                );
            }
            match token.text {
                "from" => from = Some(self.vec3(|| "the eye position ('from')".into())?),
                "at" => at = Some(self.vec3(|| "the look-at point ('at')".into())?),
                "up" => up = Some(self.vec3(|| "the up vector".into())?),
                "angle" => {
                    let a = self.number(|| "the field of view angle".into())?;
                    if !(a > 0.0 && a < 180.0) {
                        return Err(self.error_at(
                            self.last(),
                            format!("the field of view angle must be between 0 and 180 degrees, not {a}"),
                        ));
                    }
                    angle = Some(a);
                }
                "hither" => {
                    let h = self.number(|| "the hither distance".into())?;
                    if h < 0.0 {
                        return Err(
                            self.error_at(self.last(), format!("the hither distance {h} is negative"))
                        );
                    }
                    hither = Some(h);
                }
                _ /* "resolution" */ => {
                    let mut size = [0u32; 2];
                    for (k, axis) in ["width", "height"].iter().enumerate() {
                        let n = self.whole(|| format!("the resolution {axis}"))?;
                        size[k] = u32::try_from(n).ok().filter(|n| *n > 0).ok_or_else(|| {
                            self.error_at(
                                self.last(),
                                format!("the resolution {axis} must be between 1 and {} pixels", u32::MAX),
                            )
                        })?;
                    }
                    resolution = Some((size[0], size[1]));
                }
            }
        }
        let missing: Vec<String> = [
            ("from", from.is_none()),
            ("at", at.is_none()),
            ("up", up.is_none()),
            ("angle", angle.is_none()),
        ]
        .iter()
        .filter(|(_, absent)| *absent)
        .map(|(name, _)| format!("'{name}'"))
        .collect();
        let (Some(from), Some(at), Some(up), Some(angle)) = (from, at, up, angle) else {
            return Err(self.error(line, Some("v"), format!("this 'v' entity lacks {}", missing.join(", "))));
        };
        let projection =
            Projection::Perspective { fov_y: angle.to_radians(), span: FovSpan::EdgePixelCenters };
        let mut camera = Camera::look_at(from, at, up, projection)
            .map_err(|m| self.error(line, Some("v"), format!("impossible view: {}", m.into_message())))?;
        camera.near = hither.unwrap_or(0.0);
        state.view = Some(View { camera, up: up.normalize(), line, resolution });
        Ok(())
    }

    /// `l X Y Z [R G B]`: the colour is there when a number follows the position.
    fn light(&mut self, state: &mut State) -> Result<(), Error> {
        let position = self.vec3(|| "the light position".into())?;
        let coloured = self.peek().is_some_and(|t| t.text.parse::<f64>().is_ok());
        let colour = if coloured { self.colour("the light colour")? } else { DVec3::ONE };
        // The intensity depends on the number of lights and is set at the end.
        state.lights.push(Light::point(position, colour, 1.0));
        Ok(())
    }

    /// `f r g b Kd Ks Shine T ior`.
    fn fill(&mut self, state: &mut State) -> Result<(), Error> {
        let color = self.colour("the fill colour")?;
        let kd = self.number(|| "the diffuse weight Kd".into())?;
        let ks = self.number(|| "the specular weight Ks".into())?;
        let shine = self.number(|| "the Phong exponent Shine".into())?;
        let transmittance = self.number(|| "the transmittance T".into())?;
        let mut ior = self.number(|| "the index of refraction".into())?;
        if ior <= 0.0 {
            if transmittance > 0.0 {
                return Err(self.error_at(
                    self.last(),
                    format!("the index of refraction of a transmitting surface (T = {transmittance}) must be positive"),
                ));
            }
            ior = 1.0;
        }
        state.materials.push(Material {
            name: Some(format!("the 'f' on line {}", self.entity.1)),
            color,
            kd,
            ks,
            shine,
            mirror: DVec3::splat(ks),
            transmittance,
            ior,
            ..Material::default()
        });
        state.current = Some((state.materials.len() - 1) as u32);
        Ok(())
    }

    /// `s x y z r`.
    fn sphere(&mut self, state: &mut State) -> Result<(), Error> {
        let center = self.vec3(|| "the sphere centre".into())?;
        let radius = self.number(|| "the sphere radius".into())?;
        if radius == 0.0 {
            return Err(self.error_at(self.last(), "the sphere radius is zero".into()));
        }
        let material = state.material();
        state.primitives.push(Primitive::Sphere(Sphere {
            center,
            radius: radius.abs(),
            inside_only: radius < 0.0,
            material,
        }));
        Ok(())
    }

    /// `c  bx by bz br  ax ay az ar`.
    fn cylinder(&mut self, state: &mut State) -> Result<(), Error> {
        let base = self.vec3(|| "the cylinder base".into())?;
        let base_radius = self.number(|| "the cylinder base radius".into())?;
        let apex_start = self.peek();
        let apex = self.vec3(|| "the cylinder apex".into())?;
        let apex_radius = self.number(|| "the cylinder apex radius".into())?;
        let radius_token = self.last();
        if base_radius == 0.0 && apex_radius == 0.0 {
            return Err(self.error_at(radius_token, "both cylinder radii are zero".into()));
        }
        if base_radius * apex_radius < 0.0 {
            return Err(self.error_at(
                radius_token,
                format!(
                    "the cylinder radii {base_radius} and {apex_radius} have opposite signs (NFF makes \
                     both negative for a cylinder seen only from inside)"
                ),
            ));
        }
        let scale = base.abs().max(apex.abs()).max_element();
        if (apex - base).length() <= 1e-12 * scale {
            let at = apex_start.unwrap_or(radius_token);
            return Err(self.error_at(at, format!("the cylinder base and apex coincide at {base}")));
        }
        let material = state.material();
        state.primitives.push(Primitive::Cylinder(Cylinder {
            base,
            base_radius: base_radius.abs(),
            apex,
            apex_radius: apex_radius.abs(),
            inside_only: base_radius < 0.0 || apex_radius < 0.0,
            material,
        }));
        Ok(())
    }

    /// `p n` followed by n vertices, or `pp n` followed by n (vertex, normal) pairs.
    fn polygon(&mut self, state: &mut State, patch: bool) -> Result<(), Error> {
        let (keyword, line) = self.entity;
        let n = self.whole(|| "the vertex count".into())?;
        if n < 3 {
            return Err(self.error_at(
                self.last(),
                format!("a polygon needs at least 3 vertices, this '{keyword}' has {n}"),
            ));
        }
        // Cap the reservation by what the file can still hold, whatever the count claims.
        let numbers_per_vertex = if patch { 6 } else { 3 };
        let room = n.min((self.tokens.len() - self.pos) / numbers_per_vertex + 1);
        let mut points = Vec::with_capacity(room);
        let mut normals = Vec::with_capacity(if patch { room } else { 0 });
        for i in 1..=n {
            points.push(self.vec3(|| format!("vertex {i} of {n}"))?);
            if patch {
                normals.push(self.vec3(|| format!("normal {i} of {n}"))?);
            }
        }
        if !state.triangulator.triangulate(&points) {
            state.not_simple.add(1, line);
        }
        let corners = std::mem::take(&mut state.triangulator.triangles);
        let mut dropped = 0;
        let mut fixed = 0;
        for &[a, b, c] in &corners {
            let p = [points[a], points[b], points[c]];
            let mut triangle = Triangle::new(p, 0);
            // A finite triangle whose cross product overflows is no better than a flat one.
            if triangle.is_degenerate() || !triangle.cross().is_finite() {
                dropped += 1;
                continue;
            }
            if patch {
                let geometric = triangle.cross().normalize();
                triangle.n = Some([a, b, c].map(|k| {
                    normals[k].try_normalize().unwrap_or_else(|| {
                        fixed += 1;
                        geometric
                    })
                }));
            }
            // Asked only now, so that a wholly degenerate polygon adds no default material.
            triangle.material = state.material();
            state.primitives.push(Primitive::Triangle(triangle));
        }
        state.triangulator.triangles = corners;
        state.dropped.add(dropped, line);
        state.fixed_normals.add(fixed, line);
        Ok(())
    }
}
