//! `phongrt bench`'s profile of direct Phong: how many patch tests a ray costs, what each kind of
//! test costs, and what is left for Embree's traversal and the callback route; for the bench's
//! primary rays and for the shadow rays of its shaded render.
//!
//! The profile records every call Embree makes into the user geometry while the rays are traced
//! on one thread (primitive, ray, `tnear`, `tfar` as Embree passed them), then replays the calls
//! outside Embree: once in the recorded order (the patch work of a frame: with clusters, the
//! 8-lane prism test too), and the patch solves alone, once per outcome ([`TestOutcome`]: which
//! path of the solver decided), each timed as the best of a few runs. The same rays are timed
//! through Embree on the Phong mesh, on Embree's triangles of the same mesh, and on the same
//! triangles as a user geometry with a trivial test (the callback route's floor).

use std::sync::{Arc, Mutex};
use std::time::Instant;

use glam::Vec3;

use crate::bench::{bench_light, primary_rays, shadow_ray, BenchError};
use phongrt::embree::{
    CommittedScene, Device, GeometryOptions, OriginPrim, PatchTest, PhongMesh, PrimHit, Ray, RayOrigin,
    Scene, UserPrimitives, UserTriangles, PACKET8,
};
use phongrt::phong::{intersect_in_hull_traced, intersect_traced, TestOutcome, V3};
use phongrt::scene::Mesh;

/// One call into a user geometry, as Embree made it.
#[derive(Clone, Copy, Debug)]
struct Call {
    prim: u32,
    /// Where the ray starts on the geometry (shadow rays).
    origin: Option<OriginPrim>,
    org: Vec3,
    dir: Vec3,
    tnear: f32,
    tfar: f32,
}

/// A user geometry that logs each intersect call before answering it.
struct Recording<T> {
    inner: Arc<T>,
    calls: CallLog,
}

impl<T: UserPrimitives> UserPrimitives for Recording<T> {
    fn count(&self) -> u32 {
        self.inner.count()
    }

    fn bounds(&self, prim: u32) -> Option<(Vec3, Vec3)> {
        self.inner.bounds(prim)
    }

    fn intersect(&self, prim: u32, org: Vec3, dir: Vec3, tnear: f32, tfar: f32) -> Option<PrimHit> {
        self.intersect_from(prim, None, org, dir, tnear, tfar)
    }

    fn intersect_from(
        &self,
        prim: u32,
        origin: Option<OriginPrim>,
        org: Vec3,
        dir: Vec3,
        tnear: f32,
        tfar: f32,
    ) -> Option<PrimHit> {
        if let Ok(mut calls) = self.calls.lock() {
            calls.push(Call { prim, origin, org, dir, tnear, tfar });
        }
        self.inner.intersect_from(prim, origin, org, dir, tnear, tfar)
    }
}

/// Which rays a profile traces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayKind {
    /// The bench's primary rays, one per pixel centre (`intersect1`).
    Primary,
    /// The shadow rays of the bench's shaded render from those hits (`occluded1_from`, with
    /// the hit each starts on).
    Shadow,
}

impl RayKind {
    /// The name in the tables.
    pub fn name(self) -> &'static str {
        match self {
            RayKind::Primary => "primary",
            RayKind::Shadow => "shadow",
        }
    }
}

/// The calls a [`Recording`] geometry logs, shared with the code that reads them.
type CallLog = Arc<Mutex<Vec<Call>>>;

/// A scene of `prims` whose calls are logged into the returned log.
fn recording_scene<T: UserPrimitives>(
    device: &Device,
    prims: Arc<T>,
) -> Result<(CommittedScene, CallLog), BenchError> {
    let calls = Arc::new(Mutex::new(Vec::new()));
    let mut scene = Scene::new(device)?;
    scene.attach_user(Recording { inner: prims, calls: calls.clone() }, GeometryOptions::default())?;
    let scene = scene.commit()?;
    Ok((scene, calls))
}

/// A traced ray, with the hit it starts on (shadow rays).
type Traced = (Ray, Option<RayOrigin>);

/// Trace `rays` of `kind` through `scene` on this thread.
fn trace(scene: &CommittedScene, rays: &[Traced], kind: RayKind) {
    for (r, origin) in rays {
        match kind {
            RayKind::Primary => {
                std::hint::black_box(scene.intersect1(*r));
            }
            RayKind::Shadow => {
                std::hint::black_box(scene.occluded1_from(*r, *origin));
            }
        }
    }
}

/// The bench's primary rays of `m` (`size`²) traced on `scenes`, or the shadow rays of their hits.
fn rays_of(
    name: &str,
    m: &Mesh,
    size: u32,
    scenes: &Scenes,
    kind: RayKind,
) -> Result<Vec<Traced>, BenchError> {
    let (frame, primary) = primary_rays(name, m, size, size)?;
    let light = bench_light(&frame);
    Ok(match kind {
        RayKind::Primary => primary.into_iter().map(|r| (r, None)).collect(),
        RayKind::Shadow => primary
            .iter()
            .filter_map(|r| {
                let h = scenes.direct.intersect1(*r)?;
                shadow_ray(r, &h, light).map(|(s, _)| (s, Some(RayOrigin::of_hit(&h))))
            })
            .collect(),
    })
}

/// The calls `scene` logs into `log` while `rays` are traced.
fn calls_of(scene: &CommittedScene, log: &Mutex<Vec<Call>>, rays: &[Traced], kind: RayKind) -> Vec<Call> {
    let take = || std::mem::take(&mut *log.lock().unwrap_or_else(|e| e.into_inner()));
    take();
    trace(scene, rays, kind);
    take()
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

/// Where direct Phong's time goes on one scene, for one kind of ray.
#[derive(Clone, Debug)]
pub struct Profile {
    /// The scene's name, as in the bench rows.
    pub scene: String,
    /// The rays traced.
    pub kind: RayKind,
    /// Patches per Embree primitive.
    pub cluster_size: usize,
    /// Rays traced.
    pub rays: usize,
    /// Calls Embree made into the Phong geometry (one per patch, or per cluster of patches).
    pub calls: usize,
    /// Patches in the primitives called (each tested by its hull, or the cluster's prism test).
    pub members: usize,
    /// Patch solves (with clusters: the members whose prism the ray entered, up to the hit).
    pub tests: usize,
    /// The solves by outcome, in [`TestOutcome::ALL`] order (outcomes never taken left out).
    pub outcomes: Vec<OutcomeCost>,
    /// The recorded calls replayed in order, nanoseconds per ray: the frame's patch work.
    pub patch_ns_per_ray: f64,
    /// The 8-lane prism test of a cluster alone, nanoseconds per call (`None` for one patch
    /// per primitive).
    pub prism_ns_per_call: Option<f64>,
    /// The rays through Embree on the Phong mesh, nanoseconds per ray (best of a few runs).
    pub direct_ns_per_ray: f64,
    /// The same rays on Embree's triangles of the mesh.
    pub flat_ns_per_ray: f64,
    /// The same rays on the triangles as a user geometry with a trivial test.
    pub floor_ns_per_ray: f64,
    /// Calls per ray into the floor's user geometry.
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

/// The scenes a profile traces: the Phong mesh (recording), Embree's triangles, the floor
/// (recording, for its calls), and plain scenes of the Phong mesh and of the floor for timing
/// (a recording geometry locks and grows its log on every call).
struct Scenes {
    mesh: Arc<PhongMesh>,
    recording: (CommittedScene, CallLog),
    direct: CommittedScene,
    flat: CommittedScene,
    floor: (CommittedScene, CallLog),
    floor_plain: CommittedScene,
}

impl Scenes {
    fn new(device: &Device, m: &Mesh, cluster_size: usize) -> Result<Self, BenchError> {
        let mesh = Arc::new(
            PhongMesh::builder(&m.positions, &m.normals, &m.indices)
                .alpha(1.0)
                .straight_edges(&m.straight_edges())
                .cluster_size(cluster_size)
                .build()?,
        );
        let mut direct = Scene::new(device)?;
        direct.attach_phong(mesh.clone(), GeometryOptions::default())?;
        let direct = direct.commit()?;
        let mut flat = Scene::new(device)?;
        flat.attach_triangles(&m.positions, &m.indices, GeometryOptions::default())?;
        let flat = flat.commit()?;
        let floor = || UserTriangles { positions: m.positions.clone(), indices: m.indices.clone() };
        let mut floor_plain = Scene::new(device)?;
        floor_plain.attach_user(floor(), GeometryOptions::default())?;
        Ok(Scenes {
            recording: recording_scene(device, mesh.clone())?,
            floor: recording_scene(device, Arc::new(floor()))?,
            floor_plain: floor_plain.commit()?,
            mesh,
            direct,
            flat,
        })
    }
}

/// Profile direct Phong (f32, the render path) on `m` with the bench's primary rays and the
/// shadow rays of its shaded render, with `cluster_size` patches per Embree primitive.
pub fn profile_scene(
    name: &str,
    m: &Mesh,
    width: u32,
    height: u32,
    cluster_size: usize,
) -> Result<Vec<Profile>, BenchError> {
    let device = Device::new()?;
    let (frame, primary) = primary_rays(name, m, width, height)?;
    let scenes = Scenes::new(&device, m, cluster_size)?;
    // Compute the shadow rays of the primary hits.
    let light = bench_light(&frame);
    let shadow: Vec<Traced> = primary
        .iter()
        .filter_map(|r| {
            let h = scenes.direct.intersect1(*r)?;
            shadow_ray(r, &h, light).map(|(s, _)| (s, Some(RayOrigin::of_hit(&h))))
        })
        .collect();
    let primary: Vec<Traced> = primary.into_iter().map(|r| (r, None)).collect();
    Ok(vec![
        profile_rays(name, &scenes, &primary, RayKind::Primary, cluster_size),
        profile_rays(name, &scenes, &shadow, RayKind::Shadow, cluster_size),
    ])
}

/// The profile of `rays` of `kind` on `scenes`.
fn profile_rays(name: &str, scenes: &Scenes, rays: &[Traced], kind: RayKind, cluster_size: usize) -> Profile {
    let mesh = &scenes.mesh;
    let calls = calls_of(&scenes.recording.0, &scenes.recording.1, rays, kind);
    let floor_calls = calls_of(&scenes.floor.0, &scenes.floor.1, rays, kind).len();
    // Compute the patch solves of each call (the same answer as the callback's), by outcome.
    let mut by_outcome: Vec<Vec<Solve>> = vec![Vec::new(); TestOutcome::ALL.len()];
    let mut members = 0;
    for c in &calls {
        members += mesh.clusters().get(c.prim as usize).map_or(1, |k| k.members().len());
        mesh.intersect_primitive_from(c.prim, c.origin, c.org, c.dir, c.tnear, c.tfar, |test| {
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
        std::hint::black_box(mesh.intersect_from(c.prim, c.origin, c.org, c.dir, c.tnear, c.tfar));
    };
    // Time the rays through Embree: each scene as the best of a few runs of all the rays.
    let through =
        |scene: &CommittedScene| replay_ns(&[()], |_| trace(scene, rays, kind)) / rays.len().max(1) as f64;
    let per_ray = |x: f64| x / rays.len().max(1) as f64;
    Profile {
        scene: name.to_string(),
        kind,
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
        direct_ns_per_ray: through(&scenes.direct),
        flat_ns_per_ray: through(&scenes.flat),
        floor_ns_per_ray: through(&scenes.floor_plain),
        floor_calls_per_ray: per_ray(floor_calls as f64),
    }
}

/// Markdown tables of the profiles: per scene and kind of ray, the split of direct Phong's time
/// per ray beside flat and the floor on the same rays, then the cost of each kind of patch test.
pub fn to_markdown(profiles: &[Profile]) -> String {
    let mut s = String::from(
        "Where direct Phong's time goes (1 thread; patch work replayed from the calls Embree made; \
         flat and the floor traced on the same rays):\n\n\
         | scene | rays | patches per primitive | calls per ray | patches hull-tested per ray \
         | patch solves per ray | direct-f32 ns/ray | patch work ns/ray | prism test ns/call \
         | traversal + callbacks ns/ray | flat ns/ray | direct / flat | floor ns/ray | floor calls per ray \
         | callback route ns/call |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for p in profiles {
        let per_ray = |x: usize| x as f64 / p.rays.max(1) as f64;
        // What a callback costs beyond Embree's triangle test, spread over the floor's calls.
        let route = (p.floor_ns_per_ray - p.flat_ns_per_ray) / p.floor_calls_per_ray.max(1e-9);
        s += &format!(
            "| {} | {} | {} | {:.2} | {:.2} | {:.2} | {:.1} | {:.1} | {} | {:.1} | {:.1} | {:.2} | {:.1} | {:.2} | {:.1} |\n",
            p.scene,
            p.kind.name(),
            p.cluster_size,
            per_ray(p.calls),
            per_ray(p.members),
            per_ray(p.tests),
            p.direct_ns_per_ray,
            p.patch_ns_per_ray,
            p.prism_ns_per_call.map_or("-".to_string(), |x| format!("{x:.1}")),
            p.direct_ns_per_ray - p.patch_ns_per_ray,
            p.flat_ns_per_ray,
            p.direct_ns_per_ray / p.flat_ns_per_ray.max(1e-9),
            p.floor_ns_per_ray,
            p.floor_calls_per_ray,
            route,
        );
    }
    s += "\nPatch solves by outcome (each kind replayed alone):\n\n\
          | scene | rays | patches per primitive | outcome | share of solves | ns per solve | ns per ray |\n\
          |---|---|---|---|---|---|---|\n";
    for p in profiles {
        for o in &p.outcomes {
            s += &format!(
                "| {} | {} | {} | {} | {:.1}% | {:.1} | {:.1} |\n",
                p.scene,
                p.kind.name(),
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

/// What [`count_work`] runs: the work whose instructions `scripts/instructions.sh` counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Counted {
    /// The rays through Embree on the Phong mesh (one patch per primitive).
    Phong,
    /// The same rays on Embree's triangles of the mesh.
    Flat,
    /// The recorded patch solves that took this path, replayed alone.
    Outcome(TestOutcome),
    /// The rays through Embree on the Phong mesh in coherent 8-ray packets from 4x2 pixel
    /// blocks (the renderer's), each packet's lanes tested together on a patch.
    PhongPackets,
    /// As [`Counted::PhongPackets`], the lanes tested one by one (the packet route before the
    /// lane kernel: [`UserPrimitives::intersect_packet`]'s default).
    PhongPacketsLaneByLane,
    /// The same packets on Embree's triangles of the mesh.
    FlatPackets,
}

/// A Phong mesh whose packets are tested lane by lane: it keeps
/// [`UserPrimitives::intersect_packet`]'s default.
struct LaneByLane(Arc<PhongMesh>);

impl UserPrimitives for LaneByLane {
    fn count(&self) -> u32 {
        self.0.count()
    }

    fn bounds(&self, prim: u32) -> Option<(Vec3, Vec3)> {
        self.0.bounds(prim)
    }

    #[inline]
    fn intersect(&self, prim: u32, org: Vec3, dir: Vec3, tnear: f32, tfar: f32) -> Option<PrimHit> {
        self.0.intersect(prim, org, dir, tnear, tfar)
    }

    #[inline]
    fn intersect_from(
        &self,
        prim: u32,
        origin: Option<OriginPrim>,
        org: Vec3,
        dir: Vec3,
        tnear: f32,
        tfar: f32,
    ) -> Option<PrimHit> {
        self.0.intersect_from(prim, origin, org, dir, tnear, tfar)
    }
}

/// The rays of `kind` per pixel of the bench's `size`² image, row-major (`None`: a pixel with
/// no shadow ray), each shadow ray with the hit it starts from.
fn pixel_rays(scenes: &Scenes, primary: Vec<Ray>, light: Vec3, kind: RayKind) -> Vec<Option<Traced>> {
    match kind {
        RayKind::Primary => primary.into_iter().map(|r| Some((r, None))).collect(),
        RayKind::Shadow => primary
            .iter()
            .map(|r| {
                let h = scenes.direct.intersect1(*r)?;
                shadow_ray(r, &h, light).map(|(s, _)| (s, Some(RayOrigin::of_hit(&h))))
            })
            .collect(),
    }
}

/// One 8-ray packet: the rays, where each starts (shadow rays) and the active lanes.
type Packet = ([Ray; PACKET8], [Option<RayOrigin>; PACKET8], u8);

/// `rays` (one per pixel of a `size`² image, row-major) as the renderer's coherent 8-ray
/// packets from 4x2 pixel blocks, the pixels without a ray inactive; shadow rays with their
/// origins, as the renderer traces them.
fn packets_of(rays: &[Option<Traced>], size: u32) -> Vec<Packet> {
    let at = |x: u32, y: u32| if x < size && y < size { rays[(y * size + x) as usize] } else { None };
    let mut packets = Vec::new();
    for by in (0..size).step_by(2) {
        for bx in (0..size).step_by(4) {
            let lane: [Option<Traced>; PACKET8] =
                std::array::from_fn(|k| at(bx + k as u32 % 4, by + k as u32 / 4));
            let active = lane.iter().enumerate().fold(0u8, |m, (k, r)| m | ((r.is_some() as u8) << k));
            let Some((any, _)) = lane.iter().flatten().next().copied() else { continue };
            packets.push((
                lane.map(|r| r.map_or(any, |(r, _)| r)),
                lane.map(|r| r.and_then(|(_, o)| o)),
                active,
            ));
        }
    }
    packets
}

/// Trace `packets` of `kind` through `scene`.
fn trace_packets(scene: &CommittedScene, packets: &[Packet], kind: RayKind) {
    for (rays, origins, active) in packets {
        match kind {
            RayKind::Primary => {
                std::hint::black_box(scene.intersect8_rays(rays, *active, true));
            }
            RayKind::Shadow => {
                std::hint::black_box(scene.occluded8_rays_from(rays, origins, *active, true));
            }
        }
    }
}

/// Set up `m`'s scenes and rays of `kind` (the bench's, `size`²), then run `what` once inside
/// `counted_work` (private), the function a callgrind run collects alone. Returns how many rays (or
/// patch solves, for [`Counted::Outcome`]) it ran.
pub fn count_work(
    name: &str,
    m: &Mesh,
    size: u32,
    kind: RayKind,
    what: Counted,
) -> Result<usize, BenchError> {
    let device = Device::new()?;
    // The packet modes trace the bench's primary rays (and their shadow rays) as packets.
    let (frame, primary_for_packets) = primary_rays(name, m, size, size)?;
    let light = bench_light(&frame);
    let scenes = Scenes::new(&device, m, 1)?;
    let rays = rays_of(name, m, size, &scenes, kind)?;
    let solves: Vec<Solve> = match what {
        Counted::Outcome(outcome) => {
            let mut solves = Vec::new();
            for c in calls_of(&scenes.recording.0, &scenes.recording.1, &rays, kind) {
                scenes.mesh.intersect_primitive_from(
                    c.prim,
                    c.origin,
                    c.org,
                    c.dir,
                    c.tnear,
                    c.tfar,
                    |test| {
                        if test.outcome == outcome {
                            solves.push(Solve { test, org: c.org, dir: c.dir });
                        }
                    },
                );
            }
            solves
        }
        _ => Vec::new(),
    };
    let own;
    let packets = match what {
        Counted::PhongPackets => Some(&scenes.direct),
        Counted::PhongPacketsLaneByLane => {
            own = lane_by_lane_scene(&device, &scenes.mesh)?;
            Some(&own)
        }
        Counted::FlatPackets => Some(&scenes.flat),
        _ => None,
    };
    if let Some(scene) = packets {
        let rays = pixel_rays(&scenes, primary_for_packets, light, kind);
        counted_packets(scene, &packets_of(&rays, size), kind);
        return Ok(rays.iter().flatten().count());
    }
    let scene = if what == Counted::Flat { &scenes.flat } else { &scenes.direct };
    counted_work(scene, &scenes.mesh, &rays, kind, &solves, matches!(what, Counted::Outcome(_)));
    Ok(if matches!(what, Counted::Outcome(_)) { solves.len() } else { rays.len() })
}

/// `mesh` as a user geometry whose packets are tested lane by lane ([`LaneByLane`]).
fn lane_by_lane_scene(device: &Device, mesh: &Arc<PhongMesh>) -> Result<CommittedScene, BenchError> {
    let mut scene = Scene::new(device)?;
    scene.attach_user(LaneByLane(mesh.clone()), GeometryOptions::default())?;
    Ok(scene.commit()?)
}

/// The counted work of [`count_work`] for packets. Never inlined (callgrind's
/// `--toggle-collect=*counted_packets*`).
#[inline(never)]
fn counted_packets(scene: &CommittedScene, packets: &[Packet], kind: RayKind) {
    trace_packets(scene, packets, kind);
}

/// The counted work of [`count_work`]: `rays` through `scene`, or the `solves` on `mesh` when
/// `replay`. Never inlined, so that callgrind's `--toggle-collect=*counted_work*` finds it.
#[inline(never)]
fn counted_work(
    scene: &CommittedScene,
    mesh: &PhongMesh,
    rays: &[Traced],
    kind: RayKind,
    solves: &[Solve],
    replay: bool,
) {
    if !replay {
        trace(scene, rays, kind);
        return;
    }
    for s in solves {
        let Some(p) = mesh.patches().get(s.test.prim as usize) else { continue };
        let (o, d) = (V3::from(s.org), V3::from(s.dir));
        let (t0, t1, method) = (s.test.tnear, s.test.tmax, mesh.method());
        if s.test.hull_tested {
            std::hint::black_box(intersect_traced(p, o, d, t0, t1, method));
        } else {
            std::hint::black_box(intersect_in_hull_traced(p, o, d, t0, t1, method));
        }
    }
}

/// Shadow rays' patch tests of one kind ([`origin_tests`]: on the patch a ray starts on;
/// [`neighbour_tests`]: on the others, past the hull), by the outcome their full solve has: how
/// many there are, and how many of them a rule leaves out.
#[derive(Clone, Copy, Debug)]
pub struct OriginTests {
    /// The outcome of the full solve.
    pub outcome: TestOutcome,
    /// Calls of this kind with this outcome.
    pub tests: usize,
    /// Of those, the solves the rule leaves out (for [`origin_tests`], the origin skip's,
    /// proved not to hit; for [`neighbour_tests`], a measurement's).
    pub skipped: usize,
}

/// The shadow rays of `m`'s shaded render (the bench's, `size`², one patch per primitive) and,
/// by outcome, the calls Embree makes on the patch each starts on: returns the ray count and the
/// outcomes taken.
pub fn origin_tests(name: &str, m: &Mesh, size: u32) -> Result<(usize, Vec<OriginTests>), BenchError> {
    shadow_tests(name, m, size, |mesh, c, _| {
        let origin = c.origin.filter(|o| o.prim == c.prim)?;
        let mut solved = false;
        mesh.intersect_primitive_from(c.prim, Some(origin), c.org, c.dir, c.tnear, c.tfar, |_| solved = true);
        Some(!solved)
    })
}

/// As [`origin_tests`], for the calls on the other patches (those a shadow ray does not start
/// on) past the hull test: how many there are, by outcome, and how many a rule that left out
/// every patch lying wholly under the tangent plane at the ray's origin (the ray leaving that
/// plane upwards; or over it, leaving downwards) would leave out. A measurement, not a proof:
/// the plane and the patch's exact range over it (`quadratic_range`) in f64, with a margin of
/// 1e-9 of the normal's length for rounding.
pub fn neighbour_tests(name: &str, m: &Mesh, size: u32) -> Result<(usize, Vec<OriginTests>), BenchError> {
    use phongrt::phong::patch::quadratic_range;
    shadow_tests(name, m, size, |mesh, c, outcome| {
        let origin = c.origin.filter(|o| o.prim != c.prim && outcome != TestOutcome::HullReject)?;
        // The two patches in f64 (exactly: every field of an f32 patch converts).
        let patch = |prim: u32| mesh.patches().get(prim as usize).map(|p| p.cast::<f64>());
        let (p, q) = (patch(origin.prim)?, patch(c.prim)?);
        // Compute the origin patch's tangent plane at (u, v), in world space.
        let (u, v) = (origin.u as f64, origin.v as f64);
        let (pu, pv) = p.partials_local(u, v);
        let (n, p0) = (pu.cross(pv), p.eval(u, v));
        // Compute the other patch's height over that plane, a quadratic in its (u, v).
        let k = q.coefficients().map(|x| x.dot(n) * q.scale());
        let (lo, hi) = quadratic_range([k[0], k[1], k[2], k[3], k[4], k[5] + (q.center() - p0).dot(n)]);
        // Compute the origin's height and the ray's rise.
        let (org, dir) = (V3::from(c.org).cast::<f64>(), V3::from(c.dir).cast::<f64>());
        let (h, rise) = ((org - p0).dot(n), dir.dot(n));
        let margin = 1e-9 * n.length();
        Some(
            (rise > margin * dir.length() && h > hi + margin)
                || (rise < -margin * dir.length() && h < lo - margin),
        )
    })
}

/// The calls of the bench's shadow rays that `rule` takes (`Some`), given each call and the
/// outcome of its full solve, by that outcome, and how many of those it says are left out
/// (`Some(true)`).
fn shadow_tests(
    name: &str,
    m: &Mesh,
    size: u32,
    rule: impl Fn(&PhongMesh, &Call, TestOutcome) -> Option<bool>,
) -> Result<(usize, Vec<OriginTests>), BenchError> {
    let device = Device::new()?;
    let scenes = Scenes::new(&device, m, 1)?;
    let rays = rays_of(name, m, size, &scenes, RayKind::Shadow)?;
    let mut out: Vec<OriginTests> =
        TestOutcome::ALL.iter().map(|&outcome| OriginTests { outcome, tests: 0, skipped: 0 }).collect();
    let mesh = &scenes.mesh;
    for c in calls_of(&scenes.recording.0, &scenes.recording.1, &rays, RayKind::Shadow) {
        let mut full = None;
        mesh.intersect_primitive(c.prim, c.org, c.dir, c.tnear, c.tfar, |t| full = Some(t.outcome));
        let Some(outcome) = full else { continue };
        let Some(skipped) = rule(mesh, &c, outcome) else { continue };
        let Some(k) = TestOutcome::ALL.iter().position(|&x| x == outcome) else { continue };
        out[k].tests += 1;
        out[k].skipped += skipped as usize;
    }
    out.retain(|o| o.tests > 0);
    Ok((rays.len(), out))
}
