//! The `phongrt` command's pieces: a thin renderer on top of Embree (a world of flat or Phong
//! objects, camera, lights, scene files, images) and the `phongrt bench` measurements. The
//! curved primitive itself is the [`phongrt`] library.

// Comparisons written `!(x > 0.0)` are deliberate throughout: they are true for NaN, which is
// how bad input is turned away without a separate NaN test.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::nonminimal_bool)]

pub mod bench;
pub mod profile;
pub mod render;
