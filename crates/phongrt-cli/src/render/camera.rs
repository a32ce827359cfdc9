//! A pinhole camera, framed automatically on scene bounds unless told otherwise.

use glam::Vec3;

/// A pinhole camera. `fov_y_deg` is the vertical field of view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub eye: Vec3,
    pub look_at: Vec3,
    pub up: Vec3,
    pub fov_y_deg: f32,
}

/// Per-image camera basis, computed once.
#[derive(Clone, Copy, Debug)]
pub struct CameraFrame {
    pub eye: Vec3,
    /// Direction through the image centre (unit).
    pub forward: Vec3,
    /// Half-extent vectors of the image plane at distance 1.
    pub right: Vec3,
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
    #[error("eye and look_at are both {0:?}: the view direction is undefined")]
    EyeAtLookAt([f32; 3]),
    #[error("up {up:?} is zero or parallel to the view direction look_at - eye = {dir:?}")]
    UpParallel { up: [f32; 3], dir: [f32; 3] },
    #[error("fov {0} is not in (0, 180) degrees")]
    Fov(f32),
    #[error("eye {eye:?} or look_at {look_at:?} is not finite (scene bounds too large?)")]
    NonFinite { eye: [f32; 3], look_at: [f32; 3] },
}

impl Camera {
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
