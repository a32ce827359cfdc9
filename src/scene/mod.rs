//! Scene input: OBJ/MTL loading, welding, vertex normals, mesh connectivity, generated meshes.
//!
//! Loading turns an OBJ file into [`Mesh`]es, one per object/group and material, each with
//! per-vertex positions and unit normals. Positions are welded (tolerance relative to the model
//! size) independently of how the file indexes normals, so that neighbouring triangles share
//! vertices wherever they share a position and a normal; a position with several normals becomes
//! several vertices, and the edge between such vertices is a *crease* ([`EdgeKind`]).

mod build;
mod error;
mod generate;
mod load;
mod model;
pub mod mtl;
mod normals;
pub mod obj;
mod read;
mod warnings;
mod write;

pub use error::{cut_token, SceneError};
pub use generate::uv_sphere;
pub use load::{load_obj, load_obj_text};
pub use model::{
    LoadOptions, LoadStats, Material, Mesh, Model, NormalsSource, SMALL_FACE_CREASE_DEG, SMALL_FACE_FRACTION,
};
pub use read::{read_regular_file, ReadFailure, MAX_MTL_BYTES, MAX_OBJ_BYTES};
pub use warnings::FoldedWarnings;
pub use write::write_obj;

pub use crate::mesh::{classify_edges, EdgeKind};

/// The former name of [`Model`] (a loaded OBJ file), beside [`crate::embree::Scene`] (the Embree
/// scene builder): kept for one release.
///
/// ```
/// #[allow(deprecated)]
/// let old: phongrt::scene::Scene = phongrt::scene::Model::from_mesh(phongrt::scene::uv_sphere(8, 4, 1.0));
/// assert_eq!(old.meshes.len(), 1);
/// ```
#[deprecated(note = "renamed to `Model` (`phongrt::embree::Scene` is the Embree scene)")]
pub type Scene = Model;
