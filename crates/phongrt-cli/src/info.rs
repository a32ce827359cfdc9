//! `phongrt info`: what a mesh is made of, as text or JSON.

use anyhow::Context;

use crate::cli::InfoArgs;
use crate::load::{load, load_options};
use phongrt::embree::{self, Device};
use phongrt::scene;

/// The largest patch offset from its flat triangle relative to the triangle's width, over the
/// scene's meshes at the default alpha with straight creases: `(ratio, mesh, triangle)`.
pub(crate) fn largest_deviation(s: &scene::Model) -> Option<(f64, usize, usize)> {
    let alpha = phongrt::phong::DEFAULT_ALPHA as f64;
    s.meshes
        .iter()
        .enumerate()
        .filter_map(|(k, m)| {
            phongrt::mesh::max_patch_deviation(
                &m.positions,
                &m.normals,
                &m.indices,
                &m.straight_edges(),
                alpha,
            )
            .map(|(r, t)| (r, k, t))
        })
        .max_by(|a, b| a.0.total_cmp(&b.0))
}

pub(crate) fn info_cmd(args: InfoArgs) -> anyhow::Result<()> {
    let s = load(&args.scene, &load_options(&args.load, args.load.crease_angle)?, true)?;
    let device = Device::new().context("cannot start Embree")?;
    if args.json {
        let doc = info_json(&args, &s, &device);
        return crate::print_stdout(&(serde_json::to_string_pretty(&doc)? + "\n"));
    }
    // The description is put together, then written at once (a closed stdout is an error, not a
    // panic).
    crate::print_stdout(&info_text(&args, &s, &device))
}

/// The description as one JSON object (`--json`).
fn info_json(args: &InfoArgs, s: &scene::Model, device: &Device) -> serde_json::Value {
    let (major, minor, patch) = device.version();
    let st = &s.stats;
    let (lo, hi) = s.bounds();
    serde_json::json!({
        "file": args.scene.display().to_string(),
        "embree": { "version": format!("{major}.{minor}.{patch}"), "headers": embree::header_version().to_string(), "isa": device.isa().to_string() },
        "objects": s.meshes.len(),
        "materials": s.materials.len(),
        "vertices": st.vertices,
        "triangles": st.triangles,
        "normals": { "from_file": st.normals_from_file, "computed": st.normals_computed },
        "edges": { "smooth": st.smooth_edges, "crease": st.crease_edges, "border": st.border_edges, "nonmanifold": st.nonmanifold_edges, "straightened": st.straightened_edges },
        "degenerate_skipped": st.degenerate_skipped,
        "largest_deviation": largest_deviation(s).map(|(r, m, t)| serde_json::json!({ "ratio": r, "object": s.meshes[m].name, "triangle": t })),
        "duplicates_dropped": st.duplicates_dropped,
        "bounds": [lo.to_array(), hi.to_array()],
        "meshes": s.meshes.iter().map(|m| serde_json::json!({
            "name": m.name, "vertices": m.positions.len(), "triangles": m.indices.len(),
            "normals": format!("{:?}", m.normals_source),
        })).collect::<Vec<_>>(),
    })
}

/// The description as text, one fact a line.
fn info_text(args: &InfoArgs, s: &scene::Model, device: &Device) -> String {
    let (major, minor, patch) = device.version();
    let st = &s.stats;
    let (lo, hi) = s.bounds();
    let mut out = String::new();
    macro_rules! say {
        ($($t:tt)*) => {{
            out.push_str(&format!($($t)*));
            out.push('\n');
        }};
    }
    say!("file: {}", args.scene.display());
    say!("embree: {major}.{minor}.{patch} (headers {}), ISA {}", embree::header_version(), device.isa());
    say!("objects: {}", s.meshes.len());
    say!("materials: {}", s.materials.len());
    say!("vertices: {}", st.vertices);
    say!("triangles: {}", st.triangles);
    say!("normals: {} from file, {} computed", st.normals_from_file, st.normals_computed);
    say!(
        "edges: {} smooth, {} crease, {} border, {} non-manifold",
        st.smooth_edges,
        st.crease_edges,
        st.border_edges,
        st.nonmanifold_edges
    );
    if st.straightened_edges > 0 {
        say!(
            "straightened: {} smooth edges that would bulge more than {} × the height of a triangle beside them (--bulge-limit)",
            st.straightened_edges, args.load.bulge_limit
        );
    }
    if st.degenerate_skipped > 0 {
        say!("skipped: {} degenerate triangles", st.degenerate_skipped);
    }
    if st.duplicates_dropped > 0 {
        say!("dropped: {} duplicate triangles", st.duplicates_dropped);
    }
    say!("bounds: [{:.6}, {:.6}, {:.6}] .. [{:.6}, {:.6}, {:.6}]", lo.x, lo.y, lo.z, hi.x, hi.y, hi.z);
    if let Some((ratio, mesh, tri)) = largest_deviation(s) {
        say!(
            "deviation: largest patch offset from its flat triangle {ratio:.4} × the triangle's width (smallest altitude; alpha {}, object {:?}, triangle {tri})",
            phongrt::phong::DEFAULT_ALPHA,
            s.meshes[mesh].name
        );
    }
    for m in &s.meshes {
        say!(
            "  object {:?}: {} vertices, {} triangles, normals {:?}",
            m.name,
            m.positions.len(),
            m.indices.len(),
            m.normals_source
        );
    }
    out
}
