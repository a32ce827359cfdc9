//! Phong tessellation patches and their ray intersectors (pure Rust, no FFI).
//!
//! ```
//! use glam::{DVec3, Vec3};
//! use phongrt::phong::{intersect, Method, Patch, V3};
//!
//! // A triangle in z = 0 whose vertex normals lean outwards: the patch bulges towards +z.
//! let p = [DVec3::new(0.0, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0), DVec3::new(0.0, 1.0, 0.0)];
//! let n = [DVec3::new(-1.0, -1.0, 2.0), DVec3::new(1.0, -0.2, 2.0), DVec3::new(-0.2, 1.0, 2.0)];
//! let patch: Patch<f32> = Patch::new(p, n, 1.0);
//! let org = V3::from(Vec3::new(0.3, 0.3, 1.0));
//! let dir = V3::from(Vec3::new(0.0, 0.0, -1.0));
//! let hit = intersect(&patch, org, dir, 0.0, f32::INFINITY, Method::Certified).unwrap();
//! assert!(hit.t < 1.0); // in front of the flat triangle
//! let point = patch.eval(hit.u, hit.v);
//! assert!((point.z - (1.0 - hit.t)).abs() < 1e-5);
//! ```

pub mod accuracy;
pub mod intersect;
pub mod patch;
pub mod real;
pub mod reference;

pub use intersect::{intersect, solve_cubic, solve_quadratic, Method, PatchHit};
pub use patch::{control_points, Patch};
pub use real::{Real, V3};
