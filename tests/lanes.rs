//! The lane kernel (`certified_lanes`, 8 rays against one patch at once) against the scalar
//! certified path: every lane it decides has the scalar answer bit for bit (t, u, v equal, the
//! same hit or miss), and every lane it leaves unsure gets the scalar answer and outcome from
//! `unsure_answer` (the analytic method on the kernel's conics where both certificates
//! refused), on the accuracy suite's cases and on 10⁶ camera rays over the bench's sphere; and
//! the mesh's packet route (`PhongMesh::intersect_lanes`, what the packet callbacks call)
//! answers every lane exactly as the single-ray route does.
use glam::{DVec3, Vec3};
use phongrt::embree::{LaneOrigins, OriginPrim, PhongMesh, PrimHit};
use phongrt::phong::accuracy::{generate, Category, SplitMix};
use phongrt::phong::intersect::{
    certified_lanes, certified_lanes_past, hull_of_lanes, intersect_in_hull_traced, LaneDecision, LaneRays,
    LANES,
};
use phongrt::phong::{intersect, intersect_traced, Method, Patch, PatchHit, TestOutcome, DEFAULT_ALPHA};
use phongrt::scene::uv_sphere;

/// How the kernel's lanes came out.
#[derive(Default, Debug)]
struct Tally {
    hits: usize,
    misses: usize,
    unsure: usize,
    /// The unsure lanes by the scalar path's outcome.
    unsure_by: Vec<(TestOutcome, usize)>,
}

impl Tally {
    /// Count an unsure lane whose scalar outcome is `o`.
    fn unsure(&mut self, o: TestOutcome) {
        self.unsure += 1;
        match self.unsure_by.iter_mut().find(|(k, _)| *k == o) {
            Some((_, n)) => *n += 1,
            None => self.unsure_by.push((o, 1)),
        }
    }
}

/// Lane `i` of `rays` through the scalar certified path.
fn scalar(p: &Patch<f32>, rays: &LaneRays, i: usize) -> Option<PatchHit<f32>> {
    let (o, d) = rays.ray(i);
    intersect(p, o, d, rays.tmin[i], rays.tmax[i], Method::Certified)
}

/// Lane `i` of `rays` through the scalar certified path: how it ended.
fn scalar_outcome(p: &Patch<f32>, rays: &LaneRays, i: usize) -> TestOutcome {
    let (o, d) = rays.ray(i);
    intersect_traced(p, o, d, rays.tmin[i], rays.tmax[i], Method::Certified).1
}

/// Run the kernel on `rays` and check each decided lane against the scalar path, bit for bit.
fn check_block(p: &Patch<f32>, rays: &LaneRays, tally: &mut Tally, what: &dyn Fn(usize) -> String) {
    let got = certified_lanes(p, rays);
    for i in 0..LANES {
        let want = scalar(p, rays, i);
        let bits = |h: Option<PatchHit<f32>>| h.map(|h| (h.t.to_bits(), h.u.to_bits(), h.v.to_bits()));
        match got.decision[i] {
            LaneDecision::Unsure => {
                // The scalar path from where the kernel stopped: the answer and outcome of the
                // scalar path past the hull (the kernel's prism passes a superset of the scalar
                // hull's rays, so the scalar path alone may turn a lane away there instead).
                let (o, d) = rays.ray(i);
                let (lo, hi) = (rays.tmin[i], rays.tmax[i]);
                let (h, outcome) = got.unsure_answer(p, i, o, d, lo, hi);
                let past_hull = intersect_in_hull_traced(p, o, d, lo, hi, Method::Certified);
                assert_eq!(
                    (bits(h), outcome),
                    (bits(past_hull.0), past_hull.1),
                    "{}: unsure lane {i}",
                    what(i)
                );
                assert_eq!(bits(h), bits(want), "{}: unsure lane {i}", what(i));
                tally.unsure(scalar_outcome(p, rays, i));
                continue;
            }
            LaneDecision::Hit => tally.hits += 1,
            LaneDecision::Miss => tally.misses += 1,
        }
        assert_eq!(
            bits(got.hit(i)),
            bits(want),
            "{}: lane {i}: kernel {:?}, scalar {want:?}",
            what(i),
            got.hit(i)
        );
    }
}

/// The accuracy suite's cases, every category (grazing ones included): each case's ray and
/// seven neighbours (the origin moved by up to a tenth of the patch size, as a packet's rays
/// are), so that every block mixes hits, misses and hull rejections.
#[test]
fn lane_kernel_matches_the_scalar_path_on_the_accuracy_cases() {
    let mut rng = SplitMix(27);
    for cat in Category::ALL {
        let mut tally = Tally::default();
        for _ in 0..3000 {
            let c = generate(&mut rng, cat);
            let p: Patch<f32> = Patch::new(c.p, c.n, c.alpha);
            let orgs: [DVec3; LANES] = std::array::from_fn(|i| {
                if i == 0 {
                    c.org
                } else {
                    c.org + rng.unit() * (0.1 * c.size * rng.f())
                }
            });
            let rays = LaneRays {
                org: std::array::from_fn(|k| orgs.map(|o| o[k] as f32)),
                dir: std::array::from_fn(|k| [c.dir[k] as f32; LANES]),
                tmin: [0.0; LANES],
                tmax: [f32::INFINITY; LANES],
            };
            check_block(&p, &rays, &mut tally, &|i| format!("{cat:?} case {c:?}, origin {:?}", orgs[i]));
        }
        // Strongly curved patches and grazing rays fail the certificate most often: those
        // lanes go to the scalar path, as in the render.
        println!("{cat:?}: {tally:?}");
        assert!(tally.hits >= 50 && tally.misses >= 50, "{cat:?}: too little decided to judge: {tally:?}");
    }
}

/// 10⁶ camera rays (1000², in the renderer's 4x2 pixel blocks) over the bench's 120-triangle
/// sphere: each block against every patch whose bounds one of its rays enters, through the
/// kernel and through the mesh's packet route, against the scalar path and the single-ray
/// route. The kernel decides the lanes the certificates settle and most of those they refuse
/// (the analytic method from the pencil's member, in the lanes), each as the scalar path does,
/// bit for bit; the few it leaves to the scalar path are the rest.
#[test]
fn lane_kernel_matches_the_scalar_path_on_a_million_camera_rays() {
    let m = uv_sphere(12, 6, 1.0);
    assert_eq!(m.indices.len(), 120);
    let mesh = PhongMesh::new(&m.positions, &m.normals, &m.indices, DEFAULT_ALPHA).unwrap();
    assert!(mesh.tests_lanes_together());
    let boxes: Vec<_> = (0..mesh.patches().len() as u32).map(|i| mesh.patch_bounds(i)).collect();
    let eye = Vec3::new(0.3, 0.2, 3.0);
    let (w, h) = (1000u32, 1000u32);
    let (mut tally, mut hits) = (Tally::default(), 0usize);
    for by in (0..h).step_by(2) {
        for bx in (0..w).step_by(4) {
            let (dirs, rays) = camera_block(eye, (w, h), (bx, by), Vec3::new(0.1, 0.07, 0.0));
            for (prim, b) in boxes.iter().enumerate() {
                let Some((lo, hi)) = *b else { continue };
                if !dirs.iter().any(|&d| enters_box(eye, d, lo, hi)) {
                    continue;
                }
                let p = &mesh.patches()[prim];
                check_block(p, &rays, &mut tally, &|i| {
                    format!("pixel block ({bx}, {by}) lane {i}, patch {prim}")
                });
                hits += check_mesh_route(&mesh, prim as u32, &rays);
            }
        }
    }
    let lanes = tally.hits + tally.misses + tally.unsure;
    assert!(lanes >= 1_000_000 && hits > 100_000, "{lanes} lane tests, {hits} hits: {tally:?}");
    println!("{lanes} lane tests, {hits} hits: {tally:?}");
    assert!(tally.unsure * 2 < lanes, "the kernel decided too few lanes: {tally:?}");
    // With both certificates in the kernel, it leaves to the scalar path few lanes the scalar
    // path certifies (blocks with one lane past the hull, which go scalar whole): under 0.1% of
    // the lanes. The rest it leaves are what neither certifies and the kernel's analytic lanes
    // do not decide (the f64 retry, near tangencies).
    let certified = |o: &TestOutcome| matches!(o, TestOutcome::CertifiedHit | TestOutcome::CertifiedMiss);
    let left: usize = tally.unsure_by.iter().filter(|(o, _)| certified(o)).map(|(_, n)| n).sum();
    assert!(left * 1000 < lanes, "{left} unsure lanes the scalar path certifies: {tally:?}");
    // The lanes both certificates refuse are solved in the kernel too, from their members, but
    // for those it leaves to the scalar path: under 2% of the lanes end in the scalar analytic
    // method (8.6% when the kernel solved none of them).
    let analytic = |o: &TestOutcome| matches!(o, TestOutcome::AnalyticHit | TestOutcome::AnalyticMiss);
    let solved: usize = tally.unsure_by.iter().filter(|(o, _)| analytic(o)).map(|(_, n)| n).sum();
    assert!(solved * 50 < lanes, "{solved} lanes left to the scalar analytic method: {tally:?}");
}

/// The packet route of `mesh` on `rays` against the single-ray route, lane by lane (exact,
/// including the lanes the kernel leaves to the scalar path); returns how many lanes hit.
fn check_mesh_route(mesh: &PhongMesh, prim: u32, rays: &LaneRays) -> usize {
    let got = mesh.intersect_lanes(prim, rays, [true; LANES], &LaneOrigins::NONE);
    let mut hits = 0;
    for (i, got) in got.iter().enumerate() {
        let (o, d) = rays.ray(i);
        let (o, d) = (Vec3::from(o), Vec3::from(d));
        let want: Option<PrimHit> = mesh.intersect_primitive(prim, o, d, rays.tmin[i], rays.tmax[i], |_| {});
        assert_eq!(*got, want, "patch {prim} lane {i}: packet route {got:?}, single {want:?}");
        hits += want.is_some() as usize;
    }
    hits
}

/// Rays leaving sphere-120's surface towards a light (the renderer's shadow rays: from a camera
/// ray's hit, with the hit as their origin) in blocks of 8, against every patch: the mesh's
/// packet route (the origin patch settled without a solve where it can be, the other lanes
/// through the kernel) answers every lane exactly as the single-ray route does.
#[test]
fn packet_route_with_origins_matches_the_single_ray_route() {
    let m = uv_sphere(12, 6, 1.0);
    let mesh = PhongMesh::new(&m.positions, &m.normals, &m.indices, DEFAULT_ALPHA).unwrap();
    let prims = mesh.patches().len() as u32;
    let (eye, light) = (Vec3::new(0.3, 0.2, 3.0), Vec3::new(-0.5, 0.8, 0.3).normalize());
    let nearest = |o: Vec3, d: Vec3| {
        (0..prims)
            .filter_map(|p| mesh.intersect_primitive(p, o, d, 0.0, f32::INFINITY, |_| {}))
            .min_by(|a, b| a.t.total_cmp(&b.t))
    };
    // Compute the shadow rays of a 128² image, each with the hit it leaves from.
    let n = 128u32;
    let shadow: Vec<(Vec3, OriginPrim)> = (0..n * n)
        .filter_map(|i| {
            let (x, y) = ((i % n) as f32 + 0.5, (i / n) as f32 + 0.5);
            let d = Vec3::new(x / n as f32 - 0.5, 0.5 - y / n as f32, -1.0) * 0.9 - Vec3::new(0.1, 0.07, 0.0);
            let h = nearest(eye, d)?;
            Some((eye + d * h.t, OriginPrim { prim: h.prim, u: h.u, v: h.v }))
        })
        .collect();
    let (mut lanes, mut hits) = (0usize, 0usize);
    for block in shadow.chunks(LANES) {
        let at = |i: usize| block[i.min(block.len() - 1)];
        let rays = LaneRays {
            org: std::array::from_fn(|k| std::array::from_fn(|i| at(i).0[k])),
            dir: std::array::from_fn(|k| [light[k]; LANES]),
            tmin: [0.0; LANES],
            tmax: [f32::INFINITY; LANES],
        };
        let active = std::array::from_fn(|i| i < block.len());
        let origin = std::array::from_fn(|i| Some(at(i).1));
        for prim in 0..prims {
            let got = mesh.intersect_lanes(prim, &rays, active, &LaneOrigins::given(origin));
            for (i, &(o, from)) in block.iter().enumerate() {
                let want =
                    mesh.intersect_primitive_from(prim, Some(from), o, light, 0.0, f32::INFINITY, |_| {});
                assert_eq!(got[i], want, "patch {prim}, ray from {o} (origin {from:?})");
                (lanes, hits) = (lanes + 1, hits + want.is_some() as usize);
            }
        }
    }
    println!("{} shadow rays, {lanes} lane tests, {hits} hits", shadow.len());
    assert!(shadow.len() > 5000 && hits > 1000, "{} rays, {hits} hits", shadow.len());
}

/// The kernel in two calls, as the packet route makes them: where the hull test turns every
/// lane away, `certified_lanes` answers every lane a miss; otherwise a lane left out after the
/// hull is a miss, and every other lane answers as the whole kernel does, bit for bit (the lanes
/// do not depend on each other). Camera rays over the bench's sphere, 4x2 blocks.
#[test]
fn a_lane_left_out_past_the_hull_is_a_miss_and_the_others_answer_as_the_whole_kernel() {
    let m = uv_sphere(12, 6, 1.0);
    let mesh = PhongMesh::new(&m.positions, &m.normals, &m.indices, DEFAULT_ALPHA).unwrap();
    let eye = Vec3::new(0.3, 0.2, 3.0);
    let (w, h) = (160u32, 160u32);
    let (mut empty, mut left_out) = (0usize, 0usize);
    for by in (0..h).step_by(2) {
        for bx in (0..w).step_by(4) {
            let (_, rays) = camera_block(eye, (w, h), (bx, by), Vec3::ZERO);
            for p in mesh.patches() {
                let whole = certified_lanes(p, &rays);
                let mut hull = hull_of_lanes(p, &rays);
                if hull.is_empty() {
                    assert_eq!(whole.decision, [LaneDecision::Miss; LANES]);
                    empty += 1;
                    continue;
                }
                let k = (0..LANES).find(|&i| hull.passed(i)).unwrap();
                hull.leave_out(k);
                assert!(!hull.passed(k));
                let part = certified_lanes_past(p, &hull, &rays);
                assert_eq!(part.decision[k], LaneDecision::Miss, "lane {k} left out, yet {hull:?}");
                for i in (0..LANES).filter(|&i| i != k) {
                    // A lane alone past the hull goes to the scalar path either way (`Unsure`),
                    // where the whole kernel may have decided it with the others.
                    if part.decision[i] == LaneDecision::Unsure && whole.decision[i] != LaneDecision::Unsure {
                        continue;
                    }
                    assert_eq!(part.decision[i], whole.decision[i], "block ({bx}, {by}) lane {i}");
                    assert_eq!(part.hit(i).map(|h| h.t.to_bits()), whole.hit(i).map(|h| h.t.to_bits()));
                }
                left_out += 1;
            }
        }
    }
    assert!(empty > 1000 && left_out > 1000, "{empty} blocks turned away, {left_out} with a lane left out");
}

/// The camera rays from `eye` of the 4x2 pixel block at `(bx, by)` of a `w`x`h` image (lane `k`
/// is pixel `(bx + k % 4, by + k / 4)`), their directions shifted by `-shift`: the directions
/// and the lanes.
fn camera_block(
    eye: Vec3,
    (w, h): (u32, u32),
    (bx, by): (u32, u32),
    shift: Vec3,
) -> ([Vec3; LANES], LaneRays) {
    let dirs: [Vec3; LANES] = std::array::from_fn(|k| {
        let (x, y) = (bx + k as u32 % 4, by + k as u32 / 4);
        Vec3::new((x as f32 + 0.5) / w as f32 - 0.5, 0.5 - (y as f32 + 0.5) / h as f32, -1.0) * 0.9 - shift
    });
    let rays = LaneRays {
        org: std::array::from_fn(|k| [eye[k]; LANES]),
        dir: std::array::from_fn(|k| dirs.map(|d| d[k])),
        tmin: [0.0; LANES],
        tmax: [f32::INFINITY; LANES],
    };
    (dirs, rays)
}

/// Whether the ray `org + t dir`, `t > 0`, enters the box `[lo, hi]` (a slab test).
fn enters_box(org: Vec3, dir: Vec3, lo: Vec3, hi: Vec3) -> bool {
    let inv = dir.recip();
    let (a, b) = ((lo - org) * inv, (hi - org) * inv);
    let (near, far) = (a.min(b).max_element().max(0.0), a.max(b).min_element());
    near <= far
}
