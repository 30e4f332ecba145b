//! Every `#[repr(C)]` Pod struct in `src/kernel/abi.rs` against the layout naga reflects from the
//! production kernel's WGSL: member names in order, byte offsets, member types, struct sizes, alignment,
//! and the stride of the storage-buffer arrays the renderer uploads them into.
//!
//! A mismatch here means the GPU reads a field from the wrong bytes: the render is silently wrong, or
//! the buffer is too short and the validation layer (or the device) complains.

use naga::{Module, TypeInner};
use std::mem::{offset_of, size_of};
use vkpath::kernel::abi::{
    GpuAccum, GpuLight, GpuLightTriangle, GpuMaterial, GpuParams, GpuPassConstants, GpuSphere,
    GpuSplatAccum, GpuSplatConstants, GpuTriangle,
};

/// The production kernel, parsed (and validated, so the layouts are the ones the SPIR-V gets).
fn kernel() -> Module {
    // The same parse + validation + SPIR-V translation the renderer runs.
    vkpath::kernel::specialise::compile(&vkpath::kernel::library::trace_source())
        .unwrap_or_else(|e| panic!("the production kernel does not compile: {e}"))
        .module
}

/// What a Rust field is in WGSL terms: a scalar (`f32`) or an `N`-component vector of one (`[f32; 3]`
/// is `vec3<f32>`). Padding arrays (`_pad: [u32; 3]`) are expanded into scalars by [`check_struct`].
/// A WGSL member can also be a tightly packed `array<f32, N>`, which a Rust `[f32; N]` mirrors as well
/// (the offsets, checked separately, tell the two layouts apart).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Shape {
    Scalar(&'static str),
    Vector(u32, &'static str),
    Array(u32, &'static str),
}

impl Shape {
    /// Whether a WGSL member of this shape is mirrored by a Rust field of shape `rust`.
    fn mirrored_by(self, rust: Shape) -> bool {
        match (self, rust) {
            (Shape::Array(n, s), Shape::Vector(m, t)) => n == m && s == t,
            (w, r) => w == r,
        }
    }
}

impl std::fmt::Display for Shape {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Shape::Scalar(s) => f.write_str(s),
            Shape::Vector(n, s) => write!(f, "vec{n}<{s}>"),
            Shape::Array(n, s) => write!(f, "array<{s}, {n}>"),
        }
    }
}

trait WgslShape {
    const SHAPE: Shape;
}

impl WgslShape for f32 {
    const SHAPE: Shape = Shape::Scalar("f32");
}
impl WgslShape for u32 {
    const SHAPE: Shape = Shape::Scalar("u32");
}
impl WgslShape for i32 {
    const SHAPE: Shape = Shape::Scalar("i32");
}
impl<const N: usize> WgslShape for [f32; N] {
    const SHAPE: Shape = Shape::Vector(N as u32, "f32");
}
impl<const N: usize> WgslShape for [u32; N] {
    const SHAPE: Shape = Shape::Vector(N as u32, "u32");
}

/// The shape of a field, inferred from an accessor closure so that the macro need not name its type.
fn shape_of<T, F: WgslShape>(_field: fn(&T) -> &F) -> Shape {
    F::SHAPE
}

/// One field of a Rust struct: its name, byte offset and WGSL shape.
struct RustField {
    name: &'static str,
    offset: usize,
    shape: Shape,
}

/// `fields!(GpuSphere: center, radius, material, _pad)`: the listed fields with their offsets and shapes.
macro_rules! fields {
    ($t:ty: $($f:ident),+ $(,)?) => {
        vec![$(RustField {
            name: stringify!($f),
            offset: offset_of!($t, $f),
            shape: shape_of(|s: &$t| &s.$f),
        }),+]
    };
}

fn is_padding(name: &str) -> bool {
    name.starts_with("_pad")
}

/// The WGSL shape of a naga type, if it is a scalar or a vector of one.
fn wgsl_shape(module: &Module, inner: &TypeInner) -> Option<Shape> {
    let scalar = |s: naga::Scalar| match (s.kind, s.width) {
        (naga::ScalarKind::Float, 4) => Some("f32"),
        (naga::ScalarKind::Uint, 4) => Some("u32"),
        (naga::ScalarKind::Sint, 4) => Some("i32"),
        _ => None,
    };
    match inner {
        TypeInner::Scalar(s) => scalar(*s).map(Shape::Scalar),
        TypeInner::Vector { size, scalar: s } => scalar(*s).map(|n| Shape::Vector(*size as u32, n)),
        TypeInner::Array {
            base,
            size: naga::ArraySize::Constant(n),
            stride: 4,
        } => match &module.types[*base].inner {
            TypeInner::Scalar(s) => scalar(*s).map(|name| Shape::Array(n.get(), name)),
            _ => None,
        },
        // An array of vec4s packed without padding (stride 16) is the same memory as a flat array of
        // four times as many scalars (Material::coat: uniform buffers need a stride of 16 bytes).
        TypeInner::Array {
            base,
            size: naga::ArraySize::Constant(n),
            stride: 16,
        } => match &module.types[*base].inner {
            TypeInner::Vector {
                size: naga::VectorSize::Quad,
                scalar: s,
            } => scalar(*s).map(|name| Shape::Array(4 * n.get(), name)),
            _ => None,
        },
        _ => None,
    }
}

/// Checks the WGSL struct `wgsl_name` against a Rust struct of `rust_size` bytes whose fields, in
/// declaration order, are `fields` (every field must be listed: the list is also checked to cover the
/// whole struct). Panics with a message naming the struct and the member at the first mismatch.
fn check_struct(
    module: &Module,
    wgsl_name: &str,
    rust_name: &str,
    rust_size: usize,
    fields: Vec<RustField>,
) {
    let (handle, ty) = module
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref() == Some(wgsl_name))
        .unwrap_or_else(|| {
            panic!("struct {wgsl_name} (mirrored by {rust_name}) is not in the production kernel")
        });
    let TypeInner::Struct { members, span } = &ty.inner else {
        panic!(
            "WGSL type {wgsl_name} (mirrored by {rust_name}) is not a struct: {:?}",
            ty.inner
        );
    };

    // Rust padding arrays `_pad: [u32; N]` stand for N scalar WGSL members `_pad0`..: expand them, each
    // 4 bytes after the previous one.
    let mut expected = Vec::new();
    for f in &fields {
        match f.shape {
            Shape::Vector(n, scalar) if is_padding(f.name) => {
                for k in 0..n as usize {
                    expected.push((
                        format!("{}[{k}]", f.name),
                        f.offset + 4 * k,
                        Shape::Scalar(scalar),
                    ));
                }
            }
            shape => expected.push((f.name.to_string(), f.offset, shape)),
        }
    }

    let wgsl_names: Vec<_> = members
        .iter()
        .map(|m| m.name.clone().unwrap_or_default())
        .collect();
    let rust_names: Vec<_> = expected.iter().map(|(n, ..)| n.clone()).collect();
    assert_eq!(
        members.len(),
        expected.len(),
        "{rust_name} vs WGSL {wgsl_name}: member count differs (padding arrays expanded)\n  WGSL: {wgsl_names:?}\n  Rust: {rust_names:?}"
    );

    let mut covered = 0usize;
    for (i, (m, (rust_field, rust_offset, rust_shape))) in members.iter().zip(&expected).enumerate()
    {
        let wgsl_member = m.name.as_deref().unwrap_or("<unnamed>");
        let names_match = if is_padding(rust_field) {
            is_padding(wgsl_member)
        } else {
            wgsl_member == rust_field
        };
        assert!(
            names_match,
            "{rust_name} vs WGSL {wgsl_name}: member #{i} is `{wgsl_member}` in WGSL but `{rust_field}` in Rust\n  WGSL: {wgsl_names:?}\n  Rust: {rust_names:?}"
        );
        assert_eq!(
            m.offset as usize, *rust_offset,
            "{rust_name} vs WGSL {wgsl_name}: member `{wgsl_member}` is at byte {} in WGSL but field `{rust_field}` is at byte {rust_offset} in Rust",
            m.offset
        );
        let member_inner = &module.types[m.ty].inner;
        let wgsl = wgsl_shape(module, member_inner).unwrap_or_else(|| {
            panic!("{rust_name} vs WGSL {wgsl_name}: member `{wgsl_member}` has a type this test does not know: {member_inner:?}")
        });
        assert!(
            wgsl.mirrored_by(*rust_shape),
            "{rust_name} vs WGSL {wgsl_name}: member `{wgsl_member}` is {wgsl} in WGSL but field `{rust_field}` is {rust_shape} in Rust"
        );
        let size = member_inner.size(module.to_ctx()) as usize;
        assert!(
            *rust_offset >= covered,
            "{rust_name}: field `{rust_field}` at byte {rust_offset} overlaps the previous field, which ends at byte {covered}"
        );
        covered = rust_offset + size;
    }
    assert!(
        covered <= rust_size,
        "{rust_name}: its fields end at byte {covered}, past its size {rust_size}"
    );

    assert_eq!(
        *span as usize, rust_size,
        "{rust_name} vs WGSL {wgsl_name}: WGSL struct size (span) is {span} bytes, size_of::<{rust_name}>() is {rust_size}"
    );

    // Arrays of the struct in storage buffers use a stride of round_up(align, size): the struct size only
    // when it is a multiple of the alignment.
    let mut layouter = naga::proc::Layouter::default();
    layouter
        .update(module.to_ctx())
        .expect("naga computes the kernel's layouts");
    let layout = &layouter[handle];
    let align = layout.alignment * 1;
    // Structs with vec3/vec4 members align to 16; the Rust side pads to match. (Structs of scalars and
    // arrays of scalars, such as the push-constant block and Accum, align to 4.)
    let has_vectors = members
        .iter()
        .any(|m| matches!(module.types[m.ty].inner, TypeInner::Vector { .. }));
    let expected_align = if has_vectors { 16 } else { 4 };
    assert_eq!(
        align, expected_align,
        "WGSL {wgsl_name} (mirrored by {rust_name}): alignment is {align}, expected {expected_align}"
    );
    assert!(
        layout.alignment.is_aligned(*span),
        "WGSL {wgsl_name} (mirrored by {rust_name}): size {span} is not a multiple of its alignment {align}, so an array of it would have stride {} != size_of::<{rust_name}>() = {rust_size}",
        layout.to_stride()
    );
    assert_eq!(
        layout.to_stride() as usize,
        rust_size,
        "WGSL {wgsl_name} (mirrored by {rust_name}): array stride differs from the Rust size"
    );
}

/// Checks that the global `var_name` is a runtime-sized array of `struct_name` whose stride is `rust_size`.
fn check_storage_array(
    module: &Module,
    var_name: &str,
    struct_name: &str,
    rust_name: &str,
    rust_size: usize,
) {
    let (_, var) = module
        .global_variables
        .iter()
        .find(|(_, v)| v.name.as_deref() == Some(var_name))
        .unwrap_or_else(|| panic!("the production kernel has no global `{var_name}`"));
    assert!(
        matches!(var.space, naga::AddressSpace::Storage { .. }),
        "`{var_name}` should be a storage buffer, is {:?}",
        var.space
    );
    let TypeInner::Array { base, size, stride } = &module.types[var.ty].inner else {
        panic!(
            "`{var_name}` should be an array<{struct_name}>, is {:?}",
            module.types[var.ty]
        );
    };
    assert_eq!(
        module.types[*base].name.as_deref(),
        Some(struct_name),
        "`{var_name}` should be an array of {struct_name}"
    );
    assert_eq!(
        *size,
        naga::ArraySize::Dynamic,
        "`{var_name}` should be a runtime-sized array"
    );
    assert_eq!(
        *stride as usize, rust_size,
        "`{var_name}`: array<{struct_name}> stride is {stride} bytes in WGSL but the host uploads {rust_name}s of {rust_size} bytes"
    );
}

#[test]
fn params_matches_wgsl() {
    let module = kernel();
    check_struct(
        &module,
        "Params",
        "GpuParams",
        size_of::<GpuParams>(),
        fields!(GpuParams:
            cam_position, lens_radius, cam_right, view_half_width, cam_up, focus_distance, cam_forward,
            filter_width, environment_light, triangle_light, sample_clamp, filter_kind, width, height, max_bounces, seed, sampler,
            light_sampling, num_spheres, num_triangles, num_lights, roulette_depth, guard_one, camera_kind,
            aov, filter_in_image, splat, _pad),
    );
    // The uniform buffer holds one Params.
    let (_, params) = module
        .global_variables
        .iter()
        .find(|(_, v)| v.name.as_deref() == Some("params"))
        .expect("the kernel has a `params` global");
    assert_eq!(
        params.space,
        naga::AddressSpace::Uniform,
        "`params` should be a uniform buffer"
    );
    assert_eq!(
        module.types[params.ty].name.as_deref(),
        Some("Params"),
        "`params` should be a Params"
    );
}

#[test]
fn sphere_matches_wgsl() {
    let module = kernel();
    check_struct(
        &module,
        "Sphere",
        "GpuSphere",
        size_of::<GpuSphere>(),
        fields!(GpuSphere: center, radius, material, _pad),
    );
    check_storage_array(
        &module,
        "spheres",
        "Sphere",
        "GpuSphere",
        size_of::<GpuSphere>(),
    );
}

#[test]
fn triangle_matches_wgsl() {
    let module = kernel();
    check_struct(
        &module,
        "Triangle",
        "GpuTriangle",
        size_of::<GpuTriangle>(),
        fields!(GpuTriangle: v0, material, v1, _pad0, v2, _pad1),
    );
    check_storage_array(
        &module,
        "triangles",
        "Triangle",
        "GpuTriangle",
        size_of::<GpuTriangle>(),
    );
}

#[test]
fn material_matches_wgsl() {
    let module = kernel();
    check_struct(
        &module,
        "Material",
        "GpuMaterial",
        size_of::<GpuMaterial>(),
        fields!(GpuMaterial: albedo, kind, emission, ior, eta, alpha_x, k, alpha_y, flags, metallic, fdr_int, back, block),
    );
    check_storage_array(
        &module,
        "materials",
        "Material",
        "GpuMaterial",
        size_of::<GpuMaterial>(),
    );
}

#[test]
fn light_matches_wgsl() {
    let module = kernel();
    check_struct(
        &module,
        "Light",
        "GpuLight",
        size_of::<GpuLight>(),
        fields!(GpuLight: position, radius, intensity, kind, index, map_width, map_height, spot_falloff, axis, spot_inv_width, spot_cone),
    );
    check_storage_array(
        &module,
        "lights",
        "Light",
        "GpuLight",
        size_of::<GpuLight>(),
    );
}

#[test]
fn light_triangle_matches_wgsl() {
    let module = kernel();
    check_struct(
        &module,
        "LightTriangle",
        "GpuLightTriangle",
        size_of::<GpuLightTriangle>(),
        fields!(GpuLightTriangle: v0, alias_triangle, v1, keep, v2, flags, emission, triangle),
    );
    check_storage_array(
        &module,
        "light_triangles",
        "LightTriangle",
        "GpuLightTriangle",
        size_of::<GpuLightTriangle>(),
    );
}

#[test]
fn accum_matches_wgsl() {
    let module = kernel();
    check_struct(
        &module,
        "Accum",
        "GpuAccum",
        size_of::<GpuAccum>(),
        fields!(GpuAccum: sum, sum_sq, sum_sq_c),
    );
    check_storage_array(&module, "accum", "Accum", "GpuAccum", size_of::<GpuAccum>());
}

/// The splat gather's structs (shaders/splat.wgsl, accumulate.wgsl) against their Rust mirrors, and its
/// buffers' element types.
#[test]
fn splat_gather_matches_wgsl() {
    let module = vkpath::kernel::specialise::compile(&vkpath::kernel::library::splat_source())
        .unwrap_or_else(|e| panic!("the splat gather does not compile: {e}"))
        .module;
    check_struct(
        &module,
        "SplatAccum",
        "GpuSplatAccum",
        size_of::<GpuSplatAccum>(),
        fields!(GpuSplatAccum: sum, weight),
    );
    check_storage_array(
        &module,
        "splat_accum",
        "SplatAccum",
        "GpuSplatAccum",
        size_of::<GpuSplatAccum>(),
    );
    check_struct(
        &module,
        "SplatConstants",
        "GpuSplatConstants",
        size_of::<GpuSplatConstants>(),
        fields!(GpuSplatConstants: width, height, accum_base, row0, row1, first, count, filter_kind,
            filter_width, reach, _pad),
    );
    // The records the render kernel writes and the gather reads: one vec4 each.
    for m in [&module, &kernel()] {
        let (_, var) = m
            .global_variables
            .iter()
            .find(|(_, v)| v.name.as_deref() == Some("splat_samples"))
            .expect("both kernels declare `splat_samples`");
        let TypeInner::Array { base, stride, .. } = m.types[var.ty].inner else {
            panic!("splat_samples is not an array");
        };
        assert_eq!(u64::from(stride), vkpath::kernel::abi::SPLAT_RECORD_BYTES);
        assert!(matches!(m.types[base].inner, TypeInner::Vector { .. }));
    }
}

/// The production kernel as parsed, before specialisation or compaction: every declared constant and
/// override is still there, used or not.
fn parsed_kernel() -> Module {
    naga::front::wgsl::parse_str(&vkpath::kernel::library::trace_source())
        .unwrap_or_else(|e| panic!("the production kernel does not parse: {e}"))
}

/// Every constant the host shares with the shader (`abi::SHARED_CONSTANTS`: kinds, knob values, mesh
/// flags, the BVH encoding, the accumulator's width) has the same value in the WGSL.
#[test]
fn shared_constants_match_wgsl() {
    let module = parsed_kernel();
    let constant = |name: &str| -> u32 {
        let (_, c) = module
            .constants
            .iter()
            .find(|(_, c)| c.name.as_deref() == Some(name))
            .unwrap_or_else(|| panic!("the production kernel has no constant {name}"));
        match module.global_expressions[c.init] {
            naga::Expression::Literal(naga::Literal::U32(v)) => v,
            ref other => panic!("constant {name} is not a u32 literal: {other:?}"),
        }
    };
    for &(name, value) in vkpath::kernel::abi::SHARED_CONSTANTS {
        assert_eq!(constant(name), value, "{name}: WGSL vs src/kernel/abi.rs");
    }
    // The data images' row width, which the GPU layer owns (src/gpu/image.rs).
    assert_eq!(
        constant("DATA_IMAGE_WIDTH_BITS"),
        vkpath::gpu::image::DATA_IMAGE_WIDTH_BITS,
        "DATA_IMAGE_WIDTH_BITS: WGSL vs src/gpu/image.rs"
    );
    // The material kinds are generated from the registry: each row's MAT_* is its index, and every
    // MAT_* of the kernel is a row (MATERIAL_* flags are shared constants above).
    for (i, k) in vkpath::scene::bsdfs::kinds().iter().enumerate() {
        assert_eq!(constant(&k.constant()), i as u32, "{}", k.constant());
    }
    // Every other kind-like WGSL constant is in the table: a new LIGHT_* in the shader without its
    // Rust twin fails here.
    for (_, c) in module.constants.iter() {
        let name = c.name.as_deref().unwrap_or("");
        if name.starts_with("MAT_") {
            assert!(
                vkpath::scene::bsdfs::kinds()
                    .iter()
                    .any(|k| k.constant() == name),
                "WGSL constant {name} is not a kind of the material registry"
            );
            continue;
        }
        let shared = [
            "BSDF_",
            "LIGHT_",
            "CAMERA_",
            "FILTER_",
            "SAMPLER_",
            "MESH_",
            "MATERIAL_",
        ];
        if shared.iter().any(|p| name.starts_with(p)) {
            assert!(
                vkpath::kernel::abi::SHARED_CONSTANTS
                    .iter()
                    .any(|(n, _)| *n == name),
                "WGSL constant {name} has no entry in abi::SHARED_CONSTANTS"
            );
        }
    }
}

/// The one shared f32 constant: the roughness below which glossy lobes are deltas (the host picks the
/// smooth material kinds by it, the shader its delta branches).
#[test]
fn smooth_alpha_matches_wgsl() {
    let module = parsed_kernel();
    let (_, c) = module
        .constants
        .iter()
        .find(|(_, c)| c.name.as_deref() == Some("SMOOTH_ALPHA"))
        .expect("the production kernel has SMOOTH_ALPHA");
    match module.global_expressions[c.init] {
        naga::Expression::Literal(naga::Literal::F32(v)) => {
            assert_eq!(v, vkpath::kernel::abi::SMOOTH_ALPHA)
        }
        ref other => panic!("SMOOTH_ALPHA is not an f32 literal: {other:?}"),
    }
}

/// The feature and knob tables (src/kernel/features.rs) set exactly the overrides the WGSL declares:
/// none missing (it would keep its default in every kernel) and none unknown (naga would refuse it).
#[test]
fn feature_table_matches_wgsl_overrides() {
    let module = parsed_kernel();
    let mut wgsl: Vec<String> = module
        .overrides
        .iter()
        .filter_map(|(_, o)| o.name.clone())
        .collect();
    let mut rust: Vec<String> = vkpath::kernel::features::FeatureSet::generic()
        .pipeline_constants()
        .into_iter()
        .map(|(n, _)| n.to_string())
        .collect();
    wgsl.sort();
    rust.sort();
    assert_eq!(
        wgsl, rust,
        "WGSL overrides vs the Rust feature and knob tables"
    );
}

/// The helper itself must catch a mismatch: a WGSL struct whose members are swapped relative to Rust.
#[test]
#[should_panic(
    expected = "GpuMaterial vs WGSL Material: member #1 is `ior` in WGSL but `kind` in Rust"
)]
fn check_struct_reports_a_swapped_member() {
    let module = naga::front::wgsl::parse_str(
        "struct Material { albedo: vec3<f32>, ior: f32, emission: vec3<f32>, kind: u32, eta: vec3<f32>, \
         alpha_x: f32, k: vec3<f32>, alpha_y: f32, flags: u32, metallic: f32, fdr_int: f32, back: u32, \
         block: array<f32, 16>, }\n\
         @group(0) @binding(0) var<storage, read> m: array<Material>;\n",
    )
    .expect("test WGSL parses");
    check_struct(
        &module,
        "Material",
        "GpuMaterial",
        size_of::<GpuMaterial>(),
        fields!(GpuMaterial: albedo, kind, emission, ior, eta, alpha_x, k, alpha_y, flags, metallic, fdr_int, back, block),
    );
}

/// ... and a member of the right name at the wrong offset.
#[test]
#[should_panic(
    expected = "member `radius` is at byte 16 in WGSL but field `radius` is at byte 12 in Rust"
)]
fn check_struct_reports_a_wrong_offset() {
    let module = naga::front::wgsl::parse_str(
        "struct Sphere { center: vec3<f32>, @align(16) radius: f32, material: u32, _pad0: u32, _pad1: u32, _pad2: u32, }\n",
    )
    .expect("test WGSL parses");
    check_struct(
        &module,
        "Sphere",
        "GpuSphere",
        size_of::<GpuSphere>(),
        fields!(GpuSphere: center, radius, material, _pad),
    );
}

#[test]
fn pass_constants_match_wgsl() {
    let module = kernel();
    check_struct(
        &module,
        "PassConstants",
        "GpuPassConstants",
        size_of::<GpuPassConstants>(),
        fields!(
            GpuPassConstants: sample_index,
            accum_base,
            tile_x0,
            tile_y0,
            tile_x1,
            tile_y1,
            sample_count,
            queued,
            queue_in,
            queue_out,
            casts,
            pass_start,
            list_start,
            list_len
        ),
    );
    let (_, var) = module
        .global_variables
        .iter()
        .find(|(_, v)| v.name.as_deref() == Some("pass_constants"))
        .expect("the kernel takes its sample index in `pass_constants`");
    assert_eq!(var.space, naga::AddressSpace::Uniform);
    assert_eq!(module.types[var.ty].name.as_deref(), Some("PassConstants"));
}

/// The host allocates `PATH_STATE_BYTES` per path in flight for the kernel's `path_state` array.
#[test]
fn path_state_size_matches_wgsl() {
    let module = kernel();
    let (_, ty) = module
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref() == Some("PathState"))
        .expect("PathState is in the production kernel");
    let TypeInner::Struct { span, .. } = &ty.inner else {
        panic!("PathState is not a struct");
    };
    let bytes = vkpath::kernel::abi::PATH_STATE_BYTES as usize;
    assert_eq!(*span as usize, bytes);
    check_storage_array(
        &module,
        "path_state",
        "PathState",
        "PATH_STATE_BYTES",
        bytes,
    );
}

// ----- meshes and the BVH (src/kernel/abi.rs, shaders/scene_data.wgsl, shaders/bvh.wgsl) -----

#[test]
fn mesh_structs_match_wgsl() {
    use vkpath::kernel::abi::{
        GpuBvhNode, GpuInstance, GpuMaterialTextures, GpuMeshFace, GpuMeshInfo, GpuMeshVertex,
        GpuTextureInfo,
    };
    let module = kernel();
    check_struct(
        &module,
        "Instance",
        "GpuInstance",
        size_of::<GpuInstance>(),
        fields!(GpuInstance: to_object_x, to_object_y, to_object_z, to_world_x, to_world_y, to_world_z, root, flags, material, _pad),
    );
    check_storage_array(
        &module,
        "instances",
        "Instance",
        "GpuInstance",
        size_of::<GpuInstance>(),
    );
    check_struct(
        &module,
        "BvhNode",
        "GpuBvhNode",
        size_of::<GpuBvhNode>(),
        fields!(GpuBvhNode: origin, exponents, planes_xy, planes_z, _pad, child),
    );
    check_storage_array(
        &module,
        "bvh_nodes",
        "BvhNode",
        "GpuBvhNode",
        size_of::<GpuBvhNode>(),
    );
    check_struct(
        &module,
        "MeshFace",
        "GpuMeshFace",
        size_of::<GpuMeshFace>(),
        fields!(GpuMeshFace: vertices, mesh),
    );
    check_storage_array(
        &module,
        "mesh_faces",
        "MeshFace",
        "GpuMeshFace",
        size_of::<GpuMeshFace>(),
    );
    check_struct(
        &module,
        "MeshVertex",
        "GpuMeshVertex",
        size_of::<GpuMeshVertex>(),
        fields!(GpuMeshVertex: nx, ny, nz, u, v, tangent),
    );
    check_storage_array(
        &module,
        "mesh_vertices",
        "MeshVertex",
        "GpuMeshVertex",
        size_of::<GpuMeshVertex>(),
    );
    check_struct(
        &module,
        "MeshInfo",
        "GpuMeshInfo",
        size_of::<GpuMeshInfo>(),
        fields!(GpuMeshInfo: flags, _pad),
    );
    check_storage_array(
        &module,
        "meshes",
        "MeshInfo",
        "GpuMeshInfo",
        size_of::<GpuMeshInfo>(),
    );
    check_struct(
        &module,
        "TextureInfo",
        "GpuTextureInfo",
        size_of::<GpuTextureInfo>(),
        fields!(GpuTextureInfo: offset, width, height, flags, uv_matrix, uv_offset, _pad),
    );
    check_storage_array(
        &module,
        "textures",
        "TextureInfo",
        "GpuTextureInfo",
        size_of::<GpuTextureInfo>(),
    );
    check_struct(
        &module,
        "MaterialTextures",
        "GpuMaterialTextures",
        size_of::<GpuMaterialTextures>(),
        fields!(
            GpuMaterialTextures: albedo_texture,
            roughness_texture,
            metallic_texture,
            emission_texture,
            opacity_texture,
            bump_texture,
            normal_texture,
            flags,
            opacity,
            alpha_cutoff,
            bump_scale,
            normal_scale,
            blend,
            blend_weight,
            blend_texture,
            _pad0
        ),
    );
    check_storage_array(
        &module,
        "material_textures",
        "MaterialTextures",
        "GpuMaterialTextures",
        size_of::<GpuMaterialTextures>(),
    );
}

/// Every part of every array split across bindings (abi::SPLIT_ARRAYS) is a storage binding of the
/// production kernel with part 0's element type and the host's element size, each part fits the 2^27
/// bytes every Vulkan device can bind, and the kernel declares no part the table lacks.
#[test]
fn split_arrays_match_wgsl() {
    use vkpath::kernel::abi::SPLIT_ARRAYS;
    let module = parsed_kernel();
    let ty_of = |name: &str| {
        let (_, var) = module
            .global_variables
            .iter()
            .find(|(_, v)| v.name.as_deref() == Some(name))
            .unwrap_or_else(|| panic!("the production kernel has no global `{name}`"));
        assert!(
            matches!(var.space, naga::AddressSpace::Storage { .. }),
            "{name}"
        );
        var.ty
    };
    for a in &SPLIT_ARRAYS {
        assert_eq!(a.parts[0], a.name);
        assert!(a.part_elements() * a.element_bytes <= 1 << 27, "{}", a.name);
        let TypeInner::Array { stride, .. } = module.types[ty_of(a.name)].inner else {
            panic!("`{}` is not an array", a.name)
        };
        assert_eq!(stride as usize, a.element_bytes, "{}", a.name);
        for part in a.parts {
            assert_eq!(
                ty_of(part),
                ty_of(a.name),
                "`{part}` and `{}` differ",
                a.name
            );
        }
    }
    for (_, v) in module.global_variables.iter() {
        let name = v.name.as_deref().unwrap_or("");
        if let Some((base, k)) = name.rsplit_once('_')
            && k.parse::<usize>().is_ok()
        {
            let a = SPLIT_ARRAYS.iter().find(|a| a.name == base);
            assert!(
                a.is_some_and(|a| a.parts.contains(&name)),
                "the kernel declares `{name}`, which abi::SPLIT_ARRAYS does not list"
            );
        }
    }
}

/// Every uniform twin (abi::UNIFORM_ARRAYS) is a uniform binding of the production kernel holding
/// exactly UNIFORM_ARRAY_BYTES: an array of the storage array's element type (the same struct, so the
/// same layout, which the uniform address space accepts only if its stride is a multiple of 16) and
/// the host's element size; its override exists; and the kernel declares no twin the table lacks.
#[test]
fn uniform_arrays_match_wgsl() {
    use vkpath::kernel::abi::{UNIFORM_ARRAY_BYTES, UNIFORM_ARRAYS};
    let module = parsed_kernel();
    let var_of = |name: &str| {
        module
            .global_variables
            .iter()
            .find(|(_, v)| v.name.as_deref() == Some(name))
            .map(|(_, v)| v)
            .unwrap_or_else(|| panic!("the production kernel has no global `{name}`"))
    };
    for a in &UNIFORM_ARRAYS {
        let twin = var_of(a.uniform);
        assert_eq!(twin.space, naga::AddressSpace::Uniform, "{}", a.uniform);
        let TypeInner::Array {
            base,
            size: naga::ArraySize::Constant(n),
            stride,
        } = module.types[twin.ty].inner
        else {
            panic!("`{}` is not an array of fixed length", a.uniform)
        };
        assert_eq!(n.get() as usize, a.max_elements(), "{}", a.uniform);
        assert_eq!(stride as usize, a.element_bytes, "{}", a.uniform);
        assert_eq!(stride % 16, 0, "{}", a.uniform);
        assert!(a.max_elements() * a.element_bytes <= UNIFORM_ARRAY_BYTES);
        let storage = var_of(a.name);
        assert!(matches!(storage.space, naga::AddressSpace::Storage { .. }));
        let TypeInner::Array {
            base: storage_base, ..
        } = module.types[storage.ty].inner
        else {
            panic!("`{}` is not an array", a.name)
        };
        assert_eq!(
            base, storage_base,
            "`{}` and `{}` differ",
            a.uniform, a.name
        );
        assert!(
            module
                .overrides
                .iter()
                .any(|(_, o)| o.name.as_deref() == Some(a.constant)),
            "no override {}",
            a.constant
        );
    }
    for (_, v) in module.global_variables.iter() {
        let name = v.name.as_deref().unwrap_or("");
        if v.space == naga::AddressSpace::Uniform && name.ends_with("_uniform") {
            assert!(
                UNIFORM_ARRAYS.iter().any(|a| a.uniform == name),
                "the kernel declares `{name}`, which abi::UNIFORM_ARRAYS does not list"
            );
        }
    }
}
