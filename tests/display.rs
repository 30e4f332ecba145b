//! `render.clamp` (the firefly clamp) and `render.tonemap` through the renderer.

mod common;

/// An emitter of radiance [10, 5, 2.5] filling the view: unclamped every pixel is exactly that; with
/// `clamp = 2` every sample is scaled so that its largest channel is 2, keeping its hue: [2, 1, 0.5].
/// The clamp is part of the render's identity (a checkpoint of one does not resume the other) and the
/// tonemap is not (it only changes the PNG).
#[test]
fn the_firefly_clamp_scales_each_sample_down_to_it() {
    let scene = |render_extra: &str| {
        common::scene(&format!(
            "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nfov = 20\n[image]\nwidth = 8\nheight = 8\n\
             [render]\nsamples = 4\nfilter = \"box\"\n{render_extra}\n[materials]\n\
             lamp = {{ type = \"emitter\", radiance = [10.0, 5.0, 2.5] }}\n\
             [[sphere]]\ncenter = [0, 0, 0]\nradius = 3\nmaterial = \"lamp\"\n"
        ))
    };
    for (extra, want) in [
        ("", [10.0, 5.0, 2.5]),
        ("clamp = 2.0", [2.0, 1.0, 0.5]),
        ("clamp = 20.0", [10.0, 5.0, 2.5]),
    ] {
        let film = common::render(&scene(extra));
        for p in &film.mean {
            for (got, w) in p.iter().zip(want) {
                assert!((got - w).abs() <= 1e-6 * w, "{extra:?}: {p:?} vs {want:?}");
            }
        }
    }
    use vkpath::kernel::upload::{GpuScene, params_for};
    use vkpath::render::identity::content_hash;
    let hash = |s: &vkpath::Scene| content_hash(s, &GpuScene::build(s), &params_for(s, 3));
    let plain = scene("");
    assert_ne!(hash(&plain), hash(&scene("clamp = 2.0")));
    assert_eq!(hash(&plain), hash(&scene("tonemap = \"aces\"")));
}
