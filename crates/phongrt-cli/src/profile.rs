//! `phongrt bench`'s profile of direct Phong: how many patch tests a primary ray costs, what
//! each kind of test costs, and what is left for Embree's traversal and the callback route.
//!
//! The profile records every call Embree makes into the user geometry while the bench's primary
//! rays are traced on one thread (cluster, ray, `tnear`, `tfar` as Embree passed them), then
//! replays the calls outside Embree: once in the recorded order (the cluster work of a frame:
//! the 8-lane prism test and the patch solves), and the patch solves alone, once per outcome
//! ([`TestOutcome`]: which path of the solver decided), each timed as the best of a few runs.

use std::sync::{Arc, Mutex};
use std::time::Instant;

use glam::Vec3;

use crate::bench::{primary_rays, BenchError, BenchRow};
use phongrt::embree::{
    Device, PatchTest, PhongMesh, PrimHit, Ray, Scene, UserGeometryOptions, UserPrimitives, UserTriangles,
};
use phongrt::phong::{intersect_in_hull_traced, intersect_traced, TestOutcome, V3};
use phongrt::scene::Mesh;

/// One call into a user geometry, as Embree made it.
#[derive(Clone, Copy, Debug)]
struct Call {
    prim: u32,
    org: Vec3,
    dir: Vec3,
    tnear: f32,
    tfar: f32,
}

/// A user geometry that logs each intersect call before answering it.
struct Recording<T> {
    inner: Arc<T>,
    calls: Arc<Mutex<Vec<Call>>>,
}

impl<T: UserPrimitives> UserPrimitives for Recording<T> {
    fn count(&self) -> u32 {
        self.inner.count()
    }

    fn bounds(&self, prim: u32) -> Option<(Vec3, Vec3)> {
        self.inner.bounds(prim)
    }

    fn intersect(&self, prim: u32, org: Vec3, dir: Vec3, tnear: f32, tfar: f32) -> Option<PrimHit> {
        if let Ok(mut calls) = self.calls.lock() {
            calls.push(Call { prim, org, dir, tnear, tfar });
        }
        self.inner.intersect(prim, org, dir, tnear, tfar)
    }
}

/// The calls Embree makes into `prims` while `rays` are traced one by one on this thread.
fn record<T: UserPrimitives>(device: &Device, prims: Arc<T>, rays: &[Ray]) -> Result<Vec<Call>, BenchError> {
    let calls = Arc::new(Mutex::new(Vec::new()));
    let mut scene = Scene::new(device)?;
    scene.attach_user(Recording { inner: prims, calls: calls.clone() }, UserGeometryOptions::default())?;
    scene.commit()?;
    for r in rays {
        std::hint::black_box(scene.intersect1(*r));
    }
    drop(scene);
    let calls = std::mem::take(&mut *calls.lock().unwrap_or_else(|e| e.into_inner()));
    Ok(calls)
}

/// What one kind of patch test costs.
#[derive(Clone, Copy, Debug)]
pub struct OutcomeCost {
    /// The path the tests took.
    pub outcome: TestOutcome,
    /// How many of the recorded tests took it.
    pub tests: usize,
    /// Nanoseconds per test, replayed alone (best of a few runs).
    pub ns_per_test: f64,
}

/// Where direct Phong's primary-ray time goes on one scene.
#[derive(Clone, Debug)]
pub struct Profile {
    /// The scene's name, as in the bench rows.
    pub scene: String,
    /// Patches per Embree primitive.
    pub cluster_size: usize,
    /// Primary rays traced.
    pub rays: usize,
    /// Calls Embree made into the Phong geometry (one per cluster of up to 8 patches).
    pub calls: usize,
    /// Patches in the clusters called (each tested by the 8-lane prism test).
    pub members: usize,
    /// Patch solves (members whose prism the ray entered, before the nearest hit).
    pub tests: usize,
    /// The solves by outcome, in [`TestOutcome::ALL`] order (outcomes never taken left out).
    pub outcomes: Vec<OutcomeCost>,
    /// The recorded calls replayed in order, nanoseconds per ray: the frame's cluster work.
    pub patch_ns_per_ray: f64,
    /// The 8-lane prism test of a cluster alone, nanoseconds per call (`None` for one patch
    /// per primitive).
    pub prism_ns_per_call: Option<f64>,
    /// Calls per ray into the floor's user geometry (the same triangles, a trivial test).
    pub floor_calls_per_ray: f64,
}

/// How long one replay should take at least (seconds), so the clock's resolution and one
/// interruption do not matter.
const REPLAY_SECONDS: f64 = 0.02;

/// The best time of a few runs of `f` over `items`, in nanoseconds per item.
fn replay_ns<C>(items: &[C], f: impl Fn(&C)) -> f64 {
    if items.is_empty() {
        return 0.0;
    }
    let once = |reps: usize| {
        let t = Instant::now();
        for _ in 0..reps {
            items.iter().for_each(&f);
        }
        t.elapsed().as_secs_f64()
    };
    // Calibrate the repetitions on one run, then keep the best of three.
    let first = once(1).max(1e-9);
    let reps = ((REPLAY_SECONDS / first).ceil() as usize).clamp(1, 10_000);
    let best = (0..3).map(|_| once(reps)).fold(f64::INFINITY, f64::min);
    best * 1e9 / (reps * items.len()) as f64
}

/// One recorded patch solve, with its ray.
#[derive(Clone, Copy, Debug)]
struct Solve {
    test: PatchTest,
    org: Vec3,
    dir: Vec3,
}

/// Profile direct Phong (f32, the render path) on `m` with the bench's primary rays, with
/// `cluster_size` patches per Embree primitive.
pub fn profile_scene(
    name: &str,
    m: &Mesh,
    width: u32,
    height: u32,
    cluster_size: usize,
) -> Result<Profile, BenchError> {
    let device = Device::new()?;
    let (_, rays) = primary_rays(name, m, width, height)?;
    let straight = m.straight_edges();
    let mesh = Arc::new(
        PhongMesh::builder(&m.positions, &m.normals, &m.indices)
            .straight_edges(&straight)
            .cluster_size(cluster_size)
            .build()?,
    );
    // Compute the calls Embree makes: into the Phong geometry, and into the floor's.
    let calls = record(&device, mesh.clone(), &rays)?;
    let floor = UserTriangles { positions: m.positions.clone(), indices: m.indices.clone() };
    let floor_calls = record(&device, Arc::new(floor), &rays)?.len();
    // Compute the patch solves of each call (the same answer as the callback's), by outcome.
    let mut by_outcome: Vec<Vec<Solve>> = vec![Vec::new(); TestOutcome::ALL.len()];
    let mut members = 0;
    for c in &calls {
        members += mesh.clusters().get(c.prim as usize).map_or(1, |k| k.members().len());
        mesh.intersect_primitive(c.prim, c.org, c.dir, c.tnear, c.tfar, |test| {
            let k = TestOutcome::ALL.iter().position(|&o| o == test.outcome).unwrap_or(0);
            by_outcome[k].push(Solve { test, org: c.org, dir: c.dir });
        });
    }
    // Time each kind of solve alone, and the calls in their recorded order.
    let solve = |s: &Solve| {
        let Some(p) = mesh.patches().get(s.test.prim as usize) else { return };
        let (o, d) = (V3::from(s.org), V3::from(s.dir));
        let (t0, t1, m) = (s.test.tnear, s.test.tmax, mesh.method());
        if s.test.hull_tested {
            std::hint::black_box(intersect_traced(p, o, d, t0, t1, m));
        } else {
            std::hint::black_box(intersect_in_hull_traced(p, o, d, t0, t1, m));
        }
    };
    let outcomes = TestOutcome::ALL
        .iter()
        .zip(&by_outcome)
        .filter(|(_, group)| !group.is_empty())
        .map(|(&outcome, group)| OutcomeCost {
            outcome,
            tests: group.len(),
            ns_per_test: replay_ns(group, solve),
        })
        .collect();
    let call = |c: &Call| {
        std::hint::black_box(mesh.intersect(c.prim, c.org, c.dir, c.tnear, c.tfar));
    };
    let per_ray = |x: f64| x / rays.len().max(1) as f64;
    Ok(Profile {
        scene: name.to_string(),
        cluster_size,
        rays: rays.len(),
        calls: calls.len(),
        members,
        tests: by_outcome.iter().map(Vec::len).sum(),
        outcomes,
        patch_ns_per_ray: per_ray(replay_ns(&calls, call) * calls.len() as f64),
        prism_ns_per_call: (cluster_size > 1).then(|| {
            replay_ns(&calls, |c| {
                std::hint::black_box(mesh.cluster_entries(c.prim, c.org, c.dir, c.tnear, c.tfar));
            })
        }),
        floor_calls_per_ray: per_ray(floor_calls as f64),
    })
}

/// Nanoseconds per primary ray of `method` on `scene`, one thread, from the bench's rows.
fn ns_per_ray(rows: &[BenchRow], scene: &str, method: &str) -> Option<f64> {
    rows.iter().find(|r| r.scene == scene && r.method == method).map(|r| 1e3 / r.mrays_1t)
}

/// Markdown tables of the profiles: per scene, the split of direct Phong's time per ray (with
/// flat and the floor from `rows`, the same run), then the cost of each kind of patch test.
pub fn to_markdown(profiles: &[Profile], rows: &[BenchRow]) -> String {
    let mut s = String::from(
        "Where direct Phong's primary-ray time goes (1 thread; patch work replayed from the calls \
         Embree made):\n\n\
         | scene | patches per primitive | calls per ray | patches hull-tested per ray | patch solves per ray | direct-f32 ns/ray \
         | cluster work ns/ray | prism test ns/call | traversal + callbacks ns/ray | flat ns/ray \
         | floor ns/ray | floor calls per ray | callback route ns/call |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let na = |x: Option<f64>| x.map_or("?".to_string(), |x| format!("{x:.1}"));
    for p in profiles {
        let direct = ns_per_ray(rows, &p.scene, "direct-f32");
        let flat = ns_per_ray(rows, &p.scene, "flat");
        let floor = ns_per_ray(rows, &p.scene, "user-floor");
        // What a callback costs beyond the native triangle test, spread over the floor's calls.
        let route = floor.zip(flat).map(|(a, b)| (a - b) / p.floor_calls_per_ray.max(1e-9));
        s += &format!(
            "| {} | {} | {:.2} | {:.2} | {:.2} | {} | {:.1} | {} | {} | {} | {} | {:.2} | {} |\n",
            p.scene,
            p.cluster_size,
            p.calls as f64 / p.rays.max(1) as f64,
            p.members as f64 / p.rays.max(1) as f64,
            p.tests as f64 / p.rays.max(1) as f64,
            na(direct),
            p.patch_ns_per_ray,
            p.prism_ns_per_call.map_or("-".to_string(), |x| format!("{x:.1}")),
            na(direct.map(|d| d - p.patch_ns_per_ray)),
            na(flat),
            na(floor),
            p.floor_calls_per_ray,
            na(route),
        );
    }
    s += "\nPatch solves by outcome (each kind replayed alone):\n\n\
          | scene | patches per primitive | outcome | share of solves | ns per solve | ns per ray |\n\
          |---|---|---|---|---|---|\n";
    for p in profiles {
        for o in &p.outcomes {
            s += &format!(
                "| {} | {} | {} | {:.1}% | {:.1} | {:.1} |\n",
                p.scene,
                p.cluster_size,
                o.outcome.name(),
                100.0 * o.tests as f64 / p.tests.max(1) as f64,
                o.ns_per_test,
                o.ns_per_test * o.tests as f64 / p.rays.max(1) as f64,
            );
        }
    }
    s
}
