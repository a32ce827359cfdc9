//! `phongrt bench`: what accuracy costs in time — every way of getting a smooth surface side by
//! side, on the same mesh, camera and machine, against the f64 direct Phong render as reference.

use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;

use phongrt::embree::{
    patch_prim_hit, CommittedScene, Device, EmbreeError, GeometryOptions, PhongMesh, PhongMeshError, PrimHit,
    Ray, RayOrigin, Scene, UserPrimitives, UserTriangles, PACKET8,
};
use phongrt::phong::{control_points, intersect, Method, Patch, V3};
use phongrt::scene::Mesh;
use phongrt_render::Camera;

/// The ways of rendering a smooth surface from a low-poly mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BenchMethod {
    /// Embree's native triangles of the input mesh.
    Flat,
    /// The Phong surface evaluated at `L` segments per edge into native triangles.
    Pretessellated(u32),
    /// Direct Phong, certified Newton with the analytic method as fallback, f32 (the render path).
    DirectF32,
    /// As `DirectF32`, with clusters of 8 patches per Embree primitive (one 8-lane prism test).
    DirectF32Clustered,
    /// Direct Phong, analytic + polish for every ray, f32.
    AnalyticF32,
    /// Direct Phong, analytic + polish, f64 (the reference).
    DirectF64,
    /// Direct Phong, Newton–Raphson, f32.
    NewtonF32,
    /// The input triangles as a user geometry with a trivial test: the callback route's floor.
    UserFloor,
    /// Embree's Catmull–Clark subdivision surface over the same control mesh (rate 8).
    Subdivision,
}

impl std::fmt::Display for BenchMethod {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.name())
    }
}

impl BenchMethod {
    /// The method's name in the tables, CSV and plots (`flat`, `pretess-4`, `direct-f32`, ...).
    pub fn name(&self) -> String {
        match self {
            BenchMethod::Flat => "flat".into(),
            BenchMethod::Pretessellated(l) => format!("pretess-{l}"),
            BenchMethod::DirectF32 => "direct-f32".into(),
            BenchMethod::DirectF32Clustered => "direct-f32-k8".into(),
            BenchMethod::AnalyticF32 => "analytic-f32".into(),
            BenchMethod::DirectF64 => "direct-f64".into(),
            BenchMethod::NewtonF32 => "newton-f32".into(),
            BenchMethod::UserFloor => "user-floor".into(),
            BenchMethod::Subdivision => "subdiv-cc".into(),
        }
    }

    /// Whether the method ray traces the Phong surface directly (a curved primitive).
    pub fn is_direct(&self) -> bool {
        matches!(
            self,
            BenchMethod::DirectF32
                | BenchMethod::DirectF32Clustered
                | BenchMethod::AnalyticF32
                | BenchMethod::DirectF64
                | BenchMethod::NewtonF32
        )
    }

    /// Every method, pre-tessellation at levels 1..64.
    pub fn all() -> Vec<BenchMethod> {
        Self::all_with_levels(&DEFAULT_LEVELS)
    }

    /// Every method, pre-tessellation at `levels` (segments per edge).
    pub fn all_with_levels(levels: &[u32]) -> Vec<BenchMethod> {
        let mut v = vec![BenchMethod::Flat];
        v.extend(levels.iter().map(|&l| BenchMethod::Pretessellated(l)));
        v.extend([
            BenchMethod::DirectF32,
            BenchMethod::DirectF32Clustered,
            BenchMethod::AnalyticF32,
            BenchMethod::DirectF64,
            BenchMethod::NewtonF32,
            BenchMethod::UserFloor,
            BenchMethod::Subdivision,
        ]);
        v
    }
}

/// Phong patches solved in f64 (the reference's geometry).
struct PhongMesh64 {
    patches: Vec<Patch<f64>>,
}

impl UserPrimitives for PhongMesh64 {
    fn count(&self) -> u32 {
        self.patches.len() as u32
    }
    fn bounds(&self, prim: u32) -> Option<(Vec3, Vec3)> {
        self.patches.get(prim as usize)?.bounds_f32()
    }
    fn intersect(&self, prim: u32, org: Vec3, dir: Vec3, tnear: f32, tfar: f32) -> Option<PrimHit> {
        let p = self.patches.get(prim as usize)?;
        let (o, d) = (V3::from(org.as_dvec3()), V3::from(dir.as_dvec3()));
        let h = intersect(p, o, d, tnear as f64, tfar as f64, Method::AnalyticPolished)?;
        patch_prim_hit(p, prim, h, tnear, tfar)
    }
}

fn patches64(m: &Mesh, alpha: f64) -> Vec<Patch<f64>> {
    let straight = m.straight_edges();
    m.indices
        .iter()
        .enumerate()
        .map(|(t, tri)| {
            let p = tri.map(|i| m.positions[i as usize].as_dvec3());
            let n = tri.map(|i| m.normals[i as usize].as_dvec3());
            Patch::with_straight_edges(p, n, alpha, straight.get(t).copied().unwrap_or([false; 3]))
        })
        .collect()
}

/// The Phong surface evaluated at `level` segments per edge: `level²` triangles per patch.
///
/// Watertight: a vertex on an edge is evaluated from the edge's own quadratic Bézier curve
/// (its two corners and its control point, which both patches beside a smooth edge compute
/// alike), oriented from the corner whose position sorts first, and corners are the mesh's own
/// positions. Both patches beside an edge therefore produce bit-identical vertices along it, so
/// Embree's triangle test leaves no crack for a ray to slip through (it would be hit far behind,
/// an error of the pre-tessellation's making, not the surface's).
pub fn pretessellate(m: &Mesh, alpha: f64, level: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let l = level.max(1);
    let (n, lu) = (m.indices.len(), l as usize);
    let straight = m.straight_edges();
    let mut pos = Vec::with_capacity(n * (lu + 1) * (lu + 2) / 2);
    let mut idx = Vec::with_capacity(n * lu * lu);
    let lf = l as f64;
    let to_f32 = |q: V3<f64>| Vec3::new(q.x as f32, q.y as f32, q.z as f32);
    let key = |q: V3<f64>| (q.x.to_bits(), q.y.to_bits(), q.z.to_bits());
    // Point `step` of `l` along the curve from corner `a` to corner `b` with control point `c`.
    let edge_point = |a: V3<f64>, b: V3<f64>, c: V3<f64>, step: u32| -> Vec3 {
        let (a, b, step) = if key(a) <= key(b) { (a, b, step) } else { (b, a, l - step) };
        let (s, r) = (step as f64 / lf, (l - step) as f64 / lf);
        to_f32(a * (r * r) + c * (2.0 * s * r) + b * (s * s))
    };
    for (t, tri) in m.indices.iter().enumerate() {
        let corner = tri.map(|i| m.positions[i as usize]);
        let p = corner.map(|q| V3::from(q.as_dvec3()));
        let nrm = tri.map(|i| V3::from(m.normals[i as usize].as_dvec3()).normalized().unwrap_or(V3::zero()));
        let cp = control_points(p, nrm, alpha, straight.get(t).copied().unwrap_or([false; 3]));
        // Grid vertices (i, j) with u = i/l, v = j/l, i + j <= l, row by row.
        let mut row_start = Vec::with_capacity(lu + 1);
        for j in 0..=l {
            row_start.push(pos.len() as u32);
            for i in 0..=(l - j) {
                let q = match (i, j) {
                    (0, 0) => corner[0],
                    (_, 0) if i == l => corner[1],
                    (0, _) if j == l => corner[2],
                    (_, 0) => edge_point(p[0], p[1], cp[3], i),
                    _ if i + j == l => edge_point(p[1], p[2], cp[4], j),
                    (0, _) => edge_point(p[2], p[0], cp[5], l - j),
                    _ => {
                        // Interior: the Bézier triangle (w, u, v weight p0, p1, p2).
                        let (u, v) = (i as f64 / lf, j as f64 / lf);
                        let w = 1.0 - u - v;
                        to_f32(
                            cp[0] * (w * w)
                                + cp[1] * (u * u)
                                + cp[2] * (v * v)
                                + cp[3] * (2.0 * w * u)
                                + cp[4] * (2.0 * u * v)
                                + cp[5] * (2.0 * v * w),
                        )
                    }
                };
                pos.push(q);
            }
        }
        let v = |i: u32, j: u32| row_start[j as usize] + i;
        for j in 0..l {
            for i in 0..(l - j) {
                idx.push([v(i, j), v(i + 1, j), v(i, j + 1)]);
                if i + 1 < l - j {
                    idx.push([v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)]);
                }
            }
        }
    }
    (pos, idx)
}

/// The pre-tessellation levels built by default.
pub const DEFAULT_LEVELS: [u32; 7] = [1, 2, 4, 8, 16, 32, 64];

/// The largest pre-tessellation the bench builds by default (about 2 GB of Embree BVH at the
/// measured ~100 bytes per triangle); `--max-pretess-tris` raises it.
pub const MAX_PRETESSELLATED_TRIANGLES: u64 = 20_000_000;

/// The largest control mesh given to Embree's Catmull–Clark subdivision (measured ~2 kB of BVH
/// per face at rate 8: 76 MB for 36 480 faces).
pub const MAX_SUBDIVISION_FACES: usize = 300_000;

/// Samples per pixel of the shaded render (a 2×2 stratified grid).
pub const SHADED_SPP: u32 = 4;

/// One method on one scene.
#[derive(Clone, Debug)]
pub struct BenchRow {
    pub scene: String,
    pub triangles: usize,
    pub method: BenchMethod,
    pub build_ms: f64,
    pub embree_bytes: i64,
    pub own_bytes: usize,
    pub mrays_1t: f64,
    pub mrays_all: f64,
    pub first_image_ms: f64,
    /// Mean and max of |t - t_ref| / t_ref over pixels both hit.
    pub err_t_mean: f64,
    pub err_t_max: f64,
    /// The median of the same: robust to the few pixels where a coarse surface is hit at a
    /// very different depth (a silhouette crossing another part of the mesh).
    pub err_t_p50: f64,
    /// Pixels hit by one and not the other.
    pub silhouette_px: usize,
    /// A full shaded render on all cores: `SHADED_SPP` samples per pixel, one shadow ray per
    /// hit towards a directional light, Lambert on the geometric normal.
    pub shaded_ms: f64,
    /// Primary rays per second on one thread, traced in coherent 8-ray packets from 4x2 pixel
    /// blocks (`Scene::intersect8_rays`).
    pub mrays_1t_packets: f64,
    /// The shaded render of `shaded_ms` with its primary and shadow rays in coherent 8-ray
    /// packets from 4x2 pixel blocks.
    pub shaded_ms_packets: f64,
}

/// Why a bench scene could not be run.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// Embree refused the device or a method's scene.
    #[error(transparent)]
    Embree(#[from] EmbreeError),
    /// The mesh was refused as a Phong mesh.
    #[error(transparent)]
    PhongMesh(#[from] PhongMeshError),
    /// Packets answered other depths than single rays (each lane must answer as its ray alone).
    #[error("{scene}: {method}: {differ} pixels traced in packets differ from single rays")]
    PacketsDiffer {
        /// The scene.
        scene: String,
        /// The method.
        method: String,
        /// How many pixels differ.
        differ: usize,
    },
    /// The mesh's bounds give no camera (empty or non-finite).
    #[error("{0}: cannot frame a camera on its bounds")]
    Camera(String),
}

fn build(
    device: &Device,
    m: &Mesh,
    method: BenchMethod,
    robust: bool,
) -> Result<(CommittedScene, usize), BenchError> {
    let mut s = Scene::new(device)?;
    if robust {
        s.set_robust(true)?;
    }
    let own = match method {
        BenchMethod::Flat => {
            s.attach_triangles(&m.positions, &m.indices, GeometryOptions::default())?;
            0
        }
        BenchMethod::Pretessellated(l) => {
            let (p, i) = pretessellate(m, 1.0, l);
            s.attach_triangles(&p, &i, GeometryOptions::default())?;
            0
        }
        BenchMethod::DirectF32
        | BenchMethod::DirectF32Clustered
        | BenchMethod::AnalyticF32
        | BenchMethod::NewtonF32 => {
            let straight = m.straight_edges();
            let (solver, k) = match method {
                BenchMethod::NewtonF32 => (Method::Newton, 1),
                BenchMethod::AnalyticF32 => (Method::AnalyticPolished, 1),
                BenchMethod::DirectF32Clustered => (Method::Certified, 8),
                _ => (Method::Certified, 1),
            };
            let pm = PhongMesh::builder(&m.positions, &m.normals, &m.indices)
                .alpha(1.0)
                .straight_edges(&straight)
                .method(solver)
                .cluster_size(k)
                .build()?;
            let own = pm.memory_bytes();
            s.attach_phong(pm, GeometryOptions::default())?;
            own
        }
        BenchMethod::DirectF64 => {
            let patches = patches64(m, 1.0);
            let own = patches.len() * std::mem::size_of::<Patch<f64>>();
            s.attach_user(PhongMesh64 { patches }, GeometryOptions::default())?;
            own
        }
        BenchMethod::UserFloor => {
            let own = m.positions.len() * 12 + m.indices.len() * 12;
            s.attach_user(
                UserTriangles { positions: m.positions.clone(), indices: m.indices.clone() },
                GeometryOptions::default(),
            )?;
            own
        }
        BenchMethod::Subdivision => {
            s.attach_subdivision(&m.positions, &m.indices, 8.0)?;
            0
        }
    };
    let s = s.commit()?;
    Ok((s, own))
}

/// The shadow ray of the bench's shaded render for the hit `h` of `ray`, towards the
/// directional `light`, with the cosine it weighs (`None` where the light is behind the surface).
/// The origin is offset by the hit point's error bound along the normal (pbrt-v4's
/// OffsetRayOrigin with the renderer's fallback bound for `o + t d`).
pub fn shadow_ray(ray: &Ray, h: &phongrt::embree::Hit, light: Vec3) -> Option<(Ray, f32)> {
    use phongrt::phong::Real;
    use phongrt_render::world::SurfacePoint;
    let mut n = h.ng.try_normalize()?;
    if n.dot(ray.dir) > 0.0 {
        n = -n;
    }
    let cos = n.dot(light);
    if cos <= 0.0 {
        return None;
    }
    let sp = SurfacePoint {
        p: ray.at(h.t),
        p_error: <f32 as Real>::gamma(7) * (ray.org.abs() + (h.t * ray.dir).abs()),
        ng: n,
        n,
        entering: true,
        terminator: phongrt_render::Terminator::Plain,
        origin: None,
    };
    Some((Ray::new(sp.offset_origin(light), light), cos))
}

/// The directional light of the bench's shaded render: above, left and behind the camera.
pub fn bench_light(frame: &phongrt_render::CameraFrame) -> Vec3 {
    (frame.up.normalize_or_zero() * 0.8 - frame.right.normalize_or_zero() * 0.5 - frame.forward * 0.6)
        .normalize()
}

/// The shaded render of `shaded_ms`: returns the summed radiance (so the work is not optimised
/// away, and as a cross-check between methods).
fn shaded(
    scene: &CommittedScene,
    frame: &phongrt_render::CameraFrame,
    width: u32,
    height: u32,
    light: Vec3,
) -> f64 {
    let row = |y: u32| -> f64 {
        let mut sum = 0.0f64;
        for x in 0..width {
            for s in 0..SHADED_SPP {
                let (ox, oy) = phongrt_render::sample_offset(x, y, s, SHADED_SPP, 0);
                let ray = Ray::new(frame.eye, frame.direction(x as f32 + ox, y as f32 + oy, width, height));
                let Some(h) = scene.intersect1(ray) else { continue };
                let Some((shadow, cos)) = shadow_ray(&ray, &h, light) else { continue };
                if !scene.occluded1_from(shadow, Some(RayOrigin::of_hit(&h))) {
                    sum += cos as f64;
                }
            }
        }
        sum
    };
    (0..height).into_par_iter().map(row).sum()
}

/// The lanes of the 4x2 pixel block at `(bx, by)` (lane `k` is pixel `(bx + k % 4, by + k / 4)`)
/// inside the `width`x`height` image, as a mask.
fn block_lanes(bx: u32, by: u32, width: u32, height: u32) -> u8 {
    (0..PACKET8).fold(0, |m, k| {
        let (x, y) = (bx + k as u32 % 4, by + k as u32 / 4);
        m | (((x < width && y < height) as u8) << k)
    })
}

/// [`depth`] on one thread with the rays (one per pixel, row-major) traced in coherent 8-ray
/// packets from 4x2 pixel blocks: the same depths.
fn depth_packets(scene: &CommittedScene, rays: &[Ray], width: u32, height: u32) -> Vec<Option<f32>> {
    let mut out = vec![None; rays.len()];
    for by in (0..height).step_by(2) {
        for bx in (0..width).step_by(4) {
            let active = block_lanes(bx, by, width, height);
            let index = |k: usize| ((by + k as u32 / 4) * width + bx + k as u32 % 4) as usize;
            let packet =
                std::array::from_fn(|k| if active & (1 << k) != 0 { rays[index(k)] } else { rays[0] });
            let hits = scene.intersect8_rays(&packet, active, true);
            for (k, h) in hits.iter().enumerate().filter(|(k, _)| active & (1 << k) != 0) {
                out[index(k)] = h.map(|h| h.t);
            }
        }
    }
    out
}

/// The shaded render of [`shaded`] with its primary rays, then its shadow rays, traced in
/// coherent 8-ray packets from 4x2 pixel blocks (one packet per block and sample): the same
/// lanes hit and are lit, so the sum is `shaded`'s up to summation order.
fn shaded_packets(
    scene: &CommittedScene,
    frame: &phongrt_render::CameraFrame,
    width: u32,
    height: u32,
    light: Vec3,
) -> f64 {
    let rows = |by: u32| -> f64 {
        let mut sum = 0.0f64;
        for bx in (0..width).step_by(4) {
            let active = block_lanes(bx, by, width, height);
            for s in 0..SHADED_SPP {
                let rays: [Ray; PACKET8] = std::array::from_fn(|k| {
                    let (x, y) = (bx + k as u32 % 4, by + k as u32 / 4);
                    let (ox, oy) = phongrt_render::sample_offset(x, y, s, SHADED_SPP, 0);
                    Ray::new(frame.eye, frame.direction(x as f32 + ox, y as f32 + oy, width, height))
                });
                let hits = scene.intersect8_rays(&rays, active, true);
                let mut shadow = [Ray::new(Vec3::ZERO, light); PACKET8];
                let mut origins = [None; PACKET8];
                let mut cos = [0.0f32; PACKET8];
                let mut lit = 0u8;
                for (k, (h, ray)) in hits.iter().zip(&rays).enumerate() {
                    let Some(h) = h else { continue };
                    let Some((r, c)) = shadow_ray(ray, h, light) else { continue };
                    (shadow[k], origins[k], cos[k]) = (r, Some(RayOrigin::of_hit(h)), c);
                    lit |= 1 << k;
                }
                let free = lit & !scene.occluded8_rays_from(&shadow, &origins, lit, true);
                for (_, c) in cos.iter().enumerate().filter(|(k, _)| free & (1 << k) != 0) {
                    sum += *c as f64;
                }
            }
        }
        sum
    };
    (0..height.div_ceil(2)).into_par_iter().map(|i| rows(2 * i)).sum()
}

fn depth(scene: &CommittedScene, rays: &[Ray], parallel: bool) -> Vec<Option<f32>> {
    if parallel {
        rays.par_iter().map(|r| scene.intersect1(*r).map(|h| h.t)).collect()
    } else {
        rays.iter().map(|r| scene.intersect1(*r).map(|h| h.t)).collect()
    }
}

/// What `bench_scene` measures with: image size, pre-tessellation budget, Embree's robust mode.
#[derive(Clone, Copy, Debug)]
pub struct BenchOptions {
    pub width: u32,
    pub height: u32,
    /// Pre-tessellations of more triangles than this are skipped.
    pub max_pretess_tris: u64,
    /// Build every scene with `RTC_SCENE_FLAG_ROBUST` (no rays slipping between small triangles).
    pub robust: bool,
}

impl Default for BenchOptions {
    fn default() -> Self {
        BenchOptions {
            width: 256,
            height: 256,
            max_pretess_tris: MAX_PRETESSELLATED_TRIANGLES,
            robust: false,
        }
    }
}

/// The bench's camera, framed on `m`, and its primary rays through pixel centres (row by row).
pub fn primary_rays(
    name: &str,
    m: &Mesh,
    width: u32,
    height: u32,
) -> Result<(phongrt_render::CameraFrame, Vec<Ray>), BenchError> {
    let (lo, hi) = m
        .positions
        .iter()
        .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(a, b), p| (a.min(*p), b.max(*p)));
    let frame = Camera::frame_bounds(lo, hi, width as f32 / height as f32)
        .frame(width as f32 / height as f32)
        .ok_or_else(|| BenchError::Camera(name.to_string()))?;
    let rays = (0..width * height)
        .map(|i| {
            Ray::new(
                frame.eye,
                frame.direction((i % width) as f32 + 0.5, (i / width) as f32 + 0.5, width, height),
            )
        })
        .collect();
    Ok((frame, rays))
}

/// Run `methods` on `m` with primary rays through an `opts.width`×`opts.height` camera framed on it.
pub fn bench_scene(
    name: &str,
    m: &Mesh,
    methods: &[BenchMethod],
    opts: &BenchOptions,
    mut progress: impl FnMut(&str),
) -> Result<Vec<BenchRow>, BenchError> {
    // Compute the camera, its rays and the reference depths (direct f64).
    let device = Device::new()?;
    let (frame, rays) = primary_rays(name, m, opts.width, opts.height)?;
    progress(&format!("{name}: reference (direct f64)"));
    let (refscene, _) = build(&device, m, BenchMethod::DirectF64, opts.robust)?;
    let reference = depth(&refscene, &rays, true);
    drop(refscene);
    // Run each method that fits its budget.
    let view = BenchView { name, frame: &frame, rays: &rays, width: opts.width, height: opts.height };
    let mut rows = Vec::new();
    for &method in methods {
        progress(&format!("{name}: {}", method.name()));
        if let Some(why) = skip_reason(name, m, method, opts.max_pretess_tris) {
            progress(&why);
            continue;
        }
        rows.push(bench_method(&device, m, method, opts.robust, &view, &reference)?);
    }
    Ok(rows)
}

/// Why `method` is not run on `m` (as a progress line), or `None` to run it: a pre-tessellation
/// past 32-bit indices or the triangle budget, a subdivision past its face budget.
fn skip_reason(name: &str, m: &Mesh, method: BenchMethod, max_pretess_tris: u64) -> Option<String> {
    if let BenchMethod::Pretessellated(l) = method {
        let tris = m.indices.len() as u64 * (l as u64) * (l as u64);
        let verts = m.indices.len() as u64 * (l as u64 + 1) * (l as u64 + 2) / 2;
        if verts > u32::MAX as u64 {
            return Some(format!(
                "{name}: {} skipped: {verts} vertices exceed 32-bit indices",
                method.name()
            ));
        }
        if tris > max_pretess_tris {
            // About 85-100 bytes per triangle in Embree's BVH at this size (measured: 860 MB
            // for 1.0e7 triangles): beyond the budget it would not fit beside everything else.
            return Some(format!("{name}: {} skipped: {tris} triangles exceed the budget of {max_pretess_tris} (--max-pretess-tris)", method.name()));
        }
    }
    if method == BenchMethod::Subdivision && m.indices.len() > MAX_SUBDIVISION_FACES {
        return Some(format!(
            "{name}: {} skipped: {} faces exceed the budget of {MAX_SUBDIVISION_FACES}",
            method.name(),
            m.indices.len()
        ));
    }
    None
}

/// What every method of one bench scene traces: the scene's name, camera and primary rays.
struct BenchView<'a> {
    name: &'a str,
    frame: &'a phongrt_render::CameraFrame,
    rays: &'a [Ray],
    width: u32,
    height: u32,
}

/// Build `method`'s scene on `m`, time it and compare its depths with `reference`.
fn bench_method(
    device: &Device,
    m: &Mesh,
    method: BenchMethod,
    robust: bool,
    view: &BenchView,
    reference: &[Option<f32>],
) -> Result<BenchRow, BenchError> {
    // Compute the build time and memory.
    let before = device.memory_bytes().0;
    let t0 = Instant::now();
    let (scene, own) = build(device, m, method, robust)?;
    let build_ms = t0.elapsed().as_secs_f64() * 1e3;
    let embree_bytes = device.memory_bytes().0 - before;
    // Compute the rates, then the depth error of single rays against the reference.
    let (timing, d_one) = time_method(&scene, method, view)?;
    let err = DepthError::new(&d_one, reference);
    let rays = view.rays.len() as f64;
    Ok(BenchRow {
        scene: view.name.to_string(),
        triangles: m.indices.len(),
        method,
        build_ms,
        embree_bytes,
        own_bytes: own,
        mrays_1t: rays / timing.one_s / 1e6,
        mrays_all: rays / timing.all_s / 1e6,
        first_image_ms: build_ms + timing.first_s * 1e3,
        err_t_mean: err.mean,
        err_t_max: err.max,
        err_t_p50: err.p50,
        silhouette_px: err.silhouette_px,
        shaded_ms: timing.shaded_ms,
        mrays_1t_packets: rays / timing.packets_s / 1e6,
        shaded_ms_packets: timing.shaded_ms_packets,
    })
}

/// The times of one built scene: seconds for the depth passes, milliseconds for the shaded
/// renders.
struct MethodTiming {
    /// The first all-core depth pass.
    first_s: f64,
    /// The best all-core depth pass (the first one included).
    all_s: f64,
    /// The best single-thread depth pass.
    one_s: f64,
    /// The best single-thread depth pass in 8-ray packets.
    packets_s: f64,
    shaded_ms: f64,
    shaded_ms_packets: f64,
}

/// Time `scene`'s depth passes and shaded renders, each the best of a few runs (this machine is
/// shared: the best run is the one least disturbed), and check that packets answer as single
/// rays do. Also returns the single-ray depths.
fn time_method(
    scene: &CommittedScene,
    method: BenchMethod,
    view: &BenchView,
) -> Result<(MethodTiming, Vec<Option<f32>>), BenchError> {
    let &BenchView { name, frame, rays, width, height } = view;
    // Time the first image as a user sees it, then each rate.
    let t1 = Instant::now();
    let d_all = depth(scene, rays, true);
    let first_s = t1.elapsed().as_secs_f64();
    let all_s = best_of(TIMING_RUNS, || {
        std::hint::black_box(depth(scene, rays, true));
    })
    .min(first_s);
    let t2 = Instant::now();
    let d_one = depth(scene, rays, false);
    let one_s = t2.elapsed().as_secs_f64().min(best_of(TIMING_RUNS - 1, || {
        std::hint::black_box(depth(scene, rays, false));
    }));
    debug_assert_eq!(d_all, d_one);
    let light = bench_light(frame);
    let shaded_ms = best_of(TIMING_RUNS, || {
        std::hint::black_box(shaded(scene, frame, width, height, light));
    }) * 1e3;
    // The same with packets: the same rays, the same answers.
    let t3 = Instant::now();
    let d_packets = depth_packets(scene, rays, width, height);
    let packets_s = t3.elapsed().as_secs_f64().min(best_of(TIMING_RUNS - 1, || {
        std::hint::black_box(depth_packets(scene, rays, width, height));
    }));
    if d_packets != d_one {
        let differ = d_packets.iter().zip(&d_one).filter(|(a, b)| a != b).count();
        return Err(BenchError::PacketsDiffer { scene: name.to_string(), method: method.name(), differ });
    }
    let shaded_ms_packets = best_of(TIMING_RUNS, || {
        std::hint::black_box(shaded_packets(scene, frame, width, height, light));
    }) * 1e3;
    Ok((MethodTiming { first_s, all_s, one_s, packets_s, shaded_ms, shaded_ms_packets }, d_one))
}

/// The relative depth error `|t - t_ref| / t_ref` over the pixels both hit, and the pixels hit
/// by one and not the other.
struct DepthError {
    mean: f64,
    max: f64,
    p50: f64,
    silhouette_px: usize,
}

impl DepthError {
    fn new(depths: &[Option<f32>], reference: &[Option<f32>]) -> DepthError {
        let (mut sum, mut max, mut n, mut sil) = (0.0f64, 0.0f64, 0usize, 0usize);
        let mut errs = Vec::with_capacity(reference.len());
        for (a, r) in depths.iter().zip(reference) {
            match (a, r) {
                (Some(a), Some(r)) => {
                    let e = ((*a as f64 - *r as f64) / *r as f64).abs();
                    sum += e;
                    max = max.max(e);
                    errs.push(e);
                    n += 1;
                }
                (None, None) => {}
                _ => sil += 1,
            }
        }
        let mean = if n > 0 { sum / n as f64 } else { 0.0 };
        DepthError { mean, max, p50: median(&mut errs), silhouette_px: sil }
    }
}

/// The median of `v` (reordered), 0 when empty.
pub fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let k = v.len() / 2;
    *v.select_nth_unstable_by(k, f64::total_cmp).1
}

/// CSV with a header line.
pub fn to_csv(rows: &[BenchRow]) -> String {
    let mut s = String::from("scene,triangles,method,build_ms,embree_bytes,own_bytes,mrays_1t,mrays_all,first_image_ms,err_t_mean,err_t_max,err_t_p50,silhouette_px,shaded_ms,mrays_1t_packets,shaded_ms_packets\n");
    for r in rows {
        s += &format!(
            "{},{},{},{:.3},{},{},{:.3},{:.3},{:.3},{:.3e},{:.3e},{:.3e},{},{:.3},{:.3},{:.3}\n",
            r.scene,
            r.triangles,
            r.method,
            r.build_ms,
            r.embree_bytes,
            r.own_bytes,
            r.mrays_1t,
            r.mrays_all,
            r.first_image_ms,
            r.err_t_mean,
            r.err_t_max,
            r.err_t_p50,
            r.silhouette_px,
            r.shaded_ms,
            r.mrays_1t_packets,
            r.shaded_ms_packets
        );
    }
    s
}

/// The row of `method` on `scene`.
fn find<'a>(rows: &'a [BenchRow], scene: &str, method: BenchMethod) -> Option<&'a BenchRow> {
    rows.iter().find(|r| r.scene == scene && r.method == method)
}

/// A markdown table; ratios are against flat on the same scene.
pub fn to_markdown(rows: &[BenchRow]) -> String {
    let mut s = String::from("| scene | tris | method | build ms | Embree MB | own MB | Mrays/s 1 thread | Mrays/s 1 thread, packets | Mrays/s all | first image ms | rel t err mean | p50 | max | silhouette px | shaded ms | shaded × flat | shaded ms (packets) | shaded (packets) × flat (packets) |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for r in rows {
        let ratio =
            find(rows, &r.scene, BenchMethod::Flat).map_or(f64::NAN, |f| r.shaded_ms / f.shaded_ms.max(1e-9));
        let ratio_packets = find(rows, &r.scene, BenchMethod::Flat)
            .map_or(f64::NAN, |f| r.shaded_ms_packets / f.shaded_ms_packets.max(1e-9));
        s += &format!(
            "| {} | {} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.1} | {:.1e} | {:.1e} | {:.1e} | {} | {:.1} | {:.2} | {:.1} | {:.2} |\n",
            r.scene,
            r.triangles,
            r.method,
            r.build_ms,
            r.embree_bytes as f64 / 1e6,
            r.own_bytes as f64 / 1e6,
            r.mrays_1t,
            r.mrays_1t_packets,
            r.mrays_all,
            r.first_image_ms,
            r.err_t_mean,
            r.err_t_p50,
            r.err_t_max,
            r.silhouette_px,
            r.shaded_ms,
            ratio,
            r.shaded_ms_packets,
            ratio_packets
        );
    }
    s
}

/// Bytes a method holds: Embree's (memory monitor) plus our own.
fn bytes(r: &BenchRow) -> f64 {
    r.embree_bytes.max(0) as f64 + r.own_bytes as f64
}

/// Timed runs per rate, beside the first image (which also counts for the all-core rate); the
/// best is reported.
const TIMING_RUNS: usize = 3;

/// The shortest wall time of `runs` calls of `f`, in seconds (infinity for no runs).
fn best_of(runs: usize, mut f: impl FnMut()) -> f64 {
    (0..runs)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

/// A memory ratio: two decimals below 10 (`0.31`, `4.20`), whole numbers above (`240`).
fn ratio_text(r: f64) -> String {
    if r < 10.0 {
        format!("{r:.2}")
    } else {
        format!("{r:.0}")
    }
}

/// One scene's direct f32 row and the pre-tessellation levels built, coarsest first.
struct SceneLevels<'a> {
    scene: &'a str,
    direct: &'a BenchRow,
    levels: Vec<(u32, &'a BenchRow)>,
}

/// [`SceneLevels`] per scene, in order.
fn direct_and_levels(rows: &[BenchRow]) -> Vec<SceneLevels<'_>> {
    let mut scenes: Vec<&str> = rows.iter().map(|r| r.scene.as_str()).collect();
    scenes.dedup();
    scenes
        .into_iter()
        .filter_map(|sc| {
            let direct = find(rows, sc, BenchMethod::DirectF32)?;
            let mut levels: Vec<(u32, &BenchRow)> = rows
                .iter()
                .filter(|r| r.scene == sc)
                .filter_map(|r| match r.method {
                    BenchMethod::Pretessellated(l) => Some((l, r)),
                    _ => None,
                })
                .collect();
            levels.sort_by_key(|&(l, _)| l);
            Some(SceneLevels { scene: sc, direct, levels })
        })
        .collect()
}

/// Megabytes of the pre-tessellation at `level`, at the bytes per triangle of `built` (a level
/// built from the same `triangles`-triangle mesh at level `built_level`).
fn mb_at_level(built: &BenchRow, built_level: u32, level: u32, triangles: usize) -> f64 {
    let per_tri = bytes(built) / (triangles as f64 * (built_level as f64).powi(2));
    per_tri * triangles as f64 * (level as f64).powi(2) / 1e6
}

/// Whether `mb` megabytes fit in `mem_total` bytes, as a table cell.
fn fits_text(mb: f64, mem_total: Option<u64>) -> &'static str {
    match mem_total {
        Some(m) => {
            if mb * 1e6 < m as f64 {
                "yes"
            } else {
                "**no**"
            }
        }
        None => "?",
    }
}

/// Per scene: the pre-tessellation that first matches direct Phong's silhouette (no more
/// mismatched pixels than direct f32 against the f64 reference), its memory against direct's,
/// and whether it fits in `mem_total` bytes. A level beyond the build budget is estimated from
/// the bytes per triangle of the largest level built.
pub fn equal_silhouette_summary(rows: &[BenchRow], mem_total: Option<u64>) -> String {
    let mut out = String::from("| scene | direct f32 MB | equal-silhouette pre-tessellation | its MB | × direct | fits in RAM |\n|---|---|---|---|---|---|\n");
    for SceneLevels { scene: sc, direct, levels } in direct_and_levels(rows) {
        let (level, mb, measured) = match levels.iter().find(|(_, r)| r.silhouette_px <= direct.silhouette_px)
        {
            Some((l, r)) => (*l, bytes(r) / 1e6, true),
            None => {
                // Not reached within the budget: the next level up, at the largest built
                // level's bytes per triangle (which only falls slowly with size).
                let Some(&(l, r)) = levels.last() else { continue };
                (l * 2, mb_at_level(r, l, l * 2, direct.triangles), false)
            }
        };
        let direct_mb = bytes(direct) / 1e6;
        out += &format!(
            "| {sc} | {direct_mb:.2} | level {level}{} | {mb:.1}{} | {} | {} |\n",
            if measured { "" } else { " or finer (not built)" },
            if measured { "" } else { " or more (estimated)" },
            ratio_text(mb / direct_mb.max(1e-9)),
            fits_text(mb, mem_total)
        );
    }
    out
}

/// Per scene: the pre-tessellation whose median relative hit-distance error first reaches direct
/// f32's mean, its memory against direct's, and whether it fits in `mem_total` bytes. The median
/// spares the pre-tessellation the few pixels where a coarse surface is hit at a very different
/// depth, so the match is, if anything, generous to it (direct f32's own median is 0: most of its
/// depths round to the f64 reference's). Beyond the levels built, the level is extrapolated from
/// the finest one built with the error of a linear interpolant of a smooth surface, `∝ 1/level²`
/// (the measured medians follow it: 3.9× per doubling on the head and the spheres up to level
/// 64), and its memory at that level's bytes per triangle. Where the finest levels built show
/// the error has stopped following it (it reaches the f32 rounding of Embree's triangle test,
/// about 1e-7, by level 128-192 on the head and the spheres), no level is claimed.
pub fn equal_depth_summary(rows: &[BenchRow], mem_total: Option<u64>) -> String {
    let mut out = String::from("| scene | direct f32 MB | direct f32 mean rel t error | equal-depth pre-tessellation | its MB | × direct | fits in RAM |\n|---|---|---|---|---|---|---|\n");
    for SceneLevels { scene: sc, direct, levels } in direct_and_levels(rows) {
        let target = direct.err_t_mean;
        let direct_mb = bytes(direct) / 1e6;
        let Some(&(finest, finest_row)) = levels.last() else { continue };
        let (level, mb, measured) = match levels.iter().find(|(_, r)| r.err_t_p50 <= target) {
            Some((l, r)) => (*l, bytes(r) / 1e6, true),
            None => {
                if !(target > 0.0) || !(finest_row.err_t_p50 > 0.0) {
                    continue;
                }
                // Has the error stopped following 1/level²? Compare the finest level with the
                // finest one at most 2/3 as fine: falling at less than half the predicted rate
                // means it has reached a floor (the f32 rounding of the triangle test), and no
                // level reaches the target.
                if let Some(&(coarse, coarse_row)) =
                    levels.iter().rev().find(|(l, _)| *l as f64 * 1.5 <= finest as f64)
                {
                    let predicted = (finest as f64 / coarse as f64).powi(2);
                    let measured = coarse_row.err_t_p50 / finest_row.err_t_p50;
                    if measured < 0.5 * predicted {
                        out += &format!(
                            "| {sc} | {direct_mb:.2} | {target:.1e} | none: the median stops falling at {:.1e} (level {coarse}: {:.1e}, level {finest}: {:.1e}) | - | - | no level reaches it |\n",
                            finest_row.err_t_p50,
                            coarse_row.err_t_p50,
                            finest_row.err_t_p50,
                        );
                        continue;
                    }
                }
                let need = finest as f64 * (finest_row.err_t_p50 / target).sqrt();
                // Any whole level can be built: the smallest that reaches the target.
                let level = (need.ceil() as u32).max(finest + 1);
                (level, mb_at_level(finest_row, finest, level, direct.triangles), false)
            }
        };
        out += &format!(
            "| {sc} | {direct_mb:.2} | {target:.1e} | level {level}{} | {mb:.1}{} | {} | {} |\n",
            if measured { "" } else { " (extrapolated, not built)" },
            if measured { "" } else { " (estimated)" },
            ratio_text(mb / direct_mb.max(1e-9)),
            fits_text(mb, mem_total)
        );
    }
    out
}

/// Total physical memory, from `/proc/meminfo` (Linux), in bytes.
pub fn mem_total() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = s.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Register the embedded DejaVu Sans as plotters' "sans-serif" (idempotent).
/// Why a bench plot could not be drawn.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The font compiled into the binary was refused by the plotting library.
    #[error("the embedded DejaVu Sans does not parse")]
    Font,
    /// The plotting library failed to draw.
    #[error("cannot draw the plot: {0}")]
    Draw(String),
    /// The drawn buffer does not have the plot's size.
    #[error("plot buffer size mismatch")]
    Buffer,
}

fn register_plot_font() -> Result<(), PlotError> {
    plotters::style::register_font(
        "sans-serif",
        plotters::style::FontStyle::Normal,
        phongrt_render::text::DEJAVU_SANS,
    )
    .map_err(|_| PlotError::Font)
}

fn plot_error<E: std::fmt::Debug>(e: E) -> PlotError {
    PlotError::Draw(format!("{e:?}"))
}

/// Decades `[10^floor(lo), 10^ceil(hi)]` around the data, at least one decade wide.
fn decades(lo: f64, hi: f64) -> std::ops::Range<f64> {
    let (a, b) = (lo.log10().floor(), hi.log10().ceil());
    10f64.powf(a)..10f64.powf(b.max(a + 1.0))
}

/// The colour of `m` in every plot and panel: the pre-tessellation levels a ramp from light to
/// dark blue (finer is darker), every other method its own hue.
fn series_colour(m: BenchMethod) -> plotters::style::RGBColor {
    let (r, g, b) = match m {
        BenchMethod::Flat => (0, 0, 0),
        BenchMethod::Pretessellated(l) => {
            // Compute the level's place on the ramp: 1 -> 0, 64 and beyond -> 1.
            let f = (l.max(1) as f64).log2().min(6.0) / 6.0;
            let lerp = |a: f64, b: f64| (a + (b - a) * f) as u8;
            (lerp(158.0, 8.0), lerp(202.0, 48.0), lerp(225.0, 107.0))
        }
        BenchMethod::DirectF32 => (214, 39, 40),
        BenchMethod::DirectF32Clustered => (255, 127, 14),
        BenchMethod::AnalyticF32 => (148, 103, 189),
        BenchMethod::DirectF64 => (140, 86, 75),
        BenchMethod::NewtonF32 => (227, 119, 194),
        BenchMethod::UserFloor => (127, 127, 127),
        BenchMethod::Subdivision => (44, 160, 44),
    };
    plotters::style::RGBColor(r, g, b)
}

fn rgb_image(w: u32, h: u32, buf: Vec<u8>) -> Result<image::RgbImage, PlotError> {
    image::RgbImage::from_raw(w, h, buf).ok_or(PlotError::Buffer)
}

/// Error against time, log–log, one panel per scene: each method a point (legend in a column on
/// the right, flat a ring drawn over the others)
/// at (ns per primary ray on one thread, mean relative t error; errors below 1e-9 drawn at 1e-9).
/// Drawn with plotters into an 8-bit sRGB buffer.
pub fn plot(rows: &[BenchRow]) -> Result<image::RgbImage, PlotError> {
    use plotters::prelude::*;
    register_plot_font()?;
    let scenes: Vec<&str> = {
        let mut v: Vec<&str> = rows.iter().map(|r| r.scene.as_str()).collect();
        v.dedup();
        v
    };
    let (pw, ph) = (960u32, 420u32);
    let height = ph * scenes.len().max(1) as u32;
    let mut buf = vec![255u8; pw as usize * height as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (pw, height)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_error)?;
        let panels = root.split_evenly((scenes.len().max(1), 1));
        for (whole, sc) in panels.iter().zip(&scenes) {
            // The legend goes beside the chart, where it can hide no point.
            let (panel, legend) = whole.split_horizontally(pw - LEGEND_WIDTH);
            let rs: Vec<&BenchRow> = rows.iter().filter(|r| r.scene == *sc).collect();
            let pts: Vec<(f64, f64)> =
                rs.iter().map(|r| (1e3 / r.mrays_1t.max(1e-9), r.err_t_mean.max(1e-9))).collect();
            let xr = decades(
                pts.iter().map(|p| p.0).fold(f64::MAX, f64::min),
                pts.iter().map(|p| p.0).fold(f64::MIN, f64::max),
            );
            let yr = decades(1e-9, pts.iter().map(|p| p.1).fold(1e-8, f64::max));
            let mut chart = ChartBuilder::on(&panel)
                .caption(format!("{sc}: mean relative t error vs time per ray"), ("sans-serif", 20))
                .margin(12)
                .margin_right(24)
                .x_label_area_size(42)
                .y_label_area_size(64)
                .build_cartesian_2d(xr.log_scale(), yr.log_scale())
                .map_err(plot_error)?;
            chart
                .configure_mesh()
                .x_desc("ns per primary ray (1 thread)")
                .y_desc("mean relative t error")
                .x_label_formatter(&|v| format!("{v:.0e}"))
                .y_label_formatter(&|v| format!("{v:.0e}"))
                .label_style(("sans-serif", 13))
                .draw()
                .map_err(plot_error)?;
            // Flat is a ring drawn last: a method with flat's time and error (pretess-1 on a
            // fine mesh, the same triangles) would otherwise hide it.
            let flat = |r: &&&BenchRow| r.method == BenchMethod::Flat;
            for (row, p) in rs.iter().zip(&pts).filter(|(r, _)| !flat(r)) {
                let c = series_colour(row.method);
                let marker = if row.method.is_direct() { 6 } else { 4 };
                chart
                    .draw_series(std::iter::once(Circle::new(*p, marker, c.filled())))
                    .map_err(plot_error)?;
            }
            for (row, p) in rs.iter().zip(&pts).filter(|(r, _)| flat(r)) {
                let c = series_colour(row.method);
                chart
                    .draw_series(std::iter::once(Circle::new(*p, 7, c.stroke_width(2))))
                    .map_err(plot_error)?;
            }
            let entries: Vec<(String, RGBColor)> =
                rs.iter().map(|r| (r.method.name().to_string(), series_colour(r.method))).collect();
            draw_legend(&legend, &entries, LegendMark::Point)?;
        }
        root.present().map_err(plot_error)?;
    }
    rgb_image(pw, height, buf)
}

/// Build time and memory against scene size, log–log: two panels, one line per method through
/// its scenes in order of triangle count (legend in a column on the right). Drawn with plotters
/// into an 8-bit sRGB buffer.
pub fn plot_scaling(rows: &[BenchRow]) -> Result<image::RgbImage, PlotError> {
    use plotters::prelude::*;
    register_plot_font()?;
    let (pw, ph) = (960u32, 420u32);
    let mut buf = vec![255u8; pw as usize * ph as usize * 2 * 3];
    let mut methods: Vec<BenchMethod> = Vec::new();
    for r in rows {
        if !methods.contains(&r.method) {
            methods.push(r.method);
        }
    }
    let panels: [(&str, &str, ScalingMetric); 2] = [
        ("BVH build time vs triangles", "build ms", |r| r.build_ms),
        ("memory (Embree + own) vs triangles", "MB", |r| bytes(r) / 1e6),
    ];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (pw, ph * 2)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_error)?;
        for (area, panel) in root.split_evenly((2, 1)).iter().zip(panels) {
            // The legend goes beside the chart, where it can hide no line.
            let (chart, legend) = area.split_horizontally(pw - LEGEND_WIDTH);
            scaling_panel(&chart, panel, rows, &methods)?;
            let entries: Vec<(String, RGBColor)> =
                methods.iter().map(|m| (m.to_string(), series_colour(*m))).collect();
            draw_legend(&legend, &entries, LegendMark::Line)?;
        }
        root.present().map_err(plot_error)?;
    }
    rgb_image(pw, ph * 2, buf)
}

/// What a panel of [`plot_scaling`] plots against the triangle count.
type ScalingMetric = fn(&BenchRow) -> f64;

/// One log–log panel of [`plot_scaling`]: `(title, y axis, metric)` against triangles, a line
/// per method.
fn scaling_panel(
    area: &plotters::drawing::DrawingArea<plotters::prelude::BitMapBackend<'_>, plotters::coord::Shift>,
    (title, ydesc, metric): (&str, &str, ScalingMetric),
    rows: &[BenchRow],
    methods: &[BenchMethod],
) -> Result<(), PlotError> {
    use plotters::prelude::*;
    let pts: Vec<(f64, f64)> =
        rows.iter().map(|r| ((r.triangles as f64).max(1.0), metric(r).max(1e-3))).collect();
    if pts.is_empty() {
        return Ok(());
    }
    // Compute the axes' decades, then draw the mesh, the lines and the legend.
    let xr = decades(
        pts.iter().map(|p| p.0).fold(f64::MAX, f64::min),
        pts.iter().map(|p| p.0).fold(f64::MIN, f64::max),
    );
    let yr = decades(
        pts.iter().map(|p| p.1).fold(f64::MAX, f64::min),
        pts.iter().map(|p| p.1).fold(f64::MIN, f64::max),
    );
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .margin_right(24)
        .x_label_area_size(42)
        .y_label_area_size(64)
        .build_cartesian_2d(xr.log_scale(), yr.log_scale())
        .map_err(plot_error)?;
    chart
        .configure_mesh()
        .x_desc("triangles")
        .y_desc(ydesc)
        .x_label_formatter(&|v| format!("{v:.0e}"))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .label_style(("sans-serif", 13))
        .draw()
        .map_err(plot_error)?;
    for m in methods.iter() {
        let c = series_colour(*m);
        let mut series: Vec<(f64, f64)> =
            rows.iter().zip(&pts).filter(|(r, _)| r.method == *m).map(|(_, p)| *p).collect();
        series.sort_by(|a, b| a.0.total_cmp(&b.0));
        chart.draw_series(LineSeries::new(series.clone(), c.stroke_width(2))).map_err(plot_error)?;
        chart.draw_series(series.iter().map(|p| Circle::new(*p, 3, c.filled()))).map_err(plot_error)?;
    }
    Ok(())
}

/// The width in pixels of the legend column right of each chart.
const LEGEND_WIDTH: u32 = 150;

/// How a legend entry shows its series: a point ([`plot`]) or a line ([`plot_scaling`]).
#[derive(Clone, Copy)]
enum LegendMark {
    Point,
    Line,
}

/// A legend in its own column `area` (right of a chart, so it hides none of the chart's data):
/// one row per `(label, colour)`, top down from the chart's caption.
fn draw_legend(
    area: &plotters::drawing::DrawingArea<plotters::prelude::BitMapBackend<'_>, plotters::coord::Shift>,
    entries: &[(String, plotters::style::RGBColor)],
    mark: LegendMark,
) -> Result<(), PlotError> {
    use plotters::prelude::*;
    let (x, row) = (6i32, 18i32);
    for (i, (label, c)) in entries.iter().enumerate() {
        let y = 44 + row * i as i32;
        match mark {
            // Flat (black) is a ring in the chart, and so here.
            LegendMark::Point if *c == BLACK => area.draw(&Circle::new((x + 8, y), 5, c.stroke_width(2))),
            LegendMark::Point => area.draw(&Circle::new((x + 8, y), 4, c.filled())),
            LegendMark::Line => area.draw(&PathElement::new(vec![(x, y), (x + 16, y)], c.stroke_width(2))),
        }
        .map_err(plot_error)?;
        area.draw(&Text::new(label.clone(), (x + 22, y - 7), ("sans-serif", 12))).map_err(plot_error)?;
    }
    Ok(())
}
