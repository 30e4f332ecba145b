// scene_data.wgsl: the data a render kernel reads and writes, shared by the production kernel
// (trace.wgsl) and the hand-trimmed benchmark kernel (shaders/bench/). Struct layouts here are mirrored by
// `#[repr(C)]` Pod types in src/gpu/types.rs; tests/layout.rs holds each Rust layout against the layout
// naga reflects from this file.

struct Params {
    cam_position: vec3<f32>,
    lens_radius: f32,
    cam_right: vec3<f32>,
    tan_half_fov: f32,
    cam_up: vec3<f32>,
    focus_distance: f32,
    cam_forward: vec3<f32>,
    filter_sigma: f32,
    background: vec3<f32>,
    filter_kind: u32, // 0 none, 1 box, 2 gaussian
    width: u32,
    height: u32,
    max_bounces: u32,
    seed: u32,
    _pad1: u32,
    _pad2: u32,
    num_spheres: u32,
    num_triangles: u32,
    num_lights: u32,
    roulette_depth: u32, // Russian roulette from this many scattering events on
    guard_one: f32, // always 1.0; see accumulate.wgsl
    _pad0: u32,
}

struct Sphere {
    center: vec3<f32>,
    radius: f32,
    material: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

struct Triangle {
    v0: vec3<f32>,
    material: u32,
    v1: vec3<f32>,
    _pad0: u32,
    v2: vec3<f32>,
    _pad1: u32,
}

struct Material {
    albedo: vec3<f32>, // diffuse albedo or mirror tint
    kind: u32,
    emission: vec3<f32>, // radiance of an emitter, W sr^-1 m^-2
    ior: f32,
}

const LIGHT_POINT: u32 = 0u;
const LIGHT_SPHERE: u32 = 1u;

struct Light {
    position: vec3<f32>, // point position or sphere centre
    radius: f32,
    // point: radiant intensity I = P color / (4 pi) (W/sr); sphere: radiance Le = P color / (4 pi^2 r^2)
    intensity: vec3<f32>,
    kind: u32,
    sphere_index: u32, // for sphere lights: the index of its emitter sphere in `spheres`
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> spheres: array<Sphere>;
@group(0) @binding(2) var<storage, read> triangles: array<Triangle>;
@group(0) @binding(3) var<storage, read> materials: array<Material>;
@group(0) @binding(4) var<storage, read> lights: array<Light>;

// The render target: per-pixel running sums, and which sample the current dispatch traces.
struct PassConstants {
    sample_index: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(5) var<storage, read_write> accum: array<Accum>;
@group(0) @binding(6) var<uniform> pass_constants: PassConstants;
