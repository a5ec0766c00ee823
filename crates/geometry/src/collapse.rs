//! Building the 8-wide BVH the traversal reads ([`WideNode`]s): a binary BVH built by `obvhs` (PLOC, then
//! reinsertion), collapsed into nodes of up to eight children whose leaves hold whole blocks of primitives.
//!
//! The collapse is the surface-area-optimal one of Ylitie et al. ("Efficient incoherent ray traversal on GPUs
//! through compressed wide BVHs", 2017, section 3.1), with a cost model for this CPU layout: a table gives, for
//! every binary subtree and every number of slots from 1 to 8, the least cost of storing it in that many child
//! slots of a wide node, bottom-up, as one leaf (its surface area times its blocks' test cost, only for at most
//! `max_leaf` primitives), one wide node (its area times a node visit's cost, plus its children spread over eight
//! slots) or its two children sharing the slots; the nodes are then read off the table from the root. Each leaf is
//! stored from a slot that is a multiple of the block size, so that a triangle leaf is one or two blocks of four
//! triangles tested together.
//!
//! On the 1M-triangle benchmark (leaves of up to 8, blocks of 4) this gives 44k nodes and 289k leaves of 3.5
//! triangles; `obvhs`'s own collapse (the same table with GPU costs, at most three primitives per leaf) gave 103k
//! nodes and 680k leaves of 1.5, and Embree 61k nodes and 250k leaves of 3.7 (its `verbose=2` statistics). A
//! greedy collapse (open the largest child while slots are free, in the manner of Embree's wide builders) came
//! close on that mesh but put small scenes of large, overlapping triangles in one node whose leaves every ray
//! tested: 6.3 blocks per camera or light ray on `scenes/prism-beam.pbrt`, against 2.5 with the table (at a block
//! cost of 0.5).
//!
//! The children of a node are put in slots by the ray octants that meet them first, as Ylitie et al. assign them
//! (section 3.2): slot `s` gets the child farthest against the direction of octant `s` (greedily, cheapest pair
//! first), which the occlusion loop reads to visit children roughly far to near.

use glam::Vec3A;
use obvhs::aabb::Aabb;
use obvhs::bvh2::node::Bvh2Node;
use obvhs::bvh2::Bvh2;

use crate::wide::WideNode;

/// A leaf slot that holds no primitive: the padding that starts every leaf on a multiple of the block size.
pub(crate) const EMPTY_SLOT: u32 = u32::MAX;

/// An 8-wide BVH: its nodes (the root first) and the primitive in each leaf slot.
pub(crate) struct WideBvh {
    pub(crate) nodes: Vec<WideNode>,
    /// The primitive (an index into the boxes the BVH was built over) in each leaf slot, or [`EMPTY_SLOT`].
    pub(crate) slots: Vec<u32>,
    /// Levels of nodes (1 for a root alone; 0 without nodes), reported in the BVH statistics.
    pub(crate) depth: u32,
}

/// A binary BVH over `aabbs`, one primitive per leaf: `obvhs`'s PLOC build and reinsertion optimiser with its
/// "medium" settings (which measured best overall), without its debug-build validation (whose fixed 1e-5 tolerance
/// trips on far-away geometry).
fn binary_bvh(aabbs: &[Aabb]) -> Bvh2 {
    let p = obvhs::BvhBuildParams::medium_build();
    let mut bvh2 = obvhs::ploc::PlocBuilder::with_capacity(aabbs.len()).build(
        p.ploc_search_distance,
        aabbs,
        (0..aabbs.len() as u32).collect(),
        p.sort_precision,
        p.search_depth_threshold,
    );
    obvhs::bvh2::reinsertion::ReinsertionOptimizer::default().run(&mut bvh2, p.reinsertion_batch_ratio, None);
    bvh2
}

/// Surface area of a box (half of it: only ratios matter).
fn half_area(b: &Aabb) -> f32 {
    let d = (b.max - b.min).max(Vec3A::ZERO);
    d.x * d.y + d.y * d.z + d.z * d.x
}

impl WideBvh {
    /// The BVH over the boxes `aabbs`: leaves of at most `max_leaf` primitives (1 to 255), each starting at a
    /// slot that is a multiple of `block`. `tested_alone[p]` marks primitives not tested a block at a time (the
    /// shapes other than triangles, each its own test in a leaf); an empty slice marks none.
    pub(crate) fn build(aabbs: &[Aabb], max_leaf: u32, block: u32, tested_alone: &[bool]) -> Self {
        assert!((1..=255).contains(&max_leaf) && block >= 1);
        if aabbs.is_empty() {
            return Self { nodes: Vec::new(), slots: Vec::new(), depth: 0 };
        }
        let bvh2 = binary_bvh(aabbs);
        let b2 = &bvh2.nodes;
        let is_leaf = |i: u32| b2[i as usize].is_leaf();
        let left = |i: u32| b2[i as usize].first_index;

        // Primitives under each binary node: children after their parent in pre-order, so reversed it is post-order.
        let mut preorder = Vec::with_capacity(b2.len());
        let mut todo = vec![0u32];
        while let Some(i) = todo.pop() {
            preorder.push(i);
            if !is_leaf(i) {
                todo.extend([left(i), left(i) + 1]);
            }
        }
        // Per binary node: primitives under it, and how many of those are tested alone.
        let mut count = vec![[0u32; 2]; b2.len()];
        for &i in preorder.iter().rev() {
            let n = &b2[i as usize];
            count[i as usize] = if n.is_leaf() {
                let prims = &bvh2.primitive_indices[n.first_index as usize..(n.first_index + n.prim_count) as usize];
                let alone = prims.iter().filter(|&&p| tested_alone.get(p as usize) == Some(&true)).count();
                [n.prim_count, alone as u32]
            } else {
                let (l, r) = (count[n.first_index as usize], count[n.first_index as usize + 1]);
                [l[0] + r[0], l[1] + r[1]]
            };
        }
        // The least cost of each subtree in 1 to 8 slots, bottom-up.
        let mut c = Collapser {
            b2,
            count,
            dist: vec![[0.0; 8]; b2.len()],
            max_leaf,
            block,
            block_cost: block_cost(aabbs.len()),
        };
        for &i in preorder.iter().rev() {
            c.compute(i);
        }
        drop(preorder);

        let mut nodes = vec![WideNode::EMPTY];
        let mut slots = Vec::with_capacity(aabbs.len() + aabbs.len() / 2);
        // (binary node, wide node it becomes, its level).
        let mut work = vec![(0u32, 0u32, 1u32)];
        let mut depth = 0;
        let mut subtree = Vec::new();
        let mut kids = Vec::with_capacity(8);
        while let Some((i, w, level)) = work.pop() {
            depth = depth.max(level);
            // The children: a root stored as a leaf is the root's only child.
            kids.clear();
            if i == 0 && c.as_leaf(i) {
                kids.push(i);
            } else {
                let l = c.left(i);
                let k = c.split(i, 8).1;
                c.spread(l, k, &mut kids);
                c.spread(l + 1, 8 - k, &mut kids);
            }
            let by_slot = octant_slots(
                b2[i as usize].aabb().center(),
                &kids.iter().map(|&k| b2[k as usize].aabb().center()).collect::<Vec<_>>(),
            );
            let mut node = WideNode::EMPTY;
            for (slot, kid) in by_slot.iter().enumerate() {
                let Some(k) = kid.map(|k| kids[k]) else { continue };
                node.set_box(slot, b2[k as usize].aabb());
                if c.as_leaf(k) {
                    // Gather the subtree's primitives, left to right.
                    subtree.clear();
                    let mut todo = vec![k];
                    while let Some(j) = todo.pop() {
                        let n = &b2[j as usize];
                        if n.is_leaf() {
                            let first = n.first_index as usize;
                            subtree.extend_from_slice(&bvh2.primitive_indices[first..first + n.prim_count as usize]);
                        } else {
                            todo.extend([n.first_index + 1, n.first_index]);
                        }
                    }
                    while slots.len() % block as usize != 0 {
                        slots.push(EMPTY_SLOT);
                    }
                    node.set_leaf(slot, slots.len() as u32, subtree.len() as u32);
                    slots.extend_from_slice(&subtree);
                } else {
                    let index = nodes.len() as u32;
                    nodes.push(WideNode::EMPTY);
                    node.set_inner(slot, index);
                    work.push((k, index, level + 1));
                }
            }
            nodes[w as usize] = node;
        }
        while slots.len() % block as usize != 0 {
            slots.push(EMPTY_SLOT);
        }
        Self { nodes, slots, depth }
    }
}

/// Cost of a node visit in the surface-area heuristic (per unit of surface area, as a fraction of the parent's).
const NODE_COST: f32 = 1.0;
/// Cost of a leaf block's test, by the BVH's size: blocks are cheaper against nodes in big BVHs, whose node visits
/// miss the caches, while a small BVH's nodes stay in the caches and its block tests weigh more. Measured: on the
/// 1M-triangle benchmark 0.5 was faster than 1 (smaller leaves, more nodes) on every query, and than 0.35 and 0.25
/// (bigger leaves) on most; on killeroo-simple and `scenes/prism-beam.pbrt` 1 was faster than 0.5 (BENCHMARKS.md,
/// "Why the traversal is as it is").
fn block_cost(primitives: usize) -> f32 {
    if primitives >= BIG_BVH {
        0.5
    } else {
        1.0
    }
}
/// Primitives from which a BVH counts as big for [`block_cost`].
pub(crate) const BIG_BVH: usize = 1 << 19;
/// The test of a primitive that is not a triangle (a sphere, disk or bilinear patch, in f64), as much as a node
/// visit: with the cost of a block, `scenes/metals.pbrt` put its four spheres in one leaf that every ray tested,
/// slower than leaves of one sphere each (BENCHMARKS.md, "Why the traversal is as it is").
const SHAPE_COST: f32 = 1.0;

/// The binary BVH being collapsed, with the table of the optimal collapse.
struct Collapser<'a> {
    b2: &'a [Bvh2Node],
    /// Primitives under each binary node, and how many of them are tested alone.
    count: Vec<[u32; 2]>,
    /// `dist[i][j - 1]`: the least surface-area cost of storing subtree `i` in at most `j` child slots of a wide
    /// node (as one leaf, one wide node, or spread over several slots by its children).
    dist: Vec<[f32; 8]>,
    max_leaf: u32,
    block: u32,
    block_cost: f32,
}

impl Collapser<'_> {
    fn left(&self, i: u32) -> u32 {
        self.b2[i as usize].first_index
    }

    fn is_binary_leaf(&self, i: u32) -> bool {
        self.b2[i as usize].is_leaf()
    }

    /// Subtree `i` as one leaf: its blocks' tests and those of the primitives tested alone. Only for at most
    /// `max_leaf` primitives, or a binary leaf (which cannot be opened; PLOC makes leaves of one primitive, so this
    /// does not arise from [`binary_bvh`]).
    fn leaf_cost(&self, i: u32) -> f32 {
        let [count, alone] = self.count[i as usize];
        if count <= self.max_leaf || self.is_binary_leaf(i) {
            let tests = self.block_cost * (count - alone).div_ceil(self.block) as f32 + SHAPE_COST * alone as f32;
            half_area(self.b2[i as usize].aabb()) * tests
        } else {
            f32::INFINITY
        }
    }

    /// Subtree `i` as one wide node: a visit, and its children spread over eight slots.
    fn node_cost(&self, i: u32) -> f32 {
        if self.is_binary_leaf(i) {
            return f32::INFINITY;
        }
        half_area(self.b2[i as usize].aabb()) * NODE_COST + self.split(i, 8).0
    }

    /// Whether subtree `i`, in one slot, is a leaf (else a wide node).
    fn as_leaf(&self, i: u32) -> bool {
        self.leaf_cost(i) <= self.node_cost(i)
    }

    /// The least cost of spreading the two children of inner binary node `i` over `j` slots (2 to 8), and the
    /// slots it gives the left one.
    fn split(&self, i: u32, j: usize) -> (f32, usize) {
        let (l, r) = (&self.dist[self.left(i) as usize], &self.dist[self.left(i) as usize + 1]);
        (1..j).map(|k| (l[k - 1] + r[j - k - 1], k)).fold((f32::INFINITY, 1), |a, b| if b.0 < a.0 { b } else { a })
    }

    /// Fills `dist[i]` (its children's filled already).
    fn compute(&mut self, i: u32) {
        let one = self.leaf_cost(i).min(self.node_cost(i));
        let mut d = [one; 8];
        if !self.is_binary_leaf(i) {
            for j in 2..=8 {
                d[j - 1] = one.min(self.split(i, j).0);
            }
        }
        self.dist[i as usize] = d;
    }

    /// Appends to `out` the subtrees that fill the (at most) `j` slots subtree `i` is given, as the table chose.
    fn spread(&self, i: u32, j: usize, out: &mut Vec<u32>) {
        if j == 1 || self.is_binary_leaf(i) {
            out.push(i);
            return;
        }
        let (cost, k) = self.split(i, j);
        if self.dist[i as usize][0] <= cost {
            out.push(i);
        } else {
            self.spread(self.left(i), k, out);
            self.spread(self.left(i) + 1, j - k, out);
        }
    }
}

/// The slot of each child (an index into `centers`, at most eight) by the ray octants that meet it first: slot
/// `s` should hold the child lying farthest against the direction whose sign bits are `s` (bit 2 for a negative
/// x, as [`crate::wide::octant`]), measured from the parent's centre. Greedy: the cheapest (child, slot) pair is
/// taken first, as Ylitie et al. found about as good as an optimal assignment.
fn octant_slots(parent: Vec3A, centers: &[Vec3A]) -> [Option<usize>; 8] {
    let dir = |s: usize| {
        Vec3A::new(
            if s & 4 != 0 { -1.0 } else { 1.0 },
            if s & 2 != 0 { -1.0 } else { 1.0 },
            if s & 1 != 0 { -1.0 } else { 1.0 },
        )
    };
    let mut by_slot = [None; 8];
    let mut placed = [false; 8];
    for _ in 0..centers.len().min(8) {
        let mut best: Option<(f32, usize, usize)> = None;
        for (c, &center) in centers.iter().enumerate() {
            if placed[c] {
                continue;
            }
            for (s, taken) in by_slot.iter().enumerate() {
                let cost = dir(s).dot(center - parent);
                if taken.is_none() && best.is_none_or(|b| cost < b.0) {
                    best = Some((cost, c, s));
                }
            }
        }
        let Some((_, c, s)) = best else { break };
        placed[c] = true;
        by_slot[s] = Some(c);
    }
    by_slot
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::to_aabb;
    use crate::bounds::Bounds3;
    use glam::Vec3;

    /// Random boxes: many small ones and a few that span the scene (as a room's walls around small objects).
    fn boxes(n: usize, seed: u32) -> Vec<Aabb> {
        let mut next = crate::test_floats(seed);
        (0..n)
            .map(|k| {
                let c = Vec3::new(next(), next(), next()) * 10.0;
                let h = if k % 50 == 0 { Vec3::new(next(), next(), 0.01) * 10.0 } else { Vec3::splat(0.05) };
                to_aabb(&Bounds3 { min: c - h, max: c + h })
            })
            .collect()
    }

    #[test]
    fn every_primitive_is_in_one_aligned_leaf_inside_its_parents_boxes() {
        for (n, max_leaf, block) in [(1, 8, 4), (5, 8, 4), (37, 8, 4), (3000, 8, 4), (500, 1, 1), (2, 1, 1)] {
            let aabbs = boxes(n, 7 + n as u32);
            let bvh = WideBvh::build(&aabbs, max_leaf, block, &[]);
            assert_eq!(bvh.slots.len() % block as usize, 0);
            let mut seen = vec![0u32; n];
            // (node, the box its parent gives it): every child box lies inside its parent's.
            let mut todo = vec![(0u32, None::<Bounds3>, 1u32)];
            let (mut visited, mut depth) = (0, 0);
            while let Some((i, parent, level)) = todo.pop() {
                visited += 1;
                depth = depth.max(level);
                let node = &bvh.nodes[i as usize];
                for c in 0..8 {
                    let Some(b) = node.child_box(c) else { continue };
                    if let Some(p) = parent {
                        assert!(p.min.cmple(b.min).all() && b.max.cmple(p.max).all(), "child box outside");
                    }
                    if let Some(child) = node.inner_child(c) {
                        todo.push((child, Some(b), level + 1));
                        continue;
                    }
                    let (first, count) = node.leaves(1 << c).next().unwrap();
                    assert!(first % block == 0 && (1..=max_leaf).contains(&count), "leaf {first}, {count}");
                    for &p in &bvh.slots[first as usize..(first + count) as usize] {
                        assert_ne!(p, EMPTY_SLOT);
                        let a = &aabbs[p as usize];
                        assert!(b.min.cmple(a.min.into()).all() && Vec3::from(a.max).cmple(b.max).all());
                        seen[p as usize] += 1;
                    }
                }
            }
            assert_eq!(visited, bvh.nodes.len(), "every node is reached once");
            assert_eq!(depth, bvh.depth, "the depth is the deepest node's level");
            assert!(seen.iter().all(|&k| k == 1), "every primitive in exactly one leaf ({n} primitives)");
        }
    }

    #[test]
    fn shapes_tested_alone_get_leaves_of_their_own_where_triangles_share_a_block() {
        // Four unit boxes two apart on a line, as the four spheres of scenes/metals.pbrt.
        let aabbs: Vec<Aabb> = (0..4)
            .map(|k| {
                let c = Vec3::new(3.0 * k as f32, 0.0, 0.0);
                to_aabb(&Bounds3 { min: c - Vec3::splat(0.5), max: c + Vec3::splat(0.5) })
            })
            .collect();
        // The leaves' primitive counts (empty slots report 0).
        let leaves = |alone: &[bool]| {
            let bvh = WideBvh::build(&aabbs, 8, 4, alone);
            bvh.nodes.iter().flat_map(|n| n.leaves(0xff).map(|(_, count)| count)).filter(|&c| c > 0).collect::<Vec<_>>()
        };
        // As triangles: one block holds them all, cheaper than four tests of a block each.
        assert_eq!(leaves(&[]), vec![4]);
        // As shapes tested one by one: a leaf each, so that a ray tests only the ones whose box it meets.
        assert_eq!(leaves(&[true; 4]), vec![1, 1, 1, 1]);
    }
}
