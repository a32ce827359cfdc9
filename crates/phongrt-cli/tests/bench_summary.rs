//! The equal-accuracy summaries of `phongrt bench`: which pre-tessellation level matches direct
//! Phong, and the extrapolation beyond the levels built.

use phongrt_cli::bench::{equal_depth_summary, equal_silhouette_summary, BenchMethod, BenchRow};

fn row(
    method: BenchMethod,
    triangles: usize,
    bytes: usize,
    err_t_mean: f64,
    silhouette_px: usize,
) -> BenchRow {
    BenchRow {
        scene: "s".into(),
        triangles,
        method,
        build_ms: 1.0,
        embree_bytes: 0,
        own_bytes: bytes,
        mrays_1t: 1.0,
        mrays_all: 1.0,
        first_image_ms: 1.0,
        err_t_mean,
        err_t_max: err_t_mean,
        err_t_p50: err_t_mean,
        silhouette_px,
        shaded_ms: 1.0,
        mrays_1t_packets: 1.0,
        shaded_ms_packets: 1.0,
    }
}

/// The data row of a one-scene summary, split into trimmed cells.
fn cells(table: &str) -> Vec<String> {
    let line = table.lines().find(|l| l.starts_with("| s |")).expect("a row for scene s");
    line.split('|').map(|c| c.trim().to_string()).filter(|c| !c.is_empty()).collect()
}

#[test]
fn a_built_level_that_matches_is_reported_as_measured() {
    // 1000 triangles; 100 bytes per triangle at every level; error 1e-3 / level².
    let mut rows = vec![row(BenchMethod::DirectF32, 1000, 200_000, 2e-5, 0)];
    for l in [1usize, 2, 4, 8] {
        rows.push(row(
            BenchMethod::Pretessellated(l as u32),
            1000,
            100 * 1000 * l * l,
            1e-3 / (l * l) as f64,
            8 / l,
        ));
    }
    // Depth: 1e-3/64 = 1.6e-5 <= 2e-5 at level 8 (the first); 6.4 MB, 32x direct's 0.2 MB.
    let d = cells(&equal_depth_summary(&rows, Some(1 << 40)));
    assert_eq!(d[3], "level 8", "{d:?}");
    assert_eq!(d[4], "6.4", "{d:?}");
    assert_eq!(d[5], "32", "{d:?}");
    assert_eq!(d[6], "yes", "{d:?}");
    // Silhouette: 8 / l pixels reaches 0 only beyond level 8: estimated at level 16.
    let s = cells(&equal_silhouette_summary(&rows, Some(1 << 40)));
    assert!(s[2].starts_with("level 16"), "{s:?}");
}

#[test]
fn beyond_the_built_levels_the_level_is_extrapolated_and_may_not_fit() {
    // Error 1e-3 / level², direct 1e-8: level sqrt(1e5) = 316.2 -> 317, at 100 bytes per
    // triangle: 1000 * 317² * 100 B = 10.05 GB.
    let mut rows = vec![row(BenchMethod::DirectF32, 1000, 200_000, 1e-8, 0)];
    for l in [1usize, 2, 4] {
        rows.push(row(
            BenchMethod::Pretessellated(l as u32),
            1000,
            100 * 1000 * l * l,
            1e-3 / (l * l) as f64,
            0,
        ));
    }
    let d = cells(&equal_depth_summary(&rows, Some(8_000_000_000)));
    assert_eq!(d[3], "level 317 (extrapolated, not built)", "{d:?}");
    assert_eq!(d[4], "10048.9 (estimated)", "{d:?}");
    assert_eq!(d[6], "**no**", "{d:?}");
    let d = cells(&equal_depth_summary(&rows, Some(16_000_000_000)));
    assert_eq!(d[6], "yes", "{d:?}");
}

/// The pre-tessellation of a closed mesh is closed: every edge, keyed by the bit patterns of
/// its two end positions, belongs to exactly two triangles (a vertex computed differently by
/// the two patches beside an edge would leave a crack, and rays through it would be hit far
/// behind). Vertices lie on the Phong surface.
#[test]
fn pretessellation_is_watertight_and_on_the_surface() {
    use std::collections::HashMap;
    let m = phongrt::scene::uv_sphere(12, 6, 1.0);
    for level in [1, 3, 8] {
        let (pos, idx) = phongrt_cli::bench::pretessellate(&m, 1.0, level);
        assert_eq!(idx.len(), m.indices.len() * (level * level) as usize);
        let key = |i: u32| {
            let q = pos[i as usize];
            (q.x.to_bits(), q.y.to_bits(), q.z.to_bits())
        };
        let mut edges: HashMap<_, usize> = HashMap::new();
        for t in &idx {
            for k in 0..3 {
                let (a, b) = (key(t[k]), key(t[(k + 1) % 3]));
                *edges.entry(if a < b { (a, b) } else { (b, a) }).or_default() += 1;
            }
        }
        let open = edges.values().filter(|&&c| c != 2).count();
        assert_eq!(
            open,
            0,
            "level {level}: {open} of {} edges not shared by exactly two triangles",
            edges.len()
        );
        // Patch t's vertices come row by row: (i, j) at u = i/l, v = j/l.
        let per_patch = ((level + 1) * (level + 2) / 2) as usize;
        let mut worst = 0f64;
        for (t, tri) in m.indices.iter().enumerate() {
            let p = tri.map(|i| m.positions[i as usize].as_dvec3());
            let n = tri.map(|i| m.normals[i as usize].as_dvec3());
            let patch: phongrt::phong::Patch<f64> = phongrt::phong::Patch::new(p, n, 1.0);
            let mut k = t * per_patch;
            for j in 0..=level {
                for i in 0..=(level - j) {
                    let q: glam::DVec3 = patch.eval(i as f64 / level as f64, j as f64 / level as f64).into();
                    worst = worst.max((q - pos[k].as_dvec3()).length());
                    k += 1;
                }
            }
        }
        assert!(worst < 1e-6, "level {level}: a vertex is {worst} off the Phong surface");
    }
}

#[test]
fn an_error_that_stops_falling_is_not_extrapolated() {
    // Error 1e-3 / level² down to a floor of 1e-7 (reached at level 100), direct 3e-8: levels
    // 64 -> 128 -> 192 fall 2.4x and then not at all, far below the 4x and 2.25x of 1/level².
    let mut rows = vec![row(BenchMethod::DirectF32, 1000, 200_000, 3e-8, 0)];
    for l in [16usize, 32, 64, 128, 192] {
        rows.push(row(
            BenchMethod::Pretessellated(l as u32),
            1000,
            100 * 1000 * l * l,
            (1e-3 / (l * l) as f64).max(1e-7),
            0,
        ));
    }
    let d = cells(&equal_depth_summary(&rows, Some(1 << 40)));
    assert!(
        d[3].starts_with("none: the median stops falling at 1.0e-7 (level 128: 1.0e-7, level 192: 1.0e-7)"),
        "{d:?}"
    );
    assert_eq!(d[6], "no level reaches it", "{d:?}");
    // Still on the 1/level² line at the finest level built: extrapolated as before.
    rows.truncate(4);
    let d = cells(&equal_depth_summary(&rows, Some(1 << 40)));
    assert!(d[3].ends_with("(extrapolated, not built)"), "{d:?}");
}
