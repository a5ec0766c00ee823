//! The render crate's tests that need more than one module: what the builder makes of pbrt-v4 text, furnace tests with closed-form answers, integrators
//! against each other and against closed forms, and pbrt-v4's measured BRDF against an analytic GGX.

mod builder;
mod clamp;
mod coating;
mod furnace;
mod integrators;
mod layered_geometry;
mod measured;
mod media_rule;
mod regularize;
pub(crate) mod support;
