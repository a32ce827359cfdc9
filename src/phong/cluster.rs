//! Clusters of up to [`CLUSTER_SIZE`] neighbouring patches, the unit Embree sees as one user
//! primitive: one callback tests the ray against every member's prism at once (8 lanes, laid
//! out for SIMD), and only the members the ray may meet are solved, nearest first.
//!
//! Embree gives user geometry one primitive per BVH leaf, so with one patch per primitive every
//! candidate patch costs a callback and the tree is as deep as the patch count makes it. A
//! cluster puts 8 patches in a leaf, as Embree's own triangle leaves hold 4 or 8 triangles.

use super::patch::Patch;
use super::real::{Real, V3};

/// Patches per cluster: one 8-lane prism test covers them all.
pub const CLUSTER_SIZE: usize = 8;

/// The world-space prisms of a cluster's members, structure of arrays: plane `k` of member `i`
/// is `n[k][axis][i] · x <= h[k][i]`. Unused lanes have `h = -inf` (never entered).
#[derive(Clone, Debug)]
#[repr(C, align(32))]
pub struct ClusterHull {
    n: [[[f32; CLUSTER_SIZE]; 3]; 5],
    h: [[f32; CLUSTER_SIZE]; 5],
}

/// A cluster: the members' triangle indices (primIDs), their prisms, and the union of their
/// bounds (what Embree's BVH holds).
#[derive(Clone, Debug)]
pub struct Cluster {
    hull: ClusterHull,
    members: [u32; CLUSTER_SIZE],
    len: u8,
    lo: glam::Vec3,
    hi: glam::Vec3,
}

/// The smallest `f32 >= x` (for finite `x`).
fn f32_at_least(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) < x {
        f.next_up()
    } else {
        f
    }
}

impl Cluster {
    /// The cluster of `members` (at most [`CLUSTER_SIZE`] indices into `patches`, none
    /// degenerate).
    pub fn new(patches: &[Patch<f32>], members: &[u32]) -> Self {
        assert!(members.len() <= CLUSTER_SIZE, "{} members", members.len());
        let mut hull =
            ClusterHull { n: [[[0.0; CLUSTER_SIZE]; 3]; 5], h: [[f32::NEG_INFINITY; CLUSTER_SIZE]; 5] };
        let (mut lo, mut hi) = (glam::Vec3::splat(f32::INFINITY), glam::Vec3::splat(f32::NEG_INFINITY));
        for (i, &m) in members.iter().enumerate() {
            let p = &patches[m as usize];
            // Compute the world-space offsets of the local prism: x_world = x_local s + c, so
            // n·x_world <= s h + n·c, in f64 with the f32 normal the test uses, rounded up.
            let (normals, offsets) = p.prism();
            let (c, s) = (p.center().to_f64(), p.scale().to_f64());
            for k in 0..5 {
                let n = normals[k];
                (hull.n[k][0][i], hull.n[k][1][i], hull.n[k][2][i]) = (n.x, n.y, n.z);
                let world = s * offsets[k].to_f64() + n.to_f64().dot(c);
                hull.h[k][i] = f32_at_least(world + world.abs() * f64::EPSILON * 4.0);
            }
            let (plo, phi) = p.bounds();
            lo = lo.min(glam::Vec3::from(plo));
            hi = hi.max(glam::Vec3::from(phi));
        }
        let mut ids = [u32::MAX; CLUSTER_SIZE];
        ids[..members.len()].copy_from_slice(members);
        Cluster { hull, members: ids, len: members.len() as u8, lo, hi }
    }

    /// The members' triangle indices.
    pub fn members(&self) -> &[u32] {
        &self.members[..self.len as usize]
    }

    /// The union of the members' world-space bounds.
    pub fn bounds(&self) -> (glam::Vec3, glam::Vec3) {
        (self.lo, self.hi)
    }

    /// The members' prisms, for [`hull_entries`].
    pub fn hull(&self) -> &ClusterHull {
        &self.hull
    }
}

/// The ray parameter at which `org + t dir` enters each lane's prism within `(tnear, tfar)`,
/// or `+inf` where it misses it (and in unused lanes). Conservative: a ray that meets a
/// member's surface in the interval enters its prism no later than the hit.
///
/// Written as plain loops over the 8 lanes so that the compiler vectorises them (SSE2 on the
/// baseline target; the mesh's caller also compiles it for AVX, chosen at run time): every
/// version gives the same answers (no fused operations: Rust never contracts `a * b + c`).
#[inline(always)]
pub fn hull_entries(
    h: &ClusterHull,
    org: [f32; 3],
    dir: [f32; 3],
    tnear: f32,
    tfar: f32,
) -> [f32; CLUSTER_SIZE] {
    let mut t0 = [tnear; CLUSTER_SIZE];
    let mut t1 = [tfar; CLUSTER_SIZE];
    // The rounding of `h - n·o` (and of `n·d`, whose error the same slack absorbs): a few ulps
    // of the magnitudes involved, |n| = 1.
    let omax = org[0].abs().max(org[1].abs()).max(org[2].abs());
    let g = <f32 as Real>::gamma(8);
    for k in 0..5 {
        let [nx, ny, nz] = &h.n[k];
        let hk = &h.h[k];
        for i in 0..CLUSTER_SIZE {
            let dist = hk[i] - (nx[i] * org[0] + ny[i] * org[1] + nz[i] * org[2]); // >= 0 inside
            let dn = nx[i] * dir[0] + ny[i] * dir[1] + nz[i] * dir[2];
            let slack = g * (hk[i].abs() + omax + omax);
            let t = (dist + slack) / dn;
            // Leave through a plane the ray heads out of (n·d > 0, or +0), enter through the
            // others; a NaN (0/0: the ray in the plane) is no constraint (`min`/`max` ignore it).
            let leaving = (dn.to_bits() as i32) >= 0;
            let (exit, entry) = if leaving { (t, f32::NEG_INFINITY) } else { (f32::INFINITY, t) };
            t1[i] = t1[i].min(exit);
            t0[i] = t0[i].max(entry);
        }
    }
    let mut out = [f32::INFINITY; CLUSTER_SIZE];
    for i in 0..CLUSTER_SIZE {
        out[i] = if t0[i] <= t1[i] { t0[i] } else { f32::INFINITY };
    }
    out
}

/// Group the triangles `0..centroids.len()` whose `keep` is true into clusters of at most
/// `size` (1..=[`CLUSTER_SIZE`]) neighbours: split the set at the median of the centroids along
/// their widest axis, at a multiple of the cluster size, until each part fits. Deterministic
/// (ties go by index).
pub fn group_by_position(centroids: &[V3<f64>], size: usize, keep: impl Fn(usize) -> bool) -> Vec<Vec<u32>> {
    let size = size.clamp(1, CLUSTER_SIZE);
    let mut ids: Vec<u32> = (0..centroids.len() as u32).filter(|&i| keep(i as usize)).collect();
    let mut groups = Vec::with_capacity(ids.len() / size + 1);
    split(centroids, size, &mut ids, &mut groups);
    groups
}

/// One step of [`group_by_position`].
fn split(centroids: &[V3<f64>], size: usize, ids: &mut [u32], groups: &mut Vec<Vec<u32>>) {
    if ids.len() <= size {
        if !ids.is_empty() {
            groups.push(ids.to_vec());
        }
        return;
    }
    // Compute the widest axis of the centroids.
    let c = |i: u32| centroids[i as usize];
    let (mut lo, mut hi) = (c(ids[0]), c(ids[0]));
    for &i in ids.iter() {
        lo = lo.min_elem(c(i));
        hi = hi.max_elem(c(i));
    }
    let ext = hi - lo;
    let axis = if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    };
    let key = |i: u32| [c(i).x, c(i).y, c(i).z][axis];
    // Split at the median, rounded to whole clusters so that the parts fill them.
    let half = ids.len().div_ceil(2 * size) * size;
    let mid = half.min(ids.len() - 1);
    ids.select_nth_unstable_by(mid, |&a, &b| key(a).total_cmp(&key(b)).then(a.cmp(&b)));
    let (left, right) = ids.split_at_mut(mid);
    split(centroids, size, left, groups);
    split(centroids, size, right, groups);
}
