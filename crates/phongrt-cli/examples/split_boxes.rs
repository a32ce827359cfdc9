//! How many user-geometry calls Embree makes per ray with one box per Phong patch, and with
//! each patch split into four sub-patches (its triangle cut at the edge midpoints), each with a
//! box of its own: whether tighter boxes would spare the callbacks (they do not; README "Speed").
//!
//! Run: `cargo run --release -p phongrt-cli --example split_boxes -- SCENE`, SCENE `sphere-120`
//! or an OBJ file (its first mesh). The rays are the bench's: 256² primary rays, and the shadow
//! rays of their hits towards the bench's light. A geometry of boxes alone (its test counts the
//! call and reports no hit) is traced on each ray with the ray's interval cut just past its hit
//! on the Phong surface (for a shadow ray, its first blocker), as a real scene's hits cut it.
//! Both kinds of box are the patch's points on a grid (24 steps an edge) padded by 1% of the
//! box's size: alike for both, a little looser than the exact boxes the Phong geometry gives
//! Embree. "useful" counts the calls on the box of the (sub-)patch the ray really hits.
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};

use anyhow::{anyhow, Context};
use glam::Vec3;
use phongrt::embree::{Device, GeometryOptions, PhongMesh, PrimHit, Ray, Scene, UserPrimitives};
use phongrt::scene::{load_obj, uv_sphere, LoadOptions, Mesh};
use phongrt_cli::bench::{bench_light, primary_rays, shadow_ray};

thread_local! {
    /// The patch and `(u, v)` the traced ray really hits, if any.
    static TARGET: std::cell::Cell<Option<(u32, f32, f32)>> = const { std::cell::Cell::new(None) };
}

/// The sub-triangles of the domain, as `(u, v)` corners: the whole, or its four halves' cut.
const WHOLE: [[(f32, f32); 3]; 1] = [[(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)]];
const QUARTERS: [[(f32, f32); 3]; 4] = [
    [(0.0, 0.0), (0.5, 0.0), (0.0, 0.5)],
    [(0.5, 0.0), (1.0, 0.0), (0.5, 0.5)],
    [(0.0, 0.5), (0.5, 0.5), (0.0, 1.0)],
    [(0.5, 0.0), (0.5, 0.5), (0.0, 0.5)],
];

/// Which of the `parts` sub-triangles `(u, v)` lies in (the middle one where none of the
/// corner ones holds it).
fn part_of(u: f32, v: f32, parts: usize) -> usize {
    match (parts, u >= 0.5, v >= 0.5, 1.0 - u - v >= 0.5) {
        (1, ..) => 0,
        (_, true, ..) => 1,
        (_, _, true, _) => 2,
        (_, _, _, true) => 0,
        _ => 3,
    }
}

/// Boxes alone: a call is counted and never hits.
struct Boxes {
    boxes: Vec<(Vec3, Vec3)>,
    /// The patch and sub-triangle of each box.
    owner: Vec<(u32, usize)>,
    parts: usize,
    calls: AtomicU64,
    useful: AtomicU64,
}

impl UserPrimitives for Boxes {
    fn count(&self) -> u32 {
        self.boxes.len() as u32
    }
    fn bounds(&self, prim: u32) -> Option<(Vec3, Vec3)> {
        self.boxes.get(prim as usize).copied()
    }
    fn intersect(&self, prim: u32, _org: Vec3, _dir: Vec3, _tnear: f32, _tfar: f32) -> Option<PrimHit> {
        self.calls.fetch_add(1, Ordering::Relaxed);
        let (patch, part) = *self.owner.get(prim as usize)?;
        if let Some((p, u, v)) = TARGET.with(|t| t.get()) {
            if p == patch && part_of(u, v, self.parts) == part {
                self.useful.fetch_add(1, Ordering::Relaxed);
            }
        }
        None
    }
}

/// The boxes of `mesh`'s patches, one per sub-triangle of `parts`.
fn boxes(mesh: &PhongMesh, triangles: u32, parts: &[[(f32, f32); 3]]) -> Boxes {
    let (mut boxes, mut owner) = (Vec::new(), Vec::new());
    let grid = 24;
    for prim in 0..triangles {
        for (k, s) in parts.iter().enumerate() {
            let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
            for i in 0..=grid {
                for j in 0..=grid - i {
                    let (a, b) = (i as f32 / grid as f32, j as f32 / grid as f32);
                    let c = 1.0 - a - b;
                    let (u, v) = (c * s[0].0 + a * s[1].0 + b * s[2].0, c * s[0].1 + a * s[1].1 + b * s[2].1);
                    if let Some((p, _)) = mesh.surface_point(prim, u, v) {
                        (lo, hi) = (lo.min(p), hi.max(p));
                    }
                }
            }
            let pad = (hi - lo).max_element() * 0.01 + 1e-6;
            boxes.push((lo - pad, hi + pad));
            owner.push((prim, k));
        }
    }
    Boxes { boxes, owner, parts: parts.len(), calls: AtomicU64::new(0), useful: AtomicU64::new(0) }
}

/// The bench's sphere of `sphere-N` triangles, or an OBJ file's first mesh.
fn mesh(scene: &str) -> anyhow::Result<Mesh> {
    if let Some(n) = scene.strip_prefix("sphere-") {
        let tris: usize = n.parse().with_context(|| format!("{scene}: not sphere-<triangles>"))?;
        return (3..=256)
            .map(|s| uv_sphere(s, (s / 2).max(2), 1.0))
            .find(|m| m.indices.len() == tris)
            .ok_or_else(|| anyhow!("{scene}: no bench sphere has {tris} triangles"));
    }
    let s = load_obj(Path::new(scene), &LoadOptions::default())?;
    s.meshes.into_iter().next().ok_or_else(|| anyhow!("{scene}: no mesh"))
}

fn main() -> anyhow::Result<()> {
    // On one thread of a pool that sets flush-to-zero and denormals-are-zero, as every thread
    // that traces rays.
    phongrt::embree::thread_pool_builder().num_threads(1).build()?.install(run)
}

fn run() -> anyhow::Result<()> {
    let scene = std::env::args().nth(1).context("usage: split_boxes SCENE (sphere-120 or an OBJ file)")?;
    let m = mesh(&scene)?;
    let device = Device::new()?;
    // The bench's Phong mesh (alpha 1), traced for the rays' real hits.
    let phong = PhongMesh::builder(&m.positions, &m.normals, &m.indices).alpha(1.0).build()?;
    let (frame, primary) = primary_rays(&scene, &m, 256, 256)?;
    let light = bench_light(&frame);
    let cut = |r: Ray, t: Option<f32>| t.map_or(r, |t| r.with_range(r.tnear, t * 1.0001));
    let mut s = Scene::new(&device)?;
    s.attach_phong(phong.clone(), GeometryOptions::default())?;
    let direct = s.commit()?;
    for (name, parts) in [("one box a patch", &WHOLE[..]), ("four boxes a patch", &QUARTERS[..])] {
        let b = std::sync::Arc::new(boxes(&phong, m.indices.len() as u32, parts));
        let mut s = Scene::new(&device)?;
        s.attach_user(b.clone(), GeometryOptions::default())?;
        let s = s.commit()?;
        let mut counts = Vec::new();
        for shadow in [false, true] {
            let mut rays = 0u64;
            for r in &primary {
                let h = direct.intersect1(*r);
                let (ray, hit) = if shadow {
                    let Some((sr, _)) = h.and_then(|h| shadow_ray(r, &h, light)) else { continue };
                    (sr, direct.intersect1(sr))
                } else {
                    (*r, h)
                };
                TARGET.with(|t| t.set(hit.map(|h| (h.prim_id, h.u, h.v))));
                s.intersect1(cut(ray, hit.map(|h| h.t)));
                rays += 1;
            }
            let calls = b.calls.swap(0, Ordering::Relaxed) as f64 / rays.max(1) as f64;
            let useful = b.useful.swap(0, Ordering::Relaxed) as f64 / rays.max(1) as f64;
            counts.push(format!("{calls:.3} calls a ray ({useful:.3} useful)"));
        }
        println!("{scene}, {name}: primary rays {}, shadow rays {}", counts[0], counts[1]);
    }
    Ok(())
}
