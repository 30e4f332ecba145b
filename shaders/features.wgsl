// features.wgsl: the kernel's specialisation constants, one per feature a scene may or may not use.
//
// Each is a pipeline-overridable constant. The generic kernel keeps the defaults (everything on but
// HAS_SPLIT_ARRAYS); for a given scene the host sets each from the scene's feature set
// (src/kernel/features.rs, one table row per constant below), naga folds them into constants, and
// src/kernel/specialise.rs prunes every `if FEATURE { ... }` whose condition became `false` before the
// SPIR-V is written: an absent feature leaves no code at all. Guards are written `if HAS_X { if runtime_test { ... } }` so that the outer
// condition is a bare constant. A present feature runs exactly the generic code, so both kernels give the
// same bits. tests/layout.rs holds this list against the Rust table, both ways.
//
// requires: (nothing)

override HAS_SPHERES: bool = true;
override HAS_TRIANGLES: bool = true;
// Triangles are found through the BVH (bvh.wgsl) when the scene has one (more than 16 triangles: the
// host uploads no nodes for fewer, and the generic kernel then finds `bvh_nodes` empty); otherwise by a
// loop over every triangle, which is also the reference the BVH is tested and benchmarked against.
override HAS_BVH: bool = true;
override HAS_TRIANGLE_LOOP: bool = true;
// Instanced meshes: the BVH is two-level (bvh.wgsl; scene_data.wgsl, Instance); and some placement is
// in a material of its own (scene_data.wgsl, placed_material).
override HAS_INSTANCES: bool = true;
override HAS_INSTANCE_MATERIALS: bool = true;
// Spheres likewise, through their own BVH (`sphere_nodes`) when the scene has at least 16
// (upload::SPHERE_BVH_MIN; the generic kernel finds `sphere_nodes` empty below), else by a loop.
override HAS_SPHERE_BVH: bool = true;
// Meshes: interpolated vertex normals. Materials' textures (scene_data.wgsl, MaterialTextures): a
// textured albedo (base colour, tint), emission, metallic or roughness, normal maps, bump maps, and
// opacity (cut-outs and stochastic transparency, constant or textured); any texture at all (the texture
// coordinates of a hit), and any per-triangle shading data (smooth normals or texture coordinates).
override HAS_SMOOTH_NORMALS: bool = true;
override HAS_TEXTURES: bool = true;
override HAS_EMISSIVE_TEXTURES: bool = true;
override HAS_METALLIC_ROUGHNESS_TEXTURES: bool = true;
override HAS_PLUGIN_TEXTURES: bool = true; // a material plugin's parameter (plugin_textures.wgsl)
override HAS_NORMAL_MAPS: bool = true;
override HAS_BUMP_MAPS: bool = true;
override HAS_BACK_MATERIALS: bool = true;
override HAS_BLEND_MATERIALS: bool = true;
override HAS_OPACITY: bool = true;
override HAS_CHECKERBOARD: bool = true; // some texture is Mitsuba's procedural checkerboard (texture.wgsl)
override HAS_MATERIAL_TEXTURES: bool = true;
override HAS_MESH_SHADING: bool = true;
// Materials: one override per material kind, HAS_<KIND>, generated with the kinds (bsdf_kinds.wgsl,
// from the registry src/scene/bsdfs.rs).
// Some glossy material has a different roughness along the tangent and the bitangent: the integrator
// then computes a tangent per hit (surface_tangent, scene.wgsl).
override HAS_ANISOTROPY: bool = true;
// Some glossy material's microfacets follow Beckmann's distribution rather than GGX's (microfacet.wgsl).
override HAS_BECKMANN: bool = true;
override HAS_EMISSION: bool = true; // some surface emits (an emitter, or any material with `emission`)
// Lights: each kind's override (HAS_POINT_LIGHTS, HAS_SPHERE_LIGHTS, ...) is generated beside its LIGHT_*
// constant from the light registry (light_kinds.wgsl; src/kernel/light_kinds.rs).
override HAS_ENVIRONMENT_MAP: bool = true; // the environment light has a map (lights/environment.wgsl)
override HAS_LENS: bool = true; // aperture > 0
override HAS_ORTHOGRAPHIC: bool = true; // camera.type = "orthographic"
override HAS_ROULETTE: bool = true;
// Some scene array is larger than one binding's part (scene_data.wgsl, triangle_at and its siblings).
// Not a feature but the arrays' layout, and the one override whose default is off: the generic kernel
// reads every array from one binding unless the scene needs more (src/kernel/features.rs,
// FeatureSet::generic explains why).
override HAS_SPLIT_ARRAYS: bool = false;
// A small scene's array read from its uniform twin rather than its storage binding (scene_data.wgsl,
// triangle_at and its siblings; src/kernel/abi.rs, UNIFORM_ARRAYS, says why and when). The arrays'
// layout again: off in the generic kernel.
override UNIFORM_TRIANGLES: bool = false;
override UNIFORM_BVH_NODES: bool = false;
override UNIFORM_SPHERES: bool = false;
override UNIFORM_SPHERE_NODES: bool = false;
override UNIFORM_LIGHTS: bool = false;
override UNIFORM_LIGHT_TRIANGLES: bool = false;
override UNIFORM_INSTANCES: bool = false;
override UNIFORM_MATERIALS: bool = false;
override UNIFORM_TEXTURES: bool = false;
override UNIFORM_MATERIAL_TEXTURES: bool = false;
// The large read-only arrays (BVH nodes, triangles, mesh faces and vertices, texels) read from data images with textureLoad rather than
// from storage buffers (scene_data.wgsl; src/gpu/image.rs says why and when). Their layout again: the
// host decides it per device.
override DATA_IMAGES: bool = false;
// Exactly one material kind (counting emitters) / one light kind in the scene: the kind tests go.
override SINGLE_MATERIAL_KIND: bool = false;
override SINGLE_LIGHT_KIND: bool = false;
