//! [`WorldBuilder`]: every choice of a [`World`] made before it is built (objects and their
//! modes, ground, lights, materials, environment, the integrator's rules), from code or from a
//! scene file; the world it builds is immutable.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::Vec3;

use super::{
    default_lights, AmbientOcclusion, Environment, EnvironmentSource, Geometry, Ground, Light, Object,
    ObjectMode, ObjectSettings, Surface, Terminator, World,
};
use crate::scene_file::{LightSection, SceneFile};
use crate::texture::Texture;
use crate::RenderError;
use phongrt::embree::{Device, GeometryOptions, PhongMesh, Scene};
use phongrt::phong::ShadingNormal;
use phongrt::scene as sc;

/// Material values that replace an object's own (from its MTL material), field by field; `None`
/// keeps the object's value. A whole [`Surface`] converts into an override of every field.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SurfaceOverride {
    /// Diffuse reflectance.
    pub kd: Option<Vec3>,
    /// Mirror reflectance.
    pub mirror: Option<Vec3>,
    /// Transmittance.
    pub transmission: Option<f32>,
    /// Index of refraction.
    pub ior: Option<f32>,
    /// Highlight reflectance.
    pub specular: Option<Vec3>,
    /// Highlight exponent.
    pub shininess: Option<f32>,
}

impl SurfaceOverride {
    /// Write the values this override gives into `s`.
    pub fn apply(&self, s: &mut Surface) {
        s.kd = self.kd.unwrap_or(s.kd);
        s.mirror = self.mirror.unwrap_or(s.mirror);
        s.transmission = self.transmission.unwrap_or(s.transmission);
        s.ior = self.ior.unwrap_or(s.ior);
        s.specular = self.specular.unwrap_or(s.specular);
        s.shininess = self.shininess.unwrap_or(s.shininess);
    }
}

impl From<Surface> for SurfaceOverride {
    fn from(s: Surface) -> Self {
        SurfaceOverride {
            kd: Some(s.kd),
            mirror: Some(s.mirror),
            transmission: Some(s.transmission),
            ior: Some(s.ior),
            specular: Some(s.specular),
            shininess: Some(s.shininess),
        }
    }
}

/// The per-mesh settings: `settings(i, mesh)` for mesh `i` of the scene.
type SettingsFn<'a> = Arc<dyn Fn(usize, &sc::Mesh) -> ObjectSettings + Send + Sync + 'a>;

/// Builds a [`World`] from a loaded scene: start with [`World::builder`], chain the setters
/// (each replaces what an earlier call set; the later call wins), then [`WorldBuilder::build`].
///
/// Defaults: every mesh Phong at [`phongrt::phong::DEFAULT_ALPHA`] with straight creases, no
/// ground, the [`default_lights`], ambient 0.12, background (0.02, 0.02, 0.03), reflection and
/// refraction to depth 6, no ambient occlusion, no environment, the default shading normal and
/// terminator, each object's surface from its MTL material (0.7 grey without one).
#[derive(Clone)]
pub struct WorldBuilder<'a> {
    device: &'a Device,
    input: &'a sc::Model,
    settings: SettingsFn<'a>,
    ground: Option<Ground>,
    lights: Vec<Light>,
    ambient: Vec3,
    background: Vec3,
    max_depth: u32,
    ambient_occlusion: Option<AmbientOcclusion>,
    shading: ShadingNormal,
    terminator: Terminator,
    environment: Option<Environment>,
    surfaces: Vec<(String, SurfaceOverride)>,
}

impl World {
    /// A builder of the world of `input`'s meshes on `device`, with the defaults listed at
    /// [`WorldBuilder`].
    pub fn builder<'a>(device: &'a Device, input: &'a sc::Model) -> WorldBuilder<'a> {
        WorldBuilder {
            device,
            input,
            settings: Arc::new(|_, _| {
                ObjectSettings::new(ObjectMode::Phong { alpha: phongrt::phong::DEFAULT_ALPHA })
            }),
            ground: None,
            lights: default_lights(),
            ambient: Vec3::splat(0.12),
            background: Vec3::new(0.02, 0.02, 0.03),
            max_depth: 6,
            ambient_occlusion: None,
            shading: ShadingNormal::default(),
            terminator: Terminator::default(),
            environment: None,
            surfaces: Vec::new(),
        }
    }

    /// A world of `input` with the builder's defaults except that `settings(i, mesh)` chooses the
    /// mode of mesh `i`: a shortcut for `World::builder(device, input).settings(settings).build()`.
    pub fn from_scene(
        device: &Device,
        input: &sc::Model,
        settings: impl Fn(usize, &sc::Mesh) -> ObjectSettings + Send + Sync,
    ) -> Result<World, RenderError> {
        World::builder(device, input).settings(settings).build()
    }
}

impl<'a> WorldBuilder<'a> {
    /// `settings(i, mesh)` chooses the mode of mesh `i` (and whether its creases stay straight).
    /// It is `Send + Sync`, as the builder is: a builder can be made on one thread and built on
    /// another.
    pub fn settings(
        mut self,
        settings: impl Fn(usize, &sc::Mesh) -> ObjectSettings + Send + Sync + 'a,
    ) -> Self {
        self.settings = Arc::new(settings);
        self
    }

    /// Every mesh in `mode`, creases straight.
    pub fn mode(self, mode: ObjectMode) -> Self {
        self.settings(move |_, _| ObjectSettings::new(mode))
    }

    /// A ground plane under the scene's bounds (the last object, named "ground"; the bounds, and
    /// so the camera's framing, leave it out), or none.
    pub fn ground(mut self, ground: Option<Ground>) -> Self {
        self.ground = ground;
        self
    }

    /// The lights, replacing the [`default_lights`].
    pub fn lights(mut self, lights: impl IntoIterator<Item = Light>) -> Self {
        self.lights = lights.into_iter().collect();
        self
    }

    /// The ambient light (times each surface's diffuse reflectance).
    pub fn ambient(mut self, ambient: Vec3) -> Self {
        self.ambient = ambient;
        self
    }

    /// The radiance of rays that leave the scene (unless an environment is given).
    pub fn background(mut self, background: Vec3) -> Self {
        self.background = background;
        self
    }

    /// The maximum depth of reflection and refraction rays.
    pub fn max_depth(mut self, max_depth: u32) -> Self {
        self.max_depth = max_depth;
        self
    }

    /// Ambient occlusion of the ambient light, or none.
    pub fn ambient_occlusion(mut self, ao: Option<AmbientOcclusion>) -> Self {
        self.ambient_occlusion = ao;
        self
    }

    /// The shading-normal rule of Phong objects (flat ones interpolate).
    pub fn shading(mut self, shading: ShadingNormal) -> Self {
        self.shading = shading;
        self
    }

    /// The terminator rule of Phong objects (flat ones keep the classic faceted terminator).
    pub fn terminator(mut self, terminator: Terminator) -> Self {
        self.terminator = terminator;
        self
    }

    /// Environment light, or none.
    pub fn environment(mut self, environment: Option<Environment>) -> Self {
        self.environment = environment;
        self
    }

    /// Override the surface of the object named `name`, or of every object but the ground for
    /// `"*"`. Overrides apply in the order given, after the MTL materials.
    pub fn surface(mut self, name: impl Into<String>, o: impl Into<SurfaceOverride>) -> Self {
        self.surfaces.push((name.into(), o.into()));
        self
    }

    /// Apply a scene file's sections over what is set so far: `[render]`'s background, ambient,
    /// max_depth, shading and terminator; `[[light]]`s (replacing the lights if there is one);
    /// `[ambient_occlusion]`; `[ground]` (perpendicular to `up`, sized by the scene); each
    /// `[[object]]`'s mode and alpha (over the per-mesh settings) and material values (a
    /// [`WorldBuilder::surface`] override); `[environment]`, a map read beside `path` (the scene
    /// file's path, which the errors name) with its top row towards `up`. The camera, image size, samples and crease
    /// angle are not the world's: the caller reads them. A one-line error naming the file and key of
    /// a value out of range (the file's checks are run again here, for a `SceneFile` built in
    /// code), or the map if it cannot be read.
    pub fn scene_file(mut self, sf: &SceneFile, path: &Path, up: Vec3) -> Result<Self, RenderError> {
        sf.check(path)?;
        let dir = path.parent().unwrap_or(Path::new("."));
        // Compute the integrator's settings and the lights.
        let up = up.normalize_or_zero();
        let r = &sf.render;
        self.background = r.background.map_or(self.background, Vec3::from);
        self.ambient = r.ambient.map_or(self.ambient, Vec3::from);
        self.max_depth = r.max_depth.unwrap_or(self.max_depth);
        self.shading = r.shading.as_deref().and_then(ShadingNormal::from_name).unwrap_or(self.shading);
        self.terminator = r.terminator.as_deref().and_then(Terminator::from_name).unwrap_or(self.terminator);
        if !sf.lights.is_empty() {
            self.lights = sf.lights.iter().map(light_of).collect();
        }
        if let Some(a) = sf.ambient_occlusion {
            self.ambient_occlusion = Some(AmbientOcclusion { samples: a.samples, distance: a.distance });
        }
        if let Some(g) = &sf.ground {
            let kd = g.kd.map_or(Ground::default().kd, Vec3::from);
            self.ground = Some(Ground { up, height: g.height, kd, radius: None });
        }
        // Compute the objects' modes and surfaces.
        let objects = sf.objects.clone();
        let settings = self.settings.clone();
        self.settings = Arc::new(move |i, mesh| {
            let s = settings(i, mesh);
            let matching = objects.iter().filter(|o| o.name == "*" || o.name == mesh.name);
            ObjectSettings {
                mode: matching.fold(s.mode, |m, o| o.mode_over(m, phongrt::phong::DEFAULT_ALPHA)),
                ..s
            }
        });
        for o in &sf.objects {
            self = self.surface(o.name.clone(), o.surface_override());
        }
        // Compute the environment.
        if let Some(e) = &sf.environment {
            let source = match (&e.color, &e.map) {
                (Some(c), _) => EnvironmentSource::Constant(Vec3::from(*c)),
                (None, Some(m)) => {
                    let texture = Environment::load_map(&dir.join(m)).map_err(RenderError::Environment)?;
                    EnvironmentSource::Map { texture: Arc::new(texture), up }
                }
                (None, None) => {
                    return Err(RenderError::Environment("environment: give color or map".into()))
                }
            };
            self.environment = Some(Environment { source, samples: e.samples.unwrap_or(16) });
        }
        Ok(self)
    }

    /// Build the world: each mesh attached to one Embree scene in its mode, with its surface and
    /// texture, then the ground, the surface overrides, and the scene committed.
    pub fn build(self) -> Result<World, RenderError> {
        // Compute the objects, one Embree geometry each, geomIDs in mesh order.
        let mut scene = Scene::new(self.device)?;
        let mut warnings = sc::FoldedWarnings::default();
        let mut textures = TextureCache::default();
        let mut objects = Vec::with_capacity(self.input.meshes.len() + 1);
        for (i, mesh) in self.input.meshes.iter().enumerate() {
            let geometry = attach_mesh(&mut scene, mesh, &(self.settings)(i, mesh), objects.len())?;
            let material = mesh.material.and_then(|m| self.input.materials.get(m));
            objects.push(Object {
                name: mesh.name.clone(),
                geometry,
                normals: mesh.normals.clone(),
                positions: mesh.positions.clone(),
                indices: mesh.indices.clone(),
                surface: surface_of(material, &self.input.path, &mut warnings),
                is_ground: false,
                texture: textures.binding(material, mesh, &self.input.path, &mut warnings),
            });
        }
        if let Some(g) = self.ground {
            let ground = attach_ground(&mut scene, &g, self.input.bounds(), objects.len())?;
            objects.push(ground);
        }
        // Apply the surface overrides: by name, or "*" for all but the ground.
        for (name, o) in &self.surfaces {
            let named = |x: &&mut Object| !x.is_ground && (name == "*" || x.name == *name);
            objects.iter_mut().filter(named).for_each(|x| o.apply(&mut x.surface));
        }
        Ok(World {
            device: self.device.clone(),
            scene: scene.commit()?,
            objects,
            lights: self.lights,
            ambient: self.ambient,
            background: self.background,
            bounds: self.input.bounds(),
            ambient_occlusion: self.ambient_occlusion,
            max_depth: self.max_depth,
            shading: self.shading,
            terminator: self.terminator,
            warnings: warnings.into_lines().collect(),
            environment: self.environment,
        })
    }
}

/// A scene file's light.
fn light_of(l: &LightSection) -> Light {
    match *l {
        LightSection::Directional { direction, radiance, shadows } => Light::Directional {
            direction: Vec3::from(direction).normalize(),
            radiance: Vec3::from(radiance),
            shadows,
        },
        LightSection::Point { position, intensity, shadows } => {
            Light::Point { position: Vec3::from(position), intensity: Vec3::from(intensity), shadows }
        }
        LightSection::Sphere { center, radius, intensity, samples } => {
            Light::Sphere { center: Vec3::from(center), radius, intensity: Vec3::from(intensity), samples }
        }
    }
}

/// Attach `mesh` to `scene` in the mode `s` calls for, as geometry `id` (the next one).
fn attach_mesh(
    scene: &mut Scene,
    mesh: &sc::Mesh,
    s: &ObjectSettings,
    id: usize,
) -> Result<Geometry, RenderError> {
    let refused = |source| RenderError::Object { name: mesh.name.clone(), source };
    let (got, geometry) = match s.mode {
        ObjectMode::Flat => {
            let got = scene.attach_triangles(&mesh.positions, &mesh.indices, GeometryOptions::default());
            (got.map_err(refused)?, Geometry::Flat)
        }
        ObjectMode::Phong { alpha } => {
            // Compute the patches, crease and border edges straight unless asked otherwise.
            let straight = mesh.straight_edges();
            let straight = (s.straight_creases && straight.len() == mesh.indices.len()).then_some(straight);
            let pm = PhongMesh::with_straight_edges(
                &mesh.positions,
                &mesh.normals,
                &mesh.indices,
                alpha,
                straight.as_deref(),
            )
            .map_err(|source| RenderError::PhongMesh { name: mesh.name.clone(), source })?;
            let pm = Arc::new(pm);
            let got = scene.attach_phong(pm.clone(), GeometryOptions::default());
            (got.map_err(refused)?, Geometry::Phong(pm))
        }
    };
    // geomIDs are handed out densely from 0 in attach order on a fresh scene.
    if got as usize != id {
        return Err(RenderError::UnexpectedGeomId(got));
    }
    Ok(geometry)
}

/// The surface `material` calls for (0.7 grey without one), its values out of range clamped
/// with a warning naming `file`.
fn surface_of(material: Option<&sc::Material>, file: &Path, warnings: &mut sc::FoldedWarnings) -> Surface {
    let Some(m) = material else { return Surface::diffuse(Vec3::splat(0.7)) };
    let (s, w) = Surface::from_material_checked(m, file);
    for w in w {
        warnings.push("material values clamped", w);
    }
    s
}

/// Textures loaded so far, each file once (or its error, warned about once).
#[derive(Default)]
struct TextureCache(Vec<(PathBuf, Result<Arc<Texture>, String>)>);

impl TextureCache {
    /// The diffuse texture of `material` with `mesh`'s corner texture coordinates, where the file
    /// exists, decodes and the mesh has `vt` coordinates; a warning naming `file` otherwise.
    fn binding(
        &mut self,
        material: Option<&sc::Material>,
        mesh: &sc::Mesh,
        file: &Path,
        warnings: &mut sc::FoldedWarnings,
    ) -> Option<super::TextureBinding> {
        let path = material?.diffuse_texture.clone().filter(|p| p.exists())?;
        if mesh.corner_uvs.is_empty() {
            let w = format!(
                "{}: object {:?} has a texture ({}) but no `vt` coordinates; using the flat Kd colour",
                file.display(),
                mesh.name,
                path.display()
            );
            warnings.push("textures without `vt` coordinates", w);
            return None;
        }
        // Compute the texture, loading the file the first time it is named.
        let loaded = match self.0.iter().find(|(p, _)| *p == path) {
            Some((_, t)) => t.clone(),
            None => {
                let t = Texture::load(&path).map(Arc::new);
                if let Err(e) = &t {
                    warnings.push("textures that do not decode", format!("{e}; using the flat Kd colour"));
                }
                self.0.push((path, t.clone()));
                t
            }
        };
        loaded.ok().map(|t| (t, mesh.corner_uvs.clone()))
    }
}

/// The ground plane `g` under `bounds` as a flat diffuse object attached to `scene` as geometry
/// `id` (the next one).
fn attach_ground(
    scene: &mut Scene,
    g: &Ground,
    bounds: (Vec3, Vec3),
    id: usize,
) -> Result<Object, RenderError> {
    let (positions, indices) = g.triangles(bounds).ok_or(RenderError::Ground)?;
    let got = scene
        .attach_triangles(&positions, &indices, GeometryOptions::default())
        .map_err(|source| RenderError::Object { name: "ground".into(), source })?;
    if got as usize != id {
        return Err(RenderError::UnexpectedGeomId(got));
    }
    Ok(Object {
        name: "ground".into(),
        geometry: Geometry::Flat,
        normals: vec![g.up.normalize(); positions.len()],
        positions,
        indices,
        surface: Surface::diffuse(g.kd),
        is_ground: true,
        texture: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two spheres named "a" and "b" (Phong unless told otherwise).
    fn two_spheres() -> sc::Model {
        let a = sc::Mesh { name: "a".into(), ..sc::uv_sphere(8, 4, 1.0) };
        let mut b = sc::Mesh { name: "b".into(), ..a.clone() };
        b.positions.iter_mut().for_each(|p| *p += Vec3::X * 3.0);
        let mut scene = sc::Model::from_mesh(a);
        scene.meshes.push(b);
        scene
    }

    /// A builder set up on one thread builds on another (it is `Send`: its settings closure
    /// too), with the settings it was given; and it is `Sync`.
    #[test]
    fn a_builder_made_on_one_thread_builds_on_another() {
        fn send_and_sync<T: Send + Sync>() {}
        send_and_sync::<WorldBuilder<'static>>();
        let device = Device::new().unwrap();
        let scene = two_spheres();
        let builder = World::builder(&device, &scene).settings(|i, _| {
            ObjectSettings::new(if i == 0 { ObjectMode::Flat } else { ObjectMode::Phong { alpha: 0.5 } })
        });
        let world = std::thread::scope(|s| s.spawn(move || builder.build()).join().unwrap()).unwrap();
        let phong: Vec<_> = world.objects().iter().map(|o| o.geometry.phong().is_some()).collect();
        assert_eq!(phong, [false, true]);
    }

    #[test]
    fn a_scene_file_built_in_code_is_checked_as_one_read_from_disk() {
        let device = Device::new().unwrap();
        let scene = two_spheres();
        let mut sf = SceneFile::default();
        sf.render.max_depth = Some(1000);
        let Err(e) = World::builder(&device, &scene).scene_file(&sf, Path::new("code.toml"), Vec3::Y) else {
            panic!("a max_depth of 1000 was accepted");
        };
        let e = e.to_string();
        assert!(e.starts_with("code.toml") && e.contains("render.max_depth") && !e.contains('\n'), "{e}");
    }

    #[test]
    fn a_scene_files_object_overrides_apply_to_the_named_object_and_star_to_all_but_the_ground() {
        let device = Device::new().unwrap();
        let scene = two_spheres();
        let sf = SceneFile::parse(
            "[render]\nbackground = [0.1, 0.2, 0.3]\nambient = [0.0, 0.0, 0.0]\nmax_depth = 2\n\
             [[light]]\ntype = \"point\"\nposition = [0.0, 5.0, 0.0]\n\
             [ambient_occlusion]\nsamples = 4\ndistance = 1.0\n\
             [[object]]\nname = \"a\"\nkd = [0.9, 0.1, 0.1]\nmode = \"flat\"\n\
             [[object]]\nname = \"*\"\nmirror = [0.5, 0.5, 0.5]\n",
            Path::new("s.toml"),
        )
        .unwrap();
        let world = World::builder(&device, &scene)
            .ground(Some(Ground::default()))
            .scene_file(&sf, Path::new("code.toml"), Vec3::Y)
            .unwrap()
            .build()
            .unwrap();
        // Compute each object's surface: "a" alone gets its kd; "*" gives both spheres the mirror.
        let [a, b, ground] = world.objects() else { panic!("{} objects", world.objects().len()) };
        assert_eq!((a.name.as_str(), b.name.as_str(), ground.name.as_str()), ("a", "b", "ground"));
        assert_eq!(a.surface.kd, Vec3::new(0.9, 0.1, 0.1));
        assert_eq!(b.surface.kd, Surface::diffuse(Vec3::splat(0.7)).kd, "kd given for \"a\" only");
        assert_eq!((a.surface.mirror, b.surface.mirror), (Vec3::splat(0.5), Vec3::splat(0.5)));
        assert_eq!(ground.surface, Surface::diffuse(Ground::default().kd), "\"*\" leaves the ground alone");
        // The modes: "a" flat by the file, "b" the default Phong.
        assert!(matches!(a.geometry, Geometry::Flat) && b.geometry.phong().is_some());
        // The file's other sections.
        assert_eq!(world.background(), Vec3::new(0.1, 0.2, 0.3));
        assert_eq!((world.ambient(), world.max_depth()), (Vec3::ZERO, 2));
        let point = Light::Point { position: Vec3::new(0.0, 5.0, 0.0), intensity: Vec3::ONE, shadows: true };
        assert_eq!(world.lights(), [point]);
        assert_eq!(world.ambient_occlusion(), Some(AmbientOcclusion { samples: 4, distance: 1.0 }));
    }

    #[test]
    fn a_scene_files_missing_environment_map_is_a_one_line_error_naming_it() {
        let device = Device::new().unwrap();
        let scene = two_spheres();
        let sf = SceneFile::parse("[environment]\nmap = \"nope.hdr\"\n", Path::new("s.toml")).unwrap();
        let Err(e) =
            World::builder(&device, &scene).scene_file(&sf, Path::new("/no/such/dir/a.toml"), Vec3::Y)
        else {
            panic!("a missing map was accepted");
        };
        let e = e.to_string();
        assert!(
            e.starts_with("/no/such/dir/nope.hdr: cannot read environment map") && !e.contains('\n'),
            "{e}"
        );
    }
}
