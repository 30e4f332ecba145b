//! Compiling an assembled kernel to SPIR-V with naga, specialised for a feature set.
//!
//! naga's `process_overrides` folds the `override` constants (features.wgsl) to the values the feature
//! set gives; [`prune_constant_ifs`] then removes every `if` whose condition became a constant, and
//! compaction drops whatever only the removed code used (functions, buffers), so the SPIR-V of a scene has
//! no code and no bindings for the features it lacks. Nothing here speaks Vulkan: the reflected bindings
//! say what kind of buffer each is, and `gpu::kernel` makes the descriptors.

use super::KernelError as GpuError;

/// What kind of buffer a binding is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BufferKind {
    Uniform,
    Storage,
    /// A `texture_2d<u32>` read with `textureLoad`: a data image (`gpu::image`).
    SampledImage,
}

/// One resource binding of a compiled shader, reflected from the WGSL: its number, the name of its
/// variable (which the host binds buffers by) and its kind.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BindingInfo {
    pub binding: u32,
    pub name: String,
    pub kind: BufferKind,
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

/// What the kernels may use beyond WGSL's core: `unpack2x16float` (f16 texels of EXR and HDR textures,
/// texture.wgsl), which naga gates behind this capability for the backends that lack it; in SPIR-V it is
/// GLSL.std.450's UnpackHalf2x16, which every Vulkan implementation has.
pub const CAPABILITIES: naga::valid::Capabilities =
    naga::valid::Capabilities::SHADER_FLOAT16_IN_FLOAT32;

fn validate(module: &naga::Module) -> Result<naga::valid::ModuleInfo, GpuError> {
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), CAPABILITIES)
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
        let kind = match var.space {
            naga::AddressSpace::Uniform => BufferKind::Uniform,
            naga::AddressSpace::Storage { .. } => BufferKind::Storage,
            naga::AddressSpace::Handle => BufferKind::SampledImage,
            other => {
                return Err(GpuError::Shader(format!(
                    "unsupported binding address space {other:?}"
                )));
            }
        };
        bindings.push(BindingInfo {
            binding: rb.binding,
            name: var.name.clone().unwrap_or_default(),
            kind,
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::features::FeatureSet;
    use crate::kernel::library;

    #[test]
    fn production_and_benchmark_kernels_compile() {
        compile(&library::trace_source()).unwrap_or_else(|e| panic!("{e}"));
        compile(&library::trimmed_source()).unwrap_or_else(|e| panic!("{e}"));
        // Specialised with every feature off: everything prunes, and what is left still validates.
        let mut none = FeatureSet::generic();
        for row in crate::kernel::features::features() {
            none.set(row.feature, false);
        }
        compile_with(&library::trace_source(), &none.pipeline_constants())
            .unwrap_or_else(|e| panic!("{e}"));
    }
}
