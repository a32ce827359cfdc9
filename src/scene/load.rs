//! The OBJ loader: read the file, parse it ([`super::obj`]), read its materials
//! ([`super::mtl`]), build the meshes ([`super::build`]) and say what was skipped or replaced.

use std::collections::HashMap;
use std::path::Path;

use super::build::{build_meshes, unit_face_normal, weld_tolerance};
use super::{
    cut_token, mtl, obj, read_regular_file, EdgeKind, FoldedWarnings, LoadOptions, LoadStats, Material, Mesh,
    Model, NormalsSource, ReadFailure, SceneError, MAX_MTL_BYTES, MAX_OBJ_BYTES,
};

/// Load an OBJ file and its MTL files.
pub fn load_obj(path: &Path, opts: &LoadOptions) -> Result<Model, SceneError> {
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
pub fn load_obj_text(text: &str, path: &Path, opts: &LoadOptions) -> Result<Model, SceneError> {
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
    let mut scene = Model { path: path.to_path_buf(), meshes, materials, warnings, stats };
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
