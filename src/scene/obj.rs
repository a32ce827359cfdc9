//! A Wavefront OBJ geometry parser of our own (MTL files go to `tobj::load_mtl`).
//!
//! Why not `tobj` for the geometry: it fan-triangulates (wrong for concave polygons), ignores
//! smoothing groups (`s`), and its errors carry no line number. This parser reads `v`, `vn`, `vt`,
//! `f` (with `v`, `v/vt`, `v//vn`, `v/vt/vn`, negative indices), `o`, `g`, `usemtl`, `mtllib`, `s`
//! and `\` line continuations; other statements (`l`, `p`, curves) are counted and skipped.

use std::path::{Path, PathBuf};

use glam::Vec3;

use super::SceneError;

/// One polygon corner: position index and optional normal index (0-based, resolved).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Corner {
    pub v: u32,
    pub n: Option<u32>,
    /// Texture coordinate index (0-based, resolved).
    pub t: Option<u32>,
}

/// A polygon as written in the file.
#[derive(Clone, Debug)]
pub struct Face {
    pub corners: Vec<Corner>,
    /// Smoothing group (0 = off); `None` where the file never says.
    pub smoothing: Option<u32>,
    /// Index into `RawObj::groups`.
    pub group: usize,
    /// Material name in effect.
    pub material: Option<String>,
    pub line: usize,
}

/// The parsed file, indices resolved and checked.
#[derive(Clone, Debug, Default)]
pub struct RawObj {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    /// `vt` coordinates `(u, v)`; NaN where the line was unusable (see `bad_texcoord_line`).
    pub texcoords: Vec<[f32; 2]>,
    /// The first `vt` line with more than 3 numbers or a non-finite one, and how many there are.
    pub bad_texcoord_line: Option<usize>,
    pub bad_texcoords: usize,
    pub faces: Vec<Face>,
    /// Object/group names in order of appearance (index 0 = "" before any `o`/`g`).
    pub groups: Vec<String>,
    pub mtllibs: Vec<String>,
    pub skipped_statements: usize,
    pub usemtl_without_mtllib: bool,
}

fn malformed(path: &Path, line: usize, msg: impl Into<String>) -> SceneError {
    SceneError::Malformed { path: path.to_path_buf(), line, message: msg.into() }
}

fn parse_floats<const N: usize>(
    path: &Path,
    line: usize,
    what: &str,
    args: &[&str],
) -> Result<[f32; N], SceneError> {
    if args.len() < N {
        return Err(malformed(path, line, format!("`{what}` needs {N} numbers, found {}", args.len())));
    }
    let mut out = [0.0f32; N];
    for (i, a) in args.iter().take(N).enumerate() {
        let x: f32 =
            a.parse().map_err(|_| malformed(path, line, format!("`{what}`: {a:?} is not a number")))?;
        if !x.is_finite() {
            return Err(SceneError::NonFinite { path: path.to_path_buf(), line, value: a.to_string() });
        }
        out[i] = x;
    }
    Ok(out)
}

/// Resolve a 1-based (or negative, relative) OBJ index against `count` elements so far.
fn resolve(path: &Path, line: usize, kind: &str, tok: &str, count: usize) -> Result<u32, SceneError> {
    let i: i64 =
        tok.parse().map_err(|_| malformed(path, line, format!("{kind} index {tok:?} is not an integer")))?;
    let r = if i > 0 { i - 1 } else { count as i64 + i };
    if i == 0 || r < 0 || r >= count as i64 {
        return Err(SceneError::IndexOutOfRange {
            path: path.to_path_buf(),
            line,
            kind: kind.to_string(),
            index: i,
            count,
        });
    }
    Ok(r as u32)
}

/// Parse OBJ text; `path` is for messages only.
pub fn parse(text: &str, path: &Path) -> Result<RawObj, SceneError> {
    let mut obj = RawObj { groups: vec![String::new()], ..Default::default() };
    let mut texcoords = 0usize;
    let mut group = 0usize;
    let mut material: Option<String> = None;
    let mut smoothing: Option<u32> = None;
    let mut pending = String::new();
    let mut start_line = 0usize;
    for (i, raw) in text.lines().enumerate() {
        let lineno = i + 1;
        // Join `\` continuations.
        if pending.is_empty() {
            start_line = lineno;
        }
        let raw = raw.trim_end();
        if let Some(stripped) = raw.strip_suffix('\\') {
            pending.push_str(stripped);
            pending.push(' ');
            continue;
        }
        pending.push_str(raw);
        let full = std::mem::take(&mut pending);
        let content = full.split('#').next().unwrap_or("").trim();
        if content.is_empty() {
            continue;
        }
        let mut it = content.split_whitespace();
        let Some(kw) = it.next() else { continue };
        let args: Vec<&str> = it.collect();
        let line = start_line;
        match kw {
            "v" => {
                let [x, y, z] = parse_floats::<3>(path, line, "v", &args)?;
                obj.positions.push(Vec3::new(x, y, z));
            }
            "vn" => {
                let [x, y, z] = parse_floats::<3>(path, line, "vn", &args)?;
                obj.normals.push(Vec3::new(x, y, z));
            }
            "vt" => {
                if args.is_empty() {
                    return Err(malformed(path, line, "`vt` needs at least one number"));
                }
                // u [v [w]]: w is unused; more numbers, or a non-finite one, make it unusable.
                let nums: Vec<f32> = args.iter().map(|a| a.parse::<f32>().unwrap_or(f32::NAN)).collect();
                let uv = [nums[0], nums.get(1).copied().unwrap_or(0.0)];
                if nums.len() > 3 || !nums.iter().all(|x| x.is_finite()) {
                    obj.bad_texcoord_line.get_or_insert(line);
                    obj.bad_texcoords += 1;
                    obj.texcoords.push([f32::NAN; 2]);
                } else {
                    obj.texcoords.push(uv);
                }
                texcoords += 1;
            }
            "f" => {
                if args.len() < 3 {
                    return Err(malformed(
                        path,
                        line,
                        format!("a face needs at least 3 corners, found {}", args.len()),
                    ));
                }
                let mut corners = Vec::with_capacity(args.len());
                for a in &args {
                    let mut parts = a.split('/');
                    let v = parts.next().unwrap_or("");
                    let t = parts.next();
                    let n = parts.next();
                    if parts.next().is_some() {
                        return Err(malformed(
                            path,
                            line,
                            format!("face corner {a:?} has more than 3 parts"),
                        ));
                    }
                    let v = resolve(path, line, "vertex", v, obj.positions.len())?;
                    let t = match t.filter(|t| !t.is_empty()) {
                        Some(t) => Some(resolve(path, line, "texture coordinate", t, texcoords)?),
                        None => None,
                    };
                    let n = match n.filter(|n| !n.is_empty()) {
                        Some(n) => Some(resolve(path, line, "normal", n, obj.normals.len())?),
                        None => None,
                    };
                    corners.push(Corner { v, n, t });
                }
                obj.faces.push(Face { corners, smoothing, group, material: material.clone(), line });
            }
            "o" | "g" => {
                let name = args.join(" ");
                group = match obj.groups.iter().position(|g| *g == name) {
                    Some(k) => k,
                    None => {
                        obj.groups.push(name);
                        obj.groups.len() - 1
                    }
                };
            }
            "usemtl" => {
                material = Some(args.join(" "));
                if obj.mtllibs.is_empty() {
                    obj.usemtl_without_mtllib = true;
                }
            }
            "mtllib" => obj.mtllibs.extend(args.iter().map(|s| s.to_string())),
            "s" => {
                let a = args.first().copied().unwrap_or("off");
                smoothing = Some(if a == "off" { 0 } else { a.parse().unwrap_or(1) });
            }
            _ => obj.skipped_statements += 1,
        }
    }
    Ok(obj)
}

/// Resolve a path written in an OBJ/MTL file (which may use `\` separators) against `dir`.
pub fn resolve_file(dir: &Path, written: &str) -> PathBuf {
    let cleaned = written.trim().replace('\\', "/");
    let cleaned = cleaned.strip_prefix("./").unwrap_or(&cleaned);
    dir.join(cleaned)
}

/// Triangulate a simple polygon (convex or concave) by ear clipping in its best-fit plane
/// (Newell's normal). Returns corner-index triples; falls back to a fan when no ear is found
/// (self-intersecting input), so every polygon yields `n - 2` triangles.
pub fn triangulate(points: &[Vec3]) -> Vec<[usize; 3]> {
    let n = points.len();
    if n < 3 {
        return Vec::new();
    }
    if n == 3 {
        return vec![[0, 1, 2]];
    }
    // Newell normal and a 2D projection dropping its largest axis.
    let mut nrm = Vec3::ZERO;
    for i in 0..n {
        let (a, b) = (points[i], points[(i + 1) % n]);
        nrm += Vec3::new((a.y - b.y) * (a.z + b.z), (a.z - b.z) * (a.x + b.x), (a.x - b.x) * (a.y + b.y));
    }
    let ax = nrm.abs();
    let (i0, i1) = if ax.x >= ax.y && ax.x >= ax.z {
        (1, 2)
    } else if ax.y >= ax.z {
        (2, 0)
    } else {
        (0, 1)
    };
    let sign = if nrm[3 - i0 - i1] >= 0.0 { 1.0 } else { -1.0 };
    let p2: Vec<(f64, f64)> = points.iter().map(|p| (p[i0] as f64, p[i1] as f64)).collect();
    let cross = |a: usize, b: usize, c: usize| {
        let (ax, ay) = p2[a];
        let (bx, by) = p2[b];
        let (cx, cy) = p2[c];
        ((bx - ax) * (cy - ay) - (by - ay) * (cx - ax)) * sign
    };
    let mut idx: Vec<usize> = (0..n).collect();
    let mut tris = Vec::with_capacity(n - 2);
    let mut guard = 0;
    while idx.len() > 3 && guard < 4 * n * n {
        guard += 1;
        let m = idx.len();
        let mut clipped = false;
        for k in 0..m {
            let (a, b, c) = (idx[(k + m - 1) % m], idx[k], idx[(k + 1) % m]);
            if cross(a, b, c) <= 0.0 {
                continue; // reflex or degenerate corner
            }
            // No other remaining vertex inside (or on) the ear.
            let inside = idx.iter().any(|&q| {
                if q == a || q == b || q == c || p2[q] == p2[a] || p2[q] == p2[b] || p2[q] == p2[c] {
                    return false;
                }
                cross(a, b, q) >= 0.0 && cross(b, c, q) >= 0.0 && cross(c, a, q) >= 0.0
            });
            if inside {
                continue;
            }
            tris.push([a, b, c]);
            idx.remove(k);
            clipped = true;
            break;
        }
        if !clipped {
            break;
        }
    }
    if idx.len() == 3 {
        tris.push([idx[0], idx[1], idx[2]]);
    } else {
        // No ear: a self-intersecting or degenerate polygon. Fan the rest.
        for k in 1..idx.len() - 1 {
            tris.push([idx[0], idx[k], idx[k + 1]]);
        }
    }
    tris
}
