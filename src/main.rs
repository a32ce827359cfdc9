//! The `phongrt` command.

mod cli;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context};
use clap::Parser;
use glam::Vec3;

use cli::{Cli, Command, InfoArgs, Mode, RenderArgs};
use phongrt::embree::{self, Device};
use phongrt::render::scene_file::{LightSection, ModeName, SceneFile};
use phongrt::render::{
    self, AmbientOcclusion, Light, ObjectMode, ObjectSettings, RenderOutput, RenderSettings, World,
};
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
        Command::Bench(args) => bench_cmd(args),
        Command::Smoothness(args) => {
            let img = image::open(&args.image)
                .with_context(|| format!("{}: cannot read as an image", args.image.display()))?
                .to_rgb8();
            let s = render::smoothness::shading_steps(
                img.as_raw(),
                img.width(),
                img.height(),
                args.threshold,
                args.margin,
            );
            println!("{} steps, largest {:.1}/255, {} interior pixels", s.count, s.largest, s.interior);
            Ok(())
        }
        Command::Accuracy(args) => {
            anyhow::ensure!(args.rays > 0, "--rays must be at least 1");
            print!("{}", phongrt::phong::accuracy::report(args.rays, args.seed));
            Ok(())
        }
    }
}

fn load_options(crease_angle: f32) -> anyhow::Result<LoadOptions> {
    anyhow::ensure!(
        (0.0..=180.0).contains(&crease_angle),
        "--crease-angle {crease_angle} is not in [0, 180] degrees"
    );
    Ok(LoadOptions { crease_angle_deg: crease_angle, ..LoadOptions::default() })
}

fn load(path: &Path, opts: &LoadOptions) -> anyhow::Result<scene::Scene> {
    let s = scene::load_obj(path, opts)?;
    for w in &s.warnings {
        eprintln!("phongrt: warning: {w}");
    }
    Ok(s)
}

/// `NAME=flat` or `NAME=phong[:ALPHA]`.
fn parse_object_override(s: &str) -> anyhow::Result<(String, ObjectMode)> {
    let (name, mode) = s
        .rsplit_once('=')
        .with_context(|| format!("--object {s:?}: expected NAME=flat or NAME=phong[:ALPHA]"))?;
    let mode = match mode.split_once(':') {
        None if mode == "flat" => ObjectMode::Flat,
        None if mode == "phong" => ObjectMode::Phong { alpha: phongrt::phong::DEFAULT_ALPHA },
        Some(("phong", a)) => {
            let alpha: f32 =
                a.parse().with_context(|| format!("--object {s:?}: alpha {a:?} is not a number"))?;
            anyhow::ensure!((0.0..=1.0).contains(&alpha), "--object {s:?}: alpha {alpha} is not in [0, 1]");
            ObjectMode::Phong { alpha }
        }
        _ => bail!("--object {s:?}: mode must be flat, phong or phong:ALPHA"),
    };
    Ok((name.to_string(), mode))
}

fn render_cmd(args: RenderArgs) -> anyhow::Result<()> {
    anyhow::ensure!((0.0..=1.0).contains(&args.alpha), "--alpha {} is not in [0, 1]", args.alpha);
    // A .toml scene names its OBJ; an OBJ may take a scene file with --scene-file.
    let is_toml = args.scene.extension().is_some_and(|e| e.eq_ignore_ascii_case("toml"));
    let (obj_path, sf): (PathBuf, Option<SceneFile>) = if is_toml {
        let sf = SceneFile::load(&args.scene)?;
        let obj = sf
            .obj_path(&args.scene)
            .with_context(|| format!("{}: obj: missing (the OBJ file to render)", args.scene.display()))?;
        (obj, Some(sf))
    } else {
        let sf = args.scene_file.as_deref().map(SceneFile::load).transpose()?;
        (args.scene.clone(), sf)
    };
    let crease = sf.as_ref().and_then(|s| s.crease_angle).unwrap_or(args.load.crease_angle);
    let input = load(&obj_path, &load_options(crease)?)?;
    let overrides: Vec<(String, ObjectMode)> =
        args.objects.iter().map(|s| parse_object_override(s)).collect::<anyhow::Result<_>>()?;
    for (name, _) in &overrides {
        anyhow::ensure!(
            name == "*" || input.meshes.iter().any(|m| m.name == *name),
            "--object {name:?}: no such object (objects: {})",
            input.meshes.iter().map(|m| m.name.as_str()).collect::<Vec<_>>().join(", ")
        );
    }
    let default_mode = match args.mode {
        Mode::Flat => ObjectMode::Flat,
        Mode::Phong => ObjectMode::Phong { alpha: args.alpha },
    };
    let device = Device::new().context("cannot start Embree")?;
    let open_creases = args.open_creases;

    let settings_for = |forced: Option<ObjectMode>| {
        let sf = sf.clone();
        let overrides = overrides.clone();
        move |_i: usize, mesh: &scene::Mesh| -> ObjectSettings {
            if let Some(m) = forced {
                return ObjectSettings { mode: m, straight_creases: !open_creases };
            }
            let mut mode = default_mode;
            if let Some(sf) = &sf {
                for o in sf.objects.iter().filter(|o| o.name == "*" || o.name == mesh.name) {
                    match (o.mode, o.alpha) {
                        (Some(ModeName::Flat), _) => mode = ObjectMode::Flat,
                        (Some(ModeName::Phong), a) => {
                            mode = ObjectMode::Phong { alpha: a.unwrap_or(phongrt::phong::DEFAULT_ALPHA) }
                        }
                        (None, Some(a)) => mode = ObjectMode::Phong { alpha: a },
                        (None, None) => {}
                    }
                }
            }
            for (name, m) in &overrides {
                if name == "*" || *name == mesh.name {
                    mode = *m;
                }
            }
            ObjectSettings { mode, straight_creases: !open_creases }
        }
    };

    let width = args.width.or(sf.as_ref().and_then(|s| s.render.width)).unwrap_or(800);
    let height = args.height.or(sf.as_ref().and_then(|s| s.render.height)).unwrap_or(600);
    let spp = args.spp.or(sf.as_ref().and_then(|s| s.render.spp)).unwrap_or(1);
    let settings =
        RenderSettings { width, height, spp, threads: args.threads, progress: !args.quiet, seed: 0 };

    // Shading choices: the command line over the scene file over the defaults.
    let sf_render = sf.as_ref().map(|s| &s.render);
    let shading = args
        .shading
        .or(sf_render.and_then(|r| r.shading.as_deref()).and_then(phongrt::phong::ShadingNormal::from_name))
        .unwrap_or_default();
    let terminator = args
        .terminator
        .or(sf_render.and_then(|r| r.terminator.as_deref()).and_then(render::Terminator::from_name))
        .unwrap_or_default();
    // The model's up: the command line over the scene file over detection.
    let up_given = args.camera.up.or(sf.as_ref().and_then(|s| s.camera.up).map(Vec3::from));
    let sf_camera = sf.as_ref().map(|s| s.camera.clone()).unwrap_or_default();
    let (mut camera, detection) = render::camera::default_view(
        &input,
        up_given,
        args.camera.orbit.or(sf_camera.orbit).unwrap_or(0.0),
        args.camera.fov.or(sf_camera.fov),
        width as f32 / height as f32,
    );
    if up_given.is_none() {
        eprintln!("phongrt: {detection}");
    }
    if let Some(e) = args.camera.eye.or(sf_camera.eye.map(Vec3::from)) {
        camera.eye = e;
    }
    if let Some(l) = args.camera.look_at.or(sf_camera.look_at.map(Vec3::from)) {
        camera.look_at = l;
    }
    let up = camera.up.normalize_or_zero();
    let sf_ground = sf.as_ref().and_then(|s| s.ground.clone());
    let ground = (args.ground || sf_ground.is_some()).then(|| {
        let g = sf_ground.unwrap_or_default();
        render::Ground { up, height: g.height, kd: g.kd.map_or(render::Ground::default().kd, Vec3::from) }
    });

    let build = |forced: Option<ObjectMode>| -> anyhow::Result<World> {
        let mut world = World::from_scene_with_ground(&device, &input, ground, settings_for(forced))?;
        world.shading = shading;
        world.terminator = terminator;
        if forced.is_none() {
            for w in &world.warnings {
                eprintln!("phongrt: warning: {w}");
            }
        }
        // The key light follows the camera, unless the scene file places lights.
        world.lights = vec![Light::Directional {
            direction: camera.key_light_direction(),
            radiance: Vec3::splat(0.85),
            shadows: true,
        }];
        if let Some(sf) = &sf {
            apply_scene_file(&mut world, sf);
            if let Some(e) = &sf.environment {
                let source = match (&e.color, &e.map) {
                    (Some(c), _) => render::EnvironmentSource::Constant(Vec3::from(*c)),
                    (None, Some(m)) => {
                        let base = if is_toml {
                            args.scene.parent()
                        } else {
                            args.scene_file.as_deref().and_then(Path::parent)
                        };
                        let path = base.unwrap_or(Path::new(".")).join(m);
                        let texture = render::Environment::load_map(&path).map_err(anyhow::Error::msg)?;
                        render::EnvironmentSource::Map { texture: std::sync::Arc::new(texture), up }
                    }
                    (None, None) => bail!("environment: give color or map"),
                };
                world.environment = Some(render::Environment { source, samples: e.samples.unwrap_or(16) });
            }
        }
        Ok(world)
    };
    if args.compare {
        // Flat everywhere on the left; on the right each object as a plain render makes it (the
        // scene file's and --object's per-object mode and alpha).
        let flat = build(Some(ObjectMode::Flat))?;
        let phong = build(None)?;
        eprintln!("phongrt: {}", phong.effects());
        let a = render::render(&flat, &camera, &settings)?;
        report("flat", &a);
        let b = render::render(&phong, &camera, &settings)?;
        report("phong", &b);
        let ms = |o: &RenderOutput| o.elapsed.as_secs_f64() * 1e3;
        let img = render::compare_panel(
            &a.image,
            &b.image,
            &format!("flat {:.1} ms", ms(&a)),
            &format!("phong {:.1} ms ({:.2}x)", ms(&b), ms(&b) / ms(&a).max(1e-9)),
        );
        img.save(&args.output)?;
        eprintln!("phongrt: wrote {} (flat | phong | difference)", args.output.display());
        return Ok(());
    }

    let world = build(None)?;
    eprintln!("phongrt: {}", world.effects());
    let out = render::render(&world, &camera, &settings)?;
    out.image.save(&args.output)?;
    report(&args.output.display().to_string(), &out);
    Ok(())
}

fn apply_scene_file(world: &mut World, sf: &SceneFile) {
    if let Some(b) = sf.render.background {
        world.background = Vec3::from(b);
    }
    if let Some(a) = sf.render.ambient {
        world.ambient = Vec3::from(a);
    }
    if let Some(d) = sf.render.max_depth {
        world.max_depth = d;
    }
    if !sf.lights.is_empty() {
        world.lights = sf
            .lights
            .iter()
            .map(|l| match *l {
                LightSection::Directional { direction, radiance, shadows } => Light::Directional {
                    direction: Vec3::from(direction).normalize(),
                    radiance: Vec3::from(radiance),
                    shadows,
                },
                LightSection::Point { position, intensity, shadows } => {
                    Light::Point { position: Vec3::from(position), intensity: Vec3::from(intensity), shadows }
                }
                LightSection::Sphere { center, radius, intensity, samples } => Light::Sphere {
                    center: Vec3::from(center),
                    radius,
                    intensity: Vec3::from(intensity),
                    samples,
                },
            })
            .collect();
    }
    world.ambient_occlusion =
        sf.ambient_occlusion.map(|a| AmbientOcclusion { samples: a.samples, distance: a.distance });
    for o in &sf.objects {
        for obj in world.objects.iter_mut().filter(|x| !x.is_ground && (o.name == "*" || x.name == o.name)) {
            if let Some(kd) = o.kd {
                obj.surface.kd = Vec3::from(kd);
            }
            if let Some(m) = o.mirror {
                obj.surface.mirror = Vec3::from(m);
            }
            if let Some(t) = o.transmission {
                obj.surface.transmission = t;
            }
            if let Some(n) = o.ior {
                obj.surface.ior = n;
            }
            if let Some(k) = o.specular {
                obj.surface.specular = Vec3::from(k);
            }
            if let Some(n) = o.shininess {
                obj.surface.shininess = n;
            }
        }
    }
}

fn bench_cmd(args: cli::BenchArgs) -> anyhow::Result<()> {
    use phongrt::bench::{
        bench_scene, equal_depth_summary, equal_silhouette_summary, mem_total, plot, plot_scaling, to_csv,
        to_markdown, BenchMethod, BenchOptions,
    };
    anyhow::ensure!(args.size >= 8 && args.size <= 4096, "--size {} is not in 8..=4096", args.size);
    anyhow::ensure!(
        args.levels.iter().all(|&l| (1..=4096).contains(&l)),
        "--levels: each level must be in 1..=4096"
    );
    let mut levels = args.levels.clone();
    levels.sort_unstable();
    levels.dedup();
    let methods: Vec<BenchMethod> = BenchMethod::all_with_levels(&levels)
        .into_iter()
        .filter(|m| !matches!(m, BenchMethod::Pretessellated(l) if *l > args.max_level))
        .collect();
    let mut scenes: Vec<(String, scene::Mesh)> = Vec::new();
    for &s in &args.spheres {
        anyhow::ensure!((3..=4096).contains(&s), "--spheres: {s} segments is not in 3..=4096");
        let m = scene::uv_sphere(s, (s / 2).max(2), 1.0);
        scenes.push((format!("sphere-{}", m.indices.len()), m));
    }
    for p in &args.models {
        let s = load(p, &LoadOptions::default())?;
        let name = p.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        let m = s.meshes.into_iter().next().with_context(|| format!("{}: no mesh", p.display()))?;
        scenes.push((name, m));
    }
    std::fs::create_dir_all(&args.out).with_context(|| format!("{}: cannot create", args.out.display()))?;
    let bar = if std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        indicatif::ProgressBar::new((scenes.len() * (methods.len() + 1)) as u64)
    } else {
        indicatif::ProgressBar::hidden()
    };
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let mut rows = Vec::new();
    for (name, m) in &scenes {
        let opts = BenchOptions {
            width: args.size,
            height: args.size,
            max_pretess_tris: args.max_pretess_tris,
            robust: args.robust,
        };
        rows.extend(bench_scene(name, m, &methods, &opts, |msg| {
            if msg.contains("skipped") {
                bar.suspend(|| eprintln!("phongrt: {msg}"));
            }
            bar.set_message(msg.to_string());
            bar.inc(1);
        })?);
    }
    bar.finish_and_clear();
    let mem = mem_total();
    let md = format!(
        "{}\nPre-tessellation that matches direct Phong's silhouette ({ram} GB of RAM here):\n\n{}\n\
         Pre-tessellation that matches direct Phong's hit distances (median relative error, {ram} GB of RAM here):\n\n{}",
        to_markdown(&rows),
        equal_silhouette_summary(&rows, mem),
        equal_depth_summary(&rows, mem),
        ram = mem.map_or("?".to_string(), |m| format!("{:.1}", m as f64 / 1e9)),
    );
    std::fs::write(args.out.join("bench.csv"), to_csv(&rows))?;
    std::fs::write(args.out.join("bench.md"), &md)?;
    plot(&rows).save(&args.out.join("bench.png"))?;
    plot_scaling(&rows).save(&args.out.join("bench-scaling.png"))?;
    print!("{md}");
    eprintln!("phongrt: wrote {}/bench.csv, bench.md, bench.png, bench-scaling.png", args.out.display());
    Ok(())
}

fn report(what: &str, out: &RenderOutput) {
    let secs = out.elapsed.as_secs_f64();
    eprintln!(
        "phongrt: {what}: {}x{} in {:.3} s: {}, {:.2} Mrays/s",
        out.image.width,
        out.image.height,
        secs,
        out.rays,
        out.rays.total() as f64 / secs.max(1e-9) / 1e6
    );
}

fn info_cmd(args: InfoArgs) -> anyhow::Result<()> {
    let s = load(&args.scene, &load_options(args.load.crease_angle)?)?;
    let device = Device::new().context("cannot start Embree")?;
    let (major, minor, patch) = device.version();
    println!("file: {}", args.scene.display());
    println!("embree: {major}.{minor}.{patch} (headers {}), ISA {}", embree::header_version(), device.isa());
    let st = &s.stats;
    println!("objects: {}", s.meshes.len());
    println!("materials: {}", s.materials.len());
    println!("vertices: {}", st.vertices);
    println!("triangles: {}", st.triangles);
    println!("normals: {} from file, {} computed", st.normals_from_file, st.normals_computed);
    println!(
        "edges: {} smooth, {} crease, {} border, {} non-manifold",
        st.smooth_edges, st.crease_edges, st.border_edges, st.nonmanifold_edges
    );
    if st.degenerate_skipped > 0 {
        println!("skipped: {} degenerate triangles", st.degenerate_skipped);
    }
    let (lo, hi) = s.bounds();
    println!("bounds: [{:.6}, {:.6}, {:.6}] .. [{:.6}, {:.6}, {:.6}]", lo.x, lo.y, lo.z, hi.x, hi.y, hi.z);
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
