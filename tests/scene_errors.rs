//! Every way a scene file can be wrong, one test each: the error must name the file, the exact line and
//! the key, fit in one paragraph, and never come from a panic.
//!
//! Scene texts put `# line N` comments on the offending line so the expected numbers can be checked by
//! eye.

use std::path::Path;
use vkpath::scene::{Scene, SceneError};

/// Lines 1-8 of most test scenes: a valid camera and two materials. Text appended to it starts at
/// line 9.
const BASE: &str = r#"[camera]
position = [0, 0, 10]
look_at  = [0, 0, 0]
fov      = 60

[materials]
white = { type = "diffuse", albedo = [0.8, 0.8, 0.8] }
glass = { type = "dielectric", ior = 1.5 }
"#;

fn with_base(rest: &str) -> String {
    format!("{BASE}{rest}")
}

/// Parses `text` as `bad.toml`, expects an error at `line` whose key contains `key`, and checks the
/// message's shape. Returns the error for further checks.
#[track_caller]
fn expect_error(text: &str, line: usize, key: &str) -> SceneError {
    let err = match Scene::from_toml_str(text, Some(Path::new("bad.toml"))) {
        Ok(_) => panic!("expected an error at line {line}, key {key}, but the scene parsed"),
        Err(err) => err,
    };
    let message = err.to_string();
    assert_eq!(err.file(), "bad.toml", "{message}");
    assert_eq!(err.line(), Some(line), "{message}");
    assert!(
        err.key().is_some_and(|k| k.contains(key)),
        "key {:?} should contain {key:?}: {message}",
        err.key()
    );
    assert!(message.contains("bad.toml"), "{message}");
    assert!(message.contains(&format!("line {line}")), "{message}");
    assert!(message.contains(key), "{message}");
    assert!(
        !message.contains('\n'),
        "the message must be one paragraph: {message:?}"
    );
    err
}

/// Like [`expect_error`], and the key must be exactly `key`.
#[track_caller]
fn expect_error_exact(text: &str, line: usize, key: &str) -> SceneError {
    let err = expect_error(text, line, key);
    assert_eq!(err.key(), Some(key), "{err}");
    err
}

#[test]
fn the_base_scene_is_valid() {
    // Guards the other tests: each of them breaks exactly one thing.
    let scene = Scene::from_toml_str(&with_base(""), Some(Path::new("ok.toml"))).expect("valid");
    assert_eq!(scene.material_names, ["white", "glass"]);
}

#[test]
fn display_has_the_documented_shape() {
    let err = expect_error_exact(
        &with_base(
            "[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"white\"\n[[sphere]]\ncenter = [0, 0, 0]\nradius = -2\nmaterial = \"white\"\n",
        ),
        15,
        "sphere[1].radius",
    );
    assert!(
        err.to_string().starts_with(
            "bad.toml, line 15, key sphere[1].radius: the radius must be > 0, got -2. "
        ),
        "{err}"
    );
}

// ----- the file itself -----

#[test]
fn invalid_toml() {
    let text = "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 60 60\n";
    let err = expect_error_exact(text, 4, "camera.fov");
    assert!(err.to_string().contains("not valid TOML"), "{err}");
}

#[test]
fn invalid_toml_unclosed_array() {
    let text = with_base("[[sphere]]\ncenter = [0, 0, 0\nradius = 1\n");
    // The parser notices the missing `]` on the line after the array started.
    let err = Scene::from_toml_str(&text, Some(Path::new("bad.toml"))).expect_err("not TOML");
    let line = err.line().expect("a line");
    assert!((10..=11).contains(&line), "{err}");
    assert!(
        err.to_string().contains(&format!("bad.toml, line {line}")),
        "{err}"
    );
}

#[test]
fn duplicate_key_is_invalid_toml() {
    let text = "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 60\nfov = 50\n";
    expect_error_exact(text, 5, "camera.fov");
}

#[test]
fn duplicate_table_is_invalid_toml() {
    let text = with_base("\n[camera]   # line 10\nfov = 50\n");
    expect_error_exact(&text, 10, "camera");
}

#[test]
fn load_of_a_missing_file_names_the_file() {
    let path = Path::new("/nonexistent/dir/no-such-scene.toml");
    let err = Scene::load(path).expect_err("the file does not exist");
    assert_eq!(err.file(), path.display().to_string());
    assert_eq!(err.line(), None);
    let message = err.to_string();
    assert!(message.contains("no-such-scene.toml"), "{message}");
    assert!(!message.contains('\n'), "{message:?}");
}

// ----- missing and unknown keys -----

#[test]
fn missing_camera_table() {
    let text = "[image]\nwidth = 64\n";
    // The document root lacks it; its "table" starts at line 1.
    let err = expect_error_exact(text, 1, "camera");
    assert!(err.to_string().contains("missing"), "{err}");
}

#[test]
fn missing_camera_key() {
    let text = "\n[camera]   # line 2\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\n";
    let err = expect_error_exact(text, 2, "camera.fov");
    assert!(err.to_string().contains("missing"), "{err}");
}

#[test]
fn missing_sphere_key_names_the_sphere_and_its_table() {
    let text = with_base(
        r#"[[sphere]]
center = [0, 0, 0]
radius = 1
material = "white"
[[sphere]]          # line 13
center = [0, 0, 0]
material = "white"
"#,
    );
    expect_error_exact(&text, 13, "sphere[1].radius");
}

#[test]
fn missing_light_power() {
    let text = with_base("[[light]]  # line 9\ntype = \"point\"\nposition = [0, 5, 0]\n");
    expect_error_exact(&text, 9, "light[0].power");
}

#[test]
fn missing_point_light_position() {
    let text = with_base("[[light]]  # line 9\ntype = \"point\"\npower = 10\n");
    expect_error_exact(&text, 9, "light[0].position");
}

#[test]
fn missing_sphere_light_radius() {
    let text =
        with_base("[[light]]  # line 9\ntype = \"sphere\"\ncenter = [0, 5, 0]\npower = 10\n");
    expect_error_exact(&text, 9, "light[0].radius");
}

#[test]
fn missing_diffuse_albedo() {
    let text = with_base("[materials.chalk]  # line 9\ntype = \"diffuse\"\n");
    expect_error_exact(&text, 9, "materials.chalk.albedo");
}

#[test]
fn missing_dielectric_ior() {
    let text = "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 60\n[materials]\nwater = { type = \"dielectric\" }  # line 6\n";
    expect_error_exact(text, 6, "materials.water.ior");
}

#[test]
fn unknown_key_at_top_level() {
    // Before any table header: after `[materials]` it would be read as a material.
    let text = format!("title = \"my scene\"   # line 1\n{BASE}");
    let err = expect_error_exact(&text, 1, "title");
    assert!(err.to_string().contains("unknown key"), "{err}");
}

#[test]
fn unknown_table_at_top_level() {
    let text = with_base("\n[imag]  # line 10\nwidth = 64\n");
    expect_error_exact(&text, 10, "imag");
}

#[test]
fn unknown_key_inside_a_table() {
    let text =
        "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 60\nzoom = 2  # line 5\n";
    let err = expect_error_exact(text, 5, "camera.zoom");
    assert!(err.to_string().contains("unknown key `zoom`"), "{err}");
}

#[test]
fn unknown_key_inside_an_array_of_tables() {
    let text = with_base(
        r#"[[sphere]]
center = [0, 0, 0]
radius = 1
material = "white"

[[sphere]]
center = [0, 0, 0]
radius = 1
colour = "red"       # line 17
material = "white"
"#,
    );
    expect_error_exact(&text, 17, "sphere[1].colour");
}

#[test]
fn unknown_key_inside_a_material() {
    let text = "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 60\n\n[materials]\nred = { type = \"diffuse\", albedo = [1, 0, 0], roughness = 0.5 }  # line 7\n";
    expect_error_exact(text, 7, "materials.red.roughness");
}

#[test]
fn key_of_another_material_type_is_rejected() {
    let text = "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 60\n\n[materials]\nred = { type = \"diffuse\", albedo = [1, 0, 0], ior = 1.5 }  # line 7\n";
    expect_error_exact(text, 7, "materials.red.ior");
}

#[test]
fn microfacet_distribution_is_ggx_or_beckmann_on_microfacet_materials_only() {
    let text = "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 60\n\n[materials]\nau = { type = \"conductor\", preset = \"gold\", roughness = 0.3, distribution = \"phong\" }  # line 7\n";
    let err = expect_error_exact(text, 7, "materials.au.distribution");
    assert!(err.to_string().contains("beckmann"), "{err}");
    let text = "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 60\n\n[materials]\nred = { type = \"diffuse\", albedo = [1, 0, 0], distribution = \"beckmann\" }  # line 7\n";
    expect_error_exact(text, 7, "materials.red.distribution");
}

#[test]
fn key_of_another_light_type_is_rejected() {
    let text = with_base(
        "[[light]]\ntype = \"point\"\nposition = [0, 5, 0]\nradius = 2   # line 12\npower = 10\n",
    );
    expect_error_exact(&text, 12, "light[0].radius");
}

// ----- types and shapes -----

#[test]
fn wrong_type() {
    let text = with_base(
        "[[sphere]]\ncenter = [0, 0, 0]\nradius = \"big\"   # line 11\nmaterial = \"white\"\n",
    );
    expect_error_exact(&text, 11, "sphere[0].radius");
}

#[test]
fn vector_with_two_numbers() {
    let text =
        with_base("[[sphere]]\ncenter = [0, 0]   # line 10\nradius = 1\nmaterial = \"white\"\n");
    let err = expect_error_exact(&text, 10, "sphere[0].center");
    assert!(err.to_string().contains("3 numbers"), "{err}");
}

#[test]
fn vector_with_four_numbers() {
    let text = "[camera]\nposition = [0, 0, 10, 1]   # line 2\nlook_at = [0, 0, 0]\nfov = 60\n";
    expect_error_exact(text, 2, "camera.position");
}

#[test]
fn triangle_with_two_vertices() {
    let text = with_base(
        "[[triangle]]\nvertices = [[0, 0, 0], [1, 0, 0]]   # line 10\nmaterial = \"white\"\n",
    );
    expect_error_exact(&text, 10, "triangle[0].vertices");
}

#[test]
fn unknown_material_type() {
    let text = "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 60\n[materials]\nshiny = { type = \"metal\" }  # line 6\n";
    let err = expect_error_exact(text, 6, "materials.shiny.type");
    assert!(err.to_string().contains("\"metal\""), "{err}");
}

#[test]
fn unknown_light_type() {
    let text =
        with_base("[[light]]\ntype = \"area\"  # line 10\nposition = [0, 5, 0]\npower = 10\n");
    expect_error_exact(&text, 10, "light[0].type");
}

// ----- materials by name -----

#[test]
fn undefined_material() {
    let text = with_base(
        r#"[[sphere]]
center = [0, 0, 0]
radius = 1
material = "white"

[[sphere]]
center = [0, 0, 0]
radius = 1
material = "gold"   # line 17
"#,
    );
    let err = expect_error_exact(&text, 17, "sphere[1].material");
    let message = err.to_string();
    assert!(message.contains("\"gold\""), "{message}");
    // The message lists what is defined, in file order.
    assert!(message.contains("\"white\", \"glass\""), "{message}");
}

#[test]
fn undefined_material_on_a_triangle() {
    let text = with_base(
        "[[triangle]]\nvertices = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]\nmaterial = \"Glass\"  # line 11\n",
    );
    expect_error_exact(&text, 11, "triangle[0].material");
}

// ----- numbers -----

#[test]
fn nan_value() {
    let text = with_base(
        "[[sphere]]\ncenter = [0, 0, 0]\nradius = nan   # line 11\nmaterial = \"white\"\n",
    );
    let err = expect_error_exact(&text, 11, "sphere[0].radius");
    assert!(err.to_string().contains("finite"), "{err}");
}

#[test]
fn inf_value_in_a_vector() {
    let text = "[camera]\nposition = [0, inf, 10]   # line 2\nlook_at = [0, 0, 0]\nfov = 60\n";
    expect_error_exact(text, 2, "camera.position");
}

#[test]
fn negative_inf_power() {
    let text =
        with_base("[[light]]\ntype = \"point\"\nposition = [0, 5, 0]\npower = -inf  # line 12\n");
    expect_error_exact(&text, 12, "light[0].power");
}

#[test]
fn number_beyond_f32_range_is_not_finite() {
    let text = "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 60\n[image]\nexposure = 1e39   # line 6\n";
    let err = expect_error_exact(text, 6, "image.exposure");
    assert!(err.to_string().contains("finite"), "{err}");
}

#[test]
fn nan_in_a_material() {
    let text = "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 60\n[materials]\ng = { type = \"dielectric\", ior = nan }  # line 6\n";
    expect_error_exact(text, 6, "materials.g.ior");
}

#[test]
fn non_finite_triangle_vertex() {
    let text = with_base(
        "[[triangle]]\nvertices = [[0, 0, 0], [1, nan, 0], [0, 1, 0]]   # line 10\nmaterial = \"white\"\n",
    );
    expect_error(&text, 10, "triangle[0].vertices");
}

#[test]
fn radius_zero() {
    let text =
        with_base("[[sphere]]\ncenter = [0, 0, 0]\nradius = 0   # line 11\nmaterial = \"white\"\n");
    expect_error_exact(&text, 11, "sphere[0].radius");
}

#[test]
fn radius_negative() {
    let text = with_base(
        "[[sphere]]\ncenter = [0, 0, 0]\nradius = -1.5   # line 11\nmaterial = \"white\"\n",
    );
    expect_error_exact(&text, 11, "sphere[0].radius");
}

#[test]
fn sphere_light_radius_zero() {
    let text = with_base(
        "[[light]]\ntype = \"sphere\"\ncenter = [0, 5, 0]\nradius = 0   # line 12\npower = 10\n",
    );
    expect_error_exact(&text, 12, "light[0].radius");
}

#[test]
fn power_zero() {
    let text =
        with_base("[[light]]\ntype = \"point\"\nposition = [0, 5, 0]\npower = 0   # line 12\n");
    expect_error_exact(&text, 12, "light[0].power");
}

#[test]
fn power_negative() {
    let text = with_base(
        "[[light]]\ntype = \"point\"\nposition = [0, 5, 0]\npower = 10\n\n[[light]]\ntype = \"sphere\"\ncenter = [0, 5, 0]\nradius = 1\npower = -3   # line 18\n",
    );
    expect_error_exact(&text, 18, "light[1].power");
}

#[test]
fn ior_zero() {
    let text = "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 60\n[materials]\ng = { type = \"dielectric\", ior = 0 }  # line 6\n";
    expect_error_exact(text, 6, "materials.g.ior");
}

#[test]
fn ior_negative() {
    let text = "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 60\n\n[materials.g]\ntype = \"dielectric\"\nior = -1.5  # line 8\n";
    expect_error_exact(text, 8, "materials.g.ior");
}

#[test]
fn albedo_above_one() {
    let text = "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 60\n[materials]\nw = { type = \"diffuse\", albedo = [0.5, 1.2, 0.5] }  # line 6\n";
    expect_error_exact(text, 6, "materials.w.albedo");
}

#[test]
fn albedo_negative() {
    let text = "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 60\n[materials]\nok = { type = \"diffuse\", albedo = [1, 1, 1] }\nw = { type = \"diffuse\", albedo = [-0.1, 0, 0] }  # line 7\n";
    expect_error_exact(text, 7, "materials.w.albedo");
}

#[test]
fn mirror_tint_out_of_range() {
    let text = "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 60\n[materials]\nm = { type = \"mirror\", tint = [2, 2, 2] }  # line 6\n";
    expect_error_exact(text, 6, "materials.m.tint");
}

#[test]
fn light_color_negative() {
    let text = with_base(
        "[[light]]\ntype = \"point\"\nposition = [0, 5, 0]\npower = 10\ncolor = [1, -1, 1]   # line 13\n",
    );
    expect_error_exact(&text, 13, "light[0].color");
}

#[test]
fn background_negative() {
    let text = with_base("[render]\nbackground = [0, 0, -0.5]   # line 10\n");
    expect_error_exact(&text, 10, "render.background");
}

// ----- the camera -----

#[test]
fn look_at_equals_position() {
    let text = "[camera]\nposition = [1, 2, 3]\nlook_at = [1, 2, 3]   # line 3\nfov = 60\n";
    expect_error_exact(text, 3, "camera.look_at");
}

#[test]
fn up_parallel_to_view_direction() {
    let text = "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nup = [0, 0, -3]   # line 4\nfov = 60\n";
    let err = expect_error_exact(text, 4, "camera.up");
    assert!(err.to_string().contains("parallel"), "{err}");
}

#[test]
fn default_up_parallel_to_view_direction() {
    // Looking straight down with the default up [0, 1, 0]: the error points at the [camera] table.
    let text = "\n[camera]   # line 2\nposition = [0, 10, 0]\nlook_at = [0, 0, 0]\nfov = 60\n";
    let err = expect_error_exact(text, 2, "camera.up");
    assert!(err.to_string().contains("default up"), "{err}");
}

#[test]
fn up_zero() {
    let text = "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 60\nup = [0, 0, 0]   # line 5\n";
    expect_error_exact(text, 5, "camera.up");
}

#[test]
fn fov_zero() {
    let text = "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 0   # line 4\n";
    expect_error_exact(text, 4, "camera.fov");
}

#[test]
fn fov_180() {
    let text = "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 180.0   # line 4\n";
    expect_error_exact(text, 4, "camera.fov");
}

#[test]
fn fov_negative() {
    let text = "[camera]\nfov = -30   # line 2\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\n";
    expect_error_exact(text, 2, "camera.fov");
}

#[test]
fn aperture_negative() {
    let text = "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 60\naperture = -0.1   # line 5\n";
    expect_error_exact(text, 5, "camera.aperture");
}

#[test]
fn focus_distance_zero() {
    let text = "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 60\nfocus_distance = 0   # line 5\n";
    expect_error_exact(text, 5, "camera.focus_distance");
}

// ----- [image] and [render] -----

#[test]
fn width_zero() {
    let text = with_base("[image]\nwidth = 0   # line 10\n");
    expect_error_exact(&text, 10, "image.width");
}

#[test]
fn height_too_large() {
    let text = with_base("[image]\nwidth = 64\nheight = 65537   # line 11\n");
    expect_error_exact(&text, 11, "image.height");
}

#[test]
fn too_many_pixels() {
    let text = with_base("[image]\nwidth = 65536   # line 10\nheight = 8192\n");
    let err = expect_error_exact(&text, 10, "image.width");
    assert!(err.to_string().contains("pixels"), "{err}");
}

#[test]
fn exposure_negative() {
    let text = with_base("[image]\nexposure = -1   # line 10\n");
    expect_error_exact(&text, 10, "image.exposure");
}

#[test]
fn gamma_zero() {
    let text = with_base("[image]\ngamma = 0   # line 10\n");
    expect_error_exact(&text, 10, "image.gamma");
}

#[test]
fn gamma_unknown_name() {
    let text = with_base("[image]\ngamma = \"linear\"   # line 10\n");
    let err = expect_error_exact(&text, 10, "image.gamma");
    assert!(err.to_string().contains("\"srgb\""), "{err}");
}

#[test]
fn samples_zero() {
    let text = with_base("[render]\nsamples = 0   # line 10\n");
    expect_error_exact(&text, 10, "render.samples");
}

#[test]
fn samples_as_float() {
    let text = with_base("[render]\nsamples = 64.0   # line 10\n");
    expect_error_exact(&text, 10, "render.samples");
}

#[test]
fn max_bounces_negative() {
    // -1 is no limit (tests/unbounded.rs); below it, an error naming the key.
    let text = with_base("[render]\nmax_bounces = -2   # line 10\n");
    let err = expect_error_exact(&text, 10, "render.max_bounces");
    assert!(err.to_string().contains("-1 sets no limit"), "{err}");
}

#[test]
fn seed_above_u32() {
    let text = with_base("[render]\nseed = 4294967296   # line 10\n");
    expect_error_exact(&text, 10, "render.seed");
}

#[test]
fn seed_negative() {
    let text = with_base("[render]\nsamples = 4\nseed = -1   # line 11\n");
    expect_error_exact(&text, 11, "render.seed");
}

#[test]
fn seed_beyond_i64() {
    let text = with_base("[render]\nseed = 18446744073709551615   # line 10\n");
    let err = expect_error_exact(&text, 10, "render.seed");
    assert!(err.to_string().contains("out of range"), "{err}");
}

#[test]
fn unknown_filter() {
    let text = with_base("[render]\nfilter = \"mitchell\"   # line 10\n");
    let err = expect_error_exact(&text, 10, "render.filter");
    assert!(err.to_string().contains("\"gaussian\""), "{err}");
}

#[test]
fn unknown_sampler() {
    let text = with_base("[render]\nsampler = \"halton\"   # line 10\n");
    let err = expect_error_exact(&text, 10, "render.sampler");
    assert!(err.to_string().contains("\"sobol\""), "{err}");
}

#[test]
fn unknown_light_sampling() {
    let text = with_base("[render]\nlight_sampling = 3   # line 10\n");
    expect_error_exact(&text, 10, "render.light_sampling");
    let text = with_base("[render]\nlight_sampling = \"solid-angle\"   # line 10\n");
    let err = expect_error_exact(&text, 10, "render.light_sampling");
    assert!(
        err.to_string().contains("\"cone\"") && err.to_string().contains("\"mis\""),
        "{err}"
    );
}

#[test]
fn filter_sigma_zero() {
    let text = with_base("[render]\nfilter_sigma = 0   # line 10\n");
    expect_error_exact(&text, 10, "render.filter_sigma");
}

#[test]
fn filter_radius_not_positive() {
    let text = with_base("[render]\nfilter = \"tent\"\nfilter_radius = -1   # line 11\n");
    let err = expect_error_exact(&text, 11, "render.filter_radius");
    assert!(err.to_string().contains("> 0"), "{err}");
}

// ----- meshes -----

#[test]
fn mesh_obj_missing() {
    // (More OBJ and texture errors, with real files, are in tests/mesh.rs.)
    let text =
        with_base("\n[[mesh]]\nobj = \"models/bunny.obj\"   # line 11\nmaterial = \"white\"\n");
    let err = expect_error_exact(&text, 11, "mesh[0].obj");
    assert!(err.to_string().contains("models/bunny.obj"), "{err}");
    assert!(err.to_string().contains("cannot read"), "{err}");
}

// ----- nothing panics -----

#[test]
fn no_prefix_of_a_scene_panics() {
    // Every truncation of a full scene is either valid or an error; none may panic. Truncating at
    // every char boundary exercises half-written keys, arrays, strings and tables.
    let text = with_base(
        r#"
[image]
width = 64
height = 48
gamma = "srgb"

[render]
seed = 7
background = [0.1, 0.1, 0.1]

[[sphere]]
center = [0, 0, 0]
radius = 1
material = "glass"

[[triangle]]
vertices = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
material = "white"

[[light]]
type = "sphere"
center = [0, 5, 0]
radius = 0.5
power = 100
"#,
    );
    Scene::from_toml_str(&text, None).expect("the full text is valid");
    for (end, _) in text.char_indices() {
        if let Err(err) = Scene::from_toml_str(&text[..end], None) {
            assert!(!err.to_string().contains('\n'), "{err}");
        }
    }
}

#[test]
fn extreme_numbers_do_not_panic() {
    let texts = [
        "[camera]\nposition = [3e38, 3e38, 3e38]\nlook_at = [-3e38, -3e38, -3e38]\nfov = 60\n",
        "[camera]\nposition = [0, 0, 1e-45]\nlook_at = [0, 0, 0]\nfov = 60\n",
        "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 9223372036854775807\n",
        "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 60\n[image]\nwidth = -9223372036854775808\n",
        "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 60\n[image]\nwidth = 65536\nheight = 65536\n",
        "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 60\n[render]\nsamples = 99999999999999999999999999\n",
        "",
        "\u{feff}",
        "[[sphere]]\n[[sphere]]\n",
        "camera = 5\n",
        "sphere = [1, 2]\n",
        "[camera.position]\nx = 1\n",
    ];
    for text in texts {
        // Either result is fine; reaching the next iteration is the test.
        let _ = Scene::from_toml_str(text, None);
    }
}

#[test]
fn sphere_light_too_small_for_f32() {
    let text = "[camera]\nposition = [0.0, 0.0, 10.0]\nlook_at = [0.0, 0.0, 0.0]\nfov = 60.0\n\n[[light]]\ntype = \"sphere\"\ncenter = [0.0, 5.0, 0.0]\nradius = 1e-20\npower = 100.0\n";
    let e = vkpath::scene::Scene::from_toml_str(text, Some(std::path::Path::new("bad.toml")))
        .unwrap_err();
    assert_eq!(e.line(), Some(9));
    assert_eq!(e.key(), Some("light[0].radius"));
    assert!(e.to_string().contains("point light"), "{e}");
    // A small but representable radius is fine.
    let ok = text.replace("1e-20", "1e-6");
    assert!(vkpath::scene::Scene::from_toml_str(&ok, None).is_ok());
}

/// The sun's keys (scene-format.md, Additions): a direction that is present, finite and not zero, an
/// irradiance > 0, an angular diameter in [0, 180) degrees, and none of the other lights' keys.
#[test]
fn directional_light_errors() {
    let sun = |extra: &str| {
        with_base(&format!(
            "[[light]]  # line 9\ntype = \"directional\"\n{extra}"
        ))
    };
    expect_error_exact(&sun("irradiance = 3\n"), 9, "light[0].direction");
    expect_error_exact(
        &sun("direction = [0, 0, 0]  # line 11\nirradiance = 3\n"),
        11,
        "light[0].direction",
    );
    expect_error_exact(&sun("direction = [0, -1, 0]\n"), 9, "light[0].irradiance");
    expect_error_exact(
        &sun("direction = [0, -1, 0]\nirradiance = 0  # line 12\n"),
        12,
        "light[0].irradiance",
    );
    expect_error_exact(
        &sun("direction = [0, -1, 0]\nirradiance = 3\nangle = 180  # line 13\n"),
        13,
        "light[0].angle",
    );
    expect_error_exact(
        &sun("direction = [0, -1, 0]\nirradiance = 3\nangle = -1  # line 13\n"),
        13,
        "light[0].angle",
    );
    expect_error_exact(
        &sun("direction = [0, -1, 0]\nirradiance = 3\npower = 10  # line 13\n"),
        13,
        "light[0].power",
    );
    // And a point light has no direction.
    let text = with_base(
        "[[light]]\ntype = \"point\"\nposition = [0, 5, 0]\npower = 10\ndirection = [0, -1, 0]  # line 13\n",
    );
    expect_error_exact(&text, 13, "light[0].direction");
}

/// The orthographic camera's keys (scene-format.md, Additions): `type` is perspective or orthographic;
/// an orthographic camera needs an `extent` > 0 and has no `fov` and no lens; a perspective one has no
/// `extent`.
#[test]
fn orthographic_camera_errors() {
    let cam = |rest: &str| {
        format!("[camera]   # line 1\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\n{rest}")
    };
    expect_error_exact(
        &cam("type = \"fisheye\"  # line 4\nfov = 60\n"),
        4,
        "camera.type",
    );
    expect_error_exact(&cam("type = \"orthographic\"\n"), 1, "camera.extent");
    expect_error_exact(
        &cam("type = \"orthographic\"\nextent = 0  # line 5\n"),
        5,
        "camera.extent",
    );
    expect_error_exact(
        &cam("type = \"orthographic\"\nextent = 4\nfov = 60  # line 6\n"),
        6,
        "camera.fov",
    );
    expect_error_exact(
        &cam("type = \"orthographic\"\nextent = 4\naperture = 0.5  # line 6\n"),
        6,
        "camera.aperture",
    );
    expect_error_exact(&cam("fov = 60\nextent = 4  # line 5\n"), 5, "camera.extent");
    // And a valid one parses, with aperture 0 allowed.
    let ok = cam("type = \"orthographic\"\nextent = 4\naperture = 0\n");
    let s =
        Scene::from_toml_str(&ok, Some(Path::new("ok.toml"))).expect("valid orthographic camera");
    assert_eq!(s.camera.projection, vkpath::scene::Projection::Orthographic);
    assert_eq!(s.camera.extent, 4.0);
}

/// The emitting materials (scene-format.md, Additions): an emitter needs a radiance >= 0 and takes only
/// `radiance` and `two_sided`; any other material may have `emission` >= 0, and `two_sided_emission`
/// only with it.
#[test]
fn emitter_and_emission_errors() {
    let m = |def: &str| {
        format!(
            "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 60\n\n[materials]\n{def}  # line 7\n"
        )
    };
    expect_error_exact(
        &m("lamp = { type = \"emitter\" }"),
        7,
        "materials.lamp.radiance",
    );
    expect_error_exact(
        &m("lamp = { type = \"emitter\", radiance = [1, -1, 1] }"),
        7,
        "materials.lamp.radiance",
    );
    expect_error_exact(
        &m("lamp = { type = \"emitter\", radiance = [1, 1, 1], albedo = [0.5, 0.5, 0.5] }"),
        7,
        "materials.lamp.albedo",
    );
    expect_error_exact(
        &m("lamp = { type = \"emitter\", radiance = [1, 1, 1], emission = [1, 1, 1] }"),
        7,
        "materials.lamp.emission",
    );
    expect_error_exact(
        &m("w = { type = \"diffuse\", albedo = [0.5, 0.5, 0.5], emission = [0, 0, -2] }"),
        7,
        "materials.w.emission",
    );
    expect_error_exact(
        &m("w = { type = \"diffuse\", albedo = [0.5, 0.5, 0.5], two_sided_emission = true }"),
        7,
        "materials.w.two_sided_emission",
    );
    expect_error_exact(
        &m("w = { type = \"mirror\", radiance = [1, 1, 1] }"),
        7,
        "materials.w.radiance",
    );
    expect_error_exact(
        &m("w = { type = \"dielectric\", ior = 1.5, two_sided = true }"),
        7,
        "materials.w.two_sided",
    );
    // Valid ones parse, with their emission.
    let ok = m(
        "lamp = { type = \"emitter\", radiance = [1, 2, 3], two_sided = true }\n\
                w = { type = \"mirror\", emission = [0.5, 0.5, 0.5] }",
    );
    let s = Scene::from_toml_str(&ok, Some(Path::new("ok.toml"))).expect("valid emitters");
    let e = s.materials[0].emission.expect("the emitter emits");
    assert_eq!(
        (e.radiance, e.two_sided),
        (glam::Vec3::new(1.0, 2.0, 3.0), true)
    );
    assert_eq!(s.materials[0].bsdf, vkpath::scene::Bsdf::Black);
    assert!(!s.materials[1].emission.expect("the mirror emits").two_sided);
}

/// `[environment]` (scene-format.md, Additions): radiance >= 0, rotate finite, no unknown key, not
/// together with render.background, and a map that is a readable .exr or .hdr of at least 2 x 2 pixels
/// of finite, non-negative radiance; each error names the key (and the map file).
#[test]
fn environment_errors() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, w: u32, h: u32, value: f32| {
        let path = dir.path().join(name);
        let img = image::Rgb32FImage::from_pixel(w, h, image::Rgb([value, 0.5, 0.5]));
        image::DynamicImage::ImageRgb32F(img)
            .save_with_format(&path, image::ImageFormat::OpenExr)
            .unwrap();
        path
    };
    let good = write("good.exr", 4, 2, 1.0);
    let tiny = write("tiny.exr", 1, 1, 1.0);
    let negative = write("negative.exr", 4, 2, -1.0);
    let env = |rest: &str| with_base(&format!("[environment]  # line 9\n{rest}"));
    expect_error_exact(
        &env("radiance = [1, -1, 1]  # line 10\n"),
        10,
        "environment.radiance",
    );
    expect_error_exact(&env("rotate = nan  # line 10\n"), 10, "environment.rotate");
    expect_error(&env("scale = 2  # line 10\n"), 10, "environment.scale");
    let map = |path: &Path| env(&format!("map = \"{}\"  # line 10\n", path.display()));
    let e = expect_error_exact(&map(&dir.path().join("missing.exr")), 10, "environment.map");
    assert!(e.to_string().contains("missing.exr"), "{e}");
    let e = expect_error_exact(&map(&tiny), 10, "environment.map");
    assert!(e.to_string().contains("2 x 2"), "{e}");
    let e = expect_error_exact(&map(&negative), 10, "environment.map");
    assert!(e.to_string().contains("negative"), "{e}");
    let png = dir.path().join("sky.png");
    std::fs::write(&png, b"not read").unwrap();
    let e = expect_error_exact(&map(&png), 10, "environment.map");
    assert!(e.to_string().contains(".exr or .hdr"), "{e}");
    let garbage = dir.path().join("garbage.exr");
    std::fs::write(&garbage, b"this is not an EXR file").unwrap();
    expect_error_exact(&map(&garbage), 10, "environment.map");
    // Both render.background and [environment]: which is meant?
    let both = with_base(
        "[render]\nbackground = [1, 1, 1]  # line 10\n[environment]\nradiance = [1, 1, 1]\n",
    );
    expect_error_exact(&both, 10, "render.background");
    // A good map parses: radiance defaults to [1, 1, 1] with a map.
    let s = Scene::from_toml_str(&map(&good), Some(Path::new("ok.toml"))).expect("valid map");
    assert_eq!(s.environment.radiance, glam::Vec3::ONE);
    assert_eq!(
        s.environment.map.as_ref().map(|m| (m.width, m.height)),
        Some((4, 2))
    );
}

/// Issue 18: a byte that is not UTF-8 gave "cannot read the scene file" with no line, blaming the path.
/// Now the error names the line, the column and the byte.
#[test]
fn a_byte_that_is_not_utf8_is_located() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("latin1.toml");
    let mut bytes = BASE.as_bytes().to_vec();
    bytes.extend_from_slice(b"# caf\xe9 au lait   (line 9)\n");
    std::fs::write(&path, &bytes).unwrap();
    let e = Scene::load(&path).unwrap_err();
    assert_eq!(e.line(), Some(9), "{e}");
    let m = e.to_string();
    assert!(
        m.contains("0xe9") && m.contains("column 6") && m.contains("UTF-8"),
        "{m}"
    );
}

// ----- glossy materials (issue 14) -----

/// A material table on line 6, after a valid camera.
fn one_material(material: &str) -> String {
    format!(
        "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 60\n[materials]\n{material}  # line 6\n"
    )
}

#[test]
fn roughness_above_one() {
    let err = expect_error_exact(
        &one_material("m = { type = \"conductor\", preset = \"gold\", roughness = 1.5 }"),
        6,
        "materials.m.roughness",
    );
    assert!(err.to_string().contains("[0, 1]"), "{err}");
}

#[test]
fn roughness_negative_in_a_pair() {
    expect_error_exact(
        &one_material("m = { type = \"dielectric\", ior = 1.5, roughness = [0.2, -0.1] }"),
        6,
        "materials.m.roughness",
    );
}

#[test]
fn roughness_list_of_three() {
    expect_error_exact(
        &one_material(
            "m = { type = \"plastic\", albedo = [0.5, 0.5, 0.5], roughness = [0.1, 0.2, 0.3] }",
        ),
        6,
        "materials.m.roughness",
    );
}

#[test]
fn conductor_k_negative() {
    let err = expect_error_exact(
        &one_material("m = { type = \"conductor\", eta = [0.2, 0.4, 1.4], k = [3.9, -2.4, 1.6] }"),
        6,
        "materials.m.k",
    );
    assert!(err.to_string().contains(">= 0"), "{err}");
}

#[test]
fn conductor_eta_zero() {
    expect_error_exact(
        &one_material("m = { type = \"conductor\", eta = [0.0, 0.4, 1.4], k = [3.9, 2.4, 1.6] }"),
        6,
        "materials.m.eta",
    );
}

#[test]
fn conductor_eta_without_k() {
    let err = expect_error_exact(
        &one_material("m = { type = \"conductor\", eta = [0.2, 0.4, 1.4] }"),
        6,
        "materials.m.eta",
    );
    assert!(err.to_string().contains("without k"), "{err}");
}

#[test]
fn conductor_unknown_preset_lists_the_presets() {
    let err = expect_error_exact(
        &one_material("m = { type = \"conductor\", preset = \"brass\" }"),
        6,
        "materials.m.preset",
    );
    let message = err.to_string();
    assert!(
        message.contains("\"brass\"") && message.contains("\"aluminium\""),
        "{err}"
    );
}

#[test]
fn conductor_preset_and_base_color_together() {
    expect_error_exact(
        &one_material(
            "m = { type = \"conductor\", preset = \"gold\", base_color = [1.0, 0.8, 0.3] }",
        ),
        6,
        "materials.m.base_color",
    );
}

#[test]
fn conductor_without_fresnel() {
    expect_error_exact(
        &one_material("m = { type = \"conductor\", roughness = 0.2 }"),
        6,
        "materials.m",
    );
}

#[test]
fn plastic_without_albedo() {
    expect_error_exact(
        &one_material("m = { type = \"plastic\", ior = 1.5 }"),
        6,
        "materials.m.albedo",
    );
}

#[test]
fn metallic_outside_unit_range() {
    expect_error_exact(
        &one_material("m = { type = \"metallic_roughness\", metallic = 1.2 }"),
        6,
        "materials.m.metallic",
    );
}

#[test]
fn metallic_roughness_is_isotropic() {
    expect_error_exact(
        &one_material("m = { type = \"metallic_roughness\", roughness = [0.2, 0.4] }"),
        6,
        "materials.m.roughness",
    );
}

#[test]
fn roughness_on_a_diffuse_material_is_unknown() {
    expect_error_exact(
        &one_material("m = { type = \"diffuse\", albedo = [0.5, 0.5, 0.5], roughness = 0.2 }"),
        6,
        "materials.m.roughness",
    );
}

// ----- display and clamp (issue 18) -----

#[test]
fn unknown_tonemap() {
    let err = expect_error_exact(
        "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 60\n[render]\ntonemap = \"agx\"  # line 6\n",
        6,
        "render.tonemap",
    );
    assert!(err.to_string().contains("\"aces\""), "{err}");
}

#[test]
fn clamp_not_positive() {
    expect_error_exact(
        "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 60\n[render]\nclamp = 0  # line 6\n",
        6,
        "render.clamp",
    );
}
