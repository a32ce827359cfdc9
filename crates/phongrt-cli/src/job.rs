//! A render job: the scene source, the mesh, the per-object modes, the camera and the world, resolved once from the command line over the scene file over the defaults.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context};
use glam::Vec3;

use crate::cli::{self, RenderArgs};
use crate::load::{load, load_options, parse_object_override};
use crate::plan::{plan, RenderPlan};
use crate::progress::Stage;
use crate::Usage;
use phongrt::embree::Device;
use phongrt::scene::{self, LoadOptions};
use phongrt_render::render_record::{Digest, RenderRecord};
use phongrt_render::scene_file::{self, LightSection, SceneFile};
use phongrt_render::{
    self as render, Camera, Light, ObjectMode, ObjectSettings, RenderSettings, SurfaceMode, World,
};

/// Stage times of one run, in seconds.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Stages {
    pub(crate) load: f64,
    pub(crate) build: f64,
}

/// The OBJ to render and the scene file that goes with it: a .toml scene names its OBJ; an OBJ
/// may take a scene file with --scene-file.
pub(crate) struct SceneSource {
    pub(crate) obj: PathBuf,
    pub(crate) file: Option<SceneFile>,
    /// The scene file's path, for messages and relative paths (empty without one).
    pub(crate) file_path: PathBuf,
}

impl SceneSource {
    pub(crate) fn resolve(args: &RenderArgs) -> anyhow::Result<SceneSource> {
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
pub(crate) struct ModeRules {
    pub(crate) default: ObjectMode,
    /// `--alpha`: what an object made Phong without an alpha gets when it was flat.
    pub(crate) alpha: f32,
    pub(crate) file_objects: Vec<scene_file::ObjectSection>,
    /// `--object`: a name (or "*"), a mode and its alpha if given.
    pub(crate) overrides: Vec<(String, SurfaceMode, Option<f32>)>,
    pub(crate) straight_creases: bool,
}

impl ModeRules {
    /// The settings of `mesh`, or `forced` mode for every object.
    pub(crate) fn settings(&self, forced: Option<ObjectMode>, mesh: &scene::Mesh) -> ObjectSettings {
        let straight_creases = self.straight_creases;
        if let Some(mode) = forced {
            return ObjectSettings { mode, straight_creases };
        }
        let matching = self.file_objects.iter().filter(|o| o.name == "*" || o.name == mesh.name);
        let mut mode = matching.fold(self.default, |m, o| o.mode_over(m, self.alpha));
        for (name, m, alpha) in &self.overrides {
            if name == "*" || *name == mesh.name {
                mode = m.over(*alpha, mode, self.alpha);
            }
        }
        ObjectSettings { mode, straight_creases }
    }
}

/// Every choice of a render, resolved once (the command line over the scene file over the
/// defaults) and checked, with the mesh loaded: what `run` needs and nothing to decide.
pub(crate) struct RenderJob {
    /// Show a progress bar on stderr (when it is a terminal).
    pub(crate) progress: bool,
    pub(crate) plan: RenderPlan,
    pub(crate) source: SceneSource,
    pub(crate) input: scene::Model,
    pub(crate) load: LoadOptions,
    pub(crate) modes: ModeRules,
    pub(crate) settings: RenderSettings,
    pub(crate) shading: phongrt::phong::ShadingNormal,
    pub(crate) terminator: render::Terminator,
    pub(crate) camera: Camera,
    pub(crate) ground: Option<render::Ground>,
    pub(crate) stages: Stages,
    /// --quiet: warnings and errors only on stderr.
    pub(crate) quiet: bool,
}

impl RenderJob {
    pub(crate) fn resolve(args: &RenderArgs, t_start: Instant) -> anyhow::Result<RenderJob> {
        // Resolve the scene source and every option that needs no mesh.
        let source = SceneSource::resolve(args)?;
        let sf = source.file.as_ref();
        let plan = plan(args, sf)?;
        let overrides: Vec<(String, SurfaceMode, Option<f32>)> =
            args.objects.iter().map(|s| parse_object_override(s)).collect::<anyhow::Result<_>>()?;

        // Load the mesh, and check the object names given for it.
        let crease = sf.and_then(|s| s.crease_angle).unwrap_or(args.load.crease_angle);
        let load_opts = load_options(&args.load, crease)?;
        let input = load(&source.obj, &load_opts, !args.quiet)?;
        for (name, ..) in &overrides {
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
            alpha: args.alpha,
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
        let ground = resolve_ground(args, sf, &plan, &input, &camera);
        let settings = RenderSettings {
            width: plan.width,
            height: plan.height,
            spp: plan.spp,
            seed: plan.seed,
            packets: args.packets == cli::Switch::On,
        };
        Ok(RenderJob {
            progress: !args.quiet,
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
    pub(crate) fn record(&self, k: Option<u32>) -> RenderRecord {
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
    /// following the camera unless the scene file places lights, and the scene file's settings
    /// (the command line's shading, terminator and ground over them).
    pub(crate) fn world(&self, device: &Device, forced: Option<ObjectMode>) -> anyhow::Result<World> {
        // Compute the builder: the key light, the scene file over it, the resolved choices over both.
        let key_light = Light::Directional {
            direction: self.camera.key_light_direction(),
            radiance: Vec3::splat(0.85),
            shadows: true,
        };
        let mut builder = World::builder(device, &self.input).lights([key_light]);
        if let Some(sf) = &self.source.file {
            builder = builder.scene_file(sf, &self.source.file_path, self.camera.up)?;
        }
        let builder = builder
            .settings(|_, mesh| self.modes.settings(forced, mesh))
            .ground(self.ground)
            .shading(self.shading)
            .terminator(self.terminator);
        // Build it, and name its warnings once.
        let what = match forced {
            Some(ObjectMode::Flat) => "building the flat scene",
            _ => "building the scene",
        };
        let building = Stage::start(what.to_string(), self.progress);
        let world = builder.build();
        drop(building);
        let world = world?;
        if forced.is_none() {
            for w in world.warnings() {
                eprintln!("phongrt: warning: {w}");
            }
        }
        Ok(world)
    }
}

/// The ground (--ground or the scene file's `[ground]`), perpendicular to the camera's up, and
/// large enough that the view does not see its far edge (--frame-shadow off: as before).
fn resolve_ground(
    args: &RenderArgs,
    sf: Option<&SceneFile>,
    plan: &RenderPlan,
    input: &scene::Model,
    camera: &Camera,
) -> Option<render::Ground> {
    let up = camera.up.normalize_or_zero();
    let sf_ground = sf.and_then(|s| s.ground.clone());
    (args.ground || sf_ground.is_some()).then(|| {
        let g = sf_ground.unwrap_or_default();
        let kd = g.kd.map_or(render::Ground::default().kd, Vec3::from);
        let ground = render::Ground { up, height: g.height, kd, radius: None };
        let aspect = plan.width as f32 / plan.height as f32;
        let fit = args.camera.frame_shadow == cli::Switch::On;
        let radius = fit.then(|| ground.radius_for_view(input.bounds(), camera, aspect));
        render::Ground { radius, ..ground }
    })
}

/// The camera: the default view (up axis detected unless given, three-quarter front view,
/// --orbit), then the scene file's and the command line's settings over it. A camera that makes
/// no image is an error naming where each setting came from.
pub(crate) fn resolve_camera(
    args: &RenderArgs,
    source: &SceneSource,
    plan: &RenderPlan,
    input: &scene::Model,
) -> anyhow::Result<Camera> {
    let sf = source.file.as_ref();
    let (width, height) = (plan.width, plan.height);
    let up_given = args.camera.up.or(sf.and_then(|s| s.camera.up).map(Vec3::from));
    let sf_camera = sf.map(|s| s.camera.clone()).unwrap_or_default();
    let single_orbit = if plan.frames.is_some() { None } else { args.farm.orbit };
    // With a ground, the default view frames the model's shadow too (--frame-shadow off: not).
    // A scene file's lights replace the key light: the first directional one casts the shadow
    // to frame; with only point or sphere lights the model is framed alone.
    let sf_ground = sf.and_then(|s| s.ground.as_ref());
    let sf_lights = sf.map(|s| &s.lights[..]).unwrap_or_default();
    let ground_light = sf_lights.iter().find_map(|l| match l {
        LightSection::Directional { direction, .. } => Some(Vec3::from(*direction)),
        _ => None,
    });
    let options = render::camera::DefaultViewOptions {
        ground: (args.ground || sf_ground.is_some())
            && args.camera.frame_shadow == cli::Switch::On
            && (sf_lights.is_empty() || ground_light.is_some()),
        ground_height: sf_ground.and_then(|g| g.height),
        ground_light,
        front_cues: args.camera.front_cues == cli::Switch::On,
    };
    let (mut camera, detection) = render::camera::default_view_with(
        input,
        up_given,
        single_orbit.or(sf_camera.orbit).unwrap_or(0.0),
        args.camera.fov.or(sf_camera.fov),
        width as f32 / height as f32,
        options,
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
    if width > 0 && height > 0 {
        let fov_from = if args.camera.fov.is_some() { "--fov".into() } else { in_file("fov") };
        check_camera(&camera, &from, &fov_from)?;
    }
    Ok(camera)
}

/// A camera that makes no image is an error naming where each setting came from (`from`: eye,
/// look_at and up; `fov_from`): bad usage if a flag made it bad, bad input if a file did.
fn check_camera(camera: &Camera, from: &[String; 3], fov_from: &str) -> anyhow::Result<()> {
    let Some(p) = camera.problem() else { return Ok(()) };
    let src = match p {
        render::CameraProblem::EyeAtLookAt(_) | render::CameraProblem::NonFinite { .. } => {
            format!("eye from {}, look_at from {}", from[0], from[1])
        }
        render::CameraProblem::UpParallel { .. } => {
            format!("up from {}, eye from {}, look_at from {}", from[2], from[0], from[1])
        }
        render::CameraProblem::Fov(_) => fov_from.to_string(),
    };
    if src.contains("--") {
        usage!("camera: {p} ({src})");
    }
    bail!("camera: {p} ({src})");
}
