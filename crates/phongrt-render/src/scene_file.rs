//! Optional TOML scene files: an OBJ plus camera, lights, background, per-object mode and α,
//! and render settings. An OBJ alone is a complete scene; the file only adds to it.
//!
//! ```toml
//! obj = "head.obj"                # relative to this file
//! [camera]
//! eye = [0.0, 0.5, 3.0]
//! look_at = [0.0, 0.0, 0.0]
//! fov = 35.0
//! [render]
//! width = 800
//! height = 600
//! spp = 4
//! background = [0.02, 0.02, 0.03]
//! ambient = [0.1, 0.1, 0.1]
//! [[light]]
//! type = "directional"            # or "point", "sphere"
//! direction = [-0.5, 0.7, 0.6]
//! radiance = [0.9, 0.9, 0.9]
//! shadows = true
//! [[object]]
//! name = "head"                   # an object name of the OBJ, or "*" for all
//! mode = "phong"                  # or "flat"
//! alpha = 0.75
//! mirror = [0.5, 0.5, 0.5]        # optional material overrides
//! specular = [0.4, 0.4, 0.4]      # a Blinn-Phong highlight (MTL Ks), with
//! shininess = 64.0                # its exponent (MTL Ns)
//! ```

use std::path::{Path, PathBuf};

use glam::Vec3;
use serde::Deserialize;

use phongrt::scene::ReadFailure;

use super::world::{ObjectMode, SurfaceMode, SurfaceOverride};

/// The most a scene file may hold (16 MiB).
pub const MAX_SCENE_FILE_BYTES: u64 = 16 << 20;

/// Errors in a scene file: each names the file, the key and what is wrong.
#[derive(Debug, thiserror::Error)]
pub enum SceneFileError {
    /// The cause is part of the message (not also a `source()`, so a chain prints it once).
    #[error("{path}: cannot read: {reason}")]
    Io {
        /// The scene file.
        path: PathBuf,
        /// Why it could not be read (the OS error, not a regular file, or over the size limit).
        reason: String,
    },
    /// The file is not UTF-8, not TOML, or does not fit the sections (an unknown key, a value
    /// of the wrong type, a vector without exactly 3 numbers).
    #[error("{path}: {message}")]
    Parse {
        /// The scene file.
        path: PathBuf,
        /// One line: `line N: section.key: reason` where the line and key are known.
        message: String,
    },
    /// A value parsed but is out of range or inconsistent with another.
    #[error("{path}: {key}: {message}")]
    Invalid {
        /// The scene file.
        path: PathBuf,
        /// The key as written in the file, e.g. `camera.fov` or `light[0].radius` (0-based).
        key: String,
        /// What is wrong with the value.
        message: String,
    },
}

/// A parsed and checked scene file (see the module docs for its keys). Every key is optional
/// and an unknown key is an error; what is left out keeps the command line's or
/// [`WorldBuilder`](crate::WorldBuilder)'s default.
#[derive(Debug, Default, Deserialize, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// The OBJ file, relative to the scene file.
    pub obj: Option<PathBuf>,
    /// `[camera]`: the view (default: framed automatically).
    #[serde(default)]
    pub camera: CameraSection,
    /// `[render]`: image size, samples and the integrator's settings.
    #[serde(default)]
    pub render: RenderSection,
    /// The `[[light]]` tables, in file order; if there is any, they replace the default key
    /// light ([`default_lights`](crate::default_lights)).
    #[serde(default, rename = "light")]
    pub lights: Vec<LightSection>,
    /// The `[[object]]` tables, applied in file order (a later entry overrides an earlier one
    /// for the objects both match).
    #[serde(default, rename = "object")]
    pub objects: Vec<ObjectSection>,
    /// `[ambient_occlusion]`: ambient light scaled by unoccluded fraction; none without it.
    pub ambient_occlusion: Option<AoSection>,
    /// Crease angle for computed normals (degrees), in [0, 180]; default the command line's
    /// `--crease-angle` (30). Used only where the OBJ has no normals.
    pub crease_angle: Option<f32>,
    /// A ground plane under the scene, receiving its shadows.
    pub ground: Option<GroundSection>,
    /// Light from all around: a constant colour or an equirectangular map.
    pub environment: Option<EnvironmentSection>,
}

/// `[environment]`: `color = [r, g, b]` or `map = "sky.hdr"` (.hdr or .exr, relative to the scene
/// file), sampled by `samples` shadow rays per shading point (default 16).
#[derive(Debug, Default, Deserialize, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct EnvironmentSection {
    /// Constant linear RGB radiance from every direction, each >= 0.
    #[serde(default, deserialize_with = "opt_vec3")]
    pub color: Option<[f32; 3]>,
    /// An equirectangular map of linear radiance, relative to the scene file, its top row
    /// towards the camera's up axis.
    pub map: Option<PathBuf>,
    /// Shadow rays towards the environment per shading point, in 1..=4096 (default 16).
    pub samples: Option<u32>,
}

/// `[ground]`: a flat diffuse plane perpendicular to the camera's up.
#[derive(Debug, Default, Deserialize, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct GroundSection {
    /// Where the plane lies along the up axis (default: the bottom of the scene bounds).
    pub height: Option<f32>,
    /// Diffuse reflectance, each in [0, 1] (default 0.6 grey).
    #[serde(default, deserialize_with = "opt_vec3")]
    pub kd: Option<[f32; 3]>,
}

/// `[camera]`: each key left out comes from automatic framing (see [`crate::camera`]); the
/// command line's `--eye`, `--look-at`, `--up` and `--fov` override the file.
#[derive(Debug, Default, Deserialize, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CameraSection {
    /// The camera position, in the OBJ's units; finite, and not equal to `look_at`.
    #[serde(default, deserialize_with = "opt_vec3")]
    pub eye: Option<[f32; 3]>,
    /// The point seen at the image centre (default: from automatic framing).
    #[serde(default, deserialize_with = "opt_vec3")]
    pub look_at: Option<[f32; 3]>,
    /// The direction shown upwards in the image: non-zero and not parallel to `look_at - eye`
    /// (default: +y or +z, detected from the model).
    #[serde(default, deserialize_with = "opt_vec3")]
    pub up: Option<[f32; 3]>,
    /// Vertical field of view in degrees, in (0, 180) (default 35).
    pub fov: Option<f32>,
    /// Turn the default view about the model's up axis (degrees).
    pub orbit: Option<f32>,
}

/// `[render]`: the command line's flags of the same names override these.
#[derive(Debug, Default, Deserialize, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RenderSection {
    /// Image width in pixels, in 1..=32768 (command-line default 800).
    pub width: Option<u32>,
    /// Image height in pixels, in 1..=32768 (command-line default 600).
    pub height: Option<u32>,
    /// Samples per pixel (anti-aliasing), in 1..=65536 (command-line default 1).
    pub spp: Option<u32>,
    /// Deepest mirror-reflection/refraction bounce, in 0..=[`MAX_DEPTH`] (default 6); 0 traces
    /// no reflection or refraction rays.
    pub max_depth: Option<u32>,
    /// Linear RGB radiance of rays that hit nothing, each >= 0 (default [0.02, 0.02, 0.03]).
    #[serde(default, deserialize_with = "opt_vec3")]
    pub background: Option<[f32; 3]>,
    /// Linear RGB ambient light, times the diffuse reflectance, each >= 0 (default 0.12 grey).
    #[serde(default, deserialize_with = "opt_vec3")]
    pub ambient: Option<[f32; 3]>,
    /// Shading normal of Phong surfaces: "adapted" (default), "paper" or "interpolated".
    pub shading: Option<String>,
    /// Terminator of Phong surfaces: "lift" (default), "lift-ng", "plain" or "band".
    pub terminator: Option<String>,
}

/// A `[[light]]` table, chosen by its `type` key: `"directional"`, `"point"` or `"sphere"`
/// (see [`Light`](crate::Light) for how each lights a surface).
#[derive(Debug, Deserialize, Clone, PartialEq)]
#[serde(deny_unknown_fields, tag = "type", rename_all = "lowercase")]
pub enum LightSection {
    /// A light infinitely far away (a sun): parallel rays, no fall-off.
    Directional {
        /// Towards the light, from the scene; required, finite and non-zero (any length).
        #[serde(deserialize_with = "vec3")]
        direction: [f32; 3],
        /// Linear RGB irradiance on a surface facing the light, each >= 0 (default [1, 1, 1]).
        #[serde(default = "one3", deserialize_with = "vec3")]
        radiance: [f32; 3],
        /// Whether it casts shadows (default true); false costs no shadow rays.
        #[serde(default = "yes")]
        shadows: bool,
    },
    /// A point light, falling off with distance squared.
    Point {
        /// Where the light is, in the OBJ's units; required, finite.
        #[serde(deserialize_with = "vec3")]
        position: [f32; 3],
        /// Linear RGB radiant intensity (the irradiance at distance 1), each >= 0 (default
        /// [1, 1, 1]).
        #[serde(default = "one3", deserialize_with = "vec3")]
        intensity: [f32; 3],
        /// Whether it casts shadows (default true); false costs no shadow rays.
        #[serde(default = "yes")]
        shadows: bool,
    },
    /// A spherical area light, always casting soft shadows.
    Sphere {
        /// Centre of the sphere, in the OBJ's units; required, finite.
        #[serde(deserialize_with = "vec3")]
        center: [f32; 3],
        /// Radius of the sphere, in the OBJ's units; required, > 0.
        radius: f32,
        /// Linear RGB radiant intensity of the whole sphere (far away it lights as a point
        /// light of this intensity), each >= 0 (default [1, 1, 1]).
        #[serde(default = "one3", deserialize_with = "vec3")]
        intensity: [f32; 3],
        /// Shadow rays towards the sphere per shading point, in 1..=4096 (default 16).
        #[serde(default = "sixteen")]
        samples: u32,
    },
}

/// Exactly three numbers: serde's `[f32; 3]` reads the first three of a longer array and drops
/// the rest without a word (`eye = [1, 2, 3, 4]`).
fn vec3<'de, D: serde::Deserializer<'de>>(d: D) -> Result<[f32; 3], D::Error> {
    let v: Vec<f32> = Vec::deserialize(d)?;
    <[f32; 3]>::try_from(v.as_slice()).map_err(|_| {
        serde::de::Error::custom(format!("expected an array of 3 numbers, found {} numbers", v.len()))
    })
}

fn opt_vec3<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<[f32; 3]>, D::Error> {
    vec3(d).map(Some)
}

fn one3() -> [f32; 3] {
    [1.0; 3]
}
fn yes() -> bool {
    true
}
fn sixteen() -> u32 {
    16
}

/// An `[[object]]` table: the surface mode, Phong shape factor and material values of the
/// objects it names; each value left out keeps what the OBJ/MTL and command line gave.
#[derive(Debug, Deserialize, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ObjectSection {
    /// An object name from the OBJ, or "*" for every object.
    pub name: String,
    /// `"phong"` or `"flat"` (see [`ObjectSection::mode_over`] for how it combines with
    /// `alpha`).
    pub mode: Option<SurfaceMode>,
    /// Phong shape factor in [0, 1]: 0 is the flat triangle, 1 the full bulge. Given without
    /// `mode` it makes the objects Phong; `mode = "phong"` without it keeps the alpha the object
    /// had (for an object that was flat, the alpha asked for elsewhere: see
    /// [`ObjectSection::mode_over`]).
    pub alpha: Option<f32>,
    /// Diffuse reflectance (as MTL `Kd`), linear RGB, each in [0, 1].
    #[serde(default, deserialize_with = "opt_vec3")]
    pub kd: Option<[f32; 3]>,
    /// Mirror reflectance, linear RGB, each in [0, 1]; non-zero turns on reflection rays.
    #[serde(default, deserialize_with = "opt_vec3")]
    pub mirror: Option<[f32; 3]>,
    /// Fraction of light transmitted (refracted), in [0, 1]; non-zero turns on refraction
    /// rays and dims the diffuse part by `1 - transmission`.
    pub transmission: Option<f32>,
    /// Index of refraction (as MTL `Ni`), >= 1.
    pub ior: Option<f32>,
    /// Highlight reflectance (as MTL `Ks` with `illum 2`), each in [0, 1].
    #[serde(default, deserialize_with = "opt_vec3")]
    pub specular: Option<[f32; 3]>,
    /// Highlight exponent (as MTL `Ns`), >= 0.
    pub shininess: Option<f32>,
}

impl ObjectSection {
    /// The mode this entry gives an object that was in `mode`: its `mode` at its `alpha` (without
    /// one, as [`SurfaceMode::over`] keeps it, with `fallback` for an object that was flat), Phong
    /// at its `alpha` if it gives only that, else `mode`.
    pub fn mode_over(&self, mode: ObjectMode, fallback: f32) -> ObjectMode {
        match (self.mode, self.alpha) {
            (Some(m), a) => m.over(a, mode, fallback),
            (None, Some(a)) => ObjectMode::Phong { alpha: a },
            (None, None) => mode,
        }
    }

    /// The material values this entry overrides.
    pub fn surface_override(&self) -> SurfaceOverride {
        SurfaceOverride {
            kd: self.kd.map(Vec3::from),
            mirror: self.mirror.map(Vec3::from),
            transmission: self.transmission,
            ior: self.ior,
            specular: self.specular.map(Vec3::from),
            shininess: self.shininess,
        }
    }
}

/// `[ambient_occlusion]`: the ambient light is scaled by the fraction of `samples` rays from
/// the shading point that meet nothing within `distance`. Both keys are required.
#[derive(Debug, Deserialize, Clone, Copy, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct AoSection {
    /// Occlusion rays per shading point, in 1..=4096.
    pub samples: u32,
    /// How far an occluder counts, in the OBJ's units; > 0.
    pub distance: f32,
}

/// The deepest reflection/refraction recursion a scene file may ask for: with both mirror and
/// transmission the ray tree doubles per level, so 16 levels can already cost 65536 rays a sample.
pub const MAX_DEPTH: u32 = 16;

impl SceneFile {
    /// Read and check a scene file.
    /// Only regular files of at most [`MAX_SCENE_FILE_BYTES`] are read (a FIFO or a device is
    /// refused before it is opened).
    pub fn load(path: &Path) -> Result<SceneFile, SceneFileError> {
        let io = |reason: String| SceneFileError::Io { path: path.to_path_buf(), reason };
        let bytes = phongrt::scene::read_regular_file(path, MAX_SCENE_FILE_BYTES).map_err(|e| match e {
            ReadFailure::Io(e) => io(e.to_string()),
            ReadFailure::NotRegular(kind) => io(format!("not a regular file ({kind})")),
            ReadFailure::TooLarge => io(format!("larger than the {} MiB limit", MAX_SCENE_FILE_BYTES >> 20)),
        })?;
        let text = String::from_utf8(bytes).map_err(|e| SceneFileError::Parse {
            path: path.to_path_buf(),
            message: format!("not UTF-8 text (byte {})", e.utf8_error().valid_up_to()),
        })?;
        Self::parse(&text, path)
    }

    /// Check that every `[[object]]` name (other than "*") is an object of the loaded OBJ.
    pub fn check_object_names<'a>(
        &self,
        path: &Path,
        objects: impl Iterator<Item = &'a str> + Clone,
    ) -> Result<(), SceneFileError> {
        for (i, o) in self.objects.iter().enumerate() {
            if o.name != "*" && !objects.clone().any(|n| n == o.name) {
                let mut names: Vec<&str> = objects.clone().take(11).collect();
                if names.len() > 10 {
                    names[10] = "...";
                }
                return Err(SceneFileError::Invalid {
                    path: path.to_path_buf(),
                    key: format!("object[{i}].name"),
                    message: format!(
                        "{} matches no object of the OBJ (objects: {})",
                        phongrt::scene::cut_token(&o.name),
                        names.join(", ")
                    ),
                });
            }
        }
        Ok(())
    }

    /// Parse and check scene-file text; `path` is used in messages only.
    /// A leading UTF-8 byte-order mark is ignored.
    pub fn parse(text: &str, path: &Path) -> Result<SceneFile, SceneFileError> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let f: SceneFile = toml::from_str(text).map_err(|e| SceneFileError::Parse {
            path: path.to_path_buf(),
            message: one_line_toml_error(&e, text),
        })?;
        f.check(path)?;
        Ok(f)
    }

    /// The OBJ path resolved against the scene file's directory.
    pub fn obj_path(&self, scene_path: &Path) -> Option<PathBuf> {
        self.obj.as_ref().map(|o| scene_path.parent().unwrap_or(Path::new(".")).join(o))
    }

    /// Check every value of the file, section by section, as [`SceneFile::load`] does; the first
    /// problem found is the error, naming `path`. [`crate::WorldBuilder::scene_file`] runs it too,
    /// so a `SceneFile` built in code is held to the same ranges as one read from disk.
    pub fn check(&self, path: &Path) -> Result<(), SceneFileError> {
        let c = Checker { path };
        c.camera(&self.camera)?;
        c.render(&self.render)?;
        for (i, l) in self.lights.iter().enumerate() {
            c.light(i, l)?;
        }
        for (i, o) in self.objects.iter().enumerate() {
            c.object(i, o)?;
        }
        if let Some(ao) = self.ambient_occlusion {
            c.ambient_occlusion(ao)?;
        }
        c.render_names(&self.render)?;
        if let Some(g) = &self.ground {
            c.ground(g)?;
        }
        if let Some(e) = &self.environment {
            c.environment(e)?;
        }
        if let Some(a) = self.crease_angle {
            if !(0.0..=180.0).contains(&a) {
                return Err(c.bad("crease_angle".into(), format!("{a} is not in [0, 180] degrees")));
            }
        }
        Ok(())
    }
}

/// The checks of [`SceneFile::check`], each error naming the file and the key.
struct Checker<'a> {
    path: &'a Path,
}

impl Checker<'_> {
    fn bad(&self, key: String, message: String) -> SceneFileError {
        SceneFileError::Invalid { path: self.path.to_path_buf(), key, message }
    }

    fn finite(&self, key: &str, v: &[f32]) -> Result<(), SceneFileError> {
        if v.iter().all(|x| x.is_finite()) {
            Ok(())
        } else {
            Err(self.bad(key.into(), format!("{v:?} has a non-finite number")))
        }
    }

    fn nonneg(&self, key: &str, v: &[f32]) -> Result<(), SceneFileError> {
        self.finite(key, v)?;
        if v.iter().all(|&x| x >= 0.0) {
            Ok(())
        } else {
            Err(self.bad(key.into(), format!("{v:?} has a negative value")))
        }
    }

    /// A reflectance: each value in [0, 1] (above 1 a surface would reflect more light than it
    /// receives).
    fn reflectance(&self, key: &str, v: &[f32]) -> Result<(), SceneFileError> {
        self.nonneg(key, v)?;
        if v.iter().all(|&x| x <= 1.0) {
            Ok(())
        } else {
            Err(self.bad(key.into(), format!("{v:?} has a value above 1")))
        }
    }

    /// `[camera]`: finite vectors, a non-zero up, and eye/look_at/up that make a view when all
    /// are given (with automatic framing the rest is checked when the camera is made).
    fn camera(&self, c: &CameraSection) -> Result<(), SceneFileError> {
        for (k, v) in [("camera.eye", c.eye), ("camera.look_at", c.look_at), ("camera.up", c.up)] {
            if let Some(v) = v {
                self.finite(k, &v)?;
            }
        }
        if let Some(up) = c.up {
            if Vec3::from(up).length_squared() == 0.0 {
                return Err(self.bad("camera.up".into(), "must not be zero".into()));
            }
        }
        if let (Some(e), Some(l)) = (c.eye, c.look_at) {
            let dir = Vec3::from(l) - Vec3::from(e);
            if dir.try_normalize().is_none() {
                return Err(self.bad("camera.look_at".into(), format!("{l:?} equals camera.eye")));
            }
            if let Some(up) = c.up {
                if dir.normalize().cross(Vec3::from(up)).try_normalize().is_none() {
                    return Err(self.bad(
                        "camera.up".into(),
                        format!("{up:?} is parallel to the view direction (look_at - eye)"),
                    ));
                }
            }
        }
        if let Some(o) = c.orbit {
            self.finite("camera.orbit", &[o])?;
        }
        if let Some(f) = c.fov {
            if !(f > 0.0 && f < 180.0) {
                return Err(self.bad("camera.fov".into(), format!("{f} is not in (0, 180) degrees")));
            }
        }
        Ok(())
    }

    /// `[render]`'s numbers: image size, samples, depth, colours.
    fn render(&self, r: &RenderSection) -> Result<(), SceneFileError> {
        for (k, v) in [("render.width", r.width), ("render.height", r.height)] {
            if let Some(v) = v {
                if v == 0 || v > 1 << 15 {
                    return Err(self.bad(k.into(), format!("{v} is not in 1..=32768")));
                }
            }
        }
        if let Some(s) = r.spp {
            if s == 0 || s > 1 << 16 {
                return Err(self.bad("render.spp".into(), format!("{s} is not in 1..=65536")));
            }
        }
        if let Some(d) = r.max_depth {
            if d > MAX_DEPTH {
                return Err(self.bad(
                    "render.max_depth".into(),
                    format!("{d} is more than {MAX_DEPTH} (the ray tree can double at each level)"),
                ));
            }
        }
        for (k, v) in [("render.background", r.background), ("render.ambient", r.ambient)] {
            if let Some(v) = v {
                self.nonneg(k, &v)?;
            }
        }
        Ok(())
    }

    /// `[render]`'s names: shading and terminator.
    fn render_names(&self, r: &RenderSection) -> Result<(), SceneFileError> {
        if let Some(s) = &r.shading {
            if phongrt::phong::ShadingNormal::from_name(s).is_none() {
                return Err(
                    self.bad("render.shading".into(), format!("{s:?} is not adapted, paper or interpolated"))
                );
            }
        }
        if let Some(s) = &r.terminator {
            if crate::Terminator::from_name(s).is_none() {
                return Err(self
                    .bad("render.terminator".into(), format!("{s:?} is not lift, lift-ng, plain or band")));
            }
        }
        Ok(())
    }

    /// `[[light]]` number `i`.
    fn light(&self, i: usize, l: &LightSection) -> Result<(), SceneFileError> {
        let key = |f: &str| format!("light[{i}].{f}");
        match l {
            LightSection::Directional { direction, radiance, .. } => {
                self.finite(&key("direction"), direction)?;
                if Vec3::from(*direction).length_squared() == 0.0 {
                    return Err(self.bad(key("direction"), "must not be zero".into()));
                }
                self.nonneg(&key("radiance"), radiance)?;
            }
            LightSection::Point { position, intensity, .. } => {
                self.finite(&key("position"), position)?;
                self.nonneg(&key("intensity"), intensity)?;
            }
            LightSection::Sphere { center, radius, intensity, samples } => {
                self.finite(&key("center"), center)?;
                if !(radius.is_finite() && *radius > 0.0) {
                    return Err(self.bad(key("radius"), format!("{radius} is not a positive number")));
                }
                self.nonneg(&key("intensity"), intensity)?;
                if *samples == 0 || *samples > 4096 {
                    return Err(self.bad(key("samples"), format!("{samples} is not in 1..=4096")));
                }
            }
        }
        Ok(())
    }

    /// `[[object]]` number `i`: alpha and the material overrides.
    fn object(&self, i: usize, o: &ObjectSection) -> Result<(), SceneFileError> {
        let key = |f: &str| format!("object[{i}].{f}");
        if let Some(a) = o.alpha {
            if !(0.0..=1.0).contains(&a) {
                return Err(self.bad(key("alpha"), format!("{a} is not in [0, 1]")));
            }
        }
        for (k, v) in [("kd", o.kd), ("mirror", o.mirror), ("specular", o.specular)] {
            if let Some(v) = v {
                self.reflectance(&key(k), &v)?;
            }
        }
        if let Some(n) = o.shininess {
            if !(n.is_finite() && n >= 0.0) {
                return Err(self.bad(key("shininess"), format!("{n} is not a number >= 0")));
            }
        }
        if let Some(t) = o.transmission {
            if !(0.0..=1.0).contains(&t) {
                return Err(self.bad(key("transmission"), format!("{t} is not in [0, 1]")));
            }
        }
        if let Some(n) = o.ior {
            if !(n.is_finite() && n >= 1.0) {
                return Err(self.bad(key("ior"), format!("{n} is not a number >= 1")));
            }
        }
        Ok(())
    }

    /// `[ambient_occlusion]`.
    fn ambient_occlusion(&self, ao: AoSection) -> Result<(), SceneFileError> {
        if ao.samples == 0 || ao.samples > 4096 {
            return Err(
                self.bad("ambient_occlusion.samples".into(), format!("{} is not in 1..=4096", ao.samples))
            );
        }
        if !(ao.distance.is_finite() && ao.distance > 0.0) {
            return Err(self.bad(
                "ambient_occlusion.distance".into(),
                format!("{} is not a positive number", ao.distance),
            ));
        }
        Ok(())
    }

    /// `[ground]`.
    fn ground(&self, g: &GroundSection) -> Result<(), SceneFileError> {
        if let Some(h) = g.height {
            self.finite("ground.height", &[h])?;
        }
        if let Some(kd) = g.kd {
            self.reflectance("ground.kd", &kd)?;
        }
        Ok(())
    }

    /// `[environment]`: exactly one of color and map, and the sample count.
    fn environment(&self, e: &EnvironmentSection) -> Result<(), SceneFileError> {
        match (e.color, &e.map) {
            (Some(c), None) => self.nonneg("environment.color", &c)?,
            (None, Some(_)) => {}
            _ => return Err(self.bad("environment".into(), "give exactly one of color and map".into())),
        }
        if let Some(n) = e.samples {
            if n == 0 || n > 4096 {
                return Err(self.bad("environment.samples".into(), format!("{n} is not in 1..=4096")));
            }
        }
        Ok(())
    }
}

/// toml's messages span several lines (with a source excerpt); keep line, the key (`section.key`,
/// found from the line the error points into) and the reason.
fn one_line_toml_error(e: &toml::de::Error, text: &str) -> String {
    let msg = e.message().trim().replace('\n', " ");
    let msg = if msg.len() > 200 { phongrt::scene::cut_token(&msg) } else { msg };
    match e.span() {
        Some(span) => {
            let start = span.start.min(text.len());
            let start = (0..=start).rev().find(|&i| text.is_char_boundary(i)).unwrap_or(0);
            let line = text[..start].matches('\n').count() + 1;
            let key = text.lines().nth(line - 1).and_then(|l| l.split_once('=')).map(|(k, _)| {
                let k = k.trim().trim_matches('"');
                // The innermost [section] or [[section]] above the line.
                let section = text
                    .lines()
                    .take(line - 1)
                    .filter_map(|l| l.trim().strip_prefix('[').and_then(|l| l.split(']').next()))
                    .last()
                    .map(|s| s.trim_start_matches('[').trim());
                match section {
                    Some(s) if !s.is_empty() => format!("{s}.{k}"),
                    _ => k.to_string(),
                }
            });
            // An error inside a `[[light]]` (internally tagged, so buffered) points at the first
            // `[[light]]` header: name the table.
            let key = key.or_else(|| {
                let l = text.lines().nth(line - 1)?.trim();
                Some(l.strip_prefix("[[")?.split("]]").next()?.trim().to_string())
            });
            match key {
                Some(k) if !k.is_empty() && k.len() <= 64 => format!("line {line}: {k}: {msg}"),
                _ => format!("line {line}: {msg}"),
            }
        }
        None => msg,
    }
}
