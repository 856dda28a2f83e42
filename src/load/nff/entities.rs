//! The NFF entity parser: reads entities from a [`Cursor`] into a [`State`], one chunk of
//! the file (or all of it) at a time. Every error names the line and the token.

use std::path::Path;

use glam::DVec3;

use super::cursor::{Cursor, Token};
use super::state::{second_view, State, View};
use super::{AXES, KEYWORDS, VIEW_KEYWORDS};
use crate::error::Error;
use crate::scene::{Camera, Cylinder, FovSpan, Light, Material, Primitive, Projection, Sphere, Triangle};

pub(super) struct Parser<'a> {
    path: &'a Path,
    cursor: Cursor<'a>,
    /// Where the chunk ends: an entity that starts there or later is the next chunk's. An
    /// entity that starts before it is read to its end, past it if need be.
    end: usize,
    /// The token most recently consumed.
    last: Token<'a>,
    /// The entity being read: its keyword and the line it starts on.
    entity: (&'static str, usize),
}

impl<'a> Parser<'a> {
    /// A parser of the entities that start in `cursor`'s text before byte `end`.
    pub fn new(path: &'a Path, cursor: Cursor<'a>, end: usize) -> Parser<'a> {
        let last = Token { text: "", line: 0, start: 0 };
        Parser { path, cursor, end, last, entity: ("", 0) }
    }

    fn error(&self, line: usize, token: Option<&str>, message: String) -> Error {
        Error::Nff { path: self.path.to_owned(), line, token: token.map(str::to_owned), message }
    }

    fn error_at(&self, token: Token<'_>, message: String) -> Error {
        self.error(token.line, Some(token.text), message)
    }

    fn peek(&self) -> Option<Token<'a>> {
        self.cursor.peek()
    }

    /// The token most recently consumed.
    fn last(&self) -> Token<'a> {
        self.last
    }

    /// The next token, or an end-of-file error saying what was expected.
    fn expect(&mut self, what: &impl Fn() -> String) -> Result<Token<'a>, Error> {
        let token = self.cursor.next().ok_or_else(|| self.ends_inside(what))?;
        self.last = token;
        Ok(token)
    }

    /// The error for the end of the file where `what` should come.
    fn ends_inside(&self, what: &impl Fn() -> String) -> Error {
        let (keyword, line) = self.entity;
        self.error(line, None, format!("the file ends inside this '{keyword}' entity: {} is missing", what()))
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
    #[inline]
    fn number(&mut self, what: impl Fn() -> String) -> Result<f64, Error> {
        let (token, value) = self.cursor.next_number().ok_or_else(|| self.ends_inside(&what))?;
        self.last = token;
        if let Some(value) = value {
            return Ok(value);
        }
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

    /// Reads the entities that start before the chunk's end.
    pub fn entities(&mut self, state: &mut State) -> Result<(), Error> {
        while let Some(token) = self.cursor.next() {
            if token.start >= self.end {
                break;
            }
            self.last = token;
            let keyword = KEYWORDS.iter().find(|k| **k == token.text).copied();
            self.entity = (keyword.unwrap_or(""), token.line);
            match keyword {
                Some("v") => {
                    state.first_view.get_or_insert(token.line);
                    self.view(state)?
                }
                Some("b") => state.background = Some(self.colour("the background colour")?),
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
            return Err(second_view(self.path, line, *first));
        }
        let (mut from, mut at, mut up, mut angle, mut hither, mut resolution) =
            (None, None, None, None, None, None);
        while let Some(token) = self.peek() {
            if !VIEW_KEYWORDS.contains(&token.text) {
                break;
            }
            self.cursor.next();
            self.last = token;
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
        state.push_material(Material {
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
        // The buffers grow only as far as the file holds vertices, whatever the count claims.
        let mut points = std::mem::take(&mut state.points);
        let mut normals = std::mem::take(&mut state.normals);
        points.clear();
        normals.clear();
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
            let mut triangle = Triangle::new([points[a], points[b], points[c]], 0);
            if triangle.is_degenerate() {
                dropped += 1;
                continue;
            }
            // A finite triangle whose cross product overflows is no better than a flat one.
            let cross = triangle.cross();
            if !cross.is_finite() {
                dropped += 1;
                continue;
            }
            if patch {
                let geometric = cross.normalize();
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
        state.points = points;
        state.normals = normals;
        state.dropped.add(dropped, line);
        state.fixed_normals.add(fixed, line);
        Ok(())
    }
}
