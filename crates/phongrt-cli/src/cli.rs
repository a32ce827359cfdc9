//! Command-line interface definition (clap).

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};
use glam::Vec3;
use phongrt_render::SurfaceMode;

/// Ray-trace Phong Tessellation directly, as an Embree 4 user geometry.
///
/// A low-polygon mesh with vertex normals renders with smooth silhouettes and smooth shadow
/// boundaries, with no tessellation. Flat mode renders the same mesh with Embree's own
/// triangles, for comparison.
#[derive(Parser, Debug)]
#[command(name = "phongrt", version, about, long_about = None, propagate_version = true, after_help = EXIT_CODES)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render an OBJ file to a PNG (sRGB) or EXR (linear) image.
    #[command(after_help = RENDER_EXAMPLES)]
    Render(Box<RenderArgs>),
    /// Describe an OBJ file (objects, vertices, triangles, normals, bounds) and the Embree in use.
    Info(InfoArgs),
    /// Assemble tiles rendered with --tile I/N or --crop into one image, bit-identical to the
    /// single-machine render.
    #[command(after_help = STITCH_EXAMPLES)]
    Stitch(StitchArgs),
    /// Measure every intersector (analytic, analytic+polish, Newton; f32 and f64) against an
    /// independent reference on hard cases, and print a markdown table.
    Accuracy(AccuracyArgs),
    /// Measure every method (flat, pre-tessellated 1..64, direct f32/f64, Newton, user-geometry
    /// floor, Catmull-Clark) on spheres of growing size and the given OBJ files: CSV, table, plot.
    Bench(BenchArgs),
    /// Count shading steps in a PNG render: pixels at least --margin px inside the silhouette
    /// (background = the top-left pixel's colour) whose luminance jumps by more than --threshold
    /// /255 to the left or upper neighbour. Prints: steps, largest step, interior pixels.
    Smoothness(SmoothnessArgs),
    /// Print a shell completion script: `phongrt completions bash > /etc/bash_completion.d/phongrt`.
    Completions(CompletionsArgs),
}

#[derive(Args, Debug)]
pub struct CompletionsArgs {
    /// The shell.
    #[arg(value_enum)]
    pub shell: clap_complete::Shell,
}

#[derive(Args, Debug)]
pub struct SmoothnessArgs {
    /// The PNG image.
    pub image: PathBuf,
    /// Luminance step that counts, in 1/255 units.
    #[arg(long, default_value_t = 8.0)]
    pub threshold: f32,
    /// Pixels inside the silhouette that are left out (anti-aliased edges).
    #[arg(long, default_value_t = 3)]
    pub margin: u32,
}

/// A setting that is on or off.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Switch {
    /// On.
    On,
    /// Off.
    Off,
}

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// The OBJ file to render (its MTL files are read too), or a TOML scene file naming one.
    pub scene: PathBuf,
    /// Output image: .png (8-bit sRGB) or .exr (linear float, ZIP compressed); "-" writes PNG
    /// to stdout. Checked (extension, directory exists and is writable) before any work.
    #[arg(short, long, default_value = "out.png")]
    pub output: PathBuf,
    /// Image width in pixels [default: 800].
    #[arg(long)]
    pub width: Option<u32>,
    /// Image height in pixels [default: 600].
    #[arg(long)]
    pub height: Option<u32>,
    /// Samples per pixel, for anti-aliasing [default: 1].
    #[arg(long)]
    pub spp: Option<u32>,
    /// Surface mode for every object.
    #[arg(long, value_parser = parse_mode, default_value = "phong")]
    pub mode: SurfaceMode,
    /// Phong shape factor in [0, 1] (0 = flat, 1 = full Phong tessellation; 0.75 is Boubekeur &
    /// Alexa's recommendation, which bulges less).
    #[arg(long, default_value_t = phongrt::phong::DEFAULT_ALPHA)]
    pub alpha: f32,
    /// Shading normal of Phong surfaces: adapted (continuous; Keller et al. 2017), paper (Ogaki &
    /// Tokuyoshi §4's switch to the true normal) or interpolated [default: adapted].
    #[arg(long, value_parser = parse_shading)]
    pub shading: Option<phongrt::phong::ShadingNormal>,
    /// Terminator of Phong surfaces: lift (shadow rays from Hanika's lifted origin), plain (from the
    /// true surface), or band (the former true-normal band, for comparison) [default: lift].
    #[arg(long, value_parser = parse_terminator)]
    pub terminator: Option<phongrt_render::Terminator>,
    /// A ground plane under the scene (perpendicular to the camera's up), receiving its shadows.
    #[arg(long)]
    pub ground: bool,
    /// Render flat and Phong side by side with a difference panel (the paper's Figure 1).
    #[arg(long)]
    pub compare: bool,
    /// Bend crease edges by their own normals like plain Phong tessellation (cracks open along
    /// creases); only to show what the default straight-crease rule prevents.
    #[arg(long)]
    pub open_creases: bool,
    /// A TOML scene file with camera, lights, per-object mode/alpha and render settings.
    #[arg(long)]
    pub scene_file: Option<PathBuf>,
    /// Per-object mode, repeatable: NAME=flat, NAME=phong or NAME=phong:ALPHA (overrides --mode).
    #[arg(long = "object", value_name = "NAME=MODE")]
    pub objects: Vec<String>,
    /// Render threads, at least 1 [default: all cores]; more than the machine has starts what it
    /// has. The image does not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Trace camera rays and hard shadows in coherent 8-ray packets from 4x2 pixel blocks (on),
    /// or every ray alone (off). The image is the same either way.
    #[arg(long, value_enum, default_value_t = Switch::On)]
    pub packets: Switch,
    #[command(flatten)]
    pub farm: FarmArgs,
    #[command(flatten)]
    pub camera: CameraArgs,
    #[command(flatten)]
    pub load: LoadArgs,
    /// Warnings and errors only: no progress bar, no notes (up axis, effects, timings).
    #[arg(long, short)]
    pub quiet: bool,
}

#[derive(Args, Debug)]
pub struct CameraArgs {
    /// Camera position "x,y,z" (default: framed on the scene bounds).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub eye: Option<Vec3>,
    /// Point the camera looks at "x,y,z" (default: the centre of the scene bounds).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub look_at: Option<Vec3>,
    /// The model's up axis: y, z (or -y, x, ...) or a vector "x,y,z" [default: detected: +z for a
    /// model standing on a base low on z, else +y; see "Camera and framing" in the README].
    #[arg(long, value_parser = parse_up, allow_hyphen_values = true)]
    pub up: Option<Vec3>,
    /// Vertical field of view in degrees, in (0, 180) [default: 35].
    #[arg(long)]
    pub fov: Option<f32>,
    /// With a ground, frame the model and the shadow it casts under the key light together (on),
    /// or the model alone (off, the rule before).
    #[arg(long, value_enum, default_value_t = Switch::On)]
    pub frame_shadow: Switch,
    /// Turn the default view's front towards a face (objects named head, face, eye, Kopf, ...) or
    /// so a handle shows (on), or keep the exporters' convention and long models' head end (off,
    /// the rule before).
    #[arg(long, value_enum, default_value_t = Switch::On)]
    pub front_cues: Switch,
}

#[derive(Args, Debug)]
pub struct LoadArgs {
    /// Where a mesh has no normals, edges sharper than this (degrees) stay sharp.
    #[arg(long, default_value_t = 30.0)]
    pub crease_angle: f32,
    /// Where a mesh has no normals, neighbouring small faces (longest side at most a fifth of
    /// the object's size) stay smooth up to this angle (degrees), so low-poly models are smooth
    /// and buildings' large faces keep --crease-angle; 0 uses --crease-angle everywhere (the
    /// rule before).
    #[arg(long, default_value_t = phongrt::scene::SMALL_FACE_CREASE_DEG)]
    pub small_face_crease_angle: f32,
    /// Normals at one position within this angle (radians) count as one, so the edge between
    /// them is smooth; 0 compares them bit for bit (the rule before, -0 and 0 distinct).
    #[arg(long, default_value_t = phongrt::mesh::NORMAL_TOLERANCE)]
    pub normal_tolerance: f32,
    /// Keep triangles that repeat another's three positions (by default they are dropped with
    /// a warning, as their edges would be non-manifold and straight).
    #[arg(long)]
    pub keep_duplicate_faces: bool,
    /// Keep a smooth edge straight when its curve (at alpha 1) would stand off its chord by more
    /// than this many times the height of a triangle beside it: no balloons on slivers. `inf`
    /// keeps every smooth edge curved (the rule before).
    #[arg(long, default_value_t = phongrt::mesh::BULGE_LIMIT)]
    pub bulge_limit: f32,
}

#[derive(Args, Debug)]
pub struct InfoArgs {
    /// The OBJ file to describe.
    pub scene: PathBuf,
    /// Print the description as one JSON object.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub load: LoadArgs,
}

#[derive(Args, Debug)]
pub struct AccuracyArgs {
    /// Rays per category.
    #[arg(long, default_value_t = 2000)]
    pub rays: usize,
    /// Seed of the case generator.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Extra OBJ models (the first mesh of each).
    pub models: Vec<PathBuf>,
    /// Output directory for bench.csv, bench.md, bench.png and bench-scaling.png.
    #[arg(long, default_value = "bench-out")]
    pub out: PathBuf,
    /// Image size (primary rays per method = size²).
    #[arg(long, default_value_t = 256)]
    pub size: u32,
    /// Sphere sizes as segments (rings = segments / 2), comma separated.
    #[arg(long, default_value = "12,48,192", value_delimiter = ',')]
    pub spheres: Vec<u32>,
    /// Pre-tessellation levels (segments per edge) to build, comma separated.
    #[arg(long, default_value = "1,2,4,8,16,32,64", value_delimiter = ',')]
    pub levels: Vec<u32>,
    /// Skip pre-tessellation levels above this.
    #[arg(long, default_value_t = u32::MAX, hide_default_value = true)]
    pub max_level: u32,
    /// Skip pre-tessellations of more triangles than this (about 85-100 bytes each in Embree).
    #[arg(long, default_value_t = phongrt_cli::bench::MAX_PRETESSELLATED_TRIANGLES)]
    pub max_pretess_tris: u64,
    /// Build every scene in Embree's robust mode (RTC_SCENE_FLAG_ROBUST): no rays slipping between
    /// the tiny triangles of a fine pre-tessellation, at some cost in speed.
    #[arg(long)]
    pub robust: bool,
}

/// Parse a surface mode name (`--mode`; the scene file's `mode` takes the same names).
pub fn parse_mode(s: &str) -> Result<SurfaceMode, String> {
    SurfaceMode::from_name(s).ok_or_else(|| {
        let names: Vec<&str> = SurfaceMode::ALL.iter().map(|m| m.name()).collect();
        format!("{s:?} is not one of {}", names.join(", "))
    })
}

/// Parse a shading-normal rule name.
pub fn parse_shading(s: &str) -> Result<phongrt::phong::ShadingNormal, String> {
    use phongrt::phong::ShadingNormal;
    ShadingNormal::from_name(s).ok_or_else(|| {
        let names: Vec<&str> = ShadingNormal::ALL.iter().map(|r| r.name()).collect();
        format!("{s:?} is not one of {}", names.join(", "))
    })
}

/// Parse a terminator rule name.
pub fn parse_terminator(s: &str) -> Result<phongrt_render::Terminator, String> {
    use phongrt_render::Terminator;
    Terminator::from_name(s).ok_or_else(|| {
        let names: Vec<&str> = Terminator::ALL.iter().map(|r| r.name()).collect();
        format!("{s:?} is not one of {}", names.join(", "))
    })
}

/// Crop, tiles, frames, seed, stats and alpha: what a farm scheduler's task needs.
#[derive(Args, Debug)]
pub struct FarmArgs {
    /// Render only the pixels X0 <= x < X1, Y0 <= y < Y1 of the full frame; the output is the
    /// window's size and records its place for `phongrt stitch`.
    #[arg(long, value_name = "X0,Y0,X1,Y1")]
    pub crop: Option<String>,
    /// Render tile I of N (0 <= I < N): N bands of whole rows, for one scheduler task each.
    #[arg(long, value_name = "I/N")]
    pub tile: Option<String>,
    /// Render N frames of an orbit around the look-at point, written as OUT_0000.EXT, ...
    #[arg(long, value_name = "N")]
    pub frames: Option<u32>,
    /// Render only frame I of --frames N (0 <= I < N), for one scheduler task per frame.
    #[arg(long, value_name = "I", requires = "frames")]
    pub frame: Option<u32>,
    /// Turn the view about the model's up axis by DEG degrees; with --frames N, frame k turns by
    /// k*DEG/N [default: 0; with --frames: 360].
    #[arg(long, value_name = "DEG", allow_hyphen_values = true)]
    pub orbit: Option<f32>,
    /// Seed of the per-pixel sample streams (jitter, area lights, AO).
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub seed: u64,
    /// Write statistics (rays by kind, Mrays/s, time per stage, effects, settings) as JSON:
    /// "json" prints them on stdout (stderr with -o -), anything else is a file to write.
    #[arg(long, value_name = "json|FILE")]
    pub stats: Option<String>,
    /// Add an alpha channel (coverage): premultiplied in EXR, straight in PNG.
    #[arg(long)]
    pub alpha_channel: bool,
}

#[derive(Args, Debug)]
pub struct StitchArgs {
    /// The assembled image (.png or .exr).
    pub output: PathBuf,
    /// The tiles, in any order: PNG or EXR files written by `render --tile` or `--crop`.
    #[arg(required = true, value_name = "TILE")]
    pub tiles: Vec<PathBuf>,
}

/// The exit codes' text, one home for `--help` and `render --help`.
macro_rules! exit_codes {
    () => {
        "Exit status:
  0  success
  1  bad input: an OBJ, MTL or scene file that cannot be read or is invalid, or an output that
     cannot be written
  2  bad usage: an unknown flag, or a flag value that is out of range or malformed"
    };
}

/// Exit codes, shown at the end of `--help`.
pub const EXIT_CODES: &str = exit_codes!();

const RENDER_EXAMPLES: &str = concat!(
    "\
Examples:
  phongrt render scenes/sphere_lowpoly.obj -o sphere.png
  phongrt render scenes/sphere_lowpoly.obj --compare -o compare.png
  phongrt render scene.toml --width 1920 --height 1080 --spp 16 -o frame.exr --alpha-channel
  phongrt render scenes/sphere_lowpoly.obj --tile 3/8 -o tile_3.png     # one task of 8
  phongrt render scenes/sphere_lowpoly.obj --frames 120 --frame 7 -o orbit.png  # writes orbit_0007.png
  phongrt render scenes/sphere_lowpoly.obj --stats json -q -o - > out.png

",
    exit_codes!()
);

const STITCH_EXAMPLES: &str = "\
Examples:
  for i in 0 1 2 3; do phongrt render m.obj --tile $i/4 -o tile_$i.png; done
  phongrt stitch frame.png tile_*.png

Exit status:
  0  success
  1  a tile cannot be read, or the output cannot be written
  2  the tiles overlap, leave a gap, or come from frames of different sizes";

/// Parse an up axis: `x`, `y`, `z` (optionally signed) or "x,y,z" (not zero).
pub fn parse_up(s: &str) -> Result<Vec3, String> {
    let axis = match s.trim() {
        "x" | "+x" => Some(Vec3::X),
        "-x" => Some(-Vec3::X),
        "y" | "+y" => Some(Vec3::Y),
        "-y" => Some(-Vec3::Y),
        "z" | "+z" => Some(Vec3::Z),
        "-z" => Some(-Vec3::Z),
        _ => None,
    };
    let v = match axis {
        Some(v) => v,
        None => parse_vec3(s).map_err(|e| format!("{e} (or an axis: x, y, z, -y, ...)"))?,
    };
    if v.length_squared() == 0.0 {
        return Err("the up vector must not be zero".into());
    }
    Ok(v)
}

/// Parse "x,y,z" into a vector of finite numbers.
pub fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(format!("expected three comma-separated numbers \"x,y,z\", got {s:?}"));
    }
    let mut v = [0.0f32; 3];
    for (i, p) in parts.iter().enumerate() {
        v[i] = p.parse::<f32>().map_err(|_| format!("{p:?} is not a number"))?;
        if !v[i].is_finite() {
            return Err(format!("{p:?} is not finite"));
        }
    }
    Ok(Vec3::from_array(v))
}
