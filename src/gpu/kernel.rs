//! A compute kernel: pipeline + descriptor set whose layout is reflected from the shader, and a way to
//! run it and wait.

use super::image::{DATA_IMAGE_WIDTH, DataImage};
use super::{Buffer, GpuContext, GpuError};
use crate::kernel::specialise::{BindingInfo, BufferKind, CompiledShader};
use ash::vk;
use std::sync::Arc;

pub struct Kernel {
    ctx: Arc<GpuContext>,
    bindings: Vec<BindingInfo>,
    workgroup_size: [u32; 3],
    /// The context's pipeline for this SPIR-V (owned by the context, not destroyed with the kernel).
    pipeline: Pipeline,
    pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
    command_pool: vk::CommandPool,
    command_buffer: vk::CommandBuffer,
    fence: vk::Fence,
}

/// A compiled compute pipeline with its layouts. The context keeps one per SPIR-V module
/// (`GpuContext::pipelines`) and destroys them when it drops: a driver's compile of the render kernel
/// takes seconds (lavapipe runs LLVM over it), and the renderers of one feature set that a process makes on
/// one context (the tests make many) then compile it once. Every
/// kernel of the module shares the pipeline and has its own descriptor set, so they can run at once.
#[derive(Clone, Copy)]
pub(crate) struct Pipeline {
    set_layout: vk::DescriptorSetLayout,
    pipeline_layout: vk::PipelineLayout,
    pipeline: vk::Pipeline,
}

impl Pipeline {
    const NULL: Pipeline = Pipeline {
        set_layout: vk::DescriptorSetLayout::null(),
        pipeline_layout: vk::PipelineLayout::null(),
        pipeline: vk::Pipeline::null(),
    };

    /// The context's pipeline for `shader`, compiled on first use.
    fn of(ctx: &GpuContext, shader: &CompiledShader) -> Result<Pipeline, GpuError> {
        let known = |ctx: &GpuContext| {
            ctx.pipelines
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .get(&shader.spirv)
                .copied()
        };
        if let Some(p) = known(ctx) {
            return Ok(p);
        }
        // Compiled without holding the lock (other kernels go on being made); if another thread
        // compiled the same module meanwhile, its pipeline is kept and this one destroyed.
        let mut made = Pipeline::NULL;
        if let Err(e) = made.compile(ctx, shader) {
            made.destroy(&ctx.device);
            return Err(e);
        }
        let mut pipelines = ctx.pipelines.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(p) = pipelines.get(&shader.spirv) {
            made.destroy(&ctx.device);
            return Ok(*p);
        }
        pipelines.insert(shader.spirv.clone(), made);
        Ok(made)
    }

    /// Creates the layouts (reflected bindings, one set) and the pipeline into `self`, whose handles stay
    /// null from the first failure on.
    fn compile(&mut self, ctx: &GpuContext, shader: &CompiledShader) -> Result<(), GpuError> {
        let device = &ctx.device;
        let layout_bindings: Vec<vk::DescriptorSetLayoutBinding> = shader
            .bindings
            .iter()
            .map(|b| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(b.binding)
                    .descriptor_type(descriptor_type(b.kind))
                    .descriptor_count(1)
                    .stage_flags(vk::ShaderStageFlags::COMPUTE)
            })
            .collect();
        // SAFETY (whole block): plain object creation with create-infos that outlive each call.
        unsafe {
            self.set_layout = device
                .create_descriptor_set_layout(
                    &vk::DescriptorSetLayoutCreateInfo::default().bindings(&layout_bindings),
                    None,
                )
                .map_err(|e| GpuError::vk("vkCreateDescriptorSetLayout", e))?;
            let set_layouts = [self.set_layout];
            self.pipeline_layout = device
                .create_pipeline_layout(
                    &vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts),
                    None,
                )
                .map_err(|e| GpuError::vk("vkCreatePipelineLayout", e))?;
            let module = device
                .create_shader_module(
                    &vk::ShaderModuleCreateInfo::default().code(&shader.spirv),
                    None,
                )
                .map_err(|e| GpuError::vk("vkCreateShaderModule", e))?;
            let stage = vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::COMPUTE)
                .module(module)
                .name(c"main");
            let info = vk::ComputePipelineCreateInfo::default()
                .stage(stage)
                .layout(self.pipeline_layout);
            let pipelines = device.create_compute_pipelines(ctx.pipeline_cache, &[info], None);
            device.destroy_shader_module(module, None);
            self.pipeline =
                pipelines.map_err(|(_, e)| GpuError::vk("vkCreateComputePipelines", e))?[0];
        }
        Ok(())
    }

    /// Destroys the handles (null ones are ignored). Only when no kernel uses them any more: the
    /// context's drop, or a pipeline that was never shared.
    pub(crate) fn destroy(&self, device: &ash::Device) {
        // SAFETY: see above; the caller guarantees nothing in flight uses the pipeline.
        unsafe {
            device.destroy_pipeline(self.pipeline, None);
            device.destroy_pipeline_layout(self.pipeline_layout, None);
            device.destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}

impl Kernel {
    pub fn new(ctx: &Arc<GpuContext>, shader: &CompiledShader) -> Result<Kernel, GpuError> {
        // Build into a Kernel with null handles first, so that Drop cleans up whatever a failure leaves.
        let mut k = Kernel {
            ctx: ctx.clone(),
            bindings: shader.bindings.clone(),
            workgroup_size: shader.workgroup_size,
            pipeline: Pipeline::of(ctx, shader)?,
            pool: vk::DescriptorPool::null(),
            set: vk::DescriptorSet::null(),
            command_pool: vk::CommandPool::null(),
            command_buffer: vk::CommandBuffer::null(),
            fence: vk::Fence::null(),
        };
        let device = &ctx.device;
        let set_layouts = [k.pipeline.set_layout];
        // SAFETY (whole block): plain object creation with create-infos that outlive each call.
        unsafe {
            let uniform_count = shader
                .bindings
                .iter()
                .filter(|b| b.kind == BufferKind::Uniform)
                .count() as u32;
            let image_count = shader
                .bindings
                .iter()
                .filter(|b| b.kind == BufferKind::SampledImage)
                .count() as u32;
            let storage_count = shader.bindings.len() as u32 - uniform_count - image_count;
            let mut sizes = Vec::new();
            if uniform_count > 0 {
                sizes.push(vk::DescriptorPoolSize {
                    ty: vk::DescriptorType::UNIFORM_BUFFER,
                    descriptor_count: uniform_count,
                });
            }
            if storage_count > 0 {
                sizes.push(vk::DescriptorPoolSize {
                    ty: vk::DescriptorType::STORAGE_BUFFER,
                    descriptor_count: storage_count,
                });
            }
            if image_count > 0 {
                sizes.push(vk::DescriptorPoolSize {
                    ty: vk::DescriptorType::SAMPLED_IMAGE,
                    descriptor_count: image_count,
                });
            }
            k.pool = device
                .create_descriptor_pool(
                    &vk::DescriptorPoolCreateInfo::default()
                        .max_sets(1)
                        .pool_sizes(&sizes),
                    None,
                )
                .map_err(|e| GpuError::vk("vkCreateDescriptorPool", e))?;
            k.set = device
                .allocate_descriptor_sets(
                    &vk::DescriptorSetAllocateInfo::default()
                        .descriptor_pool(k.pool)
                        .set_layouts(&set_layouts),
                )
                .map_err(|e| GpuError::vk("vkAllocateDescriptorSets", e))?[0];
            // Re-recorded for every submit (see `submit`).
            (k.command_pool, k.command_buffer) = ctx.create_command_buffer()?;
            k.fence = device
                .create_fence(&vk::FenceCreateInfo::default(), None)
                .map_err(|e| GpuError::vk("vkCreateFence", e))?;
        }
        Ok(k)
    }

    /// The bindings this kernel expects, in binding order.
    pub fn bindings(&self) -> &[BindingInfo] {
        &self.bindings
    }

    /// Whether the (specialised, compacted) shader still uses the buffer named `name` (the variable's
    /// name in the WGSL).
    pub fn uses(&self, name: &str) -> bool {
        self.bindings.iter().any(|b| b.name == name)
    }

    /// Points the descriptor set at the buffers given as (WGSL variable name, buffer). Every binding the
    /// shader uses must be given; names it does not use (compacted away by specialisation) are skipped.
    pub fn bind(&mut self, buffers: &[(&str, &Buffer)]) -> Result<(), GpuError> {
        self.bind_with_images(buffers, &[])
    }

    /// [`Kernel::bind`] with data images too, given as (WGSL variable name, image) for the shader's
    /// `texture_2d<u32>` bindings.
    pub fn bind_with_images(
        &mut self,
        buffers: &[(&str, &Buffer)],
        images: &[(&str, &DataImage)],
    ) -> Result<(), GpuError> {
        let missing = |b: &BindingInfo, what: &str| {
            GpuError::Usage(format!(
                "no {what} given for `{}` (binding {})",
                b.name, b.binding
            ))
        };
        let mut buffer_infos = Vec::with_capacity(self.bindings.len());
        let mut image_infos = Vec::new();
        for b in &self.bindings {
            if b.kind == BufferKind::SampledImage {
                let image = images
                    .iter()
                    .find(|(n, _)| *n == b.name)
                    .ok_or_else(|| missing(b, "image"))?;
                image_infos.push([vk::DescriptorImageInfo {
                    sampler: vk::Sampler::null(),
                    image_view: image.1.view,
                    image_layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
                }]);
            } else {
                let buffer = buffers
                    .iter()
                    .find(|(n, _)| *n == b.name)
                    .ok_or_else(|| missing(b, "buffer"))?;
                buffer_infos.push([vk::DescriptorBufferInfo {
                    buffer: buffer.1.raw,
                    offset: 0,
                    range: vk::WHOLE_SIZE,
                }]);
            }
        }
        let (mut next_buffer, mut next_image) = (buffer_infos.iter(), image_infos.iter());
        let writes: Vec<vk::WriteDescriptorSet> = self
            .bindings
            .iter()
            .map(|b| {
                let write = vk::WriteDescriptorSet::default()
                    .dst_set(self.set)
                    .dst_binding(b.binding)
                    .descriptor_type(descriptor_type(b.kind));
                if b.kind == BufferKind::SampledImage {
                    write.image_info(next_image.next().expect("one image info per image binding"))
                } else {
                    write.buffer_info(
                        next_buffer
                            .next()
                            .expect("one buffer info per buffer binding"),
                    )
                }
            })
            .collect();
        // SAFETY: the set is not in use by the GPU (every submit waits for completion).
        unsafe { self.ctx.device.update_descriptor_sets(&writes, &[]) };
        Ok(())
    }

    /// Records `commands` into one command buffer, with a full memory barrier between consecutive
    /// commands (each may read what the previous wrote) and one to the host at the end; submits and waits.
    pub fn submit(&mut self, commands: &[Command<'_>]) -> Result<(), GpuError> {
        let max = self.ctx.limits.max_compute_work_group_count;
        for c in commands {
            if let Command::Dispatch { invocations } = c {
                let groups = self.groups(*invocations);
                if groups.iter().zip(max.iter()).any(|(g, m)| g > m) {
                    return Err(GpuError::Usage(format!(
                        "dispatch of {groups:?} workgroups exceeds the device limit {max:?}"
                    )));
                }
            }
        }
        let device = &self.ctx.device;
        let cb = self.command_buffer;
        let all_access = vk::AccessFlags::SHADER_READ
            | vk::AccessFlags::SHADER_WRITE
            | vk::AccessFlags::TRANSFER_READ
            | vk::AccessFlags::TRANSFER_WRITE;
        let stages = vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER;
        // SAFETY: the command buffer is idle (we wait below after every submit); handles are valid.
        unsafe {
            device
                .reset_command_buffer(cb, vk::CommandBufferResetFlags::empty())
                .map_err(|e| GpuError::vk("vkResetCommandBuffer", e))?;
            device
                .begin_command_buffer(
                    cb,
                    &vk::CommandBufferBeginInfo::default()
                        .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                )
                .map_err(|e| GpuError::vk("vkBeginCommandBuffer", e))?;
            device.cmd_bind_pipeline(cb, vk::PipelineBindPoint::COMPUTE, self.pipeline.pipeline);
            device.cmd_bind_descriptor_sets(
                cb,
                vk::PipelineBindPoint::COMPUTE,
                self.pipeline.pipeline_layout,
                0,
                &[self.set],
                &[],
            );
            for (i, c) in commands.iter().enumerate() {
                if i > 0 {
                    let barrier = vk::MemoryBarrier::default()
                        .src_access_mask(all_access)
                        .dst_access_mask(all_access);
                    device.cmd_pipeline_barrier(
                        cb,
                        stages,
                        stages,
                        vk::DependencyFlags::empty(),
                        &[barrier],
                        &[],
                        &[],
                    );
                }
                match c {
                    Command::Dispatch { invocations } => {
                        let groups = self.groups(*invocations);
                        if groups.iter().all(|&g| g > 0) {
                            device.cmd_dispatch(cb, groups[0], groups[1], groups[2]);
                        }
                    }
                    Command::Update(buffer, bytes) => {
                        device.cmd_update_buffer(cb, buffer.raw, 0, bytes)
                    }
                    Command::Zero(buffer) => {
                        device.cmd_fill_buffer(cb, buffer.raw, 0, vk::WHOLE_SIZE, 0)
                    }
                    Command::CopyToImage(src, image) => {
                        let to_transfer = layout_change(
                            image,
                            [vk::AccessFlags::empty(), vk::AccessFlags::TRANSFER_WRITE],
                            [
                                vk::ImageLayout::UNDEFINED,
                                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                            ],
                        );
                        device.cmd_pipeline_barrier(
                            cb,
                            vk::PipelineStageFlags::TOP_OF_PIPE,
                            vk::PipelineStageFlags::TRANSFER,
                            vk::DependencyFlags::empty(),
                            &[],
                            &[],
                            &[to_transfer],
                        );
                        let region = vk::BufferImageCopy::default()
                            .image_subresource(vk::ImageSubresourceLayers {
                                aspect_mask: vk::ImageAspectFlags::COLOR,
                                mip_level: 0,
                                base_array_layer: 0,
                                layer_count: 1,
                            })
                            .image_extent(vk::Extent3D {
                                width: DATA_IMAGE_WIDTH,
                                height: image.rows(),
                                depth: 1,
                            });
                        device.cmd_copy_buffer_to_image(
                            cb,
                            src.raw,
                            image.raw,
                            vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                            &[region],
                        );
                        let to_read = layout_change(
                            image,
                            [
                                vk::AccessFlags::TRANSFER_WRITE,
                                vk::AccessFlags::SHADER_READ,
                            ],
                            [
                                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                                vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
                            ],
                        );
                        device.cmd_pipeline_barrier(
                            cb,
                            vk::PipelineStageFlags::TRANSFER,
                            vk::PipelineStageFlags::COMPUTE_SHADER,
                            vk::DependencyFlags::empty(),
                            &[],
                            &[],
                            &[to_read],
                        );
                    }
                    Command::Copy(src, dst) => {
                        let size = src.size().min(dst.size());
                        device.cmd_copy_buffer(
                            cb,
                            src.raw,
                            dst.raw,
                            &[vk::BufferCopy {
                                src_offset: 0,
                                dst_offset: 0,
                                size,
                            }],
                        );
                    }
                }
            }
            // Make all writes visible to the host once the fence signals.
            let barrier = vk::MemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::SHADER_WRITE | vk::AccessFlags::TRANSFER_WRITE)
                .dst_access_mask(vk::AccessFlags::HOST_READ);
            device.cmd_pipeline_barrier(
                cb,
                stages,
                vk::PipelineStageFlags::HOST,
                vk::DependencyFlags::empty(),
                &[barrier],
                &[],
                &[],
            );
            device
                .end_command_buffer(cb)
                .map_err(|e| GpuError::vk("vkEndCommandBuffer", e))?;
            let cbs = [cb];
            let submit = vk::SubmitInfo::default().command_buffers(&cbs);
            {
                let queue = self.ctx.queue.lock().unwrap_or_else(|p| p.into_inner());
                device
                    .queue_submit(*queue, &[submit], self.fence)
                    .map_err(|e| GpuError::vk("vkQueueSubmit", e))?;
            }
            device
                .wait_for_fences(&[self.fence], true, u64::MAX)
                .map_err(|e| GpuError::vk("vkWaitForFences", e))?;
            device
                .reset_fences(&[self.fence])
                .map_err(|e| GpuError::vk("vkResetFences", e))?;
        }
        Ok(())
    }

    fn groups(&self, invocations: [u32; 3]) -> [u32; 3] {
        [0, 1, 2].map(|i| invocations[i].div_ceil(self.workgroup_size[i].max(1)))
    }
}

/// One step of a [`Kernel::submit`].
pub enum Command<'a> {
    /// Run the kernel over `invocations` (x, y, z).
    Dispatch { invocations: [u32; 3] },
    /// Write up to 64 KiB of bytes at the start of a buffer (created with TRANSFER_DST usage), in order
    /// with the other commands.
    Update(&'a Buffer, &'a [u8]),
    /// Fill a buffer with zeros.
    Zero(&'a Buffer),
    /// Copy the start of one buffer into another.
    Copy(&'a Buffer, &'a Buffer),
    /// Copy a buffer into a whole data image (as many bytes as the image holds), leaving the image ready
    /// for the kernel's reads (SHADER_READ_ONLY_OPTIMAL).
    CopyToImage(&'a Buffer, &'a DataImage),
}

impl Drop for Kernel {
    fn drop(&mut self) {
        let d = &self.ctx.device;
        // SAFETY: `run` waits for completion, so nothing of ours is in flight; null handles are ignored.
        unsafe {
            d.destroy_fence(self.fence, None);
            d.destroy_command_pool(self.command_pool, None);
            d.destroy_descriptor_pool(self.pool, None);
        }
    }
}

/// A barrier that moves a whole data image from one layout to another, the writes of `access[0]` made
/// visible to the accesses of `access[1]`.
fn layout_change(
    image: &DataImage,
    access: [vk::AccessFlags; 2],
    layouts: [vk::ImageLayout; 2],
) -> vk::ImageMemoryBarrier<'static> {
    vk::ImageMemoryBarrier::default()
        .src_access_mask(access[0])
        .dst_access_mask(access[1])
        .old_layout(layouts[0])
        .new_layout(layouts[1])
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .image(image.raw)
        .subresource_range(DataImage::range())
}

fn descriptor_type(kind: BufferKind) -> vk::DescriptorType {
    match kind {
        BufferKind::Uniform => vk::DescriptorType::UNIFORM_BUFFER,
        BufferKind::Storage => vk::DescriptorType::STORAGE_BUFFER,
        BufferKind::SampledImage => vk::DescriptorType::SAMPLED_IMAGE,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::testing;
    use crate::kernel::{library, specialise};

    const DOUBLE: &str = "
@group(0) @binding(0) var<storage, read> input: array<u32>;
@group(0) @binding(1) var<storage, read_write> output: array<u32>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= arrayLength(&output) { return; }
    output[id.x] = 2u * input[id.x] + OFFSET;
}";

    fn compiled(offset: u32) -> CompiledShader {
        let text = format!("const OFFSET: u32 = {offset}u;\n{DOUBLE}");
        let source = library::assemble_text("test kernel", &text).unwrap();
        specialise::compile(&source).unwrap()
    }

    /// Binds `k` to its own buffers over `input`; returns them (input, output).
    fn bind(ctx: &Arc<GpuContext>, k: &mut Kernel, input: &[u32]) -> (Buffer, Buffer) {
        let i = Buffer::storage_from(ctx, "input", input).unwrap();
        let o = Buffer::readable_storage(ctx, "output", 4 * input.len() as u64).unwrap();
        k.bind(&[("input", &i), ("output", &o)]).unwrap();
        (i, o)
    }

    /// Runs `k` over `n` elements and reads its output buffer.
    fn run(k: &mut Kernel, (_, o): &(Buffer, Buffer), n: usize) -> Vec<u32> {
        k.submit(&[Command::Dispatch {
            invocations: [n as u32, 1, 1],
        }])
        .unwrap();
        bytemuck::pod_collect_to_vec(&o.read_bytes().unwrap()[..4 * n])
    }

    /// Kernels of one SPIR-V module share the context's pipeline, each with its own descriptor set (so
    /// each runs over its own buffers), the pipeline outlives the kernels, and another module gets its own.
    #[test]
    fn kernels_of_one_module_share_its_pipeline_and_keep_their_own_buffers() {
        let ctx = testing::context();
        let one = compiled(1);
        let mut a = Kernel::new(&ctx, &one).unwrap();
        let mut b = Kernel::new(&ctx, &one).unwrap();
        assert_eq!(a.pipeline.pipeline, b.pipeline.pipeline);
        assert_ne!(a.set, b.set);
        // Both bound before either runs: each runs over its own buffers.
        let buffers_a = bind(&ctx, &mut a, &[1, 2, 3]);
        let buffers_b = bind(&ctx, &mut b, &[10, 20]);
        assert_eq!(run(&mut b, &buffers_b, 2), [21, 41]);
        assert_eq!(run(&mut a, &buffers_a, 3), [3, 5, 7]);
        let shared = a.pipeline.pipeline;
        drop(a);
        drop(b);
        let mut c = Kernel::new(&ctx, &one).unwrap();
        assert_eq!(c.pipeline.pipeline, shared);
        let buffers_c = bind(&ctx, &mut c, &[5]);
        assert_eq!(run(&mut c, &buffers_c, 1), [11]);
        let mut other = Kernel::new(&ctx, &compiled(7)).unwrap();
        assert_ne!(other.pipeline.pipeline, shared);
        let buffers_other = bind(&ctx, &mut other, &[5]);
        assert_eq!(run(&mut other, &buffers_other, 1), [17]);
        let errors = ctx.validation_errors();
        assert!(errors.is_empty(), "validation errors: {errors:?}");
    }
}
