//! The `phongrt` command.

mod cli;

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{bail, Context};
use clap::Parser;
use glam::Vec3;

use cli::{Cli, Command, InfoArgs, LoadArgs, RenderArgs, StitchArgs};
use phongrt::embree::{self, Device};
use phongrt::scene::{self, LoadOptions};
use phongrt_render::image_out::{self, EncodeOptions, ImageFormat};
use phongrt_render::render_record::{Digest, RenderRecord};
use phongrt_render::scene_file::{self, LightSection, SceneFile};
use phongrt_render::stitch::StitchError;
use phongrt_render::{
    self as render, AmbientOcclusion, Camera, Light, ObjectMode, ObjectSettings, RenderExtent, RenderOutput,
    RenderSettings, SurfaceMode, Window, World,
};

/// A mistake on the command line (a flag or its value): exit status 2. Everything else (an
/// input that cannot be read or is invalid, an output that cannot be written) is status 1.
#[derive(Debug)]
struct Usage(String);

impl std::fmt::Display for Usage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Usage {}

/// Return early with a usage error (exit status 2).
macro_rules! usage {
    ($($t:tt)*) => { return Err(anyhow::Error::new(Usage(format!($($t)*)))) };
}

/// Exit status for bad input (files read or written).
const EXIT_INPUT: u8 = 1;
/// Exit status for bad usage (flags and their values).
const EXIT_USAGE: u8 = 2;

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(
                e.kind(),
                ErrorKind::DisplayHelp
                    | ErrorKind::DisplayVersion
                    | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
            ) {
                e.exit();
            }
            // One line: clap's first line (it names the flag and the value).
            let text = e.to_string();
            let line = text.lines().find(|l| !l.trim().is_empty()).unwrap_or("bad usage");
            eprintln!("phongrt: error: {}", line.trim_start_matches("error: "));
            return ExitCode::from(EXIT_USAGE);
        }
    };
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("phongrt: error: {}", one_line(&e));
            if e.chain().any(|c| c.is::<Usage>()) {
                ExitCode::from(EXIT_USAGE)
            } else {
                ExitCode::from(EXIT_INPUT)
            }
        }
    }
}

/// The context chain on one line, most general first, without repeating a cause that an outer
/// message already quotes.
fn one_line(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for c in e.chain() {
        let s = c.to_string().replace('\n', " ");
        if line.contains(&s) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&s);
    }
    line
}

fn run(cli: Cli) -> anyhow::Result<()> {
    // SIGTERM, SIGINT and SIGHUP remove our temporary files and exit with 128 + the signal.
    phongrt_render::temp_file::remove_on_signals().context("cannot watch for signals")?;
    embree::set_flush_denormals();
    // Every thread that traces rays runs in the float mode Embree asks for, not only the
    // renderer's own pool: rayon's global pool (the bench's multi-threaded rays) too.
    rayon::ThreadPoolBuilder::new()
        .start_handler(|_| embree::set_flush_denormals())
        .build_global()
        .context("cannot start the thread pool")?;
    match cli.command {
        Command::Render(args) => render_cmd(*args),
        Command::Info(args) => info_cmd(args),
        Command::Stitch(args) => stitch_cmd(args),
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
        Command::Completions(args) => {
            use clap::CommandFactory;
            let mut out = Vec::new();
            clap_complete::generate(args.shell, &mut Cli::command(), "phongrt", &mut out);
            let mut stdout = std::io::stdout().lock();
            stdout.write_all(&out).and_then(|_| stdout.flush()).context("cannot write to stdout")
        }
        Command::Accuracy(args) => {
            if args.rays == 0 {
                usage!("--rays 0: must be at least 1");
            }
            print!("{}", phongrt::phong::accuracy::report(args.rays, args.seed));
            Ok(())
        }
    }
}

/// Refuse a file that is plainly not an OBJ (by its extension) before reading it.
fn check_obj_path(path: &Path) -> anyhow::Result<()> {
    if let Some(ext) = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()) {
        if ext != "obj" {
            bail!("{}: not an OBJ file (.{ext}); phongrt reads Wavefront .obj meshes", path.display());
        }
    }
    Ok(())
}

fn load_options(args: &LoadArgs, crease_angle: f32) -> anyhow::Result<LoadOptions> {
    if !(0.0..=180.0).contains(&crease_angle) {
        usage!("--crease-angle {crease_angle} is not in [0, 180] degrees");
    }
    let tol = args.normal_tolerance;
    if !(0.0..=0.1).contains(&tol) {
        usage!("--normal-tolerance {tol} is not in [0, 0.1] radians");
    }
    Ok(LoadOptions {
        crease_angle_deg: crease_angle,
        normal_tolerance_rad: tol,
        drop_duplicate_faces: !args.keep_duplicate_faces,
        ..LoadOptions::default()
    })
}

fn load(path: &Path, opts: &LoadOptions) -> anyhow::Result<scene::Scene> {
    check_obj_path(path)?;
    let s = scene::load_obj(path, opts)?;
    for w in &s.warnings {
        eprintln!("phongrt: warning: {w}");
    }
    Ok(s)
}

/// `NAME=flat` or `NAME=phong[:ALPHA]`.
fn parse_object_override(s: &str) -> anyhow::Result<(String, ObjectMode)> {
    let Some((name, mode)) = s.rsplit_once('=') else {
        usage!("--object {s:?}: expected NAME=flat or NAME=phong[:ALPHA]");
    };
    let (mode_name, alpha) = match mode.split_once(':') {
        Some((m, a)) => (m, Some(a)),
        None => (mode, None),
    };
    // The names are --mode's (and the scene file's `mode`).
    let mode = match (<SurfaceMode as clap::ValueEnum>::from_str(mode_name, false), alpha) {
        (Ok(m), None) => m.with_alpha(phongrt::phong::DEFAULT_ALPHA),
        (Ok(SurfaceMode::Phong), Some(a)) => {
            let Ok(alpha) = a.parse::<f32>() else {
                usage!("--object {s:?}: alpha {a:?} is not a number");
            };
            if !(0.0..=1.0).contains(&alpha) {
                usage!("--object {s:?}: alpha {alpha} is not in [0, 1]");
            }
            ObjectMode::Phong { alpha }
        }
        _ => usage!("--object {s:?}: mode must be flat, phong or phong:ALPHA"),
    };
    Ok((name.to_string(), mode))
}

/// Where the image goes.
#[derive(Clone, Debug, PartialEq)]
enum Output {
    /// `-o -`: PNG on stdout.
    Stdout,
    File(PathBuf),
}

impl Output {
    fn name(&self) -> String {
        match self {
            Output::Stdout => "-".to_string(),
            Output::File(p) => p.display().to_string(),
        }
    }
}

/// Where `--stats` goes.
#[derive(Clone, Debug)]
enum StatsTarget {
    /// `--stats json`: stdout, or stderr when the image goes to stdout.
    Print,
    File(PathBuf),
}

/// The frames to render: `count` frames of an orbit of `orbit_deg`, of which `only` (or all).
#[derive(Clone, Copy, Debug)]
struct Frames {
    count: u32,
    only: Option<u32>,
    orbit_deg: f32,
}

/// Every render option, resolved and checked once before any work.
#[derive(Clone, Debug)]
struct RenderPlan {
    width: u32,
    height: u32,
    spp: u32,
    seed: u64,
    threads: Option<usize>,
    /// The window of the frame to render (`None` = all of it).
    crop: Option<Window>,
    frames: Option<Frames>,
    output: Output,
    format: ImageFormat,
    stats: Option<StatsTarget>,
    alpha: bool,
}

impl RenderPlan {
    /// (frame index, output) for every frame to render; index `None` without `--frames`.
    fn outputs(&self) -> Vec<(Option<u32>, Output)> {
        let Some(f) = self.frames else {
            return vec![(None, self.output.clone())];
        };
        let ks: Vec<u32> = match f.only {
            Some(k) => vec![k],
            None => (0..f.count).collect(),
        };
        ks.into_iter()
            .map(|k| {
                let out = match &self.output {
                    Output::Stdout => Output::Stdout,
                    Output::File(p) => Output::File(frame_path(p, k)),
                };
                (Some(k), out)
            })
            .collect()
    }
}

/// `out.png` -> `out_0007.png`.
fn frame_path(p: &Path, k: u32) -> PathBuf {
    let stem = p.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let ext = p.extension().map(|e| format!(".{}", e.to_string_lossy())).unwrap_or_default();
    p.with_file_name(format!("{stem}_{k:04}{ext}"))
}

/// `X0,Y0,X1,Y1` inside a `w x h` frame.
fn parse_crop(s: &str, w: u32, h: u32) -> anyhow::Result<Window> {
    let v: Option<Vec<u32>> = s.split(',').map(|t| t.trim().parse().ok()).collect();
    let Some(v) = v.filter(|v| v.len() == 4) else {
        usage!("--crop {s:?}: expected four pixel bounds X0,Y0,X1,Y1 (whole numbers)");
    };
    let (x0, y0, x1, y1) = (v[0], v[1], v[2], v[3]);
    if !(x0 < x1 && x1 <= w && y0 < y1 && y1 <= h) {
        usage!("--crop {s}: not a window of the {w}x{h} image (need 0 <= X0 < X1 <= {w} and 0 <= Y0 < Y1 <= {h})");
    }
    Ok(Window { x0, y0, x1, y1, full_width: w, full_height: h })
}

/// `I/N`: the I-th of N bands of whole rows of a `w x h` frame.
fn parse_tile(s: &str, w: u32, h: u32) -> anyhow::Result<Window> {
    let parsed = s
        .split_once('/')
        .and_then(|(i, n)| Some((i.trim().parse::<u32>().ok()?, n.trim().parse::<u32>().ok()?)));
    let Some((i, n)) = parsed else {
        usage!("--tile {s:?}: expected I/N with whole numbers, 0 <= I < N");
    };
    if n == 0 {
        usage!("--tile {s}: N must be at least 1");
    }
    if i >= n {
        usage!("--tile {s}: index {i} is out of range (0..={} for {n} tiles)", n - 1);
    }
    if n > h {
        usage!("--tile {s}: {n} tiles is more than the image's {h} rows");
    }
    let band = |k: u32| (k as u64 * h as u64 / n as u64) as u32;
    Ok(Window { x0: 0, y0: band(i), x1: w, y1: band(i + 1), full_width: w, full_height: h })
}

/// The memory this machine (or `PHONGRT_MAX_MEMORY`, in bytes) lets a render use.
fn memory_budget() -> Option<u64> {
    if let Some(v) = std::env::var_os("PHONGRT_MAX_MEMORY") {
        return v.to_str().and_then(|s| s.trim().parse().ok());
    }
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

fn gb(bytes: u64) -> String {
    format!("{:.1} GB", bytes as f64 / 1e9)
}

/// Resolve and check every option that needs no mesh: all of it happens before loading.
fn plan(args: &RenderArgs, sf: Option<&SceneFile>) -> anyhow::Result<RenderPlan> {
    check_flag_ranges(args)?;
    let width = args.width.or(sf.and_then(|s| s.render.width)).unwrap_or(800);
    let height = args.height.or(sf.and_then(|s| s.render.height)).unwrap_or(600);
    let spp = args.spp.or(sf.and_then(|s| s.render.spp)).unwrap_or(1);
    let f = &args.farm;

    // Compute the window: a crop, a tile, or the whole frame.
    let crop = match (&f.crop, &f.tile) {
        (Some(_), Some(_)) => usage!("--crop and --tile: give one or the other"),
        (Some(c), None) => Some(parse_crop(c, width, height)?),
        (None, Some(t)) => Some(parse_tile(t, width, height)?),
        (None, None) => None,
    };
    if args.compare && (crop.is_some() || f.frames.is_some() || f.alpha_channel) {
        usage!("--compare renders one whole frame: it does not combine with --crop, --tile, --frames or --alpha-channel");
    }

    // Compute the frames and the threads.
    let frames = plan_frames(f)?;
    let threads = plan_threads(args.threads)?;

    // Check the output (and the stats file) before any work.
    let output =
        if args.output.as_os_str() == "-" { Output::Stdout } else { Output::File(args.output.clone()) };
    let format = check_output(&output, frames)?;
    let stats = plan_stats(f.stats.as_deref())?;

    // Estimate the memory before starting.
    let pixels = crop.map_or(width as u64 * height as u64, |c| c.width() as u64 * c.height() as u64)
        * if args.compare { 3 } else { 1 };
    let need = render::memory_estimate(pixels);
    if let Some(budget) = memory_budget() {
        if need > budget {
            usage!(
                "--width {width} --height {height}: needs about {} of memory, more than the {} available; \
                 render it in tiles (--tile I/N) and stitch them",
                gb(need),
                gb(budget)
            );
        }
    }
    Ok(RenderPlan {
        width,
        height,
        spp,
        seed: f.seed,
        threads,
        crop,
        frames,
        output,
        format,
        stats,
        alpha: f.alpha_channel,
    })
}

/// The ranges of --alpha, --width, --height, --spp, --fov and --up (the scene file's values
/// are checked when it is read).
fn check_flag_ranges(args: &RenderArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        (0.0..=1.0).contains(&args.alpha),
        Usage(format!("--alpha {} is not in [0, 1]", args.alpha))
    );
    for (flag, v) in [("--width", args.width), ("--height", args.height)] {
        if let Some(v) = v {
            if v == 0 || v > 1 << 15 {
                usage!("{flag} {v}: image size is out of range (1..=32768 per side)");
            }
        }
    }
    if let Some(s) = args.spp {
        if s == 0 || s > 1 << 16 {
            usage!("--spp {s}: samples per pixel is out of range (1..=65536)");
        }
    }
    if let Some(f) = args.camera.fov {
        if !(f > 0.0 && f < 180.0) {
            usage!("--fov {f}: the field of view is not in (0, 180) degrees");
        }
    }
    if let Some(u) = args.camera.up {
        if u.length_squared() == 0.0 {
            usage!("--up 0,0,0: the up vector must not be zero");
        }
    }
    Ok(())
}

/// --frames, --frame and --orbit.
fn plan_frames(f: &cli::FarmArgs) -> anyhow::Result<Option<Frames>> {
    if let Some(deg) = f.orbit.filter(|d| !d.is_finite()) {
        usage!("--orbit {deg}: not a finite number of degrees");
    }
    match f.frames {
        None => Ok(None),
        Some(0) => usage!("--frames 0: must be at least 1"),
        Some(n) => {
            if let Some(k) = f.frame {
                if k >= n {
                    usage!("--frame {k}: out of range for --frames {n} (0..={})", n - 1);
                }
            }
            Ok(Some(Frames { count: n, only: f.frame, orbit_deg: f.orbit.unwrap_or(360.0) }))
        }
    }
}

/// --threads: at least 1, at most what the machine has (more is a warning).
fn plan_threads(threads: Option<usize>) -> anyhow::Result<Option<usize>> {
    match threads {
        Some(0) => usage!("--threads 0: must be at least 1 (leave it out to use every core)"),
        Some(t) => {
            let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
            if t > cores {
                eprintln!("phongrt: warning: --threads {t}: this machine has {cores} cores; using {cores}");
                Ok(Some(cores))
            } else {
                Ok(Some(t))
            }
        }
        None => Ok(None),
    }
}

/// The output's format, once it is known to be writable (the first frame's file, with
/// --frames); stdout takes one PNG and must not be a terminal.
fn check_output(output: &Output, frames: Option<Frames>) -> anyhow::Result<ImageFormat> {
    match output {
        Output::Stdout => {
            if std::io::IsTerminal::is_terminal(&std::io::stdout()) {
                usage!("-o -: stdout is a terminal; redirect it to a file or a pipe");
            }
            if image_out::stdout_is_closed() {
                // Bad input (exit 1), found before any work.
                return Err(image_out::ImageError::StdoutClosed.into());
            }
            if frames.is_some_and(|f| f.only.is_none() && f.count > 1) {
                usage!(
                    "-o -: {} frames cannot all go to stdout; pick one with --frame I",
                    frames.map_or(0, |f| f.count)
                );
            }
            Ok(ImageFormat::Png)
        }
        Output::File(p) => {
            let fmt = ImageFormat::from_path(p).map_err(|e| Usage(format!("-o {}: {e}", p.display())))?;
            let first = match frames {
                Some(fr) => frame_path(p, fr.only.unwrap_or(0)),
                None => p.clone(),
            };
            image_out::check_writable(&first)?;
            Ok(fmt)
        }
    }
}

/// --stats: `json` (printed) or a file in an existing directory.
fn plan_stats(stats: Option<&str>) -> anyhow::Result<Option<StatsTarget>> {
    match stats {
        None => Ok(None),
        Some("json") => Ok(Some(StatsTarget::Print)),
        Some(file) => {
            let p = PathBuf::from(file);
            let dir = p.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
            if !dir.is_dir() {
                usage!("--stats {file}: directory {} does not exist", dir.display());
            }
            Ok(Some(StatsTarget::File(p)))
        }
    }
}

/// Stage times of one run, in seconds.
#[derive(Clone, Copy, Debug, Default)]
struct Stages {
    load: f64,
    build: f64,
}

/// The OBJ to render and the scene file that goes with it: a .toml scene names its OBJ; an OBJ
/// may take a scene file with --scene-file.
struct SceneSource {
    obj: PathBuf,
    file: Option<SceneFile>,
    /// The scene file's path, for messages and relative paths (empty without one).
    file_path: PathBuf,
}

impl SceneSource {
    fn resolve(args: &RenderArgs) -> anyhow::Result<SceneSource> {
        let is_toml = args.scene.extension().is_some_and(|e| e.eq_ignore_ascii_case("toml"));
        if is_toml {
            let sf = SceneFile::load(&args.scene)?;
            let obj = sf.obj_path(&args.scene).with_context(|| {
                format!("{}: obj: missing (the OBJ file to render)", args.scene.display())
            })?;
            return Ok(SceneSource { obj, file: Some(sf), file_path: args.scene.clone() });
        }
        let file = args.scene_file.as_deref().map(SceneFile::load).transpose()?;
        Ok(SceneSource {
            obj: args.scene.clone(),
            file,
            file_path: args.scene_file.clone().unwrap_or_default(),
        })
    }
}

/// Which mode each object gets: the scene file's `[[object]]` entries over --mode/--alpha,
/// and --object over both.
#[derive(Clone, Debug)]
struct ModeRules {
    default: ObjectMode,
    file_objects: Vec<scene_file::ObjectSection>,
    overrides: Vec<(String, ObjectMode)>,
    straight_creases: bool,
}

impl ModeRules {
    /// The settings of `mesh`, or `forced` mode for every object.
    fn settings(&self, forced: Option<ObjectMode>, mesh: &scene::Mesh) -> ObjectSettings {
        let straight_creases = self.straight_creases;
        if let Some(mode) = forced {
            return ObjectSettings { mode, straight_creases };
        }
        let mut mode = self.default;
        for o in self.file_objects.iter().filter(|o| o.name == "*" || o.name == mesh.name) {
            match (o.mode, o.alpha) {
                (Some(m), a) => mode = m.with_alpha(a.unwrap_or(phongrt::phong::DEFAULT_ALPHA)),
                (None, Some(a)) => mode = ObjectMode::Phong { alpha: a },
                (None, None) => {}
            }
        }
        for (name, m) in &self.overrides {
            if name == "*" || *name == mesh.name {
                mode = *m;
            }
        }
        ObjectSettings { mode, straight_creases }
    }
}

/// Every choice of a render, resolved once (the command line over the scene file over the
/// defaults) and checked, with the mesh loaded: what `run` needs and nothing to decide.
struct RenderJob {
    plan: RenderPlan,
    source: SceneSource,
    input: scene::Scene,
    load: LoadOptions,
    modes: ModeRules,
    settings: RenderSettings,
    shading: phongrt::phong::ShadingNormal,
    terminator: render::Terminator,
    camera: Camera,
    ground: Option<render::Ground>,
    stages: Stages,
    /// --quiet: warnings and errors only on stderr.
    quiet: bool,
}

impl RenderJob {
    fn resolve(args: &RenderArgs, t_start: Instant) -> anyhow::Result<RenderJob> {
        // Resolve the scene source and every option that needs no mesh.
        let source = SceneSource::resolve(args)?;
        let sf = source.file.as_ref();
        let plan = plan(args, sf)?;
        let overrides: Vec<(String, ObjectMode)> =
            args.objects.iter().map(|s| parse_object_override(s)).collect::<anyhow::Result<_>>()?;

        // Load the mesh, and check the object names given for it.
        let crease = sf.and_then(|s| s.crease_angle).unwrap_or(args.load.crease_angle);
        let load_opts = load_options(&args.load, crease)?;
        let input = load(&source.obj, &load_opts)?;
        for (name, _) in &overrides {
            if !(name == "*" || input.meshes.iter().any(|m| m.name == *name)) {
                usage!(
                    "--object {name:?}: no such object (objects: {})",
                    input.meshes.iter().map(|m| m.name.as_str()).collect::<Vec<_>>().join(", ")
                );
            }
        }
        if let Some(sf) = sf {
            sf.check_object_names(&source.file_path, input.meshes.iter().map(|m| m.name.as_str()))?;
        }
        let stages = Stages { load: t_start.elapsed().as_secs_f64(), ..Stages::default() };

        // Resolve the surfaces: modes, shading normal, terminator.
        let modes = ModeRules {
            default: args.mode.with_alpha(args.alpha),
            file_objects: sf.map(|s| s.objects.clone()).unwrap_or_default(),
            overrides,
            straight_creases: !args.open_creases,
        };
        let sf_render = sf.map(|s| &s.render);
        let shading = args
            .shading
            .or(sf_render
                .and_then(|r| r.shading.as_deref())
                .and_then(phongrt::phong::ShadingNormal::from_name))
            .unwrap_or_default();
        let terminator = args
            .terminator
            .or(sf_render.and_then(|r| r.terminator.as_deref()).and_then(render::Terminator::from_name))
            .unwrap_or_default();

        // Resolve the camera and the ground under it.
        let camera = resolve_camera(args, &source, &plan, &input)?;
        let up = camera.up.normalize_or_zero();
        let sf_ground = sf.and_then(|s| s.ground.clone());
        let ground = (args.ground || sf_ground.is_some()).then(|| {
            let g = sf_ground.unwrap_or_default();
            render::Ground { up, height: g.height, kd: g.kd.map_or(render::Ground::default().kd, Vec3::from) }
        });
        let settings = RenderSettings {
            width: plan.width,
            height: plan.height,
            spp: plan.spp,
            threads: plan.threads,
            progress: !args.quiet,
            seed: plan.seed,
            packets: args.packets == cli::Switch::On,
        };
        Ok(RenderJob {
            plan,
            source,
            input,
            load: load_opts,
            modes,
            settings,
            shading,
            terminator,
            camera,
            ground,
            stages,
            quiet: args.quiet,
        })
    }

    /// What a tile of frame `k` records: a digest of the scene files' contents, the resolved
    /// settings and the version (nothing of the thread count, tiling or tile index), and the
    /// settings worth naming when two tiles disagree.
    fn record(&self, k: Option<u32>) -> RenderRecord {
        // Compute the digest of the files' contents (not their paths, which differ between hosts).
        let mut d = Digest::default();
        let mut files = vec![self.source.obj.clone()];
        if !self.source.file_path.as_os_str().is_empty() {
            files.push(self.source.file_path.clone());
        }
        files.extend(self.input.materials.iter().filter_map(|m| m.diffuse_texture.clone()));
        let env_map = self.source.file.as_ref().and_then(|f| f.environment.as_ref()?.map.as_ref());
        if let Some(m) = env_map {
            files.push(self.source.file_path.parent().unwrap_or(Path::new(".")).join(m));
        }
        for f in &files {
            // Regular files only: a FIFO texture must not block the digest.
            match scene::read_regular_file(f, 1 << 40) {
                Ok(bytes) => d.part("file", &bytes),
                Err(e) => d.part("unreadable file", e.to_string().as_bytes()),
            }
        }
        // Compute the digest of the resolved settings.
        let materials: Vec<_> = self
            .input
            .materials
            .iter()
            .map(|m| scene::Material { diffuse_texture: None, ..m.clone() })
            .collect();
        let p = &self.plan;
        let settings = format!(
            "{:?}",
            (
                (p.width, p.height, p.spp, p.seed, p.frames, k, p.format, p.alpha),
                (&self.load, &materials, &self.modes, self.settings.packets),
                (self.shading, self.terminator, self.camera, self.ground),
            )
        );
        d.part("settings", settings.as_bytes());
        d.part("version", env!("CARGO_PKG_VERSION").as_bytes());
        // Name the settings most likely to differ.
        let scene = if self.source.file_path.as_os_str().is_empty() {
            &self.source.obj
        } else {
            &self.source.file_path
        };
        let scene = scene.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let fields = [
            ("scene", scene),
            (
                "mode",
                match self.modes.default {
                    ObjectMode::Flat => "flat".to_string(),
                    ObjectMode::Phong { alpha } => format!("phong:{alpha}"),
                },
            ),
            ("spp", p.spp.to_string()),
            ("seed", p.seed.to_string()),
            ("frame", k.map_or("-".into(), |k| k.to_string())),
            ("version", env!("CARGO_PKG_VERSION").to_string()),
        ];
        RenderRecord {
            digest: d.finish(),
            fields: fields.into_iter().map(|(k, v)| (k.to_string(), v)).collect(),
        }
    }

    /// The world to render: every object in its mode (or all in `forced`), the key light
    /// following the camera unless the scene file places lights, and the scene file's settings.
    fn world(&self, device: &Device, forced: Option<ObjectMode>) -> anyhow::Result<World> {
        let mut world = World::from_scene_with_ground(device, &self.input, self.ground, |_, mesh| {
            self.modes.settings(forced, mesh)
        })?;
        world.shading = self.shading;
        world.terminator = self.terminator;
        if forced.is_none() {
            for w in &world.warnings {
                eprintln!("phongrt: warning: {w}");
            }
        }
        world.lights = vec![Light::Directional {
            direction: self.camera.key_light_direction(),
            radiance: Vec3::splat(0.85),
            shadows: true,
        }];
        let Some(sf) = &self.source.file else {
            return Ok(world);
        };
        apply_scene_file(&mut world, sf);
        if let Some(e) = &sf.environment {
            let source = match (&e.color, &e.map) {
                (Some(c), _) => render::EnvironmentSource::Constant(Vec3::from(*c)),
                (None, Some(m)) => {
                    let path = self.source.file_path.parent().unwrap_or(Path::new(".")).join(m);
                    let texture = render::Environment::load_map(&path).map_err(anyhow::Error::msg)?;
                    let up = self.camera.up.normalize_or_zero();
                    render::EnvironmentSource::Map { texture: std::sync::Arc::new(texture), up }
                }
                (None, None) => bail!("environment: give color or map"),
            };
            world.environment = Some(render::Environment { source, samples: e.samples.unwrap_or(16) });
        }
        Ok(world)
    }
}

/// The camera: the default view (up axis detected unless given, three-quarter front view,
/// --orbit), then the scene file's and the command line's settings over it. A camera that makes
/// no image is an error naming where each setting came from.
fn resolve_camera(
    args: &RenderArgs,
    source: &SceneSource,
    plan: &RenderPlan,
    input: &scene::Scene,
) -> anyhow::Result<Camera> {
    let sf = source.file.as_ref();
    let (width, height) = (plan.width, plan.height);
    let up_given = args.camera.up.or(sf.and_then(|s| s.camera.up).map(Vec3::from));
    let sf_camera = sf.map(|s| s.camera.clone()).unwrap_or_default();
    let single_orbit = if plan.frames.is_some() { None } else { args.farm.orbit };
    let (mut camera, detection) = render::camera::default_view(
        input,
        up_given,
        single_orbit.or(sf_camera.orbit).unwrap_or(0.0),
        args.camera.fov.or(sf_camera.fov),
        width as f32 / height as f32,
    );
    if up_given.is_none() && !args.quiet {
        eprintln!("phongrt: {detection}");
    }
    // Apply the settings, noting where each came from.
    let mut from = ["automatic framing".to_string(), "automatic framing".into(), "detection".into()];
    let in_file = |key: &str| format!("{} camera.{key}", source.file_path.display());
    if let Some(e) = sf_camera.eye {
        camera.eye = Vec3::from(e);
        from[0] = in_file("eye");
    }
    if let Some(l) = sf_camera.look_at {
        camera.look_at = Vec3::from(l);
        from[1] = in_file("look_at");
    }
    if sf_camera.up.is_some() {
        from[2] = in_file("up");
    }
    if let Some(e) = args.camera.eye {
        camera.eye = e;
        from[0] = "--eye".into();
    }
    if let Some(l) = args.camera.look_at {
        camera.look_at = l;
        from[1] = "--look-at".into();
    }
    if args.camera.up.is_some() {
        from[2] = "--up".into();
    }
    // Check it. (A zero image size makes the framing infinite; render() refuses that size itself.)
    if let Some(p) = camera.problem().filter(|_| width > 0 && height > 0) {
        let src = match p {
            render::CameraProblem::EyeAtLookAt(_) | render::CameraProblem::NonFinite { .. } => {
                format!("eye from {}, look_at from {}", from[0], from[1])
            }
            render::CameraProblem::UpParallel { .. } => {
                format!("up from {}, eye from {}, look_at from {}", from[2], from[0], from[1])
            }
            render::CameraProblem::Fov(_) if args.camera.fov.is_some() => "--fov".into(),
            render::CameraProblem::Fov(_) => in_file("fov"),
        };
        // A camera made bad by flags is bad usage; one from a file is bad input.
        if src.contains("--") {
            usage!("camera: {p} ({src})");
        }
        bail!("camera: {p} ({src})");
    }
    Ok(camera)
}

fn render_cmd(args: RenderArgs) -> anyhow::Result<()> {
    let t_start = Instant::now();
    let job = RenderJob::resolve(&args, t_start)?;
    let device = Device::new().context("cannot start Embree")?;
    if args.compare {
        run_compare(job, &device, t_start)
    } else {
        run_frames(job, &device, t_start)
    }
}

/// `--compare`: flat everywhere on the left; on the right each object as a plain render makes
/// it (the scene file's and --object's per-object mode and alpha); their difference.
fn run_compare(mut job: RenderJob, device: &Device, t_start: Instant) -> anyhow::Result<()> {
    let t = Instant::now();
    let flat = job.world(device, Some(ObjectMode::Flat))?;
    let phong = job.world(device, None)?;
    job.stages.build = t.elapsed().as_secs_f64();
    let quiet = job.quiet;
    if !quiet {
        eprintln!("phongrt: {}", phong.effects());
    }
    let a = render::render(&flat, &job.camera, &job.settings)?;
    report(quiet, "flat", &a);
    let b = render::render(&phong, &job.camera, &job.settings)?;
    report(quiet, "phong", &b);
    let ms = |o: &RenderOutput| o.elapsed.as_secs_f64() * 1e3;
    let img = render::compare_panel(
        &a.image,
        &b.image,
        &format!("flat {:.1} ms", ms(&a)),
        &format!("phong {:.1} ms ({:.2}x)", ms(&b), ms(&b) / ms(&a).max(1e-9)),
    );
    let plan = &job.plan;
    let t = Instant::now();
    let bytes = image_out::encode(&img, plan.format, &EncodeOptions::default())?;
    write_output(&plan.output, &bytes)?;
    let write = t.elapsed().as_secs_f64();
    if !quiet {
        eprintln!("phongrt: wrote {} (flat | phong | difference)", plan.output.name());
    }
    let frames =
        [frame_stats(plan, None, &plan.output, &a, write), frame_stats(plan, None, &plan.output, &b, 0.0)];
    write_stats(plan, &job.stages, &phong, &frames, t_start)
}

/// Every frame of the plan (one without --frames), each written as soon as it is rendered.
fn run_frames(mut job: RenderJob, device: &Device, t_start: Instant) -> anyhow::Result<()> {
    let t = Instant::now();
    let world = job.world(device, None)?;
    job.stages.build = t.elapsed().as_secs_f64();
    // --quiet: warnings and errors only.
    let quiet = job.quiet;
    if !quiet {
        eprintln!("phongrt: {}", world.effects());
    }
    let plan = &job.plan;
    let extent = RenderExtent { crop: plan.crop, alpha: plan.alpha };
    let mut frames = Vec::new();
    for (k, output) in plan.outputs() {
        // Compute the frame's camera: an orbit of the eye about the look-at point.
        let camera = match (k, plan.frames) {
            (Some(k), Some(f)) => orbit(&job.camera, f.orbit_deg * k as f32 / f.count as f32),
            _ => job.camera,
        };
        if let Some(p) = camera.problem() {
            bail!("camera of frame {}: {p} (the orbit of --frames)", k.unwrap_or(0));
        }
        // Record what the tile is of (its files read before the render), then render, encode and
        // write it.
        let record = plan.crop.map(|_| job.record(k).to_text());
        let out = render::render_extent(&world, &camera, &job.settings, &extent)?;
        let t = Instant::now();
        let window = out.window;
        let opts = EncodeOptions {
            alpha: out.alpha.as_deref(),
            window: (!window.is_full()).then_some(window),
            // Every tile or crop records its render, even one that is the whole frame (--tile 0/1).
            render: record.as_deref(),
        };
        let bytes = image_out::encode(&out.image, plan.format, &opts)?;
        write_output(&output, &bytes)?;
        let write = t.elapsed().as_secs_f64();
        if out.clamped_samples > 0 {
            eprintln!(
                "phongrt: warning: {}: {} samples had radiance that is not a finite f32 number (a light too \
                 bright?): NaN made 0, the rest clamped to {:e}",
                output.name(),
                out.clamped_samples,
                render::MAX_SAMPLE_RADIANCE
            );
        }
        report(quiet, &output.name(), &out);
        frames.push(frame_stats(plan, k, &output, &out, write));
    }
    write_stats(plan, &job.stages, &world, &frames, t_start)
}

/// The camera turned by `deg` about its up vector, around the look-at point.
fn orbit(c: &Camera, deg: f32) -> Camera {
    let axis = c.up.normalize_or_zero();
    if axis == Vec3::ZERO {
        return *c;
    }
    let q = glam::Quat::from_axis_angle(axis, deg.to_radians());
    Camera { eye: c.look_at + q * (c.eye - c.look_at), ..*c }
}

/// Write the encoded image: a file replaced only by a complete one, or stdout, every write checked.
fn write_output(output: &Output, bytes: &[u8]) -> anyhow::Result<()> {
    match output {
        Output::File(p) => Ok(image_out::write_atomically(p, bytes)?),
        Output::Stdout => Ok(image_out::write_stdout(bytes)?),
    }
}

fn frame_stats(
    plan: &RenderPlan,
    k: Option<u32>,
    output: &Output,
    out: &RenderOutput,
    write_s: f64,
) -> serde_json::Value {
    let r = &out.rays;
    let secs = out.elapsed.as_secs_f64();
    let w = out.window;
    serde_json::json!({
        "frame": k,
        "output": output.name(),
        "window": [w.x0, w.y0, w.x1, w.y1],
        "width": out.image.width,
        "height": out.image.height,
        "threads": out.threads,
        "rays": {
            "primary": r.primary, "shadow": r.shadow, "reflection": r.reflection,
            "refraction": r.refraction, "ambient_occlusion": r.ambient_occlusion,
            "coverage": r.coverage, "total": r.total(),
        },
        "mrays_per_s": r.total() as f64 / secs.max(1e-9) / 1e6,
        "seconds": { "render": secs, "write": write_s },
        "clamped_samples": out.clamped_samples,
        "format": format!("{:?}", plan.format).to_lowercase(),
    })
}

fn write_stats(
    plan: &RenderPlan,
    stages: &Stages,
    world: &World,
    frames: &[serde_json::Value],
    t_start: Instant,
) -> anyhow::Result<()> {
    let Some(target) = &plan.stats else {
        return Ok(());
    };
    let e = world.effects();
    let doc = serde_json::json!({
        "full_width": plan.width,
        "full_height": plan.height,
        "spp": plan.spp,
        "seed": plan.seed,
        "effects": {
            "summary": e.to_string(),
            "shadow_lights": e.shadow_lights,
            "soft_shadow_lights": e.soft_shadow_lights,
            "reflective": e.reflective,
            "refractive": e.refractive,
            "ambient_occlusion": e.ambient_occlusion.map(|a| serde_json::json!({"samples": a.samples, "distance": a.distance})),
            "max_depth": e.max_depth,
        },
        "seconds": { "load": stages.load, "build": stages.build, "total": t_start.elapsed().as_secs_f64() },
        "frames": frames,
    });
    let text = serde_json::to_string_pretty(&doc)? + "\n";
    match target {
        StatsTarget::Print if plan.output == Output::Stdout => eprint!("{text}"),
        StatsTarget::Print => {
            let mut out = std::io::stdout().lock();
            out.write_all(text.as_bytes())
                .and_then(|_| out.flush())
                .context("--stats json: cannot write to stdout")?;
        }
        StatsTarget::File(p) => image_out::write_atomically(p, text.as_bytes())?,
    }
    Ok(())
}

/// Assemble tiles into one image (see [`phongrt_render::stitch`]).
fn stitch_cmd(args: StitchArgs) -> anyhow::Result<()> {
    match render::stitch::stitch(&args.output, &args.tiles) {
        Ok(s) => {
            eprintln!(
                "phongrt: wrote {} ({}x{} from {} tiles)",
                args.output.display(),
                s.width,
                s.height,
                s.tiles
            );
            Ok(())
        }
        Err(e @ StitchError::Refused(_)) => Err(Usage(e.to_string()).into()),
        Err(StitchError::Image(e)) => Err(e.into()),
    }
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
    use phongrt_cli::bench::{
        bench_scene, equal_depth_summary, equal_silhouette_summary, mem_total, plot, plot_scaling, to_csv,
        to_markdown, BenchMethod, BenchOptions,
    };
    if !(8..=4096).contains(&args.size) {
        usage!("--size {} is not in 8..=4096", args.size);
    }
    if let Some(l) = args.levels.iter().find(|&&l| !(1..=4096).contains(&l)) {
        usage!("--levels {l}: each level must be in 1..=4096");
    }
    let mut levels = args.levels.clone();
    levels.sort_unstable();
    levels.dedup();
    let methods: Vec<BenchMethod> = BenchMethod::all_with_levels(&levels)
        .into_iter()
        .filter(|m| !matches!(m, BenchMethod::Pretessellated(l) if *l > args.max_level))
        .collect();
    let mut scenes: Vec<(String, scene::Mesh)> = Vec::new();
    for &s in &args.spheres {
        if !(3..=4096).contains(&s) {
            usage!("--spheres {s}: segments is not in 3..=4096");
        }
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
    let mut profiles = Vec::new();
    for (name, m) in &scenes {
        bar.set_message(format!("{name}: profile"));
        for k in [1, 8] {
            profiles.extend(phongrt_cli::profile::profile_scene(name, m, args.size, args.size, k)?);
        }
    }
    bar.finish_and_clear();
    let mem = mem_total();
    let md = format!(
        "{}\n{}\nPre-tessellation that matches direct Phong's silhouette ({ram} GB of RAM here):\n\n{}\n\
         Pre-tessellation that matches direct Phong's hit distances (median relative error, {ram} GB of RAM here):\n\n{}",
        to_markdown(&rows),
        phongrt_cli::profile::to_markdown(&profiles),
        equal_silhouette_summary(&rows, mem),
        equal_depth_summary(&rows, mem),
        ram = mem.map_or("?".to_string(), |m| format!("{:.1}", m as f64 / 1e9)),
    );
    std::fs::write(args.out.join("bench.csv"), to_csv(&rows))?;
    std::fs::write(args.out.join("bench.md"), &md)?;
    save_plot(&plot(&rows)?, &args.out.join("bench.png"))?;
    save_plot(&plot_scaling(&rows)?, &args.out.join("bench-scaling.png"))?;
    print!("{md}");
    eprintln!("phongrt: wrote {}/bench.csv, bench.md, bench.png, bench-scaling.png", args.out.display());
    Ok(())
}

/// A plot saved as PNG through image 0.25's encoder, written with `write_atomically`.
fn save_plot(img: &image::RgbImage, path: &Path) -> anyhow::Result<()> {
    let mut bytes = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
        .with_context(|| format!("{}: cannot encode PNG", path.display()))?;
    Ok(image_out::write_atomically(path, &bytes)?)
}

fn report(quiet: bool, what: &str, out: &RenderOutput) {
    if quiet {
        return;
    }
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

/// The largest patch offset from its flat triangle relative to the triangle's width, over the
/// scene's meshes at the default alpha with straight creases: `(ratio, mesh, triangle)`.
fn largest_deviation(s: &scene::Scene) -> Option<(f64, usize, usize)> {
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

fn info_cmd(args: InfoArgs) -> anyhow::Result<()> {
    let s = load(&args.scene, &load_options(&args.load, args.load.crease_angle)?)?;
    let device = Device::new().context("cannot start Embree")?;
    let (major, minor, patch) = device.version();
    let st = &s.stats;
    let (lo, hi) = s.bounds();
    if args.json {
        let doc = serde_json::json!({
            "file": args.scene.display().to_string(),
            "embree": { "version": format!("{major}.{minor}.{patch}"), "headers": embree::header_version().to_string(), "isa": device.isa().to_string() },
            "objects": s.meshes.len(),
            "materials": s.materials.len(),
            "vertices": st.vertices,
            "triangles": st.triangles,
            "normals": { "from_file": st.normals_from_file, "computed": st.normals_computed },
            "edges": { "smooth": st.smooth_edges, "crease": st.crease_edges, "border": st.border_edges, "nonmanifold": st.nonmanifold_edges },
            "degenerate_skipped": st.degenerate_skipped,
            "largest_deviation": largest_deviation(&s).map(|(r, m, t)| serde_json::json!({ "ratio": r, "object": s.meshes[m].name, "triangle": t })),
            "duplicates_dropped": st.duplicates_dropped,
            "bounds": [lo.to_array(), hi.to_array()],
            "meshes": s.meshes.iter().map(|m| serde_json::json!({
                "name": m.name, "vertices": m.positions.len(), "triangles": m.indices.len(),
                "normals": format!("{:?}", m.normals_source),
            })).collect::<Vec<_>>(),
        });
        println!("{}", serde_json::to_string_pretty(&doc)?);
        return Ok(());
    }
    println!("file: {}", args.scene.display());
    println!("embree: {major}.{minor}.{patch} (headers {}), ISA {}", embree::header_version(), device.isa());
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
    if st.duplicates_dropped > 0 {
        println!("dropped: {} duplicate triangles", st.duplicates_dropped);
    }
    println!("bounds: [{:.6}, {:.6}, {:.6}] .. [{:.6}, {:.6}, {:.6}]", lo.x, lo.y, lo.z, hi.x, hi.y, hi.z);
    if let Some((ratio, mesh, tri)) = largest_deviation(&s) {
        println!(
            "deviation: largest patch offset from its flat triangle {ratio:.4} × the triangle's width (smallest altitude; alpha {}, object {:?}, triangle {tri})",
            phongrt::phong::DEFAULT_ALPHA,
            s.meshes[mesh].name
        );
    }
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
