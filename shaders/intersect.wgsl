// intersect.wgsl: ray–primitive tests and robust spawning of secondary rays.
//
// requires: (nothing)
//
// Conventions: ray directions are unit vectors; t is a distance along the ray. A miss returns T_MISS.
// Every hit also returns a conservative bound on the absolute floating-point error of the hit point, so
// that the next ray can start just outside that error box (pbrt-v4's scheme, Pharr et al. 2023, §6.8)
// instead of after an arbitrary epsilon that fails either at scale 1e-4 or at scale 1e5.

const T_MISS: f32 = 3.0e38;
// Unit roundoff of f32 (2^-24).
const F32_U: f32 = 5.9604645e-8;

// gamma(n) = n u / (1 - n u): the bound on the relative error of n chained roundings (Higham).
fn gamma_n(n: f32) -> f32 {
    return (n * F32_U) / (1.0 - n * F32_U);
}

// --- Spheres ----------------------------------------------------------------------------------------
// Solves |o + t d - c|^2 = r^2 with |d| = 1, i.e. t^2 + 2 b t + c0 = 0 with f = o - c, b = f.d,
// c0 = |f|^2 - r^2. Two precision measures (Haines et al., "Precision Improvements for Ray/Sphere
// Intersection", Ray Tracing Gems, ch. 7, 2019):
//  * the discriminant b^2 - c0 is computed as r^2 - |f - b d|^2 (the squared distance from the centre to
//    the ray's closest point), which does not cancel catastrophically for small spheres seen from afar;
//  * the two roots come from q = -b - sign(b) sqrt(disc): t0 = q and t1 = c0 / q, so neither is the
//    difference of two nearly equal numbers.
// Returns the smallest root in (t_min, t_max), or T_MISS.
fn intersect_sphere(o: vec3<f32>, d: vec3<f32>, center: vec3<f32>, radius: f32,
                    t_min: f32, t_max: f32) -> f32 {
    let f = o - center;
    let b = dot(f, d);
    let l = f - b * d;
    let disc = radius * radius - dot(l, l);
    if disc < 0.0 {
        return T_MISS;
    }
    let s = sqrt(disc);
    // (|f| - r)(|f| + r) keeps c0 accurate when the origin lies near the surface of a huge sphere.
    let lf = length(f);
    let c0 = (lf - radius) * (lf + radius);
    let q = select(-b + s, -b - s, b >= 0.0);
    var t0 = q;
    var t1 = select(c0 / q, t0, q == 0.0);
    if t0 > t1 {
        let tmp = t0;
        t0 = t1;
        t1 = tmp;
    }
    if t0 > t_min && t0 < t_max {
        return t0;
    }
    if t1 > t_min && t1 < t_max {
        return t1;
    }
    return T_MISS;
}

// A sphere hit point re-projected onto the surface (p = c + r (p - c)/|p - c|), which removes the error
// accumulated along a long ray, with its absolute error bound: the re-projection costs a few roundings
// relative to |p - c|, and adding back c costs one more relative to |p|.
struct SurfacePoint {
    p: vec3<f32>,
    err: vec3<f32>,
}

fn sphere_surface_point(o: vec3<f32>, d: vec3<f32>, t: f32, center: vec3<f32>, radius: f32) -> SurfacePoint {
    let local = o + t * d - center;
    let on_surface = local * (radius / length(local));
    let p = center + on_surface;
    let err = gamma_n(6.0) * abs(on_surface) + gamma_n(2.0) * (abs(center) + abs(p));
    return SurfacePoint(p, err);
}

// --- Triangles --------------------------------------------------------------------------------------
// Watertight ray–triangle intersection (Woop, Benthin & Wald, "Watertight Ray/Triangle Intersection",
// JCGT 2(1), 2013): translate the vertices to the ray origin, shear so that the ray is the +z axis, and
// evaluate the three 2-D edge functions. A point on a shared edge gets the same edge-function value from
// both triangles, so a ray through an edge or vertex of a closed mesh always hits at least one of them.
// Zero-area triangles and rays parallel to the plane are never hit (see the world-space test below).
struct TriangleHit {
    t: f32,
    // Barycentric coordinates of the hit (b0 for v0, b1 for v1, b2 for v2).
    b: vec3<f32>,
}

fn component(v: vec3<f32>, k: u32) -> f32 {
    return select(select(v.x, v.y, k == 1u), v.z, k == 2u);
}

// The part of the watertight test that depends on the ray alone (Woop et al. §3.1: done once per ray, not
// per triangle): kz, the dimension where |d| is largest, kx and ky the other two (swapped to keep the
// winding when d points down kz), and the shear (sx, sy, sz) that maps d to +z.
struct TriangleRay {
    o: vec3<f32>,
    d: vec3<f32>,
    k: vec3<u32>, // kx, ky, kz
    s: vec3<f32>, // sx, sy, sz
}

fn triangle_ray(o: vec3<f32>, d: vec3<f32>) -> TriangleRay {
    let ad = abs(d);
    var kz = 2u;
    if ad.x > ad.y && ad.x > ad.z {
        kz = 0u;
    } else if ad.y > ad.z {
        kz = 1u;
    }
    var kx = (kz + 1u) % 3u;
    var ky = (kx + 1u) % 3u;
    let dz = component(d, kz);
    if dz < 0.0 {
        let tmp = kx;
        kx = ky;
        ky = tmp;
    }
    let s = vec3<f32>(component(d, kx) / dz, component(d, ky) / dz, 1.0 / dz);
    return TriangleRay(o, d, vec3<u32>(kx, ky, kz), s);
}

fn intersect_triangle(o: vec3<f32>, d: vec3<f32>, v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>,
                      t_min: f32, t_max: f32) -> TriangleHit {
    return intersect_triangle_ray(triangle_ray(o, d), v0, v1, v2, t_min, t_max);
}

// intersect_triangle for a ray whose per-ray part is computed (triangle_ray): the BVH walk and the loops
// over triangles test many triangles with one ray.
fn intersect_triangle_ray(r: TriangleRay, v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, t_min: f32,
                          t_max: f32) -> TriangleHit {
    let miss = TriangleHit(T_MISS, vec3<f32>(0.0));
    let o = r.o;
    let d = r.d;
    let kx = r.k.x;
    let ky = r.k.y;
    let kz = r.k.z;
    let sx = r.s.x;
    let sy = r.s.y;
    let sz = r.s.z;

    let a = v0 - o;
    let bb = v1 - o;
    let c = v2 - o;
    let ax = component(a, kx) - sx * component(a, kz);
    let ay = component(a, ky) - sy * component(a, kz);
    let bx = component(bb, kx) - sx * component(bb, kz);
    let by = component(bb, ky) - sy * component(bb, kz);
    let cx = component(c, kx) - sx * component(c, kz);
    let cy = component(c, ky) - sy * component(c, kz);

    // Edge functions: e0 for the edge opposite v0 (v1 -> v2), etc.
    let e0 = cx * by - cy * bx;
    let e1 = ax * cy - ay * cx;
    let e2 = bx * ay - by * ax;
    // Both signs present: the ray passes outside. Zeros (on an edge) count as inside, for either winding.
    if (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0) {
        return miss;
    }
    // Degenerate configurations, decided in world space where they are exact: the sheared edge functions
    // above carry rounding, so for a zero-area triangle (collinear vertices) or a ray lying in the
    // triangle's plane they can describe a sliver of nonzero area around the ray and report a hit whose
    // barycentrics, t and normal are noise (the normal of a zero-area triangle is normalize(0) = NaN).
    // (v1 - v0) x (v2 - v0) . d is exactly 0 for such inputs whenever the edge vectors and products are
    // exact in f32 (as for vertices on a common grid, or axis-aligned triangles); pbrt-v4 makes the same
    // world-space test for zero area. Rays that this rejects without being exactly parallel lie within
    // about 1e-7 rad of the plane, the same measure-zero set that the det == 0 test below gives up.
    let ng = cross(v1 - v0, v2 - v0);
    if dot(ng, d) == 0.0 {
        return miss;
    }
    let det = e0 + e1 + e2;
    if det == 0.0 {
        return miss;
    }
    let az = sz * component(a, kz);
    let bz = sz * component(bb, kz);
    let cz = sz * component(c, kz);
    let t_scaled = e0 * az + e1 * bz + e2 * cz;
    let t = t_scaled / det;
    if !(t > t_min && t < t_max) {
        return miss;
    }
    // A ray that leaves the triangle's plane does not hit it. The plane test h = ng . (v0 - o) (|ng| times
    // the origin's distance to the plane) and ng . d decide that exactly whenever h is larger than its
    // rounding error: the ray can meet the plane only if both have the same sign. The sheared edge
    // functions alone cannot tell: their t carries an error that grows with the size of the triangle's
    // coordinates relative to the origin (pbrt-v4 bounds it, §6.8.7), so on a triangle whose vertices
    // span 1e-7 to 1e8 a ray leaving it near its small vertex found it again at a t of order 1e8 u (about
    // one ray in four, tests/shader_intersect.rs). triangle_surface_point makes spawned origins far enough
    // off the plane for h to be decisive, so this test rejects exactly those false hits. (Rejecting hits
    // with t below pbrt's bound on t would also reject true hits close to large triangles, which the same
    // tests show to be accurate.)
    let h = dot(ng, v0 - o);
    let ng_mag = cross_magnitude(v1 - v0, v2 - v0);
    let nd = dot(ng, d);
    if abs(h) > gamma_n(7.0) * dot(ng_mag, abs(v0 - o)) && abs(nd) > gamma_n(7.0) * dot(ng_mag, abs(d))
        && (h > 0.0) != (nd > 0.0) {
        return miss;
    }
    // A ray that starts exactly in the triangle's plane does not hit it: t is 0 in exact arithmetic but
    // comes out of the sheared edge functions as rounding noise of either sign. This happens on
    // axis-aligned meshes at exact coordinates (a floor at y = 0): the spawned origin's error bound
    // along the normal is 0 there (its coordinate is exact), so offset_ray_origin leaves it in the plane,
    // and the ray would re-hit its own surface or a coplanar neighbour. The world-space test is exact in
    // that case ((v0 - o) . ng is 0 exactly), and can reject only origins within rounding of the plane,
    // whose t is noise anyway. (pbrt-v4 instead bounds t's rounding error, §6.8.7; that bound also
    // rejects close hits on large triangles, which tests/shader_intersect.rs shows to be accurate.)
    if dot(ng, v0 - o) == 0.0 {
        return miss;
    }
    return TriangleHit(t, vec3<f32>(e0, e1, e2) / det);
}

// The unit geometric normal of a triangle, (v1 - v0) x (v2 - v0) normalised, for any finite vertices.
// The edges are first scaled by a power of two that brings their largest component into [1, 2): exact,
// so the direction is that of the unscaled cross product, but its squared length can no longer underflow
// (edges near 3e-14 gave NaN) or overflow (vertices near 1e18 gave 0). A zero-area triangle, which
// intersect_triangle never reports, still has no normal.
fn triangle_normal(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>) -> vec3<f32> {
    let e1 = v1 - v0;
    let e2 = v2 - v0;
    let s = edge_scale(e1, e2);
    return normalize(cross(e1 * s, e2 * s));
}

// 2^(127 - e) for the biased exponent e of the largest edge component, as bits (clamped to a normal
// float for the largest ones): the edges times it have their largest component in [1, 2).
fn edge_scale(e1: vec3<f32>, e2: vec3<f32>) -> f32 {
    let m = max(max(abs(e1.x), max(abs(e1.y), abs(e1.z))), max(abs(e2.x), max(abs(e2.y), abs(e2.z))));
    let e = i32((bitcast<u32>(m) >> 23u) & 0xffu);
    return bitcast<f32>(u32(clamp(254 - e, 1, 254)) << 23u);
}

// The magnitudes of the terms of a x b, component by component: |a_y b_z| + |a_z b_y|, ...; the rounding
// error of a computed cross product is at most gamma(2) times this (and of a dot product with it, a few
// more roundings).
fn cross_magnitude(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return abs(a.yzx * b.zxy) + abs(a.zxy * b.yzx);
}

// Hit point from barycentrics, with pbrt's bound on its error: |error| <= gamma(7) * sum |b_i v_i|; plus,
// along the normal, the rounding error of the plane test in intersect_triangle for an origin near p
// (gamma(7) (ng_mag . |v_i - p|) / |ng|, with a margin, for the farthest vertex): a ray spawned from the
// offset point is then decidably off the plane, on the side it leaves towards, at any coordinate scale.
// On ordinary meshes that term is the triangle's size times about 1e-6, below the first one.
fn triangle_surface_point(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, b: vec3<f32>) -> SurfacePoint {
    let p = b.x * v0 + b.y * v1 + b.z * v2;
    let err = gamma_n(7.0) * (abs(b.x * v0) + abs(b.y * v1) + abs(b.z * v2));
    // With the edges scaled by a power of two (exact; the ratio below does not change) so that nothing
    // under- or overflows at extreme scales.
    let s = edge_scale(v1 - v0, v2 - v0);
    let e1 = (v1 - v0) * s;
    let e2 = (v2 - v0) * s;
    let ng = cross(e1, e2);
    let len = length(ng);
    let reach = max(abs(v0 - p), max(abs(v1 - p), abs(v2 - p))) + err;
    let plane_err = gamma_n(10.0) * dot(cross_magnitude(e1, e2), reach) / len;
    // As a box whose projection on the unit normal n = ng / |ng| is plane_err: plane_err |n|, since
    // |n| . |n| = 1. (A zero-area triangle is never hit, so len > 0 here.)
    return SurfacePoint(p, err + plane_err * (abs(ng) / len));
}

// --- Spawning rays ----------------------------------------------------------------------------------
// The next float towards +inf / -inf (finite inputs); used to round the offset origin away from the surface.
fn next_float_up(x: f32) -> f32 {
    if x == 0.0 {
        return 1.4e-45;
    }
    let bits = bitcast<u32>(x);
    return bitcast<f32>(select(bits - 1u, bits + 1u, x > 0.0));
}

fn next_float_down(x: f32) -> f32 {
    if x == 0.0 {
        return -1.4e-45;
    }
    let bits = bitcast<u32>(x);
    return bitcast<f32>(select(bits + 1u, bits - 1u, x > 0.0));
}

// The origin for a ray leaving a surface point p (error box `err`, geometric normal n) in direction w:
// push p along n, to the side w leaves from, by the projection of the error box on n, then round away
// from p so that the rounding of the addition cannot bring it back inside the box.
fn offset_ray_origin(p: vec3<f32>, err: vec3<f32>, n: vec3<f32>, w: vec3<f32>) -> vec3<f32> {
    let dist = dot(abs(n), err);
    var offset = dist * n;
    if dot(w, n) < 0.0 {
        offset = -offset;
    }
    var po = p + offset;
    if offset.x > 0.0 { po.x = next_float_up(po.x); } else if offset.x < 0.0 { po.x = next_float_down(po.x); }
    if offset.y > 0.0 { po.y = next_float_up(po.y); } else if offset.y < 0.0 { po.y = next_float_down(po.y); }
    if offset.z > 0.0 { po.z = next_float_up(po.z); } else if offset.z < 0.0 { po.z = next_float_down(po.z); }
    return po;
}

// A shadow ray from the surface point p (error box err, geometric normal n) to the point p_to on a light
// (pbrt-v4's SpawnRayTo, §6.8.6): it starts at the offset origin, and its direction is aimed from that
// origin, not from p. Aimed from p, the ray would pass beside p_to by up to the offset (about 1e-3 on the
// course's radius-940 walls), and miss a light smaller than that: a radius-0.002 sphere light rendered 7 %
// too dark (docs/robustness.md). It stops a relative SHADOW_EPSILON short of p_to, so the light's own
// surface (and the rounding of p_to onto it) never counts as a blocker.
const SHADOW_EPSILON: f32 = 1.0e-4;

struct ShadowRay {
    o: vec3<f32>,
    d: vec3<f32>, // unit
    t_max: f32,
}

// A shadow ray from p towards a light at infinity along the unit direction w (a sun): unbounded.
fn spawn_ray_towards(p: vec3<f32>, err: vec3<f32>, n: vec3<f32>, w: vec3<f32>) -> ShadowRay {
    return ShadowRay(offset_ray_origin(p, err, n, w), w, T_MISS);
}

// Which side of the surface the ray leaves from is the sign of dot(p_to - p, n), trusted only beyond what
// it could be wrong by: the rounding of the difference and of the dot product (gamma(4) dot(|d|, |n|))
// plus p's own error box projected on n (where the exact surface point may lie). Within that, p_to is
// in the surface's plane as far as p can tell (a light sampled next to the shaded triangle, far from the
// origin: at |p| = 1.2e7 the error bound is 5 units), and the ray leaves on the side of n, the facing
// normal, the side the path arrived on. Deciding by the bare sign there put the origin on the far side
// for a point a hair below p, and the ray then crossed the surface near its end.
fn spawn_ray_to(p: vec3<f32>, err: vec3<f32>, n: vec3<f32>, p_to: vec3<f32>) -> ShadowRay {
    let d = p_to - p;
    let side = dot(d, n);
    let uncertain = gamma_n(4.0) * dot(abs(d), abs(n)) + dot(abs(n), err);
    let o = offset_ray_origin(p, err, n, select(n, d, abs(side) > uncertain));
    let to = p_to - o;
    let dist = length(to);
    return ShadowRay(o, to / dist, dist * (1.0 - SHADOW_EPSILON));
}

// --- Boxes ------------------------------------------------------------------------------------------
// Ray against the axis-aligned box [lo, hi] by slabs (Kay & Kajiya), for a BVH: returns the distance at
// which the ray enters the box, clamped to 0 when the origin is inside, or T_MISS when the box lies
// entirely outside (0, t_max). `inv_d` is 1 / d per component, ±inf for a zero component.
//
// Conservative, after pbrt-v4 (Pharr, Jakob & Humphreys, "Physically Based Rendering", 4th ed., §6.8.2,
// Bounds3::IntersectP): a slab distance (bound - o) * inv_d carries three roundings (the subtraction, the
// product, and the reciprocal the caller took), so it is within a relative gamma(3) of the exact one;
// scaling every far distance by 1 + 2 gamma(3) makes the computed interval contain the exact interval,
// so a ray that meets the box is never culled by rounding. An axis where inv_d is ±inf (an axis-parallel
// ray) is decided by position alone, lo <= o <= hi: its products (0 * inf = NaN where o lies on a slab
// plane) are replaced by select before anything uses them, so no result depends on how min/max or
// comparisons treat NaN (undefined in SPIR-V / WGSL). A flat box
// (lo == hi on an axis) is a valid box: its slab interval is a single distance, widened as above.
fn intersect_aabb(o: vec3<f32>, inv_d: vec3<f32>, lo: vec3<f32>, hi: vec3<f32>, t_max: f32) -> f32 {
    // One box is lane x of the four-box test the BVH walk runs (the same arithmetic, so what
    // tests/shader_intersect.rs checks here is what the renderer computes).
    let b = Boxes4(vec4<f32>(lo.x), vec4<f32>(hi.x), vec4<f32>(lo.y), vec4<f32>(hi.y), vec4<f32>(lo.z),
                   vec4<f32>(hi.z));
    return intersect_boxes4(o, inv_d, ray_parallel_axes(inv_d), b, t_max).x;
}

// Four boxes, as four-lane vectors per bound (lane k: box k); the BVH walk's node decodes into it.
struct Boxes4 {
    lo_x: vec4<f32>,
    hi_x: vec4<f32>,
    lo_y: vec4<f32>,
    hi_y: vec4<f32>,
    lo_z: vec4<f32>,
    hi_z: vec4<f32>,
}

// Which axes of inv_d are ±inf: the ray is parallel to those slabs.
fn ray_parallel_axes(inv_d: vec3<f32>) -> vec3<bool> {
    return (bitcast<vec3<u32>>(inv_d) & vec3<u32>(0x7f800000u)) == vec3<u32>(0x7f800000u);
}

// The slab test above for four boxes at once: lane k is the distance at which the ray enters box k (0
// when the origin is inside), or T_MISS. All three axes as vectors, no branches: a parallel axis's
// products (possibly 0 * inf = NaN) are formed but replaced by a slab that never binds (0 for the entry,
// t_max for the exit), and the origin's position decides it. The folds run in the axis order x, y, z;
// min and max are exact, so the result does not depend on the order. `parallel`: ray_parallel_axes.
fn intersect_boxes4(o: vec3<f32>, inv_d: vec3<f32>, parallel: vec3<bool>, b: Boxes4, t_max: f32) -> vec4<f32> {
    let widen = 1.0 + 2.0 * gamma_n(3.0);
    let xl = (b.lo_x - o.x) * inv_d.x;
    let xh = (b.hi_x - o.x) * inv_d.x;
    let yl = (b.lo_y - o.y) * inv_d.y;
    let yh = (b.hi_y - o.y) * inv_d.y;
    let zl = (b.lo_z - o.z) * inv_d.z;
    let zh = (b.hi_z - o.z) * inv_d.z;
    let near_x = select(min(xl, xh), vec4<f32>(0.0), parallel.x);
    let near_y = select(min(yl, yh), vec4<f32>(0.0), parallel.y);
    let near_z = select(min(zl, zh), vec4<f32>(0.0), parallel.z);
    let far_x = select(max(xl, xh) * widen, vec4<f32>(t_max), parallel.x);
    let far_y = select(max(yl, yh) * widen, vec4<f32>(t_max), parallel.y);
    let far_z = select(max(zl, zh) * widen, vec4<f32>(t_max), parallel.z);
    let ox = vec4<f32>(o.x);
    let oy = vec4<f32>(o.y);
    let oz = vec4<f32>(o.z);
    let no = vec4<bool>(false);
    let outside = select(no, (ox < b.lo_x) | (ox > b.hi_x), parallel.x)
        | select(no, (oy < b.lo_y) | (oy > b.hi_y), parallel.y)
        | select(no, (oz < b.lo_z) | (oz > b.hi_z), parallel.z);
    let t0 = max(max(max(vec4<f32>(0.0), near_x), near_y), near_z);
    let t1 = min(min(min(vec4<f32>(t_max), far_x), far_y), far_z);
    return select(t0, vec4<f32>(T_MISS), outside | (t0 > t1));
}
