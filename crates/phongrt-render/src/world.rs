//! The world: scene objects in one Embree scene, each flat (Embree triangles) or Phong
//! (user geometry), with materials and lights; and the integrator, which simulates only the
//! effects the scene calls for (see [`Effects`]).

use std::path::Path;

use glam::{Vec2, Vec3};

mod builder;

pub use builder::{SurfaceOverride, WorldBuilder};

use super::texture::Texture;
use super::RayCounts;
use phongrt::embree::{Blocker, CommittedScene, Device, Hit, PhongMesh, Ray, RayOrigin, PACKET8};
use phongrt::phong::ShadingNormal;
use phongrt::phong::{Real, V3};
use phongrt::rng::SplitMix;
use phongrt::scene as sc;

/// A surface mode by name, the one set of names the command line (`--mode`, `--object
/// NAME=MODE`) and scene files (`mode = "..."`) accept: `flat` and `phong`. Phong's shape
/// factor comes separately; [`SurfaceMode::with_alpha`] joins them into an [`ObjectMode`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SurfaceMode {
    /// Embree's native flat triangles, shaded with interpolated vertex normals.
    Flat,
    /// Phong tessellation ray traced directly as an Embree user geometry.
    Phong,
}

impl SurfaceMode {
    /// Every mode, in the order `--help` lists them.
    pub const ALL: [SurfaceMode; 2] = [SurfaceMode::Flat, SurfaceMode::Phong];

    /// The mode's name: `flat` or `phong`.
    pub fn name(self) -> &'static str {
        match self {
            SurfaceMode::Flat => "flat",
            SurfaceMode::Phong => "phong",
        }
    }

    /// The mode named `s` (one of [`SurfaceMode::name`]'s).
    pub fn from_name(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == s)
    }

    /// The object mode: flat, or Phong with shape factor `alpha`.
    pub fn with_alpha(self, alpha: f32) -> ObjectMode {
        match self {
            SurfaceMode::Flat => ObjectMode::Flat,
            SurfaceMode::Phong => ObjectMode::Phong { alpha },
        }
    }

    /// The object mode this mode gives an object that was in `prior`: flat, or Phong at `alpha`,
    /// and without one at `prior`'s alpha (at `fallback` when `prior` is flat: the alpha asked
    /// for elsewhere, such as `--alpha`, or [`phongrt::phong::DEFAULT_ALPHA`]). So naming the
    /// mode alone changes the mode, not an alpha set before.
    pub fn over(self, alpha: Option<f32>, prior: ObjectMode, fallback: f32) -> ObjectMode {
        let kept = match prior {
            ObjectMode::Phong { alpha } => alpha,
            ObjectMode::Flat => fallback,
        };
        self.with_alpha(alpha.unwrap_or(kept))
    }
}

/// How an object's surface is made.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ObjectMode {
    /// Embree's native triangles with interpolated shading normals.
    Flat,
    /// Phong tessellation with shape factor `alpha`, ray traced directly (user geometry).
    /// Crease and border edges are kept straight so the mesh stays closed.
    Phong {
        /// Shape factor in [0, 1]: 0 is the flat triangle, 1 the full Phong bulge (default
        /// [`phongrt::phong::DEFAULT_ALPHA`], 0.75).
        alpha: f32,
    },
}

/// A light source. `shadows: false` lights cost no shadow rays.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    /// Light arriving from `direction` (pointing towards the light), irradiance `radiance`.
    Directional {
        /// Towards the light, from the scene (any non-zero length; normalised when used).
        direction: Vec3,
        /// Linear RGB irradiance on a surface facing the light (no fall-off).
        radiance: Vec3,
        /// Whether the light casts shadows (one shadow ray per shading point).
        shadows: bool,
    },
    /// A point light with radiant intensity `intensity` (falls off with distance squared).
    Point {
        /// Where the light is, in scene units.
        position: Vec3,
        /// Linear RGB radiant intensity: irradiance at distance 1, divided by distance squared
        /// elsewhere.
        intensity: Vec3,
        /// Whether the light casts shadows (one shadow ray per shading point).
        shadows: bool,
    },
    /// A spherical area light: soft shadows from `samples` stratified shadow rays per shading point.
    Sphere {
        /// Centre of the sphere, in scene units.
        center: Vec3,
        /// Radius of the sphere, in scene units (> 0).
        radius: f32,
        /// Linear RGB radiant intensity of the whole sphere, spread over its surface points:
        /// far away it lights like a point light of this intensity.
        intensity: Vec3,
        /// Shadow rays per shading point (the scene file allows 1..=4096; 0 is taken as 1).
        samples: u32,
    },
}

impl Light {
    /// Whether this light needs shadow rays.
    pub fn casts_shadows(&self) -> bool {
        match *self {
            Light::Directional { shadows, .. } | Light::Point { shadows, .. } => shadows,
            Light::Sphere { .. } => true,
        }
    }
}

/// What a surface does to light, as the integrator uses it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surface {
    /// Diffuse reflectance (MTL `Kd`).
    pub kd: Vec3,
    /// Mirror reflectance (MTL `illum` 3, 5, 7: `Ks`); zero = no reflection rays.
    pub mirror: Vec3,
    /// Transmittance (MTL `d` < 1 or `Tr` > 0); zero = no refraction rays.
    pub transmission: f32,
    /// Index of refraction (MTL `Ni`).
    pub ior: f32,
    /// Specular reflectance of the highlight lobe (MTL `Ks` with `illum` >= 2); zero = no
    /// specular evaluation.
    pub specular: Vec3,
    /// The Blinn-Phong exponent (MTL `Ns`); 0 = no lobe.
    pub shininess: f32,
}

impl Surface {
    /// A diffuse surface of reflectance `kd`, nothing else.
    pub fn diffuse(kd: Vec3) -> Self {
        Surface { kd, mirror: Vec3::ZERO, transmission: 0.0, ior: 1.0, specular: Vec3::ZERO, shininess: 0.0 }
    }

    /// The surface an MTL material calls for.
    pub fn from_material(m: &sc::Material) -> Self {
        Self::from_material_checked(m, Path::new("")).0
    }

    /// As [`Surface::from_material`], with a one-line warning (naming `file` and the material)
    /// for each value out of range and clamped: a `Kd` not in [0, 1] (above 1 a surface would
    /// reflect more light than it receives; a NaN is made 0), a negative `Ns`, a `Ks` above 1.
    pub fn from_material_checked(m: &sc::Material, file: &Path) -> (Self, Vec<String>) {
        let mut warnings = Vec::new();
        let kd = if (m.kd.cmpge(Vec3::ZERO) & m.kd.cmple(Vec3::ONE)).all() {
            m.kd
        } else {
            warnings.push(format!(
                "{}: material {:?}: Kd {} {} {} is not in [0, 1]; clamped",
                file.display(),
                m.name,
                m.kd.x,
                m.kd.y,
                m.kd.z
            ));
            Vec3::select(m.kd.is_nan_mask(), Vec3::ZERO, m.kd).clamp(Vec3::ZERO, Vec3::ONE)
        };
        let ks = if m.ks.is_finite() { m.ks.max(Vec3::ZERO) } else { Vec3::ZERO };
        let ks = if ks.max_element() > 1.0 {
            warnings.push(format!(
                "{}: material {:?}: Ks {} {} {} is above 1; clamped to 1",
                file.display(),
                m.name,
                m.ks.x,
                m.ks.y,
                m.ks.z
            ));
            ks.min(Vec3::ONE)
        } else {
            ks
        };
        let ns = if m.ns.is_finite() { m.ns } else { 0.0 };
        let ns = if ns < 0.0 {
            warnings.push(format!(
                "{}: material {:?}: Ns {} is negative; clamped to 0 (no highlight)",
                file.display(),
                m.name,
                m.ns
            ));
            0.0
        } else {
            ns.min(1e4)
        };
        let mirror = match m.illum {
            Some(3 | 5 | 7) => ks,
            _ => Vec3::ZERO,
        };
        // A highlight for illum >= 2 with Ks > 0 and Ns > 0 (Ns = 0 is a uniform lobe: no highlight).
        let (specular, shininess) = match m.illum {
            Some(i) if i >= 2 && ns > 0.0 => (ks, ns),
            _ => (Vec3::ZERO, 0.0),
        };
        let transmission = (1.0 - m.dissolve).clamp(0.0, 1.0);
        let ior = if m.ni.is_finite() && m.ni >= 1.0 { m.ni } else { 1.0 };
        (Surface { kd, mirror, transmission, ior, specular, shininess }, warnings)
    }

    /// Whether the surface has a highlight lobe (specular evaluation per light).
    pub fn glossy(&self) -> bool {
        self.specular.max_element() > 0.0 && self.shininess > 0.0
    }

    /// The normalised Blinn-Phong lobe, `Ks (Ns + 8) / 8 (n·h)^Ns` (the `1/pi` of the energy
    /// normalisation `(Ns + 8) / (8 pi)` cancels against this renderer's light units, in which a
    /// diffuse surface reflects `Kd E`), for the shading normal `n`, the direction to the viewer
    /// `v` and to the light `l` (unit).
    pub fn blinn_phong(&self, n: Vec3, v: Vec3, l: Vec3) -> Vec3 {
        let Some(h) = (v + l).try_normalize() else { return Vec3::ZERO };
        let c = n.dot(h);
        if !(c > 0.0) {
            return Vec3::ZERO;
        }
        self.specular * ((self.shininess + 8.0) / 8.0 * c.powf(self.shininess))
    }

    /// Whether the surface reflects as a mirror (then reflection rays are traced).
    pub fn reflects(&self) -> bool {
        self.mirror.max_element() > 0.0
    }

    /// Whether the surface transmits light (then refraction rays are traced, and shadow rays pass it).
    pub fn refracts(&self) -> bool {
        self.transmission > 0.0
    }
}

/// How light is cut off at the shading terminator of a Phong surface, where the shading normal
/// and the true surface disagree about which side faces the light.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Terminator {
    /// `max(0, n·l)` with the shading normal `n`, and shadow rays whose origin is lifted off the
    /// surface by Hanika's offset (see [`phongrt::phong::Patch::shadow_lift`]) where the true surface
    /// turns away from the light, so hard shadows follow the shading normal's terminator. The lift
    /// is refused where a short ray finds other geometry in its way (thin, two-sided and
    /// non-manifold surfaces), and taken on the side the shading point is seen from. The lift
    /// fades in as the shading or the true normal's cosine to the light falls below
    /// [`LIFT_CUTOFF`], and a shadow ray passes
    /// the C0 bumps of its own mesh: a hit on the same object closer than the shading patch's
    /// [`phongrt::phong::Patch::bump_bound`] reach and lower than its height above the shading
    /// plane is skipped, so the cone points where patches meet at an angle leave no specks. The
    /// default.
    #[default]
    Lift,
    /// The lift rule before the bump pass: the lift fades on the true normal's `ng·l` and every
    /// hit blocks (specks where the true normals of neighbouring patches disagree).
    LiftNg,
    /// `max(0, n·l)` with shadow rays from the true surface: hard shadows follow each patch's own
    /// true-normal terminator (a sawtooth).
    Plain,
    /// The former rule: zero where the true surface faces away, Chiang et al. 2019's shadowing term
    /// in a band built from the true normal. The true normal jumps at every patch edge, so the band
    /// draws crescents; kept only for comparison.
    Band,
}

impl Terminator {
    /// Every rule, the default first.
    pub const ALL: [Terminator; 4] =
        [Terminator::Lift, Terminator::LiftNg, Terminator::Plain, Terminator::Band];

    /// The rule's name as the command line and scene files spell it.
    pub fn name(self) -> &'static str {
        match self {
            Terminator::Lift => "lift",
            Terminator::LiftNg => "lift-ng",
            Terminator::Plain => "plain",
            Terminator::Band => "band",
        }
    }

    /// The rule named `s` (see [`Terminator::name`]).
    pub fn from_name(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|r| r.name() == s)
    }
}

/// A ground plane under the scene, receiving its shadows (flat, diffuse).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ground {
    /// The plane's normal (unit): the camera's up axis.
    pub up: Vec3,
    /// Where the plane is along `up`; `None`: at the bottom of the scene bounds.
    pub height: Option<f32>,
    /// Diffuse reflectance.
    pub kd: Vec3,
    /// Half the side of the square plane, in scene units; `None`: 20 times the diagonal of the
    /// scene bounds ([`Ground::radius_for_view`] sizes it so a view does not see its far edge).
    pub radius: Option<f32>,
}

impl Default for Ground {
    fn default() -> Self {
        Ground { up: Vec3::Y, height: None, kd: Vec3::splat(0.6), radius: None }
    }
}

impl Ground {
    /// The plane as two triangles `(positions, indices)` under `bounds`, wide enough to fill any
    /// view that frames the bounds (40 times their diagonal), front side towards `up`. `None`
    /// for a zero or non-finite `up` or height.
    pub fn triangles(&self, bounds: (Vec3, Vec3)) -> Option<(Vec<Vec3>, Vec<[u32; 3]>)> {
        let (o, up) = self.origin(bounds)?;
        let diag = (bounds.1 - bounds.0).length().max(f32::MIN_POSITIVE);
        let (t, b) = orthonormal_basis(up);
        let r = self.radius.filter(|r| r.is_finite() && *r > 0.0).unwrap_or(20.0 * diag);
        let positions = vec![o - r * t - r * b, o + r * t - r * b, o + r * t + r * b, o - r * t + r * b];
        // Counter-clockwise seen from above, so the front faces `up`.
        let (i0, i1) = if t.cross(b).dot(up) > 0.0 { ([0, 1, 2], [0, 2, 3]) } else { ([0, 2, 1], [0, 3, 2]) };
        Some((positions, vec![i0, i1]))
    }

    /// The half side the plane needs so that `camera` (at `aspect`) sees no edge of it: the
    /// farthest point where a ray through the top row of the frame meets the plane, from the
    /// plane's centre along its sides, plus a quarter; at least 20 and at most 200 times the
    /// bounds' diagonal (200 when a ray of the top row runs within half a degree of the horizon
    /// or above it: then the far edge stands in for the horizon).
    pub fn radius_for_view(&self, bounds: (Vec3, Vec3), camera: &crate::Camera, aspect: f32) -> f32 {
        let diag = (bounds.1 - bounds.0).length().max(f32::MIN_POSITIVE);
        let (lo, hi) = (20.0 * diag, 200.0 * diag);
        let (Some((o, up)), Some(f)) = (self.origin(bounds), camera.frame(aspect)) else { return lo };
        let (t, b) = orthonormal_basis(up);
        let height = (f.eye - o).dot(up);
        if !(height > 0.0) {
            return lo;
        }
        let mut need = lo;
        // The top row's two corners and its middle.
        for x in [-1.0f32, 0.0, 1.0] {
            let d = (f.forward + f.up + x * f.right).normalize();
            let down = -d.dot(up);
            if !(down > 0.5f32.to_radians().sin()) {
                return hi;
            }
            let hit = f.eye + (height / down) * d - o;
            need = need.max(1.25 * hit.dot(t).abs().max(hit.dot(b).abs()));
        }
        need.min(hi)
    }

    /// The plane's centre (under the bounds' centre) and its unit normal.
    fn origin(&self, bounds: (Vec3, Vec3)) -> Option<(Vec3, Vec3)> {
        let up = self.up.try_normalize().filter(|u| u.is_finite())?;
        let (lo, hi) = bounds;
        let center = 0.5 * (lo + hi);
        // The lowest corner of the bounds along `up`.
        let corners = (0..8).map(|k| {
            Vec3::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            )
        });
        let bottom = corners.map(|c| c.dot(up)).fold(f32::INFINITY, f32::min);
        let h = self.height.unwrap_or(bottom);
        if !h.is_finite() {
            return None;
        }
        let o = center + (h - center.dot(up)) * up;
        o.is_finite().then_some((o, up))
    }
}

/// Where environment light comes from.
#[derive(Clone, Debug)]
pub enum EnvironmentSource {
    /// The same radiance from every direction.
    Constant(Vec3),
    /// An equirectangular (latitude-longitude) map of linear radiance, its top row towards `up`.
    Map {
        /// The map's linear RGB radiance, shared (cloning the source does not copy it).
        texture: std::sync::Arc<Texture>,
        /// The direction the map's top row (its zenith) faces: the camera's up axis.
        up: Vec3,
    },
}

/// Light from all around (scene file `[environment]`): sampled by `samples` cosine-weighted
/// shadow rays per shading point, and seen by rays that leave the scene. Only when asked for.
#[derive(Clone, Debug)]
pub struct Environment {
    /// Where the light comes from.
    pub source: EnvironmentSource,
    /// Shadow rays per shading point.
    pub samples: u32,
}

impl Environment {
    /// Read an equirectangular `.hdr` or `.exr` map (linear radiance). One-line error naming the
    /// file if it is missing, cannot be decoded, or holds a non-finite or negative value.
    pub fn load_map(path: &Path) -> Result<Texture, String> {
        let img = crate::texture::decode_regular_file(path)
            .map_err(|e| format!("{}: cannot read environment map: {e}", path.display()))?;
        let rgb = img.to_rgb32f();
        let texels: Vec<Vec3> = rgb.pixels().map(|p| Vec3::new(p[0], p[1], p[2])).collect();
        if let Some(i) = texels.iter().position(|t| !t.is_finite() || t.min_element() < 0.0) {
            return Err(format!(
                "{}: environment map has a non-finite or negative value at pixel {i}",
                path.display()
            ));
        }
        Texture::from_linear(rgb.width(), rgb.height(), texels)
            .ok_or_else(|| format!("{}: environment map has no pixels", path.display()))
    }

    /// The radiance arriving from direction `d` (towards the environment; need not be unit).
    pub fn radiance(&self, d: Vec3) -> Vec3 {
        match &self.source {
            EnvironmentSource::Constant(c) => *c,
            EnvironmentSource::Map { texture, up } => {
                let d = d.normalize_or_zero();
                // Compute the direction in the map's frame: y along `up`.
                let (x, y, z) = if up.z.abs() > 0.5 {
                    (d.x, d.z * up.z.signum(), -d.y * up.z.signum())
                } else {
                    (d.x, d.y, d.z)
                };
                let u = 0.5 + x.atan2(-z) / std::f32::consts::TAU;
                let theta = y.clamp(-1.0, 1.0).acos();
                texture.sample_latlong(u, theta / std::f32::consts::PI)
            }
        }
    }
}

/// Ambient occlusion, only when asked for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AmbientOcclusion {
    /// Rays per shading point.
    pub samples: u32,
    /// Occluders farther than this (world units) do not count.
    pub distance: f32,
}

/// The set of effects the scene calls for, derived before rendering.
#[derive(Clone, Debug, PartialEq)]
pub struct Effects {
    /// Lights that cast shadows (indices into [`World::lights`]).
    pub shadow_lights: Vec<usize>,
    /// Lights with soft shadows (area lights).
    pub soft_shadow_lights: Vec<usize>,
    /// Objects with a highlight lobe (MTL `illum` >= 2, `Ks`, `Ns` > 0).
    pub glossy: Vec<String>,
    /// Objects with a `map_Kd` texture.
    pub textured: Vec<String>,
    /// Objects whose material reflects (names).
    pub reflective: Vec<String>,
    /// Objects whose material refracts (names).
    pub refractive: Vec<String>,
    /// Ambient occlusion, if asked for.
    pub ambient_occlusion: Option<AmbientOcclusion>,
    /// Environment light: its kind and samples per shading point.
    pub environment: Option<String>,
    /// Maximum depth of reflection/refraction recursion.
    pub max_depth: u32,
}

impl std::fmt::Display for Effects {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mut parts = vec!["direct lighting".to_string()];
        // Area lights are counted once, as soft shadows.
        let hard = self.shadow_lights.iter().filter(|i| !self.soft_shadow_lights.contains(i)).count();
        if hard > 0 {
            parts.push(format!("shadows ({hard} lights)"));
        }
        if !self.soft_shadow_lights.is_empty() {
            parts.push(format!("soft shadows ({} area lights)", self.soft_shadow_lights.len()));
        }
        if !self.glossy.is_empty() {
            parts.push(format!("highlights ({} objects)", self.glossy.len()));
        }
        if !self.textured.is_empty() {
            parts.push(format!("textures ({} objects)", self.textured.len()));
        }
        if !self.reflective.is_empty() {
            parts.push(format!("reflection ({} objects)", self.reflective.len()));
        }
        if !self.refractive.is_empty() {
            parts.push(format!("refraction ({} objects)", self.refractive.len()));
            parts.push(format!("Fresnel reflection ({} objects)", self.refractive.len()));
            if !self.shadow_lights.is_empty() {
                parts.push(format!("shadows through glass ({} objects)", self.refractive.len()));
            }
        }
        if let Some(ao) = self.ambient_occlusion {
            parts.push(format!("ambient occlusion ({} samples)", ao.samples));
        }
        if let Some(e) = &self.environment {
            parts.push(format!("environment light ({e})"));
        }
        write!(f, "effects: {}", parts.join(", "))
    }
}

/// One object as the shader sees it.
#[derive(Clone, Debug)]
pub struct Object {
    /// The object's name in the OBJ ("ground" for the ground plane).
    pub name: String,
    /// How its surface is made, with the Phong patches for a Phong object.
    pub geometry: Geometry,
    /// Unit vertex normals, one per position, as loaded.
    pub normals: Vec<Vec3>,
    /// Vertex positions, as loaded.
    pub positions: Vec<Vec3>,
    /// Triangles (indices into `positions`), as loaded.
    pub indices: Vec<[u32; 3]>,
    /// What the surface does to light.
    pub surface: Surface,
    /// The ground plane (not a scene object: `[[object]] name = "*"` leaves it alone).
    pub is_ground: bool,
    /// The `map_Kd` texture (multiplying `kd`, as MTL defines it), with the corners' `vt` per
    /// triangle; `None` without a usable texture or texture coordinates.
    pub texture: Option<TextureBinding>,
}

/// How an object's surface is made: the one home of its mode, so a Phong object always has its
/// patches.
#[derive(Clone, Debug)]
pub enum Geometry {
    /// Embree's native triangles with interpolated shading normals.
    Flat,
    /// Phong tessellation ray traced directly as an Embree user geometry: the patches, shared with
    /// the Embree geometry (one copy).
    Phong(std::sync::Arc<PhongMesh>),
}

impl Geometry {
    /// The Phong patches, for a Phong object.
    pub fn phong(&self) -> Option<&std::sync::Arc<PhongMesh>> {
        match self {
            Geometry::Flat => None,
            Geometry::Phong(pm) => Some(pm),
        }
    }
}

/// A texture shared between objects, with one object's corner texture coordinates per triangle.
pub type TextureBinding = (std::sync::Arc<Texture>, Vec<[[f32; 2]; 3]>);

impl Object {
    /// The texture coordinates at `(u, v)` of triangle `prim`, by the barycentric weights
    /// `1-u-v, u, v` the hit reports (Phong patches use the same `u, v`).
    pub fn texcoord(uvs: &[[[f32; 2]; 3]], prim: u32, u: f32, v: f32) -> Option<Vec2> {
        let t = uvs.get(prim as usize)?;
        let c = |k: usize| Vec2::from(t[k]);
        let uv = (1.0 - u - v) * c(0) + u * c(1) + v * c(2);
        uv.is_finite().then_some(uv)
    }
}

/// Per-object choices (from the CLI or a scene file).
#[derive(Clone, Debug)]
pub struct ObjectSettings {
    /// Flat triangles or Phong tessellation, with Phong's shape factor.
    pub mode: ObjectMode,
    /// Keep crease and border edges straight (Phong mode), so patches beside a crease share their
    /// edge. `false` bends every edge by its own normals, as plain Phong tessellation does: only
    /// for showing the cracks that this prevents.
    pub straight_creases: bool,
}

impl ObjectSettings {
    /// Settings for `mode`, creases kept straight.
    pub fn new(mode: ObjectMode) -> Self {
        ObjectSettings { mode, straight_creases: true }
    }
}

/// Objects in one committed Embree scene, indexed by geomID, the lights, and the integrator's
/// settings. Built by a [`WorldBuilder`] (see [`World::builder`]) and immutable afterwards: read
/// through its accessors.
pub struct World {
    device: Device,
    scene: CommittedScene,
    objects: Vec<Object>,
    lights: Vec<Light>,
    ambient: Vec3,
    background: Vec3,
    bounds: (Vec3, Vec3),
    ambient_occlusion: Option<AmbientOcclusion>,
    max_depth: u32,
    shading: ShadingNormal,
    terminator: Terminator,
    warnings: Vec<String>,
    environment: Option<Environment>,
}

/// The default key light: from the upper left behind the camera, casting shadows.
pub fn default_lights() -> Vec<Light> {
    vec![Light::Directional {
        direction: Vec3::new(-0.5, 0.7, 0.6).normalize(),
        radiance: Vec3::splat(0.85),
        shadows: true,
    }]
}

impl World {
    /// The Embree device the world's scene lives on.
    pub fn device(&self) -> &Device {
        &self.device
    }

    /// The committed Embree scene: object `i` is geometry `i`.
    pub fn scene(&self) -> &CommittedScene {
        &self.scene
    }

    /// The objects, indexed by geomID (the ground, if any, last).
    pub fn objects(&self) -> &[Object] {
        &self.objects
    }

    /// The lights.
    pub fn lights(&self) -> &[Light] {
        &self.lights
    }

    /// The ambient light.
    pub fn ambient(&self) -> Vec3 {
        self.ambient
    }

    /// The radiance of rays that leave the scene when there is no environment.
    pub fn background(&self) -> Vec3 {
        self.background
    }

    /// The bounds of the scene's meshes (without the ground): what the camera frames.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.bounds
    }

    /// Ambient occlusion, if asked for.
    pub fn ambient_occlusion(&self) -> Option<AmbientOcclusion> {
        self.ambient_occlusion
    }

    /// The maximum depth of reflection and refraction rays.
    pub fn max_depth(&self) -> u32 {
        self.max_depth
    }

    /// The shading-normal rule of Phong objects (flat ones interpolate).
    pub fn shading(&self) -> ShadingNormal {
        self.shading
    }

    /// The terminator rule of Phong objects (flat ones keep the classic faceted terminator).
    pub fn terminator(&self) -> Terminator {
        self.terminator
    }

    /// One-line warnings from building the world (materials out of range, textures, ...).
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    /// Environment light, only when the scene asks for it.
    pub fn environment(&self) -> Option<&Environment> {
        self.environment.as_ref()
    }
    /// The effects this world calls for: nothing more is ever simulated.
    pub fn effects(&self) -> Effects {
        let pick = |f: fn(&Surface) -> bool| {
            self.objects.iter().filter(|o| f(&o.surface)).map(|o| o.name.clone()).collect::<Vec<_>>()
        };
        Effects {
            shadow_lights: (0..self.lights.len()).filter(|&i| self.lights[i].casts_shadows()).collect(),
            soft_shadow_lights: (0..self.lights.len())
                .filter(|&i| matches!(self.lights[i], Light::Sphere { .. }))
                .collect(),
            glossy: pick(Surface::glossy),
            textured: self.objects.iter().filter(|o| o.texture.is_some()).map(|o| o.name.clone()).collect(),
            reflective: pick(Surface::reflects),
            refractive: pick(Surface::refracts),
            ambient_occlusion: self.ambient_occlusion,
            environment: self.environment.as_ref().map(|e| {
                let kind = match e.source {
                    EnvironmentSource::Constant(_) => "constant",
                    EnvironmentSource::Map { .. } => "map",
                };
                format!("{kind}, {} samples", e.samples)
            }),
            max_depth: self.max_depth,
        }
    }

    /// The most rays one pixel sample can cost by the effects plan: a primary ray, then at
    /// each shading point a shadow ray per hard-shadow light, `samples` per area light, the
    /// ambient-occlusion and environment samples and a terminator check per light, and, where an
    /// object reflects or refracts, up to two branches per bounce to `max_depth`. An upper
    /// bound: rays that miss, or points facing away from a light, cost less.
    pub fn rays_per_sample_bound(&self) -> f64 {
        // Compute the rays at one shading point.
        let lights: f64 = self
            .lights
            .iter()
            .map(|l| match *l {
                Light::Sphere { samples, .. } => samples.max(1) as f64,
                _ if l.casts_shadows() => 2.0,
                _ => 0.0,
            })
            .sum();
        let ao = self.ambient_occlusion.map_or(0.0, |a| a.samples.max(1) as f64);
        let env = self.environment.as_ref().map_or(0.0, |e| e.samples.max(1) as f64);
        let at_point = 1.0 + lights + ao + env;

        // Compute the branching of reflection and refraction.
        let reflects = self.objects.iter().any(|o| o.surface.reflects());
        let refracts = self.objects.iter().any(|o| o.surface.refracts());
        let branches = match (reflects, refracts) {
            (_, true) => 2.0,
            (true, false) => 1.0,
            (false, false) => 0.0,
        };
        let points: f64 = (0..=self.max_depth.min(16)).map(|k| f64::powi(branches, k as i32)).sum();
        at_point * points
    }

    /// Radiance along a camera ray; `rng` feeds area-light and AO sampling.
    pub fn shade(&self, ray: Ray, counts: &mut RayCounts, rng: &mut Rng) -> Vec3 {
        counts.primary += 1;
        self.radiance(ray, 0, counts, rng)
    }

    /// Radiance along each camera ray of an 8-ray packet, as [`World::shade`] gives it lane by
    /// lane (the same value, counts and `rngs[k]` draws): the lanes in `trace` (bit `k` for lane
    /// `k`) are intersected as one coherent packet, the lanes in `shade` (a subset) are shaded,
    /// and their hard shadows towards each point or directional light (where no surface is
    /// transmissive, so one any-hit ray decides) are traced as one coherent packet per light.
    /// Lanes not shaded answer zero. A lane's answer does not depend on the other lanes: each
    /// lane of a packet query answers as the single-ray query does (tests/packets.rs).
    pub fn shade8(
        &self,
        rays: &[Ray; PACKET8],
        trace: u8,
        shade: u8,
        counts: &mut RayCounts,
        rngs: &mut [Rng; PACKET8],
    ) -> [Vec3; PACKET8] {
        let shade = shade & trace;
        let hits = self.scene.intersect8_rays(rays, trace, true);
        // Compute the arrival of each shaded lane: a miss's radiance or a shading point.
        let arrivals: [Option<Arrival<'_>>; PACKET8] = std::array::from_fn(|k| {
            (shade & (1 << k) != 0).then(|| {
                counts.primary += 1;
                self.arrival(&rays[k], hits[k])
            })
        });
        // Trace the hard shadows of the lit lanes, one packet per light.
        let mut traced = [[None; PACKET_LIGHTS]; PACKET8];
        if !self.any_transmissive() {
            for (i, light) in self.lights.iter().enumerate().take(PACKET_LIGHTS) {
                let mut shadow_rays = [Ray::new(Vec3::ZERO, Vec3::Z); PACKET8];
                let mut origins = [None; PACKET8];
                let mut active = 0u8;
                for (k, a) in arrivals.iter().enumerate() {
                    let Some(Arrival::Surface { obj, sp, .. }) = a else { continue };
                    if !lit(&obj.surface) {
                        continue;
                    }
                    let Some((dir, tfar)) = hard_shadow(light, sp) else { continue };
                    // As `visibility` does for the same light and point.
                    let o = self.shadow_origin(sp, dir, counts);
                    counts.shadow += 1;
                    shadow_rays[k] = Ray::new(o, dir).with_range(0.0, tfar);
                    origins[k] = sp.origin;
                    active |= 1 << k;
                }
                let (blocked, by) = self.scene.occluded8_rays_by(&shadow_rays, &origins, active, true);
                for (k, t) in traced.iter_mut().enumerate().filter(|(k, _)| active & (1 << k) != 0) {
                    let r = &shadow_rays[k];
                    let passes = blocked & (1 << k) != 0
                        && matches!(&arrivals[k], Some(Arrival::Surface { sp, .. })
                            if self.passes_own_bumps(sp, r.org, r.dir, r.tfar, by[k], counts));
                    t[i] = Some(if blocked & (1 << k) == 0 || passes { 1.0 } else { 0.0 });
                }
            }
        }
        // Shade each lane from its hit, with its shadows traced.
        let mut out = [Vec3::ZERO; PACKET8];
        for (k, a) in arrivals.into_iter().enumerate() {
            out[k] = match a {
                None => Vec3::ZERO,
                Some(Arrival::Miss(c)) => c,
                Some(Arrival::Surface { hit, obj, sp }) => {
                    self.radiance_at(&rays[k], &hit, obj, &sp, 0, counts, &mut rngs[k], &traced[k])
                }
            };
        }
        out
    }

    /// Whether some surface transmits light (then shadow rays pass through it, one by one).
    fn any_transmissive(&self) -> bool {
        self.objects.iter().any(|x| x.surface.refracts())
    }

    /// What a ray arrives at: the miss radiance, or the object and shading point it hits.
    fn arrival(&self, ray: &Ray, hit: Option<Hit>) -> Arrival<'_> {
        let Some(hit) = hit else {
            return Arrival::Miss(match &self.environment {
                Some(env) => env.radiance(ray.dir),
                None => self.background,
            });
        };
        let Some(obj) = self.objects.get(hit.geom_id as usize) else {
            return Arrival::Miss(self.background);
        };
        let sp = obj.surface_point(&hit, ray, self.shading, self.terminator);
        Arrival::Surface { hit, obj, sp }
    }

    fn radiance(&self, ray: Ray, depth: u32, counts: &mut RayCounts, rng: &mut Rng) -> Vec3 {
        match self.arrival(&ray, self.scene.intersect1(ray)) {
            Arrival::Miss(c) => c,
            Arrival::Surface { hit, obj, sp } => {
                self.radiance_at(&ray, &hit, obj, &sp, depth, counts, rng, &[None; PACKET_LIGHTS])
            }
        }
    }

    /// Radiance leaving the shading point `sp` of `hit` on `obj` towards the ray's origin;
    /// `traced[i]` is light `i`'s hard-shadow visibility where it was traced ahead (in a
    /// packet), `None` where this traces its own shadow ray.
    #[allow(clippy::too_many_arguments)]
    fn radiance_at(
        &self,
        ray: &Ray,
        hit: &Hit,
        obj: &Object,
        sp: &SurfacePoint,
        depth: u32,
        counts: &mut RayCounts,
        rng: &mut Rng,
        traced: &[Option<f32>; PACKET_LIGHTS],
    ) -> Vec3 {
        let s = &obj.surface;
        // Compute the direct light: diffuse, plus the highlight lobe only for glossy materials.
        let mut c = Vec3::ZERO;
        if lit(s) {
            c = self.direct_light(ray, hit, obj, sp, counts, rng, traced);
        }
        if depth >= self.max_depth {
            return c;
        }
        // Compute the mirror reflection, only for materials that call for it.
        let d = ray.dir.normalize();
        if s.reflects() {
            let r = d - 2.0 * d.dot(sp.n) * sp.n;
            counts.reflection += 1;
            let o = sp.offset_origin(r);
            c += s.mirror * self.radiance(Ray::new(o, r), depth + 1, counts, rng);
        }
        // Compute the refraction with its Fresnel reflection, only for transparent materials.
        if s.refracts() {
            c = self.add_refraction(c, d, s, sp, depth, counts, rng);
        }
        c
    }

    /// The light a lit surface reflects from the ambient light (occluded where asked), the
    /// environment and each light, in that order (the order `rng` is drawn in), its diffuse
    /// reflectance textured where the object has a texture.
    #[allow(clippy::too_many_arguments)]
    fn direct_light(
        &self,
        ray: &Ray,
        hit: &Hit,
        obj: &Object,
        sp: &SurfacePoint,
        counts: &mut RayCounts,
        rng: &mut Rng,
        traced: &[Option<f32>; PACKET_LIGHTS],
    ) -> Vec3 {
        let s = obj.surface;
        // Compute the ambient and environment light.
        let mut e = self.ambient;
        if let Some(ao) = self.ambient_occlusion {
            e *= self.ambient_visibility(sp, ao, counts, rng);
        }
        if let Some(env) = &self.environment {
            e += self.environment_light(sp, env, counts, rng);
        }
        // Compute the diffuse reflectance, the texture only for textured objects.
        let mut kd = s.kd * (1.0 - s.transmission);
        if let Some((tex, uvs)) = &obj.texture {
            if let Some(uv) = Object::texcoord(uvs, hit.prim_id, hit.u, hit.v) {
                counts.texture += 1;
                kd *= tex.sample(uv);
            }
        }
        // Compute each light's reflected light, evaluating the highlight only where glossy.
        let mut c = Vec3::ZERO;
        c += kd * e;
        let v = -ray.dir.normalize_or_zero();
        for (i, light) in self.lights.iter().enumerate() {
            let traced = traced.get(i).copied().flatten();
            if s.glossy() {
                let mut spec = 0u64;
                c += self.irradiance(light, sp, traced, counts, rng, |l| {
                    spec += 1;
                    kd + s.blinn_phong(sp.n, v, l)
                });
                counts.specular += spec;
            } else {
                c += self.irradiance(light, sp, traced, counts, rng, |_| kd);
            }
        }
        c
    }

    /// `c` plus the light a transparent surface passes along the unit ray direction `d`: its
    /// dielectric Fresnel reflection, then its refraction (none past total internal reflection),
    /// each weighted by the transmission, added in that order.
    #[allow(clippy::too_many_arguments)]
    fn add_refraction(
        &self,
        mut c: Vec3,
        d: Vec3,
        s: &Surface,
        sp: &SurfacePoint,
        depth: u32,
        counts: &mut RayCounts,
        rng: &mut Rng,
    ) -> Vec3 {
        // Compute the relative index and the Fresnel reflectance.
        let eta = if sp.entering { 1.0 / s.ior } else { s.ior };
        let n = sp.n;
        let cos_i = (-d.dot(n)).clamp(0.0, 1.0);
        let k = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
        let f = if k < 0.0 { 1.0 } else { fresnel_dielectric(cos_i, k.sqrt(), eta) };
        // Compute the reflected and the refracted ray's light.
        if f > 0.0 {
            let r = d + 2.0 * cos_i * n;
            counts.reflection += 1;
            let o = sp.offset_origin(r);
            c += s.transmission * f * self.radiance(Ray::new(o, r), depth + 1, counts, rng);
        }
        if k >= 0.0 {
            let dir = eta * d + (eta * cos_i - k.sqrt()) * n;
            counts.refraction += 1;
            let o = sp.offset_origin(dir);
            c += s.transmission * (1.0 - f) * self.radiance(Ray::new(o, dir), depth + 1, counts, rng);
        }
        c
    }

    /// Light reflected from one light at a shading point: the irradiance from each light direction
    /// `l` weighted by `brdf(l)`, with shadow rays only if the light casts them (a hard shadow's
    /// visibility is `traced` where it was traced ahead, see [`hard_shadow`]).
    fn irradiance(
        &self,
        light: &Light,
        sp: &SurfacePoint,
        traced: Option<f32>,
        counts: &mut RayCounts,
        rng: &mut Rng,
        mut brdf: impl FnMut(Vec3) -> Vec3,
    ) -> Vec3 {
        match *light {
            Light::Directional { direction, radiance, shadows } => {
                let l = direction.normalize_or_zero();
                let cos = sp.light_factor(l);
                if cos <= 0.0 {
                    return Vec3::ZERO;
                }
                let vis = match traced {
                    Some(v) => v,
                    None if shadows => self.visibility(sp, l, f32::INFINITY, counts),
                    None => 1.0,
                };
                if vis == 0.0 {
                    return Vec3::ZERO;
                }
                vis * brdf(l) * radiance * cos
            }
            Light::Point { position, intensity, shadows } => {
                let to = position - sp.p;
                let d2 = to.length_squared();
                let l = to / d2.sqrt();
                let cos = sp.light_factor(l);
                if cos <= 0.0 || d2 == 0.0 {
                    return Vec3::ZERO;
                }
                let vis = match traced {
                    Some(v) => v,
                    None if shadows => self.visibility(sp, to, 1.0, counts),
                    None => 1.0,
                };
                if vis == 0.0 {
                    return Vec3::ZERO;
                }
                vis * brdf(l) * intensity * cos / d2
            }
            Light::Sphere { center, radius, intensity, samples } => {
                let n = samples.max(1);
                let mut sum = Vec3::ZERO;
                for k in 0..n {
                    // A stratified point on the sphere (uniform in z and angle).
                    let (a, b) = rng.stratified(k, n);
                    let z = 1.0 - 2.0 * a;
                    let r = (1.0 - z * z).max(0.0).sqrt();
                    let phi = std::f32::consts::TAU * b;
                    let q = center + radius * Vec3::new(r * phi.cos(), r * phi.sin(), z);
                    let to = q - sp.p;
                    let d2 = to.length_squared();
                    let l = to / d2.sqrt();
                    let cos = sp.light_factor(l);
                    if cos <= 0.0 || d2 == 0.0 {
                        continue;
                    }
                    let vis = self.visibility(sp, to, 1.0, counts);
                    if vis > 0.0 {
                        sum += vis * brdf(l) * intensity * cos / d2;
                    }
                }
                sum / n as f32
            }
        }
    }

    /// The fraction of light arriving along `dir` over `(0, tfar)` from the offset surface point
    /// (from the lifted point, see [`Terminator::Lift`], where the true surface turns away from the
    /// light): 0 behind an opaque surface, 1 if nothing is in the way. Only when some material is
    /// transmissive, the ray continues through each transmissive surface it meets, attenuated by
    /// its transmission (no refraction: shadows through glass, without caustics), one more shadow
    /// ray per surface passed, at most [`MAX_SHADOW_SURFACES`]; otherwise one any-hit ray.
    fn visibility(&self, sp: &SurfacePoint, dir: Vec3, tfar: f32, counts: &mut RayCounts) -> f32 {
        let o = self.shadow_origin(sp, dir, counts);
        counts.shadow += 1;
        if !self.any_transmissive() {
            return if self.hard_shadow_clear(sp, o, dir, tfar, counts) { 1.0 } else { 0.0 };
        }
        let end = (tfar.is_finite()).then(|| o + tfar * dir);
        let mut ray = Ray::new(o, dir).with_range(0.0, tfar);
        let mut t = 1.0f32;
        for pass in 0..MAX_SHADOW_SURFACES {
            if pass > 0 {
                counts.shadow += 1;
            }
            let Some(hit) = self.scene.intersect1(ray) else { return t };
            let Some(obj) = self.objects.get(hit.geom_id as usize) else { return 0.0 };
            if !obj.surface.refracts() {
                return 0.0;
            }
            t *= obj.surface.transmission;
            if !(t > 0.0) {
                return 0.0;
            }
            let hp = obj.surface_point(&hit, &ray, self.shading, Terminator::Plain);
            let org = hp.offset_origin(dir);
            let rest = end.map_or(f32::INFINITY, |e| (e - org).dot(dir) / dir.length_squared());
            if !(rest > 0.0) {
                return t;
            }
            ray = Ray::new(org, dir).with_range(0.0, rest);
        }
        0.0
    }

    /// The origin of a shadow ray along `dir`. With [`Terminator::Lift`], the surface point is
    /// lifted by `w · lift`, where `w = clamp(1 - min(n·l, ng·l) / LIFT_CUTOFF, 0, 1)` fades the
    /// lift in as the shading or the true normal turns away from the light `l` (so it acts only
    /// near the terminator; [`Terminator::LiftNg`] fades on `ng·l` alone), and only if a ray from the
    /// surface point to the lifted one meets nothing: the lift never moves an origin through
    /// another sheet of geometry.
    ///
    /// The lift itself ([`World::shadow_lift`]) is computed only where the fade leaves some of it.
    pub fn shadow_origin(&self, sp: &SurfacePoint, dir: Vec3, counts: &mut RayCounts) -> Vec3 {
        if !matches!(sp.terminator, Terminator::Lift | Terminator::LiftNg) {
            return sp.offset_origin(dir);
        }
        // Compute the fade, then the lift where the fade leaves some of it.
        let l = dir.normalize_or_zero();
        let cos_g = sp.ng.dot(l);
        let cos = if sp.terminator == Terminator::LiftNg { cos_g } else { cos_g.min(sp.n.dot(l)) };
        let w = (1.0 - cos / LIFT_CUTOFF).clamp(0.0, 1.0);
        if !(w > 0.0) || !(sp.n.dot(l) > 0.0) {
            return sp.offset_origin(dir);
        }
        let full = self.shadow_lift(sp);
        if full == Vec3::ZERO {
            return sp.offset_origin(dir);
        }
        let lift = w * full;
        counts.terminator += 1;
        if self.scene.occluded1_from(Ray::new(sp.offset_origin(lift), lift).with_range(0.0, 1.0), sp.origin) {
            return sp.offset_origin(dir);
        }
        let p = sp.p + lift;
        // The sum rounds: its error joins the point's.
        let lifted = SurfacePoint { p, p_error: sp.p_error + gamma(1) * p.abs(), ..*sp };
        lifted.offset_origin(dir)
    }

    /// Whether an opaque world lets light along `dir` over `(0, tfar)` reach the shading point:
    /// the shadow ray from `o` (see [`World::shadow_origin`]) meets nothing, or only the C0 bumps
    /// of the point's own mesh (see [`Terminator::Lift`]).
    pub fn hard_shadow_clear(
        &self,
        sp: &SurfacePoint,
        o: Vec3,
        dir: Vec3,
        tfar: f32,
        counts: &mut RayCounts,
    ) -> bool {
        match self.scene.occluded1_by(Ray::new(o, dir).with_range(0.0, tfar), sp.origin) {
            None => true,
            Some(by) => self.passes_own_bumps(sp, o, dir, tfar, by, counts),
        }
    }

    /// The shadow-ray origin lift of a Phong shading point on the side its ray came from
    /// ([`phongrt::phong::Patch::shadow_lift`], world space) under [`Terminator::Lift`] and
    /// [`Terminator::LiftNg`]; zero for other rules, flat surfaces and an unknown `sp.origin`.
    /// Computed on demand: [`World::shadow_origin`] asks only near the terminator.
    pub fn shadow_lift(&self, sp: &SurfacePoint) -> Vec3 {
        if !matches!(sp.terminator, Terminator::Lift | Terminator::LiftNg) {
            return Vec3::ZERO;
        }
        let Some((pm, o)) = self.patch_of(sp) else { return Vec3::ZERO };
        // The side the ray came from, relative to the vertex normals.
        let side = if sp.entering { 1.0 } else { -1.0 };
        pm.shadow_lift(o.prim, o.u, o.v, side)
    }

    /// Within what a shadow ray from `sp` may pass the C0 bumps of its own mesh under
    /// [`Terminator::Lift`] (from [`phongrt::phong::Patch::bump_bound`]); `None` for other rules,
    /// flat surfaces, an unknown `sp.origin` and a bound that is not finite. Computed on demand:
    /// only for a blocked shadow ray.
    pub fn bump_bound(&self, sp: &SurfacePoint) -> Option<BumpBound> {
        if sp.terminator != Terminator::Lift {
            return None;
        }
        let (pm, o) = self.patch_of(sp)?;
        pm.bump_bound(o.prim).map(|(height, reach)| BumpBound { geom: o.geom_id, height, reach })
    }

    /// The Phong patches `sp` lies on, with the hit it lies on.
    fn patch_of(&self, sp: &SurfacePoint) -> Option<(&PhongMesh, RayOrigin)> {
        let o = sp.origin?;
        Some((self.objects.get(o.geom_id as usize)?.geometry.phong()?, o))
    }

    /// Whether a shadow ray `(o, dir)` over `(0, tfar)` that some surface blocks is blocked only
    /// by the C0 bumps of the shading point's own mesh (see [`Terminator::Lift`]): its hits, in
    /// order, are all on the same object, within the bump bound's reach of the point and below
    /// its height over the shading plane, and at most [`MAX_BUMP_HITS`] of them. Closest-hit
    /// rays, traced only for a blocked shadow ray, and only as far as a hit can be within reach.
    ///
    /// The answer is that of the plain walk over the whole ray (a closest-hit query over
    /// `(tnear, tfar)`, its hit checked, `tnear` moved just past it), with each query cut at `cap`
    /// ([`bump_cap`]): no hit at `t >= cap` passes the reach or the height test as they are computed.
    /// Each query answers the nearest hit of its interval (Embree's closest hit, each patch test
    /// the nearest root in the interval it is given), so a query over `(tnear, cap)` finds the
    /// plain walk's hit wherever that lies below `cap`, and nothing where it lies at or past
    /// `cap`, where the plain walk stops with `false`. So where the cut query finds a hit, both
    /// walks check the same hit; where it finds none, the plain walk's next hit (if any) is out
    /// of reach: on the first query there is one (the ray is blocked, and the blocking query
    /// leaves out only the origin's patch where it proves no hit), so `false`; after a passed
    /// bump, `false` exactly if anything is left in `(tnear, tfar)` (one occlusion query).
    ///
    /// `by`, the hit that blocked the shadow ray where the query recorded it, can settle the
    /// answer without a query: the plain walk meets every hit of the ray in order until one fails,
    /// so a hit on another object fails it there or before, and so does a hit past the cap
    /// (with room for the solves' error in `t`, [`BLOCKER_T_SLACK`]: the walk's query finds the
    /// same root, to rounding).
    fn passes_own_bumps(
        &self,
        sp: &SurfacePoint,
        o: Vec3,
        dir: Vec3,
        tfar: f32,
        by: Option<Blocker>,
        counts: &mut RayCounts,
    ) -> bool {
        let Some(b) = self.bump_bound(sp) else { return false };
        let cap = bump_cap(sp.p, sp.n, &b, o, dir);
        if by.is_some_and(|h| h.geom_id != b.geom || h.t > cap * BLOCKER_T_SLACK) {
            return false;
        }
        let capped = cap < tfar;
        let end = if capped { cap } else { tfar };
        let mut tnear = 0.0;
        for k in 0..MAX_BUMP_HITS {
            counts.terminator += 1;
            let Some(hit) = self.scene.intersect1(Ray::new(o, dir).with_range(tnear, end)) else {
                // Compute whether anything is left past the cap (out of reach).
                if !capped {
                    return true;
                }
                if k == 0 {
                    return false;
                }
                counts.terminator += 1;
                return !self.scene.occluded1(Ray::new(o, dir).with_range(tnear, tfar));
            };
            let d = o + hit.t * dir - sp.p;
            if hit.geom_id != b.geom || d.length() > b.reach || d.dot(sp.n) > b.height {
                return false;
            }
            tnear = hit.t.next_up();
        }
        false
    }

    /// The environment's light at a shading point, as the mean radiance over `env.samples`
    /// stratified cosine-weighted directions that nothing blocks (a diffuse surface reflects `kd`
    /// times it: a white surface under a constant environment `L` shows `L`).
    fn environment_light(
        &self,
        sp: &SurfacePoint,
        env: &Environment,
        counts: &mut RayCounts,
        rng: &mut Rng,
    ) -> Vec3 {
        let n = env.samples.max(1);
        let (t, b) = orthonormal_basis(sp.n);
        let mut sum = Vec3::ZERO;
        for k in 0..n {
            let (a, c) = rng.stratified(k, n);
            let r = a.sqrt();
            let phi = std::f32::consts::TAU * c;
            let d = r * phi.cos() * t + r * phi.sin() * b + (1.0 - a).max(0.0).sqrt() * sp.n;
            if d.dot(sp.ng) <= 0.0 {
                continue;
            }
            counts.environment += 1;
            let o = sp.offset_origin(d);
            if !self.scene.occluded1_from(Ray::new(o, d), sp.origin) {
                sum += env.radiance(d);
            }
        }
        sum / n as f32
    }

    /// Fraction of the cosine-weighted hemisphere not blocked within `ao.distance`.
    fn ambient_visibility(
        &self,
        sp: &SurfacePoint,
        ao: AmbientOcclusion,
        counts: &mut RayCounts,
        rng: &mut Rng,
    ) -> f32 {
        let n = ao.samples.max(1);
        let (t, b) = orthonormal_basis(sp.n);
        let mut free = 0;
        for k in 0..n {
            let (a, c) = rng.stratified(k, n);
            let r = a.sqrt();
            let phi = std::f32::consts::TAU * c;
            let d = r * phi.cos() * t + r * phi.sin() * b + (1.0 - a).max(0.0).sqrt() * sp.n;
            counts.ambient_occlusion += 1;
            let o = sp.offset_origin(d);
            if !self.scene.occluded1_from(Ray::new(o, d).with_range(0.0, ao.distance), sp.origin) {
                free += 1;
            }
        }
        free as f32 / n as f32
    }
}

/// A shading point: position with its float error bound, normals facing the incoming ray.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    /// Position on the surface.
    pub p: Vec3,
    /// Conservative bound on the absolute error of `p`, per axis.
    pub p_error: Vec3,
    /// Geometric normal (unit), on the side the ray came from.
    pub ng: Vec3,
    /// Shading normal (unit), on the same side as `ng`.
    pub n: Vec3,
    /// Whether the ray arrived from the front (the side `dp/du x dp/dv` points to).
    pub entering: bool,
    /// The terminator rule (Phong surfaces; flat ones use [`Terminator::Plain`] with no lift and
    /// keep the classic faceted terminator). What the rule needs of the patch, the shadow-ray
    /// lift and the bump bound, is computed only where a shadow ray asks for it, from `origin`
    /// ([`World::shadow_lift`], [`World::bump_bound`]).
    pub terminator: Terminator,
    /// The hit the point lies on: given to the occlusion rays that leave it, so that the patch
    /// they start on is left out where it provably cannot block them, and where the terminator
    /// rule finds the patch (`None`: not known, and no lift).
    pub origin: Option<RayOrigin>,
}

/// Where a shadow ray from a Phong surface may pass the C0 bumps of its own mesh (see
/// [`Terminator::Lift`]): hits on object `geom` at most `reach` from the shading point and at most
/// `height` above its shading plane (world space, from [`phongrt::phong::Patch::bump_bound`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BumpBound {
    /// The shading point's object (its Embree geometry id).
    pub geom: u32,
    /// Largest height above the shading plane of a hit that is passed.
    pub height: f32,
    /// Largest distance from the shading point of a hit that is passed.
    pub reach: f32,
}

/// The cosine to the light below which [`Terminator::Lift`] fades the shadow-ray lift in: the
/// smaller of the shading and true normals' (the true normal's alone with [`Terminator::LiftNg`]).
pub const LIFT_CUTOFF: f32 = 0.1;

/// The most hits on its own mesh's bumps a shadow ray passes (see [`Terminator::Lift`]).
pub const MAX_BUMP_HITS: usize = 4;

/// How far past the bump cap a recorded blocker's `t` must lie to settle
/// [`World::passes_own_bumps`] on its own: a factor far above the relative error in `t` of the
/// f32 patch solve outside grazing (8.6e-7 at most in `phongrt accuracy`'s table), so that the
/// walk's own queries, which solve the same root again with the same patch test, find it at or
/// past the cap too.
const BLOCKER_T_SLACK: f32 = 1.0 + 1e-4;

/// A ray parameter `cap` past which no point of the ray `(o, dir)` passes the bump pass's tests
/// of `b` at the shading point `p` with shading normal `n`: for every `t >= cap`, with
/// `d = o + t * dir - p` as f32 computes it, `d.length() > b.reach` or `d.dot(n) > b.height`
/// (rounded up to f32; infinite or NaN where an input is not finite or `dir` is zero, and then
/// no cap). The smaller of two caps, evaluated in f64 (its own rounding, 1e-15 relative, lies
/// within the final factors `1 + ε`), with `ε = 1e-5` (more than `2 √3 γ3`, 6.2e-7):
///
/// - Reach: `|o + t dir - p| >= t |dir| - |o - p|` (the triangle inequality). The f32
///   evaluation of `d` is off by at most `γ3 (|o|₁ + t |dir|₁ + |p|₁)` (three roundings per
///   component, summed over them; `|dir|₁ <= √3 |dir|`), and its length by a factor `1 - γ3` at
///   most (a sum of three squares, then the square root). So the computed length is above
///   `reach` for `t >= ((1 + ε) reach + |o - p| + ε (|o|₁ + |p|₁)) / ((1 - ε) |dir|)`.
/// - Height, where the ray rises over the shading plane (`dir·n > ε |dir|₁`): exactly,
///   `d·n = (o - p)·n + t dir·n`; the computed `d` is off as above, and the dot product adds
///   `γ3 |d|₁ |n|∞`, so (`|n|∞ <= 1` to rounding) the computed `d.dot(n)` is off by less than
///   `(ε / 2) (|o|₁ + |p|₁ + t |dir|₁)`, and above `height` for
///   `t >= (height - (o - p)·n + ε (|o|₁ + |p|₁)) / (dir·n - ε |dir|₁)`.
fn bump_cap(p: Vec3, n: Vec3, b: &BumpBound, o: Vec3, dir: Vec3) -> f32 {
    const EPS: f64 = 1e-5;
    let (p, n, o, dir) = (p.as_dvec3(), n.as_dvec3(), o.as_dvec3(), dir.as_dvec3());
    let size = o.abs().element_sum() + p.abs().element_sum();
    // Compute the reach cap.
    let far = (1.0 + EPS) * b.reach as f64 + (o - p).length() + EPS * size;
    let mut cap = (1.0 + EPS) * far / ((1.0 - EPS) * dir.length());
    // Compute the height cap, where the ray rises.
    let rise = dir.dot(n) - EPS * dir.abs().element_sum();
    if rise > 0.0 {
        let over = b.height as f64 - (o - p).dot(n) + EPS * size;
        let high = (1.0 + EPS) * over.max(0.0) / rise;
        cap = cap.min(high);
    }
    // Round up to f32.
    let c = cap as f32;
    if (c as f64) < cap {
        c.next_up()
    } else {
        c
    }
}

impl SurfacePoint {
    /// The light a direction `l` (unit) brings in, as a factor of `n·l`: `max(0, n·l)` except
    /// with [`Terminator::Band`], kept for comparison, where it is as follows. On Phong surfaces the
    /// shading normal `n` and the true normal `ng` differ, and where `n·l > 0` but the true
    /// surface faces away, a shadow ray would be blocked by the surface itself: a jagged hard
    /// terminator. So: 0 where the true surface faces away (no shadow ray needed); in the band
    /// `n·l < 2|n - ng|` (the only place the two can disagree in sign) Chiang et al. 2019's smooth
    /// shadowing term `G' = -G³ + G² + G`, `G = min(1, (ng·l) / ((n·l)(ng·n)))`, blended back to 1
    /// across the band; elsewhere plain `n·l`. Flat surfaces keep the classic artefact.
    pub fn light_factor(&self, l: Vec3) -> f32 {
        let cos_s = self.n.dot(l);
        if cos_s <= 0.0 {
            return 0.0;
        }
        if self.terminator != Terminator::Band {
            return cos_s;
        }
        let band = 2.0 * (self.n - self.ng).length();
        if cos_s >= band {
            return cos_s;
        }
        let cos_g = self.ng.dot(l);
        if cos_g <= 0.0 {
            return 0.0;
        }
        let g = (cos_g / (cos_s * self.ng.dot(self.n).max(f32::MIN_POSITIVE))).min(1.0);
        let gp = -g * g * g + g * g + g;
        let t = cos_s / band;
        cos_s * (gp + (1.0 - gp) * t)
    }
}

/// The lights whose hard shadows [`World::shade8`] traces in packets (the first ones; any
/// further light traces its shadow rays one by one).
pub const PACKET_LIGHTS: usize = 8;

/// What a ray arrives at (see [`World::shade8`]).
enum Arrival<'a> {
    /// Nothing: the background's (or environment's) radiance.
    Miss(Vec3),
    /// A surface: the hit, its object and its shading point.
    Surface { hit: Hit, obj: &'a Object, sp: SurfacePoint },
}

/// Whether a surface takes direct light (diffuse or glossy): only then are lights evaluated.
fn lit(s: &Surface) -> bool {
    s.kd.max_element() > 0.0 || s.glossy()
}

/// The hard-shadow ray `irradiance` traces at `sp` for a point or directional light that casts
/// shadows, as `(direction, tfar)`: `None` for other lights, and where the light brings nothing
/// (`light_factor` zero, or a point light at the shading point), so no ray is traced.
fn hard_shadow(light: &Light, sp: &SurfacePoint) -> Option<(Vec3, f32)> {
    match *light {
        Light::Directional { direction, shadows: true, .. } => {
            let l = direction.normalize_or_zero();
            // Exactly `irradiance`'s test (a NaN factor goes on to trace).
            (!(sp.light_factor(l) <= 0.0)).then_some((l, f32::INFINITY))
        }
        Light::Point { position, shadows: true, .. } => {
            let to = position - sp.p;
            let d2 = to.length_squared();
            let l = to / d2.sqrt();
            (!(sp.light_factor(l) <= 0.0 || d2 == 0.0)).then_some((to, 1.0))
        }
        _ => None,
    }
}

/// The most transmissive surfaces one shadow ray passes through before it counts as blocked.
pub const MAX_SHADOW_SURFACES: u32 = 16;

/// The dielectric Fresnel reflectance for unpolarised light (pbrt-v4's FrDielectric), from the
/// cosines of the incident and the transmitted angle and the relative index `eta = n_i / n_t`.
pub fn fresnel_dielectric(cos_i: f32, cos_t: f32, eta: f32) -> f32 {
    let r_parl = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let r_perp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let f = 0.5 * (r_parl * r_parl + r_perp * r_perp);
    if f.is_finite() {
        f.clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// The library's `gamma(n)` in f32 ([`Real::gamma`]).
fn gamma(n: u32) -> f32 {
    <f32 as Real>::gamma(n)
}

impl SurfacePoint {
    /// A ray origin just off the surface on the side `dir` leaves towards, moved by the error
    /// bound of `p` projected on the normal (pbrt-v4's OffsetRayOrigin), so the new ray cannot
    /// re-hit the surface it starts on because of rounding.
    pub fn offset_origin(&self, dir: Vec3) -> Vec3 {
        // At least the bound's largest component: the patch intersector solves in its own local
        // frame, so its roots carry rounding that is not aligned with the normal. An exactly
        // planar patch has a zero bound along its normal, yet a shadow ray leaving it found the
        // patch again at t = 3.6e-15 (speckled shadow acne on a flat triangle in Phong mode).
        let d = self.ng.abs().dot(self.p_error).max(self.p_error.max_element());
        let mut offset = d * self.ng;
        if dir.dot(self.ng) < 0.0 {
            offset = -offset;
        }
        let mut po = self.p + offset;
        // Round away from p so the offset is not lost to rounding.
        for i in 0..3 {
            if offset[i] > 0.0 {
                po[i] = po[i].next_up();
            } else if offset[i] < 0.0 {
                po[i] = po[i].next_down();
            }
        }
        po
    }
}

/// [`phongrt::phong::orthonormal_basis`] on glam vectors: `(t, b)` with `t × b = n` for a unit `n`.
fn orthonormal_basis(n: Vec3) -> (Vec3, Vec3) {
    let (t, b) = phongrt::phong::orthonormal_basis(V3::from(n));
    (t.into(), b.into())
}

impl Object {
    /// The interpolated vertex normal at `(u, v)` of triangle `prim` (Embree's convention:
    /// weights `1-u-v, u, v`), or `None` where it is degenerate.
    pub fn interpolated_normal(&self, prim: u32, u: f32, v: f32) -> Option<Vec3> {
        let t = self.indices.get(prim as usize)?;
        let n = |i: u32| self.normals.get(i as usize).copied().unwrap_or(Vec3::ZERO);
        ((1.0 - u - v) * n(t[0]) + u * n(t[1]) + v * n(t[2])).try_normalize()
    }

    /// The shading point of a hit: position recomputed from `(u, v)` on the surface, with its
    /// error bound, and normals facing the ray.
    pub fn surface_point(
        &self,
        hit: &Hit,
        ray: &Ray,
        shading: ShadingNormal,
        terminator: Terminator,
    ) -> SurfacePoint {
        let ng_raw = hit.ng.try_normalize().unwrap_or(-ray.dir.normalize_or_zero());
        let (p, p_error, n_shade) = match &self.geometry {
            Geometry::Flat => {
                let (p, err) = self.flat_point(hit.prim_id, hit.u, hit.v).unwrap_or_else(|| {
                    let p = ray.at(hit.t);
                    (p, gamma(7) * (ray.org.abs() + (hit.t * ray.dir).abs()))
                });
                (p, err, self.interpolated_normal(hit.prim_id, hit.u, hit.v).unwrap_or(ng_raw))
            }
            Geometry::Phong(pm) => {
                let (p, err) = pm.surface_point(hit.prim_id, hit.u, hit.v).unwrap_or_else(|| {
                    let p = ray.at(hit.t);
                    (p, gamma(7) * (ray.org.abs() + (hit.t * ray.dir).abs()))
                });
                let n = pm.shading_normal_with(hit.prim_id, hit.u, hit.v, ray.dir, shading).unwrap_or(ng_raw);
                (p, err, n)
            }
        };
        let entering = ng_raw.dot(ray.dir) < 0.0;
        let ng = if entering { ng_raw } else { -ng_raw };
        // The shading normal on the same side as the geometric one.
        let n = if n_shade.dot(ng) < 0.0 { -n_shade } else { n_shade };
        // Compute the terminator rule: Phong surfaces only (the lift and the bump bound it needs
        // are computed when a shadow ray asks, see `World::shadow_lift`).
        let terminator = match &self.geometry {
            Geometry::Phong(_) => terminator,
            Geometry::Flat => Terminator::Plain,
        };
        SurfacePoint { p, p_error, ng, n, entering, terminator, origin: Some(RayOrigin::of_hit(hit)) }
    }

    /// `(1-u-v) p0 + u p1 + v p2` with its rounding error bound (pbrt-v4's barycentric bound).
    fn flat_point(&self, prim: u32, u: f32, v: f32) -> Option<(Vec3, Vec3)> {
        let t = self.indices.get(prim as usize)?;
        let p = |k: usize| self.positions.get(t[k] as usize).copied();
        let (p0, p1, p2) = (p(0)?, p(1)?, p(2)?);
        let w = 1.0 - u - v;
        let pt = w * p0 + u * p1 + v * p2;
        let err = gamma(7) * ((w * p0).abs() + (u * p1).abs() + (v * p2).abs());
        Some((pt, err))
    }
}

/// A small deterministic generator (SplitMix64, shared with the accuracy report), seeded per
/// pixel and sample so images do not depend on thread count or scheduling.
#[derive(Clone, Debug)]
pub struct Rng(SplitMix);

impl Rng {
    /// A generator seeded with `seed`.
    pub fn new(seed: u64) -> Self {
        Rng(SplitMix(seed))
    }

    /// Uniform in [0, 1).
    pub fn next_f32(&mut self) -> f32 {
        (self.0.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }

    /// Sample `k` of `n` on a jittered grid over the unit square (plain jitter if `n` is not a square).
    pub fn stratified(&mut self, k: u32, n: u32) -> (f32, f32) {
        let (j1, j2) = (self.next_f32(), self.next_f32());
        let m = (n as f32).sqrt() as u32;
        if m * m == n && m > 1 {
            (((k % m) as f32 + j1) / m as f32, ((k / m) as f32 + j2) / m as f32)
        } else {
            (j1, j2)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene_file::ObjectSection;

    /// An `[[object]]` entry naming only `mode` and `alpha`.
    fn entry(mode: Option<SurfaceMode>, alpha: Option<f32>) -> ObjectSection {
        ObjectSection {
            name: "*".into(),
            mode,
            alpha,
            kd: None,
            mirror: None,
            transmission: None,
            ior: None,
            specular: None,
            shininess: None,
        }
    }

    #[test]
    fn naming_phong_without_alpha_keeps_the_alpha_set_before() {
        let (phong, flat) = (SurfaceMode::Phong, SurfaceMode::Flat);
        let at = |alpha| ObjectMode::Phong { alpha };
        // The mode alone: Phong keeps the prior alpha, or takes the fallback from flat.
        assert_eq!(phong.over(None, at(1.0), 0.5), at(1.0));
        assert_eq!(phong.over(None, ObjectMode::Flat, 0.5), at(0.5));
        assert_eq!(flat.over(None, at(1.0), 0.5), ObjectMode::Flat);
        // With an alpha, that alpha.
        assert_eq!(phong.over(Some(0.25), at(1.0), 0.5), at(0.25));
        assert_eq!(phong.over(Some(0.25), ObjectMode::Flat, 0.5), at(0.25));
        // A scene file's `[[object]]` entries combine the same way.
        assert_eq!(entry(Some(phong), None).mode_over(at(1.0), 0.5), at(1.0));
        assert_eq!(entry(Some(phong), None).mode_over(ObjectMode::Flat, 0.5), at(0.5));
        assert_eq!(entry(None, Some(0.25)).mode_over(ObjectMode::Flat, 0.5), at(0.25));
        assert_eq!(entry(Some(flat), Some(0.25)).mode_over(at(1.0), 0.5), ObjectMode::Flat);
        assert_eq!(entry(None, None).mode_over(at(1.0), 0.5), at(1.0));
    }
}
