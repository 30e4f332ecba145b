//! Helpers shared by the integration tests: render a scene given as TOML text on the shared test context
//! (Khronos validation on) and check that the validation layer stayed silent.
#![allow(dead_code)]

pub mod stats;
pub mod vec;

use vkpath::gpu::testing;
use vkpath::render::{RenderOptions, Renderer};
use vkpath::{Film, Scene};

pub fn scene(toml: &str) -> Scene {
    Scene::from_toml_str(toml, None).unwrap_or_else(|e| panic!("test scene is invalid: {e}"))
}

/// Renders `scene` with `passes` passes of `spp_per_pass` samples.
pub fn render_passes(
    scene: &Scene,
    options: &RenderOptions,
    passes: u32,
    spp_per_pass: u32,
) -> Film {
    let ctx = testing::context();
    let mut r = Renderer::new(&ctx, scene, options).expect("renderer");
    for _ in 0..passes {
        r.run_pass(spp_per_pass).expect("pass");
    }
    let film = r.film().expect("film");
    assert_no_validation_errors();
    film
}

/// Renders with the scene's own sample count in one pass.
pub fn render(scene: &Scene) -> Film {
    render_passes(scene, &RenderOptions::default(), 1, scene.render.samples)
}

pub fn assert_no_validation_errors() {
    let errors = testing::context().validation_errors();
    assert!(errors.is_empty(), "Vulkan validation errors: {errors:#?}");
}
