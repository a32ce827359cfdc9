//! The `phongrt` command.

mod cli;

use std::process::ExitCode;

use anyhow::Context;
use clap::Parser;

use cli::{Cli, Command, InfoArgs, LoadArgs, Mode, RenderArgs};
use phongrt::embree::{self, Device};
use phongrt::render::{self, Camera, ObjectMode, ObjectSettings, RenderSettings, World};
use phongrt::scene::{self, LoadOptions};

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One line: the context chain joined, most general first.
            let chain: Vec<String> = e.chain().map(|c| c.to_string()).collect();
            eprintln!("phongrt: error: {}", chain.join(": "));
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> anyhow::Result<()> {
    embree::set_flush_denormals();
    match cli.command {
        Command::Render(args) => render_cmd(args),
        Command::Info(args) => info_cmd(args),
        Command::Accuracy(args) => {
            print!("{}", phongrt::phong::accuracy::report(args.rays, args.seed));
            Ok(())
        }
    }
}

fn load_options(args: &LoadArgs) -> anyhow::Result<LoadOptions> {
    anyhow::ensure!(
        (0.0..=180.0).contains(&args.crease_angle),
        "--crease-angle {} is not in [0, 180] degrees",
        args.crease_angle
    );
    Ok(LoadOptions { crease_angle_deg: args.crease_angle, ..LoadOptions::default() })
}

fn load(path: &std::path::Path, args: &LoadArgs) -> anyhow::Result<scene::Scene> {
    let s = scene::load_obj(path, &load_options(args)?)?;
    for w in &s.warnings {
        eprintln!("phongrt: warning: {w}");
    }
    Ok(s)
}

fn render_cmd(args: RenderArgs) -> anyhow::Result<()> {
    let input = load(&args.scene, &args.load)?;
    let device = Device::new().context("cannot start Embree")?;
    let mode = match args.mode {
        Mode::Flat => ObjectMode::Flat,
    };
    let world = World::from_scene(&device, &input, |_, _| ObjectSettings { mode })?;
    let aspect = args.width as f32 / args.height.max(1) as f32;
    let mut camera = Camera::frame_bounds(world.bounds.0, world.bounds.1, aspect);
    if let Some(e) = args.camera.eye {
        camera.eye = e;
    }
    if let Some(l) = args.camera.look_at {
        camera.look_at = l;
    }
    camera.up = args.camera.up;
    if let Some(f) = args.camera.fov {
        camera.fov_y_deg = f;
    }
    let settings = RenderSettings {
        width: args.width,
        height: args.height,
        spp: args.spp,
        threads: args.threads,
        progress: !args.quiet,
        seed: 0,
    };
    let out = render::render(&world, &camera, &settings)?;
    out.image.save(&args.output)?;
    let secs = out.elapsed.as_secs_f64();
    eprintln!(
        "phongrt: wrote {} ({}x{}, {} spp) in {:.3} s: {}, {:.2} Mrays/s",
        args.output.display(),
        args.width,
        args.height,
        args.spp,
        secs,
        out.rays,
        out.rays.total() as f64 / secs.max(1e-9) / 1e6
    );
    Ok(())
}

fn info_cmd(args: InfoArgs) -> anyhow::Result<()> {
    let s = load(&args.scene, &args.load)?;
    let device = Device::new().context("cannot start Embree")?;
    let (major, minor, patch) = device.version();
    println!("file: {}", args.scene.display());
    println!("embree: {major}.{minor}.{patch} (headers {}), ISA {}", embree::header_version(), device.isa());
    let st = &s.stats;
    println!("objects: {}", s.meshes.len());
    println!("materials: {}", s.materials.len());
    println!("vertices: {}", st.vertices);
    println!("triangles: {}", st.triangles);
    println!(
        "normals: {} from file, {} computed",
        st.normals_from_file, st.normals_computed
    );
    println!(
        "edges: {} crease, {} border, {} non-manifold",
        st.crease_edges, st.border_edges, st.nonmanifold_edges
    );
    if st.degenerate_skipped > 0 {
        println!("skipped: {} degenerate triangles", st.degenerate_skipped);
    }
    let (lo, hi) = s.bounds();
    println!(
        "bounds: [{:.6}, {:.6}, {:.6}] .. [{:.6}, {:.6}, {:.6}]",
        lo.x, lo.y, lo.z, hi.x, hi.y, hi.z
    );
    for m in &s.meshes {
        println!(
            "  object {:?}: {} vertices, {} triangles, normals {:?}",
            m.name,
            m.positions.len(),
            m.indices.len(),
            m.normals_source
        );
    }
    Ok(())
}
