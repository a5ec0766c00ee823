//! Manifold next-event estimation (Hanika, Droske & Fascione 2015) through chains of smooth dielectric
//! refractions, solved one index of refraction (one wavelength) at a time.
//!
//! At a non-specular vertex x₀ a point y is sampled on a light; the straight segment x₀→y collects the smooth
//! dielectric surfaces it crosses (the seed chain x₁…x_k). Newton's method then moves x₁…x_k on their surfaces
//! until every vertex refracts exactly at the wavelength's index: the generalized half-vector
//! h = η_cam·ω_cam + η_light·ω_light is parallel to the shading normal (Jakob & Marschner 2012 §4), written as
//! the two components of ĥ in a tangent frame of the normal. Each step is projected back onto the surfaces by
//! tracing from x₀ through the moved vertices. The converged chain contributes
//! f(x₀)·|cos θ₀|·∏(T/η'²)·Le(y)·G / p(y), where G = dω₀/dA(y) is the generalized geometry term (the
//! determinant of the constraint Jacobian's block relating x₁ to y, Jakob & Marschner 2012 §4.3).
//!
//! The solver is a deterministic function of (x₀, y, the indices): the path tracer asks it again when a
//! BSDF-sampled path reaches a light through such a chain ([`covers`]) and drops exactly the paths manifold NEE
//! counts. The two estimators thus split the paths between them and their sum is unbiased, even where Newton's
//! method misses a solution (the path tracer keeps those paths).

// The solver's small dense systems read best indexed.
#![allow(clippy::needless_range_loop)]

use glam::{DVec3, Vec2, Vec3};
use spectral::{SampledSpectrum, SampledWavelengths, N_WAVELENGTHS};

use super::transport::{BounceSamples, SurfaceVertex, Tracer};
use crate::bxdf::{fresnel_dielectric, TransportMode};
use crate::light::{Light, LightSampleContext};
use crate::scene::{DifferentialHit, RenderScene, SurfaceHit, NO_MATERIAL};
use crate::texture::TextureEvalContext;

/// Longest chain of refractions followed between a vertex and a light.
pub(crate) const MAX_CHAIN: usize = 4;
/// Newton iterations (accepted or halved steps) before giving up.
const MAX_ITERATIONS: u32 = 12;
/// Convergence: largest component of the constraint (ĥ in the tangent frame, i.e. the sine of the angle between
/// ĥ and the normal).
const TOLERANCE: f64 = 1e-5;
/// Newton gives up once a step has been halved to this fraction.
const MIN_STEP: f64 = 1.0 / 256.0;
/// The wavelength (nm) whose chain is solved first from the straight seed; every wavelength's chain starts from it.
const REFERENCE_LAMBDA: f32 = 550.0;
/// Two chains are the same solution when their vertices agree within this fraction of |x₀ − y|.
const MATCH_TOLERANCE: f64 = 1e-3;

/// A vertex of a chain on a refracting surface, with how the surface moves there (in f64 for the solver).
#[derive(Clone, Copy, Debug)]
struct Vertex {
    hit: SurfaceHit,
    surface: [u32; 2],
    p: DVec3,
    ng: DVec3,
    ns: DVec3,
    dpdu: DVec3,
    dpdv: DVec3,
    dndu: DVec3,
    dndv: DVec3,
}

impl Vertex {
    fn new(dh: &DifferentialHit) -> Option<Self> {
        let d = dh.derivatives?;
        Some(Self {
            hit: dh.hit,
            surface: dh.surface,
            p: dh.hit.p.as_dvec3(),
            ng: dh.hit.n.as_dvec3(),
            ns: dh.hit.ns.as_dvec3(),
            dpdu: d.dpdu.as_dvec3(),
            dpdv: d.dpdv.as_dvec3(),
            dndu: d.dndu.as_dvec3(),
            dndv: d.dndv.as_dvec3(),
        })
    }
}

/// The surfaces the straight segment x₀→y crosses, all smooth dielectrics.
#[derive(Clone, Copy, Debug)]
struct Seed {
    v: [Vertex; MAX_CHAIN],
    len: usize,
    /// Per vertex, the material (a smooth dielectric).
    material: [u32; MAX_CHAIN],
    /// Per vertex, whether x₀'s side is the outside (where the shading normal points).
    cam_outside: [bool; MAX_CHAIN],
}

/// Traces the segment from `x0` to `y` and collects the surfaces it crosses; `None` if it crosses none, more
/// than `max_len`, or one that is not a smooth dielectric with derivatives.
fn trace_seed(tracer: &mut Tracer, x0: &SurfaceHit, y: Vec3, max_len: usize) -> Option<Seed> {
    let scene = tracer.scene;
    let mut origin = x0.spawn_origin(y - x0.p);
    let mut seed: Option<Seed> = None;
    loop {
        let to = y - origin;
        let dist = to.length();
        if !(dist > 0.0 && dist.is_finite()) {
            return None;
        }
        let d = to / dist;
        tracer.counts.intersect += 1;
        let Some(dh) = scene.geometry.intersect_differential(origin, d, dist * (1.0 - 1e-4), x0.time) else {
            return seed;
        };
        let len = seed.map_or(0, |s| s.len);
        if len == max_len || dh.hit.material == NO_MATERIAL {
            return None;
        }
        // A bump or normal map tilts the shading normal away from the surface's own: not a smooth interface here.
        if matches!(scene.normal_perturbations.get(dh.hit.material as usize), Some(Some(_))) {
            return None;
        }
        let ctx = TextureEvalContext::new(dh.hit.p, dh.hit.n, dh.hit.uv);
        scene.materials[dh.hit.material as usize].smooth_dielectric_ior(&ctx)?;
        let v = Vertex::new(&dh)?;
        let s = seed.get_or_insert(Seed {
            v: [v; MAX_CHAIN],
            len: 0,
            material: [0; MAX_CHAIN],
            cam_outside: [false; MAX_CHAIN],
        });
        s.v[len] = v;
        s.material[len] = dh.hit.material;
        s.cam_outside[len] = (-d).dot(dh.hit.ns) > 0.0;
        s.len = len + 1;
        origin = dh.hit.spawn_origin(d);
    }
}

/// Where a chain ends on the light: the point and two orthonormal tangents along which it could move (the
/// light's surface for area lights; perpendicular to the last segment for point lights).
#[derive(Clone, Copy, Debug)]
struct LightEnd {
    p: DVec3,
    t1: DVec3,
    t2: DVec3,
}

/// `v` with its component along unit `w` removed, divided by `len`: the derivative of a unit vector w = x/|x|
/// (|x| = len) along a change `v` of x.
#[inline]
fn d_unit(w: DVec3, len: f64, v: DVec3) -> DVec3 {
    (v - w * w.dot(v)) / len
}

/// The refraction constraint at one chain vertex and its derivatives (Jakob & Marschner 2012 §4, with the
/// tangent frame (s, t) a fixed function of the normal so that the constraint is differentiable everywhere).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Constraint {
    wa: DVec3,
    la: f64,
    wb: DVec3,
    lb: f64,
    eta_a: f64,
    eta_b: f64,
    hh: DVec3,
    lh: f64,
    n: DVec3,
    r: DVec3,
    s: DVec3,
    t: DVec3,
    lq: f64,
}

impl Constraint {
    /// At vertex `x` with shading normal `n`, between `prev` (x₀'s side, index `eta_a`) and `next` (the light's
    /// side, index `eta_b`); `r` is the vertex's fixed reference direction for its tangent frame
    /// s = normalize(r − n(n·r)), t = n × s. `None` when degenerate.
    pub(crate) fn new(prev: DVec3, x: DVec3, next: DVec3, n: DVec3, r: DVec3, eta_a: f64, eta_b: f64) -> Option<Self> {
        let (a, b) = (prev - x, next - x);
        let (la, lb) = (a.length(), b.length());
        let q = r - n * n.dot(r);
        let lq = q.length();
        if !(la > 0.0 && lb > 0.0 && lq > 1e-9) {
            return None;
        }
        let (wa, wb) = (a / la, b / lb);
        let h = eta_a * wa + eta_b * wb;
        let lh = h.length();
        if lh.is_nan() || lh <= 1e-12 {
            return None;
        }
        let s = q / lq;
        Some(Self { wa, la, wb, lb, eta_a, eta_b, hh: h / lh, lh, n, r, s, t: n.cross(s), lq })
    }

    /// The constraint: ĥ's components along s and t (zero exactly when the vertex refracts).
    pub(crate) fn value(&self) -> [f64; 2] {
        [self.s.dot(self.hh), self.t.dot(self.hh)]
    }

    /// Its change for changes of the previous point, the vertex, its normal and the next point.
    pub(crate) fn derivative(&self, d_prev: DVec3, dx: DVec3, dn: DVec3, d_next: DVec3) -> [f64; 2] {
        let dh =
            self.eta_a * d_unit(self.wa, self.la, d_prev - dx) + self.eta_b * d_unit(self.wb, self.lb, d_next - dx);
        let dhh = d_unit(self.hh, self.lh, dh);
        let dq = -(dn * self.n.dot(self.r) + self.n * self.r.dot(dn));
        let ds = d_unit(self.s, self.lq, dq);
        let dt = dn.cross(self.s) + self.n.cross(ds);
        [ds.dot(self.hh) + self.s.dot(dhh), dt.dot(self.hh) + self.t.dot(dhh)]
    }
}

/// The fixed data of one solve: indices on either side of each vertex, and the tangent frames' references.
#[derive(Clone, Copy, Debug)]
struct Setup {
    len: usize,
    eta_cam: [f64; MAX_CHAIN],
    eta_light: [f64; MAX_CHAIN],
    reference: [DVec3; MAX_CHAIN],
}

const N_MAX: usize = 2 * MAX_CHAIN;

/// The constraints of a chain, their Jacobian with respect to the vertices' (u, v), and the last vertex's
/// constraint's derivative with respect to the light point along the end's tangents.
struct System {
    c: [f64; N_MAX],
    j: [[f64; N_MAX]; N_MAX],
    light: [[f64; 2]; 2],
}

fn evaluate(x0: DVec3, v: &[Vertex], setup: &Setup, end: &LightEnd) -> Option<System> {
    let k = setup.len;
    let mut sys = System { c: [0.0; N_MAX], j: [[0.0; N_MAX]; N_MAX], light: [[0.0; 2]; 2] };
    let z = DVec3::ZERO;
    for i in 0..k {
        let prev = if i == 0 { x0 } else { v[i - 1].p };
        let next = if i + 1 == k { end.p } else { v[i + 1].p };
        let c = Constraint::new(prev, v[i].p, next, v[i].ns, setup.reference[i], setup.eta_cam[i], setup.eta_light[i])?;
        let [c0, c1] = c.value();
        sys.c[2 * i] = c0;
        sys.c[2 * i + 1] = c1;
        let mut put = |col: usize, d: [f64; 2]| {
            sys.j[2 * i][col] = d[0];
            sys.j[2 * i + 1][col] = d[1];
        };
        if i > 0 {
            put(2 * i - 2, c.derivative(v[i - 1].dpdu, z, z, z));
            put(2 * i - 1, c.derivative(v[i - 1].dpdv, z, z, z));
        }
        put(2 * i, c.derivative(z, v[i].dpdu, v[i].dndu, z));
        put(2 * i + 1, c.derivative(z, v[i].dpdv, v[i].dndv, z));
        if i + 1 < k {
            put(2 * i + 2, c.derivative(z, z, z, v[i + 1].dpdu));
            put(2 * i + 3, c.derivative(z, z, z, v[i + 1].dpdv));
        } else {
            let (a, b) = (c.derivative(z, z, z, end.t1), c.derivative(z, z, z, end.t2));
            sys.light = [[a[0], b[0]], [a[1], b[1]]];
        }
    }
    Some(sys)
}

/// Solves `a·x = b` for `m` right-hand sides (Gaussian elimination with partial pivoting); `None` if singular.
fn solve_linear<const M: usize>(
    mut a: [[f64; N_MAX]; N_MAX],
    mut b: [[f64; M]; N_MAX],
    n: usize,
) -> Option<[[f64; M]; N_MAX]> {
    let scale = (0..n).flat_map(|i| (0..n).map(move |j| (i, j))).fold(0.0f64, |m, (i, j)| m.max(a[i][j].abs()));
    if !(scale > 0.0 && scale.is_finite()) {
        return None;
    }
    for col in 0..n {
        let piv = (col..n).max_by(|&x, &y| a[x][col].abs().total_cmp(&a[y][col].abs()))?;
        if a[piv][col].abs() <= 1e-12 * scale {
            return None;
        }
        a.swap(col, piv);
        b.swap(col, piv);
        for row in col + 1..n {
            let f = a[row][col] / a[col][col];
            if f != 0.0 {
                for k in col..n {
                    a[row][k] -= f * a[col][k];
                }
                for k in 0..M {
                    b[row][k] -= f * b[col][k];
                }
            }
        }
    }
    let mut x = [[0.0; M]; N_MAX];
    for row in (0..n).rev() {
        for k in 0..M {
            let mut s = b[row][k];
            for c in row + 1..n {
                s -= a[row][c] * x[c][k];
            }
            x[row][k] = s / a[row][row];
        }
    }
    x.iter().take(n).all(|r| r.iter().all(|v| v.is_finite())).then_some(x)
}

/// Moves the chain to `targets` by tracing from `x0` through them: each vertex must land on its own surface.
fn reproject(
    tracer: &mut Tracer,
    x0: &SurfaceHit,
    old: &[Vertex; MAX_CHAIN],
    targets: &[DVec3; MAX_CHAIN],
    k: usize,
) -> Option<[Vertex; MAX_CHAIN]> {
    let scene = tracer.scene;
    let mut out = *old;
    let mut from = *x0;
    for i in 0..k {
        let d = (targets[i] - from.p.as_dvec3()).normalize_or_zero().as_vec3();
        if d == Vec3::ZERO {
            return None;
        }
        tracer.counts.intersect += 1;
        let dh = scene.geometry.intersect_differential(from.spawn_origin(d), d, f32::INFINITY, from.time)?;
        if dh.surface != old[i].surface {
            return None;
        }
        out[i] = Vertex::new(&dh)?;
        from = dh.hit;
    }
    Some(out)
}

fn max_abs(c: &[f64]) -> f64 {
    c.iter().fold(0.0, |m, v| m.max(v.abs()))
}

/// A converged chain with its generalized geometry term G = dω₀/dA(y).
#[derive(Clone, Copy, Debug)]
struct Solution {
    v: [Vertex; MAX_CHAIN],
    len: usize,
    g: f64,
}

/// Newton's method from the chain `start` (crossing the surfaces of `seed`, on its sides) at the indices `eta`
/// (inside each vertex's surface) from `x0` to the light end `end`, with step halving. Returns the converged
/// vertices, the solve's setup and the system there; `None` if it does not converge.
fn newton(
    tracer: &mut Tracer,
    x0: &SurfaceHit,
    seed: &Seed,
    start: &[Vertex; MAX_CHAIN],
    eta: &[f64; MAX_CHAIN],
    end: &LightEnd,
) -> Option<([Vertex; MAX_CHAIN], Setup, System)> {
    let k = seed.len;
    let mut setup =
        Setup { len: k, eta_cam: [1.0; MAX_CHAIN], eta_light: [1.0; MAX_CHAIN], reference: [DVec3::X; MAX_CHAIN] };
    for i in 0..k {
        if eta[i] == 1.0 || eta[i].is_nan() || eta[i] <= 0.0 {
            return None;
        }
        if seed.cam_outside[i] {
            setup.eta_light[i] = eta[i];
        } else {
            setup.eta_cam[i] = eta[i];
        }
        let (n, t) = (start[i].ns, start[i].dpdu);
        let r = t - n * n.dot(t);
        setup.reference[i] = if r.length_squared() > 1e-18 {
            r.normalize()
        } else {
            geometry::shapes::coordinate_system(n.as_vec3()).0.as_dvec3()
        };
    }
    let x0p = x0.p.as_dvec3();
    let n = 2 * k;
    let mut v = *start;
    let mut sys = evaluate(x0p, &v[..k], &setup, end)?;
    let mut err = max_abs(&sys.c[..n]);
    let mut step = 1.0;
    let mut delta: Option<[[f64; 1]; N_MAX]> = None;
    let mut iterations = 0;
    while err > TOLERANCE {
        iterations += 1;
        if iterations > MAX_ITERATIONS || step < MIN_STEP {
            return None;
        }
        if delta.is_none() {
            let mut rhs = [[0.0; 1]; N_MAX];
            for i in 0..n {
                rhs[i][0] = -sys.c[i];
            }
            delta = Some(solve_linear(sys.j, rhs, n)?);
        }
        let dl = delta.as_ref()?;
        let mut targets = [DVec3::ZERO; MAX_CHAIN];
        for i in 0..k {
            targets[i] = v[i].p + step * (dl[2 * i][0] * v[i].dpdu + dl[2 * i + 1][0] * v[i].dpdv);
        }
        let moved =
            reproject(tracer, x0, &v, &targets, k).and_then(|w| evaluate(x0p, &w[..k], &setup, end).map(|s| (w, s)));
        match moved {
            Some((w, s)) if max_abs(&s.c[..n]) < err => {
                v = w;
                sys = s;
                err = max_abs(&sys.c[..n]);
                delta = None;
                step = (step * 2.0).min(1.0);
            }
            _ => step *= 0.5,
        }
    }
    Some((v, setup, sys))
}

/// One wavelength's chain: Newton's method (see [`newton`]) from the reference chain `start` at the indices
/// `eta`, then the checks (every vertex refracts between the sides the seed crossed, the last segment is
/// unoccluded) and the generalized geometry term, with the light end's tangents taken perpendicular to the last
/// segment when `point_light`. `None` if it does not converge or the chain is invalid.
fn solve(
    tracer: &mut Tracer,
    x0: &SurfaceHit,
    seed: &Seed,
    start: &[Vertex; MAX_CHAIN],
    eta: &[f64; MAX_CHAIN],
    mut end: LightEnd,
    point_light: bool,
) -> Option<Solution> {
    let k = seed.len;
    let n = 2 * k;
    let x0p = x0.p.as_dvec3();
    let (v, setup, mut sys) = newton(tracer, x0, seed, start, eta, &end)?;
    // Every vertex must refract between the sides the seed crossed (shading and geometric normals agreeing).
    for i in 0..k {
        let prev = if i == 0 { x0p } else { v[i - 1].p };
        let next = if i + 1 == k { end.p } else { v[i + 1].p };
        let (wa, wb) = (prev - v[i].p, next - v[i].p);
        let (a, b) = (wa.dot(v[i].ns), wb.dot(v[i].ns));
        if (a > 0.0) != seed.cam_outside[i]
            || (b > 0.0) == seed.cam_outside[i]
            || a * wa.dot(v[i].ng) <= 0.0
            || b * wb.dot(v[i].ng) <= 0.0
        {
            return None;
        }
    }
    // The last segment must reach the light.
    let last = v[k - 1].hit;
    let to = end.p.as_vec3() - last.p;
    let origin = last.spawn_origin(to);
    let to = end.p.as_vec3() - origin;
    let dist = to.length();
    if dist.is_nan() || dist <= 0.0 || tracer.occluded(origin, to / dist, dist * (1.0 - 1e-4), last.time) {
        return None;
    }
    if point_light {
        // A point light has no surface: measure it on a plane facing the last segment.
        let w = (v[k - 1].p - end.p).normalize();
        let (t1, t2) = geometry::shapes::coordinate_system(w.as_vec3());
        end.t1 = t1.as_dvec3();
        end.t2 = t2.as_dvec3();
        sys = evaluate(x0p, &v[..k], &setup, &end)?;
    }
    // G = dω₀/dA(y): x₁ moves with y as −J⁻¹·∂C/∂y (only the last vertex's constraint depends on y).
    let mut rhs = [[0.0; 2]; N_MAX];
    rhs[n - 2] = [-sys.light[0][0], -sys.light[0][1]];
    rhs[n - 1] = [-sys.light[1][0], -sys.light[1][1]];
    let z = solve_linear(sys.j, rhs, n)?;
    let det = (z[0][0] * z[1][1] - z[0][1] * z[1][0]).abs();
    let area = v[0].dpdu.cross(v[0].dpdv).length();
    let d01 = v[0].p - x0p;
    let d2 = d01.length_squared();
    let g = det * area * v[0].ng.dot(d01).abs() / (d2 * d2.sqrt());
    (g.is_finite() && g > 0.0).then_some(Solution { v, len: k, g })
}

/// A point on a light for manifold NEE, as seen from `x0`: (point, light normal, density per unit area), or for a
/// point light its position with no normal and density 1.
fn sample_light_end(light: &Light, x0: Vec3, u: Vec2) -> Option<(Vec3, Option<Vec3>, f32)> {
    match light {
        Light::Point { p, .. } | Light::Spot { p, .. } => Some((*p, None, 1.0)),
        // Emitters with alpha cut-outs are left to path tracing ([`light_end_supported`] says so too).
        Light::DiffuseArea { shape, element, alpha: None, .. } => {
            if let geometry::Shape::Sphere(s) = shape.as_ref() {
                let (c, r) = (s.center(), s.render_radius());
                if s.is_full() && x0.distance_squared(c) > r * r {
                    // Uniform by area on the hemisphere facing x₀ (cos θ uniform, Archimedes): the other half
                    // cannot be seen from anywhere near x₀.
                    let axis = (x0 - c).normalize();
                    let (e1, e2) = geometry::shapes::coordinate_system(axis);
                    let cos = u.x;
                    let sin = (1.0 - cos * cos).max(0.0).sqrt();
                    let phi = 2.0 * std::f32::consts::PI * u.y;
                    let dir = sin * phi.cos() * e1 + sin * phi.sin() * e2 + cos * axis;
                    let n = if s.reverse_orientation() { -dir } else { dir };
                    return Some((c + r * dir, Some(n), 1.0 / (2.0 * std::f32::consts::PI * r * r)));
                }
            }
            let ss = shape.sample_area(*element as usize, u)?;
            (ss.pdf > 0.0 && ss.pdf.is_finite()).then_some((ss.p, Some(ss.n), ss.pdf))
        }
        // Lights at infinity and directional lights end no chain that a refraction can focus (and alpha cut-outs
        // are left to path tracing).
        Light::DiffuseArea { alpha: Some(_), .. }
        | Light::Distant { .. }
        | Light::DistantDisc { .. }
        | Light::UniformInfinite { .. }
        | Light::ImageInfinite { .. } => None,
    }
}

/// Whether [`sample_light_end`] can return the point `y` of area light `light` as seen from `x0`.
fn light_end_supported(light: &Light, x0: Vec3, y: Vec3) -> bool {
    match light {
        Light::DiffuseArea { shape, alpha: None, .. } => match shape.as_ref() {
            geometry::Shape::Sphere(s) => {
                let (c, r) = (s.center(), s.render_radius());
                if s.is_full() && x0.distance_squared(c) > r * r {
                    (y - c).dot(x0 - c) > 0.0
                } else {
                    true
                }
            }
            geometry::Shape::Mesh(_) | geometry::Shape::Bilinear(_) | geometry::Shape::Disk(_) => true,
        },
        Light::Point { .. }
        | Light::Spot { .. }
        | Light::Distant { .. }
        | Light::DistantDisc { .. }
        | Light::UniformInfinite { .. }
        | Light::ImageInfinite { .. }
        | Light::DiffuseArea { alpha: Some(_), .. } => false,
    }
}

/// The indices each vertex of `seed` has at the carried wavelengths of `wl` and at the reference wavelength, and
/// the slots grouped by the indices they see: one solve per group (a chain of non-dispersive glass is solved once
/// for all wavelengths). `group[j]` is the first slot with slot j's indices (`usize::MAX` for inactive slots).
struct Indices {
    eta: [[f64; MAX_CHAIN]; N_WAVELENGTHS],
    group: [usize; N_WAVELENGTHS],
    reference: [f64; MAX_CHAIN],
}

fn indices(scene: &RenderScene, seed: &Seed, wl: &SampledWavelengths) -> Indices {
    let mut out = Indices {
        eta: [[1.0; MAX_CHAIN]; N_WAVELENGTHS],
        group: [usize::MAX; N_WAVELENGTHS],
        reference: [1.0; MAX_CHAIN],
    };
    for i in 0..seed.len {
        let hit = &seed.v[i].hit;
        let ctx =
            TextureEvalContext { vertex_color: hit.vertex_color, ..TextureEvalContext::new(hit.p, hit.n, hit.uv) };
        if let Some(ior) = scene.materials[seed.material[i] as usize].smooth_dielectric_ior(&ctx) {
            out.reference[i] = ior.n(REFERENCE_LAMBDA) as f64;
            for j in 0..N_WAVELENGTHS {
                out.eta[j][i] = ior.n(wl.lambda(j)) as f64;
            }
        }
    }
    for j in 0..N_WAVELENGTHS {
        if wl.is_active(j) {
            let g = (0..j).find(|&g| out.group[g] == g && out.eta[g] == out.eta[j]).unwrap_or(j);
            out.group[j] = g;
        }
    }
    out
}

/// The chains of the carried wavelengths from `x0` to `end` near the straight `seed`: first the chain at the
/// reference wavelength from the seed, then each group's from that one (a deterministic function of x₀, y and the
/// indices, which [`covers`] relies on). Calls `found` with each group's slot and solution.
fn solve_all(
    tracer: &mut Tracer,
    x0: &SurfaceHit,
    seed: &Seed,
    idx: &Indices,
    (end, point_light): (LightEnd, bool),
    mut found: impl FnMut(usize, &Solution),
) {
    let Some((start, _, _)) = newton(tracer, x0, seed, &seed.v, &idx.reference, &end) else { return };
    for g in 0..N_WAVELENGTHS {
        if idx.group[g] == g {
            if let Some(sol) = solve(tracer, x0, seed, &start, &idx.eta[g], end, point_light) {
                found(g, &sol);
            }
        }
    }
}

/// Manifold next-event estimation at the non-specular vertex `hit` (BxDF `bxdf`, local outgoing direction `wo` in
/// `frame`): a light and a point on it from the bounce's connection numbers, then one chain per distinct set of
/// indices among the carried wavelengths. Returns f·|cos|·∏(T/η'²)·Le·G / p per wavelength (zero where no chain
/// was found), to be multiplied by the path throughput. `max_len` caps the chain's length (the path's remaining
/// depth).
pub(crate) fn estimate(
    tracer: &mut Tracer,
    v: &SurfaceVertex,
    wl: &SampledWavelengths,
    u: &BounceSamples,
    max_len: usize,
) -> SampledSpectrum {
    let scene = tracer.scene;
    let SurfaceVertex { hit, frame, bxdf, wo, .. } = *v;
    let mut out = SampledSpectrum::zero();
    let max_len = max_len.min(MAX_CHAIN);
    if max_len == 0 {
        return out;
    }
    let [u_light, u0, u1] = u.connect;
    let Some((li, p_sel)) = scene.sample_light(u_light) else { return out };
    let light = &scene.lights[li as usize];
    let Some((y, n_y, pdf_a)) = sample_light_end(light, hit.p, Vec2::new(u0, u1)) else { return out };
    let Some(seed) = trace_seed(tracer, hit, y, max_len) else { return out };
    let end = match n_y {
        Some(n) => {
            let (t1, t2) = geometry::shapes::coordinate_system(n);
            LightEnd { p: y.as_dvec3(), t1: t1.as_dvec3(), t2: t2.as_dvec3() }
        }
        None => LightEnd { p: y.as_dvec3(), t1: DVec3::X, t2: DVec3::Y },
    };
    let idx = indices(scene, &seed, wl);
    solve_all(tracer, hit, &seed, &idx, (end, n_y.is_none()), |g, sol| {
        let k = sol.len;
        let w0 = (sol.v[0].hit.p - hit.p).normalize();
        let wi = frame.to_local(w0);
        let f = bxdf.f(wo, wi, TransportMode::Radiance) * wi.z.abs();
        if f.is_black() {
            return;
        }
        let w_last = (sol.v[k - 1].hit.p - y).normalize();
        let le = match n_y {
            // No alpha on these emitters (see `sample_light_end`), so the point's uv is not needed.
            Some(n) => light.l_area(y, Vec2::ZERO, n, w_last, wl),
            None => {
                // The point light's intensity towards the last vertex: its radiance there times the squared distance.
                let ctx = LightSampleContext { p: sol.v[k - 1].hit.p };
                match light.sample_li(&ctx, Vec2::ZERO, wl) {
                    Some(ls) => ls.l * (ls.dist * ls.dist),
                    None => return,
                }
            }
        };
        let scale = (sol.g / (p_sel as f64 * pdf_a as f64)) as f32;
        for j in 0..N_WAVELENGTHS {
            if idx.group[j] != g {
                continue;
            }
            // Fresnel transmittance and radiance scaling η'² at each refraction, at this wavelength.
            let mut t = 1.0f32;
            for i in 0..k {
                let v = &sol.v[i];
                let prev = if i == 0 { hit.p } else { sol.v[i - 1].hit.p };
                let cos = (prev - v.hit.p).normalize().dot(v.hit.ns);
                let eta = idx.eta[g][i] as f32;
                let etap = if seed.cam_outside[i] { eta } else { 1.0 / eta };
                t *= (1.0 - fresnel_dielectric(cos, eta)) / (etap * etap);
            }
            out[j] = f[j] * t * le[j] * scale;
        }
    });
    if out.0.iter().all(|v| v.is_finite()) {
        out
    } else {
        SampledSpectrum::zero()
    }
}

/// The refractions a path has made since its last non-specular vertex, for [`covers`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct ChainTrack {
    /// The non-specular vertex where manifold NEE ran, and the chain length it allowed; `None` once the path has
    /// done anything manifold NEE does not follow (a reflection, a non-refracting specular surface, a longer chain).
    start: Option<(SurfaceHit, usize)>,
    p: [Vec3; MAX_CHAIN],
    len: usize,
}

impl ChainTrack {
    /// No chain: the path has not met a non-specular vertex yet.
    pub const NONE: Self = Self { start: None, p: [Vec3::ZERO; MAX_CHAIN], len: 0 };

    /// A chain starting at non-specular vertex `hit`, where manifold NEE allowed `max_len` refractions.
    pub fn start(hit: &SurfaceHit, max_len: usize) -> Self {
        Self { start: Some((*hit, max_len.min(MAX_CHAIN))), p: [Vec3::ZERO; MAX_CHAIN], len: 0 }
    }

    /// The path scattered at specular vertex `hit`: keeps the chain going if it was a transmission within the
    /// allowed length, ends it otherwise. (Whether manifold NEE follows that surface is for [`covers`] to find:
    /// it re-runs the solver, which only walks smooth dielectrics.)
    pub fn specular(&mut self, hit: &SurfaceHit, transmission: bool) {
        let Some((_, max_len)) = self.start else { return };
        if !transmission || self.len == max_len {
            self.start = None;
            return;
        }
        self.p[self.len] = hit.p;
        self.len += 1;
    }

    /// The chain ends (any other event than a specular scattering).
    pub fn end(&mut self) {
        self.start = None;
    }
}

/// Which carried wavelengths of a path that reached area light `li` at `y` (normal `n_y`) through `track` manifold
/// NEE counts
/// at the chain's start (it would sample `y`, and its solver from there finds this very chain): the path
/// tracer drops those, so that each path is counted by exactly one of the two.
pub(crate) fn covers(
    tracer: &mut Tracer,
    track: &ChainTrack,
    li: u32,
    (y, n_y): (Vec3, Vec3),
    wl: &SampledWavelengths,
) -> [bool; N_WAVELENGTHS] {
    let scene = tracer.scene;
    let mut out = [false; N_WAVELENGTHS];
    let Some((x0, max_len)) = track.start else { return out };
    if track.len == 0 || scene.light_probability(li) <= 0.0 {
        return out;
    }
    let light = &scene.lights[li as usize];
    if !light_end_supported(light, x0.p, y) {
        return out;
    }
    let Some(seed) = trace_seed(tracer, &x0, y, max_len) else { return out };
    if seed.len != track.len {
        return out;
    }
    let (t1, t2) = geometry::shapes::coordinate_system(n_y);
    let end = LightEnd { p: y.as_dvec3(), t1: t1.as_dvec3(), t2: t2.as_dvec3() };
    let idx = indices(scene, &seed, wl);
    let tol = MATCH_TOLERANCE * (y - x0.p).length() as f64;
    solve_all(tracer, &x0, &seed, &idx, (end, false), |g, sol| {
        if (0..sol.len).all(|i| sol.v[i].p.distance(track.p[i].as_dvec3()) < tol) {
            for j in 0..N_WAVELENGTHS {
                out[j] |= idx.group[j] == g;
            }
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Camera, Projection, ScreenWindow};
    use crate::material::{DielectricIor, Material, Roughness};
    use crate::scene::{SceneGeometry, ShapeInfo};
    use crate::texture::SpectrumTexture;
    use geometry::{GeometryScene, MeshData, Shape, Transform, TriangleMesh};
    use spectral::Spectrum;
    use std::sync::Arc;

    /// A horizontal quad at height `y` over [−s, s]², its normal up or down.
    fn horizontal(y: f32, s: f32, up: bool) -> Shape {
        let mut p = vec![Vec3::new(-s, y, -s), Vec3::new(s, y, -s), Vec3::new(s, y, s), Vec3::new(-s, y, s)];
        if up {
            p.reverse();
        }
        let data = MeshData { positions: p, indices: vec![0, 1, 2, 0, 2, 3], ..Default::default() };
        let mesh = TriangleMesh::new(&Transform::IDENTITY, data, false).unwrap();
        Shape::Mesh(Arc::new(mesh))
    }

    /// A diffuse floor at y = 0 under a slab of N-SF11 glass between y = 1 and y = 1.4, lit by `lights`.
    fn slab_scene(lights: Vec<Light>) -> RenderScene {
        glass_scene(lights, vec![horizontal(1.0, 20.0, false), horizontal(1.4, 20.0, true)])
    }

    /// A diffuse floor at y = 0 under `glass_shapes` (N-SF11), lit by `lights`.
    fn glass_scene(lights: Vec<Light>, glass_shapes: Vec<Shape>) -> RenderScene {
        let glass = DielectricIor::Model(optics::catalogue::lookup("N-SF11").unwrap().ior);
        let materials = vec![
            Material::Diffuse { reflectance: SpectrumTexture::Constant(Spectrum::Constant(0.5)) },
            Material::Dielectric {
                ior: glass,
                roughness: Roughness::smooth(),
                coating: Default::default(),
                tint: None,
            },
        ];
        let mut shapes = vec![horizontal(0.0, 20.0, true)];
        let mut info = vec![ShapeInfo { material: 0, area_light_base: None, media: None, vertex_colors: None }];
        for g in glass_shapes {
            shapes.push(g);
            info.push(ShapeInfo { material: 1, area_light_base: None, media: None, vertex_colors: None });
        }
        let accel = GeometryScene::from_shapes(shapes).unwrap();
        let cam = Transform::look_at(DVec3::new(0.0, 5.0, -5.0), DVec3::ZERO, DVec3::Y).unwrap();
        let camera = Camera::new(
            Projection::Perspective { tan_half_fov: 0.5 },
            &cam,
            (4, 4),
            ScreenWindow::for_aspect(1.0),
            0.0,
            1e6,
        );
        RenderScene::new(Arc::new(SceneGeometry::new(accel, vec![info])), materials, lights, vec![], None, camera)
    }

    /// The chains from the floor point under `x` to `y` at the wavelengths of `wl`: (slot of the group, solution).
    fn chains(
        scene: &RenderScene,
        x: Vec3,
        y: Vec3,
        point_light: bool,
        wl: &SampledWavelengths,
    ) -> Vec<(usize, Solution)> {
        let mut tracer = Tracer::new(scene);
        let x0 = scene.geometry.intersect(x + Vec3::Y * 0.5, -Vec3::Y, f32::INFINITY, 0.0).unwrap();
        let seed = trace_seed(&mut tracer, &x0, y, MAX_CHAIN).unwrap();
        let idx = indices(scene, &seed, wl);
        let end = LightEnd { p: y.as_dvec3(), t1: DVec3::X, t2: DVec3::Z };
        let mut out = vec![];
        solve_all(&mut tracer, &x0, &seed, &idx, (end, point_light), |g, sol| out.push((g, *sol)));
        out
    }

    /// Through a flat slab the chain from x₀ to y has a closed form: the direction leaves the floor at the angle θ
    /// with (h_below + h_above)·tan θ + t·tan θ' = D, sin θ = η sin θ' (Snell), solved here by bisection. Manifold
    /// NEE must put both refractions there, at each wavelength's own index (N-SF11 is strongly dispersive: the
    /// chains of 450 and 650 nm differ by millimetres).
    #[test]
    fn slab_chain_is_where_snell_puts_it_at_every_wavelength() {
        let scene = slab_scene(vec![]);
        let ior = optics::catalogue::lookup("N-SF11").unwrap().ior;
        let (x, y) = (Vec3::new(0.3, 0.0, -0.2), Vec3::new(2.3, 3.0, 1.1));
        let wl = SampledWavelengths::new([420.0, 510.0, 600.0, 690.0], [1.0; 4]);
        let sols = chains(&scene, x, y, true, &wl);
        assert_eq!(sols.len(), 4, "one chain per wavelength");
        let horizontal = (y - x) * Vec3::new(1.0, 0.0, 1.0);
        let dist = horizontal.length() as f64;
        let dir = (horizontal / horizontal.length()).as_dvec3();
        let mut first_hits = vec![];
        for (slot, sol) in sols {
            let eta = ior.n(wl.lambda(slot) as f64);
            let reach = |s: f64| 2.6 * s / (1.0 - s * s).sqrt() + 0.4 * (s / eta) / (1.0 - s * s / (eta * eta)).sqrt();
            let (mut lo, mut hi) = (0.0, 1.0 - 1e-12);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if reach(mid) < dist {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            let s = 0.5 * (lo + hi);
            let x1 = x.as_dvec3() + dir * (s / (1.0 - s * s).sqrt()) + DVec3::Y;
            let sg = s / eta;
            let x2 = x1 + dir * (0.4 * sg / (1.0 - sg * sg).sqrt()) + 0.4 * DVec3::Y;
            assert_eq!(sol.len, 2);
            let (e1, e2) = (sol.v[0].p.distance(x1), sol.v[1].p.distance(x2));
            assert!(
                e1 < 2e-5 && e2 < 2e-5,
                "{} nm: {:?} vs {x1}, {:?} vs {x2}",
                wl.lambda(slot),
                sol.v[0].p,
                sol.v[1].p
            );
            first_hits.push(x1);
        }
        assert!(first_hits[0].distance(first_hits[3]) > 2e-3, "the wavelengths refract apart: {first_hits:?}");
    }

    /// The generalized geometry term G = dω₀/dA(y) of a solved chain against finite differences: moving y by δ
    /// along the two tangents of the light end moves the direction leaving x₀ by a parallelogram of solid angle
    /// G·δ², through the slab (point light: tangents across the last segment). (Through a ball the test below
    /// checks G inside the whole estimate.)
    #[test]
    fn geometry_term_matches_finite_differences() {
        check_geometry_term(&slab_scene(vec![]), Vec3::new(0.3, 0.0, -0.2), Vec3::new(2.3, 3.0, 1.1));
    }

    fn check_geometry_term(scene: &RenderScene, x: Vec3, y: Vec3) {
        let wl = SampledWavelengths::new([550.0; 4], [1.0; 4]);
        let sol = chains(scene, x, y, true, &wl)[0].1;
        let w_last = (sol.v[sol.len - 1].p - y.as_dvec3()).normalize();
        let (t1, t2) = geometry::shapes::coordinate_system(w_last.as_vec3());
        let omega = |y: Vec3| {
            let s = chains(scene, x, y, true, &wl)[0].1;
            (s.v[0].p - x.as_dvec3()).normalize()
        };
        let d = 1e-3;
        let (w0, wa, wb) = (omega(y), omega(y + d * t1), omega(y + d * t2));
        let fd = (wa - w0).cross(wb - w0).length() / (d as f64 * d as f64);
        assert!((fd - sol.g).abs() < 0.01 * sol.g, "G {} vs finite differences {fd}", sol.g);
    }

    /// The constraint's analytic derivative against central finite differences, for each of its four inputs
    /// (previous point, vertex, normal, next point), away from a solution.
    #[test]
    fn constraint_derivative_matches_finite_differences() {
        let prev = DVec3::new(-1.0, 2.0, 0.3);
        let x = DVec3::new(0.1, 0.05, -0.02);
        let next = DVec3::new(0.8, -3.0, 0.5);
        let n = DVec3::new(0.1, 0.9, 0.2).normalize();
        let r = DVec3::new(1.0, 0.0, 0.1);
        let c = |prev, x, n, next| Constraint::new(prev, x, next, n, r, 1.0, 1.7).unwrap();
        let base = c(prev, x, n, next);
        let dirs = [DVec3::new(0.3, -0.2, 0.7), DVec3::new(-0.5, 0.4, 0.1)];
        let z = DVec3::ZERO;
        for d in dirs {
            let e = 1e-6;
            for which in 0..4 {
                let pick = |s: f64| {
                    let m = |w: usize| if which == w { d * s } else { z };
                    c(prev + m(0), x + m(1), n + m(2), next + m(3)).value()
                };
                let (hi, lo) = (pick(e), pick(-e));
                let fd = [(hi[0] - lo[0]) / (2.0 * e), (hi[1] - lo[1]) / (2.0 * e)];
                let m = |w: usize| if which == w { d } else { z };
                let an = base.derivative(m(0), m(1), m(2), m(3));
                for q in 0..2 {
                    assert!(an[q].abs() > 1e-3 || fd[q].abs() < 1e-6, "input {which}: derivative {an:?} vs {fd:?}");
                    assert!((an[q] - fd[q]).abs() < 1e-6 * (1.0 + fd[q].abs()), "input {which}: {an:?} vs {fd:?}");
                }
            }
        }
    }

    /// The constraint vanishes exactly for a refraction obeying Snell's law (and not for a slightly wrong one).
    #[test]
    fn constraint_vanishes_at_snell_refraction() {
        let n = DVec3::Z;
        let eta = 1.6;
        let theta_i = 0.7f64;
        let theta_t = (theta_i.sin() / eta).asin();
        let prev = DVec3::new(-theta_i.sin(), 0.0, theta_i.cos()) * 2.0;
        let next = DVec3::new(theta_t.sin(), 0.0, -theta_t.cos()) * 3.0;
        let c = Constraint::new(prev, DVec3::ZERO, next, n, DVec3::X, 1.0, eta).unwrap();
        assert!(max_abs(&c.value()) < 1e-12, "{:?}", c.value());
        let c = Constraint::new(prev, DVec3::ZERO, next, n, DVec3::X, 1.0, eta * 1.01).unwrap();
        assert!(max_abs(&c.value()) > 1e-3, "{:?}", c.value());
    }
}

#[cfg(test)]
mod tests_support {
    use super::*;
    use crate::camera::{Camera, Projection, ScreenWindow};
    use crate::material::{DielectricIor, Material, Roughness};
    use crate::scene::{SceneGeometry, ShapeInfo};
    use crate::texture::SpectrumTexture;
    use geometry::{GeometryScene, MeshData, Shape, Transform, TriangleMesh};
    use spectral::Spectrum;
    use std::sync::Arc;

    /// A diffuse floor, an N-SF11 ball (radius 0.7) on it and a spherical lamp (radius 0.2) above it; and a floor
    /// point in the ball's caustic.
    pub fn sphere_lamp_scene() -> (RenderScene, Vec3) {
        let glass = DielectricIor::Model(optics::catalogue::lookup("N-SF11").unwrap().ior);
        let materials = vec![
            Material::Diffuse { reflectance: SpectrumTexture::Constant(Spectrum::Constant(0.5)) },
            Material::Dielectric {
                ior: glass,
                roughness: Roughness::smooth(),
                coating: Default::default(),
                tint: None,
            },
        ];
        let s = 20.0;
        let p = vec![Vec3::new(-s, 0.0, s), Vec3::new(s, 0.0, s), Vec3::new(s, 0.0, -s), Vec3::new(-s, 0.0, -s)];
        let data = MeshData { positions: p, indices: vec![0, 1, 2, 0, 2, 3], ..Default::default() };
        let floor = Shape::Mesh(Arc::new(TriangleMesh::new(&Transform::IDENTITY, data, false).unwrap()));
        let ball =
            Shape::Sphere(geometry::Sphere::new(0.7, Transform::translate(DVec3::new(0.6, 0.7, 0.0)), false).unwrap());
        let lamp =
            Shape::Sphere(geometry::Sphere::new(0.2, Transform::translate(DVec3::new(0.6, 2.4, 0.0)), false).unwrap());
        let lights = vec![Light::DiffuseArea {
            shape: Box::new(lamp.clone()),
            element: 0,
            l: Spectrum::Constant(1.0),
            image: None,
            two_sided: false,
            alpha: None,
            invisible: false,
        }];
        let info = vec![
            ShapeInfo { material: 0, area_light_base: None, media: None, vertex_colors: None },
            ShapeInfo { material: 1, area_light_base: None, media: None, vertex_colors: None },
            ShapeInfo { material: 0, area_light_base: Some(0), media: None, vertex_colors: None },
        ];
        let accel = GeometryScene::from_shapes(vec![floor, ball, lamp]).unwrap();
        let cam = Transform::look_at(DVec3::new(0.0, 5.0, -5.0), DVec3::ZERO, DVec3::Y).unwrap();
        let camera = Camera::new(
            Projection::Perspective { tan_half_fov: 0.5 },
            &cam,
            (4, 4),
            ScreenWindow::for_aspect(1.0),
            0.0,
            1e6,
        );
        (
            RenderScene::new(Arc::new(SceneGeometry::new(accel, vec![info])), materials, lights, vec![], None, camera),
            Vec3::new(0.7, 0.0, 0.05),
        )
    }
}

#[cfg(test)]
mod brute {
    use super::tests_support::*;
    use super::*;
    use crate::bxdf::Bxdf;
    use crate::sampling::Frame;

    /// Manifold NEE's estimate at a floor point in the caustic of a glass ball under a spherical lamp, averaged over
    /// a grid of light samples, equals per wavelength (four distinct indices of N-SF11) the brute-force integral
    /// of f·cos·∏(T/η'²)·Le over the directions (a fine grid, cosine-weighted) whose refracted paths reach the lamp
    /// and that [`covers`] says manifold NEE counts: the two halves of the split the path tracer relies on agree
    /// (within 0.5%; they agree to 0.05%, a missing factor or wavelength would be off by far more).
    #[test]
    fn estimate_equals_the_integral_of_the_paths_it_covers() {
        let (scene, x) = sphere_lamp_scene();
        let mut tracer = Tracer::new(&scene);
        let x0 = scene.geometry.intersect(x + Vec3::Y * 0.3, -Vec3::Y, f32::INFINITY, 0.0).unwrap();
        let wl = SampledWavelengths::new([450.0, 520.0, 600.0, 680.0], [1.0; 4]);
        let bxdf = Bxdf::Diffuse { r: SampledSpectrum::splat(1.0) };
        let nz = if x0.n.y < 0.0 { -x0.n } else { x0.n };
        let frame = Frame::from_z(nz);
        let wo = frame.to_local(Vec3::Y);
        let n = 300;
        let mut sum_m = SampledSpectrum::zero();
        for i in 0..n {
            for j in 0..n {
                let u = BounceSamples {
                    connect: [0.5, (i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32],
                    lobe: 0.0,
                    dir: Vec2::ZERO,
                    rr: 0.0,
                    mix: 0.0,
                    wavelength: 0.0,
                };
                let v = SurfaceVertex { hit: &x0, frame: &frame, bxdf: &bxdf, wo, medium: None };
                sum_m += estimate(&mut tracer, &v, &wl, &u, 4);
            }
        }
        let mnee = sum_m * (1.0 / (n * n) as f32);
        let m = 1000;
        let mut sum_c = SampledSpectrum::zero();
        let ior = optics::catalogue::lookup("N-SF11").unwrap().ior;
        for slot in 0..4 {
            let eta = ior.n(wl.lambda(slot) as f64) as f32;
            let wl1 = wl.branch(slot);
            for i in 0..m {
                for j in 0..m {
                    let u = Vec2::new((i as f32 + 0.5) / m as f32, (j as f32 + 0.5) / m as f32);
                    let mut d = frame.from_local(crate::sampling::sample_cosine_hemisphere(u));
                    let mut o = x0.spawn_origin(d);
                    let mut track = ChainTrack::start(&x0, 4);
                    let mut w = 1.0f32;
                    for _ in 0..4 {
                        let Some(h) = scene.geometry.intersect(o, d, f32::INFINITY, 0.0) else { break };
                        if h.area_light.is_some() {
                            if covers(&mut tracer, &track, 0, (h.p, h.n), &wl1)[slot] {
                                sum_c[slot] += w * scene.lights[0].l_area(h.p, h.uv, h.n, -d, &wl)[slot];
                            }
                            break;
                        }
                        if h.material != 1 {
                            break;
                        }
                        let f = Frame::from_z(h.ns);
                        let wol = f.to_local(-d);
                        let Some((wi, etap)) = crate::bxdf::refract(wol, Vec3::Z, eta) else { break };
                        w *= (1.0 - fresnel_dielectric(wol.z, eta)) / (etap * etap);
                        track.specular(&h, true);
                        d = f.from_local(wi);
                        o = h.spawn_origin(d);
                    }
                }
            }
        }
        // Cosine-weighted: ∫ f cos L dω = (1/π)·π·E[L] with f = 1/π.
        let covered = sum_c * (1.0 / (m * m) as f32);
        for j in 0..4 {
            assert!(covered[j] > 0.01, "slot {j}: the caustic is lit ({covered:?})");
            assert!((mnee[j] - covered[j]).abs() < 0.005 * covered[j], "slot {j}: {mnee:?} vs {covered:?}");
        }
    }
}
