//! A film's accumulators as plain data, to be stored (checkpoints, the parts of a sharded render) and put back.
//!
//! The state is a list of named *planes*, one `f64` per pixel of the film's bounds (row-major from the top row),
//! plus the counts that are not per pixel. Plane names: `X`, `Y`, `Z` (weighted XYZ sums), `W` (filter-weight
//! sums), `S<b>` for spectral bucket `b` (weighted sums); with AOVs `albedo.R/G/B`, `N.X/Y/Z` and `aovCount`; with
//! a gbuffer its sums (`gbuffer.W`, `P.X/Y/Z`, `Ng.X/Y/Z`, `u`, `v`, `dzdx`, `dzdy`, `variance.n`,
//! `variance.R/G/B` and `variance.R2/G2/B2`: see the `gbuffer` module); after the first splat `splat.X/Y/Z` and
//! `splat.S<b>`. A state put back with [`Film::paste`] gives a film whose every
//! accumulator has the same bits, so a render continued from it is the render that was never stopped.

use super::{gbuffer, zeroed, Film, PixelBounds};
use crate::FilmError;
use std::collections::BTreeMap;

/// One accumulator of every pixel of a film's bounds.
#[derive(Clone, Debug, PartialEq)]
pub struct Plane {
    /// The accumulator's name (see the module documentation).
    pub name: String,
    /// One value per pixel of the bounds, row-major from the top row.
    pub values: Vec<f64>,
}

/// A film's accumulators: see the module documentation.
#[derive(Clone, Debug, PartialEq)]
pub struct FilmState {
    /// The pixels the planes cover, in full-image coordinates.
    pub bounds: PixelBounds,
    /// The per-pixel accumulators.
    pub planes: Vec<Plane>,
    /// Light paths whose splats were added (see [`Film::add_light_paths`]).
    pub light_paths: f64,
    /// Camera samples dropped for non-finite values.
    pub rejected_samples: u64,
    /// Splats dropped for non-finite values.
    pub rejected_splats: u64,
}

impl FilmState {
    /// Whether the state holds splat sums.
    pub fn has_splats(&self) -> bool {
        self.planes.iter().any(|p| p.name == "splat.X")
    }
}

fn mismatch(msg: impl Into<String>) -> FilmError {
    FilmError::Mismatch(msg.into())
}

impl Film {
    /// The names of this film's planes, in the order [`Film::state`] lists them, with or without the splat planes.
    pub fn plane_names(&self, splats: bool) -> Vec<String> {
        let nb = self.nbuckets;
        let mut names: Vec<String> = ["X", "Y", "Z", "W"].iter().map(|s| s.to_string()).collect();
        names.extend((0..nb).map(|b| format!("S{b}")));
        if self.spec.aovs {
            for n in ["albedo.R", "albedo.G", "albedo.B", "N.X", "N.Y", "N.Z", "aovCount"] {
                names.push(n.to_string());
            }
        }
        if self.spec.gbuffer.is_some() {
            names.extend(gbuffer::PLANE_NAMES.iter().map(|s| s.to_string()));
        }
        if splats {
            names.extend(["splat.X", "splat.Y", "splat.Z"].iter().map(|s| s.to_string()));
            names.extend((0..nb).map(|b| format!("splat.S{b}")));
        }
        names
    }

    /// The film's accumulators (a copy).
    pub fn state(&self) -> FilmState {
        let npix = self.weight.len();
        let nb = self.nbuckets;
        let splats = !self.splat_xyz.is_empty();
        let mut planes = Vec::new();
        let mut push = |name: String, values: Vec<f64>| planes.push(Plane { name, values });
        let c3 = |v: &[[f64; 3]], c: usize| v.iter().map(|a| a[c]).collect::<Vec<f64>>();
        let bucket = |v: &[f64], b: usize| (0..npix).map(|i| v[i * nb + b]).collect::<Vec<f64>>();
        for (c, n) in ["X", "Y", "Z"].iter().enumerate() {
            push(n.to_string(), c3(&self.xyz, c));
        }
        push("W".into(), self.weight.clone());
        for b in 0..nb {
            push(format!("S{b}"), bucket(&self.buckets, b));
        }
        if self.spec.aovs {
            for (c, n) in ["albedo.R", "albedo.G", "albedo.B"].iter().enumerate() {
                push(n.to_string(), c3(&self.albedo, c));
            }
            for (c, n) in ["N.X", "N.Y", "N.Z"].iter().enumerate() {
                push(n.to_string(), c3(&self.normal, c));
            }
            push("aovCount".into(), self.aov_count.clone());
        }
        if self.spec.gbuffer.is_some() {
            for (k, n) in gbuffer::PLANE_NAMES.iter().enumerate() {
                push(n.to_string(), self.surfaces.iter().map(|s| s[k]).collect());
            }
        }
        if splats {
            for (c, n) in ["splat.X", "splat.Y", "splat.Z"].iter().enumerate() {
                push(n.to_string(), c3(&self.splat_xyz, c));
            }
            for b in 0..nb {
                push(format!("splat.S{b}"), bucket(&self.splat_buckets, b));
            }
        }
        FilmState {
            bounds: self.bounds,
            planes,
            light_paths: self.light_paths,
            rejected_samples: self.rejected.iter().sum(),
            rejected_splats: self.rejected_splats,
        }
    }

    /// Checks that `state` has exactly this film's planes (with or without splats), each with one value per pixel
    /// of `state.bounds`, and returns them by name.
    fn check_planes<'s>(&self, state: &'s FilmState) -> Result<BTreeMap<&'s str, &'s [f64]>, FilmError> {
        let b = state.bounds;
        let npix = b.width() as usize * b.height() as usize;
        let expected = self.plane_names(state.has_splats());
        let mut by_name = BTreeMap::new();
        for p in &state.planes {
            if p.values.len() != npix {
                return Err(mismatch(format!(
                    "plane '{}' has {} values for {}×{} pixels",
                    p.name,
                    p.values.len(),
                    b.width(),
                    b.height()
                )));
            }
            if by_name.insert(p.name.as_str(), p.values.as_slice()).is_some() {
                return Err(mismatch(format!("plane '{}' appears twice", p.name)));
            }
        }
        let found: Vec<&str> = by_name.keys().copied().collect();
        let mut want: Vec<&str> = expected.iter().map(String::as_str).collect();
        want.sort_unstable();
        if found != want {
            return Err(mismatch(format!(
                "the stored accumulators [{}] are not this film's [{}] (another film kind, bucket count, AOV or gbuffer setting)",
                found.join(", "),
                want.join(", ")
            )));
        }
        if !(state.light_paths.is_finite() && state.light_paths >= 0.0) {
            return Err(mismatch(format!("light path count {} is not a count", state.light_paths)));
        }
        Ok(by_name)
    }

    /// Copies `state`'s accumulators into this film: the pixels of `state.bounds` (which must lie inside the film's
    /// bounds) get exactly the stored values; the counts of dropped samples are added. A state with splats or light
    /// paths must cover the film's whole bounds (splats are scaled per film), and its light-path count replaces
    /// the film's. With equal bounds this restores a film bit for bit.
    pub fn paste(&mut self, state: &FilmState) -> Result<(), FilmError> {
        let planes = self.check_planes(state)?;
        let (t, f) = (state.bounds, self.bounds);
        if t.width() == 0 || t.height() == 0 || t.x0 < f.x0 || t.y0 < f.y0 || t.x1 > f.x1 || t.y1 > f.y1 {
            return Err(mismatch(format!("pixels {t:?} are not inside the film's {f:?}")));
        }
        let whole = t == f;
        if !whole && (state.has_splats() || state.light_paths != 0.0) {
            return Err(mismatch("a part of the image with splats cannot be pasted: splats reach every pixel"));
        }
        self.allocate_splats_for(state)?;
        let (fw, tw) = (f.width() as usize, t.width() as usize);
        // Index in the film of pixel `j` of the state.
        let at = |j: usize| (t.y0 - f.y0) as usize * fw + (j / tw) * fw + (t.x0 - f.x0) as usize + j % tw;
        self.for_each_plane(|name, target, stride, offset| {
            if let Some(values) = planes.get(name) {
                for (j, v) in values.iter().enumerate() {
                    target[at(j) * stride + offset] = *v;
                }
            }
        });
        if whole {
            self.light_paths = state.light_paths;
        }
        self.rejected[(t.y0 - f.y0) as usize] += state.rejected_samples;
        self.rejected_splats += state.rejected_splats;
        Ok(())
    }

    /// Adds `state`'s accumulators to this film's (a render of other samples of the same pixels): the bounds must
    /// be the film's. Sums are added pixel by pixel, so the result equals one render of all the samples up to the
    /// rounding of the additions.
    pub fn add_state(&mut self, state: &FilmState) -> Result<(), FilmError> {
        let planes = self.check_planes(state)?;
        if state.bounds != self.bounds {
            return Err(mismatch(format!("pixels {:?} are not the film's {:?}", state.bounds, self.bounds)));
        }
        self.allocate_splats_for(state)?;
        self.for_each_plane(|name, target, stride, offset| {
            if let Some(values) = planes.get(name) {
                for (j, v) in values.iter().enumerate() {
                    target[j * stride + offset] += *v;
                }
            }
        });
        self.light_paths += state.light_paths;
        self.rejected[0] += state.rejected_samples;
        self.rejected_splats += state.rejected_splats;
        Ok(())
    }

    /// Allocates the splat sums (zero) if `state` has splats and the film none yet.
    fn allocate_splats_for(&mut self, state: &FilmState) -> Result<(), FilmError> {
        if state.has_splats() && self.splat_xyz.is_empty() {
            let npix = self.weight.len();
            let too_large = || mismatch("the splat accumulators do not fit in memory");
            self.splat_xyz = zeroed(npix, [0.0; 3]).ok_or_else(too_large)?;
            self.splat_buckets = zeroed(npix * self.nbuckets, 0.0).ok_or_else(too_large)?;
        }
        Ok(())
    }

    /// Calls `f(name, values, stride, offset)` for every plane the film holds: plane value of pixel `i` is
    /// `values[i * stride + offset]`.
    fn for_each_plane(&mut self, mut f: impl FnMut(&str, &mut [f64], usize, usize)) {
        let nb = self.nbuckets;
        for (c, n) in ["X", "Y", "Z"].iter().enumerate() {
            f(n, self.xyz.as_flattened_mut(), 3, c);
        }
        f("W", &mut self.weight, 1, 0);
        for b in 0..nb {
            f(&format!("S{b}"), &mut self.buckets, nb, b);
        }
        if self.spec.aovs {
            for (c, n) in ["albedo.R", "albedo.G", "albedo.B"].iter().enumerate() {
                f(n, self.albedo.as_flattened_mut(), 3, c);
            }
            for (c, n) in ["N.X", "N.Y", "N.Z"].iter().enumerate() {
                f(n, self.normal.as_flattened_mut(), 3, c);
            }
            f("aovCount", &mut self.aov_count, 1, 0);
        }
        if self.spec.gbuffer.is_some() {
            for (k, n) in gbuffer::PLANE_NAMES.iter().enumerate() {
                f(n, self.surfaces.as_flattened_mut(), gbuffer::NSUMS, k);
            }
        }
        if !self.splat_xyz.is_empty() {
            for (c, n) in ["splat.X", "splat.Y", "splat.Z"].iter().enumerate() {
                f(n, self.splat_xyz.as_flattened_mut(), 3, c);
            }
            for b in 0..nb {
                f(&format!("splat.S{b}"), &mut self.splat_buckets, nb, b);
            }
        }
    }
}
