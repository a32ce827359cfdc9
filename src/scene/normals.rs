//! Computed vertex normals: angle-weighted face normals around each position, joined across
//! smoothing groups or within the crease angles ([`super::LoadOptions::crease_angle_deg`],
//! [`super::LoadOptions::small_face_crease_angle_deg`]).

use std::collections::HashMap;

use glam::Vec3;

use super::build::{unit_face_normal, Tri};
use super::{LoadOptions, SMALL_FACE_FRACTION};

fn angle_at(a: Vec3, b: Vec3, c: Vec3) -> f32 {
    // The interior angle at `a` of triangle (a, b, c), robust for small angles.
    // In f64, so huge coordinates cannot overflow into a NaN weight.
    let (u, v) = (b.as_dvec3() - a.as_dvec3(), c.as_dvec3() - a.as_dvec3());
    u.cross(v).length().atan2(u.dot(v)) as f32
}

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
pub(super) struct ComputedNormals {
    face_normals: Vec<Vec3>,
    /// Per (triangle, corner).
    corner: HashMap<(usize, usize), Vec3>,
}

impl ComputedNormals {
    pub(super) fn new(tris: &[Tri], positions: &[Vec3], opts: &LoadOptions) -> ComputedNormals {
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
    pub(super) fn at(&self, ti: usize, k: usize) -> Vec3 {
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
