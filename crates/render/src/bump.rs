//! Bump and normal mapping (pbrt-v4 §10.5.3 and `NormalMap`): a material's `"texture displacement"` or
//! `"string normalmap"` tilts the shading frame at a hit before the BSDF is built, so every integrator sees it. The
//! geometric normal, and with it which side of the surface a direction is on, does not change.

use std::sync::Arc;

use glam::{Vec2, Vec3};

use crate::scene::SurfaceHit;
use crate::texture::{FloatTexture, ImageTexture, RgbImage, TextureEvalContext};

/// The step in u and v of bump mapping's finite differences where the hit has no footprint (pbrt-v4's fallback for
/// rays without differentials).
pub const BUMP_DELTA: f32 = 0.0005;

/// The shading geometry at a surface point that bump and normal mapping start from and change.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadingGeometry {
    /// Render-space point.
    pub p: Vec3,
    /// Geometric normal (unit).
    pub n: Vec3,
    /// Surface (u, v).
    pub uv: Vec2,
    /// Shading normal (unit, on the side of `n`).
    pub ns: Vec3,
    /// Shading ∂p/∂u (not normalised).
    pub dpdu: Vec3,
    /// Shading ∂p/∂v (not normalised).
    pub dpdv: Vec3,
    /// The surface's own ∂p/∂v, from its texture coordinates: the side of increasing v, which the shading partials
    /// of a mesh with vertex normals do not keep (pbrt-v4 makes them ns × ∂p/∂u), and which glTF's bitangent follows.
    pub surface_dpdv: Vec3,
}

impl ShadingGeometry {
    /// The shading geometry of a hit.
    pub fn of(hit: &SurfaceHit) -> Self {
        Self {
            p: hit.p,
            n: hit.n,
            uv: hit.uv,
            ns: hit.ns,
            dpdu: hit.shading_dpdu,
            dpdv: hit.shading_dpdv,
            surface_dpdv: hit.surface_dpdv,
        }
    }

    /// The geometry with shading partials `dpdu`, `dpdv` and the normal they define: the unit ∂p/∂u × ∂p/∂v turned
    /// to the side of the geometric normal (pbrt-v4's `SetShadingGeometry`, where the geometric normal's orientation
    /// wins). Unchanged if the partials are degenerate.
    pub fn with_partials(&self, dpdu: Vec3, dpdv: Vec3) -> Self {
        let Some(ns) = dpdu.cross(dpdv).try_normalize() else { return *self };
        if !(dpdu.is_finite() && dpdv.is_finite()) {
            return *self;
        }
        let ns = if ns.dot(self.n) < 0.0 { -ns } else { ns };
        Self { ns, dpdu, dpdv, ..*self }
    }
}

/// Bump mapping (Blinn 1978; pbrt-v4's `BumpMap`): the surface displaced along the shading normal by
/// `displacement`, differentiated by forward differences: ∂p′/∂u ≈ ∂p/∂u + (d(u + Δu) − d(u))/Δu · ns, likewise for
/// v, with Δu = ½(|∂u/∂x| + |∂u/∂y|) half the footprint of `ctx` in u (so an image's bumps are seen at the scale its
/// MIP filter reads them; [`BUMP_DELTA`] where there is no footprint) and the displacement evaluated with the
/// footprint of `ctx` at the shifted points. pbrt-v4 also adds d·∂n/∂u, which Prismatic's hits do not carry; it
/// only matters where the displacement is large against the radius of curvature. Returns the new shading partials.
pub fn bump(displacement: &FloatTexture, g: &ShadingGeometry, ctx: &TextureEvalContext) -> (Vec3, Vec3) {
    let [dudx, dudy, dvdx, dvdy] = ctx.duv;
    let step = |a: f32, b: f32| match 0.5 * (a.abs() + b.abs()) {
        s if s > 0.0 && s.is_finite() => s,
        _ => BUMP_DELTA,
    };
    let here = TextureEvalContext { p: g.p, n: g.n, uv: g.uv, ..*ctx };
    let d = displacement.eval(&here);
    let du = step(dudx, dudy);
    let shifted_u = TextureEvalContext { p: g.p + du * g.dpdu, uv: g.uv + Vec2::new(du, 0.0), ..here };
    let d_u = displacement.eval(&shifted_u);
    let dv = step(dvdx, dvdy);
    let shifted_v = TextureEvalContext { p: g.p + dv * g.dpdv, uv: g.uv + Vec2::new(0.0, dv), ..here };
    let d_v = displacement.eval(&shifted_v);
    (g.dpdu + ((d_u - d) / du) * g.ns, g.dpdv + ((d_v - d) / dv) * g.ns)
}

/// Normal mapping (pbrt-v4's `NormalMap`): the image's RGB at (u, 1 − v), read linearly, bilinearly interpolated
/// and repeating, is 2·rgb − 1 in the frame (x = ∂p/∂u normalised, y = ns × x, z = ns). Returns shading partials
/// perpendicular to that normal with the old partials' lengths.
pub fn normal_map(image: &RgbImage, g: &ShadingGeometry) -> (Vec3, Vec3) {
    let rgb = image.bilerp(g.uv);
    let Some(local) = Vec3::new(2.0 * rgb[0] - 1.0, 2.0 * rgb[1] - 1.0, 2.0 * rgb[2] - 1.0).try_normalize() else {
        return (g.dpdu, g.dpdv);
    };
    let Some(x) = g.dpdu.try_normalize() else { return (g.dpdu, g.dpdv) };
    let y = g.ns.cross(x);
    tilt(local.x * x + local.y * y + local.z * g.ns, g)
}

/// Normal mapping as glTF 2.0 defines it (§3.9.3, `normalTexture`): the image's RGB, looked up through the
/// texture's mapping and filter, is 2·rgb − 1 with x and y multiplied by `scale`, in the frame x = ∂p/∂u
/// normalised, y = ±ns × x on the side of the surface's ∂p/∂v (the bitangent's sign, which MikkTSpace stores as the
/// tangent's w, follows from the texture coordinates, so mirrored coordinates keep their bumps), z = ns. Returns shading
/// partials perpendicular to that normal with the old partials' lengths.
pub fn normal_map_texture(
    tex: &ImageTexture,
    scale: f32,
    g: &ShadingGeometry,
    ctx: &TextureEvalContext,
) -> (Vec3, Vec3) {
    let at = TextureEvalContext { p: g.p, n: g.n, uv: g.uv, ..*ctx };
    let rgb = tex.rgb(&at);
    let tangent = Vec3::new(scale * (2.0 * rgb[0] - 1.0), scale * (2.0 * rgb[1] - 1.0), 2.0 * rgb[2] - 1.0);
    let Some(local) = tangent.try_normalize() else { return (g.dpdu, g.dpdv) };
    let Some(x) = g.dpdu.try_normalize() else { return (g.dpdu, g.dpdv) };
    let y = g.ns.cross(x);
    let y = if y.dot(g.surface_dpdv) < 0.0 { -y } else { y };
    tilt(local.x * x + local.y * y + local.z * g.ns, g)
}

/// Shading partials perpendicular to the new normal `ns` with the lengths of `g`'s partials (Gram–Schmidt: ∂p/∂u
/// made perpendicular to `ns`, then ∂p/∂v completing the frame); `g`'s own where that degenerates.
fn tilt(ns: Vec3, g: &ShadingGeometry) -> (Vec3, Vec3) {
    let Some(ns) = ns.try_normalize() else { return (g.dpdu, g.dpdv) };
    let (ulen, vlen) = (g.dpdu.length(), g.dpdv.length());
    let Some(dpdu) = (g.dpdu - ns * ns.dot(g.dpdu)).try_normalize() else { return (g.dpdu, g.dpdv) };
    let dpdv = ns.cross(dpdu).normalize_or_zero();
    (dpdu * ulen, dpdv * vlen)
}

/// How a material tilts the shading normal.
#[derive(Clone, Debug)]
pub enum NormalPerturbation {
    /// A displacement texture (`"texture displacement"`, or a constant `"float displacement"`).
    Bump(FloatTexture),
    /// A tangent-space normal map (`"string normalmap"`), linear RGB.
    NormalMap(Arc<RgbImage>),
    /// A tangent-space normal map read through an image texture, as glTF's `normalTexture` (`"texture normalmap"`
    /// naming an `imagemap`, with `"float normalscale"`).
    NormalTexture {
        /// The image map (linear).
        tex: Box<ImageTexture>,
        /// glTF's `normalTexture.scale`: the factor of the tangent-plane components.
        scale: f32,
    },
}

impl NormalPerturbation {
    /// The shading geometry after the perturbation; `ctx` carries the hit's footprint for bump mapping.
    pub fn perturb(&self, g: &ShadingGeometry, ctx: &TextureEvalContext) -> ShadingGeometry {
        let (dpdu, dpdv) = match self {
            NormalPerturbation::Bump(d) => bump(d, g, ctx),
            NormalPerturbation::NormalMap(img) => normal_map(img, g),
            NormalPerturbation::NormalTexture { tex, scale } => normal_map_texture(tex, *scale, g, ctx),
        };
        g.with_partials(dpdu, dpdv)
    }

    /// Tilts the shading frame of `hit` (its shading normal, the tangent its BSDF frame starts from, and its shading
    /// partials); the geometric normal stays. `ctx` is the hit's texture context (with its footprint, if any).
    pub fn apply(&self, hit: &mut SurfaceHit, ctx: &TextureEvalContext) {
        let g = self.perturb(&ShadingGeometry::of(hit), ctx);
        hit.ns = g.ns;
        hit.dpdu = g.dpdu;
        hit.shading_dpdu = g.dpdu;
        hit.shading_dpdv = g.dpdv;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::texture::{TextureMapping2D, UvMapping};

    /// A flat patch in z = 0 with u along x and v along y (scaled by `su`, `sv`).
    fn plane(su: f32, sv: f32) -> ShadingGeometry {
        ShadingGeometry {
            p: Vec3::new(0.3, 0.2, 0.0),
            n: Vec3::Z,
            uv: Vec2::new(0.3 / su, 0.2 / sv),
            ns: Vec3::Z,
            dpdu: su * Vec3::X,
            dpdv: sv * Vec3::Y,
            surface_dpdv: sv * Vec3::Y,
        }
    }

    /// The texture context at `g` without a footprint.
    fn point(g: &ShadingGeometry) -> TextureEvalContext {
        TextureEvalContext::new(g.p, g.n, g.uv)
    }

    /// d(u, v) = a·u + b·v, as a bilerp texture over (u, v).
    fn ramp(a: f32, b: f32) -> FloatTexture {
        FloatTexture::Bilerp { map: Box::new(TextureMapping2D::Uv(UvMapping::default())), v: [0.0, b, a, a + b] }
    }

    #[test]
    fn bump_of_a_constant_is_no_bump() {
        for g in [plane(1.0, 1.0), plane(3.0, 0.5)] {
            for c in [0.0, 0.7, -2.0] {
                let out = NormalPerturbation::Bump(FloatTexture::Constant(c)).perturb(&g, &point(&g));
                assert!((out.ns - g.ns).length() < 1e-6, "{c}: {:?}", out.ns);
                assert_eq!((out.dpdu, out.dpdv), (g.dpdu, g.dpdv), "the partials are unchanged exactly");
            }
        }
        // On a tilted shading frame (a mesh with vertex normals) too: the normal stays ns, not the geometric one.
        let ns = Vec3::new(0.0, 0.6, 0.8);
        let dpdu = Vec3::X;
        let g = ShadingGeometry { ns, dpdu, dpdv: ns.cross(dpdu), ..plane(1.0, 1.0) };
        let out = NormalPerturbation::Bump(FloatTexture::Constant(0.3)).perturb(&g, &point(&g));
        assert!((out.ns - ns).length() < 1e-6);
    }

    #[test]
    fn bump_of_a_linear_ramp_tilts_the_normal_by_its_slope() {
        // Height h = k·u on a plane where u runs along x at su units per unit of u: the slope is k/su along x, the
        // bumped normal (−k/su, 0, 1)/√(1 + (k/su)²), tilted by atan(k/su) towards −x.
        for (k, su) in [(0.5f32, 1.0f32), (2.0, 4.0), (-1.5, 0.5)] {
            let g = plane(su, 1.0);
            let out = NormalPerturbation::Bump(ramp(k, 0.0)).perturb(&g, &point(&g));
            let slope = k / su;
            let expect = Vec3::new(-slope, 0.0, 1.0).normalize();
            assert!((out.ns - expect).length() < 2e-4, "k {k} su {su}: {:?} vs {expect:?}", out.ns);
            let angle = out.ns.dot(Vec3::Z).clamp(-1.0, 1.0).acos();
            assert!((angle - slope.abs().atan()).abs() < 2e-4, "{angle} vs {}", slope.abs().atan());
        }
        // A ramp in v tilts towards −y; both at once give (−a, −b, 1).
        let out = NormalPerturbation::Bump(ramp(0.3, -0.8)).perturb(&plane(1.0, 1.0), &point(&plane(1.0, 1.0)));
        assert!((out.ns - Vec3::new(-0.3, 0.8, 1.0).normalize()).length() < 2e-4, "{:?}", out.ns);
        // The geometric normal's side wins: a surface whose geometric normal is −z keeps its bumped normal there.
        let g = ShadingGeometry { n: -Vec3::Z, ns: -Vec3::Z, ..plane(1.0, 1.0) };
        let out = NormalPerturbation::Bump(ramp(0.5, 0.0)).perturb(&g, &point(&g));
        assert!(out.ns.z < 0.0 && (out.ns.z.abs() - 1.0 / 1.25f32.sqrt()).abs() < 2e-4, "{:?}", out.ns);
    }

    #[test]
    fn bump_steps_by_half_the_footprint_as_pbrt_v4_does() {
        // d = u² (a ramp times itself): the forward difference over Δ is 2u + Δ, so the tilt tells the step. pbrt-v4
        // steps Δu = ½(|∂u/∂x| + |∂u/∂y|), Δv likewise, and 0.0005 where the ray has no differentials.
        let square = FloatTexture::Scale { tex: Box::new(ramp(1.0, 0.0)), scale: Box::new(ramp(1.0, 0.0)) };
        let g = plane(1.0, 1.0);
        let u = g.uv.x;
        for (duv, step) in [([0.2f32, -0.1, 0.0, 0.0], 0.15f32), ([0.0; 4], BUMP_DELTA), ([0.02, 0.0, 0.5, 0.5], 0.01)]
        {
            let ctx = TextureEvalContext { duv, ..point(&g) };
            let out = NormalPerturbation::Bump(square.clone()).perturb(&g, &ctx);
            let slope = 2.0 * u + step;
            let expect = Vec3::new(-slope, 0.0, 1.0).normalize();
            assert!((out.ns - expect).length() < 2e-4, "step {step}: {:?} vs {expect:?}", out.ns);
        }
    }

    #[test]
    fn a_flat_normal_map_leaves_the_normal_to_8_bit_precision() {
        // (128, 128, 255) read linearly: 2·128/255 − 1 = 1/255 in x and y, a tilt of √2/255 ≈ 0.0055 rad.
        let v = 128.0 / 255.0;
        let img = RgbImage::new(1, 1, vec![[v, v, 1.0]]);
        for g in [plane(1.0, 1.0), plane(2.0, 5.0)] {
            let out = NormalPerturbation::NormalMap(Arc::new(img.clone())).perturb(&g, &point(&g));
            assert!((out.ns - g.ns).length() < 2.0 / 255.0, "{:?}", out.ns);
            assert!((out.dpdu.length() - g.dpdu.length()).abs() < 1e-5, "lengths kept");
            assert!((out.dpdv.length() - g.dpdv.length()).abs() < 1e-5);
            assert!(out.dpdu.dot(out.ns).abs() < 1e-6 && out.dpdv.dot(out.ns).abs() < 1e-6);
        }
        // An exactly flat map, (0.5, 0.5, 1), is no change at all; a tilted one turns the normal in the (∂p/∂u, ns ×
        // ∂p/∂u) frame: (1, 0.5, 1) is local (1, 0, 1)/√2, towards +u.
        let flat = RgbImage::new(1, 1, vec![[0.5, 0.5, 1.0]]);
        let out = NormalPerturbation::NormalMap(Arc::new(flat)).perturb(&plane(2.0, 1.0), &point(&plane(2.0, 1.0)));
        assert!((out.ns - Vec3::Z).length() < 1e-6);
        let tilted = RgbImage::new(1, 1, vec![[1.0, 0.5, 1.0]]);
        let out = NormalPerturbation::NormalMap(Arc::new(tilted)).perturb(&plane(2.0, 1.0), &point(&plane(2.0, 1.0)));
        assert!((out.ns - Vec3::new(1.0, 0.0, 1.0).normalize()).length() < 1e-6, "{:?}", out.ns);
    }
}
