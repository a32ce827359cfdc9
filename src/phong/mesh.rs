//! Phong-tessellated meshes: one patch per triangle (or, opted into, clusters of up to 8
//! neighbouring patches: [`crate::phong::cluster`]), built from the caller's arrays, with the
//! queries the ray callbacks and shading use. Pure Rust: attaching one to Embree is
//! [`crate::embree::phong_geometry`].

use glam::{DVec3, Vec3};
use multiversion::multiversion;

use crate::embree::user_geometry::{LaneOrigins, OriginPrim, PrimHit};
use crate::phong::cluster::{group_by_position, hull_entries, Cluster, ClusterHull, CLUSTER_SIZE};
use crate::phong::convexity::{audit, convexity, leaves_patch_by, leaves_patch_lanes, Convexity};
use crate::phong::intersect::{certified_lanes_past, hull_of_lanes, LaneDecision, LaneRays, LANES};
use crate::phong::{
    intersect_in_hull_traced, intersect_traced, Method, Patch, PatchHit, ShadingNormal, TestOutcome, V3,
};

/// Why a Phong mesh was refused. Each displays as one line naming the vertex, triangle or value.
#[derive(Debug, Clone, thiserror::Error)]
pub enum PhongMeshError {
    /// The normal array's length differs from the position array's (normals, positions).
    #[error("{0} normals for {1} positions (need one per vertex)")]
    NormalCount(usize, usize),
    /// A triangle refers to a vertex past the end of the arrays.
    #[error("triangle {tri} has vertex index {index}, but there are {count} vertices")]
    Index {
        /// The triangle.
        tri: usize,
        /// Its out-of-range vertex index.
        index: u32,
        /// The number of vertices.
        count: usize,
    },
    /// The shape factor is outside [0, 1] (or NaN).
    #[error("alpha {0} is not in [0, 1]")]
    Alpha(f32),
    /// A vertex's position or normal has a NaN or infinite coordinate.
    #[error("vertex {0} has a non-finite position or normal")]
    NonFinite(usize),
    /// A vertex normal is the zero vector.
    #[error("vertex {0} has a zero normal (its triangles could never be hit)")]
    ZeroNormal(usize),
    /// The straight-edge flags are not one triple per triangle (flags, triangles).
    #[error("{0} per-triangle straight-edge flags for {1} triangles")]
    EdgeFlagCount(usize, usize),
    /// The weld tolerance is negative, NaN or infinite.
    #[error("weld tolerance {0} is not a finite number >= 0")]
    WeldTolerance(f32),
    /// More triangles than a u32 primID can number.
    #[error("{0} triangles: more than a u32 primID can count")]
    TooManyTriangles(usize),
    /// The patches per Embree primitive are outside 1..=8.
    #[error("cluster size {0} is not in 1..=8")]
    ClusterSize(usize),
}

/// A Phong mesh: patches precomputed per triangle, owned so it outlives the geometry.
///
/// The fields are private so that the patches and their precomputed bounds cannot drift
/// apart: build a new mesh to change the geometry. Share it with a scene as an
/// `Arc<PhongMesh>` ([`crate::embree::Scene::attach_phong`]) to keep it for shading queries without a copy.
#[derive(Clone, Debug)]
pub struct PhongMesh {
    patches: Vec<Patch<f32>>,
    /// Each patch's [`Convexity`], for leaving out the patch an occlusion ray starts on.
    convexity: Vec<Convexity>,
    /// The clusters of non-degenerate patches that are Embree's user primitives (empty: each
    /// patch is one).
    clusters: Vec<Cluster>,
    /// Patches that are never hit (zero area or zero normal), counted for reporting.
    degenerate: usize,
    /// Triangle edges kept straight (each shared edge counted from both sides).
    straight: usize,
    method: Method,
}

/// How a [`PhongMeshBuilder`] treats the edges between triangles.
#[derive(Clone, Copy, Debug)]
enum EdgeRule<'a> {
    /// Weld by position, keep crease and border edges straight (the default).
    Watertight { weld_tolerance: f32 },
    /// Plain Phong tessellation of the arrays as given: every edge bent by its own normals.
    Plain,
    /// The arrays as given, with the caller's straight-edge flags.
    Given(&'a [[bool; 3]]),
}

/// Options for a [`PhongMesh`], resolved by [`PhongMeshBuilder::build`]. Made by
/// [`PhongMesh::builder`].
///
/// ```
/// use phongrt::embree::PhongMesh;
/// use phongrt::glam::Vec3;
/// let p = [Vec3::ZERO, Vec3::X, Vec3::Y];
/// let n = [Vec3::Z, Vec3::new(0.3, 0.0, 1.0), Vec3::new(0.0, 0.3, 1.0)];
/// // Plain Phong tessellation: the border edges bend too.
/// let mesh = PhongMesh::builder(&p, &n, &[[0, 1, 2]]).alpha(0.75).plain().build().unwrap();
/// assert_eq!(mesh.straight_edge_count(), 0);
/// ```
#[derive(Clone, Debug)]
pub struct PhongMeshBuilder<'a> {
    positions: &'a [Vec3],
    normals: &'a [Vec3],
    indices: &'a [[u32; 3]],
    alpha: f32,
    edges: EdgeRule<'a>,
    method: Method,
    cluster_size: usize,
}

impl<'a> PhongMeshBuilder<'a> {
    /// Patches per Embree primitive, 1 (the default) to 8. Above 1, neighbouring patches are
    /// grouped and one callback tests a ray against all of a group's prisms at once (8 lanes);
    /// the answers are the same. `phongrt bench` measures both (`direct-f32`,
    /// `direct-f32-k8`): on its scenes one patch per primitive is faster, as Embree's own
    /// 8-wide BVH nodes already cull the patches' bounds before any callback.
    pub fn cluster_size(mut self, k: usize) -> Self {
        self.cluster_size = k;
        self
    }

    /// The shape factor in [0, 1] (0 = flat triangles, 1 = full Phong tessellation); the
    /// default is [`crate::phong::DEFAULT_ALPHA`] (0.75, Boubekeur and Alexa's recommendation),
    /// as everywhere else in phongrt. `.alpha(1.0)` gives the builder's former default.
    pub fn alpha(mut self, alpha: f32) -> Self {
        self.alpha = alpha;
        self
    }

    /// Plain Phong tessellation: no welding, every edge bent by the normals at its ends, as the
    /// paper defines it. Meshes with split normals or borders then show cracks.
    pub fn plain(mut self) -> Self {
        self.edges = EdgeRule::Plain;
        self
    }

    /// Keep edge `k` of triangle `t` straight where `straight[t][k]`, and weld nothing (for
    /// arrays already prepared, e.g. by [`crate::mesh::prepare`] or the OBJ loader).
    pub fn straight_edges(mut self, straight: &'a [[bool; 3]]) -> Self {
        self.edges = EdgeRule::Given(straight);
        self
    }

    /// Weld positions closer than `relative` times the diagonal of the mesh's bounds (default
    /// [`crate::mesh::WELD_TOLERANCE`]; 0 welds only equal positions). Undoes [`Self::plain`]
    /// and [`Self::straight_edges`].
    pub fn weld_tolerance(mut self, relative: f32) -> Self {
        self.edges = EdgeRule::Watertight { weld_tolerance: relative };
        self
    }

    /// The intersection method of the ray callbacks ([`Method::Certified`] by default).
    pub fn method(mut self, method: Method) -> Self {
        self.method = method;
        self
    }

    /// Check the arrays and build the patches.
    pub fn build(self) -> Result<PhongMesh, PhongMeshError> {
        let (positions, normals, indices) = (self.positions, self.normals, self.indices);
        // Check everything first, naming the first offender.
        if normals.len() != positions.len() {
            return Err(PhongMeshError::NormalCount(normals.len(), positions.len()));
        }
        if !(0.0..=1.0).contains(&self.alpha) {
            return Err(PhongMeshError::Alpha(self.alpha));
        }
        if indices.len() > u32::MAX as usize {
            return Err(PhongMeshError::TooManyTriangles(indices.len()));
        }
        if !(1..=CLUSTER_SIZE).contains(&self.cluster_size) {
            return Err(PhongMeshError::ClusterSize(self.cluster_size));
        }
        match self.edges {
            EdgeRule::Given(s) if s.len() != indices.len() => {
                return Err(PhongMeshError::EdgeFlagCount(s.len(), indices.len()));
            }
            EdgeRule::Watertight { weld_tolerance: w } if !(w >= 0.0 && w.is_finite()) => {
                return Err(PhongMeshError::WeldTolerance(w));
            }
            _ => {}
        }
        if let Some(i) = (0..positions.len()).find(|&i| !positions[i].is_finite() || !normals[i].is_finite())
        {
            return Err(PhongMeshError::NonFinite(i));
        }
        // The patches normalize in f64, where any non-zero f32 vector has a non-zero length.
        if let Some(i) = normals.iter().position(|n| n.as_dvec3().length_squared() == 0.0) {
            return Err(PhongMeshError::ZeroNormal(i));
        }
        if let Some((t, &index)) = indices
            .iter()
            .enumerate()
            .find_map(|(t, tri)| tri.iter().find(|&&i| i as usize >= positions.len()).map(|i| (t, i)))
        {
            return Err(PhongMeshError::Index { tri: t, index, count: positions.len() });
        }
        // Compute the arrays the patches are built from.
        let k = self.cluster_size;
        let mesh = match self.edges {
            EdgeRule::Watertight { weld_tolerance } => {
                let m = crate::mesh::prepare(positions, normals, indices, weld_tolerance);
                let straight = m.straight_edges();
                build_patches(&m.positions, &m.normals, &m.indices, self.alpha, Some(&straight), k)
            }
            EdgeRule::Plain => build_patches(positions, normals, indices, self.alpha, None, k),
            EdgeRule::Given(s) => build_patches(positions, normals, indices, self.alpha, Some(s), k),
        };
        Ok(PhongMesh { method: self.method, ..mesh })
    }
}

/// The patches of checked arrays.
fn build_patches(
    positions: &[Vec3],
    normals: &[Vec3],
    indices: &[[u32; 3]],
    alpha: f32,
    straight: Option<&[[bool; 3]]>,
    cluster_size: usize,
) -> PhongMesh {
    // Patches are independent: build them on every core (order kept, so deterministic).
    use rayon::prelude::*;
    let patches: Vec<Patch<f32>> = indices
        .par_iter()
        .enumerate()
        .map(|(t, tri)| {
            let p = tri.map(|i| positions[i as usize].as_dvec3());
            let n = tri.map(|i| normals[i as usize].as_dvec3());
            let s = straight.map_or([false; 3], |s| s[t]);
            Patch::with_straight_edges(p, n, alpha as f64, s)
        })
        .collect();
    // Group neighbouring patches (never-hit ones left out) into clusters, if asked to.
    let clusters = if cluster_size > 1 {
        let centroids: Vec<V3<f64>> = patches.iter().map(|p| p.center().to_f64()).collect();
        let groups = group_by_position(&centroids, cluster_size, |t| !patches[t].degenerate());
        groups.par_iter().map(|g| Cluster::new(&patches, g)).collect()
    } else {
        Vec::new()
    };
    let degenerate = patches.iter().filter(|p| p.degenerate()).count();
    let straight = straight.map_or(0, |s| s.iter().flatten().filter(|&&b| b).count());
    let convexity = patches.par_iter().map(convexity).collect();
    PhongMesh { patches, convexity, clusters, degenerate, straight, method: Method::Certified }
}

/// Where the ray enters each member's prism of a cluster (see
/// [`crate::phong::cluster::hull_entries`]), 8 lanes at once in one register where the CPU has
/// AVX (chosen at run time by the `multiversion` crate), in two SSE2 registers otherwise.
#[multiversion(targets("x86_64+avx"))]
fn cluster_entries(h: &ClusterHull, org: Vec3, dir: Vec3, tnear: f32, tfar: f32) -> [f32; CLUSTER_SIZE] {
    hull_entries(h, org.to_array(), dir.to_array(), tnear, tfar)
}

impl PhongMesh {
    /// Build a watertight Phong mesh from the caller's arrays: vertex positions and normals (one
    /// per vertex), triangles and the shape factor `alpha` in [0, 1].
    ///
    /// Positions are welded (see [`crate::mesh::prepare`]: within
    /// [`crate::mesh::WELD_TOLERANCE`] of the mesh's size), so triangles that share a position
    /// share an edge whatever the indexing, and every edge that is not smooth (a crease, where
    /// the normals are split, a border, a non-manifold edge) is kept straight: no ray slips
    /// between two patches. Triangles keep their order (primID) and corner order (`u`, `v`).
    /// For plain Phong tessellation use [`PhongMesh::builder`]`(..).plain()`.
    ///
    /// Refused, naming the vertex or triangle: a normal count that differs from the position
    /// count, an out-of-range index, a non-finite position or normal, a zero normal, an alpha
    /// outside [0, 1].
    pub fn new(
        positions: &[Vec3],
        normals: &[Vec3],
        indices: &[[u32; 3]],
        alpha: f32,
    ) -> Result<Self, PhongMeshError> {
        Self::builder(positions, normals, indices).alpha(alpha).build()
    }

    /// Options for a mesh of these arrays (watertight, alpha [`crate::phong::DEFAULT_ALPHA`], certified intersection unless
    /// set): see [`PhongMeshBuilder`].
    pub fn builder<'a>(
        positions: &'a [Vec3],
        normals: &'a [Vec3],
        indices: &'a [[u32; 3]],
    ) -> PhongMeshBuilder<'a> {
        PhongMeshBuilder {
            positions,
            normals,
            indices,
            alpha: crate::phong::DEFAULT_ALPHA,
            edges: EdgeRule::Watertight { weld_tolerance: crate::mesh::WELD_TOLERANCE },
            method: Method::Certified,
            cluster_size: 1,
        }
    }

    /// The arrays as given (no welding), keeping edge `k` of triangle `t` straight where
    /// `straight[t][k]` (`None`: plain Phong tessellation). For arrays already prepared, such
    /// as the OBJ loader's meshes with [`crate::scene::Mesh::straight_edges`].
    pub fn with_straight_edges(
        positions: &[Vec3],
        normals: &[Vec3],
        indices: &[[u32; 3]],
        alpha: f32,
        straight: Option<&[[bool; 3]]>,
    ) -> Result<Self, PhongMeshError> {
        let b = Self::builder(positions, normals, indices).alpha(alpha);
        match straight {
            Some(s) => b.straight_edges(s),
            None => b.plain(),
        }
        .build()
    }

    /// How many triangle edges are kept straight (a shared edge counts once per triangle).
    pub fn straight_edge_count(&self) -> usize {
        self.straight
    }

    /// The patches, one per triangle (primID order).
    pub fn patches(&self) -> &[Patch<f32>] {
        &self.patches
    }

    /// The sides patch `prim` is convex towards (`None` past the end).
    pub fn convexity(&self, prim: u32) -> Option<Convexity> {
        self.convexity.get(prim as usize).copied()
    }

    /// Conservative world-space bounds of patch `prim` (`None` past the end).
    pub fn patch_bounds(&self, prim: u32) -> Option<(Vec3, Vec3)> {
        let (lo, hi) = self.patches.get(prim as usize)?.bounds();
        Some((lo.into(), hi.into()))
    }

    /// The clusters Embree sees as its user primitives (each up to 8 neighbouring patches;
    /// empty for one patch per primitive, the default).
    pub fn clusters(&self) -> &[Cluster] {
        &self.clusters
    }

    /// Where `org + t dir` enters the prism of each member of `cluster` within `(tnear, tfar)`
    /// (`+inf`: it misses it), as the ray callbacks compute it (`None` past the end).
    pub fn cluster_entries(
        &self,
        cluster: u32,
        org: Vec3,
        dir: Vec3,
        tnear: f32,
        tfar: f32,
    ) -> Option<[f32; CLUSTER_SIZE]> {
        Some(cluster_entries(self.clusters.get(cluster as usize)?.hull(), org, dir, tnear, tfar))
    }

    /// How many patches are never hit (zero area or zero normal).
    pub fn degenerate(&self) -> usize {
        self.degenerate
    }

    /// The intersection method the ray callbacks use ([`Method::Certified`] unless set).
    pub fn method(&self) -> Method {
        self.method
    }

    /// Use `method` for the ray callbacks.
    pub fn set_method(&mut self, method: Method) {
        self.method = method;
    }

    /// The true surface point at `(u, v)` of patch `prim`, with a bound on its rounding error.
    pub fn surface_point(&self, prim: u32, u: f32, v: f32) -> Option<(Vec3, Vec3)> {
        let p = self.patches.get(prim as usize)?;
        if !(u.is_finite() && v.is_finite()) {
            return None;
        }
        let (pt, err) = p.eval_with_error(u, v);
        Some((pt.into(), err.into()))
    }

    /// The default shading normal ([`ShadingNormal::Adapted`]) at `(u, v)` for a ray along `dir`:
    /// unit, facing the side the ray came from. `None` for a primitive out of range, a non-finite
    /// `(u, v)` or `dir`, or a degenerate normal.
    pub fn shading_normal(&self, prim: u32, u: f32, v: f32, dir: Vec3) -> Option<Vec3> {
        self.shading_normal_with(prim, u, v, dir, ShadingNormal::default())
    }

    /// The shading normal at `(u, v)` for a ray along `dir` under `rule` (see [`ShadingNormal`]).
    pub fn shading_normal_with(
        &self,
        prim: u32,
        u: f32,
        v: f32,
        dir: Vec3,
        rule: ShadingNormal,
    ) -> Option<Vec3> {
        let p = self.patches.get(prim as usize)?;
        if !(u.is_finite() && v.is_finite()) {
            return None;
        }
        p.shading_normal_with(u, v, V3::from(dir), rule).map(Vec3::from).filter(|n| n.is_finite())
    }

    /// Patch `prim`'s [`Patch::bump_bound`] `(height, reach)`, or `None` where it is not finite.
    pub fn bump_bound(&self, prim: u32) -> Option<(f32, f32)> {
        let (h, r) = self.patches.get(prim as usize)?.bump_bound();
        (h.is_finite() && r.is_finite()).then_some((h, r))
    }

    /// The shadow-ray origin lift at `(u, v)` of patch `prim` on the side `side` of the vertex
    /// normals (+1 or -1): see [`Patch::shadow_lift`]. Zero where it is not finite.
    pub fn shadow_lift(&self, prim: u32, u: f32, v: f32, side: f32) -> Vec3 {
        match self.patches.get(prim as usize) {
            Some(p) if u.is_finite() && v.is_finite() => {
                Some(Vec3::from(p.shadow_lift(u, v, side))).filter(|l| l.is_finite()).unwrap_or(Vec3::ZERO)
            }
            _ => Vec3::ZERO,
        }
    }

    /// The true surface normal `dP/du × dP/dv` (unit) at `(u, v)`.
    pub fn geometric_normal(&self, prim: u32, u: f32, v: f32) -> Option<Vec3> {
        self.patches.get(prim as usize)?.geometric_normal(u, v).map(Vec3::from)
    }

    /// Bytes held by this mesh.
    pub fn memory_bytes(&self) -> usize {
        self.patches.len() * (std::mem::size_of::<Patch<f32>>() + std::mem::size_of::<Convexity>())
            + self.clusters.len() * std::mem::size_of::<Cluster>()
    }
}

/// One patch solve inside a ray callback's test, as [`PhongMesh::intersect_primitive`] reports it.
#[derive(Clone, Copy, Debug)]
pub struct PatchTest {
    /// The patch (triangle index).
    pub prim: u32,
    /// The ray interval it was solved on: `tnear` and the nearest hit so far (or `tfar`).
    pub tnear: f32,
    /// See `tnear`.
    pub tmax: f32,
    /// The path the solve took.
    pub outcome: TestOutcome,
    /// Whether the solve ran the patch's own bounds and prism test (one patch per primitive),
    /// or the cluster's prism test had run instead.
    pub hull_tested: bool,
}

impl PhongMesh {
    /// The nearest hit of `org + t dir`, `t` in `(tnear, tfar)`, on Embree primitive `item` (a
    /// patch, or a cluster of them): what the ray callbacks answer. `on_test` sees each patch
    /// solve (for profiling).
    ///
    /// In a cluster, the members whose prisms the ray enters are solved in the order it enters
    /// them, each up to the nearest hit so far, until the next entry lies beyond it.
    #[inline(always)]
    pub fn intersect_primitive(
        &self,
        item: u32,
        org: Vec3,
        dir: Vec3,
        tnear: f32,
        tfar: f32,
        on_test: impl FnMut(PatchTest),
    ) -> Option<PrimHit> {
        self.intersect_primitive_from(item, None, org, dir, tnear, tfar, on_test)
    }

    /// [`PhongMesh::intersect_primitive`] for a ray that starts at `origin` (a point of one of
    /// this mesh's patches) when given: that patch is left out, without a solve, where
    /// [`leaves_patch`](crate::phong::convexity::leaves_patch) proves the ray cannot meet it
    /// again (`on_test` does not see it).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn intersect_primitive_from(
        &self,
        item: u32,
        origin: Option<OriginPrim>,
        org: Vec3,
        dir: Vec3,
        tnear: f32,
        tfar: f32,
        mut on_test: impl FnMut(PatchTest),
    ) -> Option<PrimHit> {
        let (o, d) = (V3::from(org), V3::from(dir));
        if self.clusters.is_empty() {
            let p = self.patches.get(item as usize)?;
            if self.leaves_origin(item, origin, o, d, tnear, tfar) {
                return None;
            }
            // The patch the ray starts on: no hull test (the ray starts inside the hull).
            let (h, outcome, hull_tested) = if origin.is_some_and(|x| x.prim == item) {
                let (h, outcome) = intersect_in_hull_traced(p, o, d, tnear, tfar, self.method);
                (h, outcome, false)
            } else {
                let (h, outcome) = intersect_traced(p, o, d, tnear, tfar, self.method);
                (h, outcome, true)
            };
            on_test(PatchTest { prim: item, tnear, tmax: tfar, outcome, hull_tested });
            return h.map(|h| self.prim_hit(p, item, h));
        }
        self.intersect_cluster_from(item, origin, org, dir, tnear, tfar, on_test)
    }

    /// [`PhongMesh::intersect_primitive_from`] on a cluster: out of line, so that the route of
    /// one patch per primitive (the default) keeps nothing in memory for it.
    #[inline(never)]
    #[allow(clippy::too_many_arguments)]
    fn intersect_cluster_from(
        &self,
        item: u32,
        origin: Option<OriginPrim>,
        org: Vec3,
        dir: Vec3,
        tnear: f32,
        tfar: f32,
        mut on_test: impl FnMut(PatchTest),
    ) -> Option<PrimHit> {
        let (o, d) = (V3::from(org), V3::from(dir));
        let c = self.clusters.get(item as usize)?;
        // Compute the entries, and the members entered, nearest first (ties by lane).
        let entries = cluster_entries(c.hull(), org, dir, tnear, tfar);
        let mut order = [(0.0f32, 0u32); CLUSTER_SIZE];
        let mut n = 0;
        for (i, &m) in c.members().iter().enumerate() {
            let t = entries[i];
            if t < f32::INFINITY {
                let mut k = n;
                while k > 0 && order[k - 1].0 > t {
                    order[k] = order[k - 1];
                    k -= 1;
                }
                order[k] = (t, m);
                n += 1;
            }
        }
        // Solve them until the next entry lies beyond the nearest hit; the normal only for it.
        let mut best: Option<(u32, PatchHit<f32>)> = None;
        let mut tmax = tfar;
        for &(entry, prim) in &order[..n] {
            if !(entry < tmax) {
                break;
            }
            let Some(p) = self.patches.get(prim as usize) else { continue };
            if self.leaves_origin(prim, origin, o, d, tnear, tmax) {
                continue;
            }
            let (hit, outcome) = intersect_in_hull_traced(p, o, d, tnear, tmax, self.method);
            on_test(PatchTest { prim, tnear, tmax, outcome, hull_tested: false });
            if let Some(h) = hit {
                tmax = h.t;
                best = Some((prim, h));
            }
        }
        let (prim, h) = best?;
        Some(self.prim_hit(self.patches.get(prim as usize)?, prim, h))
    }

    /// Whether patch `prim` is the one the ray starts on (`origin`) and
    /// [`leaves_patch`](crate::phong::convexity::leaves_patch) proves the ray cannot meet it again
    /// (the single rays' route; a packet's lanes take [`PhongMesh::leaves_origin_lanes`]). Under
    /// the [`audit`], such a patch is solved anyway (on `(tnear, tmax)`, as the solve left out
    /// would have been) and counted.
    #[inline(always)]
    fn leaves_origin(
        &self,
        prim: u32,
        origin: Option<OriginPrim>,
        org: V3<f32>,
        dir: V3<f32>,
        tnear: f32,
        tmax: f32,
    ) -> bool {
        let Some(origin) = origin.filter(|o| o.prim == prim) else { return false };
        let (Some(p), Some(&conv)) = (self.patches.get(prim as usize), self.convexity.get(prim as usize))
        else {
            return false;
        };
        if !leaves_patch_by::<_, true>(p, conv, origin.u, origin.v, org, dir, tnear) {
            return false;
        }
        if audit::on() {
            audit::record(prim, intersect_traced(p, org, dir, tnear, tmax, self.method).0.map(|h| h.t));
        }
        true
    }

    /// [`PhongMesh::leaves_origin`] without the unfolded rule for the lanes of `rays` that
    /// `starts` marks, rays that start on patch `p` (primitive `prim`) at `(u[i], v[i])`: the
    /// lanes it settles, as a mask; all at once ([`leaves_patch_lanes`]), with the same answers.
    #[inline(never)]
    fn leaves_origin_lanes(
        &self,
        prim: u32,
        p: &Patch<f32>,
        starts: u32,
        (u, v): (&[f32; LANES], &[f32; LANES]),
        rays: &LaneRays,
    ) -> u32 {
        let Some(&conv) = self.convexity.get(prim as usize) else { return 0 };
        let settled = leaves_patch_lanes(p, conv, starts, u, v, rays);
        if audit::on() {
            for i in (0..LANES).filter(|&i| settled >> i & 1 != 0) {
                let (org, dir) = rays.ray(i);
                let hit = intersect_traced(p, org, dir, rays.tmin[i], rays.tmax[i], self.method).0;
                audit::record(prim, hit.map(|h| h.t));
            }
        }
        settled
    }

    /// Whether [`PhongMesh::intersect_lanes`] tests lanes together: one patch per primitive
    /// and [`Method::Certified`] (clusters and the other methods go lane by lane).
    pub fn tests_lanes_together(&self) -> bool {
        self.clusters.is_empty() && self.method == Method::Certified
    }

    /// [`PhongMesh::intersect_primitive_from`] for the lanes of `rays` where `active`, lane `i`
    /// starting at `origin.get(i)` when given: all of them at once (see
    /// [`certified_lanes`](crate::phong::intersect::certified_lanes)) when
    /// [`PhongMesh::tests_lanes_together`], lane by lane otherwise, with the same answers
    /// either way. Lanes the lane kernel leaves unsure are solved by the scalar path from where
    /// the kernel stopped
    /// ([`LaneAnswers::unsure_answer`](crate::phong::intersect::LaneAnswers::unsure_answer)); a
    /// lane whose origin patch [`leaves_patch`](crate::phong::convexity::leaves_patch) settles,
    /// without its unfolded rule, is left out of the kernel after its hull test. Only the lanes
    /// past the hull test look up their origins.
    // Inlined into the packet callbacks: called out of line, its answer (256 bytes) went back
    // through memory on every call, most of them a hull test that turned every lane away (8-ray
    // packets, head shadow rays: 2,168 -> 2,113 instructions a ray, scripts/instructions.sh).
    #[allow(clippy::needless_range_loop)] // lane loops index several arrays by the lane
    #[inline(always)]
    pub fn intersect_lanes(
        &self,
        item: u32,
        rays: &LaneRays,
        active: [bool; LANES],
        origin: &LaneOrigins,
    ) -> [Option<PrimHit>; LANES] {
        let mut hits = [None; LANES];
        if !self.tests_lanes_together() {
            for i in (0..LANES).filter(|&i| active[i]) {
                let (o, d) = rays.ray(i);
                let (o, d) = (Vec3::from(o), Vec3::from(d));
                hits[i] = self.intersect_primitive_from(
                    item,
                    origin.get(i),
                    o,
                    d,
                    rays.tmin[i],
                    rays.tmax[i],
                    |_| {},
                );
            }
            return hits;
        }
        let Some(p) = self.patches.get(item as usize) else { return hits };
        // Compute the hull test on every lane: most calls end here, every lane turned away.
        let mut hull = hull_of_lanes(p, rays);
        if hull.is_empty() {
            return hits;
        }
        // Compute the lanes to solve: active, past the hull, and not settled by their origin
        // (the lanes that start on this patch gathered, then settled together).
        let (mut starts, mut u, mut v) = (0u32, [0.0f32; LANES], [0.0f32; LANES]);
        for i in 0..LANES {
            if !hull.passed(i) {
                continue;
            }
            if !active[i] {
                hull.leave_out(i);
                continue;
            }
            if let Some(from) = origin.get(i).filter(|o| o.prim == item) {
                (u[i], v[i]) = (from.u, from.v);
                starts |= 1 << i;
            }
        }
        if starts != 0 {
            let settled = self.leaves_origin_lanes(item, p, starts, (&u, &v), rays);
            for i in (0..LANES).filter(|&i| settled >> i & 1 != 0) {
                hull.leave_out(i);
            }
        }
        let answers = certified_lanes_past(p, &hull, rays);
        // Most calls past the hull still find every lane turned away: one comparison of the 8
        // decisions.
        if answers.decision == [LaneDecision::Miss; LANES] {
            return hits;
        }
        // Compute the lanes' hits (a miss, or a lane left out, leaves the lane's `None`).
        for i in 0..LANES {
            let hit = match answers.decision[i] {
                LaneDecision::Miss => continue,
                LaneDecision::Hit => PatchHit { t: answers.t[i], u: answers.u[i], v: answers.v[i] },
                LaneDecision::Unsure => {
                    let (o, d) = rays.ray(i);
                    let (lo, hi) = (rays.tmin[i], rays.tmax[i]);
                    match answers.unsure_answer(p, i, o, d, lo, hi).0 {
                        Some(h) => h,
                        None => continue,
                    }
                }
            };
            hits[i] = Some(self.prim_hit(p, item, hit));
        }
        hits
    }

    /// The hit Embree is given for `h` on patch `p` (triangle `prim`).
    #[inline(always)]
    fn prim_hit(&self, p: &Patch<f32>, prim: u32, h: PatchHit<f32>) -> PrimHit {
        let (pu, pv) = p.partials_local(h.u, h.v);
        PrimHit { t: h.t, u: h.u, v: h.v, ng: Vec3::from(pu.cross(pv)), prim }
    }
}

/// The hit Embree is given for `h`, found in precision `T` on patch `p` (triangle `prim`), rounded
/// to f32: `None` when the rounded `t` leaves the open interval `(tnear, tfar)` (for user
/// geometry of patches solved in f64, as the bench's reference).
pub fn patch_prim_hit<T: crate::phong::Real>(
    p: &Patch<T>,
    prim: u32,
    h: PatchHit<T>,
    tnear: f32,
    tfar: f32,
) -> Option<PrimHit> {
    let t = h.t.to_f64() as f32;
    if !(t > tnear && t < tfar) {
        return None;
    }
    let (pu, pv) = p.partials_local(h.u, h.v);
    let ng = pu.cross(pv).to_f64();
    let ng = Vec3::new(ng.x as f32, ng.y as f32, ng.z as f32);
    Some(PrimHit { t, u: h.u.to_f64() as f32, v: h.v.to_f64() as f32, ng, prim })
}

/// Evaluate the Phong surface of triangle `(p, n)` at `(u, v)` in f64 (a convenience for users).
pub fn phong_point(p: [Vec3; 3], n: [Vec3; 3], alpha: f32, u: f64, v: f64) -> Vec3 {
    let patch: Patch<f64> = Patch::new(p.map(|x| x.as_dvec3()), n.map(|x| x.as_dvec3()), alpha as f64);
    let q: DVec3 = patch.eval(u, v).into();
    q.as_vec3()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix;

    /// The patch a ray starts on is solved without its hull test (the ray starts inside the
    /// hull): from random points of a curved patch, lifted by up to 1e-2 of its size to either
    /// side, in random directions, the answer is the one without the origin, hit for hit and bit
    /// for bit, wherever the origin test does not settle the ray (and `None` where it does).
    #[test]
    fn the_patch_a_ray_starts_on_answers_as_without_the_origin() {
        let p = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let n = [Vec3::new(-0.5, -0.5, 1.0), Vec3::new(0.8, 0.0, 1.0), Vec3::new(0.0, -0.8, 1.0)];
        let mesh = PhongMesh::builder(&p, &n, &[[0, 1, 2]]).alpha(1.0).plain().build().unwrap();
        let mut rng = SplitMix(71);
        let (mut solved, mut hits) = (0, 0);
        for _ in 0..20_000 {
            let (mut u, mut v) = (rng.range(0.0, 1.0) as f32, rng.range(0.0, 1.0) as f32);
            if u + v > 1.0 {
                (u, v) = (1.0 - u, 1.0 - v);
            }
            let Some(ng) = mesh.geometric_normal(0, u, v) else { continue };
            let lift = 10f32.powf(rng.range(-5.0, -2.0) as f32) * rng.range(-1.0, 1.0).signum() as f32;
            let org = mesh.surface_point(0, u, v).unwrap().0 + ng * lift;
            let dir = Vec3::new(
                rng.range(-1.0, 1.0) as f32,
                rng.range(-1.0, 1.0) as f32,
                rng.range(-1.0, 1.0) as f32,
            );
            let origin = Some(OriginPrim { prim: 0, u, v });
            let mut tested = None;
            let from =
                mesh.intersect_primitive_from(0, origin, org, dir, 0.0, f32::INFINITY, |t| tested = Some(t));
            let plain = mesh.intersect_primitive(0, org, dir, 0.0, f32::INFINITY, |_| {});
            match tested {
                Some(t) => {
                    assert!(!t.hull_tested, "the hull test ran");
                    assert_eq!(from, plain, "u {u} v {v} lift {lift:e} dir {dir:?}");
                    solved += 1;
                    hits += from.is_some() as usize;
                }
                None => assert_eq!((from, plain), (None, None), "settled, yet hit: u {u} v {v} dir {dir:?}"),
            }
        }
        assert!(solved > 2000 && hits > 500, "{solved} solved, {hits} hits");
    }
}
