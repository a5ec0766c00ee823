//! Traversal against Embree 3: the project's BVH and Embree on the same ~1M triangles and the same rays.
//!
//! Needs Embree 3 (`scripts/install-embree.sh`) and the `embree` feature:
//! `cargo bench -p geometry --bench embree --features embree`; `scripts/bench-traversal.sh` runs it and prints the
//! comparison table (BENCHMARKS.md, "Traversal against Embree 3").
//!
//! The scene is one mesh: a bumpy sphere (819,200 triangles) in a closed, bumpy spherical room (204,800 larger
//! triangles), so that every ray hits something and the cost is traversal, not rays leaving the scene. Rays:
//! - `camera`: a 256×256 pinhole grid (coherent);
//! - `bounce`: cosine-distributed directions from the camera rays' hits (found with the project's BVH), each from a
//!   randomly chosen hit (incoherent);
//! - `shadow`: from those hits to random points on a square light above the scene, only towards the side the
//!   surface faces (as a renderer would trace them), with the finite `t_max` of [`spawn_ray_to_point`].
//!
//! Each set is traced for the closest hit and for occlusion, on one thread and on two (rayon, chunks of rays).
//! The project answers closest-hit queries with the full [`geometry::Hit`] the renderer uses (point, error bounds,
//! normals, uv, tangents, ids); Embree's `rtcIntersect1` fills its `RTCHit` (t, u, v, Ng, primID, geomID). Before
//! timing, every ray of every set is traced by both and their answers compared (see [`check_agreement`]).
//!
//! The Embree calls go through the small hand-written FFI below (only what this benchmark uses, for Embree 3.13's
//! C API in `embree3/rtcore*.h`).

use std::f32::consts::PI;
use std::hint::black_box;
use std::sync::Arc;
use std::time::Duration;

use criterion::measurement::{Measurement, ValueFormatter, WallTime};
use criterion::{Criterion, Throughput};
use geometry::accel::{Accel, GeometryScene};
use geometry::mesh::{MeshData, TriangleMesh};
use geometry::shapes::{coordinate_system, Shape};
use geometry::{LargeArray, Ray, Transform, Vec3};
use rayon::prelude::*;

mod support;
use support::hash01;

/// Embree 3's C API: the few declarations this benchmark needs.
#[allow(non_camel_case_types, non_snake_case, clippy::upper_case_acronyms)]
mod ffi {
    use std::ffi::{c_char, c_uint, c_void};

    pub type RTCDevice = *mut c_void;
    pub type RTCScene = *mut c_void;
    pub type RTCGeometry = *mut c_void;

    pub const RTC_GEOMETRY_TYPE_TRIANGLE: c_uint = 0;
    pub const RTC_BUFFER_TYPE_INDEX: c_uint = 0;
    pub const RTC_BUFFER_TYPE_VERTEX: c_uint = 1;
    pub const RTC_FORMAT_UINT3: c_uint = 0x5003;
    pub const RTC_FORMAT_FLOAT3: c_uint = 0x9003;
    pub const RTC_INVALID_GEOMETRY_ID: c_uint = u32::MAX;
    pub const RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT: c_uint = 0;
    pub const RTC_ERROR_NONE: c_uint = 0;
    pub const RTC_SCENE_FLAG_ROBUST: c_uint = 1 << 2;
    pub const RTC_BUILD_QUALITY_HIGH: c_uint = 2;

    /// `struct RTCRay` (rtcore_ray.h).
    #[repr(C, align(16))]
    #[derive(Clone, Copy, Debug)]
    pub struct RTCRay {
        pub org_x: f32,
        pub org_y: f32,
        pub org_z: f32,
        pub tnear: f32,
        pub dir_x: f32,
        pub dir_y: f32,
        pub dir_z: f32,
        pub time: f32,
        pub tfar: f32,
        pub mask: c_uint,
        pub id: c_uint,
        pub flags: c_uint,
    }

    /// `struct RTCHit` (rtcore_ray.h) with `RTC_MAX_INSTANCE_LEVEL_COUNT` 1, as Debian's build is configured.
    #[repr(C, align(16))]
    #[derive(Clone, Copy, Debug)]
    pub struct RTCHit {
        pub Ng_x: f32,
        pub Ng_y: f32,
        pub Ng_z: f32,
        pub u: f32,
        pub v: f32,
        pub primID: c_uint,
        pub geomID: c_uint,
        pub instID: [c_uint; 1],
    }

    /// `struct RTCRayHit` (rtcore_ray.h).
    #[repr(C)]
    #[derive(Clone, Copy, Debug)]
    pub struct RTCRayHit {
        pub ray: RTCRay,
        pub hit: RTCHit,
    }

    /// `struct RTCIntersectContext` (rtcore_common.h) for `RTC_MAX_INSTANCE_LEVEL_COUNT` 1 and `RTC_MIN_WIDTH` 0.
    #[repr(C)]
    #[derive(Clone, Copy, Debug)]
    pub struct RTCIntersectContext {
        pub flags: c_uint,
        pub filter: Option<unsafe extern "C" fn(*const c_void)>,
        pub instID: [c_uint; 1],
    }

    // The layouts the C compiler gives these structs on x86-64.
    const _: () = assert!(std::mem::size_of::<RTCRay>() == 48 && std::mem::align_of::<RTCRay>() == 16);
    const _: () = assert!(std::mem::size_of::<RTCHit>() == 32 && std::mem::align_of::<RTCHit>() == 16);
    const _: () = assert!(std::mem::size_of::<RTCRayHit>() == 80);
    const _: () = assert!(std::mem::size_of::<RTCIntersectContext>() == 24);

    impl RTCIntersectContext {
        /// The equivalent of the header's inline `rtcInitIntersectContext`: incoherent, no filter, no instance.
        pub fn new() -> Self {
            Self { flags: RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT, filter: None, instID: [RTC_INVALID_GEOMETRY_ID] }
        }
    }

    #[link(name = "embree3")]
    extern "C" {
        pub fn rtcNewDevice(config: *const c_char) -> RTCDevice;
        pub fn rtcReleaseDevice(device: RTCDevice);
        pub fn rtcGetDeviceError(device: RTCDevice) -> c_uint;
        pub fn rtcNewScene(device: RTCDevice) -> RTCScene;
        pub fn rtcReleaseScene(scene: RTCScene);
        pub fn rtcAttachGeometry(scene: RTCScene, geometry: RTCGeometry) -> c_uint;
        pub fn rtcCommitScene(scene: RTCScene);
        pub fn rtcSetSceneFlags(scene: RTCScene, flags: c_uint);
        pub fn rtcSetSceneBuildQuality(scene: RTCScene, quality: c_uint);
        pub fn rtcNewGeometry(device: RTCDevice, kind: c_uint) -> RTCGeometry;
        pub fn rtcSetNewGeometryBuffer(
            geometry: RTCGeometry,
            kind: c_uint,
            slot: c_uint,
            format: c_uint,
            byte_stride: usize,
            item_count: usize,
        ) -> *mut c_void;
        pub fn rtcCommitGeometry(geometry: RTCGeometry);
        pub fn rtcReleaseGeometry(geometry: RTCGeometry);
        pub fn rtcIntersect1(scene: RTCScene, context: *mut RTCIntersectContext, rayhit: *mut RTCRayHit);
        pub fn rtcOccluded1(scene: RTCScene, context: *mut RTCIntersectContext, ray: *mut RTCRay);
    }
}

/// An Embree device and a committed scene of one triangle mesh.
struct EmbreeScene {
    device: ffi::RTCDevice,
    scene: ffi::RTCScene,
}

// SAFETY: after `rtcCommitScene` the scene is only read; Embree documents `rtcIntersect1` and `rtcOccluded1` on a
// committed scene as safe to call from any number of threads at once, and the handles are plain pointers to
// reference-counted objects that `Drop` releases once.
unsafe impl Send for EmbreeScene {}
// SAFETY: see `Send`: shared references only ever trace rays.
unsafe impl Sync for EmbreeScene {}

/// An Embree ray for `o + t·d`, `t` in `[0, t_max]` (`t` in units of `|d|`, as in the project).
fn embree_ray(r: &Ray, t_max: f32) -> ffi::RTCRay {
    ffi::RTCRay {
        org_x: r.o.x,
        org_y: r.o.y,
        org_z: r.o.z,
        tnear: 0.0,
        dir_x: r.d.x,
        dir_y: r.d.y,
        dir_z: r.d.z,
        time: 0.0,
        tfar: t_max,
        mask: u32::MAX,
        id: 0,
        flags: 0,
    }
}

impl EmbreeScene {
    /// Builds Embree's BVH over the triangles (`indices` in threes): with the default settings, or with the robust
    /// (watertight) triangle test and/or the high-quality (spatial-split) build if asked.
    fn new(positions: &[Vec3], indices: &[u32], robust: bool, high_quality: bool) -> Self {
        assert!(indices.len().is_multiple_of(3) && indices.iter().all(|&i| (i as usize) < positions.len()));
        // SAFETY: a null configuration string is documented as "default configuration".
        let device = unsafe { ffi::rtcNewDevice(std::ptr::null()) };
        assert!(!device.is_null(), "Embree: rtcNewDevice failed");
        // SAFETY: `device` is a live device.
        let scene = unsafe { ffi::rtcNewScene(device) };
        // SAFETY: `device` is a live device; the geometry type is a valid enum value.
        let geom = unsafe { ffi::rtcNewGeometry(device, ffi::RTC_GEOMETRY_TYPE_TRIANGLE) };
        assert!(!scene.is_null() && !geom.is_null(), "Embree: scene or geometry creation failed");
        // SAFETY: `scene` is live and not yet committed; the flag and quality are valid enum values.
        unsafe {
            if robust {
                ffi::rtcSetSceneFlags(scene, ffi::RTC_SCENE_FLAG_ROBUST);
            }
            if high_quality {
                ffi::rtcSetSceneBuildQuality(scene, ffi::RTC_BUILD_QUALITY_HIGH);
            }
        }
        // SAFETY: `geom` is live; Embree allocates (with its own padding) a buffer of `positions.len()` items of 12
        // bytes, which we fill with exactly that many floats before committing.
        unsafe {
            let v = ffi::rtcSetNewGeometryBuffer(
                geom,
                ffi::RTC_BUFFER_TYPE_VERTEX,
                0,
                ffi::RTC_FORMAT_FLOAT3,
                12,
                positions.len(),
            ) as *mut f32;
            assert!(!v.is_null(), "Embree: vertex buffer allocation failed");
            for (k, p) in positions.iter().enumerate() {
                v.add(3 * k).write(p.x);
                v.add(3 * k + 1).write(p.y);
                v.add(3 * k + 2).write(p.z);
            }
        }
        // SAFETY: as above, a buffer of `indices.len() / 3` items of three u32, filled with exactly that many.
        unsafe {
            let ib = ffi::rtcSetNewGeometryBuffer(
                geom,
                ffi::RTC_BUFFER_TYPE_INDEX,
                0,
                ffi::RTC_FORMAT_UINT3,
                12,
                indices.len() / 3,
            ) as *mut u32;
            assert!(!ib.is_null(), "Embree: index buffer allocation failed");
            std::ptr::copy_nonoverlapping(indices.as_ptr(), ib, indices.len());
        }
        // SAFETY: `geom` and `scene` are live and the buffers are filled; attaching keeps a reference to the geometry
        // in the scene, so ours is released; the scene is committed (built) before any ray is traced.
        let error = unsafe {
            ffi::rtcCommitGeometry(geom);
            let id = ffi::rtcAttachGeometry(scene, geom);
            assert_eq!(id, 0, "the mesh is the scene's first geometry");
            ffi::rtcReleaseGeometry(geom);
            ffi::rtcCommitScene(scene);
            ffi::rtcGetDeviceError(device)
        };
        assert_eq!(error, ffi::RTC_ERROR_NONE, "Embree reported error {error} while building");
        Self { device, scene }
    }

    /// The closest hit with `0 ≤ t ≤ t_max`: `(t, primitive, u, v, Ng)`.
    #[inline]
    fn intersect(&self, r: &Ray, t_max: f32) -> Option<ffi::RTCRayHit> {
        let mut context = ffi::RTCIntersectContext::new();
        let mut rh = ffi::RTCRayHit {
            ray: embree_ray(r, t_max),
            hit: ffi::RTCHit {
                Ng_x: 0.0,
                Ng_y: 0.0,
                Ng_z: 0.0,
                u: 0.0,
                v: 0.0,
                primID: ffi::RTC_INVALID_GEOMETRY_ID,
                geomID: ffi::RTC_INVALID_GEOMETRY_ID,
                instID: [ffi::RTC_INVALID_GEOMETRY_ID],
            },
        };
        // SAFETY: the scene is committed and only read; `context` and `rh` are valid, 16-byte aligned, and live for
        // the call, as `rtcIntersect1` requires.
        unsafe { ffi::rtcIntersect1(self.scene, &mut context, &mut rh) };
        (rh.hit.geomID != ffi::RTC_INVALID_GEOMETRY_ID).then_some(rh)
    }

    /// True if anything is hit with `0 ≤ t ≤ t_max`.
    #[inline]
    fn occluded(&self, r: &Ray, t_max: f32) -> bool {
        let mut context = ffi::RTCIntersectContext::new();
        let mut ray = embree_ray(r, t_max);
        // SAFETY: as in `intersect`; Embree sets `tfar` to −∞ when the ray is occluded.
        unsafe { ffi::rtcOccluded1(self.scene, &mut context, &mut ray) };
        ray.tfar == f32::NEG_INFINITY
    }
}

impl Drop for EmbreeScene {
    fn drop(&mut self) {
        // SAFETY: both handles are live and released exactly once; no ray is being traced (we own `self`).
        unsafe {
            ffi::rtcReleaseScene(self.scene);
            ffi::rtcReleaseDevice(self.device);
        }
    }
}

/// The calling thread's CPU time (Linux `CLOCK_THREAD_CPUTIME_ID`), for criterion: on a machine shared with other
/// jobs, time the thread was not running is not counted, so the one-thread rates are far less noisy than by wall
/// clock. Only meaningful for work done on the calling thread (the one-thread benchmarks).
struct ThreadCpuTime;

/// `struct timespec` on x86-64 Linux.
#[repr(C)]
struct Timespec {
    tv_sec: i64,
    tv_nsec: i64,
}

extern "C" {
    /// POSIX `clock_gettime` (from the C library the standard library already links).
    fn clock_gettime(clock: i32, tp: *mut Timespec) -> i32;
}

/// Linux's `CLOCK_THREAD_CPUTIME_ID`.
const CLOCK_THREAD_CPUTIME_ID: i32 = 3;

impl ThreadCpuTime {
    fn now_ns() -> u64 {
        let mut ts = Timespec { tv_sec: 0, tv_nsec: 0 };
        // SAFETY: `ts` is a valid, writable `struct timespec`; the clock id is a valid Linux clock.
        let rc = unsafe { clock_gettime(CLOCK_THREAD_CPUTIME_ID, &mut ts) };
        assert_eq!(rc, 0, "clock_gettime(CLOCK_THREAD_CPUTIME_ID) failed");
        ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
    }
}

impl Measurement for ThreadCpuTime {
    type Intermediate = u64;
    type Value = u64;
    fn start(&self) -> u64 {
        Self::now_ns()
    }
    fn end(&self, start: u64) -> u64 {
        Self::now_ns() - start
    }
    fn add(&self, a: &u64, b: &u64) -> u64 {
        a + b
    }
    fn zero(&self) -> u64 {
        0
    }
    fn to_f64(&self, v: &u64) -> f64 {
        *v as f64
    }
    fn formatter(&self) -> &dyn ValueFormatter {
        &CpuFormatter
    }
}

/// Formats CPU nanoseconds as milliseconds and element throughput as millions per CPU-second.
struct CpuFormatter;

impl ValueFormatter for CpuFormatter {
    fn scale_values(&self, _typical: f64, values: &mut [f64]) -> &'static str {
        values.iter_mut().for_each(|v| *v *= 1e-6);
        "ms (CPU)"
    }
    fn scale_throughputs(&self, _typical: f64, throughput: &Throughput, values: &mut [f64]) -> &'static str {
        let n = match *throughput {
            Throughput::Elements(n) | Throughput::Bytes(n) | Throughput::BytesDecimal(n) | Throughput::Bits(n) => n,
        };
        values.iter_mut().for_each(|v| *v = n as f64 * 1e3 / *v);
        "M/CPU-s"
    }
    fn scale_for_machines(&self, _values: &mut [f64]) -> &'static str {
        "ns"
    }
}

/// A lat-long sphere of radius about `radius` and `2·n·n` triangles with radial bumps, appended to `data`.
fn bumpy_sphere(data: &mut MeshData, radius: f32, n: usize) {
    let base = data.positions.len() as u32;
    for j in 0..=n {
        let theta = PI * j as f32 / n as f32;
        for i in 0..n {
            let phi = 2.0 * PI * i as f32 / n as f32;
            let r =
                1.0 + 0.05 * (7.0 * theta).sin() * (5.0 * phi).cos() + 0.01 * (31.0 * theta).sin() * (23.0 * phi).cos();
            let dir = Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
            data.positions.push(radius * r * dir);
        }
    }
    let v = |i: usize, j: usize| base + (j * n + i % n) as u32;
    for j in 0..n {
        for i in 0..n {
            data.indices.extend([v(i, j), v(i + 1, j + 1), v(i + 1, j), v(i, j), v(i, j + 1), v(i + 1, j + 1)]);
        }
    }
}

/// The scene, one mesh: a bumpy sphere of radius 1 and `2·n·n` triangles inside a bumpy spherical room of radius 5
/// and `2·m·m` triangles (closed, so that every ray from inside hits something).
fn scene_mesh(n: usize, m: usize) -> MeshData {
    let mut data = MeshData::default();
    bumpy_sphere(&mut data, 1.0, n);
    bumpy_sphere(&mut data, 5.0, m);
    data
}

/// Pinhole camera rays through a `res × res` grid of pixel centres.
fn camera_rays(res: usize) -> Vec<Ray> {
    let eye = Vec3::new(0.0, -3.6, 1.4);
    let forward = (Vec3::new(0.0, 0.0, -0.4) - eye).normalize();
    let right = forward.cross(Vec3::Z).normalize();
    let up = right.cross(forward);
    let half = (45f32.to_radians() / 2.0).tan();
    let mut rays = Vec::with_capacity(res * res);
    for y in 0..res {
        for x in 0..res {
            let sx = (2.0 * (x as f32 + 0.5) / res as f32 - 1.0) * half;
            let sy = (1.0 - 2.0 * (y as f32 + 0.5) / res as f32) * half;
            rays.push(Ray::new(eye, (forward + sx * right + sy * up).normalize()));
        }
    }
    rays
}

/// A set of rays with the `t_max` they are traced with.
struct RaySet {
    name: &'static str,
    rays: Vec<Ray>,
    t_max: Vec<f32>,
}

/// The camera, bounce and shadow ray sets, `count` rays each; the hits the latter start from are found with `scene`.
fn ray_sets(scene: &GeometryScene, res: usize) -> Vec<RaySet> {
    let camera = camera_rays(res);
    let count = camera.len();
    // Surface points seen by the camera, with the normal turned towards the camera.
    let hits: Vec<(geometry::Hit, Vec3)> = camera
        .iter()
        .filter_map(|r| scene.intersect(r, f32::INFINITY).map(|h| (h, if h.n.dot(r.d) > 0.0 { -h.n } else { h.n })))
        .collect();
    assert!(hits.len() > count / 2, "the camera sees the scene");
    let pick = |k: u64| &hits[((hash01(k) as f64 * hits.len() as f64) as usize).min(hits.len() - 1)];
    // Diffuse bounces: cosine-weighted directions (Malley's method) about the facing normal.
    let bounce: Vec<Ray> = (0..count as u64)
        .map(|k| {
            let (h, n) = pick(4 * k);
            let (u1, u2) = (hash01(4 * k + 1), hash01(4 * k + 2));
            let (r, phi) = (u1.sqrt(), 2.0 * PI * u2);
            let (s, t) = coordinate_system(*n);
            let w = r * phi.cos() * s + r * phi.sin() * t + (1.0 - u1).max(0.0).sqrt() * *n;
            h.spawn_ray(w)
        })
        .collect();
    // Shadow rays to a 2×2 square light at z = 3, from points on the side it lights.
    let mut shadow = Vec::with_capacity(count);
    let mut shadow_t = Vec::with_capacity(count);
    let mut k = 0u64;
    while shadow.len() < count {
        k += 1;
        let (h, n) = pick(3 * k);
        let q = Vec3::new(1.5 + 2.0 * hash01(3 * k + 1) - 1.0, -1.0 + 2.0 * hash01(3 * k + 2) - 1.0, 3.0);
        if (q - h.p).dot(*n) > 0.0 {
            let (r, t) = h.spawn_ray_to_point(q);
            shadow.push(r);
            shadow_t.push(t);
        }
    }
    vec![
        RaySet { name: "camera", t_max: vec![f32::INFINITY; count], rays: camera },
        RaySet { name: "bounce", t_max: vec![f32::INFINITY; count], rays: bounce },
        RaySet { name: "shadow", rays: shadow, t_max: shadow_t },
    ]
}

/// Traces every ray of `set` with both and compares: closest hits must agree on hit or miss, on the primitive and on
/// `t` (1e-4 relative, or a few ulps of the coordinates next to the origin), Embree's barycentrics must rebuild the project's hit point, and Ng must be parallel to the
/// project's normal; occlusion answers must agree. Prints the counts and fails if more than 0.1% of the rays
/// disagree.
fn check_agreement(set: &RaySet, mesh: &TriangleMesh, ours: &GeometryScene, embree: &EmbreeScene) {
    let n = set.rays.len();
    let (mut hits, mut hit_miss, mut other_prim, mut t_off, mut geom_off, mut occl) = (0, 0, 0, 0, 0, 0);
    let mut max_rel_t = 0f32;
    for (r, &t_max) in set.rays.iter().zip(&set.t_max) {
        match (ours.intersect(r, t_max), embree.intersect(r, t_max)) {
            (Some(a), Some(b)) => {
                hits += 1;
                max_rel_t = max_rel_t.max((a.t - b.ray.tfar).abs() / a.t);
                // 1e-4 relative, or a few ulps of the coordinates for hits next to the origin (where that is all
                // the precision a `t` can have).
                let ulps = 16.0 * f32::EPSILON * (r.o.abs().max_element() + a.t * r.d.abs().max_element());
                if (a.t - b.ray.tfar).abs() > (1e-4 * a.t).max(ulps / r.d.length()) {
                    t_off += 1;
                }
                if a.primitive != b.hit.primID {
                    other_prim += 1;
                } else {
                    let [p0, p1, p2] = mesh.triangle_positions(b.hit.primID as usize);
                    let p = (1.0 - b.hit.u - b.hit.v) * p0 + b.hit.u * p1 + b.hit.v * p2;
                    let ng = Vec3::new(b.hit.Ng_x, b.hit.Ng_y, b.hit.Ng_z).normalize();
                    if (p - a.p).length() > 1e-4 * a.t.max(1.0) || ng.dot(a.n).abs() < 0.9999 {
                        geom_off += 1;
                    }
                }
            }
            (None, None) => {}
            _ => hit_miss += 1,
        }
        if ours.occluded(r, t_max) != embree.occluded(r, t_max) {
            occl += 1;
        }
    }
    eprintln!(
        "{}: {n} rays, {hits} hit by both; disagreements: hit/miss {hit_miss}, primitive {other_prim}, t {t_off} \
         (largest relative t difference {max_rel_t:.1e}), point or normal {geom_off}, occlusion {occl}",
        set.name
    );
    let limit = n / 1000;
    assert!(
        hit_miss + other_prim <= limit && t_off <= limit && geom_off <= limit && occl <= limit,
        "{}: the project's BVH and Embree disagree on more than 0.1% of the rays",
        set.name
    );
}

/// Rays per parallel task on two threads.
const CHUNK: usize = 256;

/// Sets everything up, checks the two agree, and registers the benchmarks (two-thread ones only by wall clock).
fn bench<M: Measurement>(c: &mut Criterion<M>, wall_clock: bool) {
    let data = scene_mesh(640, 320);
    let tris = data.triangle_count();
    let mesh = Arc::new(TriangleMesh::new(&Transform::IDENTITY, data, false).unwrap());
    let ours = GeometryScene::from_shapes(vec![Shape::Mesh(mesh.clone())]).unwrap();
    // `TRAVERSAL_EMBREE_ROBUST=1`: Embree's watertight triangle test; `TRAVERSAL_EMBREE_QUALITY=high`: its
    // spatial-split build. Both off by default (Embree's defaults).
    let robust = std::env::var("TRAVERSAL_EMBREE_ROBUST").is_ok_and(|v| v == "1");
    let high = std::env::var("TRAVERSAL_EMBREE_QUALITY").is_ok_and(|v| v == "high");
    let start = std::time::Instant::now();
    let embree = EmbreeScene::new(mesh.positions(), mesh.indices(), robust, high);
    eprintln!(
        "{tris} triangles; build: project {:.0} ms, Embree {:.0} ms (robust: {robust}, high quality: {high})",
        ours.build_time().as_secs_f64() * 1e3,
        start.elapsed().as_secs_f64() * 1e3
    );
    let sets = ray_sets(&ours, 256);
    let st = ours.bvh_stats();
    eprintln!(
        "project BVH: {} nodes in {} levels, {} leaves ({:.2} triangles each), {:.1} MB of nodes and {:.1} MB of \
         leaves; SAH {:.2} (nodes {:.2}, leaves {:.2}; Embree's `verbose=2` prints its own in the same convention)",
        st.nodes,
        st.depth,
        st.leaves,
        st.primitives as f64 / st.leaves.max(1) as f64,
        st.node_bytes as f64 / 1e6,
        st.leaf_bytes as f64 / 1e6,
        st.sah_nodes + st.sah_leaves,
        st.sah_nodes,
        st.sah_leaves
    );
    for set in &sets {
        check_agreement(set, &mesh, &ours, &embree);
    }
    if let Some(rounds) = std::env::var("TRAVERSAL_INTERLEAVED").ok().and_then(|v| v.parse::<usize>().ok()) {
        interleaved(rounds.max(1), &sets, &ours, &embree);
        return;
    }
    let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
    // `TRAVERSAL_EMBREE_FIRST=1` swaps the order within each pair, so that repeated runs can alternate it.
    let embree_first = std::env::var("TRAVERSAL_EMBREE_FIRST").is_ok_and(|v| v == "1");
    for set in &sets {
        for query in ["closest", "occluded"] {
            for &threads in if wall_clock { &[1, 2][..] } else { &[1][..] } {
                let mut g = c.benchmark_group(format!("{query}_{}_{threads}t", set.name));
                g.throughput(Throughput::Elements(set.rays.len() as u64));
                let rays: Vec<(Ray, f32)> = set.rays.iter().copied().zip(set.t_max.iter().copied()).collect();
                let run_ours = |(r, t): &(Ray, f32)| match query {
                    "closest" => black_box(ours.intersect(black_box(r), *t)).is_some(),
                    _ => ours.occluded(black_box(r), *t),
                };
                let run_embree = |(r, t): &(Ray, f32)| match query {
                    "closest" => black_box(embree.intersect(black_box(r), *t)).is_some(),
                    _ => embree.occluded(black_box(r), *t),
                };
                let trace = |f: &(dyn Fn(&(Ray, f32)) -> bool + Sync)| -> usize {
                    if threads == 1 {
                        rays.iter().filter(|x| f(x)).count()
                    } else {
                        pool.install(|| rays.par_chunks(CHUNK).map(|c| c.iter().filter(|x| f(x)).count()).sum())
                    }
                };
                for who in if embree_first { ["embree", "prismatic"] } else { ["prismatic", "embree"] } {
                    g.bench_function(who, |b| {
                        b.iter(|| if who == "embree" { trace(&run_embree) } else { trace(&run_ours) })
                    });
                }
                g.finish();
            }
        }
    }
}

/// Mean time of one load in a chain of dependent loads, each from a random cache line of `bytes` of memory (a
/// single random cycle through the lines, in a [`LargeArray`]: 2 MB pages, placed as the project's BVH arrays are),
/// in nanoseconds. Where the benchmark's ~65 MB per side do not fit in the caches, the rate at which memory answers
/// moves the ratio between the two sides (BENCHMARKS.md, "The memory's state"), so interleaved runs print this
/// before and after their rounds.
fn load_latency_ns(bytes: usize) -> f64 {
    /// One cache line, holding the index of the next line in the chain.
    #[derive(Clone, Copy)]
    #[repr(C, align(64))]
    struct Line(usize);
    let lines = bytes / 64;
    // Sattolo's shuffle: a random permutation that is one cycle through every line.
    let mut order: Vec<u32> = (0..lines as u32).collect();
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    for i in (1..lines).rev() {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        order.swap(i, (state % i as u64) as usize);
    }
    let mut chain = vec![Line(0); lines];
    for (i, &line) in order.iter().enumerate() {
        chain[line as usize] = Line(order[(i + 1) % lines] as usize);
    }
    let memory = LargeArray::new(chain);
    let mut at = order[0] as usize;
    for _ in 0..lines {
        at = memory[at].0;
    }
    let loads = 4_000_000;
    let start = std::time::Instant::now();
    for _ in 0..loads {
        at = memory[at].0;
    }
    black_box(at);
    start.elapsed().as_nanos() as f64 / loads as f64
}

/// Prints [`load_latency_ns`] over 64 MB (about one side's BVH) and 4 MB, prefixed with `when`.
fn print_load_latency(when: &str) {
    println!(
        "memory latency {when}: {:.0} ns per random load over 64 MB, {:.0} ns over 4 MB",
        load_latency_ns(64 << 20),
        load_latency_ns(4 << 20)
    );
}

/// `TRAVERSAL_INTERLEAVED=N` (instead of criterion's benchmarks): for each set and query, `N` rounds on this
/// thread, each tracing the whole set with the project and with Embree back to back (the order alternating
/// between rounds; each timed pass after an untimed one of the same side), timed by the thread's CPU time; prints
/// the median rates and the median of the rounds' ratios with its quartiles. The two timings of a round are close
/// together, so the drift of a shared machine, which moves criterion's separately timed benchmarks, cancels in each
/// ratio. `TRAVERSAL_LOG_ROUNDS=1` prints each round's two times;
/// `TRAVERSAL_ONLY=occluded_bounce` (say) runs only the queries whose `query_set` name contains it.
/// `TRAVERSAL_INTERLEAVED_THREADS=2`: each pass on two threads (rayon over chunks of [`CHUNK`] rays, as the
/// criterion benchmarks' two-thread rows), timed by the wall clock, so that the two sides share the caches and the
/// memory bus as a two-thread renderer does.
fn interleaved(rounds: usize, sets: &[RaySet], ours: &GeometryScene, embree: &EmbreeScene) {
    // The value at fraction `f` of the sorted values (0.5: the median).
    let quantile = |v: &mut Vec<f64>, f: f64| {
        v.sort_by(f64::total_cmp);
        v[((v.len() - 1) as f64 * f).round() as usize]
    };
    let two_threads = std::env::var("TRAVERSAL_INTERLEAVED_THREADS").is_ok_and(|v| v == "2");
    let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
    let unit = if two_threads { "Mrays/s, 2 threads" } else { "Mrays/CPU-s" };
    print_load_latency("before");
    println!("| query | rays | project {unit} | Embree {unit} | project / Embree, median (quartiles) |");
    println!("|---|---|---|---|---|");
    let only = std::env::var("TRAVERSAL_ONLY").unwrap_or_default();
    for query in ["closest", "occluded"] {
        for set in sets.iter().filter(|s| format!("{query}_{}", s.name).contains(&only)) {
            let trace = |embree_side: bool, rays: &[Ray], t_max: &[f32]| {
                let mut n = 0usize;
                for (r, &t) in rays.iter().zip(t_max) {
                    let hit = match (query, embree_side) {
                        ("closest", false) => black_box(ours.intersect(black_box(r), t)).is_some(),
                        ("closest", true) => black_box(embree.intersect(black_box(r), t)).is_some(),
                        (_, false) => ours.occluded(black_box(r), t),
                        (_, true) => embree.occluded(black_box(r), t),
                    };
                    n += usize::from(hit);
                }
                black_box(n)
            };
            let time = |embree_side: bool| {
                if two_threads {
                    let start = std::time::Instant::now();
                    let n: usize = pool.install(|| {
                        set.rays
                            .par_chunks(CHUNK)
                            .zip(set.t_max.par_chunks(CHUNK))
                            .map(|(r, t)| trace(embree_side, r, t))
                            .sum()
                    });
                    black_box(n);
                    start.elapsed().as_nanos() as f64
                } else {
                    let start = ThreadCpuTime::now_ns();
                    trace(embree_side, &set.rays, &set.t_max);
                    (ThreadCpuTime::now_ns() - start) as f64
                }
            };
            let (mut ours_ns, mut embree_ns, mut ratios) = (Vec::new(), Vec::new(), Vec::new());
            for round in 0..rounds {
                // Each timed pass right after an untimed one of the same side: a pass after the other side's runs
                // slower (the other's 65 MB of nodes and triangles have replaced its own in the caches; BENCHMARKS.md,
                // "Traversal against Embree 3"), and a renderer only ever runs its own.
                let pass = |embree_side: bool| {
                    time(embree_side);
                    time(embree_side)
                };
                let (a, b) = if round.is_multiple_of(2) {
                    let a = pass(false);
                    (a, pass(true))
                } else {
                    let b = pass(true);
                    (pass(false), b)
                };
                ours_ns.push(a);
                embree_ns.push(b);
                ratios.push(b / a);
                if std::env::var("TRAVERSAL_LOG_ROUNDS").is_ok() {
                    eprintln!("{query} {} round {round}: ours {:.1} ms, embree {:.1} ms", set.name, a * 1e-6, b * 1e-6);
                }
            }
            let rate = |ns: f64| set.rays.len() as f64 / ns * 1e3;
            let (o, e) = (rate(quantile(&mut ours_ns, 0.5)), rate(quantile(&mut embree_ns, 0.5)));
            let [q1, q2, q3] = [0.25, 0.5, 0.75].map(|f| quantile(&mut ratios, f));
            println!("| {query} | {} | {o:.2} | {e:.2} | {q2:.3} ({q1:.3}–{q3:.3}) |", set.name);
        }
    }
    print_load_latency("after");
}

fn main() {
    // `TRAVERSAL_CPU_TIME=1`: time by the thread's CPU time (one-thread benchmarks only), see [`ThreadCpuTime`].
    let cpu_time = std::env::var("TRAVERSAL_CPU_TIME").is_ok_and(|v| v == "1");
    if cpu_time {
        let mut c = config(Criterion::default().with_measurement(ThreadCpuTime));
        bench(&mut c, false);
        c.final_summary();
    } else {
        let mut c = config(Criterion::default().with_measurement(WallTime));
        bench(&mut c, true);
        c.final_summary();
    }
}

/// Short runs by default (command-line options override them).
fn config<M: Measurement>(c: Criterion<M>) -> Criterion<M> {
    c.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .configure_from_args()
}
