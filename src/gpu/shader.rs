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
];

/// The per-pixel accumulator. Not in the pure library: it updates the `accum` storage array in place,
/// which the kernel that includes it declares (binding 5 of scene_data.wgsl, or a test kernel's own).
pub const ACCUMULATE: (&str, &str) = (
    "accumulate.wgsl",
    include_str!("../../shaders/accumulate.wgsl"),
);

/// The render kernels' data: structs and bindings 0–6.
pub const SCENE_DATA: (&str, &str) = (
    "scene_data.wgsl",
    include_str!("../../shaders/scene_data.wgsl"),
);
/// Scene queries and direct lighting, with the specialisation constants.
pub const SCENE: (&str, &str) = ("scene.wgsl", include_str!("../../shaders/scene.wgsl"));
/// The triangle BVH's traversal (bindings 2 and 7).
pub const BVH: (&str, &str) = ("bvh.wgsl", include_str!("../../shaders/bvh.wgsl"));
/// Albedo textures: sRGB decoding and bilinear filtering (bindings 10 and 11).
pub const TEXTURE: (&str, &str) = ("texture.wgsl", include_str!("../../shaders/texture.wgsl"));
/// The path-tracing kernel (binding 5: the accumulator).
pub const TRACE: (&str, &str) = ("trace.wgsl", include_str!("../../shaders/trace.wgsl"));

/// A kernel written by hand for diffuse spheres and point lights only: the bound that specialisation is
/// measured against (`vkpath bench specialisation`).
pub const TRIMMED_DIFFUSE_POINT: (&str, &str) = (
    "bench/trimmed_diffuse_point.wgsl",
    include_str!("../../shaders/bench/trimmed_diffuse_point.wgsl"),
);

/// The full source of the hand-trimmed benchmark kernel.
pub fn trimmed_source() -> String {
    compose(&[
        SCENE_DATA,
        ACCUMULATE,
        BVH,
        TEXTURE,
        SCENE,
        TRIMMED_DIFFUSE_POINT,
    ])
}

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
    compose(&[SCENE_DATA, ACCUMULATE, BVH, TEXTURE, SCENE, TRACE])
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
}

/// Parses, validates and translates WGSL with one compute entry point `main`, its `override` constants
/// left at their defaults.
pub fn compile(source: &str) -> Result<CompiledShader, GpuError> {
    compile_with(source, &[])
}

fn validate(module: &naga::Module) -> Result<naga::valid::ModuleInfo, GpuError> {
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::empty(),
    )
    .validate(module)
    .map_err(|e| GpuError::Shader(format!("{:?}", e.into_inner())))
}

/// Parses WGSL, sets the named `override` constants, folds them (naga's `process_overrides`), removes
/// every `if` whose condition became a constant (keeping the branch taken: see [`prune_constant_ifs`])
/// and every function no longer called, then translates to SPIR-V. With no constants given the module is
/// the generic one, defaults and all, and nothing is pruned.
pub fn compile_with(source: &str, constants: &[(&str, f64)]) -> Result<CompiledShader, GpuError> {
    let module = naga::front::wgsl::parse_str(source)
        .map_err(|e| GpuError::Shader(e.emit_to_string(source).replace('\n', " ")))?;
    let info = validate(&module)?;
    // Always fold: the SPIR-V writer takes no overrides. With no constants given, the defaults (the generic
    // kernel: every feature on) are folded, and pruning only flattens `if true` blocks.
    let mut values = naga::back::PipelineConstants::default();
    for (name, value) in constants {
        values.insert((*name).to_string(), *value);
    }
    let entry = Some((naga::ShaderStage::Compute, "main"));
    let (folded, _) =
        naga::back::pipeline_constants::process_overrides(&module, &info, entry, &values)
            .map_err(|e| GpuError::Shader(format!("specialisation failed: {e}")))?;
    let mut module = folded.into_owned();
    prune_constant_ifs(&mut module);
    naga::compact::compact(&mut module, naga::compact::KeepUnused::No);
    let info = validate(&module)?;

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
    for (_, var) in module.global_variables.iter() {
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
    })
}

/// The value of a boolean expression that is a constant after specialisation.
fn constant_bool(
    expr: naga::Handle<naga::Expression>,
    expressions: &naga::Arena<naga::Expression>,
    module_constants: &naga::Arena<naga::Constant>,
    globals: &naga::Arena<naga::Expression>,
) -> Option<bool> {
    let literal = |e: &naga::Expression| match e {
        naga::Expression::Literal(naga::Literal::Bool(b)) => Some(*b),
        _ => None,
    };
    match &expressions[expr] {
        naga::Expression::Constant(c) => literal(&globals[module_constants[*c].init]),
        e => literal(e),
    }
}

/// Replaces `if c { A } else { B }` by `A` or `B` wherever `c` is a constant, in every function: the code of
/// an absent feature is gone from the module before it is written as SPIR-V, so no driver ever compiles it.
pub fn prune_constant_ifs(module: &mut naga::Module) {
    fn prune(
        block: naga::Block,
        is_const: &dyn Fn(naga::Handle<naga::Expression>) -> Option<bool>,
    ) -> naga::Block {
        use naga::Statement as S;
        let mut out = naga::Block::with_capacity(block.len());
        for (statement, span) in block.span_into_iter() {
            let statement = match statement {
                S::If {
                    condition,
                    accept,
                    reject,
                } => match is_const(condition) {
                    Some(true) => S::Block(prune(accept, is_const)),
                    Some(false) => S::Block(prune(reject, is_const)),
                    None => S::If {
                        condition,
                        accept: prune(accept, is_const),
                        reject: prune(reject, is_const),
                    },
                },
                S::Block(b) => S::Block(prune(b, is_const)),
                S::Loop {
                    body,
                    continuing,
                    break_if,
                } => S::Loop {
                    body: prune(body, is_const),
                    continuing: prune(continuing, is_const),
                    break_if,
                },
                S::Switch { selector, cases } => S::Switch {
                    selector,
                    cases: cases
                        .into_iter()
                        .map(|c| naga::SwitchCase {
                            body: prune(c.body, is_const),
                            ..c
                        })
                        .collect(),
                },
                other => other,
            };
            out.push(statement, span);
        }
        out
    }
    let constants = &module.constants;
    let globals = &module.global_expressions;
    let functions = module
        .functions
        .iter_mut()
        .map(|(_, f)| f)
        .chain(module.entry_points.iter_mut().map(|e| &mut e.function));
    for f in functions {
        let expressions = &f.expressions;
        let is_const = |e| constant_bool(e, expressions, constants, globals);
        let body = std::mem::take(&mut f.body);
        f.body = prune(body, &is_const);
        // `let` names of expressions that only the removed code evaluated must go too, or compaction
        // would keep them (and whatever they refer to, such as a removed function's call result).
        let mut live = std::collections::HashSet::new();
        collect_evaluated(&f.body, &mut live);
        let expressions = &f.expressions;
        f.named_expressions
            .retain(|h, _| live.contains(h) || expressions[*h].needs_pre_emit());
    }
}

/// The expressions a block evaluates: those its `Emit` statements cover and its calls' results.
fn collect_evaluated(
    block: &naga::Block,
    live: &mut std::collections::HashSet<naga::Handle<naga::Expression>>,
) {
    use naga::Statement as S;
    for statement in block.iter() {
        match statement {
            S::Emit(range) => live.extend(range.clone()),
            S::Call {
                result: Some(r), ..
            } => {
                live.insert(*r);
            }
            S::Block(b) => collect_evaluated(b, live),
            S::If { accept, reject, .. } => {
                collect_evaluated(accept, live);
                collect_evaluated(reject, live);
            }
            S::Loop {
                body, continuing, ..
            } => {
                collect_evaluated(body, live);
                collect_evaluated(continuing, live);
            }
            S::Switch { cases, .. } => cases.iter().for_each(|c| collect_evaluated(&c.body, live)),
            _ => {}
        }
    }
}
