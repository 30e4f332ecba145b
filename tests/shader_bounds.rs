//! Buffer indices past the end. The kernels' SPIR-V leaves buffer indices unchecked (naga's checks cost
//! 37-42 % on sphere scenes on lavapipe: docs/performance.md); the driver checks them instead: the device
//! is created with `robustBufferAccess` wherever it offers it (every Vulkan device must), so that a read
//! past the end of a storage buffer returns zero or a value of that buffer and a write goes nowhere,
//! instead of being undefined behaviour that can fault a GPU.
//!
//! What can fail here: the context must report the feature enabled. Lavapipe checks buffer bounds whether
//! asked or not, so on it the values read past the end show only that the kernel survives such reads; on a
//! GPU the same test checks the driver's guarantee.

mod common;

use vkpath::gpu::testing;

#[test]
fn buffer_reads_past_the_end_are_defined() {
    let ctx = testing::context();
    assert!(
        ctx.device_info().robust_buffer_access,
        "Vulkan requires every device to offer robustBufferAccess"
    );
    assert!(
        ctx.robust_buffer_access(),
        "the context must enable robustBufferAccess where the device offers it"
    );
    let n = 64u32;
    // Even invocations read just past the end, odd ones far past it (byte offsets beyond 2^32 / 4).
    let input: Vec<[u32; 4]> = (0..n)
        .map(|i| {
            let index = if i % 2 == 0 { n + i } else { u32::MAX / 16 + i };
            [index, 1000 + i, 0, 0]
        })
        .collect();
    let out: Vec<[u32; 4]> = testing::run_kernel(
        &ctx,
        include_str!("../shaders/tests/bounds.wgsl"),
        &input,
        input.len(),
    )
    .unwrap();
    for (i, o) in out.iter().enumerate() {
        let v = o[0];
        assert!(
            v == 0 || (1000..1000 + n).contains(&v),
            "invocation {i}: a read past the end gave {v}, neither zero nor a value of the buffer"
        );
    }
    common::assert_no_validation_errors();
}
