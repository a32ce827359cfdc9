//! phongrt: direct ray tracing of Phong Tessellation (Boubekeur & Alexa 2008) as an
//! Embree 4 user geometry.
//!
//! * [`phong`]: the patch and its intersectors, pure Rust, no FFI.
//! * [`embree`]: the RAII wrappers and the user-geometry callbacks. All `unsafe` code lives here.
//! * [`mesh`]: mesh preparation on plain arrays: welding, edge classes, straight creases (what
//!   [`embree::PhongMesh::new`] does to the caller's arrays).
//! * [`scene`]: OBJ/MTL loading (welding, normals, edge classes, through [`mesh`]), generated
//!   meshes.
//! * [`rng`]: SplitMix64, the deterministic generator of the accuracy cases and the renderer.
//! * [`sys`]: the raw Embree 4 bindings, for code that drives its own `RTCScene` (as git2 exposes
//!   `raw`).
//!
//! The renderer and the `phongrt` command are the `phongrt-cli` crate; the C API's shared and
//! static libraries are the `phongrt-capi` crate (its functions are this crate's `capi` feature).

// Comparisons written `!(x > 0.0)` are deliberate throughout: they are true for NaN, which is
// how bad input is turned away without a separate NaN test.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::nonminimal_bool)]
// Every unsafe operation sits in an `unsafe` block with a `// SAFETY:` comment naming the Embree
// (or Rust) guarantee it relies on, also inside `unsafe fn`.
#![deny(unsafe_op_in_unsafe_fn)]
#![warn(clippy::undocumented_unsafe_blocks)]
#![warn(missing_docs)]

pub mod embree;
pub mod mesh;
pub mod phong;
pub mod rng;
pub mod scene;
pub mod sys;
/// One error for the whole library, for callers that `?` across its parts: device, scene and
/// geometry errors ([`embree::EmbreeError`]), refused meshes ([`phong::mesh::PhongMeshError`])
/// and scenes that cannot load ([`scene::SceneError`]). Each part's own error converts into it
/// with `?`, and displays as that error does.
///
/// ```
/// use phongrt::embree::{CommittedScene, Device, PhongMesh, Scene};
/// fn sphere() -> Result<CommittedScene, phongrt::Error> {
///     let device = Device::new()?; // EmbreeError
///     let m = phongrt::scene::uv_sphere(12, 6, 1.0);
///     let mesh = PhongMesh::builder(&m.positions, &m.normals, &m.indices).build()?; // PhongMeshError
///     let mut scene = Scene::new(&device)?;
///     scene.attach_phong(mesh, Default::default())?;
///     Ok(scene.commit()?)
/// }
/// assert!(sphere().is_ok());
/// let refused = PhongMesh::builder(&[], &[glam::Vec3::Z], &[]).build().unwrap_err();
/// let e = phongrt::Error::from(refused);
/// assert!(matches!(e, phongrt::Error::Mesh(_)));
/// assert_eq!(e.to_string(), "1 normals for 0 positions (need one per vertex)");
/// ```
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// An Embree error, or a refusal of the Embree layer.
    #[error(transparent)]
    Embree(#[from] embree::EmbreeError),
    /// A Phong mesh was refused.
    #[error(transparent)]
    Mesh(#[from] phong::mesh::PhongMeshError),
    /// A scene file could not be loaded.
    #[error(transparent)]
    Scene(#[from] scene::SceneError),
}

/// The glam this crate's API uses (`Vec3`, `DVec3`): depend on it through here to get the same
/// version.
pub use glam;

/// The README's Rust examples, compiled and run as doctests (the one that needs a mesh in
/// scope is marked `ignore`; `crates/phongrt-render/tests/phong_embree.rs` runs the same calls).
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
