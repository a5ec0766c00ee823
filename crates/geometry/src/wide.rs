//! The BVH nodes as the traversal reads them (8-wide, with float child boxes; built in the `collapse` module) and
//! the two traversal loops over them.
//!
//! A node holds its eight child boxes as planes grouped by axis and side, so that the slab test reads them four
//! children per vector; it takes 256 bytes, four cache lines. (`obvhs`'s compressed 80-byte nodes, which the
//! project used before, quantise each plane to 8 bits and cost a conversion and a multiply-add per plane and visit.)
//!
//! The two loops, [`closest_first`] and [`any_hit`], serve both levels of the scene's BVH: their caller tests the
//! leaves (triangles and shapes of an object, or the instances of the top level).

use std::mem::MaybeUninit;

use glam::{Vec3, Vec4};
use obvhs::aabb::Aabb;

use crate::bounds::Bounds3;
#[cfg(target_arch = "x86_64")]
use crate::simd::Avx2;
use crate::simd::Portable;

/// Far-distance widening so float error never culls a box the ray touches (pbrt-v4's `1 + 2γ(3)`).
pub(crate) const FAR_SCALE: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// Ray data for the node test.
pub(crate) struct NodeRay {
    o: [f32; 3],
    /// The negated reciprocal direction: the test computes `(o − plane) · (−1/d)`, which is `(plane − o) · (1/d)`
    /// bit for bit but for the sign of a zero (rounding to nearest is symmetric), and lets the 8-wide build take
    /// each plane row straight from memory as the subtrahend.
    neg_inv_d: [f32; 3],
}

impl NodeRay {
    pub(crate) fn new(o: Vec3, d: Vec3) -> Self {
        // Clamp tiny components so no inf or NaN enters the slab test; 1e20 bounds keep every product finite.
        let inv = |x: f32| if x.abs() < 1e-20 { 1e20f32.copysign(x) } else { 1.0 / x };
        Self { o: o.to_array(), neg_inv_d: [-inv(d.x), -inv(d.y), -inv(d.z)] }
    }
}

/// One 8-wide node: its child boxes as float planes, and where each child is. Four cache lines, aligned to them.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(crate) struct WideNode {
    /// `planes[axis][side][child]`: child boxes' minimum (side 0) and maximum (side 1) planes (+∞ and −∞ in an
    /// empty slot, which the slab test masks out by `valid`).
    planes: [[[f32; 8]; 2]; 3],
    /// For an inner child its node index; for a leaf its first slot (the leaf's primitives are `count` slots from
    /// there); 0 for an empty slot.
    child: [u32; 8],
    /// The primitive count of each leaf child (0 for inner children and empty slots).
    count: [u8; 8],
    /// Bit `c` set if child `c` is an inner node.
    pub(crate) inner: u32,
    /// Bit `c` set if slot `c` holds a child: an empty slot's infinite planes give each axis the whole line as
    /// its interval in [`WideNode::slabs4`]'s lesser/greater form, so the test masks it out instead.
    valid: u32,
}

impl WideNode {
    /// A node with eight empty slots.
    pub(crate) const EMPTY: Self = Self {
        planes: [[[f32::INFINITY; 8], [f32::NEG_INFINITY; 8]]; 3],
        child: [0; 8],
        count: [0; 8],
        inner: 0,
        valid: 0,
    };

    /// Sets child `c`'s box.
    pub(crate) fn set_box(&mut self, c: usize, b: &Aabb) {
        for axis in 0..3 {
            self.planes[axis][0][c] = b.min[axis];
            self.planes[axis][1][c] = b.max[axis];
        }
        self.valid |= 1 << c;
    }

    /// Makes child `c` an inner node: node `index`.
    pub(crate) fn set_inner(&mut self, c: usize, index: u32) {
        self.child[c] = index;
        self.count[c] = 0;
        self.inner |= 1 << c;
    }

    /// Makes child `c` a leaf of the `count` primitives in slots `first..first + count` (`count` 1 to 255).
    pub(crate) fn set_leaf(&mut self, c: usize, first: u32, count: u32) {
        assert!((1..=255).contains(&count), "a BVH leaf holds 1 to 255 primitives, not {count}");
        self.child[c] = first;
        self.count[c] = count as u8;
        self.inner &= !(1 << c);
    }

    /// Child `c`'s box, if the slot is not empty.
    pub(crate) fn child_box(&self, c: usize) -> Option<Bounds3> {
        let p = &self.planes;
        let min = Vec3::new(p[0][0][c], p[1][0][c], p[2][0][c]);
        let max = Vec3::new(p[0][1][c], p[1][1][c], p[2][1][c]);
        (self.valid & (1 << c) != 0).then_some(Bounds3 { min, max })
    }

    /// Child `c`'s node index, if it is an inner node.
    #[cfg(test)]
    pub(crate) fn inner_child(&self, c: usize) -> Option<u32> {
        (self.inner & (1 << c) != 0).then_some(self.child[c])
    }

    /// The leaves among the children of `mask` as (first slot, primitive count), in slot order.
    #[inline(always)]
    pub(crate) fn leaves(&self, mask: u32) -> impl Iterator<Item = (u32, u32)> + '_ {
        let mut leaves = mask & !self.inner;
        std::iter::from_fn(move || {
            (leaves != 0).then(|| {
                let c = leaves.trailing_zeros() as usize;
                leaves &= leaves - 1;
                (self.child[c], self.count[c] as u32)
            })
        })
    }

    /// Slab test of the ray against the eight child boxes: bit `i` of the mask is set if the ray meets child
    /// `i`'s box with `t < t_max`, and the array holds each child's entry distance (clamped to 0). Four children
    /// per vector; [`NodeTest`] chooses this or the 8-wide build.
    ///
    /// `(plane − o) · (1/d)` carries only a relative error of a few ulps, and pbrt's `1 + 2γ(3)` widening of the
    /// far distance makes the test conservative (no ray that touches a box is culled, even one grazing a box face
    /// from an origin on that face). Each axis's entry and exit are the lesser and greater of its two planes'
    /// distances, which are ordered as the planes are (rounding is monotonic): the same values as choosing the
    /// planes by the direction's sign, without the per-ray row offsets.
    #[inline(always)]
    fn slabs4(&self, r: &NodeRay, t_max: f32) -> (u32, [f32; 8]) {
        let [ox, oy, oz] = r.o.map(Vec4::splat);
        let [ix, iy, iz] = r.neg_inv_d.map(Vec4::splat);
        let t_max4 = Vec4::splat(t_max);
        let mut mask = 0u32;
        let mut t_near = [0.0f32; 8];
        for i in 0..2 {
            let load = |axis: usize, side: usize| Vec4::from_slice(&self.planes[axis][side][4 * i..4 * i + 4]);
            let (xa, xb) = ((ox - load(0, 0)) * ix, (ox - load(0, 1)) * ix);
            let (ya, yb) = ((oy - load(1, 0)) * iy, (oy - load(1, 1)) * iy);
            let (za, zb) = ((oz - load(2, 0)) * iz, (oz - load(2, 1)) * iz);
            let t0 = xa.min(xb).max(ya.min(yb)).max(za.min(zb)).max(Vec4::ZERO);
            let t1 = (xa.max(xb).min(ya.max(yb)).min(za.max(zb)) * FAR_SCALE).min(t_max4);
            mask |= t0.cmple(t1).bitmask() << (4 * i);
            t0.write_to_slice(&mut t_near[4 * i..4 * i + 4]);
        }
        (mask & self.valid, t_near)
    }
}

/// The node test as a traversal runs it: [`WideNode::slabs4`]'s result, computed four or eight children at a time.
pub(crate) trait NodeTest: Copy {
    /// See [`WideNode::slabs4`].
    fn slabs(self, node: &WideNode, r: &NodeRay, t_max: f32) -> (u32, [f32; 8]);

    /// `f()` (a traversal's leaf test) compiled for this instruction set. A closure that the AVX2 loop calls
    /// without inlining it is otherwise compiled for the baseline instruction set (SSE, two-operand forms, each
    /// broadcast two instructions); the AVX2 build runs it in a function of its own instead.
    fn leaf_test<R>(self, f: impl FnOnce() -> R) -> R;
}

impl NodeTest for Portable {
    #[inline(always)]
    fn slabs(self, node: &WideNode, r: &NodeRay, t_max: f32) -> (u32, [f32; 8]) {
        node.slabs4(r, t_max)
    }

    #[inline(always)]
    fn leaf_test<R>(self, f: impl FnOnce() -> R) -> R {
        f()
    }
}

#[cfg(target_arch = "x86_64")]
impl NodeTest for Avx2 {
    #[inline(always)]
    fn slabs(self, node: &WideNode, r: &NodeRay, t_max: f32) -> (u32, [f32; 8]) {
        // SAFETY: `slabs8` requires only that the CPU supports AVX2, which an `Avx2` value proves (see
        // `Avx2::detect`).
        #[allow(unsafe_code)]
        unsafe {
            slabs8(node, r, t_max)
        }
    }

    #[inline(always)]
    fn leaf_test<R>(self, f: impl FnOnce() -> R) -> R {
        self.run_out_of_line(f)
    }
}

/// [`WideNode::slabs4`] in one 8-wide pass: the same operations in the same order, so the same bits.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn slabs8(node: &WideNode, r: &NodeRay, t_max: f32) -> (u32, [f32; 8]) {
    use std::arch::x86_64::{
        __m256, _mm256_castps256_ps128, _mm256_cmp_ps, _mm256_extractf128_ps, _mm256_load_ps, _mm256_max_ps,
        _mm256_min_ps, _mm256_movemask_ps, _mm256_mul_ps, _mm256_set1_ps, _mm256_setzero_ps, _mm256_sub_ps, _CMP_LE_OQ,
    };
    // A plane row as one vector: one aligned 32-byte load (built lane by lane, the compiler made it two 16-byte
    // loads and an insert).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn load(a: &[f32; 8]) -> __m256 {
        const _: () = assert!(std::mem::align_of::<WideNode>() >= 32 && std::mem::offset_of!(WideNode, planes) == 0);
        // SAFETY: `a` is a row of `WideNode::planes`: 32 readable bytes, 32-byte aligned (the rows are 32 bytes
        // long and start at the node's 64-byte-aligned start, as the assertion above checks).
        #[allow(unsafe_code)]
        unsafe {
            _mm256_load_ps(a.as_ptr())
        }
    }
    let p = &node.planes;
    let dist = |plane: &[f32; 8], axis: usize| {
        _mm256_mul_ps(_mm256_sub_ps(_mm256_set1_ps(r.o[axis]), load(plane)), _mm256_set1_ps(r.neg_inv_d[axis]))
    };
    let (xa, xb) = (dist(&p[0][0], 0), dist(&p[0][1], 0));
    let (ya, yb) = (dist(&p[1][0], 1), dist(&p[1][1], 1));
    let (za, zb) = (dist(&p[2][0], 2), dist(&p[2][1], 2));
    // Vec4's `max`/`min` are `maxps(self, rhs)`/`minps(self, rhs)`, kept in the same operand order here.
    let t0 = _mm256_max_ps(
        _mm256_max_ps(_mm256_max_ps(_mm256_min_ps(xa, xb), _mm256_min_ps(ya, yb)), _mm256_min_ps(za, zb)),
        _mm256_setzero_ps(),
    );
    let t1 = _mm256_min_ps(
        _mm256_mul_ps(
            _mm256_min_ps(_mm256_min_ps(_mm256_max_ps(xa, xb), _mm256_max_ps(ya, yb)), _mm256_max_ps(za, zb)),
            _mm256_set1_ps(FAR_SCALE),
        ),
        _mm256_set1_ps(t_max),
    );
    let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t0, t1)) as u32;
    let mut t_near = [0.0f32; 8];
    Vec4::from(_mm256_castps256_ps128(t0)).write_to_slice(&mut t_near[..4]);
    Vec4::from(_mm256_extractf128_ps::<1>(t0)).write_to_slice(&mut t_near[4..]);
    (mask & node.valid, t_near)
}

/// The ray's octant as the collapse orders a node's children by it: bit 2 for a negative x direction, bit 1 for
/// y, bit 0 for z. Child `c` of a node lies roughly `c ^ octant` steps behind the first one the ray meets (the
/// builder put in slot `s` the child nearest to where rays of octant `s` come from).
#[inline]
pub(crate) fn octant(d: Vec3) -> u32 {
    ((d.x < 0.0) as u32) << 2 | ((d.y < 0.0) as u32) << 1 | (d.z < 0.0) as u32
}

/// The 8-bit mask `m` with bit `c` moved to bit `c ^ x` (`x` below 8).
#[inline(always)]
pub(crate) fn xor_permute(m: u32, x: u32) -> u32 {
    let m = if x & 1 != 0 { ((m & 0x55) << 1) | ((m >> 1) & 0x55) } else { m };
    let m = if x & 2 != 0 { ((m & 0x33) << 2) | ((m >> 2) & 0x33) } else { m };
    if x & 4 != 0 {
        ((m & 0x0f) << 4) | ((m >> 4) & 0x0f)
    } else {
        m
    }
}

/// Entries of the traversal stack: a node index and the distance at which the ray enters its box. A fixed array
/// that spills into a vector (which never allocates unless the fixed part is full), so that no tree depth can
/// overflow it.
///
/// The array is left uninitialised: zeroing its 512 bytes at the start of every query was a `memset` call per query
/// for entries that are never read before they are written (BENCHMARKS.md, "Why the traversal is as it is").
struct NodeStack {
    /// Entries `..len` have been written by [`NodeStack::push`]; the rest are uninitialised.
    items: [MaybeUninit<(u32, f32)>; NODE_STACK],
    len: usize,
    /// Entries pushed while the array was full (so never empty unless `len == NODE_STACK`).
    spill: Vec<(u32, f32)>,
}

/// Fixed part of [`NodeStack`]: a BVH8 visit pushes at most 7 entries more than it pops, so this covers trees
/// nine levels deep even when every child is hit.
const NODE_STACK: usize = 64;

impl NodeStack {
    #[inline(always)]
    fn new() -> Self {
        Self { items: [const { MaybeUninit::uninit() }; NODE_STACK], len: 0, spill: Vec::new() }
    }

    #[inline(always)]
    fn push(&mut self, e: (u32, f32)) {
        if self.len < NODE_STACK {
            self.items[self.len].write(e);
            self.len += 1;
        } else {
            self.spill.push(e);
        }
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<(u32, f32)> {
        if self.len == NODE_STACK {
            if let Some(e) = self.spill.pop() {
                return Some(e);
            }
        }
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: entry `len` (the old `len - 1`) was written by `push`, which wrote every entry below `len`, and
        // nothing has overwritten it since with anything but another written entry. Measured: see the type's
        // doc comment.
        #[allow(unsafe_code)]
        unsafe {
            Some(self.items[self.len].assume_init())
        }
    }
}

/// Closest-hit traversal of `nodes` (root first) for the ray `r`, nearest first (as Embree and pbrt-v4 visit
/// children). The hit leaves of a node are handed to `leaves(node, mask)` (bit `c` of `mask` for each child the ray
/// meets; [`WideNode::leaves`] lists the leaves among them), which tests them and returns the closest distance found
/// so far (`t_max` to begin with); the node's hit inner children are pushed farthest first, and a popped node is
/// skipped if the ray enters it beyond the closest hit found since it was pushed (the same `t0 ≤ t_max` test the
/// slab test makes).
///
/// The loop is pipelined against memory, which a ray through a large BVH mostly waits on: a visit asks the caches
/// for its hit inner children's nodes (as Embree does) and, through `prefetch(node, mask)`, for its hit leaves,
/// whose test it leaves to the visit after next, after that visit's slab test (or to the end), so that their
/// misses overlap the next two nodes' instead of following one another. Two visits rather than one: faster closest
/// hits on the 1M-triangle benchmark, on one and two threads, and on a quarter of it that fits in the cache
/// (BENCHMARKS.md, "Why the traversal is as it is"); the later tests cull with a closest distance that is a visit
/// staler, which costs less than the wait. Culling uses the closest distance known at each
/// point, never nearer than the final one, so the hit is the same but for which of two primitives at the same
/// distance is reported -- or an ulp apart: the triangle test compares a hit with the closest so far in scaled form
/// (`t·det` against `t_max·det`, as pbrt-v4 does), and that rounding and the reported `t`'s can order such a pair
/// either way, so the one found first is kept. A test of a BVH of nested tiny triangles meets it on 12 of 2,000
/// rays, the traversal's hit an ulp nearer than brute force's as often as farther; widening the box test's
/// `t_max` as its far distance changed none of them, so it is not the box test.
#[inline(always)]
pub(crate) fn closest_first<'n>(
    test: impl NodeTest,
    nodes: &'n [WideNode],
    r: &NodeRay,
    mut t_max: f32,
    prefetch: impl Fn(&WideNode, u32),
    mut leaves: impl FnMut(&WideNode, u32) -> f32,
) {
    if nodes.is_empty() {
        return;
    }
    let mut stack = NodeStack::new();
    let mut next = Some((0u32, 0.0f32));
    // Hit leaves awaiting their test: `due`'s are tested at this visit, `pending`'s (the last visit's) at the next.
    let mut due: Option<(&'n WideNode, u32)> = None;
    let mut pending: Option<(&'n WideNode, u32)> = None;
    while let Some((index, t_enter)) = next.take().or_else(|| stack.pop()) {
        if t_enter > t_max {
            continue;
        }
        let node = &nodes[index as usize];
        let (hit8, t_near) = test.slabs(node, r, t_max);
        prefetch_children(nodes, node, hit8, 3);
        if let Some((n, m)) = due.take() {
            t_max = leaves(n, m);
        }
        due = pending.take();
        if hit8 & !node.inner != 0 {
            prefetch(node, hit8);
            pending = Some((node, hit8));
        }
        let mut inner_hits = hit8 & node.inner;
        // One or two inner children hit (the common cases) without the sort's data-dependent loop, whose branches
        // the processor mispredicted (BENCHMARKS.md, "Why the traversal is as it is"); the same order as the sort.
        if inner_hits.count_ones() <= 2 {
            if inner_hits != 0 {
                let a = inner_hits.trailing_zeros() as usize;
                inner_hits &= inner_hits - 1;
                let ea = (node.child[a], t_near[a]);
                if inner_hits == 0 {
                    next = Some(ea);
                } else {
                    let b = inner_hits.trailing_zeros() as usize;
                    let eb = (node.child[b], t_near[b]);
                    let (far, near) = if ea.1 < eb.1 { (eb, ea) } else { (ea, eb) };
                    stack.push(far);
                    next = Some(near);
                }
            }
            continue;
        }
        let mut inner = [(0u32, 0.0f32); 8];
        let mut n_inner = 0;
        while inner_hits != 0 {
            let child = inner_hits.trailing_zeros() as usize;
            inner_hits &= inner_hits - 1;
            let entry = (node.child[child], t_near[child]);
            // Insertion sort, nearest last (popped first).
            let mut k = n_inner;
            while k > 0 && inner[k - 1].1 < entry.1 {
                inner[k] = inner[k - 1];
                k -= 1;
            }
            inner[k] = entry;
            n_inner += 1;
        }
        // Three or more here, so `inner` is not empty.
        for &e in &inner[..n_inner - 1] {
            stack.push(e);
        }
        next = Some(inner[n_inner - 1]);
    }
    if let Some((n, m)) = due {
        leaves(n, m);
    }
    if let Some((n, m)) = pending {
        leaves(n, m);
    }
}

/// Asks the caches for the first `lines` lines of the nodes of the inner children among `hit8` of `node`.
#[inline(always)]
fn prefetch_children(nodes: &[WideNode], node: &WideNode, hit8: u32, lines: usize) {
    let mut inner = hit8 & node.inner;
    while inner != 0 {
        let c = inner.trailing_zeros() as usize;
        inner &= inner - 1;
        prefetch_lines(nodes.as_ptr().wrapping_add(node.child[c] as usize), lines);
    }
}

/// Asks the caches for the first `lines` lines of each block of each leaf among the children `mask` of `node`,
/// where a leaf's slots are kept in `blocks` of four (its first slot divided by four is its first block's index; a
/// leaf of more than four primitives has a second block after it, asked for too if `second_block`). The second
/// block speeds up incoherent rays in a big BVH, whose leaves are in memory, but slows down a mid-sized one such as
/// killeroo-simple's, whose leaves stay in the caches, so the callers ask for it only in big BVHs (BENCHMARKS.md,
/// "Why the traversal is as it is").
#[inline(always)]
pub(crate) fn prefetch_leaf_blocks<T>(blocks: &[T], node: &WideNode, mask: u32, lines: usize, second_block: bool) {
    let mut leaves = mask & !node.inner;
    while leaves != 0 {
        let c = leaves.trailing_zeros() as usize;
        leaves &= leaves - 1;
        let p = blocks.as_ptr().wrapping_add((node.child[c] >> 2) as usize);
        prefetch_lines(p, lines);
        if second_block && node.count[c] > 4 {
            prefetch_lines(p.wrapping_add(1), lines);
        }
    }
}

/// Asks the caches for `lines` 64-byte lines from `p`. Any address will do: the pointer is never dereferenced,
/// so the callers compute it with `wrapping_add` and no bounds check (a stale or out-of-range address only wastes
/// the prefetch).
#[inline(always)]
fn prefetch_lines<T>(p: *const T, lines: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        let p = p.cast::<i8>();
        for line in 0..lines {
            // SAFETY: `_mm_prefetch` needs SSE, which every x86-64 processor has; a prefetch is a hint that reads
            // nothing architecturally and cannot fault, whatever the address (`wrapping_add` keeps the pointer
            // arithmetic defined). Measured: see `closest_first`'s doc comment and BENCHMARKS.md, "Why the traversal
            // is as it is".
            #[allow(unsafe_code)]
            unsafe {
                _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(64 * line));
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (p, lines);
}

/// Occlusion traversal of `nodes` (root first) for the ray `r` of octant `oct` ([`octant`]): true as soon as
/// `leaves(node, mask)` (as for [`closest_first`]) reports a hit with `t < t_max`.
///
/// Pipelined as [`closest_first`], one visit deep instead of two (`prefetch(node, mask)` starts loading a node's hit
/// leaves, which are tested after the next visit's slab test): a hit ends the search, and each visit more before a
/// leaf's test is one more node a hit makes useless. Since the BVH's arrays are fully in 2 MB pages (`LargeArray`),
/// one visit is faster than two on every incoherent occlusion query of the 1M-triangle benchmark, on one and two
/// threads. The hit inner children are visited in the reverse of the octant order (farthest-looking first). Any hit
/// ends the search, so the nearest surfaces are not the best bet: on the 1M-triangle benchmark this order beat
/// nearest-first by distance and the octant order itself on bounce rays, and matched the unordered visit on shadow
/// rays (BENCHMARKS.md, "Why the traversal is as it is").
#[inline(always)]
pub(crate) fn any_hit(
    test: impl NodeTest,
    nodes: &[WideNode],
    r: &NodeRay,
    oct: u32,
    t_max: f32,
    prefetch: impl Fn(&WideNode, u32),
    mut leaves: impl FnMut(&WideNode, u32) -> bool,
) -> bool {
    if nodes.is_empty() {
        return false;
    }
    let oct = oct ^ 7; // the reverse of the octant order
    let mut stack = NodeStack::new();
    let mut next = Some((0u32, 0.0f32));
    // The last visit's hit leaves, tested at this visit after the slab test.
    let mut due: Option<(&WideNode, u32)> = None;
    loop {
        // One call site of `leaves` (inside the loop, for the last node's leaves too), so that the compiler inlines
        // it into the AVX2 build of the loop, which made occlusion of camera and shadow rays faster. The same in
        // `closest_first` made closest hits slower (and, once the other shapes' lanes were out of line, no faster),
        // so it stays out of line there (BENCHMARKS.md, "Why the traversal is as it is").
        let visit = next.take().or_else(|| stack.pop()).map(|(index, _)| {
            let node = &nodes[index as usize];
            let (hit8, _) = test.slabs(node, r, t_max);
            // All four lines, the children's indices and masks (read right after a node's test) with the planes:
            // one-thread occlusion of incoherent rays gained, two threads stayed level; the closest-hit loop keeps
            // three, being slower with four (BENCHMARKS.md, "Why the traversal is as it is").
            prefetch_children(nodes, node, hit8, 4);
            (node, hit8)
        });
        if let Some((n, m)) = due.take() {
            if leaves(n, m) {
                return true;
            }
        }
        // No nodes left (the last node's leaves were just tested, keeping `leaves` to one call site).
        let Some((node, hit8)) = visit else {
            return false;
        };
        if hit8 & !node.inner != 0 {
            prefetch(node, hit8);
            due = Some((node, hit8));
        }
        // Inner children in order of `c ^ oct`: pushed from the last to the second, the first visited next.
        let inner_hits = hit8 & node.inner;
        if inner_hits.count_ones() <= 2 {
            // The common cases without the loop (as in `closest_first`), in the same order.
            if inner_hits != 0 {
                let a = inner_hits.trailing_zeros();
                let rest = inner_hits & (inner_hits - 1);
                if rest == 0 {
                    next = Some((node.child[a as usize], 0.0));
                } else {
                    let b = rest.trailing_zeros();
                    let (first, second) = if a ^ oct < b ^ oct { (a, b) } else { (b, a) };
                    stack.push((node.child[second as usize], 0.0));
                    next = Some((node.child[first as usize], 0.0));
                }
            }
            continue;
        }
        // Three or more here.
        let mut order = xor_permute(inner_hits, oct);
        let first = order.trailing_zeros();
        order &= order - 1;
        while order != 0 {
            let j = 31 - order.leading_zeros();
            order &= !(1 << j);
            stack.push((node.child[(j ^ oct) as usize], 0.0));
        }
        next = Some((node.child[(first ^ oct) as usize], 0.0));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::to_aabb;
    use crate::bounds::Bounds3;
    use crate::collapse::WideBvh;
    use crate::simd::with_best_simd;
    use obvhs::aabb::Aabb;

    #[test]
    fn the_node_stack_spills_past_its_array_and_pops_in_reverse_order() {
        let mut stack = NodeStack::new();
        let entry = |i: u32| (i, i as f32 * 0.5);
        for round in 0..2 {
            let n = 3 * NODE_STACK as u32 + round;
            for i in 0..n {
                stack.push(entry(i));
            }
            assert_eq!(stack.spill.len(), n as usize - NODE_STACK);
            for i in (0..n).rev() {
                assert_eq!(stack.pop(), Some(entry(i)));
            }
            assert_eq!(stack.pop(), None);
        }
    }

    #[test]
    fn xor_permute_moves_each_bit_to_its_index_xor_x() {
        for m in 0..256u32 {
            for x in 0..8u32 {
                let want = (0..8).filter(|c| m & (1 << c) != 0).fold(0, |acc, c| acc | (1 << (c ^ x)));
                assert_eq!(xor_permute(m, x), want, "mask {m:#010b}, x {x}");
            }
        }
    }

    #[test]
    fn the_avx2_build_of_the_node_test_gives_the_same_bits_as_the_baseline_build() {
        // `with_best_simd` runs the 8-wide build on a CPU with AVX2 (as the project's machines have); the test then
        // compares the two builds of the same source, which must agree exactly (no operation changes, only the
        // vector width).
        let mut next = crate::test_floats(24_680);
        let aabbs: Vec<Aabb> = (0..3000)
            .map(|_| {
                let c = Vec3::new(next(), next(), next()) * 10.0;
                let h = Vec3::new(next(), next(), next()) * 0.3;
                to_aabb(&Bounds3 { min: c - h, max: c + h })
            })
            .collect();
        let nodes = WideBvh::build(&aabbs, 8, 4, &[]).nodes;
        let mut kept = 0;
        for k in 0..300 {
            let o = Vec3::new(next(), next(), next()) * 12.0 - Vec3::ONE;
            let d = Vec3::new(next() - 0.5, next() - 0.5, if k % 5 == 0 { 0.0 } else { next() - 0.5 });
            let (r, t_max) = (NodeRay::new(o, d), if k % 2 == 0 { f32::INFINITY } else { next() * 8.0 });
            for node in &nodes {
                let (mask, t_near) = node.slabs4(&r, t_max);
                let (mask_simd, t_near_simd) = with_best_simd!(t => t.slabs(node, &r, t_max));
                assert_eq!(mask, mask_simd);
                assert_eq!(t_near.map(f32::to_bits), t_near_simd.map(f32::to_bits));
                kept += mask.count_ones();
            }
        }
        assert!(kept > 1500, "{kept} boxes kept");
    }

    #[test]
    fn the_slab_test_keeps_every_child_box_the_ray_meets_and_reports_where_it_enters() {
        // Random boxes at several scales and offsets (far from the origin too); rays from inside and outside, some
        // axis-parallel, with finite and infinite t_max. Each child box is intersected exactly (f64) as reference.
        let mut next = crate::test_floats(987_654_321);
        for (scale, offset) in [(1.0f32, 0.0f32), (0.01, 5.0), (300.0, -1e4)] {
            let aabbs: Vec<Aabb> = (0..2000)
                .map(|_| {
                    let c = Vec3::new(next(), next(), next()) * scale + Vec3::splat(offset);
                    let h = Vec3::new(next(), next(), next()) * 0.05 * scale;
                    to_aabb(&Bounds3 { min: c - h, max: c + h })
                })
                .collect();
            let nodes: Vec<WideNode> = WideBvh::build(&aabbs, 8, 4, &[]).nodes;
            assert!(nodes.len() > 10);
            let (mut met, mut reported) = (0, 0);
            for k in 0..400 {
                let o = Vec3::new(next(), next(), next()) * 1.4 * scale + Vec3::splat(offset - 0.2 * scale);
                let mut d = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5);
                if k % 7 == 0 {
                    d = Vec3::new(0.0, 0.0, if k % 2 == 0 { 1.0 } else { -1.0 });
                }
                let r = NodeRay::new(o, d);
                let t_max = if k % 3 == 0 { f32::INFINITY } else { next() * scale };
                for node in &nodes {
                    let (mask, t_near) = node.slabs4(&r, t_max);
                    for (c, &t_near) in t_near.iter().enumerate() {
                        // The exact entry and exit distances of child c's box (an empty slot has none).
                        let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
                        for a in 0..3 {
                            let (lo, hi) = (node.planes[a][0][c] as f64, node.planes[a][1][c] as f64);
                            let (oa, da) = (o[a] as f64, d[a] as f64);
                            if node.valid & (1 << c) == 0 {
                                t0 = f64::INFINITY; // an empty slot
                            }
                            if da == 0.0 {
                                if oa < lo || oa > hi {
                                    t0 = f64::INFINITY;
                                }
                                continue;
                            }
                            let (ta, tb) = ((lo - oa) / da, (hi - oa) / da);
                            t0 = t0.max(ta.min(tb));
                            t1 = t1.min(ta.max(tb));
                        }
                        let meets = t0 <= t1 && t0 < t_max as f64;
                        let hit = mask & (1 << c) != 0;
                        // Conservative: a box the ray meets before t_max is never culled.
                        assert!(!meets || hit, "child {c} culled: t0 {t0}, t1 {t1}, t_max {t_max}");
                        if hit {
                            // ... and what it keeps it meets, up to the test's rounding, entering where it says.
                            let tol = 1e-5 * t1.abs().max(t0.abs()).max(1e-30);
                            assert!(t0 <= t1 + tol, "child {c} kept: t0 {t0}, t1 {t1}");
                            assert!((t_near as f64 - t0).abs() <= tol, "child {c}: {t_near} vs {t0}");
                            reported += 1;
                        }
                        met += usize::from(meets);
                    }
                }
            }
            assert!(met > 1000 && reported >= met, "{met} boxes met, {reported} kept at scale {scale}");
        }
    }
}
