// bvh.wgsl: the triangle BVH (built on the host by src/scene/bvh.rs, nodes in `bvh_nodes`), walked without
// recursion; and the spheres' BVH (`sphere_nodes`, when a scene has many: src/kernel/upload.rs), the same
// kind of tree over the spheres' boxes, walked by the same code with spheres in its leaves.
//
// The tree is 4 wide: node 0 is the root and is always an interior node; an interior node stores the
// boxes of its (up to) four children, quantised to a byte per plane (Ylitie, Karras & Laine 2017), and one
// visit decodes and tests all four boxes at once with four-lane vectors,
// goes on with the nearest child the ray enters and pushes the others (with their entry distances) on a
// small stack, farthest first; a popped entry is skipped when the closest hit found since is nearer than
// where the ray enters its box (Aila & Laine, "Understanding the Efficiency of Ray Traversal on GPUs",
// HPG 2009, for storing the children's boxes in the parent; Dammertz et al. 2008 and Embree's BVH4 for the
// width; pbrt-v4 §7.3.5 for the stack walk). Leaves are ranges of at most 4 triangles in `triangles` (of
// spheres in `spheres`, in the spheres' tree).
//
// A child reference with BVH_LEAF set is a leaf, first = (ref & ~BVH_LEAF) >> BVH_LEAF_COUNT_BITS and
// count = (ref & BVH_LEAF_COUNT_MASK) + 1; BVH_NONE is an unused slot; otherwise it is a node index.
// (Mirrors src/scene/bvh.rs.)
//
// Instances (a two-level BVH; src/kernel/upload.rs, add_instanced): the top-level tree's leaves are
// placements of meshes whose triangles and trees are stored once, in the mesh's own space. Reaching one,
// the walk maps the ray into that space (o' = M^-1 o, d' = M^-1 d, not renormalised, so that t is the
// same parameter along both rays and the closest hit so far culls in either), pushes BVH_EXIT and goes
// on in the placement's tree; popping BVH_EXIT restores the world ray (pbrt-v4 §7.1.4's
// TransformedPrimitive, with the recursion turned into the walk's own stack, as Embree's instancing does).
//
// requires: scene_data.wgsl, intersect.wgsl, opacity.wgsl
const BVH_LEAF: u32 = 0x80000000u;
// In a scene with instances (HAS_INSTANCES), a top-level leaf is one placement: BVH_LEAF | BVH_INSTANCE |
// (i << BVH_LEAF_COUNT_BITS) for instances[i]. BVH_EXIT (never a placement's reference: the host keeps
// their indices below 2^28) is what the walk pushes under a placement's tree, to take the ray back to
// the world when the tree is done.
const BVH_INSTANCE: u32 = 0x40000000u;
const BVH_EXIT: u32 = 0xfffffffeu;
const BVH_LEAF_COUNT_BITS: u32 = 2u;
const BVH_LEAF_COUNT_MASK: u32 = 3u;
const BVH_NONE: u32 = 0xffffffffu;
// The host checks that the tree fits (src/scene/bvh.rs, Bvh::wide): at most (children - 1) entries per
// level of the current path are pending.
const BVH_STACK_SIZE: u32 = 64u;
// Lavapipe ends all loops of an invocation after 65535 iterations in total, and the renderer bounds a
// ray cast's iterations before rendering, so one traversal runs at most this many iterations: one interior
// node (four boxes) or one triangle each. Typical rays need a few dozen to a few hundred (src/scene/bvh.rs, MAX_STEPS,
// explains the choice; tests/shader_bvh.rs measures it).
const BVH_MAX_STEPS: u32 = 2048u;

// Boxes are culled against the closest hit so far widened by this factor (~128 ulps). A box's entry
// distance and a triangle's t are both rounded, and where a triangle touches its box's face (at a vertex,
// every box's faces are vertex coordinates) the entry distance can come out an ulp or two beyond the t of
// the triangle inside: without the slack, a walk could skip the box of a triangle an ulp nearer than the
// hit it holds, and return a hit one ulp farther than the brute-force loop. The slack costs a box test on
// the rare boxes entered within 1.5e-5 (relative) beyond the hit.
const BVH_CULL_SLACK: f32 = 1.0000153; // 1 + 2^-16

// The traversal stack: child references and the distances at which the ray enters their boxes. Module
// scope (`private`: one per invocation) rather than function locals, because WGSL zero-initialises a
// function's variables on every call: 512 bytes cleared per walk, measured at 5x the cost of a whole
// walk on lavapipe for small scenes. Private variables are cleared once per invocation, and every walk
// writes an entry before reading it.
var<private> bvh_stack_ref: array<u32, BVH_STACK_SIZE>;
var<private> bvh_stack_t: array<f32, BVH_STACK_SIZE>;

// Iterations the last walk ran (BVH_MAX_STEPS when it reached the cap); read by tests/shader_bvh.rs, dead in the
// render kernel (the compiler drops the store).
var<private> bvh_last_steps: u32;

// 1/d per component, with an exact ±infinity where |d| is below the smallest normal f32: the Vulkan
// precision rules leave x / 0 undefined, and intersect_aabb decides an axis whose 1/d is infinite by the
// origin's position alone.
fn ray_inverse(d: vec3<f32>) -> vec3<f32> {
    let inf = vec3<f32>(bitcast<f32>(0x7f800000u));
    let signed_inf = select(inf, -inf, d < vec3<f32>(0.0));
    return select(1.0 / d, signed_inf, abs(d) < vec3<f32>(1.17549435e-38));
}

// The four child boxes of a node, decoded (src/scene/bvh.rs, QuantisedNode): plane = origin + q scale per
// axis, q the child's byte of the plane's word, scale = 2^(e - 127) built from its exponent bits. The
// product is exact and the sum correctly rounded, so these are the boxes the host checked to contain the
// children (scene::bvh::quantise).
fn bytes4(w: u32) -> vec4<f32> {
    return vec4<f32>((vec4<u32>(w) >> vec4<u32>(0u, 8u, 16u, 24u)) & vec4<u32>(0xffu));
}

fn decode_boxes(n: BvhNode) -> Boxes4 {
    let s = bitcast<vec3<f32>>(((vec3<u32>(n.exponents) >> vec3<u32>(0u, 8u, 16u)) & vec3<u32>(0xffu)) << vec3<u32>(23u));
    return Boxes4(
        n.origin.x + bytes4(n.planes_xy.x) * s.x,
        n.origin.x + bytes4(n.planes_xy.y) * s.x,
        n.origin.y + bytes4(n.planes_xy.z) * s.y,
        n.origin.y + bytes4(n.planes_xy.w) * s.y,
        n.origin.z + bytes4(n.planes_z.x) * s.z,
        n.origin.z + bytes4(n.planes_z.y) * s.z,
    );
}

// One compare-exchange of the sorting network in bvh_intersect: the pairs (ta, ca), (tb, cb) in ascending
// order of distance (strict: equal distances keep their order).
fn bvh_order(ta: ptr<function, f32>, tb: ptr<function, f32>, ca: ptr<function, u32>, cb: ptr<function, u32>) {
    if *tb < *ta {
        let t = *ta;
        *ta = *tb;
        *tb = t;
        let c = *ca;
        *ca = *cb;
        *cb = c;
    }
}

// Pushes a child the ray enters (t < T_MISS) with its entry distance.
fn bvh_push(sp: ptr<function, u32>, child: u32, t: f32) {
    if t < T_MISS {
        bvh_stack_ref[*sp] = child;
        bvh_stack_t[*sp] = t;
        *sp += 1u;
    }
}

// The closest triangle hit along o + t d with t in (0, t_max), or with any_hit the first one found (for
// shadow rays, which only ask whether something is in the way). Returns a Hit of kind PRIM_TRIANGLE whose
// prim_index is the triangle's index in `triangles`, or PRIM_NONE.
//
// One loop iteration does the node work and the triangle work side by side: it visits the next interior
// node (if the walk has one) and tests the next triangle of the current leaf (if one is left). A leaf the
// walk reaches waits, as the node to visit, until the current leaf is done. On SIMD hardware (a GPU's warp,
// lavapipe's 8 lanes) an iteration costs a node visit plus a triangle test whenever its lanes disagree on
// which to do, so a lane that does both in one iteration does for free what would otherwise take a second
// one: 10 % fewer iterations on Bitterli's veach-bidir, the same closest hits (docs/performance.md).
// Boxes are culled with the closest hit found so far, which only ever gets nearer, so the result is the
// closest hit whatever the order in which leaves are finished.
//
// Each iteration visits a node, tests a triangle, or pops an entry it culls (or ends the walk), so a walk
// runs at most 4 nodes + triangles + 1 iterations (three pushed entries per node), as
// render::worst_case_loop_iterations counts.
fn bvh_intersect(o: vec3<f32>, d: vec3<f32>, t_max: f32, any_hit: bool) -> Hit {
    return bvh_walk(o, d, t_max, any_hit, false);
}

// The same for the spheres' own tree (`sphere_nodes`, whose leaves index `spheres`): the closest sphere
// hit, as the loop over every sphere finds it (the same intersect_sphere, so the same t), or PRIM_NONE.
fn sphere_bvh_intersect(o: vec3<f32>, d: vec3<f32>, t_max: f32, any_hit: bool) -> Hit {
    return bvh_walk(o, d, t_max, any_hit, true);
}

// The walk of either tree: `sphere_tree` (a constant at each call, which the drivers fold after
// inlining) picks the node array and what a leaf holds.
fn bvh_walk(o: vec3<f32>, d: vec3<f32>, t_max: f32, any_hit: bool, sphere_tree: bool) -> Hit {
    var hit = Hit(t_max, PRIM_NONE, 0u, vec3<f32>(0.0), NO_INSTANCE);
    // The ray as the current tree sees it: in the world, or in a placement's space (instance).
    var ro = o;
    var rd = d;
    var inv_d = ray_inverse(d);
    var parallel = ray_parallel_axes(inv_d);
    var tr = triangle_ray(o, d);
    var instance = NO_INSTANCE;
    var sp = 0u;
    var node = 0u; // the next reference to visit (a node, or a leaf waiting for the current one), or BVH_NONE
    var first = 0u; // triangles [first, end) of the current leaf
    var end = 0u;
    var steps = 0u;
    for (; steps < BVH_MAX_STEPS; steps++) {
        if node == BVH_NONE && sp > 0u {
            sp -= 1u;
            // An entry whose box the ray enters beyond the closest hit found since it was pushed is skipped.
            if bvh_stack_t[sp] <= hit.t * BVH_CULL_SLACK {
                node = bvh_stack_ref[sp];
            }
        }
        if HAS_INSTANCES && !sphere_tree && first == end && node != BVH_NONE
           && (node & (BVH_LEAF | BVH_INSTANCE)) == (BVH_LEAF | BVH_INSTANCE) {
            if node == BVH_EXIT {
                // The placement's tree is done: back to the world ray.
                ro = o;
                rd = d;
                instance = NO_INSTANCE;
                node = BVH_NONE;
            } else {
                // Into placement i's space, and on with its tree's root (visited below, this iteration).
                instance = (node & ~(BVH_LEAF | BVH_INSTANCE)) >> BVH_LEAF_COUNT_BITS;
                let m = instance_at(instance);
                ro = vec3<f32>(dot(m.to_object_x.xyz, o) + m.to_object_x.w, dot(m.to_object_y.xyz, o) + m.to_object_y.w,
                               dot(m.to_object_z.xyz, o) + m.to_object_z.w);
                rd = vec3<f32>(dot(m.to_object_x.xyz, d), dot(m.to_object_y.xyz, d), dot(m.to_object_z.xyz, d));
                // (Never culled: its entry distance is 0.)
                bvh_stack_ref[sp] = BVH_EXIT;
                bvh_stack_t[sp] = 0.0;
                sp += 1u;
                node = m.root;
            }
            inv_d = ray_inverse(rd);
            parallel = ray_parallel_axes(inv_d);
            tr = triangle_ray(ro, rd);
        }
        if first == end && node != BVH_NONE && (node & BVH_LEAF) != 0u {
            first = (node & ~BVH_LEAF) >> BVH_LEAF_COUNT_BITS;
            end = first + (node & BVH_LEAF_COUNT_MASK) + 1u;
            node = BVH_NONE;
        }
        let visit = node != BVH_NONE && (node & BVH_LEAF) == 0u;
        let test = first != end;
        if !visit && !test {
            if node == BVH_NONE && sp == 0u {
                break;
            }
            continue; // the popped entry was culled
        }
        if visit {
            var n: BvhNode;
            if sphere_tree {
                n = sphere_node_at(node);
            } else {
                n = bvh_node_at(node);
            }
            let boxes = intersect_boxes4(ro, inv_d, parallel, decode_boxes(n), hit.t * BVH_CULL_SLACK);
            let t = select(boxes, vec4<f32>(T_MISS), n.child == vec4<u32>(BVH_NONE)); // unused slots
            // Sort the four (distance, child) pairs by distance, misses (T_MISS) last: a five-exchange
            // sorting network (Knuth, TAOCP 3, §5.3.4), strict comparisons so that equal distances keep
            // the children's order.
            var ta = t.x;
            var tb = t.y;
            var tc = t.z;
            var td = t.w;
            var ca = n.child.x;
            var cb = n.child.y;
            var cc = n.child.z;
            var cd = n.child.w;
            bvh_order(&ta, &tb, &ca, &cb);
            bvh_order(&tc, &td, &cc, &cd);
            bvh_order(&ta, &tc, &ca, &cc);
            bvh_order(&tb, &td, &cb, &cd);
            bvh_order(&tb, &tc, &cb, &cc);
            // The farthest waits deepest on the stack; the nearest is visited next.
            bvh_push(&sp, cd, td);
            bvh_push(&sp, cc, tc);
            bvh_push(&sp, cb, tb);
            node = select(BVH_NONE, ca, ta < T_MISS);
        }
        if test && sphere_tree {
            // One sphere of the current leaf, tested as the loop over spheres tests it (scene.wgsl).
            let sphere = sphere_at(first);
            let ts = intersect_sphere(o, d, sphere.center, sphere.radius, 0.0, hit.t);
            if ts < hit.t {
                let candidate = Hit(ts, PRIM_SPHERE, first, vec3<f32>(0.0), NO_INSTANCE);
                if !hit_is_transparent(o, d, candidate, sphere.material) {
                    hit = candidate;
                    if any_hit {
                        break;
                    }
                }
            }
            first += 1u;
        }
        if test && !sphere_tree {
            // One triangle of the current leaf: the same watertight test as the brute-force loop, so both
            // find the same closest hit.
            let tri = triangle_at(first);
            let th = intersect_triangle_ray(tr, tri.v0, tri.v1, tri.v2, 0.0, hit.t);
            if th.t < hit.t {
                // (A hit the surface's opacity lets through is no hit: scene.wgsl, hit_is_transparent.
                // Its hash takes the ray in the tree's space, so that two placements of one mesh decide
                // independently.)
                let candidate = Hit(th.t, PRIM_TRIANGLE, first, th.b, instance);
                if !hit_is_transparent(ro, rd, candidate, placed_material(tri.material, instance)) {
                    hit = candidate;
                    if any_hit {
                        break;
                    }
                }
            }
            first += 1u;
        }
    }
    bvh_last_steps = steps;
    return hit;
}
