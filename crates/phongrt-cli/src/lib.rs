//! The `phongrt` command's pieces: the `phongrt bench` and `phongrt profile` measurements. The
//! renderer is the [`phongrt_render`] crate, the curved primitive itself the [`phongrt`] library.

// Comparisons written `!(x > 0.0)` are deliberate throughout: they are true for NaN, which is
// how bad input is turned away without a separate NaN test.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::nonminimal_bool)]

pub mod bench;
pub mod profile;
