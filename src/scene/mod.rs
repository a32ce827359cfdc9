//! Scene input: OBJ/MTL loading, welding, vertex normals, mesh connectivity, generated meshes.
//!
//! Loading turns an OBJ file into [`Mesh`]es, one per object/group and material, each with
//! per-vertex positions and unit normals. Positions are welded (tolerance relative to the model
//! size) independently of how the file indexes normals, so that neighbouring triangles share
//! vertices wherever they share a position and a normal; a position with several normals becomes
//! several vertices, and the edge between such vertices is a *crease* ([`EdgeKind`]).

pub mod mtl;
pub mod obj;
mod warnings;

pub use warnings::FoldedWarnings;

use crate::mesh::weld;
pub use crate::mesh::{classify_edges, EdgeKind};

use std::collections::HashMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use glam::{DVec3, Vec3};

/// Errors that stop a scene from loading. Each displays as one line naming the file.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The OBJ file cannot be opened or read. The cause is part of the message (not also a
    /// `source()`, so a chain prints it once).
    #[error("{path}: cannot read: {error}")]
    Io {
        /// The OBJ file.
        path: PathBuf,
        /// Why.
        error: std::io::Error,
    },
    /// The path is a directory, FIFO, device or socket: refused before it is opened, since
    /// reading it could block or never end.
    #[error("{path}: not a regular file ({kind}); give the path of an OBJ file")]
    NotRegularFile {
        /// The path given.
        path: PathBuf,
        /// What it is instead, e.g. "a FIFO" or "a directory".
        kind: &'static str,
    },
    /// The OBJ file is larger than [`MAX_OBJ_BYTES`] (refused before it is read).
    #[error("{path}: larger than the {limit_mib} MiB limit for {what}")]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// What it was read as ("an OBJ file").
        what: &'static str,
        /// The limit, in MiB.
        limit_mib: u64,
    },
    /// A statement that does not parse: a number that is not one, a face corner with more than
    /// three parts, a `vt` without numbers, too few numbers for `v` or `vn`.
    #[error("{path}:{line}: malformed line: {message}")]
    Malformed {
        /// The OBJ file.
        path: PathBuf,
        /// The 1-based line the statement starts on (`\` continuations join later lines to it).
        line: usize,
        /// What is wrong, quoting the token (cut by [`cut_token`]).
        message: String,
    },
    /// A face index that is 0, or points past the elements defined before its line (OBJ indices
    /// refer backwards only).
    #[error("{path}:{line}: {kind} index {index} out of range ({count} defined so far)")]
    IndexOutOfRange {
        /// The OBJ file.
        path: PathBuf,
        /// The face's line.
        line: usize,
        /// "vertex", "normal" or "texture coordinate".
        kind: String,
        /// The index as written: 1-based, or negative (relative to the last defined).
        index: i64,
        /// How many elements of that kind precede the line.
        count: usize,
    },
    /// A `v` or `vn` coordinate that parses but is infinite or NaN.
    #[error("{path}:{line}: coordinate {value:?} is not a finite number")]
    NonFinite {
        /// The OBJ file.
        path: PathBuf,
        /// The statement's line.
        line: usize,
        /// The token, quoted and cut by [`cut_token`].
        value: String,
    },
    /// Nothing to render: the file has no faces, or every triangle is degenerate.
    #[error("{path}: no triangles to render{detail}")]
    Empty {
        /// The OBJ file.
        path: PathBuf,
        /// Which of the two, with the count: " (8 vertices, no faces)" or
        /// " (all 12 faces are degenerate)".
        detail: String,
    },
    /// The file holds a NUL byte: binary data or UTF-16 text, not an OBJ.
    #[error("{path}: binary data (NUL bytes), not an OBJ text file")]
    NotText {
        /// The file.
        path: PathBuf,
    },
}

/// The most an OBJ file may hold (1 GiB): more is refused before it is read.
pub const MAX_OBJ_BYTES: u64 = 1 << 30;
/// The most an MTL file may hold (64 MiB).
pub const MAX_MTL_BYTES: u64 = 64 << 20;

/// Why an input file could not be read whole.
#[derive(Debug)]
pub enum ReadFailure {
    /// Opening or reading failed.
    Io(std::io::Error),
    /// A FIFO, device, socket or directory (named: "a FIFO"): reading it could block or never
    /// end.
    NotRegular(&'static str),
    /// More bytes than the limit given to [`read_regular_file`].
    TooLarge,
}

/// Read a whole regular file of at most `limit` bytes. FIFOs, devices (`/dev/zero`), sockets
/// and directories are refused before they are opened, so reading never blocks or runs away;
/// the size is checked again while reading (the file may grow).
pub fn read_regular_file(path: &Path, limit: u64) -> Result<Vec<u8>, ReadFailure> {
    use std::io::Read;
    let kind = |m: &std::fs::Metadata| -> Option<&'static str> {
        use std::os::unix::fs::FileTypeExt;
        let t = m.file_type();
        if t.is_file() {
            None
        } else if t.is_dir() {
            Some("a directory")
        } else if t.is_fifo() {
            Some("a FIFO")
        } else if t.is_char_device() {
            Some("a character device")
        } else if t.is_block_device() {
            Some("a block device")
        } else if t.is_socket() {
            Some("a socket")
        } else {
            Some("not a file")
        }
    };
    let meta = std::fs::metadata(path).map_err(ReadFailure::Io)?;
    if let Some(k) = kind(&meta) {
        return Err(ReadFailure::NotRegular(k));
    }
    if meta.len() > limit {
        return Err(ReadFailure::TooLarge);
    }
    let f = std::fs::File::open(path).map_err(ReadFailure::Io)?;
    // The path may have been replaced between the two calls: check what was opened.
    if let Some(k) = kind(&f.metadata().map_err(ReadFailure::Io)?) {
        return Err(ReadFailure::NotRegular(k));
    }
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    f.take(limit + 1).read_to_end(&mut bytes).map_err(ReadFailure::Io)?;
    if bytes.len() as u64 > limit {
        return Err(ReadFailure::TooLarge);
    }
    Ok(bytes)
}

impl std::fmt::Display for ReadFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ReadFailure::Io(e) => write!(f, "cannot read: {e}"),
            ReadFailure::NotRegular(k) => write!(f, "not a regular file ({k})"),
            ReadFailure::TooLarge => write!(f, "too large"),
        }
    }
}

/// A token from an input file as shown in a message: at most 40 characters, and when cut, its
/// length in bytes (a 10 MB token must not become a 10 MB error line).
pub fn cut_token(s: &str) -> String {
    const KEEP: usize = 40;
    match s.char_indices().nth(KEEP) {
        None => format!("{s:?}"),
        Some((end, _)) => format!("{:?}... ({} bytes)", &s[..end], s.len()),
    }
}

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
    /// Index into [`Scene::materials`].
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

/// A loaded scene.
#[derive(Clone, Debug)]
pub struct Scene {
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

impl Scene {
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
    pub fn from_mesh(mesh: Mesh) -> Scene {
        let mut s = Scene {
            path: PathBuf::from(format!("<{}>", mesh.name)),
            meshes: vec![mesh],
            materials: Vec::new(),
            warnings: Vec::new(),
            stats: LoadStats::default(),
        };
        s.recount();
        s
    }

    fn recount(&mut self) {
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

/// Load an OBJ file and its MTL files.
pub fn load_obj(path: &Path, opts: &LoadOptions) -> Result<Scene, SceneError> {
    let bytes = read_regular_file(path, MAX_OBJ_BYTES).map_err(|e| match e {
        ReadFailure::Io(error) => SceneError::Io { path: path.to_path_buf(), error },
        ReadFailure::NotRegular(kind) => SceneError::NotRegularFile { path: path.to_path_buf(), kind },
        ReadFailure::TooLarge => SceneError::TooLarge {
            path: path.to_path_buf(),
            what: "an OBJ file",
            limit_mib: MAX_OBJ_BYTES >> 20,
        },
    })?;
    // OBJ is ASCII in practice; comments and names may be Latin-1, so decode lossily, but a NUL
    // byte means a binary file (or UTF-16 text).
    if bytes.contains(&0) {
        return Err(SceneError::NotText { path: path.to_path_buf() });
    }
    let text = String::from_utf8_lossy(&bytes);
    load_obj_text(&text, path, opts)
}

/// Load OBJ text as if read from `path` (MTL files are looked up beside `path`).
pub fn load_obj_text(text: &str, path: &Path, opts: &LoadOptions) -> Result<Scene, SceneError> {
    let raw = obj::parse(text, path)?;
    let dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    let name = path.display().to_string();

    // Read the materials, and say what the parser skipped.
    let mut warnings = Vec::new();
    let materials = load_materials(&raw, &dir, &name, &mut warnings);
    warn_skipped_input(&raw, &name, &mut warnings);

    // Build one mesh per (group, material), in order of first appearance.
    let tol = weld_tolerance(&raw, opts);
    let mut stats = LoadStats::default();
    let (meshes, undefined) = build_meshes(&raw, &materials, tol, opts, &mut stats);
    warn_built_meshes(&meshes, &undefined, &stats, &name, &mut warnings);
    warnings.extend(crease_warning(&meshes, opts, &name));
    if meshes.is_empty() {
        let detail = if raw.faces.is_empty() {
            format!(" ({} vertices, no faces)", raw.positions.len())
        } else {
            format!(" (all {} faces are degenerate)", raw.faces.len())
        };
        return Err(SceneError::Empty { path: path.to_path_buf(), detail });
    }
    let mut scene = Scene { path: path.to_path_buf(), meshes, materials, warnings, stats };
    scene.recount();
    Ok(scene)
}

/// The materials of every `mtllib` (resolved against `dir`), in order; a library that cannot
/// be read, or a texture that is missing, is a warning (the default material, the flat `Kd`).
fn load_materials(raw: &obj::RawObj, dir: &Path, name: &str, warnings: &mut Vec<String>) -> Vec<Material> {
    let mut materials: Vec<Material> = Vec::new();
    let mut textures = FoldedWarnings::default();
    for lib in &raw.mtllibs {
        let mtl_path = obj::resolve_file(dir, lib);
        let loaded = read_regular_file(&mtl_path, MAX_MTL_BYTES)
            .map(|b| mtl::parse(&String::from_utf8_lossy(&b), &mtl_path));
        match loaded {
            Ok(lib) => {
                warnings.extend(lib.warning);
                for m in lib.materials {
                    let tex = m.diffuse_texture.as_ref().map(|t| obj::resolve_file(dir, t));
                    if let Some(t) = &tex {
                        if let Some(w) = texture_warning(&mtl_path, t) {
                            textures.push("unreadable textures", w);
                        }
                    }
                    materials.push(m.to_material(tex));
                }
            }
            Err(e) => warnings.push(format!(
                "{name}: material library {}: {}; using a default material",
                mtl_path.display(),
                match e {
                    ReadFailure::TooLarge => format!("larger than the {} MiB limit", MAX_MTL_BYTES >> 20),
                    e => e.to_string(),
                }
            )),
        }
    }
    warnings.extend(textures.into_lines());
    materials
}

/// Say when a texture cannot be read (the render uses the flat Kd colour).
fn texture_warning(mtl_path: &Path, texture: &Path) -> Option<String> {
    match std::fs::metadata(texture) {
        Ok(md) if md.is_file() => None,
        Ok(_) => Some(format!(
            "{}: texture {} is not a regular file; using the flat Kd colour",
            mtl_path.display(),
            texture.display()
        )),
        Err(_) => Some(format!(
            "{}: texture {} not found; using the flat Kd colour",
            mtl_path.display(),
            texture.display()
        )),
    }
}

/// One warning each for what the parser counted and skipped: `usemtl` without `mtllib`, bad
/// `vt` lines, unsupported statements, elements without a surface.
fn warn_skipped_input(raw: &obj::RawObj, name: &str, warnings: &mut Vec<String>) {
    if raw.usemtl_without_mtllib && raw.mtllibs.is_empty() {
        warnings.push(format!("{name}: `usemtl` without `mtllib`; using a default material"));
    }
    if let Some(line) = raw.bad_texcoord_line {
        warnings.push(format!(
            "{name}:{line}: {} `vt` lines with more than 3 numbers or a non-finite one; those corners get no texture",
            raw.bad_texcoords
        ));
    }
    if let Some(line) = raw.first_non_finite_normal_line {
        warnings.push(format!(
            "{name}:{line}: {} `vn` lines with a coordinate that is not a finite number (first here); their corners get computed normals",
            raw.non_finite_normals
        ));
    }
    if raw.skipped_statements > 0 {
        warnings.push(format!(
            "{name}: skipped {} unsupported statements (curves, surfaces, ...)",
            raw.skipped_statements
        ));
    }
    if let Some(first) = raw.first_skipped_element_line {
        let parts: Vec<String> = [
            (raw.short_faces, "faces with fewer than 3 corners"),
            (raw.line_elements, "line (`l`) elements"),
            (raw.point_elements, "point (`p`) elements"),
        ]
        .iter()
        .filter(|(n, _)| *n > 0)
        .map(|(n, what)| format!("{n} {what}"))
        .collect();
        warnings.push(format!("{name}: skipped {} (no surface; first at line {first})", parts.join(", ")));
    }
}

/// The welding tolerance: `opts.weld_tolerance` times the diagonal of what the faces use (an
/// unused far-away vertex must not change it); `build_mesh` caps it per vertex by the local
/// edge lengths.
fn weld_tolerance(raw: &obj::RawObj, opts: &LoadOptions) -> f32 {
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for c in raw.faces.iter().flat_map(|f| &f.corners) {
        let p = raw.positions[c.v as usize].as_dvec3();
        lo = lo.min(p);
        hi = hi.max(p);
    }
    let diag = if lo.x <= hi.x { (hi - lo).length() } else { 0.0 };
    (opts.weld_tolerance.max(0.0) as f64 * diag).min(f32::MAX as f64) as f32
}

/// The faces of one mesh to build: a (group, material) pair in order of first appearance.
struct FaceGroup<'a> {
    group: usize,
    material: Option<&'a str>,
    faces: Vec<&'a obj::Face>,
}

/// Group faces by (group, material), in order of first appearance; and per group, how many
/// materials it uses.
fn group_faces(raw: &obj::RawObj) -> (Vec<FaceGroup<'_>>, HashMap<usize, usize>) {
    let mut groups: Vec<FaceGroup> = Vec::new();
    let mut ids: HashMap<(usize, Option<&str>), usize> = HashMap::new();
    let mut materials_per_group: HashMap<usize, usize> = HashMap::new();
    for f in &raw.faces {
        let k = *ids.entry((f.group, f.material.as_deref())).or_insert_with(|| {
            groups.push(FaceGroup { group: f.group, material: f.material.as_deref(), faces: Vec::new() });
            *materials_per_group.entry(f.group).or_default() += 1;
            groups.len() - 1
        });
        groups[k].faces.push(f);
    }
    (groups, materials_per_group)
}

/// Build the meshes (skipping those with no triangle left), named after their group (and
/// material, when the group has several). Also returns the material names used but not
/// defined by any `mtllib`, in order of first use.
fn build_meshes<'a>(
    raw: &'a obj::RawObj,
    materials: &[Material],
    tol: f32,
    opts: &LoadOptions,
    stats: &mut LoadStats,
) -> (Vec<Mesh>, Vec<&'a str>) {
    let (groups, materials_per_group) = group_faces(raw);
    let material_ids: HashMap<&str, usize> =
        materials.iter().enumerate().rev().map(|(i, m)| (m.name.as_str(), i)).collect();
    let mut meshes = Vec::new();
    let mut undefined: Vec<&str> = Vec::new();
    let mut undefined_seen: std::collections::HashSet<&str> = Default::default();
    for g in groups {
        // Compute the material index, noting a name no library defines.
        let material = g.material.and_then(|m| material_ids.get(m).copied());
        if let (Some(m), None) = (g.material, material) {
            if !raw.mtllibs.is_empty() && undefined_seen.insert(m) {
                undefined.push(m);
            }
        }
        // Compute the mesh name.
        let gname = raw.groups.get(g.group).cloned().unwrap_or_default();
        let mname = if gname.is_empty() { format!("mesh{}", meshes.len()) } else { gname };
        let mname = match (materials_per_group[&g.group] > 1, g.material) {
            (true, Some(m)) => format!("{mname}/{m}"),
            _ => mname,
        };
        if let Some(mesh) = build_mesh(raw, &g.faces, mname, material, tol, opts, stats) {
            meshes.push(mesh);
        }
    }
    (meshes, undefined)
}

/// One warning each for materials not defined, degenerate triangles skipped (loudly when many)
/// and file normals replaced.
fn warn_built_meshes(
    meshes: &[Mesh],
    undefined: &[&str],
    stats: &LoadStats,
    name: &str,
    warnings: &mut Vec<String>,
) {
    if !undefined.is_empty() {
        warnings.push(format!(
            "{name}: {} materials not defined (e.g. {}); using a default material",
            undefined.len(),
            cut_token(undefined[0])
        ));
    }
    if stats.degenerate_skipped > 0 {
        let total = stats.degenerate_skipped + meshes.iter().map(|m: &Mesh| m.indices.len()).sum::<usize>();
        let share = stats.degenerate_skipped as f64 / total as f64;
        // More than a few: say so loudly, with the share (the file itself is suspect).
        let loud = if stats.degenerate_skipped > 16 && share > 0.01 {
            format!(" of {total} ({:.1}%): the file's geometry looks broken", 100.0 * share)
        } else {
            String::new()
        };
        warnings.push(format!(
            "{name}: skipped {} degenerate (zero-area) triangles{loud}",
            stats.degenerate_skipped
        ));
    }
    if stats.zero_normals_replaced > 0 {
        warnings.push(format!(
            "{name}: {} zero-length or invalid normals replaced by computed ones",
            stats.zero_normals_replaced
        ));
    }
    if stats.duplicates_dropped > 0 {
        warnings.push(format!(
            "{name}: dropped {} duplicate triangles (the same three positions as another)",
            stats.duplicates_dropped
        ));
    }
}

/// A warning when many edges of the meshes whose normals were computed are creases that are
/// not hard edges (their faces meet at less than [`SOFT_CREASE_DEG`]): more than a quarter of
/// the shared edges. The model then renders about as faceted as flat, and a larger
/// `--crease-angle` would smooth it. A box or a capped cylinder (creases of 90°) gets none.
fn crease_warning(meshes: &[Mesh], opts: &LoadOptions, name: &str) -> Option<String> {
    let (mut soft, mut shared) = (0usize, 0usize);
    for m in meshes.iter().filter(|m| m.normals_source != NormalsSource::FromFile) {
        let (s, n) = soft_creases(m);
        soft += s;
        shared += n;
    }
    (shared > 0 && 4 * soft > shared).then(|| {
        format!(
            "{name}: {soft} of the {shared} edges with computed normals are creases under {SOFT_CREASE_DEG}° at the {}° crease angle, so the model looks faceted; try a larger --crease-angle (e.g. 60)",
            opts.crease_angle_deg
        )
    })
}

/// A triangle's unit normal (right-handed winding), computed in f64; zero for a degenerate one.
fn unit_face_normal(corners: [Vec3; 3]) -> DVec3 {
    let [a, b, c] = corners.map(|p| p.as_dvec3());
    (b - a).cross(c - a).normalize_or_zero()
}

/// Creases whose faces meet at less than this (degrees) count as soft in [`crease_warning`].
const SOFT_CREASE_DEG: f32 = 80.0;

/// A mesh's crease edges whose two faces' normals differ by less than [`SOFT_CREASE_DEG`], and
/// its shared (smooth or crease) edges, each edge counted once.
fn soft_creases(m: &Mesh) -> (usize, usize) {
    let face_normal = |t: usize| unit_face_normal(m.indices[t].map(|i| m.positions[i as usize]));
    let mut creases: HashMap<(u32, u32), Vec<usize>> = HashMap::new();
    let mut shared = 0;
    for (t, kinds) in m.edge_kinds.iter().enumerate() {
        for (k, kind) in kinds.iter().enumerate() {
            shared += matches!(kind, EdgeKind::Crease | EdgeKind::Smooth | EdgeKind::Straightened) as usize;
            if *kind == EdgeKind::Crease {
                let tri = m.indices[t];
                let (a, b) = (m.position_ids[tri[k] as usize], m.position_ids[tri[(k + 1) % 3] as usize]);
                creases.entry((a.min(b), a.max(b))).or_default().push(t);
            }
        }
    }
    let cos_soft = (SOFT_CREASE_DEG as f64).to_radians().cos();
    let soft = creases
        .values()
        .filter(|f| f.len() == 2 && face_normal(f[0]).dot(face_normal(f[1])) > cos_soft)
        .count();
    (soft, shared / 2)
}

fn angle_at(a: Vec3, b: Vec3, c: Vec3) -> f32 {
    // The interior angle at `a` of triangle (a, b, c), robust for small angles.
    // In f64, so huge coordinates cannot overflow into a NaN weight.
    let (u, v) = (b.as_dvec3() - a.as_dvec3(), c.as_dvec3() - a.as_dvec3());
    u.cross(v).length().atan2(u.dot(v)) as f32
}

/// Build one mesh from polygons: triangulate, weld, assign normals, classify edges.
fn build_mesh(
    raw: &obj::RawObj,
    faces: &[&obj::Face],
    name: String,
    material: Option<usize>,
    tol: f32,
    opts: &LoadOptions,
    stats: &mut LoadStats,
) -> Option<Mesh> {
    // Triangulate into corners (file position index, file normal index), with smoothing groups.
    let (tri_corners, tri_smooth) = triangulate_faces(raw, faces);
    // Weld the positions this mesh uses.
    let welded = WeldedPositions::new(raw, &tri_corners, tol);
    // Keep the non-degenerate triangles, with their file normals and texture coordinates.
    let mut tris = welded_triangles(raw, &welded, &tri_corners, &tri_smooth, stats);
    if opts.drop_duplicate_faces {
        drop_duplicate_triangles(&mut tris, stats);
    }
    if tris.is_empty() {
        return None;
    }
    // Compute a normal for every corner (used where the file gives none).
    let computed = ComputedNormals::new(&tris, &welded.positions, opts);
    // Make the output vertices: one per (position, normal).
    let out = output_vertices(&tris, &welded.positions, &computed, opts.normal_tolerance_rad);
    stats.normals_from_file += out.from_file;
    stats.normals_computed += out.computed;

    // Classify the edges, straightening those that would balloon; keep the corner texture
    // coordinates if any is usable.
    let mut edge_kinds = classify_edges(&out.indices, &out.position_ids);
    crate::mesh::straighten_bulging_edges(
        &out.positions,
        &out.normals,
        &out.indices,
        &mut edge_kinds,
        opts.bulge_limit,
    );
    let normals_source = match (out.from_file, out.computed) {
        (_, 0) => NormalsSource::FromFile,
        (0, _) => NormalsSource::Computed,
        _ => NormalsSource::Mixed,
    };
    let corner_uvs = if tris.iter().any(|t| t.uv.iter().any(|uv| uv[0].is_finite())) {
        tris.iter().map(|t| t.uv).collect()
    } else {
        Vec::new()
    };
    Some(Mesh {
        name,
        positions: out.positions,
        normals: out.normals,
        indices: out.indices,
        material,
        position_ids: out.position_ids,
        edge_kinds,
        normals_source,
        corner_uvs,
    })
}

/// Every polygon ear-clipped into triangles of file corners, with each triangle's smoothing
/// group.
fn triangulate_faces(raw: &obj::RawObj, faces: &[&obj::Face]) -> (Vec<[obj::Corner; 3]>, Vec<Option<u32>>) {
    let mut tri_corners: Vec<[obj::Corner; 3]> = Vec::new();
    let mut tri_smooth: Vec<Option<u32>> = Vec::new();
    for f in faces {
        let pts: Vec<Vec3> = f.corners.iter().map(|c| raw.positions[c.v as usize]).collect();
        for t in obj::triangulate(&pts) {
            tri_corners.push(t.map(|k| f.corners[k]));
            tri_smooth.push(f.smoothing);
        }
    }
    (tri_corners, tri_smooth)
}

/// The file positions one mesh uses, welded: welded position ids index `positions`.
struct WeldedPositions {
    /// The file position indices used, sorted.
    used: Vec<u32>,
    /// Their positions (`positions[i]` is file position `used[i]`).
    positions: Vec<Vec3>,
    /// Per used position, its welded position id.
    ids: Vec<u32>,
}

impl WeldedPositions {
    fn new(raw: &obj::RawObj, tri_corners: &[[obj::Corner; 3]], tol: f32) -> WeldedPositions {
        let used: Vec<u32> = {
            let mut u: Vec<u32> = tri_corners.iter().flatten().map(|c| c.v).collect();
            u.sort_unstable();
            u.dedup();
            u
        };
        let positions: Vec<Vec3> = used.iter().map(|&v| raw.positions[v as usize]).collect();
        // Per position, a tenth of its shortest non-zero incident edge: welding moves no corner
        // farther than that, so corners a and b of an edge of length L never meet
        // (|a - b| <= cap_a + cap_b <= 0.2 L), and welding never collapses a triangle.
        let slot = |v: u32| used.binary_search(&v).unwrap_or(0);
        let mut caps = vec![f64::INFINITY; used.len()];
        for t in tri_corners {
            for k in 0..3 {
                let (a, b) = (slot(t[k].v), slot(t[(k + 1) % 3].v));
                let len = positions[a].as_dvec3().distance(positions[b].as_dvec3());
                if len > 0.0 {
                    caps[a] = caps[a].min(0.1 * len);
                    caps[b] = caps[b].min(0.1 * len);
                }
            }
        }
        let ids = weld(&positions, &caps, tol);
        WeldedPositions { used, positions, ids }
    }

    /// The welded position id of file position `v`.
    fn id(&self, v: u32) -> u32 {
        self.ids[self.used.binary_search(&v).unwrap_or(0)]
    }

    /// The position of welded position id `pid`.
    fn at(&self, pid: u32) -> Vec3 {
        self.positions[pid as usize]
    }
}

/// A triangle of a mesh being built.
struct Tri {
    /// Welded position ids of the corners.
    pid: [u32; 3],
    /// The file's unit normal per corner, where it gives a usable one.
    file_normal: [Option<Vec3>; 3],
    /// The smoothing group (`None` where the file never says).
    smoothing: Option<u32>,
    /// The texture coordinates per corner (NaN where none).
    uv: [[f32; 2]; 3],
}

/// The triangles with distinct welded corners and non-zero area (the others are counted in
/// `stats.degenerate_skipped`), with the file's normals (zero ones counted in
/// `stats.zero_normals_replaced`) and texture coordinates.
fn welded_triangles(
    raw: &obj::RawObj,
    welded: &WeldedPositions,
    tri_corners: &[[obj::Corner; 3]],
    tri_smooth: &[Option<u32>],
    stats: &mut LoadStats,
) -> Vec<Tri> {
    let mut tris = Vec::new();
    for (t, s) in tri_corners.iter().zip(tri_smooth) {
        let pid = t.map(|c| welded.id(c.v));
        let [a, b, c] = pid.map(|p| welded.at(p).as_dvec3());
        // In f64: the cross product of finite f32 coordinates cannot overflow there.
        let area2 = (b - a).cross(c - a).length();
        if pid[0] == pid[1] || pid[1] == pid[2] || pid[0] == pid[2] || !(area2 > 0.0) {
            stats.degenerate_skipped += 1;
            continue;
        }
        let file_normal = t.map(|c| {
            c.n.map(|n| raw.normals[n as usize]).and_then(|n| {
                // A huge f32 normal overflows its f32 length: then in f64. NaN gives None.
                let r = n.try_normalize().or_else(|| n.as_dvec3().try_normalize().map(|d| d.as_vec3()));
                if r.is_none() {
                    stats.zero_normals_replaced += 1;
                }
                r
            })
        });
        let uv = t.map(|c| c.t.and_then(|i| raw.texcoords.get(i as usize).copied()).unwrap_or([f32::NAN; 2]));
        tris.push(Tri { pid, file_normal, smoothing: *s, uv });
    }
    tris
}

/// Drop the triangles that repeat an earlier one's welded positions (counted in
/// `stats.duplicates_dropped`; see [`crate::mesh::duplicate_triangles`]).
fn drop_duplicate_triangles(tris: &mut Vec<Tri>, stats: &mut LoadStats) {
    let dup = crate::mesh::duplicate_triangles(tris.iter().map(|t| t.pid));
    let mut k = 0;
    tris.retain(|_| {
        k += 1;
        !dup[k - 1]
    });
    stats.duplicates_dropped += dup.iter().filter(|&&d| d).count();
}

/// The default [`LoadOptions::small_face_crease_angle_deg`]: small faces join up to 60°.
pub const SMALL_FACE_CREASE_DEG: f32 = 60.0;

/// A face is small, for [`LoadOptions::small_face_crease_angle_deg`], when its longest side is
/// at most this fraction of its mesh's bounding-box diagonal.
pub const SMALL_FACE_FRACTION: f32 = 0.2;

/// Which neighbouring faces share computed normals: the same non-zero smoothing group where
/// the mesh has any, else face normals within the crease angle, or within the wider small-face
/// angle when both faces are small.
struct JoinRule<'a> {
    tris: &'a [Tri],
    face_normals: &'a [Vec3],
    any_smoothing: bool,
    cos_crease: f32,
    cos_small: f32,
    /// Per triangle: its longest side is at most [`SMALL_FACE_FRACTION`] of the diagonal.
    small: Vec<bool>,
}

impl<'a> JoinRule<'a> {
    fn new(tris: &'a [Tri], positions: &[Vec3], face_normals: &'a [Vec3], opts: &LoadOptions) -> Self {
        let cos_of = |deg: f32| deg.clamp(0.0, 180.0).to_radians().cos();
        // Compute the mesh's diagonal, then which faces are small against it.
        let at = |pid: u32| positions[pid as usize];
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for p in tris.iter().flat_map(|t| t.pid.map(at)) {
            (lo, hi) = (lo.min(p), hi.max(p));
        }
        let limit = SMALL_FACE_FRACTION * (hi - lo).length();
        let small = tris
            .iter()
            .map(|t| {
                let [p, q, r] = t.pid.map(at);
                p.distance(q).max(q.distance(r)).max(r.distance(p)) <= limit
            })
            .collect();
        JoinRule {
            tris,
            face_normals,
            any_smoothing: tris.iter().any(|t| t.smoothing.is_some()),
            cos_crease: cos_of(opts.crease_angle_deg),
            cos_small: if opts.small_face_crease_angle_deg > 0.0 {
                cos_of(opts.small_face_crease_angle_deg)
            } else {
                f32::INFINITY
            },
            small,
        }
    }

    /// Whether faces `ti` and `tj`, which share an edge, share its normals.
    fn joins(&self, ti: usize, tj: usize) -> bool {
        if self.any_smoothing {
            // Smoothing groups: share normals within a non-zero group; group 0 is flat.
            let (si, sj) = (&self.tris[ti].smoothing, &self.tris[tj].smoothing);
            return matches!((si, sj), (Some(a), Some(b)) if *a != 0 && a == b);
        }
        let d = self.face_normals[ti].dot(self.face_normals[tj]);
        d >= self.cos_crease || (d >= self.cos_small && self.small[ti] && self.small[tj])
    }
}

/// Computed vertex normals per triangle corner: around each position, the angle-weighted mean
/// of the face normals of the corners that join (same smoothing group, or within the crease
/// angle), bit for bit the same for every corner of a cluster.
struct ComputedNormals {
    face_normals: Vec<Vec3>,
    /// Per (triangle, corner).
    corner: HashMap<(usize, usize), Vec3>,
}

impl ComputedNormals {
    fn new(tris: &[Tri], positions: &[Vec3], opts: &LoadOptions) -> ComputedNormals {
        let at = |pid: u32| positions[pid as usize];
        // Compute the face normals and the corners incident to each position.
        let face_normals: Vec<Vec3> =
            tris.iter().map(|t| unit_face_normal(t.pid.map(at)).as_vec3()).collect();
        let mut incident: HashMap<u32, Vec<(usize, usize)>> = HashMap::new();
        for (ti, t) in tris.iter().enumerate() {
            for (k, &pid) in t.pid.iter().enumerate() {
                incident.entry(pid).or_default().push((ti, k));
            }
        }
        // Which faces join: smoothing groups if the mesh has any, else the crease angles.
        let rule = JoinRule::new(tris, positions, &face_normals, opts);
        let joins = |ti: usize, tj: usize| rule.joins(ti, tj);
        // Around each position, one normal per cluster of joined corners.
        let mut corner: HashMap<(usize, usize), Vec3> = HashMap::new();
        for (&pid, list) in &incident {
            let cluster = corner_clusters(pid, list, tris, &joins);
            let mut sums: HashMap<usize, Vec3> = HashMap::new();
            for (e, &(t, k)) in list.iter().enumerate() {
                let q = &tris[t].pid;
                let ang = angle_at(at(q[k]), at(q[(k + 1) % 3]), at(q[(k + 2) % 3]));
                *sums.entry(cluster[e]).or_insert(Vec3::ZERO) += ang * face_normals[t];
            }
            for (e, &(t, k)) in list.iter().enumerate() {
                let n = sums[&cluster[e]].try_normalize().unwrap_or(face_normals[t]);
                corner.insert((t, k), n);
            }
        }
        ComputedNormals { face_normals, corner }
    }

    /// The computed normal of corner `k` of triangle `ti`.
    fn at(&self, ti: usize, k: usize) -> Vec3 {
        self.corner.get(&(ti, k)).copied().unwrap_or(self.face_normals[ti])
    }
}

/// Cluster the corners `list` (triangle, corner) around position `pid`: two faces that share an
/// edge at `pid` and join are one cluster. Returns each entry's cluster id (an index into
/// `list`).
fn corner_clusters(
    pid: u32,
    list: &[(usize, usize)],
    tris: &[Tri],
    joins: &impl Fn(usize, usize) -> bool,
) -> Vec<usize> {
    let mut parent: Vec<usize> = (0..list.len()).collect();
    fn find(p: &mut [usize], mut x: usize) -> usize {
        while p[x] != x {
            p[x] = p[p[x]];
            x = p[x];
        }
        x
    }
    // Faces that share an edge at this position share its other end `q`: group the corners by
    // `q` (linear, where comparing all pairs would be quadratic in the valence, and a hostile
    // fan has 100k triangles around one vertex).
    let mut by_other: HashMap<u32, Vec<usize>> = HashMap::new();
    for (e, &(t, _)) in list.iter().enumerate() {
        for &q in tris[t].pid.iter().filter(|&&q| q != pid) {
            by_other.entry(q).or_default().push(e);
        }
    }
    for group in by_other.values() {
        // A manifold edge has 2 faces; a non-manifold one may have many: all pairs up to 64,
        // then neighbours in order only (bounded work).
        let all_pairs = group.len() <= 64;
        for i in 0..group.len() {
            let last = if all_pairs { group.len() } else { (i + 2).min(group.len()) };
            for j in i + 1..last {
                let (a, b) = (group[i], group[j]);
                if joins(list[a].0, list[b].0) {
                    let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
                    parent[ra] = rb;
                }
            }
        }
    }
    (0..list.len()).map(|e| find(&mut parent, e)).collect()
}

/// A mesh's output vertex arrays.
struct OutputVertices {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    position_ids: Vec<u32>,
    indices: Vec<[u32; 3]>,
    /// Vertices whose normal came from the file.
    from_file: usize,
    /// Vertices whose normal was computed.
    computed: usize,
}

/// One output vertex per (welded position, normal): the file's normal where usable, else the
/// computed one.
fn output_vertices(
    tris: &[Tri],
    positions: &[Vec3],
    computed_normals: &ComputedNormals,
    normal_tolerance: f32,
) -> OutputVertices {
    let mut out = OutputVertices {
        positions: Vec::new(),
        normals: Vec::new(),
        position_ids: Vec::new(),
        indices: Vec::with_capacity(tris.len()),
        from_file: 0,
        computed: 0,
    };
    let mut vmap: HashMap<(u32, [u32; 3]), u32> = HashMap::new();
    let mut snap = crate::mesh::NormalSnap::new(normal_tolerance);
    for (ti, t) in tris.iter().enumerate() {
        let mut tri = [0u32; 3];
        for k in 0..3 {
            let (n, file) = match t.file_normal[k] {
                Some(n) => (n, true),
                None => (computed_normals.at(ti, k), false),
            };
            let n = snap.snap(t.pid[k], n);
            let key = (t.pid[k], n.to_array().map(f32::to_bits));
            tri[k] = *vmap.entry(key).or_insert_with(|| {
                out.positions.push(positions[t.pid[k] as usize]);
                out.normals.push(n);
                out.position_ids.push(t.pid[k]);
                if file {
                    out.from_file += 1;
                } else {
                    out.computed += 1;
                }
                (out.positions.len() - 1) as u32
            });
        }
        out.indices.push(tri);
    }
    out
}

/// A UV sphere of `segments` × `rings` with exact normals (poles are single vertices).
pub fn uv_sphere(segments: u32, rings: u32, radius: f32) -> Mesh {
    let (segments, rings) = (segments.max(3), rings.max(2));
    let mut positions = vec![Vec3::Y * radius];
    let mut normals = vec![Vec3::Y];
    for r in 1..rings {
        let th = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..segments {
            let ph = std::f32::consts::TAU * s as f32 / segments as f32;
            let n = Vec3::new(th.sin() * ph.cos(), th.cos(), -th.sin() * ph.sin());
            positions.push(n * radius);
            normals.push(n);
        }
    }
    positions.push(-Vec3::Y * radius);
    normals.push(-Vec3::Y);
    let ring = |r: u32, s: u32| 1 + (r - 1) * segments + s % segments;
    let last = positions.len() as u32 - 1;
    let mut indices = Vec::new();
    for s in 0..segments {
        indices.push([0, ring(1, s), ring(1, s + 1)]);
        for r in 1..rings - 1 {
            indices.push([ring(r, s), ring(r + 1, s), ring(r + 1, s + 1)]);
            indices.push([ring(r, s), ring(r + 1, s + 1), ring(r, s + 1)]);
        }
        indices.push([ring(rings - 1, s), last, ring(rings - 1, s + 1)]);
    }
    let mut mesh = Mesh::from_triangles("sphere", positions, normals, indices);
    mesh.normals_source = NormalsSource::Computed;
    mesh
}

/// Write a mesh as OBJ (positions, normals, `f v//vn`), 7 significant digits.
pub fn write_obj(mesh: &Mesh, path: &Path, header: &str) -> std::io::Result<()> {
    let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
    for l in header.lines() {
        writeln!(f, "# {l}")?;
    }
    writeln!(f, "o {}", mesh.name)?;
    for p in &mesh.positions {
        writeln!(f, "v {:.7} {:.7} {:.7}", p.x, p.y, p.z)?;
    }
    for n in &mesh.normals {
        writeln!(f, "vn {:.7} {:.7} {:.7}", n.x, n.y, n.z)?;
    }
    for t in &mesh.indices {
        let [a, b, c] = t.map(|i| i + 1);
        writeln!(f, "f {a}//{a} {b}//{b} {c}//{c}")?;
    }
    f.flush()
}
