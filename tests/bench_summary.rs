//! The equal-accuracy summaries of `phongrt bench`: which pre-tessellation level matches direct
//! Phong, and the extrapolation beyond the levels built.

use phongrt::bench::{equal_depth_summary, equal_silhouette_summary, BenchRow};

fn row(method: &str, triangles: usize, bytes: usize, err_t_mean: f64, silhouette_px: usize) -> BenchRow {
    BenchRow {
        scene: "s".into(),
        triangles,
        method: method.into(),
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
    let mut rows = vec![row("direct-f32", 1000, 200_000, 2e-5, 0)];
    for l in [1usize, 2, 4, 8] {
        rows.push(row(&format!("pretess-{l}"), 1000, 100 * 1000 * l * l, 1e-3 / (l * l) as f64, 8 / l));
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
    let mut rows = vec![row("direct-f32", 1000, 200_000, 1e-8, 0)];
    for l in [1usize, 2, 4] {
        rows.push(row(&format!("pretess-{l}"), 1000, 100 * 1000 * l * l, 1e-3 / (l * l) as f64, 0));
    }
    let d = cells(&equal_depth_summary(&rows, Some(8_000_000_000)));
    assert_eq!(d[3], "level 317 (extrapolated, not built)", "{d:?}");
    assert_eq!(d[4], "10048.9 (estimated)", "{d:?}");
    assert_eq!(d[6], "**no**", "{d:?}");
    let d = cells(&equal_depth_summary(&rows, Some(16_000_000_000)));
    assert_eq!(d[6], "yes", "{d:?}");
}
