//! The bottom-level BVH's nodes as the traversal reads them: `obvhs`'s compressed 8-wide nodes with their child
//! boxes decoded to floats once, at build time.
//!
//! A compressed node stores each child box plane as an 8-bit multiple of a power of two above the node's corner,
//! so that a node fits in 80 bytes; testing a ray against it first decodes all 48 planes (a conversion, a multiply
//! and an add each). Decoded nodes take 256 bytes but leave the slab test two operations per plane. The planes are
//! decoded exactly as the compressed test decoded them (`p + q·e` in f32, with `q·e` exact), so the slab test
//! answers the same, bit for bit, and the tree, its leaves and their order are the ones `obvhs` built.

use glam::{Vec3, Vec3A, Vec4};
use obvhs::cwbvh::node::CwBvhNode;

/// Far-distance widening so float error never culls a box the ray touches (pbrt-v4's `1 + 2γ(3)`).
pub(crate) const FAR_SCALE: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// Ray data for the node test.
pub(crate) struct NodeRay {
    pub(crate) o: Vec3A,
    pub(crate) inv_d: Vec3A,
    pub(crate) neg: [bool; 3],
}

impl NodeRay {
    pub(crate) fn new(o: Vec3, d: Vec3) -> Self {
        // Clamp tiny components so no inf or NaN enters the slab test; 1e20 bounds keep every product finite.
        let inv = |x: f32| if x.abs() < 1e-20 { 1e20f32.copysign(x) } else { 1.0 / x };
        let inv_d = Vec3A::new(inv(d.x), inv(d.y), inv(d.z));
        // The slab order follows the sign of the inverse (so −0.0 components are handled consistently).
        Self { o: o.into(), inv_d, neg: [inv_d.x < 0.0, inv_d.y < 0.0, inv_d.z < 0.0] }
    }
}

/// One 8-wide node with decoded child boxes. Four cache lines, aligned to them.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(crate) struct WideNode {
    /// `planes[axis][side][child]`: child boxes' minimum (side 0) and maximum (side 1) planes. Empty child slots
    /// have a minimum above the maximum, so no ray meets them.
    planes: [[[f32; 8]; 2]; 3],
    /// The node index of each inner child (unused for leaves and empty slots).
    pub(crate) child: [u32; 8],
    /// `obvhs`'s child metadata: for a leaf, its primitive count in unary in the top 3 bits and the first
    /// primitive's offset from `prim_base` below; for an inner child `0b001_xxxxx`; 0 for an empty slot.
    pub(crate) meta: [u8; 8],
    /// The first leaf slot of this node's leaves.
    pub(crate) prim_base: u32,
    /// Bit `c` set if child `c` is an inner node.
    pub(crate) inner: u32,
}

impl WideNode {
    /// The decoded form of a compressed node of `nodes`.
    pub(crate) fn decode(node: &CwBvhNode) -> Self {
        let e = node.compute_extent();
        let p = node.p;
        let mut planes = [[[0.0f32; 8]; 2]; 3];
        let mut child = [0u32; 8];
        let mut inner = 0u32;
        for c in 0..8 {
            // The same two roundings as the compressed slab test: q·e is exact (e is a power of two), then + p.
            planes[0][0][c] = node.child_min_x[c] as f32 * e.x + p.x;
            planes[0][1][c] = node.child_max_x[c] as f32 * e.x + p.x;
            planes[1][0][c] = node.child_min_y[c] as f32 * e.y + p.y;
            planes[1][1][c] = node.child_max_y[c] as f32 * e.y + p.y;
            planes[2][0][c] = node.child_min_z[c] as f32 * e.z + p.z;
            planes[2][1][c] = node.child_max_z[c] as f32 * e.z + p.z;
            let meta = node.child_meta[c] as u32;
            if meta & 0b1_1000 == 0b1_1000 {
                let slot = (meta & 31) - 24;
                let below = (node.imask as u32) & ((1 << slot) - 1);
                child[c] = node.child_base_idx + below.count_ones();
                inner |= 1 << c;
            }
        }
        Self { planes, child, meta: node.child_meta, prim_base: node.primitive_base_idx, inner }
    }

    /// The node's leaf slots among the children of `mask`: bit `i` stands for slot `prim_base + i`.
    #[inline(always)]
    pub(crate) fn leaf_slots(&self, mask: u32) -> u32 {
        let mut leaves = mask & !self.inner;
        let mut slots = 0u32;
        while leaves != 0 {
            let meta = self.meta[leaves.trailing_zeros() as usize] as u32;
            leaves &= leaves - 1;
            slots |= (meta >> 5) << (meta & 31);
        }
        slots
    }

    /// Slab test of the ray against the eight child boxes: bit `i` of the mask is set if the ray meets child
    /// `i`'s box with `t < t_max`, and the array holds each child's entry distance (clamped to 0).
    ///
    /// `(plane − o) · (1/d)` carries only a relative error of a few ulps, and pbrt's `1 + 2γ(3)` widening of the
    /// far distance makes the test conservative (no ray that touches a box is culled, even one grazing a box face
    /// from an origin on that face).
    #[inline(always)]
    pub(crate) fn slabs(&self, r: &NodeRay, t_max: f32) -> (u32, [f32; 8]) {
        let (ox, oy, oz) = (Vec4::splat(r.o.x), Vec4::splat(r.o.y), Vec4::splat(r.o.z));
        let (ix, iy, iz) = (Vec4::splat(r.inv_d.x), Vec4::splat(r.inv_d.y), Vec4::splat(r.inv_d.z));
        let near = [r.neg[0] as usize, r.neg[1] as usize, r.neg[2] as usize];
        let t_max4 = Vec4::splat(t_max);
        let mut mask = 0u32;
        let mut t_near = [0.0f32; 8];
        for i in 0..2 {
            let load = |axis: usize, side: usize| Vec4::from_slice(&self.planes[axis][side][4 * i..4 * i + 4]);
            let tx0 = (load(0, near[0]) - ox) * ix;
            let tx1 = (load(0, 1 - near[0]) - ox) * ix;
            let ty0 = (load(1, near[1]) - oy) * iy;
            let ty1 = (load(1, 1 - near[1]) - oy) * iy;
            let tz0 = (load(2, near[2]) - oz) * iz;
            let tz1 = (load(2, 1 - near[2]) - oz) * iz;
            let t0 = tx0.max(ty0).max(tz0).max(Vec4::ZERO);
            let t1 = (tx1.min(ty1).min(tz1) * FAR_SCALE).min(t_max4);
            mask |= t0.cmple(t1).bitmask() << (4 * i);
            t0.write_to_slice(&mut t_near[4 * i..4 * i + 4]);
        }
        (mask, t_near)
    }
}

/// The ray's octant as `obvhs` orders a node's children by it: bit 2 for a negative x direction, bit 1 for y, bit
/// 0 for z. Child `c` of a node lies roughly `c ^ octant` steps behind the first one the ray meets (the builder put
/// in slot `s` the child nearest to where rays of octant `s` come from).
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
