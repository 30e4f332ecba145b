// scene_data.wgsl: the data a render kernel reads and writes, shared by the production kernel
// (trace.wgsl) and the hand-trimmed benchmark kernel (shaders/bench/). Struct layouts here (and those of
// the modules it requires: Material, Light, Accum) are mirrored by `#[repr(C)]` Pod types in
// src/kernel/abi.rs; tests/layout.rs holds each Rust layout against the layout naga reflects. The host
// binds every buffer by the name it has here (src/render/mod.rs), never by number.
//
// requires: features.wgsl, bsdf.wgsl, lights.wgsl, accumulate.wgsl
//
// (lights/triangles.wgsl and lights/environment.wgsl declare the buffers only those lights read.)

struct Params {
    cam_position: vec3<f32>,
    lens_radius: f32,
    cam_right: vec3<f32>,
    view_half_width: f32, // tan(fov / 2) (perspective) or extent / 2 (orthographic)
    cam_up: vec3<f32>,
    focus_distance: f32,
    cam_forward: vec3<f32>,
    filter_width: f32, // the Gaussian's standard deviation or the tent's radius, in pixels
    environment_light: u32, // the environment's index in `lights`, or NO_LIGHT
    triangle_light: u32, // the LIGHT_TRIANGLES light's index in `lights`, or NO_LIGHT
    sample_clamp: f32, // render.clamp: a sample's largest channel is scaled down to it; 0 = no clamp
    filter_kind: u32, // 0 none, 1 box, 2 gaussian
    width: u32,
    height: u32,
    max_bounces: u32,
    seed: u32,
    sampler: u32, // SAMPLER_INDEPENDENT or SAMPLER_SOBOL (rng.wgsl)
    light_sampling: u32, // LIGHT_SAMPLING_* (lights/common.wgsl): how sphere lights are sampled
    num_spheres: u32,
    num_triangles: u32,
    num_lights: u32,
    roulette_depth: u32, // Russian roulette from this many scattering events on
    guard_one: f32, // always 1.0; see accumulate.wgsl
    camera_kind: u32, // CAMERA_PERSPECTIVE or CAMERA_ORTHOGRAPHIC (camera.wgsl)
    aov: u32, // AOV_NONE (radiance) or the --aov layer the samples are (trace.wgsl)
    filter_in_image: u32, // 1: the pixel filter is cut off at the image's edges (film_position, trace.wgsl)
    splat: u32, // 1: samples are splatted (render.splat; trace.wgsl, splat.wgsl)
    _pad1: u32,
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

// Triangle meshes (see src/scene/bvh.rs and src/kernel/upload.rs). An interior BVH node holds the quantised
// boxes of its (up to) four children; a child reference is a node index, a leaf (BVH_LEAF set) or BVH_NONE
// (see bvh.wgsl).
struct BvhNode {
    origin: vec3<f32>,
    exponents: u32,
    planes_xy: vec4<u32>,
    planes_z: vec2<u32>,
    _pad0: u32,
    _pad1: u32,
    child: vec4<u32>,
}

const NO_MESH: u32 = 0xffffffffu;
const MESH_SMOOTH: u32 = 1u; // interpolate the vertex normals
const MESH_UV: u32 = 2u; // the vertices have texture coordinates (else a triangle's uv are (0,0), (1,0), (0,1))
const NO_TEXTURE: u32 = 0xffffffffu;

// Shading data of triangle i (same index as `triangles`): its three vertices in `mesh_vertices` and its
// mesh in `meshes`, or mesh == NO_MESH for a triangle without (flat, and uv from its barycentrics).
struct MeshFace {
    vertices: vec3<u32>,
    mesh: u32,
}

// A shading normal (unit, world space; zero means "use the geometric normal"), texture coordinates, and
// a normal map's tangent, octahedral-encoded (mesh_tangent; 0: none).
struct MeshVertex {
    nx: f32,
    ny: f32,
    nz: f32,
    u: f32,
    v: f32,
    tangent: u32,
}

// A vertex's tangent (xyz unit, w = +-1 the bitangent's sign), decoded from MeshVertex::tangent
// (encode_tangent in src/kernel/abi.rs gives the layout); w = 0 where it has none.
fn mesh_tangent(bits: u32) -> vec4<f32> {
    if (bits & 0x80000000u) == 0u {
        return vec4<f32>(0.0);
    }
    let p = vec2<f32>(f32(bits & 0x7fffu), f32((bits >> 15u) & 0x7fffu)) * (2.0 / 32767.0) - vec2<f32>(1.0);
    var d = vec3<f32>(p, 1.0 - abs(p.x) - abs(p.y));
    if d.z < 0.0 {
        let s = select(vec2<f32>(-1.0), vec2<f32>(1.0), p >= vec2<f32>(0.0));
        d = vec3<f32>((vec2<f32>(1.0) - abs(p.yx)) * s, d.z);
    }
    return vec4<f32>(normalize(d), select(1.0, -1.0, (bits & 0x40000000u) != 0u));
}

// A mesh's MESH_* flags. (Its textures belong to its material: MaterialTextures.)
struct MeshInfo {
    flags: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// The texture table: one texture reference each (texture.wgsl): texture k's texels are texels[offset ..]
// (width x height, rows from the top, one word per texel or two with TEXTURE_HALF), read through the uv
// transform uv' = (uv_matrix.xy . uv, uv_matrix.zw . uv) + uv_offset, with the TEXTURE_* flags' wrap
// mode, filter, channel and colour space.
struct TextureInfo {
    offset: u32,
    width: u32,
    height: u32,
    flags: u32,
    uv_matrix: vec4<f32>,
    uv_offset: vec2<f32>,
    _pad0: u32,
    _pad1: u32,
}

// MaterialTextures::flags: opacity below alpha_cutoff is a hole, at or above it solid (a cut-out);
// without it, opacity is stochastic transparency.
const MATERIAL_CUTOUT: u32 = 1u;

// The textured parameters and surface modifiers of material i (same index as `materials`; uploaded only
// when some material has one). Each *_texture is an index into `textures` or NO_TEXTURE; a textured
// parameter is the material's constant (its factor) times the texture's value: albedo (diffuse albedo,
// mirror tint, plastic base, base colour, Schlick f0), roughness (alpha = (constant roughness x texel)^2),
// metallic, emission. opacity is the fraction of light the surface stops (times the opacity texture);
// bump a height map (bump_scale scene units per unit of texel), normal a tangent-space normal map whose
// x and y are scaled by normal_scale.
struct MaterialTextures {
    albedo_texture: u32,
    roughness_texture: u32,
    metallic_texture: u32,
    emission_texture: u32,
    opacity_texture: u32,
    bump_texture: u32,
    normal_texture: u32,
    flags: u32,
    opacity: f32,
    alpha_cutoff: f32,
    bump_scale: f32,
    normal_scale: f32,
    blend: u32, // 1 + the material shown instead with probability blend_weight (x texture); 0: none
    blend_weight: f32,
    blend_texture: u32,
    _pad0: u32,
}

// A placement of an instanced mesh (src/kernel/upload.rs, add_instanced), or, placed by the identity, the
// scene's other triangles, in a scene with instances: the rows of its world-to-object and object-to-world
// maps (x' = dot(row.xyz, x) + row.w), the node of `bvh_nodes` where its mesh's own tree starts, and
// INSTANCE_* flags.
struct Instance {
    to_object_x: vec4<f32>,
    to_object_y: vec4<f32>,
    to_object_z: vec4<f32>,
    to_world_x: vec4<f32>,
    to_world_y: vec4<f32>,
    to_world_z: vec4<f32>,
    root: u32,
    flags: u32,
    // The material the placement's faces take instead of their own, or NO_MATERIAL.
    material: u32,
    _pad: u32,
}

// The placement mirrors: the winding's normal is flipped (a mirrored copy keeps its faces' fronts).
const INSTANCE_MIRRORS: u32 = 1u;
// Instance::material: the placement's faces keep their own materials.
const NO_MATERIAL: u32 = 0xffffffffu;

// The material of a triangle whose own is `material`, hit through placement `instance` (NO_INSTANCE: in
// world space): the placement's material where it gives one (an [[instance]] in a material of its own).
fn placed_material(material: u32, instance: u32) -> u32 {
    if HAS_INSTANCE_MATERIALS {
        if instance != NO_INSTANCE {
            let m = instance_at(instance).material;
            if m != NO_MATERIAL {
                return m;
            }
        }
    }
    return material;
}
// Hit::instance of a hit on a primitive in world space (any hit in a scene without instances).
const NO_INSTANCE: u32 = 0xffffffffu;

// A closest hit: which primitive, where along the ray, and for triangles the barycentrics.
const PRIM_NONE: u32 = 0u;
const PRIM_SPHERE: u32 = 1u;
const PRIM_TRIANGLE: u32 = 2u;

struct Hit {
    t: f32,
    prim_kind: u32,
    prim_index: u32,
    b: vec3<f32>, // triangle barycentrics
    // The placement (`instances`) whose mesh holds the triangle, which is then in the mesh's own space;
    // NO_INSTANCE otherwise.
    instance: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> spheres: array<Sphere>;
@group(0) @binding(2) var<storage, read> triangles: array<Triangle>;
@group(0) @binding(3) var<storage, read> materials: array<Material>;
@group(0) @binding(4) var<storage, read> lights: array<Light>;
@group(0) @binding(7) var<storage, read> bvh_nodes: array<BvhNode>;
// The spheres' own BVH (bvh.wgsl), when there are at least upload::SPHERE_BVH_MIN spheres: its leaves
// index `spheres`, which the host then stores in the tree's leaf order. Empty otherwise.
@group(0) @binding(38) var<storage, read> sphere_nodes: array<BvhNode>;
@group(0) @binding(8) var<storage, read> mesh_faces: array<MeshFace>;
@group(0) @binding(9) var<storage, read> mesh_vertices: array<MeshVertex>;
@group(0) @binding(10) var<storage, read> meshes: array<MeshInfo>;
@group(0) @binding(39) var<storage, read> instances: array<Instance>;
// Every texture's texels, RGBA8 (r in the low byte) or RGBA f16 (two words), rows from the top:
// sRGB-encoded colour or linear data, as its TextureInfo says.
@group(0) @binding(11) var<storage, read> texels: array<u32>;
@group(0) @binding(16) var<storage, read> textures: array<TextureInfo>;
@group(0) @binding(17) var<storage, read> material_textures: array<MaterialTextures>;

// Uniform twins: a small scene's arrays, read from uniform buffers of UNIFORM_ARRAY_BYTES = 65536 bytes
// (src/kernel/abi.rs, UNIFORM_ARRAYS) where the kernel has UNIFORM_<ARRAY> (features.wgsl): on a CPU
// driver a uniform read whose index differs between lanes is branchless, a storage read is not (abi.rs
// says why). Each holds 65536 / (its element's bytes) elements; the host pads the buffer to that.
// (Binding 45, the emitting triangles' twin, is in lights/triangles.wgsl.) Each accessor below reads
// its twin as `if UNIFORM_X { twin } else { storage }`: with the `else`, specialisation drops the
// branch not taken and the binding with it (an `if` that returns, followed by the storage read, would
// keep both bound).
@group(0) @binding(40) var<uniform> triangles_uniform: array<Triangle, 1365>;
@group(0) @binding(41) var<uniform> bvh_nodes_uniform: array<BvhNode, 1024>;
@group(0) @binding(42) var<uniform> spheres_uniform: array<Sphere, 2048>;
@group(0) @binding(43) var<uniform> sphere_nodes_uniform: array<BvhNode, 1024>;
@group(0) @binding(44) var<uniform> lights_uniform: array<Light, 819>;
@group(0) @binding(46) var<uniform> instances_uniform: array<Instance, 585>;
@group(0) @binding(47) var<uniform> materials_uniform: array<Material, 455>;
@group(0) @binding(50) var<uniform> textures_uniform: array<TextureInfo, 1365>;
@group(0) @binding(51) var<uniform> material_textures_uniform: array<MaterialTextures, 1024>;

// Arrays larger than one storage binding may hold (Vulkan guarantees 2^27 bytes) are read through
// several: part k of an array holds its elements [k 2^BITS, (k + 1) 2^BITS), part 0 under the array's
// own name above (src/kernel/abi.rs, SPLIT_ARRAYS, fixes the names, sizes and counts). The kernel reads
// each through its accessor below, which picks the part by the index's high bits; a scene whose arrays
// fit one part each has no HAS_SPLIT_ARRAYS, and its kernel reads the arrays directly.
const TRIANGLE_PART_BITS: u32 = 21u;
const BVH_NODE_PART_BITS: u32 = 21u;
const MESH_FACE_PART_BITS: u32 = 23u;
const MESH_VERTEX_PART_BITS: u32 = 22u;
const TEXEL_PART_BITS: u32 = 25u;
const DATA_IMAGE_WIDTH_BITS: u32 = 12u;
@group(0) @binding(21) var<storage, read> triangles_1: array<Triangle>;
@group(0) @binding(22) var<storage, read> triangles_2: array<Triangle>;
@group(0) @binding(23) var<storage, read> triangles_3: array<Triangle>;
@group(0) @binding(24) var<storage, read> triangles_4: array<Triangle>;
@group(0) @binding(25) var<storage, read> triangles_5: array<Triangle>;
@group(0) @binding(26) var<storage, read> triangles_6: array<Triangle>;
@group(0) @binding(27) var<storage, read> triangles_7: array<Triangle>;
@group(0) @binding(28) var<storage, read> bvh_nodes_1: array<BvhNode>;
@group(0) @binding(29) var<storage, read> bvh_nodes_2: array<BvhNode>;
@group(0) @binding(30) var<storage, read> bvh_nodes_3: array<BvhNode>;
@group(0) @binding(31) var<storage, read> mesh_faces_1: array<MeshFace>;
@group(0) @binding(32) var<storage, read> mesh_vertices_1: array<MeshVertex>;
@group(0) @binding(33) var<storage, read> mesh_vertices_2: array<MeshVertex>;
@group(0) @binding(34) var<storage, read> mesh_vertices_3: array<MeshVertex>;
@group(0) @binding(35) var<storage, read> texels_1: array<u32>;
@group(0) @binding(36) var<storage, read> texels_2: array<u32>;
@group(0) @binding(37) var<storage, read> texels_3: array<u32>;

fn part_mask(bits: u32) -> u32 {
    return (1u << bits) - 1u;
}

fn triangle_at(i: u32) -> Triangle {
    if UNIFORM_TRIANGLES {
        return triangles_uniform[i];
    } else if DATA_IMAGES {
        return triangle_from_image(i);
    } else {
        if HAS_SPLIT_ARRAYS {
            let j = i & part_mask(TRIANGLE_PART_BITS);
            switch i >> TRIANGLE_PART_BITS {
                case 0u: { return triangles[j]; }
                case 1u: { return triangles_1[j]; }
                case 2u: { return triangles_2[j]; }
                case 3u: { return triangles_3[j]; }
                case 4u: { return triangles_4[j]; }
                case 5u: { return triangles_5[j]; }
                case 6u: { return triangles_6[j]; }
                default: { return triangles_7[j]; }
            }
        }
        return triangles[i];
    }
}

// Data images (src/gpu/image.rs): an array's bytes as the texels of a 2D rgba32uint image,
// 2^DATA_IMAGE_WIDTH_BITS texels a row, so that 16-byte texel j is at (j mod width, j / width). A BVH node
// is four texels, a triangle three, a mesh face one, a mesh vertex one and a half, a texel word a
// quarter. Read where the kernel has DATA_IMAGES and the array has no uniform
// twin.
@group(0) @binding(52) var bvh_nodes_image: texture_2d<u32>;
@group(0) @binding(53) var triangles_image: texture_2d<u32>;
@group(0) @binding(54) var mesh_faces_image: texture_2d<u32>;
@group(0) @binding(55) var mesh_vertices_image: texture_2d<u32>;
@group(0) @binding(56) var texels_image: texture_2d<u32>;

fn data_texel_position(j: u32) -> vec2<u32> {
    return vec2<u32>(j & ((1u << DATA_IMAGE_WIDTH_BITS) - 1u), j >> DATA_IMAGE_WIDTH_BITS);
}

fn bvh_node_texel(j: u32) -> vec4<u32> {
    return textureLoad(bvh_nodes_image, data_texel_position(j), 0);
}

fn triangle_texel(j: u32) -> vec4<u32> {
    return textureLoad(triangles_image, data_texel_position(j), 0);
}

fn bvh_node_from_image(i: u32) -> BvhNode {
    let a = bvh_node_texel(4u * i);
    let b = bvh_node_texel(4u * i + 1u);
    let c = bvh_node_texel(4u * i + 2u);
    let d = bvh_node_texel(4u * i + 3u);
    return BvhNode(bitcast<vec3<f32>>(a.xyz), a.w, b, c.xy, c.z, c.w, d);
}

fn triangle_from_image(i: u32) -> Triangle {
    let a = triangle_texel(3u * i);
    let b = triangle_texel(3u * i + 1u);
    let c = triangle_texel(3u * i + 2u);
    return Triangle(bitcast<vec3<f32>>(a.xyz), a.w, bitcast<vec3<f32>>(b.xyz), b.w, bitcast<vec3<f32>>(c.xyz), c.w);
}

fn bvh_node_at(i: u32) -> BvhNode {
    if UNIFORM_BVH_NODES {
        return bvh_nodes_uniform[i];
    } else if DATA_IMAGES {
        return bvh_node_from_image(i);
    } else {
        if HAS_SPLIT_ARRAYS {
            let j = i & part_mask(BVH_NODE_PART_BITS);
            switch i >> BVH_NODE_PART_BITS {
                case 0u: { return bvh_nodes[j]; }
                case 1u: { return bvh_nodes_1[j]; }
                case 2u: { return bvh_nodes_2[j]; }
                default: { return bvh_nodes_3[j]; }
            }
        }
        return bvh_nodes[i];
    }
}

// Whether the scene's triangles have a BVH (the generic kernel finds `bvh_nodes` empty otherwise; a
// uniform twin is used only for a tree that has nodes). With DATA_IMAGES the nodes are in their image and
// the storage binding is only a witness of their number: one element when there are nodes, none when not
// (render::upload_scene).
fn has_bvh_nodes() -> bool {
    if UNIFORM_BVH_NODES {
        return true;
    } else {
        return arrayLength(&bvh_nodes) > 0u;
    }
}

// The same for the spheres' tree.
fn has_sphere_nodes() -> bool {
    if UNIFORM_SPHERE_NODES {
        return true;
    } else {
        return arrayLength(&sphere_nodes) > 0u;
    }
}

fn sphere_at(i: u32) -> Sphere {
    if UNIFORM_SPHERES {
        return spheres_uniform[i];
    } else {
        return spheres[i];
    }
}

fn sphere_node_at(i: u32) -> BvhNode {
    if UNIFORM_SPHERE_NODES {
        return sphere_nodes_uniform[i];
    } else {
        return sphere_nodes[i];
    }
}

fn light_at(i: u32) -> Light {
    if UNIFORM_LIGHTS {
        return lights_uniform[i];
    } else {
        return lights[i];
    }
}

fn material_at(i: u32) -> Material {
    if UNIFORM_MATERIALS {
        return materials_uniform[i];
    } else {
        return materials[i];
    }
}

// Entry i of the texture table (texture.wgsl).
fn texture_info_at(i: u32) -> TextureInfo {
    if UNIFORM_TEXTURES {
        return textures_uniform[i];
    } else {
        return textures[i];
    }
}

fn instance_at(i: u32) -> Instance {
    if UNIFORM_INSTANCES {
        return instances_uniform[i];
    } else {
        return instances[i];
    }
}

fn mesh_face_at(i: u32) -> MeshFace {
    if DATA_IMAGES {
        let t = textureLoad(mesh_faces_image, data_texel_position(i), 0);
        return MeshFace(t.xyz, t.w);
    } else {
        return mesh_face_from_storage(i);
    }
}

fn mesh_face_from_storage(i: u32) -> MeshFace {
    if HAS_SPLIT_ARRAYS {
        let j = i & part_mask(MESH_FACE_PART_BITS);
        switch i >> MESH_FACE_PART_BITS {
            case 0u: { return mesh_faces[j]; }
            default: { return mesh_faces_1[j]; }
        }
    }
    return mesh_faces[i];
}

// A vertex is six words: vertex i starts at word 6i, texel 3i / 2, at its first word for an even i and
// its third for an odd one, and ends in the next texel (the image has a texel to spare past its data:
// gpu::image).
fn mesh_vertex_at(i: u32) -> MeshVertex {
    if DATA_IMAGES {
        let j = (3u * i) >> 1u;
        let a = textureLoad(mesh_vertices_image, data_texel_position(j), 0);
        let b = textureLoad(mesh_vertices_image, data_texel_position(j + 1u), 0);
        let odd = (i & 1u) != 0u;
        let w = select(a, vec4<u32>(a.zw, b.xy), odd);
        let last = select(b.xy, b.zw, odd);
        return MeshVertex(bitcast<f32>(w.x), bitcast<f32>(w.y), bitcast<f32>(w.z), bitcast<f32>(w.w),
                          bitcast<f32>(last.x), last.y);
    } else {
        return mesh_vertex_from_storage(i);
    }
}

fn mesh_vertex_from_storage(i: u32) -> MeshVertex {
    if HAS_SPLIT_ARRAYS {
        let j = i & part_mask(MESH_VERTEX_PART_BITS);
        switch i >> MESH_VERTEX_PART_BITS {
            case 0u: { return mesh_vertices[j]; }
            case 1u: { return mesh_vertices_1[j]; }
            case 2u: { return mesh_vertices_2[j]; }
            default: { return mesh_vertices_3[j]; }
        }
    }
    return mesh_vertices[i];
}

// Word i of the texels: component i mod 4 of texel i / 4.
fn texel_at(i: u32) -> u32 {
    if DATA_IMAGES {
        let t = textureLoad(texels_image, data_texel_position(i >> 2u), 0);
        let k = i & 3u;
        return select(select(t.x, t.y, k == 1u), select(t.z, t.w, k == 3u), k >= 2u);
    } else {
        return texel_from_storage(i);
    }
}

fn texel_from_storage(i: u32) -> u32 {
    if HAS_SPLIT_ARRAYS {
        let j = i & part_mask(TEXEL_PART_BITS);
        switch i >> TEXEL_PART_BITS {
            case 0u: { return texels[j]; }
            case 1u: { return texels_1[j]; }
            case 2u: { return texels_2[j]; }
            default: { return texels_3[j]; }
        }
    }
    return texels[i];
}

// The render target: per-pixel running sums, and which samples the current dispatch traces over which
// pixels. An image too large for one buffer or one dispatch is cut (src/render/mod.rs, "Tiles"): each
// strip of whole rows has its own accumulator, whose entry 0 is pixel `accum_base` (row-major over the
// whole image), and each dispatch covers one tile of a strip, the pixels from (tile_x0, tile_y0)
// (included) to (tile_x1, tile_y1) (excluded). Untiled, that is the whole image and accum_base = 0.
struct PassConstants {
    sample_index: u32,
    accum_base: u32,
    tile_x0: u32,
    tile_y0: u32,
    tile_x1: u32,
    tile_y1: u32,
    // The dispatch traces samples sample_index .. sample_index + sample_count - 1 of each pixel.
    sample_count: u32,
    // Path continuation (trace.wgsl, main): 0 when the dispatch begins the tile's paths, one invocation
    // per pixel; otherwise the number of paths it continues, one invocation each, whose slots in
    // `path_state` are listed at path_queue[queue_in ..]. The paths still going when an invocation has
    // made `casts` ray casts are listed at path_queue[queue_out ..] for the next dispatch.
    queued: u32,
    queue_in: u32,
    queue_out: u32,
    casts: u32,
    // The pass's first sample index: sample s of a pixel is its splat record s - pass_start (trace.wgsl).
    pass_start: u32,
    // Adaptive sampling (render.adaptive, src/render/adaptive.rs): when list_len > 0, the dispatch that
    // begins paths traces the pixels active_pixels[list_start .. list_start + list_len] (one invocation
    // each, in rows tile_x1 - tile_x0 wide) instead of the tile's rectangle, so that pixels that have
    // converged cost nothing. 0: the rectangle.
    list_start: u32,
    list_len: u32,
}

@group(0) @binding(5) var<storage, read_write> accum: array<Accum>;
@group(0) @binding(6) var<uniform> pass_constants: PassConstants;

// Samples the accumulator could not take as they were, counted over the whole render (SAMPLE_CLAMPED and
// SAMPLE_NOT_FINITE of accumulate.wgsl, one counter each), and paths ended by BOUNCE_CAP rather than by
// the scene's own bounce limit or by roulette (FAULT_BOUNCE_CAP, trace.wgsl): the host reads them after
// each pass and reports them (`--json`, stderr), so that no sample is changed silently.
const FAULT_BOUNCE_CAP: u32 = 2u;
// The most bounces a path makes, whatever the scene asks (src/kernel/abi.rs explains the choice).
const BOUNCE_CAP: u32 = 1024u;
@group(0) @binding(12) var<storage, read_write> sample_faults: array<atomic<u32>, 3>;

fn count_sample_fault(fault: u32) {
    if (fault & SAMPLE_CLAMPED) != 0u {
        atomicAdd(&sample_faults[0], 1u);
    }
    if (fault & SAMPLE_NOT_FINITE) != 0u {
        atomicAdd(&sample_faults[1], 1u);
    }
}
