// Test kernel: a ray hits one primitive, a secondary ray leaves the hit point exactly as trace.wgsl and
// scene.wgsl spawn them (surface point and error bound from sphere_surface_point / triangle_surface_point,
// the geometric normal of surface_at, the facing normal of trace_path, offset_ray_origin), and the
// secondary ray is intersected with the same primitive again.
//
// Case: o.xyz, d.xyz the incoming ray; o.w the primitive (0 sphere, 1 triangle); d.w the mode:
//   0 reflect   wi = reflect_dir(d, n)                        next ray over (0, T_MISS)
//   1 refract   wi = refract_dir(d, n, eta) (reflect on TIR)  next ray over (0, T_MISS)
//   2 shadow    spawn_ray_to the light l.xyz                  next ray over (0, dist (1 - 1e-4)),
//               skipped (next.x = -1) when the light is below the horizon, as direct_light does
//   3 refract, then a shadow ray from the refracted ray's origin towards l.xyz, over (0, dist)
//   4 shadow    as 2 without the horizon test (a surface that transmits: direct_light keeps lights on
//               either side and spawn_ray_to alone decides which side the ray leaves from)
// a: sphere centre and radius, or triangle v0; b, c: triangle v1, v2; l.w: index of refraction.
// Out: hit = (t of the incoming ray, p); next = (t of the secondary ray or T_MISS, its origin);
//      w = (its direction, its t_max).
//
// requires: intersect.wgsl, bsdf.wgsl

struct SpawnCase {
    o: vec4<f32>,
    d: vec4<f32>,
    a: vec4<f32>,
    b: vec4<f32>,
    c: vec4<f32>,
    l: vec4<f32>,
}

struct SpawnOut {
    hit: vec4<f32>,
    next: vec4<f32>,
    w: vec4<f32>,
}

@group(0) @binding(0) var<storage, read> input: array<SpawnCase>;
@group(0) @binding(1) var<storage, read_write> output: array<SpawnOut>;

fn prim_intersect(c: SpawnCase, o: vec3<f32>, d: vec3<f32>, t_max: f32) -> TriangleHit {
    if c.o.w == 0.0 {
        return TriangleHit(intersect_sphere(o, d, c.a.xyz, c.a.w, 0.0, t_max), vec3<f32>(0.0));
    }
    return intersect_triangle(o, d, c.a.xyz, c.b.xyz, c.c.xyz, 0.0, t_max);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= arrayLength(&output) {
        return;
    }
    let c = input[id.x];
    let d = c.d.xyz;
    let h = prim_intersect(c, c.o.xyz, d, T_MISS);
    if h.t >= T_MISS {
        output[id.x] = SpawnOut(vec4<f32>(T_MISS, vec3<f32>(0.0)), vec4<f32>(0.0), vec4<f32>(0.0));
        return;
    }
    // surface_at (scene.wgsl)
    var sp: SurfacePoint;
    var n: vec3<f32>;
    if c.o.w == 0.0 {
        sp = sphere_surface_point(c.o.xyz, d, h.t, c.a.xyz, c.a.w);
        n = normalize(sp.p - c.a.xyz);
    } else {
        sp = triangle_surface_point(c.a.xyz, c.b.xyz, c.c.xyz, h.b);
        n = triangle_normal(c.a.xyz, c.b.xyz, c.c.xyz);
    }
    // trace_path (trace.wgsl): the normal on the side the ray came from.
    let entering = dot(d, n) < 0.0;
    let nf = select(-n, n, entering);
    let mode = u32(c.d.w);
    var wi: vec3<f32>;
    var t_max = T_MISS;
    if mode == 0u {
        wi = reflect_dir(d, nf);
    } else if mode == 2u || mode == 4u {
        let to_light = c.l.xyz - sp.p;
        let dist = length(to_light);
        wi = to_light / dist;
        t_max = dist * (1.0 - 1.0e-4);
        if mode == 2u && dot(nf, wi) <= 0.0 {
            output[id.x] = SpawnOut(vec4<f32>(h.t, sp.p), vec4<f32>(-1.0, vec3<f32>(0.0)), vec4<f32>(0.0));
            return;
        }
    } else {
        let eta = select(1.0 / c.l.w, c.l.w, entering);
        if fresnel_dielectric(-dot(d, nf), eta) >= 1.0 {
            wi = reflect_dir(d, nf);
        } else {
            wi = refract_dir(d, nf, eta);
        }
    }
    var o2 = offset_ray_origin(sp.p, sp.err, nf, wi);
    if mode == 2u || mode == 4u {
        // As direct_light aims it: from the offset origin at the light (spawn_ray_to).
        let shadow = spawn_ray_to(sp.p, sp.err, nf, c.l.xyz);
        o2 = shadow.o;
        wi = shadow.d;
        t_max = shadow.t_max;
    }
    if mode == 3u {
        let to_light = c.l.xyz - o2;
        t_max = length(to_light);
        wi = to_light / t_max;
    }
    let t2 = prim_intersect(c, o2, wi, t_max).t;
    output[id.x] = SpawnOut(vec4<f32>(h.t, sp.p), vec4<f32>(t2, o2), vec4<f32>(wi, t_max));
}
