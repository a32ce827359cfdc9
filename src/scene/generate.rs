//! Generated meshes.

use glam::Vec3;

use super::{Mesh, NormalsSource};

/// A UV sphere of `segments` × `rings` with exact normals (poles are single vertices).
pub fn uv_sphere(segments: u32, rings: u32, radius: f32) -> Mesh {
    let (segments, rings) = (segments.max(3), rings.max(2));
    let mut positions = vec![Vec3::Y * radius];
    let mut normals = vec![Vec3::Y];
    for r in 1..rings {
        let th = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..segments {
            let ph = std::f32::consts::TAU * s as f32 / segments as f32;
            let n = Vec3::new(th.sin() * ph.cos(), th.cos(), -th.sin() * ph.sin());
            positions.push(n * radius);
            normals.push(n);
        }
    }
    positions.push(-Vec3::Y * radius);
    normals.push(-Vec3::Y);
    let ring = |r: u32, s: u32| 1 + (r - 1) * segments + s % segments;
    let last = positions.len() as u32 - 1;
    let mut indices = Vec::new();
    for s in 0..segments {
        indices.push([0, ring(1, s), ring(1, s + 1)]);
        for r in 1..rings - 1 {
            indices.push([ring(r, s), ring(r + 1, s), ring(r + 1, s + 1)]);
            indices.push([ring(r, s), ring(r + 1, s + 1), ring(r, s + 1)]);
        }
        indices.push([ring(rings - 1, s), last, ring(rings - 1, s + 1)]);
    }
    let mut mesh = Mesh::from_triangles("sphere", positions, normals, indices);
    mesh.normals_source = NormalsSource::Computed;
    mesh
}
