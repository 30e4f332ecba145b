// Test kernel: rays against a whole triangle mesh (a brute-force closest hit, as scene_intersect does).
// Input layout (all vec4<f32>):
//   input[0].x        bit pattern of the triangle count n (u32)
//   input[1 + 3 i + k] vertex k of triangle i (xyz)
//   input[1 + 3 n + 3 j] ray j: origin (xyz), w = t_max
//   input[2 + 3 n + 3 j] ray j: direction (xyz), w = mode
//   input[3 + 3 n + 3 j] ray j: light position (xyz), w = index of refraction
// Mode 0: out = (number of triangles hit in (0, t_max), closest t, index of the closest, 0).
// Mode 1: the ray refracts into the mesh at its closest hit, spawned as trace.wgsl does (surface_at's
// triangle_surface_point and geometric normal, the facing normal, offset_ray_origin), and a shadow ray
// goes from the refracted ray's origin to the light; out = (number of triangles the shadow ray hits in
// (0, distance to the light), the refracted ray's origin), or all -1 when the first ray missed.
//
// requires: intersect.wgsl, bsdf.wgsl

@group(0) @binding(0) var<storage, read> input: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read_write> output: array<vec4<f32>>;

struct MeshHit {
    count: u32,
    t: f32,
    index: u32,
    b: vec3<f32>,
}

fn mesh_intersect(n: u32, o: vec3<f32>, d: vec3<f32>, t_max: f32) -> MeshHit {
    var hit = MeshHit(0u, t_max, 0xffffffffu, vec3<f32>(0.0));
    for (var i = 0u; i < n; i++) {
        let v0 = input[1u + 3u * i].xyz;
        let v1 = input[2u + 3u * i].xyz;
        let v2 = input[3u + 3u * i].xyz;
        let h = intersect_triangle(o, d, v0, v1, v2, 0.0, t_max);
        if h.t < t_max {
            hit.count += 1u;
            if h.t < hit.t {
                hit.t = h.t;
                hit.index = i;
                hit.b = h.b;
            }
        }
    }
    return hit;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= arrayLength(&output) {
        return;
    }
    let n = bitcast<u32>(input[0].x);
    let ro = input[1u + 3u * n + 3u * id.x];
    let rd = input[2u + 3u * n + 3u * id.x];
    let rl = input[3u + 3u * n + 3u * id.x];
    let hit = mesh_intersect(n, ro.xyz, rd.xyz, ro.w);
    if rd.w == 0.0 {
        output[id.x] = vec4<f32>(f32(hit.count), hit.t, bitcast<f32>(hit.index), 0.0);
        return;
    }
    if hit.count == 0u {
        output[id.x] = vec4<f32>(-1.0);
        return;
    }
    let v0 = input[1u + 3u * hit.index].xyz;
    let v1 = input[2u + 3u * hit.index].xyz;
    let v2 = input[3u + 3u * hit.index].xyz;
    let sp = triangle_surface_point(v0, v1, v2, hit.b);
    let ng = triangle_normal(v0, v1, v2);
    let d = rd.xyz;
    let entering = dot(d, ng) < 0.0;
    let nf = select(-ng, ng, entering);
    let eta = select(1.0 / rl.w, rl.w, entering);
    let wi = refract_dir(d, nf, eta);
    let o2 = offset_ray_origin(sp.p, sp.err, nf, wi);
    let to_light = rl.xyz - o2;
    let dist = length(to_light);
    let shadow = mesh_intersect(n, o2, to_light / dist, dist);
    output[id.x] = vec4<f32>(f32(shadow.count), o2);
}
