//! The loaded data model: [`Model`] (meshes, materials, warnings, counts), [`Mesh`], [`Material`],
//! [`LoadStats`] and the [`LoadOptions`] that shape loading.

use std::path::PathBuf;

use glam::Vec3;

use super::{classify_edges, EdgeKind};

/// Where a mesh's normals come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NormalsSource {
    /// Every vertex normal is the file's `vn` (normalised).
    FromFile,
    /// Every vertex normal was computed: angle-weighted face normals, split at creases
    /// (smoothing groups, or [`LoadOptions::crease_angle_deg`]).
    Computed,
    /// Some of each: corners without a usable `vn` got computed normals.
    Mixed,
}

/// A triangle mesh with per-vertex unit normals.
#[derive(Clone, Debug)]
pub struct Mesh {
    /// The OBJ object or group name (`mesh0`, `mesh1`, ... before any `o`/`g`), with
    /// `/MATERIAL` appended when the group uses several materials.
    pub name: String,
    /// Vertex positions. A loaded mesh has one vertex per welded position and normal, so a
    /// position at a crease appears once per normal (see `position_ids`).
    pub positions: Vec<Vec3>,
    /// Unit vertex normals, one per position.
    pub normals: Vec<Vec3>,
    /// Triangles, counter-clockwise as in the file.
    pub indices: Vec<[u32; 3]>,
    /// Index into [`Model::materials`].
    pub material: Option<usize>,
    /// Per vertex: the welded position id (vertices with equal ids share a position).
    pub position_ids: Vec<u32>,
    /// Per triangle edge `i` = (corner `i`, corner `i+1`).
    pub edge_kinds: Vec<[EdgeKind; 3]>,
    /// Whether the normals came from the file, were computed, or both.
    pub normals_source: NormalsSource,
    /// Per triangle, the texture coordinates `(u, v)` of its corners (OBJ `vt`), kept per corner
    /// so UV seams do not split vertices (and so do not turn smooth edges into creases). Empty
    /// when the file gives none for this mesh; NaN at a corner without a usable one.
    pub corner_uvs: Vec<[[f32; 2]; 3]>,
}

impl Mesh {
    /// A mesh from its own arrays: each vertex is its own position (no welding), and edges are
    /// classified from the triangles.
    pub fn from_triangles(
        name: &str,
        positions: Vec<Vec3>,
        normals: Vec<Vec3>,
        indices: Vec<[u32; 3]>,
    ) -> Mesh {
        let position_ids = (0..positions.len() as u32).collect::<Vec<_>>();
        let edge_kinds = classify_edges(&indices, &position_ids);
        Mesh {
            name: name.into(),
            positions,
            normals,
            indices,
            material: None,
            position_ids,
            edge_kinds,
            normals_source: NormalsSource::FromFile,
            corner_uvs: Vec::new(),
        }
    }

    /// Per triangle edge: whether Phong tessellation must keep it straight (every edge that is
    /// not smooth: a crease, a border or a non-manifold edge), for watertight creases.
    pub fn straight_edges(&self) -> Vec<[bool; 3]> {
        crate::mesh::straight_edges(&self.edge_kinds)
    }
}

/// A material, as much of MTL as the renderer uses.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// The `newmtl` name (`usemtl` refers to it).
    pub name: String,
    /// Diffuse reflectance (`Kd`, linear RGB).
    pub kd: Vec3,
    /// Specular reflectance (`Ks`): the highlight with `illum` >= 2, and the mirror with
    /// `illum` 3, 5 or 7.
    pub ks: Vec3,
    /// Emission (`Ke`): read, not rendered.
    pub ke: Vec3,
    /// Specular exponent (`Ns`); 0 = no highlight.
    pub ns: f32,
    /// Index of refraction (`Ni`), for transmission.
    pub ni: f32,
    /// Opacity `d` (1 = opaque; `Tr` = 1 - `d`).
    pub dissolve: f32,
    /// The illumination model (`illum`), `None` when the file gives none.
    pub illum: Option<u8>,
    /// The `map_Kd` texture, resolved against the OBJ file's directory.
    pub diffuse_texture: Option<PathBuf>,
}

impl Default for Material {
    fn default() -> Self {
        Material {
            name: "default".into(),
            kd: Vec3::splat(0.7),
            ks: Vec3::ZERO,
            ke: Vec3::ZERO,
            ns: 0.0,
            ni: 1.0,
            dissolve: 1.0,
            illum: None,
            diffuse_texture: None,
        }
    }
}

/// Counts over the whole scene.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LoadStats {
    /// Output vertices, over all meshes.
    pub vertices: usize,
    /// Output triangles, over all meshes (degenerate ones are not among them).
    pub triangles: usize,
    /// Output vertices whose normal came from the file.
    pub normals_from_file: usize,
    /// Output vertices whose normal was computed.
    pub normals_computed: usize,
    /// Edges shared by two triangles with the same vertices (one normal per end), counted once.
    pub smooth_edges: usize,
    /// Edges shared by two triangles whose vertices differ in normal at the same positions,
    /// counted once.
    pub crease_edges: usize,
    /// Edges of one triangle only.
    pub border_edges: usize,
    /// Edge sides on an edge of three or more triangles (each side counted).
    pub nonmanifold_edges: usize,
    /// Triangles dropped as degenerate (a repeated position after welding, or zero area).
    pub degenerate_skipped: usize,
    /// File normals of zero length (or not normalisable) that were replaced by computed ones.
    pub zero_normals_replaced: usize,
    /// Triangles dropped as duplicates of another (same welded positions, either winding).
    pub duplicates_dropped: usize,
    /// Smooth edges kept straight because they would balloon ([`EdgeKind::Straightened`],
    /// [`LoadOptions::bulge_limit`]), counted once.
    pub straightened_edges: usize,
}

/// A loaded model: an OBJ file's meshes and materials (or one generated mesh), what loading
/// warned about, and its counts. Not [`crate::embree::Scene`], the Embree scene it is traced in.
#[derive(Clone, Debug)]
pub struct Model {
    /// The OBJ file (`<name>` for a generated mesh).
    pub path: PathBuf,
    /// One mesh per object/group and material, in order of first appearance.
    pub meshes: Vec<Mesh>,
    /// Materials of every `mtllib`, in file order ([`Mesh::material`] indexes this).
    pub materials: Vec<Material>,
    /// One-line messages about input that was skipped or replaced (unsupported statements,
    /// degenerate triangles, missing materials or textures), each naming the file.
    pub warnings: Vec<String>,
    /// Counts over all meshes.
    pub stats: LoadStats,
}

/// Loading choices.
#[derive(Clone, Debug, PartialEq)]
pub struct LoadOptions {
    /// Where normals are computed: neighbouring faces whose normals differ by more than this
    /// (degrees) get separate vertex normals (a crease).
    pub crease_angle_deg: f32,
    /// Where normals are computed and the file has no smoothing groups, neighbouring faces that
    /// are both small (longest side at most [`SMALL_FACE_FRACTION`] of the mesh's bounding-box
    /// diagonal) also join up to this angle (degrees), so a low-poly organic model is smooth
    /// while the large faces of a building keep the crease angle; 0 turns it off (the rule
    /// before: one crease angle for every face).
    pub small_face_crease_angle_deg: f32,
    /// Welding tolerance, relative to the bounding-box diagonal.
    pub weld_tolerance: f32,
    /// Normals at one position within this angle (radians) are the same normal, so the edges
    /// between them are smooth ([`crate::mesh::NormalSnap`]); 0 compares them bit for bit.
    pub normal_tolerance_rad: f32,
    /// Drop triangles that repeat an earlier one's three welded positions (either winding),
    /// with a warning; `false` keeps them (and their non-manifold edges).
    pub drop_duplicate_faces: bool,
    /// Smooth edges whose curve at α = 1 would stand off the chord by more than this many times
    /// the altitude onto them of a triangle beside them are kept straight
    /// ([`crate::mesh::bulging_edges`]); infinity (or 0) keeps every smooth edge curved, the rule
    /// before.
    pub bulge_limit: f32,
}

impl Default for LoadOptions {
    fn default() -> Self {
        LoadOptions {
            crease_angle_deg: 30.0,
            small_face_crease_angle_deg: SMALL_FACE_CREASE_DEG,
            weld_tolerance: 1e-6,
            normal_tolerance_rad: crate::mesh::NORMAL_TOLERANCE,
            drop_duplicate_faces: true,
            bulge_limit: crate::mesh::BULGE_LIMIT,
        }
    }
}

impl Model {
    /// Bounds of every mesh position.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for p in self.meshes.iter().flat_map(|m| m.positions.iter()) {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        if lo.x > hi.x {
            (Vec3::ZERO, Vec3::ZERO)
        } else {
            (lo, hi)
        }
    }

    /// A scene of one mesh (for generated geometry).
    pub fn from_mesh(mesh: Mesh) -> Model {
        let mut s = Model {
            path: PathBuf::from(format!("<{}>", mesh.name)),
            meshes: vec![mesh],
            materials: Vec::new(),
            warnings: Vec::new(),
            stats: LoadStats::default(),
        };
        s.recount();
        s
    }

    /// Recompute the counts from the meshes (keeping those only loading knows).
    pub(super) fn recount(&mut self) {
        let mut st = LoadStats {
            degenerate_skipped: self.stats.degenerate_skipped,
            zero_normals_replaced: self.stats.zero_normals_replaced,
            duplicates_dropped: self.stats.duplicates_dropped,
            ..Default::default()
        };
        for m in &self.meshes {
            st.vertices += m.positions.len();
            st.triangles += m.indices.len();
            for ek in m.edge_kinds.iter().flatten() {
                match ek {
                    EdgeKind::Smooth => st.smooth_edges += 1,
                    EdgeKind::Crease => st.crease_edges += 1,
                    EdgeKind::Border => st.border_edges += 1,
                    EdgeKind::NonManifold => st.nonmanifold_edges += 1,
                    EdgeKind::Straightened => st.straightened_edges += 1,
                }
            }
        }
        // Each shared edge was seen from both sides.
        st.smooth_edges /= 2;
        st.crease_edges /= 2;
        st.straightened_edges /= 2;
        st.normals_from_file = self.stats.normals_from_file;
        st.normals_computed = self.stats.normals_computed;
        if st.normals_from_file + st.normals_computed == 0 {
            st.normals_computed = st.vertices;
        }
        self.stats = st;
    }
}

/// The default [`LoadOptions::small_face_crease_angle_deg`]: small faces join up to 60°.
pub const SMALL_FACE_CREASE_DEG: f32 = 60.0;

/// A face is small, for [`LoadOptions::small_face_crease_angle_deg`], when its longest side is
/// at most this fraction of its mesh's bounding-box diagonal.
pub const SMALL_FACE_FRACTION: f32 = 0.2;
