//! Mesh building from parsed OBJ faces: group by object and material, triangulate, weld,
//! drop degenerate and duplicate triangles, assign normals (the file's, else computed ones, see
//! [`super::normals`]), make one vertex per (position, normal), classify edges.

use std::collections::HashMap;

use glam::{DVec3, Vec3};

use super::normals::ComputedNormals;
use super::{classify_edges, obj, LoadOptions, LoadStats, Material, Mesh, NormalsSource};
use crate::mesh::{absolute_weld_tolerance, weld, weld_caps};

/// The welding tolerance: `opts.weld_tolerance` times the diagonal of what the faces use (an
/// unused far-away vertex must not change it); `build_mesh` caps it per vertex by the local
/// edge lengths.
pub(super) fn weld_tolerance(raw: &obj::RawObj, opts: &LoadOptions) -> f32 {
    let used = raw.faces.iter().flat_map(|f| &f.corners).map(|c| raw.positions[c.v as usize]);
    absolute_weld_tolerance(used, opts.weld_tolerance)
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
pub(super) fn build_meshes<'a>(
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

/// A triangle's unit normal (right-handed winding), computed in f64; zero for a degenerate one.
pub(super) fn unit_face_normal(corners: [Vec3; 3]) -> DVec3 {
    let [a, b, c] = corners.map(|p| p.as_dvec3());
    (b - a).cross(c - a).normalize_or_zero()
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
        // Per position, a tenth of its shortest non-zero incident edge (`weld_caps`): welding
        // moves no corner farther than that, so welding never collapses a triangle.
        let slot = |v: u32| used.binary_search(&v).unwrap_or(0) as u32;
        let triangles: Vec<[u32; 3]> = tri_corners.iter().map(|t| t.map(|c| slot(c.v))).collect();
        let caps = weld_caps(&positions, &triangles);
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
pub(super) struct Tri {
    /// Welded position ids of the corners.
    pub(super) pid: [u32; 3],
    /// The file's unit normal per corner, where it gives a usable one.
    file_normal: [Option<Vec3>; 3],
    /// The smoothing group (`None` where the file never says).
    pub(super) smoothing: Option<u32>,
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
