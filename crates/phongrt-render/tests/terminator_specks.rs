//! No dark specks at the terminator: on the convex demo sphere under one directional light, a
//! point that the shading normal calls lit is never in its own shadow with the default rule,
//! while the former rule (`lift-ng`) blocks some (the cone points where the patches' true normals
//! meet 6–8° apart); and the pass through the mesh's own bumps leaks no light: the shadow of
//! another object, and a mesh's shadow onto itself across a real gap, stay; and the pass, cut at
//! its reach, answers as the walk over the whole ray did.
mod common;

use glam::Vec3;
use phongrt::embree::{Device, Ray};
use phongrt::phong::DEFAULT_ALPHA;
use phongrt::scene::{load_obj, uv_sphere, LoadOptions, Mesh, Model};
use phongrt_render::world::{SurfacePoint, MAX_BUMP_HITS};
use phongrt_render::{ObjectMode, RayCounts, Terminator, World};

fn demo_sphere() -> Model {
    let path = common::root().join("scenes/sphere_lowpoly.obj");
    load_obj(&path, &LoadOptions::default()).unwrap()
}

fn phong_world(device: &Device, scene: &Model, terminator: Terminator) -> World {
    World::builder(device, scene)
        .mode(ObjectMode::Phong { alpha: DEFAULT_ALPHA })
        .terminator(terminator)
        .build()
        .unwrap()
}

/// `n` directions spread over the unit sphere (a Fibonacci lattice).
fn directions(n: usize) -> impl Iterator<Item = Vec3> {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..n).map(move |k| {
        let z = 1.0 - 2.0 * (k as f32 + 0.5) / n as f32;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = golden * k as f32;
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    })
}

/// Shading points of object 0's unit sphere about `center` in `view`, seen from every side (rays
/// towards `center` from `n` directions at distance 10), with the light `l`: `(points the shading
/// normal calls lit by more than `min_cos`, how many of them the hard shadow in `w` blocks)`.
/// `w` is `view` with more geometry after object 0's sphere, so its own faces keep their ids.
fn blocked_lit_points(
    view: &World,
    w: &World,
    center: Vec3,
    l: Vec3,
    min_cos: f32,
    n: usize,
) -> (usize, usize) {
    let (mut lit, mut blocked) = (0, 0);
    let mut counts = RayCounts::default();
    for d in directions(n) {
        let ray = Ray::new(center + 10.0 * d, -d);
        let Some(hit) = view.scene().intersect1(ray) else { continue };
        if hit.geom_id != 0 {
            continue;
        }
        let sp = view.objects()[0].surface_point(&hit, &ray, view.shading(), view.terminator());
        // Only the unit sphere about `center` (its Phong surface bulges up to 2% out), not a
        // second one in the same mesh.
        if sp.n.dot(l) <= min_cos || sp.n.dot(l).is_nan() || (sp.p - center).length() > 1.1 {
            continue;
        }
        lit += 1;
        let o = w.shadow_origin(&sp, l, &mut counts);
        blocked += !w.hard_shadow_clear(&sp, o, l, f32::INFINITY, &mut counts) as usize;
    }
    (lit, blocked)
}

/// The default key light.
fn key_light(w: &World) -> Vec3 {
    match w.lights()[0] {
        phongrt_render::Light::Directional { direction, .. } => direction,
        _ => unreachable!("the default light is directional"),
    }
}

#[test]
fn lit_points_of_the_demo_sphere_are_not_in_their_own_shadow() {
    let device = Device::new().unwrap();
    let scene = demo_sphere();
    let (new, old) =
        (phong_world(&device, &scene, Terminator::Lift), phong_world(&device, &scene, Terminator::LiftNg));
    let mut specks = (0, 0);
    // The key light, and lights all round (each one meets other cone points at its terminator).
    let lights: Vec<Vec3> = std::iter::once(key_light(&new)).chain(directions(24)).collect();
    for &l in &lights {
        let (lit, b_new) = blocked_lit_points(&new, &new, Vec3::ZERO, l, 0.0, 40_000);
        let (_, b_old) = blocked_lit_points(&old, &old, Vec3::ZERO, l, 0.0, 40_000);
        assert!(lit > 10_000, "{lit} lit points");
        specks = (specks.0 + b_new, specks.1 + b_old);
    }
    println!("blocked lit points over {} lights: lift {}, lift-ng {}", lights.len(), specks.0, specks.1);
    assert_eq!(specks.0, 0, "{} lit points of a convex sphere in its own shadow", specks.0);
    assert!(specks.1 > 0, "the former rule shows no specks either: the check cannot fail");
}

/// Two meshes' triangles as one mesh (one object), the second moved by `offset`.
fn merged(a: &Mesh, b: &Mesh, offset: Vec3) -> Mesh {
    let mut p = a.positions.clone();
    let mut n = a.normals.clone();
    let mut i = a.indices.clone();
    let base = p.len() as u32;
    p.extend(b.positions.iter().map(|q| *q + offset));
    n.extend(&b.normals);
    i.extend(b.indices.iter().map(|t| t.map(|k| k + base)));
    Mesh::from_triangles("pair", p, n, i)
}

#[test]
fn a_mesh_shadows_itself_across_a_real_gap() {
    let device = Device::new().unwrap();
    // Two low-poly spheres of radius 1 in one mesh, 0.25 apart along the light: the lower one's
    // cap under the upper one is in shadow, though both belong to the same object.
    let s = uv_sphere(12, 6, 1.0);
    let l = Vec3::new(0.3, 1.0, 0.2).normalize();
    let w = phong_world(&device, &Model::from_mesh(merged(&s, &s, l * 2.25)), Terminator::Lift);
    let view = phong_world(&device, &Model::from_mesh(s.clone()), Terminator::Lift);
    let bound = w.objects()[0].geometry.phong().unwrap().bump_bound(0).unwrap();
    println!("bump bound (height, reach) of a patch: {bound:?}");
    assert!(bound.0 < 0.25, "the bound {bound:?} spans the gap: the test proves nothing");
    // The lower sphere's points facing the upper one (their n·l > 0.9) are all blocked.
    let (lit, blocked) = blocked_lit_points(&view, &w, Vec3::ZERO, l, 0.9, 40_000);
    println!("{blocked} of {lit} points under the upper sphere in shadow");
    assert!(lit > 500, "{lit} points");
    assert_eq!(blocked, lit, "light leaks through the gap onto {} points", lit - blocked);
}

#[test]
fn another_objects_contact_shadow_stays() {
    let device = Device::new().unwrap();
    // The demo sphere, and a second sphere (another object) resting on it from the light's side,
    // touching it (gap 1e-3): the first sphere's cap under it is in shadow.
    let l = Vec3::new(-0.5, 0.7, 0.6).normalize();
    let mut scene = demo_sphere();
    let view = phong_world(&device, &scene, Terminator::Lift);
    let mut other = uv_sphere(12, 6, 1.0);
    other.positions.iter_mut().for_each(|q| *q += l * 2.001);
    other.name = "other".into();
    scene.meshes.push(other);
    let w = phong_world(&device, &scene, Terminator::Lift);
    let (lit, blocked) = blocked_lit_points(&view, &w, Vec3::ZERO, l, 0.9, 40_000);
    println!("{blocked} of {lit} points under the other sphere in shadow");
    assert!(lit > 500, "{lit} points");
    assert_eq!(blocked, lit, "light leaks under the other object onto {} points", lit - blocked);
}

#[test]
fn flat_offset_height_is_the_largest_offset_on_the_domain() {
    use phongrt::phong::flat_offset_height;
    // Against a fine grid, for offsets that peak on an edge, inside, or change sign.
    for (a, b, c) in [
        (1.0, 1.0, 1.0),
        (-0.3, 0.8, 0.1),
        (0.5, 0.5, -2.0),
        (0.0, 0.0, 1.0),
        (2.0, -1.0, 3.0),
        (-1.0, -1.0, 0.5),
    ] {
        let q = |u: f64, v: f64| a * (u * u - u) + b * (v * v - v) + c * u * v;
        let mut grid: f64 = 0.0;
        for i in 0..=400 {
            for j in 0..=400 - i {
                grid = grid.max(q(i as f64 / 400.0, j as f64 / 400.0).abs());
            }
        }
        let h = flat_offset_height(a, b, c);
        assert!(h >= grid - 1e-12 && h <= grid + 1e-4, "({a}, {b}, {c}): {h} against the grid's {grid}");
    }
}

/// The bump pass as it was before it was cut at its reach: closest-hit rays over the whole
/// remaining ray, each hit checked against the bump bound. `(passes, rays traced)`.
fn bump_walk_over_the_whole_ray(w: &World, sp: &SurfacePoint, o: Vec3, dir: Vec3, tfar: f32) -> (bool, u64) {
    let Some(b) = w.bump_bound(sp) else { return (false, 0) };
    let mut tnear = 0.0;
    for k in 0..MAX_BUMP_HITS as u64 {
        let Some(hit) = w.scene().intersect1(Ray::new(o, dir).with_range(tnear, tfar)) else {
            return (true, k + 1);
        };
        let d = o + hit.t * dir - sp.p;
        if hit.geom_id != b.geom || d.length() > b.reach || d.dot(sp.n) > b.height {
            return (false, k + 1);
        }
        tnear = hit.t.next_up();
    }
    (false, MAX_BUMP_HITS as u64)
}

/// Over shading points of `w`'s object 0 seen from every side and `lights` directions each
/// (directional, and point lights at distances 0.05 to 3 along them), the blocked shadow rays'
/// `hard_shadow_clear` against [`bump_walk_over_the_whole_ray`]: `(blocked rays, of them
/// passed, rays of the whole walk, rays of the cut one)`; panics at the first disagreement.
fn cut_bump_pass_against_the_whole_walk(w: &World, center: Vec3, radius: f32, lights: usize) -> [u64; 4] {
    let mut tally = [0u64; 4];
    let spin = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    for (i, d) in directions(4_000).enumerate() {
        let ray = Ray::new(center + 4.0 * radius * d, -d);
        let Some(hit) = w.scene().intersect1(ray) else { continue };
        if hit.geom_id != 0 {
            continue;
        }
        let sp = w.objects()[0].surface_point(&hit, &ray, w.shading(), w.terminator());
        let (t, b) = sp.n.any_orthonormal_pair();
        for k in 0..lights {
            // Lights all round the point, grazing its shading plane (where the bumps are met),
            // each point at its own turn.
            let phi = spin * (i * lights + k) as f32;
            let rise = -0.05 + 0.35 * (k % 5) as f32 / 4.0;
            let l = (phi.cos() * t + phi.sin() * b + rise * sp.n).normalize();
            let reach = radius * (0.05 + 3.0 * (k % 7) as f32 / 6.0);
            let (dir, tfar) = if k % 2 == 0 { (l, f32::INFINITY) } else { (reach * l, 1.0) };
            if sp.light_factor(l) <= 0.0 {
                continue;
            }
            let o = w.shadow_origin(&sp, dir, &mut RayCounts::default());
            if !w.scene().occluded1_from(Ray::new(o, dir).with_range(0.0, tfar), sp.origin) {
                continue;
            }
            let (whole, rays) = bump_walk_over_the_whole_ray(w, &sp, o, dir, tfar);
            let mut counts = RayCounts::default();
            let cut = w.hard_shadow_clear(&sp, o, dir, tfar, &mut counts);
            assert_eq!(cut, whole, "point {} ({hit:?}), light {dir} over (0, {tfar})", sp.p);
            tally = [tally[0] + 1, tally[1] + whole as u64, tally[2] + rays, tally[3] + counts.terminator];
        }
    }
    tally
}

#[test]
fn the_bump_pass_cut_at_its_reach_answers_as_the_walk_over_the_whole_ray() {
    let device = Device::new().unwrap();
    // The demo sphere on the ground (hits on another object), and two spheres in one mesh with a
    // gap (hits on the same object out of reach, past passed bumps).
    let sphere = World::builder(&device, &demo_sphere())
        .mode(ObjectMode::Phong { alpha: DEFAULT_ALPHA })
        .ground(Some(phongrt_render::Ground::default()))
        .build()
        .unwrap();
    let s = uv_sphere(12, 6, 1.0);
    let pair = merged(&s, &s, Vec3::new(0.3, 2.1, 0.2));
    let pair = phong_world(&device, &Model::from_mesh(pair), Terminator::Lift);
    // A bumpy sphere: corners moved in and out by up to 8%, their normals left radial, so
    // neighbouring patches meet at angles (the bumps the pass lets shadow rays through).
    let mut bumpy = uv_sphere(24, 12, 1.0);
    bumpy.positions.iter_mut().enumerate().for_each(|(k, q)| *q *= 1.0 + 0.08 * (2.7 * k as f32).sin());
    let bumpy = phong_world(&device, &Model::from_mesh(bumpy), Terminator::Lift);
    let mut passes = 0;
    for (name, w, center) in [
        ("sphere", &sphere, Vec3::ZERO),
        ("pair", &pair, Vec3::new(0.15, 1.05, 0.1)),
        ("bumpy", &bumpy, Vec3::ZERO),
    ] {
        let [blocked, passed, whole, cut] = cut_bump_pass_against_the_whole_walk(w, center, 1.6, 64);
        println!("{name}: {blocked} blocked shadow rays, {passed} passed; rays {whole} whole, {cut} cut");
        assert!(blocked > 10_000 && passed < blocked, "{name}: too few cases to judge");
        passes += passed;
    }
    assert!(passes > 1_000, "{passes} shadow rays passed bumps: too few to judge");
}

#[test]
#[ignore = "needs ../shared/corpus"]
fn the_bump_pass_cut_at_its_reach_answers_as_the_walk_over_the_whole_ray_on_the_head() {
    let device = Device::new().unwrap();
    let path = common::corpus_required().join("african_head/african_head.obj");
    let head = phong_world(&device, &load_obj(&path, &LoadOptions::default()).unwrap(), Terminator::Lift);
    let (lo, hi) = head.bounds();
    let [blocked, passed, whole, cut] =
        cut_bump_pass_against_the_whole_walk(&head, 0.5 * (lo + hi), 0.5 * (hi - lo).length(), 32);
    println!("head: {blocked} blocked shadow rays, {passed} passed; rays {whole} whole, {cut} cut");
    assert!(blocked > 10_000 && passed > 100 && passed < blocked, "too few cases to judge");
}
