//! Scene input: OBJ/MTL loading, welding, vertex normals, mesh connectivity, generated meshes.
//!
//! Loading turns an OBJ file into [`Mesh`]es, one per object/group and material, each with
//! per-vertex positions and unit normals. Positions are welded (tolerance relative to the model
//! size) independently of how the file indexes normals, so that neighbouring triangles share
//! vertices wherever they share a position and a normal; a position with several normals becomes
//! several vertices, and the edge between such vertices is a *crease* ([`EdgeKind`]).

pub mod obj;

use std::collections::HashMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use glam::Vec3;

/// Errors that stop a scene from loading. Each displays as one line naming the file.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("{path}: cannot read: {source}")]
    Io { path: PathBuf, source: std::io::Error },
    #[error("{path}:{line}: malformed line: {message}")]
    Malformed { path: PathBuf, line: usize, message: String },
    #[error("{path}:{line}: {kind} index {index} out of range ({count} defined so far)")]
    IndexOutOfRange { path: PathBuf, line: usize, kind: String, index: i64, count: usize },
    #[error("{path}:{line}: coordinate {value:?} is not a finite number")]
    NonFinite { path: PathBuf, line: usize, value: String },
    #[error("{path}: no triangles to render{detail}")]
    Empty { path: PathBuf, detail: String },
    #[error("{path}: binary data (NUL bytes), not an OBJ text file")]
    NotText { path: PathBuf },
}

/// How an edge of a triangle relates to its neighbour (edge `i` runs from corner `i` to `i+1`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum EdgeKind {
    /// Shared with one neighbour, same vertices (so same normals) at both ends.
    Smooth,
    /// Shared with one neighbour by position, but the normals differ at an end.
    Crease,
    /// No neighbour.
    Border,
    /// More than two triangles share the edge.
    NonManifold,
}

/// Where a mesh's normals come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NormalsSource {
    FromFile,
    Computed,
    Mixed,
}

/// A triangle mesh with per-vertex unit normals.
#[derive(Clone, Debug)]
pub struct Mesh {
    pub name: String,
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    /// Triangles, counter-clockwise as in the file.
    pub indices: Vec<[u32; 3]>,
    /// Index into [`Scene::materials`].
    pub material: Option<usize>,
    /// Per vertex: the welded position id (vertices with equal ids share a position).
    pub position_ids: Vec<u32>,
    /// Per triangle edge `i` = (corner `i`, corner `i+1`).
    pub edge_kinds: Vec<[EdgeKind; 3]>,
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
        self.edge_kinds.iter().map(|k| k.map(|e| e != EdgeKind::Smooth)).collect()
    }
}

/// A material, as much of MTL as the renderer uses.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    pub kd: Vec3,
    pub ks: Vec3,
    pub ke: Vec3,
    pub ns: f32,
    pub ni: f32,
    /// Opacity `d` (1 = opaque; `Tr` = 1 - `d`).
    pub dissolve: f32,
    pub illum: Option<u8>,
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
    pub vertices: usize,
    pub triangles: usize,
    /// Output vertices whose normal came from the file / was computed.
    pub normals_from_file: usize,
    pub normals_computed: usize,
    pub smooth_edges: usize,
    pub crease_edges: usize,
    pub border_edges: usize,
    pub nonmanifold_edges: usize,
    pub degenerate_skipped: usize,
    pub zero_normals_replaced: usize,
}

/// A loaded scene.
#[derive(Clone, Debug)]
pub struct Scene {
    pub path: PathBuf,
    pub meshes: Vec<Mesh>,
    pub materials: Vec<Material>,
    pub warnings: Vec<String>,
    pub stats: LoadStats,
}

/// Loading choices.
#[derive(Clone, Debug, PartialEq)]
pub struct LoadOptions {
    /// Where normals are computed: neighbouring faces whose normals differ by more than this
    /// (degrees) get separate vertex normals (a crease).
    pub crease_angle_deg: f32,
    /// Welding tolerance, relative to the bounding-box diagonal.
    pub weld_tolerance: f32,
}

impl Default for LoadOptions {
    fn default() -> Self {
        LoadOptions { crease_angle_deg: 30.0, weld_tolerance: 1e-6 }
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
                }
            }
        }
        // Each shared edge was seen from both sides.
        st.smooth_edges /= 2;
        st.crease_edges /= 2;
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
    let bytes = std::fs::read(path).map_err(|source| SceneError::Io { path: path.to_path_buf(), source })?;
    // OBJ is ASCII in practice; comments and names may be Latin-1, so decode lossily, but a NUL
    // byte means a binary file.
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
    let mut warnings = Vec::new();
    let name = path.display().to_string();

    // Materials.
    let mut materials: Vec<Material> = Vec::new();
    for lib in &raw.mtllibs {
        let mtl_path = obj::resolve_file(&dir, lib);
        let loaded = std::fs::read(&mtl_path).map_err(|e| e.to_string()).and_then(|b| {
            tobj::load_mtl_buf(&mut String::from_utf8_lossy(&b).as_bytes()).map_err(|e| e.to_string())
        });
        match loaded {
            Ok((mats, _)) => {
                for m in mats {
                    let tex = m.diffuse_texture.as_ref().map(|t| obj::resolve_file(&dir, t));
                    if let Some(t) = &tex {
                        if !t.exists() {
                            warnings.push(format!(
                                "{}: texture {} not found; using the flat Kd colour",
                                mtl_path.display(),
                                t.display()
                            ));
                        }
                    }
                    let v3 = |a: Option<[f32; 3]>, d: Vec3| {
                        a.map(Vec3::from).filter(|v| v.is_finite()).unwrap_or(d)
                    };
                    let ke = m
                        .unknown_param
                        .get("Ke")
                        .and_then(|s| {
                            let v: Vec<f32> = s.split_whitespace().filter_map(|x| x.parse().ok()).collect();
                            (v.len() == 3).then(|| Vec3::new(v[0], v[1], v[2]))
                        })
                        .unwrap_or(Vec3::ZERO);
                    let mut dissolve = m.dissolve.filter(|d| d.is_finite()).unwrap_or(1.0);
                    if let Some(tr) = m.unknown_param.get("Tr").and_then(|s| s.trim().parse::<f32>().ok()) {
                        if m.dissolve.is_none() && tr.is_finite() {
                            dissolve = 1.0 - tr;
                        }
                    }
                    materials.push(Material {
                        name: m.name.clone(),
                        kd: v3(m.diffuse, Vec3::splat(0.7)),
                        ks: v3(m.specular, Vec3::ZERO),
                        ke,
                        ns: m.shininess.unwrap_or(0.0),
                        ni: m.optical_density.filter(|n| n.is_finite()).unwrap_or(1.0),
                        dissolve: dissolve.clamp(0.0, 1.0),
                        illum: m.illumination_model,
                        diffuse_texture: tex,
                    });
                }
            }
            Err(e) => warnings.push(format!(
                "{name}: material library {} not usable ({e}); using a default material",
                mtl_path.display()
            )),
        }
    }
    if raw.usemtl_without_mtllib && raw.mtllibs.is_empty() {
        warnings.push(format!("{name}: `usemtl` without `mtllib`; using a default material"));
    }
    if let Some(line) = raw.bad_texcoord_line {
        warnings.push(format!(
            "{name}:{line}: {} `vt` lines with more than 3 numbers or a non-finite one; those corners get no texture",
            raw.bad_texcoords
        ));
    }
    if raw.skipped_statements > 0 {
        warnings.push(format!(
            "{name}: skipped {} unsupported statements (lines, points, curves, ...)",
            raw.skipped_statements
        ));
    }

    // Group faces into meshes by (group, material).
    let mut keys: Vec<(usize, Option<String>)> = Vec::new();
    let mut faces_of: Vec<Vec<usize>> = Vec::new();
    for (fi, f) in raw.faces.iter().enumerate() {
        let key = (f.group, f.material.clone());
        let k = match keys.iter().position(|k| *k == key) {
            Some(k) => k,
            None => {
                keys.push(key);
                faces_of.push(Vec::new());
                keys.len() - 1
            }
        };
        faces_of[k].push(fi);
    }

    // Welding tolerance from the model size.
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for p in &raw.positions {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    let diag = if lo.x <= hi.x { (hi - lo).length() } else { 0.0 };
    let tol = opts.weld_tolerance.max(0.0) * diag;

    let mut meshes = Vec::new();
    let mut stats = LoadStats::default();
    let mut undefined: Vec<&str> = Vec::new();
    for (k, (group, mat)) in keys.iter().enumerate() {
        let material = mat.as_ref().and_then(|m| materials.iter().position(|x| x.name == *m));
        if let (Some(m), None) = (mat, material) {
            if !raw.mtllibs.is_empty() && !undefined.contains(&m.as_str()) {
                undefined.push(m);
            }
        }
        let gname = raw.groups.get(*group).cloned().unwrap_or_default();
        let mname = if gname.is_empty() { format!("mesh{}", meshes.len()) } else { gname };
        let mname = match (keys.iter().filter(|(g, _)| g == group).count() > 1, mat) {
            (true, Some(m)) => format!("{mname}/{m}"),
            _ => mname,
        };
        let faces: Vec<&obj::Face> = faces_of[k].iter().map(|&i| &raw.faces[i]).collect();
        if let Some(mesh) = build_mesh(&raw, &faces, mname, material, tol, opts, &mut stats) {
            meshes.push(mesh);
        }
    }
    if !undefined.is_empty() {
        warnings.push(format!(
            "{name}: {} materials not defined (e.g. {:?}); using a default material",
            undefined.len(),
            undefined[0]
        ));
    }
    if stats.degenerate_skipped > 0 {
        warnings
            .push(format!("{name}: skipped {} degenerate (zero-area) triangles", stats.degenerate_skipped));
    }
    if stats.zero_normals_replaced > 0 {
        warnings.push(format!(
            "{name}: {} zero-length or invalid normals replaced by computed ones",
            stats.zero_normals_replaced
        ));
    }
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

/// Weld positions within `tol` using a hash grid; returns a position id per input position
/// (ids index the first position of each cluster).
fn weld(points: &[Vec3], tol: f32) -> Vec<u32> {
    if tol <= 0.0 {
        // Exact welding on bit patterns (+0 and -0 equal).
        let mut map: HashMap<[u32; 3], u32> = HashMap::with_capacity(points.len());
        return points
            .iter()
            .enumerate()
            .map(|(i, p)| *map.entry((*p + Vec3::ZERO).to_array().map(f32::to_bits)).or_insert(i as u32))
            .collect();
    }
    let cell = |p: Vec3| ((p.x / tol).floor() as i64, (p.y / tol).floor() as i64, (p.z / tol).floor() as i64);
    let mut grid: HashMap<(i64, i64, i64), Vec<u32>> = HashMap::with_capacity(points.len());
    let mut ids = Vec::with_capacity(points.len());
    for (i, p) in points.iter().enumerate() {
        let c = cell(*p);
        let mut found = None;
        'search: for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(list) = grid.get(&(c.0 + dx, c.1 + dy, c.2 + dz)) {
                        for &j in list {
                            if points[j as usize].distance(*p) <= tol {
                                found = Some(ids[j as usize]);
                                break 'search;
                            }
                        }
                    }
                }
            }
        }
        let id = found.unwrap_or(i as u32);
        ids.push(id);
        if found.is_none() {
            grid.entry(c).or_default().push(i as u32);
        }
    }
    ids
}

fn angle_at(a: Vec3, b: Vec3, c: Vec3) -> f32 {
    // The interior angle at `a` of triangle (a, b, c), robust for small angles.
    let (u, v) = (b - a, c - a);
    u.cross(v).length().atan2(u.dot(v))
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
    // Triangulate into corners (file position index, file normal index, smoothing group).
    let mut tri_corners: Vec<[obj::Corner; 3]> = Vec::new();
    let mut tri_smooth: Vec<Option<u32>> = Vec::new();
    for f in faces {
        let pts: Vec<Vec3> = f.corners.iter().map(|c| raw.positions[c.v as usize]).collect();
        for t in obj::triangulate(&pts) {
            tri_corners.push(t.map(|k| f.corners[k]));
            tri_smooth.push(f.smoothing);
        }
    }
    // Weld the positions this mesh uses.
    let used: Vec<u32> = {
        let mut u: Vec<u32> = tri_corners.iter().flatten().map(|c| c.v).collect();
        u.sort_unstable();
        u.dedup();
        u
    };
    let pts: Vec<Vec3> = used.iter().map(|&v| raw.positions[v as usize]).collect();
    let wid = weld(&pts, tol);
    let local = |v: u32| -> u32 { wid[used.binary_search(&v).unwrap_or(0)] };
    let wpos = |pid: u32| pts[pid as usize];

    // Drop degenerate triangles (repeated welded positions or zero area).
    // Per triangle: welded position ids, the file's unit normal per corner (if usable), smoothing group.
    type Tri = ([u32; 3], [Option<Vec3>; 3], Option<u32>, [[f32; 2]; 3]);
    let mut tris: Vec<Tri> = Vec::new();
    for (t, s) in tri_corners.iter().zip(&tri_smooth) {
        let pid = t.map(|c| local(c.v));
        let (a, b, c) = (wpos(pid[0]), wpos(pid[1]), wpos(pid[2]));
        let area2 = (b - a).cross(c - a).length();
        if pid[0] == pid[1] || pid[1] == pid[2] || pid[0] == pid[2] || !(area2 > 0.0) {
            stats.degenerate_skipped += 1;
            continue;
        }
        let fnorm = t.map(|c| {
            c.n.map(|n| raw.normals[n as usize]).and_then(|n| {
                let r = n.try_normalize();
                if r.is_none() {
                    stats.zero_normals_replaced += 1;
                }
                r
            })
        });
        let uv = t.map(|c| c.t.and_then(|i| raw.texcoords.get(i as usize).copied()).unwrap_or([f32::NAN; 2]));
        tris.push((pid, fnorm, *s, uv));
    }
    if tris.is_empty() {
        return None;
    }

    // Face normals and corner angles, for computed normals.
    let face_n: Vec<Vec3> = tris
        .iter()
        .map(|(p, _, _, _)| (wpos(p[1]) - wpos(p[0])).cross(wpos(p[2]) - wpos(p[0])).normalize_or_zero())
        .collect();
    let mut incident: HashMap<u32, Vec<(usize, usize)>> = HashMap::new();
    for (ti, (p, _, _, _)) in tris.iter().enumerate() {
        for (k, &pid) in p.iter().enumerate() {
            incident.entry(pid).or_default().push((ti, k));
        }
    }
    let cos_crease = opts.crease_angle_deg.clamp(0.0, 180.0).to_radians().cos();
    let any_smoothing = tris.iter().any(|(_, _, s, _)| s.is_some());
    let joins = |ti: usize, tj: usize| -> bool {
        let (si, sj) = (&tris[ti].2, &tris[tj].2);
        if any_smoothing {
            // Smoothing groups: share normals within a non-zero group; group 0 is flat.
            matches!((si, sj), (Some(a), Some(b)) if *a != 0 && a == b)
        } else {
            face_n[ti].dot(face_n[tj]) >= cos_crease
        }
    };
    // Around each position, cluster the incident corners: two faces that share an edge at this
    // position and join (same smoothing group, or within the crease angle) are one cluster; a
    // cluster's corners all get the same (angle-weighted) normal, bit for bit.
    let mut corner_normal: HashMap<(usize, usize), Vec3> = HashMap::new();
    for (&pid, list) in &incident {
        let m = list.len();
        let mut parent: Vec<usize> = (0..m).collect();
        fn find(p: &mut [usize], mut x: usize) -> usize {
            while p[x] != x {
                p[x] = p[p[x]];
                x = p[x];
            }
            x
        }
        for a in 0..m {
            for b in a + 1..m {
                let ((ta, _), (tb, _)) = (list[a], list[b]);
                let pa = &tris[ta].0;
                let pb = &tris[tb].0;
                let shares_edge = pa.iter().any(|&q| q != pid && pb.contains(&q));
                if shares_edge && joins(ta, tb) {
                    let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
                    parent[ra] = rb;
                }
            }
        }
        let mut sums: HashMap<usize, Vec3> = HashMap::new();
        for (e, &(t, k)) in list.iter().enumerate() {
            let q = &tris[t].0;
            let ang = angle_at(wpos(q[k]), wpos(q[(k + 1) % 3]), wpos(q[(k + 2) % 3]));
            *sums.entry(find(&mut parent, e)).or_insert(Vec3::ZERO) += ang * face_n[t];
        }
        for (e, &(t, k)) in list.iter().enumerate() {
            let n = sums[&find(&mut parent, e)].try_normalize().unwrap_or(face_n[t]);
            corner_normal.insert((t, k), n);
        }
    }
    let computed_normal =
        |ti: usize, k: usize| -> Vec3 { corner_normal.get(&(ti, k)).copied().unwrap_or(face_n[ti]) };

    // Output vertices: one per (position, normal).
    let mut vmap: HashMap<(u32, [u32; 3]), u32> = HashMap::new();
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut position_ids = Vec::new();
    let mut indices = Vec::with_capacity(tris.len());
    let (mut from_file, mut computed) = (0usize, 0usize);
    for (ti, (p, fnorm, _, _)) in tris.iter().enumerate() {
        let mut tri = [0u32; 3];
        for k in 0..3 {
            let (n, file) = match fnorm[k] {
                Some(n) => (n, true),
                None => (computed_normal(ti, k), false),
            };
            let key = (p[k], n.to_array().map(f32::to_bits));
            tri[k] = *vmap.entry(key).or_insert_with(|| {
                positions.push(wpos(p[k]));
                normals.push(n);
                position_ids.push(p[k]);
                if file {
                    from_file += 1;
                } else {
                    computed += 1;
                }
                (positions.len() - 1) as u32
            });
        }
        indices.push(tri);
    }
    stats.normals_from_file += from_file;
    stats.normals_computed += computed;

    let edge_kinds = classify_edges(&indices, &position_ids);
    let normals_source = match (from_file, computed) {
        (_, 0) => NormalsSource::FromFile,
        (0, _) => NormalsSource::Computed,
        _ => NormalsSource::Mixed,
    };
    let corner_uvs = if tris.iter().any(|t| t.3.iter().any(|uv| uv[0].is_finite())) {
        tris.iter().map(|t| t.3).collect()
    } else {
        Vec::new()
    };
    Some(Mesh {
        name,
        positions,
        normals,
        indices,
        material,
        position_ids,
        edge_kinds,
        normals_source,
        corner_uvs,
    })
}

/// Classify every triangle edge by its neighbours on welded positions.
pub fn classify_edges(indices: &[[u32; 3]], position_ids: &[u32]) -> Vec<[EdgeKind; 3]> {
    let mut edges: HashMap<(u32, u32), Vec<(usize, usize)>> = HashMap::new();
    for (t, tri) in indices.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (position_ids[tri[k] as usize], position_ids[tri[(k + 1) % 3] as usize]);
            edges.entry((a.min(b), a.max(b))).or_default().push((t, k));
        }
    }
    let mut kinds = vec![[EdgeKind::Border; 3]; indices.len()];
    for list in edges.values() {
        let kind = match list.len() {
            1 => EdgeKind::Border,
            2 => {
                let (t0, k0) = list[0];
                let (t1, k1) = list[1];
                let e0 = [indices[t0][k0], indices[t0][(k0 + 1) % 3]];
                let e1 = [indices[t1][k1], indices[t1][(k1 + 1) % 3]];
                if (e0[0] == e1[1] && e0[1] == e1[0]) || (e0[0] == e1[0] && e0[1] == e1[1]) {
                    EdgeKind::Smooth
                } else {
                    EdgeKind::Crease
                }
            }
            _ => EdgeKind::NonManifold,
        };
        for &(t, k) in list {
            kinds[t][k] = kind;
        }
    }
    kinds
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
    let position_ids = (0..positions.len() as u32).collect::<Vec<_>>();
    let edge_kinds = classify_edges(&indices, &position_ids);
    Mesh {
        name: "sphere".into(),
        positions,
        normals,
        indices,
        material: None,
        position_ids,
        edge_kinds,
        normals_source: NormalsSource::Computed,
        corner_uvs: Vec::new(),
    }
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
