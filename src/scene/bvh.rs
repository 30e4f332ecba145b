//! A bounding volume hierarchy over triangles, built on the host with the binned surface area heuristic
//! as a binary tree, then collapsed into the 4-wide tree ([`WideNode`], [`Bvh::wide`]) whose nodes
//! `shaders/bvh.wgsl` walks.
//!
//! **The surface area heuristic** (Goldsmith & Salmon 1987; MacDonald & Booth 1990; as in pbrt-v4 §7.3,
//! Pharr, Jakob & Humphreys 2023). For a ray that passes through a node's box B, the probability that it
//! also passes through a child box Bc inside it is about SA(Bc) / SA(B) (for uniformly distributed
//! lines, Cauchy's formula). So the expected cost of splitting the node's triangles into (L, R) is
//!
//! ```text
//!     C(split) = C_trav + (SA(L) N_L + SA(R) N_R) / SA(B) * C_isect,      C(leaf) = N * C_isect
//! ```
//!
//! and the builder picks the cheapest split, or a leaf when no split is cheaper (and the node is small
//! enough to be a leaf). We take C_trav = C_isect = 1: in our traversal one loop iteration either visits an
//! interior node (two box tests) or tests one triangle, and both cost about the same on a GPU thread.
//!
//! **Binning** (Wald, "On fast Construction of SAH-based Bounding Volume Hierarchies", 2007). Instead of
//! sorting, each axis's range of triangle centroids is cut into [`BINS`] equal bins; one pass counts the
//! triangles and grows a box per bin, and a sweep from each side evaluates the [`BINS`] - 1 planes between
//! bins. All three axes are tried. That is O(N) per level, O(N log N) in all.
//!
//! **Bounded depth.** The shader's traversal stack has [`STACK_SIZE`] entries and holds at most one entry
//! per level, so the tree must not be deeper. Below [`SAH_MAX_DEPTH`] levels the builder switches to
//! median splits (half the triangles each side), which add at most log2(N) <= 29 more levels: the depth
//! is at most 32 + 29 = 61 < 64 for any number of triangles we accept.

use glam::Vec3;
use std::time::Instant;

/// Bins per axis.
pub const BINS: usize = 16;
/// The most triangles in one leaf. A leaf reference keeps (count - 1) in [`LEAF_COUNT_BITS`] bits.
pub const MAX_LEAF: usize = 4;
/// A child reference with this bit set is a leaf: triangles `[first, first + count)` with
/// `first = (ref & !LEAF) >> LEAF_COUNT_BITS` and `count = (ref & LEAF_COUNT_MASK) + 1`; otherwise it is
/// the index of an interior node. Mirrored in `shaders/bvh.wgsl`.
pub const LEAF: u32 = 0x8000_0000;
/// In a scene with instances, a leaf of the top-level tree is one placement: `LEAF | INSTANCE | (i <<
/// LEAF_COUNT_BITS)` for `GpuInstance` i (a triangle leaf's first index stays below bit 30 there: the
/// upload checks it).
pub const INSTANCE: u32 = 0x4000_0000;
pub const LEAF_COUNT_BITS: u32 = 2;
pub const LEAF_COUNT_MASK: u32 = (1 << LEAF_COUNT_BITS) - 1;
/// Entries of the shader's traversal stack (`BVH_STACK_SIZE` in bvh.wgsl).
pub const STACK_SIZE: usize = 64;
/// Depth from which splits are medians instead of SAH (see the module comment).
pub const SAH_MAX_DEPTH: usize = 32;
/// The traversal loop of one ray in `shaders/bvh.wgsl` runs at most this many iterations
/// (`BVH_MAX_STEPS`). One iteration visits one interior node (its four child boxes), tests one triangle,
/// or both.
///
/// Why a cap: Mesa's lavapipe ends every loop of an invocation after 65535 iterations in total, and the
/// renderer must bound one ray cast's iterations before it renders (`render::worst_case_loop_iterations`,
/// `render::casts_per_dispatch`). The uncapped worst case of one traversal is every node and every
/// triangle, which for 10^6 triangles would not fit. With the cap, a cast costs at most (lights + 1)
/// traversals of 2048 iterations: with one light, 4096, so that an invocation makes 15 casts per
/// dispatch on the largest meshes (paths go on in the next dispatch). A ray through a good BVH needs far fewer:
/// roughly 2 log2(N) interior nodes plus a few leaves, and `tests/shader_bvh.rs` measures the largest count over
/// random rays into meshes of up to 10^5 triangles (a few hundred at most). A ray that reached the cap
/// would keep the closest hit found so far (a shadow ray: unoccluded); the tests check that none does.
pub const MAX_STEPS: u32 = 2048;

/// An axis-aligned box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub lo: Vec3,
    pub hi: Vec3,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        lo: Vec3::splat(f32::INFINITY),
        hi: Vec3::splat(f32::NEG_INFINITY),
    };

    pub fn grow(&mut self, p: Vec3) {
        self.lo = self.lo.min(p);
        self.hi = self.hi.max(p);
    }

    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb {
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.lo.x > self.hi.x
    }

    /// Surface area, in f64 (the products of large f32 extents must not overflow); 0 for an empty box.
    pub fn surface_area(&self) -> f64 {
        if self.is_empty() {
            return 0.0;
        }
        let e = (self.hi - self.lo).as_dvec3();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    pub fn contains(&self, o: &Aabb) -> bool {
        self.lo.cmple(o.lo).all() && self.hi.cmpge(o.hi).all()
    }
}

/// An interior node of the binary tree the builder makes: the boxes and references of its two children
/// (see [`LEAF`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Node {
    pub bounds: [Aabb; 2],
    pub child: [u32; 2],
}

/// A built hierarchy. The triangles must be uploaded in `order`: leaf ranges index that order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Bvh {
    /// Interior nodes, depth-first; node 0 is the root (there is always one when there are triangles).
    pub nodes: Vec<Node>,
    /// `order[i]` is the original index of the i-th triangle in leaf order.
    pub order: Vec<u32>,
    /// Leaves, and the depth of the deepest interior node (the root has depth 1).
    pub leaves: usize,
    pub depth: usize,
    pub build_seconds: f64,
}

/// Per-triangle data the builder sorts by.
struct Prim {
    bounds: Aabb,
    centroid: Vec3,
}

/// Subtrees over at least this many triangles build their two halves on two threads (rayon's `join`);
/// smaller ones build on the thread they are on. Large enough that the relocation of a finished half's
/// nodes (see [`Builder::fill`]) and rayon's scheduling stay small next to the work split.
const PARALLEL_MIN: usize = 1 << 14;

/// Leaves and depth of a (sub)tree, summed over the parts built on different threads.
#[derive(Clone, Copy, Default)]
struct TreeStats {
    leaves: usize,
    depth: usize,
}

/// What the builder reads: every triangle's box and centroid (never written, shared by the threads).
struct Builder<'a> {
    prims: &'a [Prim],
    /// The most primitives in a leaf: [`MAX_LEAF`], or 1 for the top-level tree of a scene with
    /// instances (a leaf there is one placement: [`INSTANCE`]).
    max_leaf: usize,
}

/// Builds the hierarchy over `triangles` (each three vertices).
///
/// **In parallel, with the same tree as one thread**: a node's two halves are disjoint ranges of `order`,
/// so above [`PARALLEL_MIN`] triangles they are built at once on rayon's pool, each into its own node
/// array, and appended parent-left-right, which is the depth-first order the one-thread walk produces
/// (references to the appended nodes are shifted by where they land). The splits depend only on the
/// triangles, so the tree, the order and the bits of every render are the same on any number of threads.
pub fn build(triangles: &[[Vec3; 3]]) -> Bvh {
    use rayon::prelude::*;
    assert!(
        triangles.len() <= super::mesh::MAX_TRIANGLES,
        "the scene parser caps triangles"
    );
    let start = Instant::now();
    let boxes: Vec<Aabb> = triangles
        .par_iter()
        .map(|t| {
            let mut b = Aabb::EMPTY;
            t.iter().for_each(|&p| b.grow(p));
            b
        })
        .collect();
    build_prims(&boxes, MAX_LEAF, start)
}

/// Builds the hierarchy over primitives given by their boxes (spheres: `upload`'s sphere tree), as
/// [`build`] does over triangles; the primitives must be uploaded in `order`.
pub fn build_boxes(boxes: &[Aabb]) -> Bvh {
    build_prims(boxes, MAX_LEAF, Instant::now())
}

/// Builds the hierarchy over boxes with one primitive in each leaf: the top-level tree over the
/// placements of a scene with instances (a leaf enters one placement's own tree).
pub fn build_single_leaves(boxes: &[Aabb]) -> Bvh {
    build_prims(boxes, 1, Instant::now())
}

fn build_prims(boxes: &[Aabb], max_leaf: usize, start: Instant) -> Bvh {
    use rayon::prelude::*;
    let n = boxes.len();
    if n == 0 {
        return Bvh::default();
    }
    // The box centre: what binning sorts by (pbrt-v4 does the same).
    let prims: Vec<Prim> = boxes
        .par_iter()
        .map(|&b| Prim {
            bounds: b,
            centroid: (b.lo + b.hi) * 0.5,
        })
        .collect();
    let builder = Builder {
        prims: &prims,
        max_leaf,
    };
    let mut order: Vec<u32> = (0..n as u32).collect();
    let mut nodes = Vec::with_capacity(n / 2 + 1);
    nodes.push(Node {
        bounds: [Aabb::EMPTY; 2],
        child: [0; 2],
    });
    let mut stats = TreeStats::default();
    // The root is always an interior node (the shader starts at node 0). A single triangle gets the
    // same leaf on both sides, which costs one repeated test and changes no result.
    if n == 1 {
        let leaf = Builder::leaf(0, 1);
        let b = prims[0].bounds;
        nodes[0] = Node {
            bounds: [b, b],
            child: [leaf, leaf],
        };
        stats = TreeStats {
            leaves: 1,
            depth: 1,
        };
    } else {
        let (bounds, centroids) = builder.bounds(&order);
        let split = builder.choose_split(&order, &bounds, &centroids, 1);
        builder.fill(
            0, &mut order, 0, 1, &centroids, split, &mut nodes, &mut stats,
        );
    }
    Bvh {
        nodes,
        order,
        leaves: stats.leaves,
        depth: stats.depth,
        build_seconds: start.elapsed().as_secs_f64(),
    }
}

impl Builder<'_> {
    fn bounds(&self, order: &[u32]) -> (Aabb, Aabb) {
        let mut b = Aabb::EMPTY;
        let mut c = Aabb::EMPTY;
        for &i in order {
            let p = &self.prims[i as usize];
            b = b.union(&p.bounds);
            c.grow(p.centroid);
        }
        (b, c)
    }

    /// The leaf over triangles `[start, end)` of the final order.
    fn leaf(start: usize, end: usize) -> u32 {
        debug_assert!(end > start && end - start <= MAX_LEAF);
        LEAF | ((start as u32) << LEAF_COUNT_BITS) | (end - start - 1) as u32
    }

    /// The split `subtree` and the root use: binned SAH, or the median below [`SAH_MAX_DEPTH`] (None).
    fn choose_split(
        &self,
        order: &[u32],
        bounds: &Aabb,
        centroids: &Aabb,
        depth: usize,
    ) -> Option<(f64, usize, usize)> {
        if depth >= SAH_MAX_DEPTH {
            None
        } else {
            self.best_sah_split(order, bounds, centroids)
        }
    }

    /// Builds the subtree over `order` (the final order's triangles `base ..`), appending its interior
    /// nodes to `out` depth-first, and returns its reference and box.
    fn subtree(
        &self,
        order: &mut [u32],
        base: usize,
        depth: usize,
        out: &mut Vec<Node>,
        stats: &mut TreeStats,
    ) -> (u32, Aabb) {
        let (bounds, centroids) = self.bounds(order);
        let n = order.len();
        let split = self.choose_split(order, &bounds, &centroids, depth);
        // SAH: a leaf costs n triangle tests; a split costs what best_sah_split computed.
        if n <= self.max_leaf && split.is_none_or(|(cost, _, _)| cost >= n as f64) {
            stats.leaves += 1;
            return (Self::leaf(base, base + n), bounds);
        }
        let index = out.len();
        out.push(Node {
            bounds: [Aabb::EMPTY; 2],
            child: [0; 2],
        });
        self.fill(index, order, base, depth, &centroids, split, out, stats);
        (index as u32, bounds)
    }

    /// Makes node `out[index]` the interior node over `order`: partitions by `split` (or at the median)
    /// and builds both subtrees, on two threads when `order` is large (see [`build`]).
    #[allow(clippy::too_many_arguments)]
    fn fill(
        &self,
        index: usize,
        order: &mut [u32],
        base: usize,
        depth: usize,
        centroids: &Aabb,
        split: Option<(f64, usize, usize)>,
        out: &mut Vec<Node>,
        stats: &mut TreeStats,
    ) {
        stats.depth = stats.depth.max(depth);
        let mid = match split {
            Some((_, axis, plane)) => self.partition(order, centroids, axis, plane),
            None => self.median(order, centroids),
        };
        let n = order.len();
        let (lo, hi) = order.split_at_mut(mid);
        let ((left, lb), (right, rb)) = if n >= PARALLEL_MIN {
            let half = |order: &mut [u32], base: usize| {
                let mut nodes = Vec::new();
                let mut s = TreeStats::default();
                let (r, b) = self.subtree(order, base, depth + 1, &mut nodes, &mut s);
                (r, b, nodes, s)
            };
            let ((l, lb, ln, ls), (r, rb, rn, rs)) =
                rayon::join(|| half(lo, base), || half(hi, base + mid));
            for s in [ls, rs] {
                stats.leaves += s.leaves;
                stats.depth = stats.depth.max(s.depth);
            }
            ((append(out, ln, l), lb), (append(out, rn, r), rb))
        } else {
            (
                self.subtree(lo, base, depth + 1, out, stats),
                self.subtree(hi, base + mid, depth + 1, out, stats),
            )
        };
        out[index] = Node {
            bounds: [lb, rb],
            child: [left, right],
        };
    }

    /// The bin of a centroid coordinate `c` on an axis whose centroids span [lo, lo + extent].
    fn bin(c: f32, lo: f32, scale: f64) -> usize {
        (((c - lo) as f64 * scale) as usize).min(BINS - 1)
    }

    /// The cheapest binned SAH split of `order`: (cost, axis, last bin on the left), or None when all
    /// centroids coincide. Costs are in units of one triangle test (see the module comment).
    fn best_sah_split(
        &self,
        order: &[u32],
        bounds: &Aabb,
        centroids: &Aabb,
    ) -> Option<(f64, usize, usize)> {
        let area = bounds.surface_area();
        let mut best: Option<(f64, usize, usize)> = None;
        for axis in 0..3 {
            let lo = centroids.lo[axis];
            let extent = (centroids.hi[axis] - lo) as f64;
            if extent <= 0.0 {
                continue;
            }
            let scale = BINS as f64 / extent;
            let mut counts = [0usize; BINS];
            let mut boxes = [Aabb::EMPTY; BINS];
            for &i in order {
                let p = &self.prims[i as usize];
                let b = Self::bin(p.centroid[axis], lo, scale);
                counts[b] += 1;
                boxes[b] = boxes[b].union(&p.bounds);
            }
            // right[k]: (area, count) of bins k..BINS, swept from the right.
            let mut right = [(0.0f64, 0usize); BINS];
            let mut acc = Aabb::EMPTY;
            let mut count = 0;
            for k in (1..BINS).rev() {
                acc = acc.union(&boxes[k]);
                count += counts[k];
                right[k] = (acc.surface_area(), count);
            }
            let mut acc = Aabb::EMPTY;
            let mut count = 0;
            for k in 0..BINS - 1 {
                acc = acc.union(&boxes[k]);
                count += counts[k];
                let (right_area, right_count) = right[k + 1];
                if count == 0 || right_count == 0 {
                    continue;
                }
                let cost = if area > 0.0 {
                    1.0 + (acc.surface_area() * count as f64 + right_area * right_count as f64)
                        / area
                } else {
                    // Every triangle is a point (zero-area box): any split costs the same.
                    1.0 + order.len() as f64
                };
                if best.is_none_or(|(c, _, _)| cost < c) {
                    best = Some((cost, axis, k));
                }
            }
        }
        best
    }

    /// Puts the triangles whose centroid falls in bins 0..=plane first; returns where the rest start.
    fn partition(&self, order: &mut [u32], centroids: &Aabb, axis: usize, plane: usize) -> usize {
        let lo = centroids.lo[axis];
        let scale = BINS as f64 / (centroids.hi[axis] - lo) as f64;
        let (mut i, mut j) = (0, order.len());
        while i < j {
            let c = self.prims[order[i] as usize].centroid[axis];
            if Self::bin(c, lo, scale) <= plane {
                i += 1;
            } else {
                j -= 1;
                order.swap(i, j);
            }
        }
        // best_sah_split only returns planes with triangles on both sides.
        debug_assert!(i > 0 && i < order.len());
        i
    }

    /// Splits at the median centroid along the longest axis of the centroids' box (any order when they
    /// all coincide): both halves are non-empty and at most half the size, rounded up.
    fn median(&self, order: &mut [u32], centroids: &Aabb) -> usize {
        let mid = order.len() / 2;
        let extent = centroids.hi - centroids.lo;
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        if extent[axis] > 0.0 {
            let prims = self.prims;
            order.select_nth_unstable_by(mid, |&a, &b| {
                prims[a as usize].centroid[axis].total_cmp(&prims[b as usize].centroid[axis])
            });
        }
        mid
    }
}

/// Appends `nodes` (a subtree built on its own, its references relative to its first node) to `out`,
/// shifting its interior references by where it lands; returns the subtree's reference in `out`.
fn append(out: &mut Vec<Node>, nodes: Vec<Node>, reference: u32) -> u32 {
    let offset = out.len() as u32;
    let shift = |r: u32| if r & LEAF != 0 { r } else { r + offset };
    out.extend(nodes.into_iter().map(|n| Node {
        bounds: n.bounds,
        child: n.child.map(shift),
    }));
    shift(reference)
}

impl Bvh {
    /// Visits the leaves' triangle ranges (start, count), depth-first.
    pub fn leaf_ranges(&self) -> Vec<(usize, usize)> {
        let mut out = Vec::new();
        let mut stack = vec![0u32];
        if self.nodes.is_empty() {
            return out;
        }
        while let Some(r) = stack.pop() {
            if r & LEAF != 0 {
                let first = ((r & !LEAF) >> LEAF_COUNT_BITS) as usize;
                out.push((first, (r & LEAF_COUNT_MASK) as usize + 1));
            } else {
                let node = &self.nodes[r as usize];
                stack.push(node.child[1]);
                stack.push(node.child[0]);
            }
        }
        out
    }
}

/// Children per node of the tree the shader walks ([`WideNode`]).
pub const WIDTH: usize = 4;
/// An unused child slot of a [`WideNode`] (its box is empty; the shader skips it by this reference).
pub const NO_CHILD: u32 = u32::MAX;

/// A node of the 4-wide tree the shader walks: up to [`WIDTH`] children, each a node index or a leaf
/// reference ([`LEAF`]), with their boxes; unused slots are [`NO_CHILD`].
///
/// **Why 4 wide** (Dammertz et al., "Shallow Bounding Volume Hierarchies for Fast SIMD Ray Tracing of
/// Incoherent Rays", 2008; Wald et al. 2008; Embree's BVH4): one visit tests four boxes with 4-lane vector
/// arithmetic, and a walk visits about half as many nodes as in the binary tree (the depth is about
/// halved), so the walk's per-iteration costs (the loop itself, the node fetch, the stack) are paid about
/// half as often. docs/performance.md has the measurement that decided it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WideNode {
    pub bounds: [Aabb; WIDTH],
    pub child: [u32; WIDTH],
}

impl Bvh {
    /// The 4-wide tree of this binary one, with the same leaves (so the same triangle order): each wide
    /// node takes a binary node's two children and, while it has fewer than four, replaces its child of
    /// largest surface area that is an interior node by that node's two children (the greedy collapse of
    /// Wald, Benthin & Boulos 2008 and pbrt-v3's discussion of wide BVHs). Node 0 is the root.
    ///
    /// The shader's stack ([`STACK_SIZE`] entries) holds, for every node on the current path, the children
    /// it has not yet visited: at most (children - 1) per node. The collapse checks the largest sum along
    /// any root-to-leaf path; in the rare tree where it exceeds the stack (a deep, median-split chain),
    /// it keeps the binary nodes instead (two children each, one pending per level, which the binary
    /// tree's depth bound already fits).
    pub fn wide(&self) -> Vec<WideNode> {
        if self.nodes.is_empty() {
            return Vec::new();
        }
        let mut out = Vec::with_capacity(self.nodes.len() / 2 + 1);
        self.collapse(0, true, &mut out);
        if wide_stack_need(&out, 0) > STACK_SIZE {
            out.clear();
            self.collapse(0, false, &mut out);
        }
        out
    }

    /// Appends the wide node for binary node `node` (and, after it, its subtrees); returns its index.
    fn collapse(&self, node: usize, expand: bool, out: &mut Vec<WideNode>) -> u32 {
        let n = &self.nodes[node];
        let mut kids: Vec<(u32, Aabb)> = vec![(n.child[0], n.bounds[0]), (n.child[1], n.bounds[1])];
        while expand && kids.len() < WIDTH {
            let widest = kids
                .iter()
                .enumerate()
                .filter(|(_, (r, _))| r & LEAF == 0)
                .max_by(|(_, (_, a)), (_, (_, b))| a.surface_area().total_cmp(&b.surface_area()))
                .map(|(i, _)| i);
            let Some(i) = widest else { break };
            let inner = &self.nodes[kids[i].0 as usize];
            kids[i] = (inner.child[0], inner.bounds[0]);
            kids.insert(i + 1, (inner.child[1], inner.bounds[1]));
        }
        let index = out.len();
        out.push(WideNode {
            bounds: [Aabb::EMPTY; WIDTH],
            child: [NO_CHILD; WIDTH],
        });
        for (k, (r, b)) in kids.into_iter().enumerate() {
            let r = if r & LEAF != 0 {
                r
            } else {
                self.collapse(r as usize, expand, out)
            };
            out[index].child[k] = r;
            out[index].bounds[k] = b;
        }
        index as u32
    }
}

/// A [`WideNode`]'s child boxes quantised to 8 bits per plane, relative to the node's own box (Ylitie,
/// Karras & Laine, "Efficient Incoherent Ray Traversal on GPUs Through Compressed Wide BVHs", HPG 2017,
/// §3.1): per axis a = origin + q scale, with q in 0..=255 and scale a power of two, each child's lower
/// plane rounded down and its upper plane rounded up, so that every decoded box contains the exact one.
///
/// **Why.** On lavapipe the walk's cost is dominated by fetching nodes: a ray's node index differs from
/// lane to lane, so each word of a node is a gather. Measured: fetching a second 28-word node per visit
/// made the whole render 50 % slower (Bitterli's Cornell box and veach-bidir). Quantised, a node's boxes
/// take 10 words instead of 24 (docs/performance.md has the gain).
///
/// **Exactness.** The shader decodes a plane as `origin + f32(q) * scale`: the product is exact (an 8-bit
/// integer times a power of two, kept in the normal range by [`MIN_SCALE_EXP`]), so the one rounding is
/// the sum's, correctly rounded in Vulkan as here; [`quantise`] checks each plane with that very
/// arithmetic and moves q outward until it holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuantisedNode {
    /// The node's box's lower corner.
    pub origin: [f32; 3],
    /// Per axis, the biased f32 exponent e of the scale 2^(e - 127), in bits 0-7, 8-15, 16-23.
    pub exponents: u32,
    /// Child k's quantised planes in byte k of: lo_x, hi_x, lo_y, hi_y, lo_z, hi_z.
    pub planes: [u32; 6],
    pub child: [u32; WIDTH],
}

/// The smallest biased exponent of a scale: 2^-100, far above the subnormals (which a device may flush
/// to zero), so that q scale stays exact.
pub const MIN_SCALE_EXP: u32 = 27;

/// The plane `q` decodes to on axis origin `o` with scale `s`: the shader's arithmetic (bvh.wgsl).
pub fn decode_plane(o: f32, q: u32, s: f32) -> f32 {
    o + q as f32 * s
}

/// Quantises a wide node (see [`QuantisedNode`]).
pub fn quantise(n: &WideNode) -> QuantisedNode {
    let used: Vec<usize> = (0..WIDTH).filter(|&k| n.child[k] != NO_CHILD).collect();
    let mut all = Aabb::EMPTY;
    for &k in &used {
        all = all.union(&n.bounds[k]);
    }
    let mut exponents = 0u32;
    let mut planes = [0u32; 6];
    for axis in 0..3 {
        let o = all.lo[axis];
        // The smallest power of two with (hi - o) / scale <= 254, in f64 (no rounding of the extent), so
        // that rounding the upper plane up and one correction step stay within 255.
        let extent = all.hi[axis] as f64 - o as f64;
        let scale = |e: u32| f64::powi(2.0, e as i32 - 127);
        let mut e = if extent > 0.0 {
            ((extent / 254.0).log2().ceil() as i32 + 127).clamp(MIN_SCALE_EXP as i32, 254) as u32
        } else {
            MIN_SCALE_EXP
        };
        // (log2 rounds: settle on the smallest exponent that fits.)
        while e < 254 && extent / scale(e) > 254.0 {
            e += 1;
        }
        while e > MIN_SCALE_EXP && extent / scale(e - 1) <= 254.0 {
            e -= 1;
        }
        let s = f32::from_bits(e << 23);
        exponents |= e << (8 * axis);
        for &k in &used {
            let (lo, hi) = (n.bounds[k].lo[axis], n.bounds[k].hi[axis]);
            let mut q_lo = (((lo as f64 - o as f64) / s as f64).floor().max(0.0) as u32).min(255);
            while q_lo > 0 && decode_plane(o, q_lo, s) > lo {
                q_lo -= 1;
            }
            let mut q_hi = (((hi as f64 - o as f64) / s as f64).ceil().max(0.0) as u32).min(255);
            while q_hi < 255 && decode_plane(o, q_hi, s) < hi {
                q_hi += 1;
            }
            debug_assert!(decode_plane(o, q_lo, s) <= lo && decode_plane(o, q_hi, s) >= hi);
            planes[2 * axis] |= q_lo << (8 * k);
            planes[2 * axis + 1] |= q_hi << (8 * k);
        }
    }
    QuantisedNode {
        origin: all.lo.into(),
        exponents,
        planes,
        child: n.child,
    }
}

/// The boxes a [`QuantisedNode`] decodes to, as the shader decodes them (unused slots included).
pub fn dequantise(q: &QuantisedNode) -> [Aabb; WIDTH] {
    std::array::from_fn(|k| {
        let mut lo = Vec3::ZERO;
        let mut hi = Vec3::ZERO;
        for axis in 0..3 {
            let s = f32::from_bits(((q.exponents >> (8 * axis)) & 0xff) << 23);
            let byte = |w: u32| (w >> (8 * k)) & 0xff;
            lo[axis] = decode_plane(q.origin[axis], byte(q.planes[2 * axis]), s);
            hi[axis] = decode_plane(q.origin[axis], byte(q.planes[2 * axis + 1]), s);
        }
        Aabb { lo, hi }
    })
}

/// The most traversal-stack entries a walk of the wide tree below `node` can hold: (children - 1) at each
/// node of a root-to-leaf path, summed, the largest over all paths.
pub fn wide_stack_need(nodes: &[WideNode], node: usize) -> usize {
    let n = &nodes[node];
    let used = n.child.iter().filter(|&&c| c != NO_CHILD).count();
    let below = n
        .child
        .iter()
        .filter(|&&c| c != NO_CHILD && c & LEAF == 0)
        .map(|&c| wide_stack_need(nodes, c as usize))
        .max()
        .unwrap_or(0);
    used.saturating_sub(1) + below
}

#[cfg(test)]
mod tests {
    use super::*;

    fn random_triangles(n: usize, seed: u64) -> Vec<[Vec3; 3]> {
        let mut state = seed;
        let mut next = move || {
            // SplitMix64.
            state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
        };
        (0..n)
            .map(|_| {
                let c = Vec3::new(next(), next(), next()) * 100.0;
                let mut v = || c + Vec3::new(next(), next(), next()) * 2.0;
                [v(), v(), v()]
            })
            .collect()
    }

    /// Every triangle is in exactly one leaf, every child box contains what is below it, and the depth
    /// fits the shader's stack.
    fn check_invariants(tris: &[[Vec3; 3]], bvh: &Bvh) {
        let mut seen = vec![0u32; tris.len()];
        for &i in &bvh.order {
            seen[i as usize] += 1;
        }
        assert!(seen.iter().all(|&c| c == 1), "order is not a permutation");
        let mut covered = vec![0u32; tris.len()];
        fn check(
            bvh: &Bvh,
            tris: &[[Vec3; 3]],
            r: u32,
            bounds: Aabb,
            depth: usize,
            covered: &mut [u32],
        ) -> usize {
            if r & LEAF != 0 {
                let first = ((r & !LEAF) >> LEAF_COUNT_BITS) as usize;
                let count = (r & LEAF_COUNT_MASK) as usize + 1;
                for k in first..first + count {
                    covered[k] += 1;
                    for v in tris[bvh.order[k] as usize] {
                        assert!(bounds.contains(&Aabb { lo: v, hi: v }));
                    }
                }
                return depth;
            }
            let node = &bvh.nodes[r as usize];
            let mut deepest = depth;
            for side in 0..2 {
                assert!(bounds.contains(&node.bounds[side]));
                deepest = deepest.max(check(
                    bvh,
                    tris,
                    node.child[side],
                    node.bounds[side],
                    depth + 1,
                    covered,
                ));
            }
            deepest
        }
        let all = Aabb {
            lo: Vec3::splat(f32::NEG_INFINITY),
            hi: Vec3::splat(f32::INFINITY),
        };
        let depth = check(bvh, tris, 0, all, 0, &mut covered);
        // The leaves' own depth is one more than their parent's.
        assert!(depth <= STACK_SIZE, "depth {depth}");
        // (A single triangle is the one leaf on both sides of the root.)
        let expected = if tris.len() == 1 { 2 } else { 1 };
        assert!(
            covered.iter().all(|&c| c == expected),
            "a triangle is in no or several leaves"
        );
        if tris.len() > 1 {
            assert_eq!(bvh.leaf_ranges().len(), bvh.leaves);
            assert_eq!(bvh.nodes.len() + 1, bvh.leaves, "a binary tree");
        }
        check_wide(tris, bvh);
    }

    /// The wide tree: the binary tree's leaves, each reached once; every child's box the binary tree's
    /// box of the same subtree (so it holds the subtree's triangles); unused slots only after used ones;
    /// and the stack need within the shader's stack.
    fn check_wide(tris: &[[Vec3; 3]], bvh: &Bvh) {
        let wide = bvh.wide();
        fn leaves(wide: &[WideNode], node: usize, out: &mut Vec<u32>) -> Vec<Vec3> {
            let mut points = Vec::new();
            let n = &wide[node];
            let used = n.child.iter().take_while(|&&c| c != NO_CHILD).count();
            assert!(used >= 2, "a wide node has at least two children");
            assert!(n.child[used..].iter().all(|&c| c == NO_CHILD));
            for k in 0..used {
                let below = if n.child[k] & LEAF != 0 {
                    out.push(n.child[k]);
                    vec![]
                } else {
                    leaves(wide, n.child[k] as usize, out)
                };
                for p in &below {
                    assert!(n.bounds[k].contains(&Aabb { lo: *p, hi: *p }));
                }
                points.extend(below);
                points.push(n.bounds[k].lo);
                points.push(n.bounds[k].hi);
            }
            points
        }
        let mut wide_leaves = Vec::new();
        leaves(&wide, 0, &mut wide_leaves);
        // The leaves' triangles lie in their boxes: a leaf's box is its slot's box.
        fn leaf_boxes(wide: &[WideNode]) -> Vec<(u32, Aabb)> {
            wide.iter()
                .flat_map(|n| {
                    n.child
                        .iter()
                        .zip(n.bounds)
                        .filter(|(c, _)| **c != NO_CHILD && **c & LEAF != 0)
                })
                .map(|(c, b)| (*c, b))
                .collect()
        }
        for (r, b) in leaf_boxes(&wide) {
            let first = ((r & !LEAF) >> LEAF_COUNT_BITS) as usize;
            let count = (r & LEAF_COUNT_MASK) as usize + 1;
            for k in first..first + count {
                for v in tris[bvh.order[k] as usize] {
                    assert!(b.contains(&Aabb { lo: v, hi: v }));
                }
            }
        }
        let mut binary: Vec<u32> = Vec::new();
        let mut stack = vec![0u32];
        while let Some(r) = stack.pop() {
            if r & LEAF != 0 {
                binary.push(r);
            } else {
                stack.extend(bvh.nodes[r as usize].child);
            }
        }
        wide_leaves.sort_unstable();
        binary.sort_unstable();
        assert_eq!(wide_leaves, binary, "the same leaves, once each");
        assert!(wide_stack_need(&wide, 0) <= STACK_SIZE);
        assert!(wide.len() <= bvh.nodes.len());
    }

    #[test]
    fn random_triangles_make_a_valid_tree() {
        for n in [1usize, 2, 3, 4, 5, 17, 1000, 20_000] {
            let tris = random_triangles(n, n as u64);
            let bvh = build(&tris);
            check_invariants(&tris, &bvh);
            if n >= 1000 {
                // SAH on scattered small triangles: shallow, small leaves.
                assert!(bvh.depth < 40, "n = {n}: depth {}", bvh.depth);
                assert!(bvh.leaves as f64 > n as f64 / MAX_LEAF as f64);
            }
        }
    }

    /// The halves built on other threads are stitched back in the one-thread depth-first order: one
    /// thread and the whole pool make the same nodes, order, leaf count and depth (so the same bits).
    #[test]
    fn parallel_build_makes_the_one_thread_tree() {
        let tris = random_triangles(4 * PARALLEL_MIN + 123, 7);
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| build(&tris));
        let many = rayon::ThreadPoolBuilder::new()
            .num_threads(4)
            .build()
            .unwrap()
            .install(|| build(&tris));
        check_invariants(&tris, &many);
        assert_eq!(one.nodes, many.nodes);
        assert_eq!(one.order, many.order);
        assert_eq!((one.leaves, one.depth), (many.leaves, many.depth));
    }

    #[test]
    fn identical_triangles_still_split_into_small_leaves() {
        let t = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let tris = vec![t; 1000];
        let bvh = build(&tris);
        check_invariants(&tris, &bvh);
        // Median splits of 1000 coincident triangles: log2(1000 / 4) + 1 levels.
        assert!(bvh.depth <= 10, "depth {}", bvh.depth);
    }

    #[test]
    fn a_degenerate_chain_stays_within_the_stack() {
        // Triangles whose sizes grow geometrically: SAH alone would peel one off per level.
        let tris: Vec<[Vec3; 3]> = (0..3000)
            .map(|i| {
                let s = 1.01f32.powi(i);
                [Vec3::ZERO, Vec3::X * s, Vec3::Y * s]
            })
            .collect();
        let bvh = build(&tris);
        check_invariants(&tris, &bvh);
    }

    /// Every decoded box contains its child's exact box, and is tight: within two steps of the scale on each
    /// side (one for the rounding outward, one for a correction), for boxes at every scale from 1e-20 to
    /// 1e30, offsets from the origin included, and for flat boxes.
    #[test]
    fn quantised_boxes_contain_the_exact_ones_and_stay_tight() {
        let mut state = 12345u64;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 40) as f32) / (1u64 << 24) as f32
        };
        let mut checked = 0;
        for exp in [-20i32, -5, 0, 3, 8, 20, 30] {
            for _ in 0..400 {
                let scale = 10f32.powi(exp);
                let centre =
                    Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * scale * 1e3 * next();
                let mut n = WideNode {
                    bounds: [Aabb::EMPTY; WIDTH],
                    child: [NO_CHILD; WIDTH],
                };
                let used = 2 + (next() * 3.0) as usize % 3;
                for k in 0..used {
                    let a = centre + Vec3::new(next(), next(), next()) * scale;
                    let mut b = a + Vec3::new(next(), next(), next()) * scale * next();
                    if next() < 0.2 {
                        b.y = a.y; // flat
                    }
                    n.bounds[k] = Aabb {
                        lo: a.min(b),
                        hi: a.max(b),
                    };
                    n.child[k] = k as u32;
                }
                let q = quantise(&n);
                let decoded = dequantise(&q);
                for (d, exact) in decoded.iter().zip(&n.bounds).take(used) {
                    assert!(d.contains(exact), "{d:?} does not contain {exact:?}");
                    for axis in 0..3 {
                        let s = f32::from_bits(((q.exponents >> (8 * axis)) & 0xff) << 23) as f64;
                        let slack_lo = exact.lo[axis] as f64 - d.lo[axis] as f64;
                        let slack_hi = d.hi[axis] as f64 - exact.hi[axis] as f64;
                        // Two steps, plus the rounding of the origin's sum (an ulp of the coordinates).
                        let ulp = (exact.hi[axis].abs().max(exact.lo[axis].abs()) as f64)
                            * 2f64.powi(-22);
                        assert!(
                            slack_lo <= 2.0 * s + ulp && slack_hi <= 2.0 * s + ulp,
                            "axis {axis}: slack {slack_lo} {slack_hi}, scale {s}"
                        );
                    }
                    checked += 1;
                }
            }
        }
        assert!(checked > 5000);
    }

    #[test]
    fn the_wide_tree_has_about_half_the_depth_and_nodes() {
        let tris = random_triangles(20_000, 7);
        let bvh = build(&tris);
        let wide = bvh.wide();
        fn depth(wide: &[WideNode], node: usize) -> usize {
            1 + wide[node]
                .child
                .iter()
                .filter(|&&c| c != NO_CHILD && c & LEAF == 0)
                .map(|&c| depth(wide, c as usize))
                .max()
                .unwrap_or(0)
        }
        let d = depth(&wide, 0);
        // (Measured: 19,693 binary nodes of depth 17 become 9,510 wide nodes of depth 9. Not a third: a
        // binary node whose children are both leaves stays a two-child node.)
        assert!(
            wide.len() * 20 <= bvh.nodes.len() * 11,
            "{} of {} nodes",
            wide.len(),
            bvh.nodes.len()
        );
        assert!(
            d * 2 <= bvh.depth + 2,
            "wide depth {d}, binary {}",
            bvh.depth
        );
    }
}
