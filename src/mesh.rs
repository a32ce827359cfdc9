//! Mesh preparation for Phong tessellation, on plain arrays: welding by position, edge classes
//! and the straight-edge rule that keeps creases and borders watertight.
//!
//! Phong tessellation bends each edge of a triangle by the normals at its two ends. Two triangles
//! that share an edge by position but not its normals (a *crease*: split normals, as exporters
//! write hard edges) bend it two different ways and part along it; a *border* edge bends away
//! from whatever it was meant to meet. Keeping every edge that is not smooth straight closes both
//! ([`straight_edges`]). [`prepare`] does it all for a user's own arrays; the OBJ loader
//! ([`crate::scene`]) uses the same pieces.

use std::collections::HashMap;

use glam::{DVec3, Vec3};

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
    /// Smooth (one normal per end, shared with one neighbour) but kept straight: the curve its
    /// end normals would give it strays from the chord by more than [`BULGE_LIMIT`] times the
    /// height of a triangle beside it ([`bulging_edges`]), a balloon on a sliver.
    Straightened,
}

/// Weld positions using a hash grid of cell `tol`; returns a position id per input position
/// (ids index the first position of each cluster). Two positions weld when their distance is at
/// most `tol` and at most both of their `caps` (a tenth of each one's shortest incident edge, so
/// no triangle with a non-zero edge can lose a corner: see [`weld_caps`]).
pub fn weld(points: &[Vec3], caps: &[f64], tol: f32) -> Vec<u32> {
    if tol <= 0.0 {
        // Exact welding on bit patterns (+0 and -0 equal).
        let mut map: HashMap<[u32; 3], u32> = HashMap::with_capacity(points.len());
        return points
            .iter()
            .enumerate()
            .map(|(i, p)| *map.entry((*p + Vec3::ZERO).to_array().map(f32::to_bits)).or_insert(i as u32))
            .collect();
    }
    let tol = tol as f64;
    let cell = |p: Vec3| {
        let q = p.as_dvec3() / tol;
        (q.x.floor() as i64, q.y.floor() as i64, q.z.floor() as i64)
    };
    let mut grid: HashMap<(i64, i64, i64), Vec<u32>> = HashMap::with_capacity(points.len());
    let mut ids = Vec::with_capacity(points.len());
    for (i, p) in points.iter().enumerate() {
        let c = cell(*p);
        let ti = tol.min(caps[i]);
        let mut found = None;
        'search: for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let key = (c.0.saturating_add(dx), c.1.saturating_add(dy), c.2.saturating_add(dz));
                    if let Some(list) = grid.get(&key) {
                        for &j in list {
                            let d = points[j as usize].as_dvec3().distance(p.as_dvec3());
                            if d <= ti.min(caps[j as usize]) {
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

/// Per position, a tenth of its shortest non-zero incident edge over `triangles` (infinite for a
/// position no such edge touches): the caps of [`weld`], so that welding moves no corner of an
/// edge of length `L` farther than `0.1 L` and never collapses a triangle.
pub fn weld_caps(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<f64> {
    let mut caps = vec![f64::INFINITY; positions.len()];
    for t in triangles {
        for k in 0..3 {
            let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
            let len = positions[a].as_dvec3().distance(positions[b].as_dvec3());
            if len > 0.0 {
                caps[a] = caps[a].min(0.1 * len);
                caps[b] = caps[b].min(0.1 * len);
            }
        }
    }
    caps
}

/// The absolute welding tolerance: `relative` times the diagonal of the bounds of `used` (the
/// positions the triangles use: an unused far-away vertex must not change it), at most
/// `f32::MAX`; 0 for no positions.
pub(crate) fn absolute_weld_tolerance(used: impl IntoIterator<Item = Vec3>, relative: f32) -> f32 {
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for p in used {
        let p = p.as_dvec3();
        lo = lo.min(p);
        hi = hi.max(p);
    }
    let diag = if lo.x <= hi.x { (hi - lo).length() } else { 0.0 };
    (relative.max(0.0) as f64 * diag).min(f32::MAX as f64) as f32
}

/// Per triangle edge: whether Phong tessellation must keep it straight (every edge that is not
/// [`EdgeKind::Smooth`]: a crease, a border or a non-manifold edge).
pub fn straight_edges(edge_kinds: &[[EdgeKind; 3]]) -> Vec<[bool; 3]> {
    edge_kinds.iter().map(|k| k.map(|e| e != EdgeKind::Smooth)).collect()
}

/// The default limit of [`bulging_edges`]: a smooth edge whose curve at α = 1 would stand off its
/// chord by more than this many times the height of a triangle beside it (the triangle's altitude
/// onto the edge) is kept straight.
pub const BULGE_LIMIT: f32 = 2.0;

/// How far the curve of edge `(p_i, p_j)` with end normals `n_i`, `n_j` stands off its chord
/// at α = 1: half the offset of its Bézier control point `(π_i(p_j) + π_j(p_i)) / 2` from the
/// edge's midpoint (the quadratic's value at its middle). Symmetric in `i`, `j`, bit for bit.
pub fn edge_bulge(pi: Vec3, pj: Vec3, ni: Vec3, nj: Vec3) -> f64 {
    let (pi, pj, ni, nj) = (pi.as_dvec3(), pj.as_dvec3(), ni.as_dvec3(), nj.as_dvec3());
    // π_i(p_j) - p_j = -((p_j - p_i)·n_i) n_i and π_j(p_i) - p_i = ((p_j - p_i)·n_j) n_j.
    let e = pj - pi;
    let offset = (nj * e.dot(nj) - ni * e.dot(ni)) * 0.5;
    0.5 * offset.length()
}

/// Per triangle edge: whether a smooth edge balloons, so that Phong tessellation must keep it
/// straight. An edge balloons when its curve at α = 1 ([`edge_bulge`]) stands off its chord by
/// more than `limit` times the altitude onto it of either triangle beside it: a long sliver
/// whose end normals lean apart (computed normals beside a bevel, or a file's wild normals)
/// would swell many of its widths off its flat triangle. The decision is per edge (the larger
/// ratio of the two triangles), so both patches sharing the edge keep it straight and the mesh
/// stays watertight. A `limit` that is not finite and positive marks nothing.
pub fn bulging_edges(
    positions: &[Vec3],
    normals: &[Vec3],
    indices: &[[u32; 3]],
    edge_kinds: &[[EdgeKind; 3]],
    limit: f32,
) -> Vec<[bool; 3]> {
    let mut out = vec![[false; 3]; indices.len()];
    if !(limit.is_finite() && limit > 0.0) {
        return out;
    }
    // Compute, per smooth edge (its two vertex ids), the largest bulge over altitude beside it.
    let mut worst: HashMap<(u32, u32), f64> = HashMap::new();
    for (t, tri) in indices.iter().enumerate() {
        let p = tri.map(|i| positions[i as usize]);
        let area2 = (p[1] - p[0]).as_dvec3().cross((p[2] - p[0]).as_dvec3()).length();
        for k in (0..3).filter(|&k| edge_kinds[t][k] == EdgeKind::Smooth) {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            let (pa, pb) = (positions[a as usize], positions[b as usize]);
            let bulge = edge_bulge(pa, pb, normals[a as usize], normals[b as usize]);
            let altitude = area2 / pa.as_dvec3().distance(pb.as_dvec3());
            let ratio = if altitude > 0.0 { bulge / altitude } else { f64::INFINITY };
            let w = worst.entry((a.min(b), a.max(b))).or_insert(0.0);
            *w = w.max(if ratio.is_nan() { f64::INFINITY } else { ratio });
        }
    }
    // Mark every side of the edges over the limit.
    for (t, tri) in indices.iter().enumerate() {
        for k in (0..3).filter(|&k| edge_kinds[t][k] == EdgeKind::Smooth) {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            out[t][k] = worst[&(a.min(b), a.max(b))] > limit as f64;
        }
    }
    out
}

/// Mark the smooth edges that balloon ([`bulging_edges`] at `limit`) as
/// [`EdgeKind::Straightened`]; returns how many edges (each counted once).
pub fn straighten_bulging_edges(
    positions: &[Vec3],
    normals: &[Vec3],
    indices: &[[u32; 3]],
    edge_kinds: &mut [[EdgeKind; 3]],
    limit: f32,
) -> usize {
    let bulging = bulging_edges(positions, normals, indices, edge_kinds, limit);
    let mut sides = 0;
    for (kinds, b) in edge_kinds.iter_mut().zip(bulging) {
        for k in (0..3).filter(|&k| b[k]) {
            kinds[k] = EdgeKind::Straightened;
            sides += 1;
        }
    }
    sides / 2
}

/// The default angle (radians) within which two unit normals at one position count as the same
/// normal ([`NormalSnap`]): normals that differ only by rounding (a sin/cos sphere's poles and
/// seam, `-0` against `0`) must not make a crease.
pub const NORMAL_TOLERANCE: f32 = 1e-4;

/// Makes nearly equal normals at a position equal, bit for bit: per welded position, the first
/// normal seen within the tolerance angle of a later one stands for both. With a tolerance of 0
/// normals are compared bit for bit (the rule before the tolerance, `-0` and `0` distinct).
#[derive(Debug, Default)]
pub struct NormalSnap {
    /// `sin` of the tolerance angle; `None` for bit-for-bit comparison.
    sin_tol: Option<f64>,
    seen: HashMap<u32, Vec<Vec3>>,
}

impl NormalSnap {
    /// Normals within `tol` radians (clamped to [0, 0.1]) count as equal; 0 compares bit for bit.
    pub fn new(tol: f32) -> NormalSnap {
        let tol = if tol.is_finite() { tol.clamp(0.0, 0.1) } else { 0.0 };
        NormalSnap { sin_tol: (tol > 0.0).then(|| (tol as f64).sin()), seen: HashMap::new() }
    }

    /// The normal to use for unit normal `n` at welded position `pid`: an earlier one at `pid`
    /// within the tolerance, else `n` itself (with `-0` components made `+0`).
    pub fn snap(&mut self, pid: u32, n: Vec3) -> Vec3 {
        let Some(sin_tol) = self.sin_tol else { return n };
        let n = n + Vec3::ZERO; // -0 + 0 = +0
        let list = self.seen.entry(pid).or_default();
        // Compare in f64: the sine of the angle between them, on the same side.
        let close = |m: &Vec3| {
            let (a, b) = (m.as_dvec3(), n.as_dvec3());
            a.dot(b) > 0.0 && a.cross(b).length() <= sin_tol * a.length() * b.length()
        };
        if let Some(m) = list.iter().find(|m| close(m)) {
            return *m;
        }
        list.push(n);
        n
    }
}

/// Per triangle: whether it repeats an earlier triangle's three welded positions, in either
/// winding (such a copy makes every edge it shares non-manifold, and so straight).
pub fn duplicate_triangles(position_triples: impl IntoIterator<Item = [u32; 3]>) -> Vec<bool> {
    let mut seen: std::collections::HashSet<[u32; 3]> = Default::default();
    position_triples
        .into_iter()
        .map(|mut t| {
            t.sort_unstable();
            !seen.insert(t)
        })
        .collect()
}

/// The largest offset of a Phong patch from its flat triangle, relative to the triangle's width
/// (its smallest altitude, `2 · area / longest edge`), over a mesh: `(ratio, triangle)`, or
/// `None` for a mesh with no triangle of non-zero area. A balloon (a sliver's patch swollen far
/// off its triangle by wild normals) shows as a ratio of several; a smooth low-poly sphere's
/// patches stand a fraction of their width off theirs.
///
/// The patch minus its triangle is the quadratic `Σ 2 w_i w_j (c_ij − m_ij)` over the edges, with
/// `c_ij` the edge's control point and `m_ij` its midpoint; its length is taken on a grid of
/// 231 points `(u, v)` (steps of 1/20), so the figure is a close lower bound.
pub fn max_patch_deviation(
    positions: &[Vec3],
    normals: &[Vec3],
    indices: &[[u32; 3]],
    straight: &[[bool; 3]],
    alpha: f64,
) -> Option<(f64, usize)> {
    use crate::phong::V3;
    const STEPS: usize = 20;
    let mut best: Option<(f64, usize)> = None;
    for (t, tri) in indices.iter().enumerate() {
        // Compute the edges' control-point offsets from their midpoints.
        let p = tri.map(|i| V3::from(positions[i as usize].as_dvec3()));
        let n = tri.map(|i| V3::from(normals[i as usize].as_dvec3()));
        let st = straight.get(t).copied().unwrap_or([false; 3]);
        let c = crate::phong::control_points(p, n, alpha, st);
        let d = [(c[3] - (p[0] + p[1]) * 0.5), (c[4] - (p[1] + p[2]) * 0.5), (c[5] - (p[2] + p[0]) * 0.5)];
        let longest = (p[1] - p[0]).length().max((p[2] - p[1]).length()).max((p[0] - p[2]).length());
        let size = (p[1] - p[0]).cross(p[2] - p[0]).length() / longest;
        if !(size > 0.0) {
            continue;
        }
        // Compute the largest offset on the grid (w = barycentric weights of corners 0, 1, 2).
        let mut worst = 0.0f64;
        for i in 0..=STEPS {
            for j in 0..=STEPS - i {
                let w =
                    [i as f64 / STEPS as f64, j as f64 / STEPS as f64, (STEPS - i - j) as f64 / STEPS as f64];
                let off =
                    d[0] * (2.0 * w[0] * w[1]) + d[1] * (2.0 * w[1] * w[2]) + d[2] * (2.0 * w[2] * w[0]);
                worst = worst.max(off.length());
            }
        }
        let ratio = worst / size;
        if ratio.is_finite() && best.is_none_or(|(b, _)| ratio > b) {
            best = Some((ratio, t));
        }
    }
    best
}

/// The default welding tolerance of [`prepare`], relative to the diagonal of the bounds of the
/// positions the triangles use (the OBJ loader's default too).
pub const WELD_TOLERANCE: f32 = 1e-6;

/// A mesh from the caller's arrays, prepared for watertight Phong tessellation by [`prepare`].
///
/// Triangles keep their order and corner order (so a hit's primID and `(u, v)` refer to the
/// caller's triangle); only the vertex arrays are rebuilt.
#[derive(Clone, Debug, PartialEq)]
pub struct Prepared {
    /// One per (welded position, unit normal).
    pub positions: Vec<Vec3>,
    /// Unit normals, one per vertex.
    pub normals: Vec<Vec3>,
    /// The caller's triangles, re-indexed into the vertices above.
    pub indices: Vec<[u32; 3]>,
    /// Per vertex: the welded position id (vertices with equal ids share a position).
    pub position_ids: Vec<u32>,
    /// Per triangle edge `k` = (corner `k`, corner `k+1`).
    pub edge_kinds: Vec<[EdgeKind; 3]>,
}

impl Prepared {
    /// Per triangle edge: keep it straight ([`straight_edges`] of the edge kinds).
    pub fn straight_edges(&self) -> Vec<[bool; 3]> {
        straight_edges(&self.edge_kinds)
    }
}

/// Prepare the caller's arrays for watertight Phong tessellation:
///
/// 1. weld positions closer than `weld_tolerance` times the diagonal of the bounds of the used
///    positions (capped per vertex by [`weld_caps`]); welded corners take the first position of
///    their cluster, bit for bit;
/// 2. make one vertex per (welded position, unit normal): corners that share a position and a
///    normal (within [`NORMAL_TOLERANCE`] radians, see [`NormalSnap`]) share a vertex, whatever
///    the caller's indexing (a triangle soup too), and all of them get that normal bit for bit;
/// 3. classify the edges ([`classify_edges`]): an edge is smooth where both of its ends share
///    vertices with the neighbour's, a crease where they share only positions.
///
/// The inputs must be valid: one normal per position, every index in range, finite positions
/// and finite non-zero normals (`PhongMesh`'s constructors check, naming what is wrong).
pub fn prepare(positions: &[Vec3], normals: &[Vec3], indices: &[[u32; 3]], weld_tolerance: f32) -> Prepared {
    // Compute the welding tolerance from the size of what the triangles use.
    let used = indices.iter().flatten().map(|&i| positions[i as usize]);
    let tol = absolute_weld_tolerance(used, weld_tolerance);

    // Compute the welded position of every input vertex.
    let caps = weld_caps(positions, indices);
    let pid = weld(positions, &caps, tol);

    // Compute one output vertex per (welded position, unit normal), in order of first use.
    let mut vmap: HashMap<(u32, [u32; 3]), u32> = HashMap::with_capacity(positions.len());
    let mut out = Prepared {
        positions: Vec::with_capacity(positions.len()),
        normals: Vec::with_capacity(positions.len()),
        indices: Vec::with_capacity(indices.len()),
        position_ids: Vec::with_capacity(positions.len()),
        edge_kinds: Vec::new(),
    };
    let mut renumber: HashMap<u32, u32> = HashMap::new();
    let mut snap = NormalSnap::new(NORMAL_TOLERANCE);
    for tri in indices {
        let t = tri.map(|i| {
            let p = pid[i as usize];
            // In f64: a tiny f32 normal has no f64 length underflow.
            let n = normals[i as usize].as_dvec3().normalize_or_zero().as_vec3();
            let n = snap.snap(p, n);
            let key = (p, n.to_array().map(f32::to_bits));
            *vmap.entry(key).or_insert_with(|| {
                out.positions.push(positions[p as usize]);
                out.normals.push(n);
                let next = renumber.len() as u32;
                out.position_ids.push(*renumber.entry(p).or_insert(next));
                (out.positions.len() - 1) as u32
            })
        });
        out.indices.push(t);
    }
    out.edge_kinds = classify_edges(&out.indices, &out.position_ids);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two triangles of a unit square as a soup (no shared vertices) with equal normals.
    fn square_soup(n2: Vec3) -> (Vec<Vec3>, Vec<Vec3>, Vec<[u32; 3]>) {
        let p = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        let n = vec![Vec3::Z, Vec3::Z, Vec3::Z, Vec3::Z, n2, Vec3::Z];
        (p, n, vec![[0, 1, 2], [3, 4, 5]])
    }

    #[test]
    fn a_soup_with_equal_normals_welds_into_a_smooth_diagonal() {
        let (p, n, i) = square_soup(Vec3::Z * 3.0);
        let m = prepare(&p, &n, &i, WELD_TOLERANCE);
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.edge_kinds[0][2], EdgeKind::Smooth); // (2, 0) is the diagonal
        assert_eq!(m.edge_kinds[0][0], EdgeKind::Border);
        assert_eq!(m.straight_edges()[0], [true, true, false]);
    }

    #[test]
    fn split_normals_make_the_diagonal_a_crease() {
        let (p, n, i) = square_soup(Vec3::new(0.0, 0.6, 0.8));
        let m = prepare(&p, &n, &i, WELD_TOLERANCE);
        assert_eq!(m.positions.len(), 5);
        assert_eq!(m.edge_kinds[0][2], EdgeKind::Crease);
        assert_eq!(m.edge_kinds[1][0], EdgeKind::Crease);
    }

    /// A triangle `(0,0,0), (L,0,0), (0,W,0)` whose corner normals lean out by 20° in the plane.
    fn leaning(l: f32, w: f32) -> (Vec<Vec3>, Vec<Vec3>, Vec<[u32; 3]>) {
        let (s, c) = 20f32.to_radians().sin_cos();
        let p = vec![Vec3::ZERO, Vec3::new(l, 0.0, 0.0), Vec3::new(0.0, w, 0.0)];
        let n = vec![Vec3::new(-s, -s, c).normalize(), Vec3::new(s, 0.0, c), Vec3::new(0.0, s, c)];
        (p, n, vec![[0, 1, 2]])
    }

    #[test]
    fn a_flat_patch_and_straight_edges_deviate_nothing() {
        let (p, _, i) = leaning(1.0, 1.0);
        let flat = max_patch_deviation(&p, &[Vec3::Z; 3], &i, &[], 0.75).unwrap();
        assert_eq!(flat, (0.0, 0));
        let (p, n, i) = leaning(1.0, 1.0);
        let straight = max_patch_deviation(&p, &n, &i, &[[true; 3]], 0.75).unwrap();
        assert_eq!(straight, (0.0, 0));
    }

    #[test]
    fn a_sliver_with_leaning_normals_deviates_by_many_widths() {
        let (p, n, i) = leaning(1.0, 1.0);
        let wide = max_patch_deviation(&p, &n, &i, &[], 0.75).unwrap().0;
        let (p, n, i) = leaning(100.0, 1.0);
        let sliver = max_patch_deviation(&p, &n, &i, &[], 0.75).unwrap().0;
        assert!(wide > 0.01 && wide < 0.5, "{wide}");
        assert!(sliver > 5.0, "{sliver}");
    }

    #[test]
    fn near_positions_weld_onto_the_first_bit_for_bit() {
        let (mut p, n, i) = square_soup(Vec3::Z);
        p[4] += Vec3::splat(1e-7);
        let m = prepare(&p, &n, &i, WELD_TOLERANCE);
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.positions[m.indices[1][1] as usize], Vec3::new(1.0, 1.0, 0.0));
    }
}
