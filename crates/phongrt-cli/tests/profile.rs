//! The bench's profile of direct Phong: every patch test Embree asks for is counted once and
//! classified by the path that decided it, and the traced intersector answers as the plain one.
use phongrt::phong::accuracy::{generate, Category, SplitMix};
use phongrt::phong::{intersect, intersect_traced, Method, Patch, TestOutcome, V3};
use phongrt_cli::profile::{profile_scene, RayKind};

#[test]
fn profile_counts_every_patch_test_once_by_outcome() {
    let m = phongrt::scene::uv_sphere(12, 6, 1.0);
    let profiles = profile_scene("sphere", &m, 48, 48, 1).unwrap();
    assert_eq!(profiles.len(), 2);
    let (p, shadow) = (&profiles[0], &profiles[1]);
    assert_eq!((p.kind, shadow.kind), (RayKind::Primary, RayKind::Shadow));
    assert_eq!(p.rays, 48 * 48);
    // A shadow ray for each lit hit, fewer than the primary rays; each is a patch test or more
    // (it leaves the sphere through the patches around its origin).
    assert!(shadow.rays > 0 && shadow.rays < p.rays);
    assert_eq!(shadow.outcomes.iter().map(|o| o.tests).sum::<usize>(), shadow.tests);
    assert!(shadow.direct_ns_per_ray > 0.0 && shadow.flat_ns_per_ray > 0.0);
    assert!(p.tests > p.rays / 4, "{} tests for {} rays", p.tests, p.rays);
    assert_eq!(p.outcomes.iter().map(|o| o.tests).sum::<usize>(), p.tests);
    // A sphere seen from outside: some tests are turned away by the hull, some certified hits.
    let tests_of = |k: TestOutcome| p.outcomes.iter().find(|o| o.outcome == k).map_or(0, |o| o.tests);
    assert!(tests_of(TestOutcome::HullReject) > 0);
    assert!(tests_of(TestOutcome::CertifiedHit) > 0);
    assert!(p.outcomes.iter().all(|o| o.ns_per_test > 0.0 && o.ns_per_test.is_finite()));
    assert!(p.patch_ns_per_ray > 0.0 && p.floor_calls_per_ray > 0.0);
    assert!(p.direct_ns_per_ray > 0.0 && p.flat_ns_per_ray > 0.0 && p.floor_ns_per_ray > 0.0);
}

#[test]
fn traced_intersection_gives_the_same_hit_as_intersect() {
    let mut rng = SplitMix(11);
    let mut seen = std::collections::HashSet::new();
    for cat in [Category::RandomCurved, Category::StronglyCurved, Category::Grazing, Category::NearFlat] {
        for _ in 0..2000 {
            let c = generate(&mut rng, cat);
            let patch: Patch<f32> = Patch::new(c.p, c.n, c.alpha);
            let (o, d) = (V3::from(c.org).cast::<f32>(), V3::from(c.dir).cast::<f32>());
            for method in [Method::Certified, Method::AnalyticPolished, Method::Newton, Method::Analytic] {
                let (hit, outcome) = intersect_traced(&patch, o, d, 0.0, f32::INFINITY, method);
                assert_eq!(hit, intersect(&patch, o, d, 0.0, f32::INFINITY, method));
                let hit_outcome = matches!(
                    outcome,
                    TestOutcome::CertifiedHit
                        | TestOutcome::AnalyticHit
                        | TestOutcome::F64Retry
                        | TestOutcome::Newton
                );
                assert!(hit.is_none() || hit_outcome, "{outcome:?} with a hit");
                seen.insert(outcome);
            }
            // The same ray moved well clear of the patch is turned away by the hull alone.
            let away = o + V3::from(c.dir.any_orthonormal_vector() * 10.0).cast::<f32>();
            let (hit, outcome) = intersect_traced(&patch, away, d, 0.0, f32::INFINITY, Method::Certified);
            assert!(hit.is_none());
            seen.insert(outcome);
        }
    }
    for k in [
        TestOutcome::CertifiedHit,
        TestOutcome::AnalyticHit,
        TestOutcome::AnalyticMiss,
        TestOutcome::HullReject,
    ] {
        assert!(seen.contains(&k), "{k:?} never taken");
    }
}
