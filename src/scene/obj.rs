//! A Wavefront OBJ geometry parser of our own (MTL files go to [`super::mtl`]).
//!
//! Why not `tobj` for the geometry: it fan-triangulates (wrong for concave polygons), ignores
//! smoothing groups (`s`), and its errors carry no line number. This parser reads `v`, `vn`, `vt`,
//! `f` (with `v`, `v/vt`, `v//vn`, `v/vt/vn`, negative indices), `o`, `g`, `usemtl`, `mtllib`, `s`
//! and `\` line continuations; other statements (`l`, `p`, curves) are counted and skipped.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{DVec3, Vec3};

use super::{cut_token, SceneError};

/// One polygon corner: position index and optional normal index (0-based, resolved).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Corner {
    /// Position index into [`RawObj::positions`].
    pub v: u32,
    /// Normal index into [`RawObj::normals`], if the corner names one (`v//vn`, `v/vt/vn`).
    pub n: Option<u32>,
    /// Texture coordinate index (0-based, resolved).
    pub t: Option<u32>,
}

/// A polygon as written in the file.
#[derive(Clone, Debug)]
pub struct Face {
    /// The corners in file order (at least 3; shorter `f` lines are counted and skipped).
    pub corners: Vec<Corner>,
    /// Smoothing group (0 = off); `None` where the file never says.
    pub smoothing: Option<u32>,
    /// Index into `RawObj::groups`.
    pub group: usize,
    /// Material name in effect.
    pub material: Option<String>,
    /// The 1-based line of the `f` statement, for messages.
    pub line: usize,
}

/// The parsed file, indices resolved and checked.
#[derive(Clone, Debug, Default)]
pub struct RawObj {
    /// `v` positions, in file order (finite).
    pub positions: Vec<Vec3>,
    /// `vn` normals as written (finite, not normalised, possibly zero).
    pub normals: Vec<Vec3>,
    /// `vt` coordinates `(u, v)`; NaN where the line was unusable (see `bad_texcoord_line`).
    pub texcoords: Vec<[f32; 2]>,
    /// The first `vt` line with more than 3 numbers or a non-finite one.
    pub bad_texcoord_line: Option<usize>,
    /// How many `vt` lines are unusable that way.
    pub bad_texcoords: usize,
    /// Every `f` with at least 3 corners, in file order.
    pub faces: Vec<Face>,
    /// Object/group names in order of appearance (index 0 = "" before any `o`/`g`).
    pub groups: Vec<String>,
    /// `mtllib` file names as written, in order (resolve with [`resolve_file`]).
    pub mtllibs: Vec<String>,
    /// Statements skipped as unsupported (curves, surfaces, ...).
    pub skipped_statements: usize,
    /// `f` lines with fewer than 3 corners, skipped (as tinyobjloader and Blender do).
    pub short_faces: usize,
    /// `l` (line) elements, skipped: they have no surface.
    pub line_elements: usize,
    /// `p` (point) elements, skipped likewise.
    pub point_elements: usize,
    /// The first skipped element's line, for the warning.
    pub first_skipped_element_line: Option<usize>,
    /// Whether a `usemtl` came before any `mtllib` (a warning when no `mtllib` follows).
    pub usemtl_without_mtllib: bool,
    /// `vn` lines with a coordinate that is not a finite number (NaN, infinite, or past the f32
    /// range): kept as a NaN normal, which the loader replaces by a computed one.
    pub non_finite_normals: usize,
    /// The first such line, for the warning.
    pub first_non_finite_normal_line: Option<usize>,
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
    let out = parse_numbers::<N>(path, line, what, args)?;
    if let Some(i) = out.iter().position(|x| !x.is_finite()) {
        return Err(SceneError::NonFinite { path: path.to_path_buf(), line, value: cut_token(args[i]) });
    }
    Ok(out)
}

/// The first `N` numbers of a statement, which may be infinite or NaN (`nan`, `inf`, `1e39`).
fn parse_numbers<const N: usize>(
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
        let x: f32 = a
            .parse()
            .map_err(|_| malformed(path, line, format!("`{what}`: {} is not a number", cut_token(a))))?;
        out[i] = x;
    }
    Ok(out)
}

/// Resolve a 1-based (or negative, relative) OBJ index against `count` elements so far.
fn resolve(path: &Path, line: usize, kind: &str, tok: &str, count: usize) -> Result<u32, SceneError> {
    let i: i64 = tok
        .parse()
        .map_err(|_| malformed(path, line, format!("{kind} index {} is not an integer", cut_token(tok))))?;
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

/// Parse OBJ text; `path` is for messages only. A leading UTF-8 byte-order mark is ignored.
pub fn parse(text: &str, path: &Path) -> Result<RawObj, SceneError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut parser = Parser {
        path,
        obj: RawObj { groups: vec![String::new()], ..Default::default() },
        group_ids: HashMap::from([(String::new(), 0)]),
        texcoords: 0,
        group: 0,
        material: None,
        smoothing: None,
    };
    for_each_statement(text, |line, kw, args| parser.statement(line, kw, args))?;
    Ok(parser.obj)
}

/// Call `f(line, keyword, arguments)` for each statement of `text`: `\` continuations joined
/// (`line` is where the statement starts), comments and blank lines dropped.
fn for_each_statement(
    text: &str,
    mut f: impl FnMut(usize, &str, &[&str]) -> Result<(), SceneError>,
) -> Result<(), SceneError> {
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
        f(start_line, kw, &args)?;
    }
    Ok(())
}

/// The parse so far, and the state statements set for the faces that follow.
struct Parser<'p> {
    path: &'p Path,
    obj: RawObj,
    group_ids: HashMap<String, usize>,
    /// `vt` lines so far (usable or not: face indices count them all).
    texcoords: usize,
    group: usize,
    material: Option<String>,
    smoothing: Option<u32>,
}

impl Parser<'_> {
    /// Apply one statement.
    fn statement(&mut self, line: usize, kw: &str, args: &[&str]) -> Result<(), SceneError> {
        let path = self.path;
        match kw {
            "v" => {
                let [x, y, z] = parse_floats::<3>(path, line, "v", args)?;
                self.obj.positions.push(Vec3::new(x, y, z));
            }
            "vn" => {
                // A normal that is not finite is kept as NaN (replaced by a computed one, with a
                // warning); a position that is not finite is an error.
                let n = Vec3::from(parse_numbers::<3>(path, line, "vn", args)?);
                if !n.is_finite() {
                    self.obj.non_finite_normals += 1;
                    self.obj.first_non_finite_normal_line.get_or_insert(line);
                }
                self.obj.normals.push(if n.is_finite() { n } else { Vec3::NAN });
            }
            "vt" => self.texcoord(line, args)?,
            "f" | "l" | "p" if args.len() < 3 || kw != "f" => {
                // No surface: skipped, counted for one warning.
                match kw {
                    "f" => self.obj.short_faces += 1,
                    "l" => self.obj.line_elements += 1,
                    _ => self.obj.point_elements += 1,
                }
                self.obj.first_skipped_element_line.get_or_insert(line);
            }
            "f" => self.face(line, args)?,
            "o" | "g" => {
                let name = args.join(" ");
                let groups = &mut self.obj.groups;
                self.group = *self.group_ids.entry(name).or_insert_with_key(|name| {
                    groups.push(name.clone());
                    groups.len() - 1
                });
            }
            "usemtl" => {
                self.material = Some(args.join(" "));
                if self.obj.mtllibs.is_empty() {
                    self.obj.usemtl_without_mtllib = true;
                }
            }
            "mtllib" => self.obj.mtllibs.extend(args.iter().map(|s| s.to_string())),
            "s" => {
                let a = args.first().copied().unwrap_or("off");
                self.smoothing = Some(if a == "off" { 0 } else { a.parse().unwrap_or(1) });
            }
            _ => self.obj.skipped_statements += 1,
        }
        Ok(())
    }

    /// `vt u [v [w]]`: w is unused; more numbers, or a non-finite one, make it unusable (NaN,
    /// counted for one warning).
    fn texcoord(&mut self, line: usize, args: &[&str]) -> Result<(), SceneError> {
        if args.is_empty() {
            return Err(malformed(self.path, line, "`vt` needs at least one number"));
        }
        let nums: Vec<f32> = args.iter().map(|a| a.parse::<f32>().unwrap_or(f32::NAN)).collect();
        let uv = [nums[0], nums.get(1).copied().unwrap_or(0.0)];
        if nums.len() > 3 || !nums.iter().all(|x| x.is_finite()) {
            self.obj.bad_texcoord_line.get_or_insert(line);
            self.obj.bad_texcoords += 1;
            self.obj.texcoords.push([f32::NAN; 2]);
        } else {
            self.obj.texcoords.push(uv);
        }
        self.texcoords += 1;
        Ok(())
    }

    /// `f v[/vt[/vn]] ...` with at least 3 corners, each index resolved against what precedes.
    fn face(&mut self, line: usize, args: &[&str]) -> Result<(), SceneError> {
        let path = self.path;
        let mut corners = Vec::with_capacity(args.len());
        for a in args {
            let mut parts = a.split('/');
            let v = parts.next().unwrap_or("");
            let t = parts.next();
            let n = parts.next();
            if parts.next().is_some() {
                return Err(malformed(
                    path,
                    line,
                    format!("face corner {} has more than 3 parts", cut_token(a)),
                ));
            }
            let v = resolve(path, line, "vertex", v, self.obj.positions.len())?;
            let t = match t.filter(|t| !t.is_empty()) {
                Some(t) => Some(resolve(path, line, "texture coordinate", t, self.texcoords)?),
                None => None,
            };
            let n = match n.filter(|n| !n.is_empty()) {
                Some(n) => Some(resolve(path, line, "normal", n, self.obj.normals.len())?),
                None => None,
            };
            corners.push(Corner { v, n, t });
        }
        let (smoothing, group, material) = (self.smoothing, self.group, self.material.clone());
        self.obj.faces.push(Face { corners, smoothing, group, material, line });
        Ok(())
    }
}

/// Resolve a path written in an OBJ/MTL file (which may use `\` separators) against `dir`.
pub fn resolve_file(dir: &Path, written: &str) -> PathBuf {
    let cleaned = written.trim().replace('\\', "/");
    let cleaned = cleaned.strip_prefix("./").unwrap_or(&cleaned);
    dir.join(cleaned)
}

/// How many "corner inside the ear" tests (and grid cells visited) [`triangulate`] may make per corner of the polygon
/// before it fans the rest: real polygons need a few; 64 leaves a wide margin.
pub const EAR_TEST_BUDGET_PER_CORNER: u64 = 64;

/// Triangulate a simple polygon (convex or concave) by ear clipping in its best-fit plane
/// (Newell's normal). Returns corner-index triples; falls back to a fan when no ear is found
/// (self-intersecting input), so every polygon yields `n - 2` triangles.
///
/// Linear time at worst: after [`EAR_TEST_BUDGET_PER_CORNER`] tests per corner the rest is
/// fanned. Near-linear for real polygons well within that: the corners form a linked ring that is walked once around
/// (not rescanned from the start after each ear), and the "no corner inside the ear" test only
/// looks at reflex corners (the only ones that can be inside) in a uniform grid's cells under the
/// ear's bounding box; walking on past each ear keeps corner valences small.
pub fn triangulate(points: &[Vec3]) -> Vec<[usize; 3]> {
    let n = points.len();
    if n < 3 {
        return Vec::new();
    }
    if n == 3 {
        return vec![[0, 1, 2]];
    }
    // Compute the polygon in its plane.
    let plane = Plane2::of(points);
    let (p2, cross) = (&plane.p, |a: usize, b: usize, c: usize| plane.cross(a, b, c));

    // Compute the ring and the reflex (or flat) corners.
    let mut next: Vec<usize> = (0..n).map(|i| (i + 1) % n).collect();
    let mut prev: Vec<usize> = (0..n).map(|i| (i + n - 1) % n).collect();
    let mut reflex: Vec<bool> = (0..n).map(|i| cross(prev[i], i, next[i]) <= 0.0).collect();
    let grid = ReflexGrid::new(p2, &reflex);
    let mut grid = grid;

    let mut tris = Vec::with_capacity(n - 2);
    let (mut remaining, mut cur, mut misses) = (n, 0usize, 0usize);
    // The corner tests allowed in all: a polygon that needs more (many corners piled on few
    // points, where every ear's box holds most corners) is fanned from where the budget ran out,
    // so the time stays linear in `n` whatever the input.
    let mut budget = EAR_TEST_BUDGET_PER_CORNER * n as u64;
    while remaining > 3 && budget > 0 {
        let (a, b, c) = (prev[cur], cur, next[cur]);
        let is_ear = !reflex[b] && {
            let (clear, cost) = plane.ear_is_clear([a, b, c], &grid, &reflex);
            budget = budget.saturating_sub(cost);
            clear
        };
        if !is_ear {
            cur = next[cur];
            misses += 1;
            if misses > remaining {
                break; // a whole turn without an ear
            }
            continue;
        }
        tris.push([a, b, c]);
        next[a] = c;
        prev[c] = a;
        remaining -= 1;
        misses = 0;
        // Clipping changes the corners at a and c only; a corner that turns reflex (possible in
        // a self-intersecting polygon) goes back into the grid.
        for q in [a, c] {
            let r = cross(prev[q], q, next[q]) <= 0.0;
            if r && !reflex[q] {
                grid.insert(q, p2[q]);
            }
            reflex[q] = r;
        }
        // Go on past the ear (as earcut does): clipping around the ring, not back at `a`, gives
        // strips rather than a fan of every triangle around one corner.
        cur = next[c];
    }
    // Three corners left: the last triangle; else (no ear: a self-intersecting or degenerate
    // polygon, or the budget spent) fan the rest.
    let mut k = next[cur];
    for _ in 0..remaining - 2 {
        tris.push([cur, k, next[k]]);
        k = next[k];
    }
    tris
}

/// A polygon projected to 2D by dropping the largest axis of its Newell normal, with the sign
/// that makes its turn counter-clockwise.
struct Plane2 {
    p: Vec<(f64, f64)>,
    sign: f64,
}

impl Plane2 {
    fn of(points: &[Vec3]) -> Plane2 {
        let n = points.len();
        let mut nrm = DVec3::ZERO;
        for i in 0..n {
            let (a, b) = (points[i].as_dvec3(), points[(i + 1) % n].as_dvec3());
            nrm +=
                DVec3::new((a.y - b.y) * (a.z + b.z), (a.z - b.z) * (a.x + b.x), (a.x - b.x) * (a.y + b.y));
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
        Plane2 { p: points.iter().map(|p| (p[i0] as f64, p[i1] as f64)).collect(), sign }
    }

    /// Twice the signed area of corners a, b, c (positive: a left turn).
    fn cross(&self, a: usize, b: usize, c: usize) -> f64 {
        let ((ax, ay), (bx, by), (cx, cy)) = (self.p[a], self.p[b], self.p[c]);
        ((bx - ax) * (cy - ay) - (by - ay) * (cx - ax)) * self.sign
    }

    /// Whether no remaining reflex corner lies inside (or on) the ear `[a, b, c]`, copies of
    /// its corners aside; and the grid cells and corners looked at.
    fn ear_is_clear(&self, [a, b, c]: [usize; 3], grid: &ReflexGrid, reflex: &[bool]) -> (bool, u64) {
        let p2 = &self.p;
        let (lo, hi) = bbox3(p2[a], p2[b], p2[c]);
        let (hit, cost) = grid.any_in(lo, hi, |q| {
            if !reflex[q] || [a, b, c].contains(&q) || [p2[a], p2[b], p2[c]].contains(&p2[q]) {
                return false;
            }
            self.cross(a, b, q) >= 0.0 && self.cross(b, c, q) >= 0.0 && self.cross(c, a, q) >= 0.0
        });
        (!hit, cost)
    }
}

fn bbox3(a: (f64, f64), b: (f64, f64), c: (f64, f64)) -> ((f64, f64), (f64, f64)) {
    ((a.0.min(b.0).min(c.0), a.1.min(b.1).min(c.1)), (a.0.max(b.0).max(c.0), a.1.max(b.1).max(c.1)))
}

/// Reflex corners in a uniform grid of about one cell per corner over the polygon's bounds.
/// Entries are never removed: a corner that turns convex is skipped by the caller's test.
struct ReflexGrid {
    lo: (f64, f64),
    inv: (f64, f64),
    dims: (usize, usize),
    cells: Vec<Vec<u32>>,
}

impl ReflexGrid {
    fn new(p2: &[(f64, f64)], reflex: &[bool]) -> ReflexGrid {
        let mut lo = (f64::INFINITY, f64::INFINITY);
        let mut hi = (f64::NEG_INFINITY, f64::NEG_INFINITY);
        for p in p2 {
            lo = (lo.0.min(p.0), lo.1.min(p.1));
            hi = (hi.0.max(p.0), hi.1.max(p.1));
        }
        // About one cell per corner, near-square cells (at most 2^20 cells).
        let ext = ((hi.0 - lo.0).max(f64::MIN_POSITIVE), (hi.1 - lo.1).max(f64::MIN_POSITIVE));
        let cells = (p2.len() as f64).min((1 << 20) as f64);
        let aspect = (ext.0 / ext.1).clamp(1.0 / cells, cells);
        let nx = ((cells * aspect).sqrt().ceil() as usize).clamp(1, 1 << 20);
        let ny = ((cells / nx as f64).ceil() as usize).clamp(1, 1 << 20);
        let inv = (nx as f64 / ext.0, ny as f64 / ext.1);
        let mut g = ReflexGrid { lo, inv, dims: (nx, ny), cells: vec![Vec::new(); nx * ny] };
        for (i, p) in p2.iter().enumerate() {
            if reflex[i] {
                g.insert(i, *p);
            }
        }
        g
    }

    fn cell(&self, p: (f64, f64)) -> (usize, usize) {
        let f = |x: f64, lo: f64, inv: f64, d: usize| (((x - lo) * inv) as usize).min(d - 1);
        (f(p.0, self.lo.0, self.inv.0, self.dims.0), f(p.1, self.lo.1, self.inv.1, self.dims.1))
    }

    fn insert(&mut self, i: usize, p: (f64, f64)) {
        let (x, y) = self.cell(p);
        self.cells[y * self.dims.0 + x].push(i as u32);
    }

    /// Whether `hit` holds for an entry in a cell under the box `[lo, hi]`, and the work that
    /// took (cells visited plus entries tested).
    fn any_in(&self, lo: (f64, f64), hi: (f64, f64), mut hit: impl FnMut(usize) -> bool) -> (bool, u64) {
        let (x0, y0) = self.cell(lo);
        let (x1, y1) = self.cell(hi);
        let mut cost = 0u64;
        let found = (y0..=y1).any(|y| {
            (x0..=x1).any(|x| {
                cost += 1;
                self.cells[y * self.dims.0 + x].iter().any(|&q| {
                    cost += 1;
                    hit(q as usize)
                })
            })
        });
        (found, cost)
    }
}
