//! Phong tessellation patches and their ray intersectors (pure Rust, no FFI).
