//! Helpers shared by the render crate's tests (and, for `rgl`, its BSDF benchmark).
pub mod rgl;

pub(crate) use crate::measured::warp::Warp2D;
