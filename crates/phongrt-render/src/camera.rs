//! A pinhole camera, framed automatically on scene bounds unless told otherwise.

use glam::Vec3;

/// A pinhole camera. `fov_y_deg` is the vertical field of view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// The camera's position, in the scene's units.
    pub eye: Vec3,
    /// The point seen at the image centre; must differ from `eye`.
    pub look_at: Vec3,
    /// The direction shown upwards in the image: any length, need not be perpendicular to the
    /// view, but must not be zero or parallel to `look_at - eye`.
    pub up: Vec3,
    /// Vertical field of view in degrees, in (0, 180); the horizontal one follows from the
    /// image's aspect ratio.
    pub fov_y_deg: f32,
}

/// Per-image camera basis, computed once.
#[derive(Clone, Copy, Debug)]
pub struct CameraFrame {
    /// The origin of every camera ray ([`Camera::eye`]).
    pub eye: Vec3,
    /// Direction through the image centre (unit).
    pub forward: Vec3,
    /// Half-extent vectors of the image plane at distance 1.
    pub right: Vec3,
    /// Towards the top of the image, perpendicular to `forward` and `right`, of length
    /// `tan(fov_y / 2)` (the image plane's half height at distance 1).
    pub up: Vec3,
}

impl Camera {
    /// A camera that sees the whole box `[lo, hi]` from the front (+z), a little above and to
    /// the right, as the paper's figures do.
    pub fn frame_bounds(lo: Vec3, hi: Vec3, aspect: f32) -> Camera {
        let center = 0.5 * (lo + hi);
        let radius = (0.5 * (hi - lo).length()).max(1e-6);
        let fov_y_deg: f32 = 35.0;
        // Fit the bounding sphere in the narrower of the two fields of view.
        let half_y = (0.5 * fov_y_deg).to_radians();
        let half_x = (half_y.tan() * aspect).atan();
        let half = half_y.min(half_x);
        let dist = radius / half.sin() * 1.02;
        let dir = Vec3::new(0.25, 0.2, 1.0).normalize();
        Camera { eye: center + dist * dir, look_at: center, up: Vec3::Y, fov_y_deg }
    }

    /// The basis for an image of the given aspect ratio (width / height). Returns `None` for a
    /// degenerate camera (eye at the look-at point, up parallel to the view direction, bad fov).
    pub fn frame(&self, aspect: f32) -> Option<CameraFrame> {
        let forward = (self.look_at - self.eye).try_normalize()?;
        let right = forward.cross(self.up).try_normalize()?;
        let up = right.cross(forward);
        if !(self.fov_y_deg > 0.0 && self.fov_y_deg < 180.0) || !(aspect > 0.0) || !aspect.is_finite() {
            return None;
        }
        let t = (0.5 * self.fov_y_deg).to_radians().tan();
        Some(CameraFrame { eye: self.eye, forward, right: right * t * aspect, up: up * t })
    }
}

/// Why a camera cannot make an image; displays naming the settings involved (`eye`,
/// `look_at`, `up`, `fov`), for the caller to say where each came from.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum CameraProblem {
    /// `eye` and `look_at` are the same point (given here), so there is no view direction.
    #[error("eye and look_at are both {0:?}: the view direction is undefined")]
    EyeAtLookAt([f32; 3]),
    /// `up` is zero or parallel to the view direction, so the image has no horizontal axis.
    #[error("up {up:?} is zero or parallel to the view direction look_at - eye = {dir:?}")]
    UpParallel {
        /// The camera's `up` as given.
        up: [f32; 3],
        /// The view direction `look_at - eye` (not normalised).
        dir: [f32; 3],
    },
    /// The vertical field of view (given here) is not in (0, 180) degrees, or is NaN.
    #[error("fov {0} is not in (0, 180) degrees")]
    Fov(f32),
    /// `eye` or `look_at` has an infinite or NaN coordinate (automatic framing of bounds too
    /// large for f32 can make one).
    #[error("eye {eye:?} or look_at {look_at:?} is not finite (scene bounds too large?)")]
    NonFinite {
        /// The camera's position.
        eye: [f32; 3],
        /// The camera's look-at point.
        look_at: [f32; 3],
    },
}

impl Camera {
    /// The camera turned by `deg` about its up vector, around the look-at point (itself when
    /// the up vector is zero).
    pub fn orbit(&self, deg: f32) -> Camera {
        let axis = self.up.normalize_or_zero();
        if axis == Vec3::ZERO {
            return *self;
        }
        let q = glam::Quat::from_axis_angle(axis, deg.to_radians());
        Camera { eye: self.look_at + q * (self.eye - self.look_at), ..*self }
    }

    /// What is wrong with this camera, if anything (`frame` returns `None` exactly then, for a
    /// positive finite aspect ratio).
    pub fn problem(&self) -> Option<CameraProblem> {
        if !(self.eye.is_finite() && self.look_at.is_finite()) {
            return Some(CameraProblem::NonFinite { eye: self.eye.into(), look_at: self.look_at.into() });
        }
        let Some(forward) = (self.look_at - self.eye).try_normalize() else {
            return Some(CameraProblem::EyeAtLookAt(self.eye.into()));
        };
        if forward.cross(self.up).try_normalize().is_none() {
            return Some(CameraProblem::UpParallel {
                up: self.up.into(),
                dir: (self.look_at - self.eye).into(),
            });
        }
        if !(self.fov_y_deg > 0.0 && self.fov_y_deg < 180.0) {
            return Some(CameraProblem::Fov(self.fov_y_deg));
        }
        None
    }
}

impl CameraFrame {
    /// The direction (not normalised) through the image point `(x, y)` in pixels, with
    /// `(0, 0)` the top-left corner of the image.
    pub fn direction(&self, x: f32, y: f32, width: u32, height: u32) -> Vec3 {
        let sx = 2.0 * x / width as f32 - 1.0;
        let sy = 1.0 - 2.0 * y / height as f32;
        self.forward + sx * self.right + sy * self.up
    }

    /// The pixel position of a world point (inverse of `direction`), or `None` behind the eye.
    pub fn project(&self, p: Vec3, width: u32, height: u32) -> Option<(f32, f32)> {
        let d = p - self.eye;
        let z = d.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        let sx = d.dot(self.right) / (z * self.right.length_squared());
        let sy = d.dot(self.up) / (z * self.up.length_squared());
        Some(((sx + 1.0) * 0.5 * width as f32, (1.0 - sy) * 0.5 * height as f32))
    }
}

/// The fraction of the frame's narrower extent that [`Camera::three_quarter`] fills.
pub const DEFAULT_FILL: f32 = 0.8;

/// How the default view is placed about a model (see [`Camera::three_quarter`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewSpec {
    /// The model's up axis (unit).
    pub up: Vec3,
    /// The direction the model's front faces (unit, perpendicular to `up`).
    pub front: Vec3,
    /// Extra turn of the camera about the model's up axis, degrees (counter-clockwise seen from above).
    pub orbit_deg: f32,
    /// Vertical field of view, degrees.
    pub fov_y_deg: f32,
    /// The fraction of the frame the model's projected vertices span in the tighter direction.
    pub fill: f32,
    /// A ground plane at this height along `up` (`p · up = h`): the view then frames the
    /// shadow the model casts on it under the camera's key light too
    /// ([`Camera::key_light_direction`]). `None`: no ground, the model alone.
    pub ground: Option<f32>,
    /// The direction towards the light whose shadow on the ground is framed (unit); `None`: the
    /// camera's key light.
    pub ground_light: Option<Vec3>,
}

impl ViewSpec {
    /// The default view for a model whose up axis is `up`: the front by the exporters' convention
    /// (see [`front_for_up`]), no orbit, 35 degree field of view, [`DEFAULT_FILL`].
    pub fn for_up(up: Vec3) -> Self {
        ViewSpec {
            up,
            front: front_for_up(up),
            orbit_deg: 0.0,
            fov_y_deg: 35.0,
            fill: DEFAULT_FILL,
            ground: None,
            ground_light: None,
        }
    }
}

/// The front of a model with up axis `up`, by the convention of the common exporters: a y-up
/// OBJ (Blender's default export: forward -Z, up Y) has its front facing +z; a z-up file (Blender's
/// own axes, CAD) has it facing -y, the side Blender's front view shows. Any other up: a
/// perpendicular made from +z or -y.
pub fn front_for_up(up: Vec3) -> Vec3 {
    let up = up.normalize_or_zero();
    let pick = if up.z.abs() > 0.9 { -Vec3::Y * up.z.signum() } else { Vec3::Z };
    (pick - pick.dot(up) * up).try_normalize().unwrap_or(Vec3::X)
}

/// Azimuth of the default three-quarter view from the front, degrees (towards the model's left,
/// the viewer's right).
pub const THREE_QUARTER_AZIMUTH_DEG: f32 = 30.0;
/// Elevation of the default view above the model's horizon, degrees.
pub const THREE_QUARTER_ELEVATION_DEG: f32 = 20.0;

impl Camera {
    /// A three-quarter view of `points` (a model's vertices): from the front `spec.front`
    /// turned [`THREE_QUARTER_AZIMUTH_DEG`] + `spec.orbit_deg` about `spec.up` and raised
    /// [`THREE_QUARTER_ELEVATION_DEG`], aimed and placed so the points' projection is centred
    /// and spans `spec.fill` of the frame in the tighter direction. The centre starts at the
    /// centre of `bounds`; two passes re-aim at the projected extent's centre. With a ground
    /// (`spec.ground`) the points' shadows on it ([`shadow_points`]) are framed with them. `None`
    /// for no points or a degenerate spec.
    pub fn three_quarter(
        points: &[Vec3],
        bounds: (Vec3, Vec3),
        spec: &ViewSpec,
        aspect: f32,
    ) -> Option<Camera> {
        let up = spec.up.try_normalize()?;
        let front = (spec.front - spec.front.dot(up) * up).try_normalize()?;
        if points.is_empty() || !(spec.fill > 0.0 && spec.fill <= 1.0) || !(aspect > 0.0) {
            return None;
        }
        // Compute the view direction (from the model towards the eye).
        let az = (THREE_QUARTER_AZIMUTH_DEG + spec.orbit_deg).to_radians();
        let el = THREE_QUARTER_ELEVATION_DEG.to_radians();
        let side = up.cross(front); // the model's left, the viewer's right
        let horiz = az.cos() * front + az.sin() * side;
        let back = (el.cos() * horiz + el.sin() * up).normalize();
        let right = (-back).cross(up).try_normalize()?;
        let cup = right.cross(-back);
        let ty = (0.5 * spec.fov_y_deg).to_radians().tan();
        let tx = ty * aspect;
        if !(ty > 0.0 && ty.is_finite()) {
            return None;
        }
        // Compute what to frame: the points, and their shadows on the ground if there is one.
        let mut framed = points.to_vec();
        if let Some(h) = spec.ground {
            let key = Camera { eye: back, look_at: Vec3::ZERO, up, fov_y_deg: spec.fov_y_deg };
            let light = spec
                .ground_light
                .and_then(|l| l.try_normalize())
                .unwrap_or_else(|| key.key_light_direction());
            framed.extend(shadow_points(points, up, h, light));
        }
        let points = &framed[..];
        // Compute the distance that fits every point, then re-centre on the projected extent.
        let mut center = 0.5 * (bounds.0 + bounds.1);
        let mut dist = 0.0f32;
        for _pass in 0..3 {
            dist = points.iter().fold(0.0f32, |d, p| {
                let q = *p - center;
                let z = q.dot(back);
                d.max(z + q.dot(right).abs() / (spec.fill * tx)).max(z + q.dot(cup).abs() / (spec.fill * ty))
            });
            let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
            for p in points {
                let q = *p - center;
                let depth = (dist - q.dot(back)).max(1e-12);
                let s = Vec3::new(q.dot(right) / depth, q.dot(cup) / depth, 0.0);
                lo = lo.min(s);
                hi = hi.max(s);
            }
            let mid = 0.5 * (lo + hi);
            center += dist * (mid.x * right + mid.y * cup);
        }
        let dist = dist.max(1e-6);
        Some(Camera { eye: center + dist * back, look_at: center, up, fov_y_deg: spec.fov_y_deg })
    }

    /// The key light's direction for this camera (unit, towards the light): from the upper left
    /// of the camera and in front of the model, so the side facing the camera is the lit side.
    pub fn key_light_direction(&self) -> Vec3 {
        let back = (self.eye - self.look_at).normalize_or_zero();
        let right = (-back).cross(self.up).normalize_or_zero();
        let up = right.cross(-back);
        (-0.5 * right + 0.7 * up + 0.6 * back).try_normalize().unwrap_or(back)
    }
}

/// Where the points cast their shadows on the plane `p · up = h` under a directional light
/// from `light` (unit, towards the light): each point moved along the light onto the plane.
/// Nothing for a light within 3 degrees of the horizon (its shadows run off to infinity).
pub fn shadow_points(points: &[Vec3], up: Vec3, h: f32, light: Vec3) -> Vec<Vec3> {
    let rise = light.dot(up);
    if !(rise > 0.05) {
        return Vec::new();
    }
    points.iter().map(|p| *p - ((p.dot(up) - h) / rise) * light).filter(|s| s.is_finite()).collect()
}

/// Choices of the default view beyond the camera settings ([`default_view_with`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DefaultViewOptions {
    /// The scene stands on a ground plane ([`crate::Ground`]): frame the shadow the model casts
    /// on it under the camera's key light too.
    pub ground: bool,
    /// The ground's height along the up axis; `None`: the bottom of the scene's bounds, where
    /// the ground is placed by default.
    pub ground_height: Option<f32>,
    /// The direction towards the light whose shadow is framed; `None`: the key light that
    /// follows the camera ([`Camera::key_light_direction`]).
    pub ground_light: Option<Vec3>,
    /// Turn the front towards a face its object names mark, or so a handle shows
    /// ([`named_part_front`], [`handle_front`]); `false`: the exporters' convention and the head
    /// end of long models only (the rule before).
    pub front_cues: bool,
}

impl Default for DefaultViewOptions {
    fn default() -> Self {
        DefaultViewOptions { ground: false, ground_height: None, ground_light: None, front_cues: true }
    }
}

/// The default camera for a loaded scene: the up axis given or detected ([`detect_up`]), the
/// three-quarter view of its vertices ([`Camera::three_quarter`]) turned by `orbit_deg`, with
/// field of view `fov_y_deg` (35 degrees by default), no ground, with front cues. Returns the
/// detection too (for reporting).
pub fn default_view(
    scene: &phongrt::scene::Model,
    up: Option<Vec3>,
    orbit_deg: f32,
    fov_y_deg: Option<f32>,
    aspect: f32,
) -> (Camera, UpDetection) {
    default_view_with(scene, up, orbit_deg, fov_y_deg, aspect, DefaultViewOptions::default())
}

/// As [`default_view`], with the choices of `options`: on a ground, the view frames the model
/// and its shadow together.
pub fn default_view_with(
    scene: &phongrt::scene::Model,
    up: Option<Vec3>,
    orbit_deg: f32,
    fov_y_deg: Option<f32>,
    aspect: f32,
    options: DefaultViewOptions,
) -> (Camera, UpDetection) {
    // Compute the up axis and front, detected unless the up axis is given.
    let mut detection = detect_up(
        scene.meshes.iter().flat_map(|m| m.indices.iter().map(|t| t.map(|i| m.positions[i as usize]))),
    );
    if options.front_cues && detection.flat_axis.is_none() {
        if let Some(front) = named_part_front(scene, detection.up).or_else(|| handle_front(scene, detection))
        {
            detection.front = front;
        }
    }
    let mut spec = match up {
        Some(up) => ViewSpec::for_up(up),
        None => ViewSpec { front: detection.front, ..ViewSpec::for_up(detection.up) },
    };
    spec.orbit_deg = orbit_deg;
    if let Some(f) = fov_y_deg {
        spec.fov_y_deg = f;
    }
    // Compute the ground's height: the bounds' lowest corner along up, as the ground is placed.
    let (lo, hi) = scene.bounds();
    spec.ground =
        options.ground.then(|| options.ground_height.unwrap_or_else(|| lowest_corner(lo, hi, spec.up)));
    spec.ground_light = options.ground_light;
    let points: Vec<Vec3> = scene.meshes.iter().flat_map(|m| m.positions.iter().copied()).collect();
    let camera = Camera::three_quarter(&points, (lo, hi), &spec, aspect)
        .unwrap_or_else(|| Camera { up: spec.up, ..Camera::frame_bounds(lo, hi, aspect) });
    (camera, detection)
}

/// The lowest of the box's eight corners along `up` (unit).
fn lowest_corner(lo: Vec3, hi: Vec3, up: Vec3) -> f32 {
    let up = up.normalize_or_zero();
    (0..8)
        .map(|k| {
            let c = Vec3::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            );
            c.dot(up)
        })
        .fold(f32::INFINITY, f32::min)
}

/// Object names that mark a model's face: its front is the side they are on.
const FACE_PART_NAMES: [&str; 6] = ["head", "face", "eye", "kopf", "auge", "tete"];

/// The front of a model whose objects name its face (`head`, `face`, `eye`, `kopf`, `auge`,
/// `tete`, in any case, as the
/// spider's "Kopf" and "Auge"): the horizontal direction from the centre of the bounds to the
/// centroid of those objects' vertices, when it is more than 10% of the horizontal extent off
/// the centre (a model that is all head, like `african_head`'s object "head", keeps its front).
pub fn named_part_front(scene: &phongrt::scene::Model, up: Vec3) -> Option<Vec3> {
    let is_face = |name: &str| {
        let n = name.to_ascii_lowercase();
        FACE_PART_NAMES.iter().any(|k| n.contains(k))
    };
    let (sum, count) = scene
        .meshes
        .iter()
        .filter(|m| is_face(&m.name))
        .flat_map(|m| m.positions.iter())
        .fold((Vec3::ZERO, 0usize), |(s, n), p| (s + *p, n + 1));
    let (lo, hi) = scene.bounds();
    let off = sum / count.max(1) as f32 - 0.5 * (lo + hi);
    let off = off - off.dot(up) * up;
    let ext = (hi - lo) - (hi - lo).dot(up).abs() * up.abs();
    (count > 0 && off.length() > 0.1 * ext.length()).then(|| off.normalize())
}

/// The front of a prop with a handle (the mug): a compact model (not long along a horizontal
/// axis) whose bounds' centre lies more than 10% of the extent off its surface's area centroid
/// along a horizontal axis has a part sticking out that way. The front is turned a quarter from
/// it, so the default three-quarter view (30 degrees towards the model's left) sees the handle at
/// 60 degrees, standing out to the right. `None` when the front already comes from the model's
/// length ([`detect_up`]'s head end) or nothing sticks out.
pub fn handle_front(scene: &phongrt::scene::Model, detection: UpDetection) -> Option<Vec3> {
    let up = detection.up;
    if (detection.front - front_for_up(up)).length() > 1e-6 {
        return None;
    }
    // Compute the area centroid of the surface.
    let (mut area, mut centroid) = (0.0f64, glam::DVec3::ZERO);
    for m in &scene.meshes {
        for t in &m.indices {
            let [a, b, c] = t.map(|i| m.positions[i as usize].as_dvec3());
            let w = 0.5 * (b - a).cross(c - a).length();
            area += w;
            centroid += w * (a + b + c) / 3.0;
        }
    }
    let centroid = (centroid / area.max(f64::MIN_POSITIVE)).as_vec3();
    let (lo, hi) = scene.bounds();
    let (off, ext) = (0.5 * (lo + hi) - centroid, hi - lo);
    // The horizontal axis along which the bounds' centre is farthest off, relative to the extent.
    let axes = [Vec3::X, Vec3::Y, Vec3::Z].into_iter().filter(|a| a.dot(up).abs() < 0.5);
    let (axis, rel) = axes
        .map(|a| (a * off.dot(a).signum(), off.dot(a).abs() / ext.dot(a).max(f32::MIN_POSITIVE)))
        .max_by(|x, y| x.1.total_cmp(&y.1))?;
    (rel > 0.1).then(|| axis.cross(up).normalize())
}

/// The up axis and front [`detect_up`] chose, and the evidence.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpDetection {
    /// The up axis chosen: +z when the model stands on a base facing down along z (more than
    /// twice the y base, and above 0.5% of the area), else +y; for a flat model, +z if it is thin
    /// along y, else +y.
    pub up: Vec3,
    /// The front (see [`front_for_up`]; for a flat model, the side its faces point to).
    pub front: Vec3,
    /// Area of the base facing down along y, as a fraction of the total area: faces within 18
    /// degrees of the y axis at the bottom of the bounds (either winding).
    pub base_y: f32,
    /// The same along z.
    pub base_z: f32,
    /// The axis a flat model (thinner than 1/1000 of its diagonal) lies across, if any.
    pub flat_axis: Option<usize>,
}

impl std::fmt::Display for UpDetection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let axis = |v: Vec3| {
            let a = v.abs();
            let k = if a.x >= a.y && a.x >= a.z {
                0
            } else if a.y >= a.z {
                1
            } else {
                2
            };
            format!("{}{}", if v[k] < 0.0 { "-" } else { "+" }, ["x", "y", "z"][k])
        };
        match self.flat_axis {
            Some(k) => write!(
                f,
                "up {}, front {} (a flat model across {}: seen from the side its faces point to)",
                axis(self.up),
                axis(self.front),
                ["x", "y", "z"][k]
            ),
            None => write!(
                f,
                "up {}, front {} (base {:.1}% of the area on z, {:.1}% on y)",
                axis(self.up),
                axis(self.front),
                100.0 * self.base_z,
                100.0 * self.base_y
            ),
        }
    }
}

/// Detect whether a model stands on +y or +z. Most OBJ files are y-up (the format's de facto
/// convention), but CAD and Blender-native files are z-up. The cue is the base a model stands on:
/// the area of triangles facing along the axis (normal within 18 degrees of it) whose three corners
/// all lie within 0.2% of the bounds' diagonal of the bounds' minimum along it: a flat face at
/// the very bottom (a curved wall touching the bottom contributes only slivers). A z-up model (a
/// mug, a machine part) has a large flat base low on z; a y-up one low on y, or none (an animal
/// on its legs). `+z` is chosen only when its
/// base is more than twice y's and at least 0.5% of the total area; else `+y`. A flat model
/// (thinner than 1/1000 of its diagonal along an axis) is seen face-on instead: its front is the
/// side its area-weighted normals point to, its up +y (or +z when it lies across y).
///
/// The front is the exporters' convention ([`front_for_up`]) except for a model that is long
/// along a horizontal axis (at least 1.3 times its other horizontal extent): an animal or a
/// vehicle, whose front is the end where its highest parts are.
pub fn detect_up(triangles: impl Iterator<Item = [Vec3; 3]> + Clone) -> UpDetection {
    let triangles_for_front = triangles.clone();
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for t in triangles.clone() {
        for p in t {
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    let ext = (hi - lo).max(Vec3::ZERO);
    let diag = ext.length();
    let cos18 = 18f32.to_radians().cos();
    let (mut total, mut by, mut bz) = (0.0f64, 0.0f64, 0.0f64);
    let mut normal_sum = Vec3::ZERO;
    for [a, b, c] in triangles {
        let n2 = (b - a).cross(c - a);
        let area = 0.5 * n2.length();
        if !(area > 0.0) {
            continue;
        }
        let n = n2 / (2.0 * area);
        let low = |k: usize| [a, b, c].iter().all(|p| p[k] - lo[k] <= 2e-3 * diag);
        total += area as f64;
        normal_sum += 0.5 * n2;
        // Either winding counts: meshes are not always oriented outwards.
        if n.y.abs() > cos18 && low(1) {
            by += area as f64;
        }
        if n.z.abs() > cos18 && low(2) {
            bz += area as f64;
        }
    }
    let total = total.max(f64::MIN_POSITIVE);
    let (base_y, base_z) = ((by / total) as f32, (bz / total) as f32);
    let flat_axis = (0..3).find(|&k| ext[k] <= 1e-3 * diag && diag > 0.0);
    if let Some(k) = flat_axis {
        let mut front = Vec3::ZERO;
        front[k] = if normal_sum[k] < 0.0 { -1.0 } else { 1.0 };
        let up = if k == 1 { Vec3::Z } else { Vec3::Y };
        return UpDetection { up, front, base_y, base_z, flat_axis };
    }
    let up = if base_z > 2.0 * base_y && base_z > 0.005 { Vec3::Z } else { Vec3::Y };
    let front = head_end(triangles_for_front, lo, hi, up).unwrap_or_else(|| front_for_up(up));
    UpDetection { up, front, base_y, base_z, flat_axis }
}

/// For a model long along one horizontal axis (1.3 times the other horizontal extent or more),
/// the end of that axis where its top is: the centroid of the corners in the highest 10% of the
/// height lies more than 10% of the length from the middle (a quadruped's head and horns, a duck's
/// head). `None` for a compact or symmetric model.
fn head_end(triangles: impl Iterator<Item = [Vec3; 3]>, lo: Vec3, hi: Vec3, up: Vec3) -> Option<Vec3> {
    let (ax, bx) = if up.z.abs() > 0.5 { (Vec3::X, Vec3::Y) } else { (Vec3::X, Vec3::Z) };
    let ext = hi - lo;
    let (la, lb) = (ext.dot(ax), ext.dot(bx));
    let (long, len) = if la >= 1.3 * lb {
        (ax, la)
    } else if lb >= 1.3 * la {
        (bx, lb)
    } else {
        return None;
    };
    let (top, height) = (hi.dot(up), ext.dot(up));
    let mid = (0.5 * (lo + hi)).dot(long);
    let (mut sum, mut n) = (0.0f64, 0u64);
    for p in triangles.flatten() {
        if p.dot(up) >= top - 0.1 * height {
            sum += (p.dot(long) - mid) as f64;
            n += 1;
        }
    }
    let offset = (sum / n.max(1) as f64) as f32;
    (n > 0 && offset.abs() > 0.1 * len).then(|| long * offset.signum())
}
