//! Embree 4: bindings, RAII wrappers, user-geometry callbacks.
pub mod sys;
