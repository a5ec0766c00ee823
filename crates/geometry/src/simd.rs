//! The traversal's instruction set, chosen at run time.
//!
//! The BVH's node test has two builds ([`crate::wide::NodeTest`]): [`Portable`], two 4-wide halves that any x86-64
//! (or other) CPU runs, and [`Avx2`], one 8-wide pass. A query runs through [`with_best_simd!`], which checks once
//! per process whether the CPU has AVX2 and, if so, runs the query's whole traversal (loop, node test and leaf
//! tests, inlined or, for the closest-hit leaf test, in a function of its own) in code compiled for AVX2. One
//! binary thus serves every machine at the speed of the one it runs on. The top levels over instances keep the
//! portable test: they are small and seldom the cost.
//!
//! `PRISMATIC_SIMD=portable` in the environment forces the portable build, to compare the two: they give the same
//! hits, bit for bit (no float operation changes, only how many lanes an instruction holds).

/// The portable node test (see the module docs).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Portable;

/// Proof that the CPU has AVX2: [`Avx2::detect`] is the only way to make one.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
pub(crate) struct Avx2(());

#[cfg(target_arch = "x86_64")]
impl Avx2 {
    /// `Some` if the CPU has AVX2 and `PRISMATIC_SIMD` is not `portable` (checked once per process).
    #[inline(always)]
    pub(crate) fn detect() -> Option<Self> {
        static CHOICE: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
        let has = *CHOICE.get_or_init(|| {
            std::env::var("PRISMATIC_SIMD").map_or(true, |v| v != "portable")
                && std::arch::is_x86_feature_detected!("avx2")
        });
        has.then_some(Self(()))
    }

    /// `query()`, compiled with AVX2 enabled for everything inlined into it.
    #[inline(always)]
    pub(crate) fn run<R>(self, query: impl FnOnce() -> R) -> R {
        // SAFETY: `run_avx2` requires only that the CPU supports AVX2, which `self` proves (`detect` checked it
        // with `is_x86_feature_detected!`). Measured worth it: see BENCHMARKS.md, "Build settings".
        #[allow(unsafe_code)]
        unsafe {
            run_avx2(query)
        }
    }

    /// `f()`, compiled with AVX2 enabled, in a function of its own (not inlined into the caller).
    #[inline(always)]
    pub(crate) fn run_out_of_line<R>(self, f: impl FnOnce() -> R) -> R {
        // SAFETY: as for `run`: `self` proves the CPU supports AVX2.
        #[allow(unsafe_code)]
        unsafe {
            run_avx2_out_of_line(f)
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn run_avx2<R>(query: impl FnOnce() -> R) -> R {
    query()
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline(never)]
fn run_avx2_out_of_line<R>(f: impl FnOnce() -> R) -> R {
    f()
}

/// `with_best_simd!(t => body)`: evaluates `body` with `t` bound to the best node test for this CPU, [`Avx2`] (and
/// `body` compiled for AVX2) or [`Portable`]. `body` is expanded once for each.
macro_rules! with_best_simd {
    ($t:ident => $body:expr) => {{
        #[cfg(target_arch = "x86_64")]
        let result = match $crate::simd::Avx2::detect() {
            Some(token) => token.run(|| {
                let $t = token;
                $body
            }),
            None => {
                let $t = $crate::simd::Portable;
                $body
            }
        };
        #[cfg(not(target_arch = "x86_64"))]
        let result = {
            let $t = $crate::simd::Portable;
            $body
        };
        result
    }};
}
pub(crate) use with_best_simd;
