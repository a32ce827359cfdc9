//! Embree 4: bindings generated against the installed headers, RAII wrappers, and (in
//! [`phong_geometry`]) Phong patches as user geometry. All of the crate's `unsafe` lives here.
pub mod device;
pub mod scene;

pub use device::{
    header_version, set_flush_denormals, thread_pool_builder, Device, EmbreeError, ErrorCode,
    MAX_INSTANCE_LEVEL_COUNT,
};
pub use scene::{
    new_rayhit, CommittedScene, GeometryOptions, Hit, IntersectArgs, OccludedArgs, QueryContext, Ray, Scene,
    PACKET8,
};
mod panic;
pub mod user_geometry;
#[allow(deprecated)]
pub use user_geometry::UserGeometryOptions;
pub use user_geometry::{
    user_hits_out_of_range, Blocker, LaneOrigins, OriginPrim, PacketRays, PrimHit, RayOrigin, UserPrimitives,
    UserTriangles, MAX_PACKET,
};
#[cfg(feature = "capi")]
pub mod capi;
pub mod phong_geometry;
pub use phong_geometry::{attach_phong_raw, RawPhongGeometry};
// The mesh lives in crate::phong::mesh; these names stay here too while callers move.
pub use crate::phong::mesh::{patch_prim_hit, PatchTest, PhongMesh, PhongMeshBuilder, PhongMeshError};
