//! The work `scripts/instructions.sh` counts under callgrind: the bench's primary or shadow rays
//! (256², one patch per primitive) through Embree on the Phong mesh or on its flat triangles, or
//! the patch solves of one outcome replayed alone, or the same rays in 8-ray packets
//! (`phong-packets`, `phong-packets-lane-by-lane`, `flat-packets`). Prints how many rays or
//! solves it ran; the instructions are those of `counted_work` (or `counted_packets`) alone
//! (callgrind `--toggle-collect`).
//!
//! Run: `cargo run --release --example instructions -- SCENE primary|shadow WHAT`, SCENE
//! `sphere-120` or an OBJ file, WHAT `phong`, `flat`, one of the packet modes above, or a
//! [`TestOutcome`] name with `-` for spaces; or `-- SCENE shadow origin` for the tests of the
//! patch each shadow ray starts on (no callgrind needed): the ray count, then one line per
//! outcome of their full solve, `OUTCOME tests skipped`; `-- SCENE shadow neighbour` the same
//! for the other patches' tests past the hull, and what a rule leaving out a patch wholly
//! under the origin's tangent plane would skip (`profile::neighbour_tests`).
use std::path::Path;
use std::process::ExitCode;

use phongrt::phong::TestOutcome;
use phongrt::scene::{load_obj, uv_sphere, LoadOptions, Mesh};
use phongrt_cli::profile::{count_work, neighbour_tests, origin_tests, Counted, RayKind};

/// The mesh of `scene`: the bench's sphere of `sphere-N` triangles, or an OBJ file's first mesh.
fn mesh(scene: &str) -> Result<Mesh, String> {
    if let Some(n) = scene.strip_prefix("sphere-") {
        let tris: usize = n.parse().map_err(|_| format!("{scene}: not sphere-<triangles>"))?;
        // The bench's spheres (`--spheres S`): S segments, S/2 rings.
        return (3..=256)
            .map(|s| uv_sphere(s, (s / 2).max(2), 1.0))
            .find(|m| m.indices.len() == tris)
            .ok_or(format!("{scene}: no bench sphere has {tris} triangles"));
    }
    let s = load_obj(Path::new(scene), &LoadOptions::default()).map_err(|e| e.to_string())?;
    s.meshes.into_iter().next().ok_or(format!("{scene}: no mesh"))
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let run = || -> Result<usize, String> {
        let [scene, kind, what] = args.as_slice() else {
            return Err(
                "usage: instructions SCENE primary|shadow phong|flat|PACKETS|OUTCOME|origin|neighbour".into(),
            );
        };
        let name = Path::new(scene).file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        if what == "origin" || what == "neighbour" {
            let tests = if what == "origin" { origin_tests } else { neighbour_tests };
            let (rays, outcomes) = tests(&name, &mesh(scene)?, 256).map_err(|e| e.to_string())?;
            for o in outcomes {
                println!("{} {} {}", o.outcome.name().replace(' ', "-"), o.tests, o.skipped);
            }
            return Ok(rays);
        }
        let kind = match kind.as_str() {
            "primary" => RayKind::Primary,
            "shadow" => RayKind::Shadow,
            k => return Err(format!("{k:?} is not primary or shadow")),
        };
        let what = match what.as_str() {
            "phong" => Counted::Phong,
            "flat" => Counted::Flat,
            "phong-packets" => Counted::PhongPackets,
            "phong-packets-lane-by-lane" => Counted::PhongPacketsLaneByLane,
            "flat-packets" => Counted::FlatPackets,
            w => Counted::Outcome(
                TestOutcome::ALL
                    .into_iter()
                    .find(|o| o.name().replace(' ', "-") == w)
                    .ok_or(format!("{w:?} is not phong, flat or an outcome"))?,
            ),
        };
        count_work(&name, &mesh(scene)?, 256, kind, what).map_err(|e| e.to_string())
    };
    // On one thread of a pool that sets flush-to-zero and denormals-are-zero, as every thread
    // that traces rays (Embree's recommendation; the bench's and the renderer's threads do).
    let pool = match phongrt::embree::thread_pool_builder().num_threads(1).build() {
        Ok(pool) => pool,
        Err(e) => {
            eprintln!("instructions: a thread pool: {e}");
            return ExitCode::FAILURE;
        }
    };
    match pool.install(run) {
        Ok(n) => {
            println!("{n}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("instructions: {e}");
            ExitCode::FAILURE
        }
    }
}
