//! Scene input: OBJ/MTL loading, welding, vertex normals, generated meshes.
