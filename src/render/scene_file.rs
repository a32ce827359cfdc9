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

/// Errors in a scene file: each names the file, the key and what is wrong.
#[derive(Debug, thiserror::Error)]
pub enum SceneFileError {
    #[error("{path}: cannot read: {source}")]
    Io { path: PathBuf, source: std::io::Error },
    #[error("{path}: {message}")]
    Parse { path: PathBuf, message: String },
    #[error("{path}: {key}: {message}")]
    Invalid { path: PathBuf, key: String, message: String },
}

#[derive(Debug, Default, Deserialize, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// The OBJ file, relative to the scene file.
    pub obj: Option<PathBuf>,
    #[serde(default)]
    pub camera: CameraSection,
    #[serde(default)]
    pub render: RenderSection,
    #[serde(default, rename = "light")]
    pub lights: Vec<LightSection>,
    #[serde(default, rename = "object")]
    pub objects: Vec<ObjectSection>,
    pub ambient_occlusion: Option<AoSection>,
    /// Crease angle for computed normals (degrees).
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
    pub color: Option<[f32; 3]>,
    pub map: Option<PathBuf>,
    pub samples: Option<u32>,
}

/// `[ground]`: a flat diffuse plane perpendicular to the camera's up.
#[derive(Debug, Default, Deserialize, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct GroundSection {
    /// Where the plane lies along the up axis (default: the bottom of the scene bounds).
    pub height: Option<f32>,
    /// Diffuse reflectance (default 0.6 grey).
    pub kd: Option<[f32; 3]>,
}

#[derive(Debug, Default, Deserialize, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CameraSection {
    pub eye: Option<[f32; 3]>,
    pub look_at: Option<[f32; 3]>,
    pub up: Option<[f32; 3]>,
    pub fov: Option<f32>,
    /// Turn the default view about the model's up axis (degrees).
    pub orbit: Option<f32>,
}

#[derive(Debug, Default, Deserialize, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RenderSection {
    pub width: Option<u32>,
    pub height: Option<u32>,
    pub spp: Option<u32>,
    pub max_depth: Option<u32>,
    pub background: Option<[f32; 3]>,
    pub ambient: Option<[f32; 3]>,
    /// Shading normal of Phong surfaces: "adapted" (default), "paper" or "interpolated".
    pub shading: Option<String>,
    /// Terminator of Phong surfaces: "lift" (default), "plain" or "band".
    pub terminator: Option<String>,
}

#[derive(Debug, Deserialize, Clone, PartialEq)]
#[serde(deny_unknown_fields, tag = "type", rename_all = "lowercase")]
pub enum LightSection {
    Directional {
        direction: [f32; 3],
        #[serde(default = "one3")]
        radiance: [f32; 3],
        #[serde(default = "yes")]
        shadows: bool,
    },
    Point {
        position: [f32; 3],
        #[serde(default = "one3")]
        intensity: [f32; 3],
        #[serde(default = "yes")]
        shadows: bool,
    },
    Sphere {
        center: [f32; 3],
        radius: f32,
        #[serde(default = "one3")]
        intensity: [f32; 3],
        #[serde(default = "sixteen")]
        samples: u32,
    },
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

#[derive(Debug, Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum ModeName {
    Flat,
    Phong,
}

#[derive(Debug, Deserialize, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ObjectSection {
    /// An object name from the OBJ, or "*" for every object.
    pub name: String,
    pub mode: Option<ModeName>,
    pub alpha: Option<f32>,
    pub kd: Option<[f32; 3]>,
    pub mirror: Option<[f32; 3]>,
    pub transmission: Option<f32>,
    pub ior: Option<f32>,
    /// Highlight reflectance (as MTL `Ks` with `illum 2`), each in [0, 1].
    pub specular: Option<[f32; 3]>,
    /// Highlight exponent (as MTL `Ns`), >= 0.
    pub shininess: Option<f32>,
}

#[derive(Debug, Deserialize, Clone, Copy, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct AoSection {
    pub samples: u32,
    pub distance: f32,
}

impl SceneFile {
    /// Read and check a scene file.
    pub fn load(path: &Path) -> Result<SceneFile, SceneFileError> {
        let text = std::fs::read_to_string(path)
            .map_err(|source| SceneFileError::Io { path: path.to_path_buf(), source })?;
        Self::parse(&text, path)
    }

    /// Parse and check scene-file text; `path` is used in messages only.
    pub fn parse(text: &str, path: &Path) -> Result<SceneFile, SceneFileError> {
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

    fn check(&self, path: &Path) -> Result<(), SceneFileError> {
        let bad =
            |key: String, message: String| SceneFileError::Invalid { path: path.to_path_buf(), key, message };
        let finite = |key: &str, v: &[f32]| -> Result<(), SceneFileError> {
            if v.iter().all(|x| x.is_finite()) {
                Ok(())
            } else {
                Err(bad(key.into(), format!("{v:?} has a non-finite number")))
            }
        };
        let nonneg = |key: &str, v: &[f32]| -> Result<(), SceneFileError> {
            finite(key, v)?;
            if v.iter().all(|&x| x >= 0.0) {
                Ok(())
            } else {
                Err(bad(key.into(), format!("{v:?} has a negative value")))
            }
        };
        let c = &self.camera;
        for (k, v) in [("camera.eye", c.eye), ("camera.look_at", c.look_at), ("camera.up", c.up)] {
            if let Some(v) = v {
                finite(k, &v)?;
            }
        }
        if let Some(up) = c.up {
            if Vec3::from(up).length_squared() == 0.0 {
                return Err(bad("camera.up".into(), "must not be zero".into()));
            }
        }
        if let Some(o) = c.orbit {
            finite("camera.orbit", &[o])?;
        }
        if let Some(f) = c.fov {
            if !(f > 0.0 && f < 180.0) {
                return Err(bad("camera.fov".into(), format!("{f} is not in (0, 180) degrees")));
            }
        }
        let r = &self.render;
        for (k, v) in [("render.width", r.width), ("render.height", r.height)] {
            if let Some(v) = v {
                if v == 0 || v > 1 << 15 {
                    return Err(bad(k.into(), format!("{v} is not in 1..=32768")));
                }
            }
        }
        if let Some(s) = r.spp {
            if s == 0 || s > 1 << 16 {
                return Err(bad("render.spp".into(), format!("{s} is not in 1..=65536")));
            }
        }
        if let Some(d) = r.max_depth {
            if d > 64 {
                return Err(bad("render.max_depth".into(), format!("{d} is more than 64")));
            }
        }
        for (k, v) in [("render.background", r.background), ("render.ambient", r.ambient)] {
            if let Some(v) = v {
                nonneg(k, &v)?;
            }
        }
        for (i, l) in self.lights.iter().enumerate() {
            let key = |f: &str| format!("light[{i}].{f}");
            match l {
                LightSection::Directional { direction, radiance, .. } => {
                    finite(&key("direction"), direction)?;
                    if Vec3::from(*direction).length_squared() == 0.0 {
                        return Err(bad(key("direction"), "must not be zero".into()));
                    }
                    nonneg(&key("radiance"), radiance)?;
                }
                LightSection::Point { position, intensity, .. } => {
                    finite(&key("position"), position)?;
                    nonneg(&key("intensity"), intensity)?;
                }
                LightSection::Sphere { center, radius, intensity, samples } => {
                    finite(&key("center"), center)?;
                    if !(radius.is_finite() && *radius > 0.0) {
                        return Err(bad(key("radius"), format!("{radius} is not a positive number")));
                    }
                    nonneg(&key("intensity"), intensity)?;
                    if *samples == 0 || *samples > 4096 {
                        return Err(bad(key("samples"), format!("{samples} is not in 1..=4096")));
                    }
                }
            }
        }
        for (i, o) in self.objects.iter().enumerate() {
            let key = |f: &str| format!("object[{i}].{f}");
            if let Some(a) = o.alpha {
                if !(0.0..=1.0).contains(&a) {
                    return Err(bad(key("alpha"), format!("{a} is not in [0, 1]")));
                }
            }
            for (k, v) in [("kd", o.kd), ("mirror", o.mirror)] {
                if let Some(v) = v {
                    nonneg(&key(k), &v)?;
                }
            }
            if let Some(v) = o.specular {
                nonneg(&key("specular"), &v)?;
                if v.iter().any(|&x| x > 1.0) {
                    return Err(bad(key("specular"), format!("{v:?} has a value above 1")));
                }
            }
            if let Some(n) = o.shininess {
                if !(n.is_finite() && n >= 0.0) {
                    return Err(bad(key("shininess"), format!("{n} is not a number >= 0")));
                }
            }
            if let Some(t) = o.transmission {
                if !(0.0..=1.0).contains(&t) {
                    return Err(bad(key("transmission"), format!("{t} is not in [0, 1]")));
                }
            }
            if let Some(n) = o.ior {
                if !(n.is_finite() && n >= 1.0) {
                    return Err(bad(key("ior"), format!("{n} is not a number >= 1")));
                }
            }
        }
        if let Some(ao) = self.ambient_occlusion {
            if ao.samples == 0 || ao.samples > 4096 {
                return Err(bad(
                    "ambient_occlusion.samples".into(),
                    format!("{} is not in 1..=4096", ao.samples),
                ));
            }
            if !(ao.distance.is_finite() && ao.distance > 0.0) {
                return Err(bad(
                    "ambient_occlusion.distance".into(),
                    format!("{} is not a positive number", ao.distance),
                ));
            }
        }
        if let Some(s) = &r.shading {
            if crate::phong::ShadingNormal::from_name(s).is_none() {
                return Err(bad(
                    "render.shading".into(),
                    format!("{s:?} is not adapted, paper or interpolated"),
                ));
            }
        }
        if let Some(s) = &r.terminator {
            if crate::render::Terminator::from_name(s).is_none() {
                return Err(bad("render.terminator".into(), format!("{s:?} is not lift, plain or band")));
            }
        }
        if let Some(g) = &self.ground {
            if let Some(h) = g.height {
                finite("ground.height", &[h])?;
            }
            if let Some(kd) = g.kd {
                nonneg("ground.kd", &kd)?;
            }
        }
        if let Some(e) = &self.environment {
            match (e.color, &e.map) {
                (Some(c), None) => nonneg("environment.color", &c)?,
                (None, Some(_)) => {}
                _ => return Err(bad("environment".into(), "give exactly one of color and map".into())),
            }
            if let Some(n) = e.samples {
                if n == 0 || n > 4096 {
                    return Err(bad("environment.samples".into(), format!("{n} is not in 1..=4096")));
                }
            }
        }
        if let Some(a) = self.crease_angle {
            if !(0.0..=180.0).contains(&a) {
                return Err(bad("crease_angle".into(), format!("{a} is not in [0, 180] degrees")));
            }
        }
        Ok(())
    }
}

/// toml's messages span several lines (with a source excerpt); keep line, column and reason.
fn one_line_toml_error(e: &toml::de::Error, text: &str) -> String {
    let msg = e.message().trim().replace('\n', " ");
    match e.span() {
        Some(span) => {
            let line = text[..span.start.min(text.len())].matches('\n').count() + 1;
            format!("line {line}: {msg}")
        }
        None => msg,
    }
}
