//! The WGSL library and its compilation to SPIR-V by naga, at run time.
//!
//! WGSL has no `#include`, so the host composes a shader by concatenating library files in dependency
//! order. The production kernel (`trace.wgsl`) and every test kernel call the same library functions:
//! a test of `intersect_sphere` tests exactly the code that renders.

use super::GpuError;
use ash::vk;

/// The pure function library, in dependency order: no bindings, only functions and structs.
pub const LIBRARY: &[(&str, &str)] = &[
    ("rng.wgsl", include_str!("../../shaders/rng.wgsl")),
    ("sampling.wgsl", include_str!("../../shaders/sampling.wgsl")),
    (
        "intersect.wgsl",
        include_str!("../../shaders/intersect.wgsl"),
    ),
    (
        "materials.wgsl",
        include_str!("../../shaders/materials.wgsl"),
    ),
    ("camera.wgsl", include_str!("../../shaders/camera.wgsl")),
    (
        "accumulate.wgsl",
        include_str!("../../shaders/accumulate.wgsl"),
    ),
];

/// Scene buffers (bindings 0–4), scene queries and direct lighting.
pub const SCENE: (&str, &str) = ("scene.wgsl", include_str!("../../shaders/scene.wgsl"));
/// The path-tracing kernel (binding 5: the accumulator).
pub const TRACE: (&str, &str) = ("trace.wgsl", include_str!("../../shaders/trace.wgsl"));

/// Concatenates the library with extra modules, marking where each file starts so that naga's error
/// messages can be traced back to a file.
pub fn compose(extra: &[(&str, &str)]) -> String {
    let mut out = String::new();
    for (name, text) in LIBRARY.iter().chain(extra.iter()) {
        out.push_str(&format!("// ---- {name} ----\n"));
        out.push_str(text);
        out.push('\n');
    }
    out
}

/// The full source of the production kernel.
pub fn trace_source() -> String {
    compose(&[SCENE, TRACE])
}

/// One resource binding of a compiled shader, reflected from the WGSL.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BindingInfo {
    pub binding: u32,
    pub name: String,
    pub descriptor_type: vk::DescriptorType,
}

/// A validated naga module, its SPIR-V and its bindings (all in group 0).
pub struct CompiledShader {
    pub module: naga::Module,
    pub info: naga::valid::ModuleInfo,
    pub spirv: Vec<u32>,
    pub bindings: Vec<BindingInfo>,
    pub workgroup_size: [u32; 3],
    /// Size in bytes of the `var<immediate>` block (push constants), 0 if the shader has none.
    pub immediate_size: u32,
}

/// Parses, validates and translates WGSL with one compute entry point `main`.
pub fn compile(source: &str) -> Result<CompiledShader, GpuError> {
    let module = naga::front::wgsl::parse_str(source)
        .map_err(|e| GpuError::Shader(e.emit_to_string(source).replace('\n', " ")))?;
    let info = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::IMMEDIATES,
    )
    .validate(&module)
    .map_err(|e| GpuError::Shader(format!("{:?}", e.into_inner())))?;
    let entry = module
        .entry_points
        .iter()
        .find(|e| e.name == "main" && e.stage == naga::ShaderStage::Compute)
        .ok_or_else(|| GpuError::Shader("no `@compute fn main` entry point".into()))?;
    let workgroup_size = entry.workgroup_size;
    let options = naga::back::spv::Options {
        // Our loops are bounded by scene sizes and bounce limits; naga's extra loop counters would only
        // cost time in the hottest code.
        force_loop_bounding: false,
        flags: naga::back::spv::WriterFlags::empty(),
        ..Default::default()
    };
    let pipeline = naga::back::spv::PipelineOptions {
        shader_stage: naga::ShaderStage::Compute,
        entry_point: "main".into(),
    };
    let spirv = naga::back::spv::write_vec(&module, &info, &options, Some(&pipeline))
        .map_err(|e| GpuError::Shader(e.to_string()))?;
    let mut bindings = Vec::new();
    let mut immediate_size = 0;
    for (_, var) in module.global_variables.iter() {
        if var.space == naga::AddressSpace::Immediate {
            immediate_size = module.types[var.ty].inner.size(module.to_ctx());
            continue;
        }
        let Some(rb) = &var.binding else { continue };
        if rb.group != 0 {
            return Err(GpuError::Shader(format!(
                "binding group {} used; only group 0 is supported",
                rb.group
            )));
        }
        let descriptor_type = match var.space {
            naga::AddressSpace::Uniform => vk::DescriptorType::UNIFORM_BUFFER,
            naga::AddressSpace::Storage { .. } => vk::DescriptorType::STORAGE_BUFFER,
            other => {
                return Err(GpuError::Shader(format!(
                    "unsupported binding address space {other:?}"
                )));
            }
        };
        bindings.push(BindingInfo {
            binding: rb.binding,
            name: var.name.clone().unwrap_or_default(),
            descriptor_type,
        });
    }
    bindings.sort_by_key(|b| b.binding);
    Ok(CompiledShader {
        module,
        info,
        spirv,
        bindings,
        workgroup_size,
        immediate_size,
    })
}
