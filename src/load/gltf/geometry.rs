//! The node hierarchy and the triangles of its meshes.
//!
//! [`walk`] visits the chosen scene depth first (roots in scene order, children in file
//! order) and gives each mesh, camera and light node its world matrix. [`triangles`]
//! decodes every mesh primitive once (accessors shared between primitives are read once),
//! then places a copy of its triangles for every node that instances the mesh, in
//! parallel, keeping the traversal order so that object ids are stable.

use std::collections::HashMap;
use std::sync::Arc;

use glam::{DMat3, DMat4, DQuat, DVec2, DVec3, DVec4};
use gltf::mesh::Mode;
use gltf::{Document, Semantic};
use rayon::prelude::*;

use super::animation::Pose;
use super::data::Reader;
use super::materials::MaterialTable;
use super::Ctx;
use crate::error::Error;
use crate::scene::{Primitive, Triangle};

/// Something attached to a node, with the node's world matrix.
pub struct Placed {
    pub node: usize,
    /// Index of the mesh, camera or light.
    pub item: usize,
    pub world: DMat4,
}

/// What the chosen scene holds, in traversal order.
pub struct Hierarchy {
    pub meshes: Vec<Placed>,
    pub cameras: Vec<Placed>,
    pub lights: Vec<Placed>,
    /// Skinned mesh nodes (skinning is ignored).
    pub skinned: usize,
}

/// The local transform of a node (matrix, or T·R·S with the rotation renormalised), with
/// the animated parts of `pose` in place of the file's.
fn local_matrix(ctx: &Ctx, node: &gltf::Node, pose: &Pose) -> Result<DMat4, Error> {
    let loc = format!("nodes[{}]", node.index());
    match node.transform() {
        gltf::scene::Transform::Matrix { matrix } => {
            let m = DMat4::from_cols_array_2d(&matrix.map(|c| c.map(f64::from)));
            if !m.is_finite() {
                return Err(ctx.err(loc, "matrix is not finite"));
            }
            if m.row(3) != glam::DVec4::W {
                return Err(ctx.err(
                    loc,
                    format!("matrix is not affine: its last row is {:?}, expected [0, 0, 0, 1]", m.row(3)),
                ));
            }
            Ok(m)
        }
        gltf::scene::Transform::Decomposed { translation, rotation, scale } => {
            let animated = pose.nodes.get(&node.index()).copied().unwrap_or_default();
            let t = animated.translation.unwrap_or(DVec3::from(translation.map(f64::from)));
            let s = animated.scale.unwrap_or(DVec3::from(scale.map(f64::from)));
            let q = animated.rotation.unwrap_or(DQuat::from_array(rotation.map(f64::from)));
            if !(t.is_finite() && s.is_finite() && q.is_finite()) {
                return Err(ctx.err(loc, "translation, rotation or scale is not finite"));
            }
            let len = q.length();
            if len == 0.0 {
                return Err(ctx.err(loc, "rotation is a zero quaternion"));
            }
            Ok(DMat4::from_scale_rotation_translation(s, q / len, t))
        }
    }
}

/// Walks the default scene (or scene 0, or every root node when the file has no scene),
/// its animated nodes posed by `pose`.
pub fn walk(ctx: &Ctx, doc: &Document, pose: &Pose) -> Result<Hierarchy, Error> {
    let (label, roots): (String, Vec<usize>) = match doc.default_scene().or_else(|| doc.scenes().next()) {
        Some(s) => (format!("scenes[{}]", s.index()), s.nodes().map(|n| n.index()).collect()),
        None => {
            let mut is_child = vec![false; doc.nodes().len()];
            for n in doc.nodes() {
                for c in n.children() {
                    is_child[c.index()] = true;
                }
            }
            ("the root nodes".into(), (0..is_child.len()).filter(|&i| !is_child[i]).collect())
        }
    };
    let nodes: Vec<gltf::Node> = doc.nodes().collect();
    let mut h = Hierarchy { meshes: Vec::new(), cameras: Vec::new(), lights: Vec::new(), skinned: 0 };
    let mut visited = vec![false; nodes.len()];
    // Explicit stack (deep hierarchies must not overflow the call stack); children are
    // pushed in reverse so that they are visited in file order.
    let mut stack: Vec<(usize, DMat4)> = roots.iter().rev().map(|&r| (r, DMat4::IDENTITY)).collect();
    while let Some((i, parent)) = stack.pop() {
        if std::mem::replace(&mut visited[i], true) {
            return Err(ctx.err(
                format!("nodes[{i}]"),
                format!("is reached twice from {label}: a node may have only one parent and the hierarchy no cycles"),
            ));
        }
        let node = &nodes[i];
        let world = parent * local_matrix(ctx, node, pose)?;
        if let Some(mesh) = node.mesh() {
            h.meshes.push(Placed { node: i, item: mesh.index(), world });
            h.skinned += node.skin().is_some() as usize;
        }
        if let Some(camera) = node.camera() {
            h.cameras.push(Placed { node: i, item: camera.index(), world });
        }
        if let Some(light) = node.light() {
            h.lights.push(Placed { node: i, item: light.index(), world });
        }
        let children: Vec<usize> = node.children().map(|c| c.index()).collect();
        stack.extend(children.into_iter().rev().map(|c| (c, world)));
    }
    Ok(h)
}

/// One mesh primitive, decoded and checked, shared by all nodes that instance its mesh.
struct PrimGeom {
    positions: Arc<Vec<[f32; 3]>>,
    /// Unit or zero (zero marks a bad normal: the triangle's geometric normal is used).
    normals: Option<Arc<Vec<[f32; 3]>>>,
    /// TEXCOORD_0 and TEXCOORD_1, where the material's textures read them.
    uvs: [Option<Arc<Vec<[f32; 2]>>>; 2],
    /// COLOR_0, linear RGB.
    colors: Option<Arc<Vec<[f32; 3]>>>,
    tris: Arc<Vec<[u32; 3]>>,
    /// Tangents of a normal-mapped primitive, per corner of each of `tris` (TANGENT, or
    /// MikkTSpace's where it is absent); xyz zero where none could be made.
    tangents: Option<Arc<Vec<[[f32; 4]; 3]>>>,
    material: u32,
}

/// How a primitive's vertices were assembled into triangles: (indices accessor, mode,
/// vertex count).
type TriangleKey = (Option<usize>, u32, usize);

/// Decoded accessors, by accessor index (and, for triangles, by how they were assembled).
#[derive(Default)]
struct Cache {
    positions: HashMap<usize, Arc<Vec<[f32; 3]>>>,
    normals: HashMap<usize, Arc<Vec<[f32; 3]>>>,
    uvs: HashMap<usize, Arc<Vec<[f32; 2]>>>,
    indices: HashMap<usize, Arc<Vec<u32>>>,
    tris: HashMap<TriangleKey, Arc<Vec<[u32; 3]>>>,
}

fn attr_loc(prim_loc: &str, name: &str, acc: &gltf::Accessor) -> String {
    format!("{prim_loc}.attributes.{name} (accessors[{}])", acc.index())
}

/// Vertex triples for a primitive mode (strips and fans converted as glTF defines them).
fn assemble(idx: &[u32], mode: Mode) -> Result<Vec<[u32; 3]>, String> {
    Ok(match mode {
        Mode::Triangles => {
            if idx.len() % 3 != 0 {
                return Err(format!("{} vertices is not a multiple of 3 for TRIANGLES", idx.len()));
            }
            idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
        }
        Mode::TriangleStrip => {
            (0..idx.len().saturating_sub(2))
                .map(|i| {
                    if i % 2 == 0 {
                        [idx[i], idx[i + 1], idx[i + 2]]
                    } else {
                        [idx[i], idx[i + 2], idx[i + 1]]
                    }
                })
                .collect()
        }
        Mode::TriangleFan => (1..idx.len().saturating_sub(1)).map(|i| [idx[i], idx[i + 1], idx[0]]).collect(),
        _ => Vec::new(),
    })
}

impl Cache {
    fn decode(
        &mut self,
        reader: &Reader,
        mesh: usize,
        prim: &gltf::Primitive,
        table: &MaterialTable,
        warnings: &mut Vec<String>,
    ) -> Result<Option<PrimGeom>, Error> {
        let ctx = reader.ctx;
        let loc = format!("meshes[{mesh}].primitives[{}]", prim.index());
        let mode = prim.mode();
        if !matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
            warnings.push(format!("{loc}: mode {mode:?} is not a surface; skipped"));
            return Ok(None);
        }
        let Some(pos_acc) = prim.get(&Semantic::Positions) else {
            warnings.push(format!("{loc}: has no POSITION attribute; skipped"));
            return Ok(None);
        };
        let positions = match self.positions.get(&pos_acc.index()) {
            Some(p) => p.clone(),
            None => {
                let p = Arc::new(reader.positions(&pos_acc, &attr_loc(&loc, "POSITION", &pos_acc))?);
                self.positions.insert(pos_acc.index(), p.clone());
                p
            }
        };
        let n = positions.len();
        let same_count = |acc: &gltf::Accessor, name: &str| -> Result<(), Error> {
            if reader.count(acc) != n {
                return Err(ctx.err(
                    attr_loc(&loc, name, acc),
                    format!("has {} elements, but POSITION has {n}", reader.count(acc)),
                ));
            }
            Ok(())
        };

        let normals = match prim.get(&Semantic::Normals) {
            None => None,
            Some(acc) => {
                same_count(&acc, "NORMAL")?;
                Some(self.normals(reader, &acc, &attr_loc(&loc, "NORMAL", &acc), warnings)?)
            }
        };

        let (material, needs) = table.lookup(prim.material().index());
        let mut uvs = [None, None];
        for (set, uv) in uvs.iter_mut().enumerate() {
            if !needs.uv[set] {
                continue;
            }
            *uv = match prim.get(&Semantic::TexCoords(set as u32)) {
                None => {
                    warnings.push(format!(
                        "{loc}: its material's textures read TEXCOORD_{set}, which the primitive lacks; they are not applied to it"
                    ));
                    None
                }
                Some(acc) => {
                    let name = format!("TEXCOORD_{set}");
                    same_count(&acc, &name)?;
                    Some(match self.uvs.get(&acc.index()) {
                        Some(v) => v.clone(),
                        None => {
                            let v = Arc::new(reader.texcoords(&acc, &attr_loc(&loc, &name, &acc))?);
                            self.uvs.insert(acc.index(), v.clone());
                            v
                        }
                    })
                }
            };
        }

        let colors = match prim.get(&Semantic::Colors(0)) {
            None => None,
            Some(acc) => {
                same_count(&acc, "COLOR_0")?;
                Some(Arc::new(reader.colors(&acc, &attr_loc(&loc, "COLOR_0", &acc))?))
            }
        };

        let tris = self.triangles(reader, prim, &loc, n, &attr_loc(&loc, "POSITION", &pos_acc))?;
        let tangents = match needs.tangents.and_then(|set| uvs[set as usize].as_ref()) {
            None => None,
            // glTF: without NORMAL, TANGENT is ignored (the normals are the flat ones).
            Some(uv) => Some(Arc::new(match prim.get(&Semantic::Tangents).filter(|_| normals.is_some()) {
                Some(acc) => {
                    same_count(&acc, "TANGENT")?;
                    let t = reader.tangents(&acc, &attr_loc(&loc, "TANGENT", &acc))?;
                    tris.iter().map(|tri| tri.map(|i| t[i as usize])).collect()
                }
                None => mikktspace_tangents(&positions, normals.as_deref().map(|v| &v[..]), uv, &tris),
            })),
        };
        Ok(Some(PrimGeom { positions, normals, uvs, colors, tris, tangents, material }))
    }

    /// The unit normals of accessor `acc` (at `aloc`), decoded once; zero or non-finite ones
    /// become zero (their vertices take the triangle's geometric normal), with a warning.
    fn normals(
        &mut self,
        reader: &Reader,
        acc: &gltf::Accessor,
        aloc: &str,
        warnings: &mut Vec<String>,
    ) -> Result<Arc<Vec<[f32; 3]>>, Error> {
        if let Some(v) = self.normals.get(&acc.index()) {
            return Ok(v.clone());
        }
        let mut v = reader.normals(acc, aloc)?;
        let mut bad = 0;
        for nrm in &mut v {
            let len = nrm.iter().map(|c| c * c).sum::<f32>().sqrt();
            if len.is_finite() && len > 0.0 {
                *nrm = nrm.map(|c| c / len);
            } else {
                *nrm = [0.0; 3];
                bad += 1;
            }
        }
        if bad > 0 {
            warnings.push(format!(
                "{aloc}: {bad} normals are zero or not finite; their vertices use the triangle's geometric normal"
            ));
        }
        let v = Arc::new(v);
        self.normals.insert(acc.index(), v.clone());
        Ok(v)
    }

    /// The triangles of `prim` (at `loc`) over its `n` vertices, from its indices (checked
    /// in range) or, without any, the vertices in order (`pos_loc`: the positions'
    /// accessor), assembled by its mode; decoded once per indices, mode and count.
    fn triangles(
        &mut self,
        reader: &Reader,
        prim: &gltf::Primitive,
        loc: &str,
        n: usize,
        pos_loc: &str,
    ) -> Result<Arc<Vec<[u32; 3]>>, Error> {
        let ctx = reader.ctx;
        let (idx_acc, mode) = (prim.indices(), prim.mode());
        let key = (idx_acc.as_ref().map(|a| a.index()), mode.as_gl_enum(), n);
        if let Some(t) = self.tris.get(&key) {
            return Ok(t.clone());
        }
        let (idx, idx_loc) = match &idx_acc {
            None => (Arc::new((0..n as u32).collect::<Vec<u32>>()), pos_loc.to_string()),
            Some(acc) => {
                let iloc = format!("{loc}.indices (accessors[{}])", acc.index());
                let idx = match self.indices.get(&acc.index()) {
                    Some(v) => v.clone(),
                    None => {
                        let v = Arc::new(reader.indices(acc, &iloc)?);
                        self.indices.insert(acc.index(), v.clone());
                        v
                    }
                };
                if let Some((k, &v)) = idx.iter().enumerate().find(|(_, &v)| v as usize >= n) {
                    return Err(ctx.err(
                        iloc,
                        format!("index {v} (element {k}) is out of range: POSITION has {n} vertices"),
                    ));
                }
                (idx, iloc)
            }
        };
        let t = Arc::new(assemble(&idx, mode).map_err(|m| ctx.err(idx_loc, m))?);
        self.tris.insert(key, t.clone());
        Ok(t)
    }
}

/// A primitive's triangles as MikkTSpace sees them (faces of three corners).
struct Mikk<'a> {
    positions: &'a [[f32; 3]],
    /// Vertex normals; a face's geometric normal where absent or zero.
    normals: Option<&'a [[f32; 3]]>,
    uvs: &'a [[f32; 2]],
    tris: &'a [[u32; 3]],
    out: Vec<[[f32; 4]; 3]>,
}

impl Mikk<'_> {
    fn face_normal(&self, face: usize) -> [f32; 3] {
        let p = self.tris[face].map(|i| glam::Vec3::from(self.positions[i as usize]));
        (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero().to_array()
    }
}

impl mikktspace::Geometry for Mikk<'_> {
    fn num_faces(&self) -> usize {
        self.tris.len()
    }
    fn num_vertices_of_face(&self, _face: usize) -> usize {
        3
    }
    fn position(&self, face: usize, vert: usize) -> [f32; 3] {
        self.positions[self.tris[face][vert] as usize]
    }
    fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
        match self.normals.map(|n| n[self.tris[face][vert] as usize]) {
            Some(n) if n != [0.0; 3] => n,
            _ => self.face_normal(face),
        }
    }
    fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
        self.uvs[self.tris[face][vert] as usize]
    }
    fn set_tangent_encoded(&mut self, tangent: [f32; 4], face: usize, vert: usize) {
        // MikkTSpace's bitangent follows +v; glTF's UVs grow v downwards while its normal
        // maps' +Y is up the image, so glTF's bitangent is the other way (its sign negated,
        // as glTF viewers generate them).
        let [x, y, z, w] = tangent;
        self.out[face][vert] = [x, y, z, -w];
    }
}

/// Tangents per triangle corner generated by MikkTSpace (the glTF specification's rule for
/// normal-mapped primitives without TANGENT, or without NORMAL, whose TANGENT must be
/// ignored), in glTF's handedness. Corners it leaves alone (degenerate UVs) stay zero, and
/// their triangles are shaded without the normal map.
fn mikktspace_tangents(
    positions: &[[f32; 3]],
    normals: Option<&[[f32; 3]]>,
    uvs: &[[f32; 2]],
    tris: &[[u32; 3]],
) -> Vec<[[f32; 4]; 3]> {
    let mut m = Mikk { positions, normals, uvs, tris, out: vec![[[0.0; 4]; 3]; tris.len()] };
    mikktspace::generate_tangents(&mut m);
    m.out
}

/// Most triangles a scene may instance (a few node references can multiply a mesh far
/// beyond any memory; each triangle takes about 200 bytes).
const MAX_TRIANGLES: usize = 1 << 26;

/// Triangles per parallel job: large meshes are split so that both cores get work.
const CHUNK: usize = 16 * 1024;

/// A range of one primitive's triangles placed by one node.
struct Job {
    geom: Arc<PrimGeom>,
    world: DMat4,
    start: usize,
    end: usize,
}

fn dvec3(v: [f32; 3]) -> DVec3 {
    DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64)
}

impl Job {
    /// World-space triangles of the job and the number of degenerate ones dropped.
    fn run(&self) -> (Vec<Primitive>, usize) {
        let g = &*self.geom;
        let linear = DMat3::from_mat4(self.world);
        // Normals transform by the inverse transpose; a mirroring transform reverses the
        // winding, so the vertex order is flipped to keep the geometric normal outwards.
        let normal_m = linear.inverse().transpose();
        let flip = linear.determinant() < 0.0;
        let mut out = Vec::with_capacity(self.end - self.start);
        let mut dropped = 0;
        for (k, t) in g.tris.iter().enumerate().take(self.end).skip(self.start) {
            let idx = if flip { [t[0], t[2], t[1]] } else { *t };
            let p = idx.map(|i| self.world.transform_point3(dvec3(g.positions[i as usize])));
            let mut tri = Triangle::new(p, g.material);
            if tri.is_degenerate() {
                dropped += 1;
                continue;
            }
            if let Some(normals) = &g.normals {
                let geometric = tri.cross().normalize();
                tri.n = Some(idx.map(|i| {
                    let n = normal_m * dvec3(normals[i as usize]);
                    let len = n.length();
                    if len > 0.0 && len.is_finite() {
                        n / len
                    } else {
                        geometric
                    }
                }));
            }
            let uv_of = |uvs: &[[f32; 2]]| idx.map(|i| DVec2::from(uvs[i as usize].map(f64::from)));
            tri.uv = g.uvs[0].as_deref().map(|v| uv_of(v));
            tri.uv1 = g.uvs[1].as_deref().map(|v| Box::new(uv_of(v)));
            if let Some(tangents) = &g.tangents {
                let corners = tangents[k];
                let corners = if flip { [corners[0], corners[2], corners[1]] } else { corners };
                let sign = if flip { -1.0 } else { 1.0 };
                let t: Option<Vec<DVec4>> = corners
                    .iter()
                    .map(|c| {
                        let v = linear * dvec3([c[0], c[1], c[2]]);
                        let len = v.length();
                        (len > 0.0 && len.is_finite())
                            .then(|| (v / len).extend(sign * (c[3] as f64).signum()))
                    })
                    .collect();
                tri.tangent = t.map(|t| Box::new([t[0], t[1], t[2]]));
            }
            if let Some(colors) = &g.colors {
                tri.color = Some(Box::new(idx.map(|i| dvec3(colors[i as usize]))));
            }
            out.push(Primitive::Triangle(tri));
        }
        (out, dropped)
    }
}

/// The world-space triangles of every mesh instance of the hierarchy, in traversal order.
pub fn triangles(
    reader: &Reader,
    doc: &Document,
    hierarchy: &Hierarchy,
    table: &MaterialTable,
    warnings: &mut Vec<String>,
) -> Result<Vec<Primitive>, Error> {
    let meshes: Vec<gltf::Mesh> = doc.meshes().collect();
    let mut cache = Cache::default();
    let mut decoded: HashMap<(usize, usize), Option<Arc<PrimGeom>>> = HashMap::new();
    let mut morphed = vec![false; meshes.len()];
    let mut jobs = Vec::new();
    for placed in &hierarchy.meshes {
        let mesh = &meshes[placed.item];
        for prim in mesh.primitives() {
            let key = (mesh.index(), prim.index());
            let geom = match decoded.get(&key) {
                Some(g) => g.clone(),
                None => {
                    let g = cache.decode(reader, mesh.index(), &prim, table, warnings)?.map(Arc::new);
                    decoded.insert(key, g.clone());
                    g
                }
            };
            if prim.morph_targets().len() > 0 && !std::mem::replace(&mut morphed[mesh.index()], true) {
                warnings.push(format!(
                    "meshes[{}]: morph targets are ignored (the base shape is shown)",
                    mesh.index()
                ));
            }
            if let Some(geom) = geom {
                let n = geom.tris.len();
                for start in (0..n).step_by(CHUNK) {
                    jobs.push(Job {
                        geom: geom.clone(),
                        world: placed.world,
                        start,
                        end: (start + CHUNK).min(n),
                    });
                }
            }
        }
    }
    if hierarchy.skinned > 0 {
        warnings.push(format!(
            "{} skinned mesh nodes: skinning is ignored (meshes are placed by their node's transform)",
            hierarchy.skinned
        ));
    }
    let total: usize = jobs.iter().map(|j| j.end - j.start).sum();
    if total > MAX_TRIANGLES {
        return Err(reader.ctx.invalid(format!(
            "the scene instances {total} triangles; at most {MAX_TRIANGLES} are supported"
        )));
    }
    let results: Vec<(Vec<Primitive>, usize)> = jobs.par_iter().map(Job::run).collect();
    let dropped: usize = results.iter().map(|r| r.1).sum();
    let mut out = Vec::with_capacity(results.iter().map(|r| r.0.len()).sum());
    for (tris, _) in results {
        out.extend(tris);
    }
    if dropped > 0 {
        warnings.push(format!("dropped {dropped} degenerate triangles"));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strips_and_fans_keep_the_winding() {
        // A strip of 4 vertices: (0,1,2) then (1,3,2), both counter-clockwise in a quad
        // 0 1 / 2 3 laid out zig-zag.
        assert_eq!(assemble(&[0, 1, 2, 3], Mode::TriangleStrip).unwrap(), vec![[0, 1, 2], [1, 3, 2]]);
        assert_eq!(assemble(&[0, 1, 2, 3], Mode::TriangleFan).unwrap(), vec![[1, 2, 0], [2, 3, 0]]);
        assert_eq!(assemble(&[0, 1], Mode::TriangleStrip).unwrap(), Vec::<[u32; 3]>::new());
        assert!(assemble(&[0, 1, 2, 3], Mode::Triangles).is_err());
    }
}
