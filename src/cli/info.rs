//! `vkpath info`: the Vulkan devices, the one vkpath would choose and why, and its limits.

use super::report::{InfoReport, print_json};
use vkpath::Error;
use vkpath::denoise::DeviceChoice;

/// `vkpath info`: the devices, the one chosen (by VKPATH_DEVICE, else by type) and why, and its limits;
/// or all of that as JSON.
pub fn run_info(json: bool) -> Result<i32, Error> {
    let devices = vkpath::gpu::context::list_devices()?;
    let substring = std::env::var("VKPATH_DEVICE")
        .ok()
        .filter(|s| !s.is_empty());
    let (chosen, reason) = vkpath::gpu::context::choose_device(&devices, substring.as_deref())?;
    let denoiser = vkpath::denoise::availability(DeviceChoice::for_vulkan(&devices[chosen]));
    if json {
        print_json(&InfoReport {
            devices: &devices,
            chosen,
            reason: &reason,
            denoiser: denoiser.as_deref().ok(),
            denoiser_missing: denoiser.as_ref().err().map(String::as_str),
        });
        return Ok(0);
    }
    for d in &devices {
        let mark = if d.index == chosen { "*" } else { " " };
        println!(
            "{mark} [{}] {} ({}, Vulkan {})",
            d.index, d.name, d.device_type, d.api_version
        );
    }
    let d = &devices[chosen];
    println!("chosen: [{}] {}, because {}", d.index, d.name, reason);
    if !d.driver.is_empty() {
        println!("driver: {}", d.driver);
    }
    if let Some(w) = d.old_lavapipe_warning() {
        eprintln!("vkpath: warning: {w}");
    }
    match &denoiser {
        Ok(what) => println!("denoising (--denoise): {what}"),
        Err(why) => println!("denoising (--denoise): not available: {why}"),
    }
    println!("limits:");
    println!(
        "  max compute workgroup count:       {:?}",
        d.max_compute_workgroup_count
    );
    println!(
        "  max compute workgroup invocations: {}",
        d.max_compute_workgroup_invocations
    );
    println!(
        "  max storage buffer range:          {} bytes",
        d.max_storage_buffer_range
    );
    println!(
        "  max uniform buffer range:          {} bytes{}",
        d.max_uniform_buffer_range,
        if vkpath::render::uniform_arrays_help(d) {
            " (a small scene's arrays are read from uniform buffers)"
        } else {
            ""
        }
    );
    println!(
        "  max image dimension 2D:            {} texels{}",
        d.max_image_dimension_2d,
        if vkpath::render::data_images_help(d) {
            " (meshes' BVH nodes and triangles are read from images)"
        } else {
            ""
        }
    );
    println!(
        "  max memory allocation size:        {} bytes",
        d.max_memory_allocation_size
    );
    println!(
        "  device-local memory:               {} bytes",
        d.device_local_memory_bytes
    );
    println!(
        "  buffer bounds checks:              {}",
        if d.robust_buffer_access {
            "robustBufferAccess (enabled)"
        } else {
            "none: the device lacks robustBufferAccess"
        }
    );
    Ok(0)
}
