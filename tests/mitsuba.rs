//! Mitsuba 3 XML scenes (src/scene/mitsuba/): hand-written XML covering each element, checked after
//! loading against hand-computed values; an XML scene and its hand-written TOML equivalent render the same
//! bits; every refusal names the file, the line and the element; mutated XML never panics.

mod common;

use common::cli::{run, write};
use glam::Vec3;
use proptest::prelude::*;
use std::f32::consts::PI;
use std::path::Path;
use vkpath::Scene;
use vkpath::materials::Value;
use vkpath::scene::NO_BOUNCE_LIMIT;
use vkpath::scene::mitsuba;
use vkpath::scene::texture::{Channel, TextureFilter, Wrap};
use vkpath::scene::translated::ImportOptions;
use vkpath::scene::{Bsdf, ConductorFresnel, Filter, Light, Projection, Roughness, Sampler};

/// A perspective sensor the scenes below share: 40 x 20 pixels, box filter, 16 spp.
const SENSOR: &str = r#"
    <sensor type="perspective">
        <float name="fov" value="60"/>
        <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="16"/></sampler>
        <film type="hdrfilm">
            <integer name="width" value="40"/><integer name="height" value="20"/>
            <rfilter type="box"/>
        </film>
    </sensor>"#;

/// `<scene>` around `body` (with the shared sensor unless the body has its own).
fn scene_xml(body: &str) -> String {
    let sensor = if body.contains("<sensor") { "" } else { SENSOR };
    format!("<?xml version=\"1.0\"?>\n<scene version=\"3.0.0\">{sensor}\n{body}\n</scene>\n")
}

fn load_in(dir: &Path, body: &str) -> Scene {
    let p = write(dir, "scene.xml", &scene_xml(body));
    Scene::load(&p).unwrap_or_else(|e| panic!("{e}"))
}

fn load(body: &str) -> Scene {
    let dir = tempfile::tempdir().unwrap();
    load_in(dir.path(), body)
}

/// The error text for a scene, and the line it should name.
fn error_in(dir: &Path, body: &str) -> String {
    let p = write(dir, "scene.xml", &scene_xml(body));
    match Scene::load(&p) {
        Ok(_) => panic!("expected an error for {body}"),
        Err(e) => e.to_string(),
    }
}

/// The 1-based line of `needle` in the scene file that `scene_xml(body)` writes.
fn line_of(body: &str, needle: &str) -> usize {
    scene_xml(body)
        .lines()
        .position(|l| l.contains(needle))
        .expect("needle in the scene")
        + 1
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).abs().max_element() < 1e-5
}

fn assert_close(a: Vec3, b: Vec3) {
    assert!(close(a, b), "{a} vs {b}");
}

#[test]
fn the_sensor_film_sampler_and_integrator_map_to_camera_image_and_render() {
    let s = load(
        r#"<integrator type="path"><integer name="max_depth" value="4"/><integer name="rr_depth" value="3"/></integrator>"#,
    );
    assert_eq!(s.camera.position, Vec3::new(0.0, 0.0, 5.0));
    assert_eq!(s.camera.look_at, Vec3::ZERO);
    assert_eq!(s.camera.up, Vec3::Y);
    assert_eq!(s.camera.fov_deg, 60.0);
    assert_eq!(s.camera.projection, Projection::Perspective);
    assert_eq!((s.image.width, s.image.height), (40, 20));
    assert_eq!(s.render.samples, 16);
    // max_depth counts segments, max_bounces scattering events.
    assert_eq!(s.render.max_bounces, 3);
    assert_eq!(s.render.filter, Filter::Box);
    assert_eq!(s.render.sampler, Sampler::Independent);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);

    // No integrator: Mitsuba's path tracer without a depth limit. rr_depth other than vkpath's is a note.
    assert_eq!(load("").render.max_bounces, NO_BOUNCE_LIMIT);
    let s = load(
        r#"<integrator type="path"><integer name="max_depth" value="-1"/><integer name="rr_depth" value="5"/></integrator>"#,
    );
    assert_eq!(s.render.max_bounces, NO_BOUNCE_LIMIT);
    assert!(
        s.warnings.iter().any(|w| w.contains("rr_depth = 5")),
        "{:?}",
        s.warnings
    );
    let s = load(r#"<integrator type="path"><integer name="max_depth" value="1"/></integrator>"#);
    assert_eq!(s.render.max_bounces, 0);

    // Defaults: Mitsuba's hdrfilm 768 x 576 with a Gaussian of std-dev 0.5, independent sampler 4 spp.
    let s = load(
        r#"<sensor type="perspective"><float name="fov" value="45"/>
             <film type="hdrfilm"><rfilter type="gaussian"><float name="stddev" value="0.25"/></rfilter></film>
           </sensor>"#,
    );
    assert_eq!((s.image.width, s.image.height), (768, 576));
    assert_eq!(s.render.samples, 4);
    assert_eq!(
        (s.render.filter, s.render.filter_sigma),
        (Filter::Gaussian, 0.25)
    );
    // Mitsuba's tent (Bitterli's scenes use it): radius 1 pixel unless given.
    for (inner, radius) in [("", 1.0), (r#"<float name="radius" value="1.5"/>"#, 1.5)] {
        let s = load(&format!(
            r#"<sensor type="perspective"><float name="fov" value="45"/>
                 <film type="hdrfilm"><rfilter type="tent">{inner}</rfilter></film></sensor>"#
        ));
        assert_eq!(
            (s.render.filter, s.render.filter_radius),
            (Filter::Tent, radius)
        );
    }
    // Identity to_world: at the origin looking down +z, up +y.
    assert_eq!(s.camera.position, Vec3::ZERO);
    assert_close(s.camera.look_at, Vec3::Z);
    assert_close(s.camera.up, Vec3::Y);
    let s = load(
        r#"<sensor type="perspective"><float name="fov" value="45"/>
             <sampler type="ldsampler"><integer name="sample_count" value="64"/><integer name="seed" value="9"/></sampler>
             <film type="hdrfilm"/></sensor>"#,
    );
    assert_eq!((s.render.samples, s.render.seed), (64, 9));
    assert_eq!(s.render.sampler, Sampler::Sobol);
    assert_eq!(
        (s.render.filter, s.render.filter_sigma),
        (Filter::Gaussian, 0.5)
    );
}

/// fov_axis: the horizontal fov from the image's aspect a = w / h and t = tan(fov / 2).
#[test]
fn every_fov_axis_becomes_the_horizontal_fov() {
    let fov = |axis: &str, w: u32, h: u32| {
        load(&format!(
            r#"<sensor type="perspective"><float name="fov" value="40"/>{axis}
                 <film type="hdrfilm"><integer name="width" value="{w}"/><integer name="height" value="{h}"/></film>
               </sensor>"#
        ))
        .camera
        .fov_deg as f64
    };
    let t = 20f64.to_radians().tan();
    let deg = |x: f64| x.to_degrees();
    let wide = 2.0; // 200 x 100
    let by_y = deg(2.0 * (wide * t).atan());
    let by_diagonal = deg(2.0 * (t / (1.0 + 1.0 / (wide * wide)).sqrt()).atan());
    let axis = |a: &str| format!(r#"<string name="fov_axis" value="{a}"/>"#);
    let near = |a: f64, b: f64| assert!((a - b).abs() < 1e-4, "{a} vs {b}");
    near(fov("", 200, 100), 40.0);
    near(fov(&axis("x"), 200, 100), 40.0);
    near(fov(&axis("y"), 200, 100), by_y);
    near(fov(&axis("diagonal"), 200, 100), by_diagonal);
    near(fov(&axis("smaller"), 200, 100), by_y); // wide image: the smaller side is y
    near(fov(&axis("larger"), 200, 100), 40.0);
    near(fov(&axis("smaller"), 100, 200), 40.0); // tall image: the smaller side is x
    near(fov(&axis("larger"), 100, 200), deg(2.0 * (0.5 * t).atan()));
    // No fov: the 50 mm focal length of 35 mm film, a diagonal fov of 2 atan(43.27 / 100).
    let s = load(
        r#"<sensor type="perspective"><string name="focal_length" value="50mm"/><film type="hdrfilm"><integer name="width" value="300"/><integer name="height" value="200"/></film></sensor>"#,
    );
    let d = (36f64 * 36.0 + 24.0 * 24.0).sqrt() / 100.0; // tan of half the diagonal fov
    near(
        s.camera.fov_deg as f64,
        deg(2.0 * (d / (1.0 + 1.0 / 2.25f64).sqrt()).atan()),
    );
}

/// A camera given by a matrix (as mitsuba.xml.dict_to_xml writes a sensor's: rotations and a
/// translation), a thin lens, and an orthographic camera scaled to its extent.
#[test]
fn cameras_from_matrices_thin_lenses_and_orthographic_views() {
    // rotate about y by 180 degrees then translate: at (1, 2, 3) looking down -z, up +y.
    let s = load(
        r#"<sensor type="thinlens">
             <float name="fov" value="30"/><float name="aperture_radius" value="0.1"/><float name="focus_distance" value="4"/>
             <transform name="to_world"><rotate y="1" angle="180"/><translate value="1 2 3"/></transform>
             <film type="hdrfilm"/></sensor>"#,
    );
    assert_close(s.camera.position, Vec3::new(1.0, 2.0, 3.0));
    assert_close(s.camera.look_at, Vec3::new(1.0, 2.0, 2.0));
    assert_close(s.camera.up, Vec3::Y);
    assert_eq!((s.camera.aperture, s.camera.focus_distance), (0.1, 4.0));
    // The same placement as a row-major 4 x 4 matrix: columns left (-1, 0, 0), up, forward (0, 0, -1).
    let s = load(
        r#"<sensor type="perspective"><float name="fov" value="30"/>
             <transform name="to_world"><matrix value="-1 0 0 1  0 1 0 2  0 0 -1 3  0 0 0 1"/></transform>
           </sensor>"#,
    );
    assert_close(s.camera.position, Vec3::new(1.0, 2.0, 3.0));
    assert_close(s.camera.look_at, Vec3::new(1.0, 2.0, 2.0));
    // Mitsuba's camera +x is the image's left, here world -x: vkpath's right, forward x up, is +x.
    let forward = s.camera.look_at - s.camera.position;
    assert_close(forward.cross(s.camera.up), Vec3::X);
    // Orthographic: to_world = lookat x scale(half, half, 1) sees a view 2 x half wide.
    let s = load(
        r#"<sensor type="orthographic">
             <transform name="to_world"><scale x="2.5" y="2.5"/><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
           </sensor>"#,
    );
    assert_eq!(s.camera.projection, Projection::Orthographic);
    assert!((s.camera.extent - 5.0).abs() < 1e-6, "{}", s.camera.extent);
    assert_close(s.camera.look_at, Vec3::new(0.0, 0.0, 4.0));
    // --camera N: sensor N in file order.
    let dir = tempfile::tempdir().unwrap();
    let two = scene_xml(&format!(
        r#"{SENSOR}<sensor type="perspective"><float name="fov" value="20"/></sensor>"#
    ));
    let p = write(dir.path(), "two.xml", &two);
    let second = Scene::load_with_camera(&p, Some(1)).unwrap();
    assert_eq!(second.camera.fov_deg, 20.0);
    let e = Scene::load_with_camera(&p, Some(2))
        .unwrap_err()
        .to_string();
    assert!(e.contains("--camera 2") && e.contains("has 2"), "{e}");
}

#[test]
fn shapes_are_placed_by_their_transforms() {
    let s = load(
        r#"
        <shape type="sphere"><point name="center" value="1, 0, 0"/><float name="radius" value="2"/>
            <transform name="to_world"><scale value="3"/><translate x="0" y="1" z="0"/></transform></shape>
        <shape type="sphere"><transform name="to_world"><translate value="0 0 -2"/><rotate y="1" angle="90"/></transform></shape>
        <shape type="rectangle"><transform name="to_world"><scale value="2"/><translate z="-1"/></transform></shape>
        <shape type="rectangle"><boolean name="flip_normals" value="true"/></shape>
        <shape type="cube"/>
        <shape type="disk"/>"#,
    );
    // Mitsuba: to_world x translate(center) x scale(radius); the later element left-multiplies.
    assert_eq!(s.spheres.len(), 2);
    assert_close(s.spheres[0].center, Vec3::new(3.0, 1.0, 0.0));
    assert!((s.spheres[0].radius - 6.0).abs() < 1e-6);
    // translate then rotate about y by 90 degrees: (0, 0, -2) -> (-2, 0, 0).
    assert_close(s.spheres[1].center, Vec3::new(-2.0, 0.0, 0.0));
    assert_eq!(s.spheres[1].radius, 1.0);
    // The rectangle: [-1, 1]^2 at z = 0, normal +z, scaled by 2 and moved to z = -1.
    let t = &s.triangles;
    assert_eq!(t.len(), 2 + 2 + 12 + mitsuba::DISK_SEGMENTS);
    let v = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    assert_eq!(
        t[0].vertices,
        [v(-2.0, -2.0, -1.0), v(2.0, -2.0, -1.0), v(2.0, 2.0, -1.0)]
    );
    assert_eq!(
        t[1].vertices,
        [v(-2.0, -2.0, -1.0), v(2.0, 2.0, -1.0), v(-2.0, 2.0, -1.0)]
    );
    let normal = |tri: &vkpath::scene::Triangle| {
        let [a, b, c] = tri.vertices;
        (b - a).cross(c - a).normalize()
    };
    assert_close(normal(&t[0]), Vec3::Z);
    assert_close(normal(&t[2]), -Vec3::Z); // flip_normals reverses the winding
    // The cube's 12 faces point outwards.
    for tri in &t[4..16] {
        let centre = (tri.vertices[0] + tri.vertices[1] + tri.vertices[2]) / 3.0;
        assert!(normal(tri).dot(centre) > 0.0);
    }
    // The disk: a fan about the origin facing +z whose area is pi.
    let area: f32 = t[16..]
        .iter()
        .map(|tri| {
            let [a, b, c] = tri.vertices;
            (b - a).cross(c - a).z / 2.0
        })
        .sum();
    assert!((area - PI).abs() < 1e-5, "{area}");
}

/// An `obj` shape's to_world that scales unevenly or shears becomes the mesh's `matrix` (a similarity
/// stays scale / rotate / translate); one that mirrors is refused, naming its element: Mitsuba turns a
/// mirrored mesh's faces around, vkpath's `matrix` keeps their fronts.
#[test]
fn mesh_transforms_that_stretch_become_matrices_and_mirrors_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "tri.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    );
    let s = load_in(
        dir.path(),
        r#"<shape type="obj"><string name="filename" value="tri.obj"/>
            <transform name="to_world"><scale x="2" y="3" z="1"/><rotate z="1" angle="90"/><translate x="1"/></transform></shape>"#,
    );
    // scale (2, 3, 1), then a quarter turn about z ((x, y) -> (-y, x)), then x + 1.
    let p = &s.meshes[0].positions;
    assert_close(p[0], Vec3::new(1.0, 0.0, 0.0));
    assert_close(p[1], Vec3::new(1.0, 2.0, 0.0));
    assert_close(p[2], Vec3::new(-2.0, 0.0, 0.0));
    let body = r#"<shape type="obj"><string name="filename" value="tri.obj"/>
            <transform name="to_world"><scale x="-1"/></transform></shape>"#;
    let message = error_in(dir.path(), body);
    assert!(message.contains("mirrors"), "{message}");
    assert!(
        message.contains(&format!("line {}", line_of(body, "<scale x=\"-1\""))),
        "{message}"
    );
}

/// Mitsuba's `spot` (intensity W/sr on the axis, local +z of its to_world, cutoff_angle and beam_width
/// in degrees) is vkpath's spot light; the TOML form refuses power and intensity together and a beam
/// wider than the cutoff, naming the key.
#[test]
fn spot_emitters_become_spot_lights() {
    let s = load(
        r#"<emitter type="spot"><rgb name="intensity" value="2, 4, 8"/><float name="cutoff_angle" value="30"/>
            <transform name="to_world"><lookat origin="0, 5, 0" target="0, 0, 0" up="0, 0, 1"/></transform></emitter>"#,
    );
    let [
        Light::Spot {
            position,
            axis,
            intensity,
            color,
            cutoff_deg,
            beam_deg,
            falloff: vkpath::scene::SpotFalloff::Linear,
        },
    ] = s.lights[..]
    else {
        panic!("{:?}", s.lights)
    };
    assert_close(position, Vec3::new(0.0, 5.0, 0.0));
    assert_close(axis, Vec3::new(0.0, -1.0, 0.0));
    assert!((intensity - 8.0).abs() < 1e-5);
    assert_close(color, Vec3::new(0.25, 0.5, 1.0));
    assert_eq!((cutoff_deg, beam_deg), (30.0, 22.5)); // Mitsuba's default beam: 3/4 of the cutoff
    let dir = tempfile::tempdir().unwrap();
    for (keys, key) in [
        ("power = 10.0\nintensity = 2.0", "light[0].intensity"),
        (
            "power = 10.0\ncutoff_angle = 20.0\nbeam_width = 25.0",
            "light[0].beam_width",
        ),
        ("power = 10.0\ncutoff_angle = 95.0", "light[0].cutoff_angle"),
    ] {
        let toml = format!(
            "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nfov = 40\n\
             [[light]]\ntype = \"spot\"\nposition = [0, 2, 0]\nlook_at = [0, 0, 0]\n{keys}\n"
        );
        let p = write(dir.path(), "spot.toml", &toml);
        let message = Scene::load(&p)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(message.contains(key), "{key}: {message}");
    }
}

/// Mitsuba's `direct` integrator is path tracing with max_depth 2 (the same expectation): the scene gets
/// max_bounces 1 and renders the same bits as the file with `<integrator type="path">` at max_depth 2;
/// its per-point sample counts are read past with a warning, hide_emitters is refused.
#[test]
fn the_direct_integrator_is_path_tracing_at_max_depth_two() {
    let body = |integrator: &str| {
        format!(
            r#"{integrator}
            <shape type="sphere"><bsdf type="diffuse"/></shape>
            <emitter type="point"><point name="position" value="0, 3, 3"/><rgb name="intensity" value="5"/></emitter>"#
        )
    };
    let direct = load(&body(
        r#"<integrator type="direct"><integer name="emitter_samples" value="4"/></integrator>"#,
    ));
    let path = load(&body(
        r#"<integrator type="path"><integer name="max_depth" value="2"/></integrator>"#,
    ));
    assert_eq!(direct.render.max_bounces, 1);
    assert!(
        direct
            .warnings
            .iter()
            .any(|w| w.contains("emitter_samples")),
        "{:?}",
        direct.warnings
    );
    let render = |s: &Scene| common::render_passes(s, &Default::default(), 1, 4).mean;
    assert_eq!(render(&direct), render(&path));
    let dir = tempfile::tempdir().unwrap();
    let e = error_in(
        dir.path(),
        &body(
            r#"<integrator type="direct"><boolean name="hide_emitters" value="true"/></integrator>"#,
        ),
    );
    assert!(e.contains("hide_emitters"), "{e}");
}

/// `<path value="...">` adds a folder to the file resolver, relative to the file naming it: a mesh and an
/// include found there; a folder that does not exist is an error naming the element's line.
#[test]
fn path_elements_add_folders_to_search() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("assets/deeper")).unwrap();
    write(
        &dir.path().join("assets"),
        "tri.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    );
    write(
        &dir.path().join("assets/deeper"),
        "light.xml",
        r#"<scene version="3.0.0"><emitter type="point"><point name="position" value="0, 2, 2"/></emitter></scene>"#,
    );
    let s = load_in(
        dir.path(),
        r#"<path value="assets"/><path value="assets/deeper"/>
        <include filename="light.xml"/>
        <shape type="obj"><string name="filename" value="tri.obj"/></shape>"#,
    );
    assert_eq!((s.meshes.len(), s.lights.len()), (1, 1));
    assert!(
        s.meshes[0].obj.ends_with("assets/tri.obj"),
        "{:?}",
        s.meshes[0].obj
    );
    let body = r#"<path value="nowhere"/>"#;
    let message = error_in(dir.path(), body);
    assert!(message.contains("nowhere"), "{message}");
    assert!(
        message.contains(&format!("line {}", line_of(body, "nowhere"))),
        "{message}"
    );
}

/// Mitsuba's thindielectric is vkpath's thin_dielectric (int_ior over ext_ior, air by default); a tint
/// is refused.
#[test]
fn mitsuba_0_5_films_keep_their_banner_and_edge_parameters() {
    // Bitterli's living room (a Mitsuba 0.5 export) gives its film banner and high_quality_edges; Mitsuba
    // 0.6 read both, Mitsuba 3 refuses them. vkpath reads them in files whose version is below 2.0.
    let film = |version: &str, banner: &str| {
        format!(
            r#"<?xml version="1.0"?>
<scene version="{version}">
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <film type="hdrfilm">
            <integer name="width" value="40"/><integer name="height" value="20"/>
            <boolean name="banner" value="{banner}"/>
            <boolean name="highQualityEdges" value="true"/>
            <boolean name="attachLog" value="false"/>
        </film>
    </sensor>
    <shape type="sphere"><bsdf type="diffuse"/></shape>
</scene>
"#
        )
    };
    let dir = tempfile::tempdir().unwrap();
    let old = write(dir.path(), "old.xml", &film("0.5.0", "false"));
    let s = Scene::load(&old).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!((s.image.width, s.image.height), (40, 20));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let logo = write(dir.path(), "logo.xml", &film("0.5.0", "true"));
    let s = Scene::load(&logo).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("line 7") && w.contains("banner = true")),
        "{:?}",
        s.warnings
    );
    // A Mitsuba 3 file: refused as Mitsuba 3 refuses it, naming the parameter and its line.
    let new = write(dir.path(), "new.xml", &film("3.0.0", "false"));
    let Err(e) = Scene::load(&new) else {
        panic!("a Mitsuba 3 film with banner loaded")
    };
    let e = e.to_string();
    assert!(e.contains("line 7") && e.contains("\"banner\""), "{e}");
}

#[test]
fn thindielectric_is_a_thin_pane() {
    let s = load(
        r#"<shape type="sphere"><bsdf type="thindielectric"><float name="int_ior" value="1.6"/></bsdf></shape>"#,
    );
    match s.materials[s.spheres[0].material as usize].bsdf {
        Bsdf::ThinDielectric { ior } => assert!((ior - 1.6 / 1.000277).abs() < 1e-5, "{ior}"),
        ref other => panic!("{other:?}"),
    }
    let dir = tempfile::tempdir().unwrap();
    let e = error_in(
        dir.path(),
        r#"<shape type="sphere"><bsdf type="thindielectric"><rgb name="specular_transmittance" value="0.5"/></bsdf></shape>"#,
    );
    assert!(e.contains("specular_transmittance"), "{e}");
}

#[test]
fn bsdfs_and_emitters_map_to_materials_and_lights() {
    let dir = tempfile::tempdir().unwrap();
    // A 2 x 2 environment map and a textured OBJ quad.
    image::Rgb32FImage::from_pixel(4, 2, image::Rgb([1.0, 1.0, 1.0]))
        .save(dir.path().join("sky.exr"))
        .unwrap();
    image::RgbImage::from_pixel(2, 2, image::Rgb([200, 100, 50]))
        .save(dir.path().join("tex.png"))
        .unwrap();
    write(
        dir.path(),
        "quad.obj",
        "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n",
    );
    let s = load_in(
        dir.path(),
        r#"
        <bsdf type="twosided" id="white"><bsdf type="diffuse"><rgb name="reflectance" value="0.8"/></bsdf></bsdf>
        <shape type="sphere"><ref id="white"/></shape>
        <shape type="sphere"><bsdf type="conductor"><string name="material" value="Au"/></bsdf></shape>
        <shape type="sphere"><bsdf type="roughconductor"><string name="distribution" value="ggx"/>
            <float name="alpha" value="0.09"/><rgb name="eta" value="0.2, 0.9, 1.1"/><rgb name="k" value="3.9 2.4 2.1"/></bsdf></shape>
        <shape type="sphere"><bsdf type="conductor"><rgb name="specular_reflectance" value="0.9, 0.8, 0.7"/></bsdf></shape>
        <shape type="sphere"><bsdf type="dielectric"><float name="int_ior" value="1.5"/><float name="ext_ior" value="1.0"/></bsdf></shape>
        <shape type="sphere"><bsdf type="roughdielectric"><string name="int_ior" value="water"/><string name="distribution" value="ggx"/><float name="alpha" value="0.16"/></bsdf></shape>
        <shape type="sphere"><bsdf type="plastic"><rgb name="diffuse_reflectance" value="0.5, 0.1, 0.1"/>
            <float name="int_ior" value="1.5"/><float name="ext_ior" value="1"/><boolean name="nonlinear" value="true"/></bsdf></shape>
        <shape type="sphere"><emitter type="area"><rgb name="radiance" value="3, 2, 1"/></emitter>
            <bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf></shape>
        <shape type="obj"><string name="filename" value="quad.obj"/><boolean name="face_normals" value="true"/>
            <bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="tex.png"/></texture></bsdf>
            <transform name="to_world"><scale value="2"/><rotate x="1" angle="-90"/><translate y="-1"/></transform></shape>
        <emitter type="point"><point name="position" value="1, 2, 3"/><rgb name="intensity" value="2, 1, 0.5"/></emitter>
        <emitter type="directional"><vector name="direction" value="0, -1, 0"/><spectrum name="irradiance" value="3"/></emitter>
        <emitter type="envmap"><string name="filename" value="sky.exr"/><float name="scale" value="2"/>
            <transform name="to_world"><rotate y="1" angle="90"/></transform></emitter>"#,
    );
    let bsdf = |i: usize| s.materials[s.spheres[i].material as usize].bsdf;
    assert_eq!(
        bsdf(0),
        Bsdf::Diffuse {
            albedo: Vec3::splat(0.8)
        }
    );
    assert_eq!(s.material_names[s.spheres[0].material as usize], "white");
    let Bsdf::Conductor {
        fresnel: ConductorFresnel::Complex { eta, .. },
        roughness,
        ..
    } = bsdf(1)
    else {
        panic!("{:?}", bsdf(1))
    };
    assert_eq!(roughness, Roughness::SMOOTH);
    assert!((eta.x - 0.143_036).abs() < 1e-6, "the gold preset");
    assert_eq!(
        bsdf(2),
        Bsdf::Conductor {
            fresnel: ConductorFresnel::Complex {
                eta: Vec3::new(0.2, 0.9, 1.1),
                k: Vec3::new(3.9, 2.4, 2.1)
            },
            roughness: Roughness::isotropic(0.3), // sqrt(alpha)
            tint: Vec3::ONE,
        }
    );
    assert_eq!(
        bsdf(3),
        Bsdf::Mirror {
            tint: Vec3::new(0.9, 0.8, 0.7)
        }
    );
    assert_eq!(
        bsdf(4),
        Bsdf::Dielectric {
            ior: 1.5,
            roughness: Roughness::SMOOTH
        }
    );
    // int_ior "water" over the default ext_ior "air".
    let Bsdf::Dielectric { ior, roughness } = bsdf(5) else {
        panic!()
    };
    assert!((ior - 1.3330 / 1.000277).abs() < 1e-6 && roughness == Roughness::isotropic(0.4));
    assert_eq!(
        bsdf(6),
        Bsdf::Plastic {
            albedo: Vec3::new(0.5, 0.1, 0.1),
            ior: 1.5,
            roughness: Roughness::SMOOTH,
            nonlinear: true,
        }
    );
    let lamp = &s.materials[s.spheres[7].material as usize];
    assert_eq!(lamp.bsdf, Bsdf::Diffuse { albedo: Vec3::ZERO });
    let e = lamp.emission.unwrap();
    assert_eq!((e.radiance, e.two_sided), (Vec3::new(3.0, 2.0, 1.0), false));
    // The mesh: placed by scale 2, rotation -90 about x, translation; flat; textured.
    let m = &s.meshes[0];
    assert!(m.normals.is_empty(), "face_normals: flat");
    let tex = s.materials[m.material as usize]
        .textures
        .albedo
        .as_ref()
        .expect("the reflectance bitmap is the material's albedo texture");
    assert!(tex.srgb && tex.channel == Channel::Rgb);
    let mut ys: Vec<f32> = m.positions.iter().map(|p| p.y).collect();
    ys.dedup_by(|a, b| (*a - *b).abs() < 1e-5);
    assert_eq!(ys.len(), 1);
    assert!((ys[0] + 1.0).abs() < 1e-5);
    assert!(
        m.positions
            .iter()
            .any(|p| close(*p, Vec3::new(2.0, -1.0, -2.0))),
        "{:?}",
        m.positions
    );
    // Lights: point power 4 pi max(I), colour I / max(I); directional irradiance 3.
    let Light::Point {
        position,
        power,
        color,
    } = s.lights[0]
    else {
        panic!()
    };
    assert_eq!(position, Vec3::new(1.0, 2.0, 3.0));
    assert!((power - 8.0 * PI).abs() < 1e-4);
    assert_eq!(color, Vec3::new(1.0, 0.5, 0.25));
    let Light::Directional {
        direction,
        irradiance,
        color,
        angle_deg,
    } = s.lights[1]
    else {
        panic!()
    };
    assert_eq!(
        (direction, irradiance, color, angle_deg),
        (-Vec3::Y, 3.0, Vec3::ONE, 0.0)
    );
    // The environment: the map, its scale as radiance, its rotation about y.
    assert!(s.environment.map.is_some());
    assert_eq!(s.environment.radiance, Vec3::splat(2.0));
    assert!((s.environment.rotate_deg - 90.0).abs() < 1e-4);
    let s =
        load(r#"<emitter type="constant"><rgb name="radiance" value="0.5, 0.6, 0.7"/></emitter>"#);
    assert_eq!(s.environment.radiance, Vec3::new(0.5, 0.6, 0.7));
}

/// Mitsuba's mask is vkpath's stochastic opacity (no cut-off) on the nested BSDF; a bitmap opacity is
/// read as Mitsuba's eval_1 reads it, the luminance of the sRGB-decoded colour (an image's alpha is not
/// read). Bitmap keys: filter_type nearest, wrap_mode clamp/mirror and raw become filter, wrap and the
/// colour space. Textures on a shape without uvs are refused.
#[test]
fn masks_and_bitmaps_become_opacity_and_texture_references() {
    let dir = tempfile::tempdir().unwrap();
    image::RgbaImage::from_pixel(2, 2, image::Rgba([200, 100, 50, 0]))
        .save(dir.path().join("leaf.png"))
        .unwrap();
    write(
        dir.path(),
        "quad.obj",
        "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n",
    );
    let s = load_in(
        dir.path(),
        r#"
        <shape type="sphere"><bsdf type="mask"><float name="opacity" value="0.25"/>
            <bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.8"/></bsdf></bsdf></bsdf></shape>
        <shape type="obj"><string name="filename" value="quad.obj"/>
            <bsdf type="mask"><texture name="opacity" type="bitmap"><string name="filename" value="leaf.png"/></texture>
                <bsdf type="diffuse"><texture name="reflectance" type="bitmap"><string name="filename" value="leaf.png"/>
                    <string name="filter_type" value="nearest"/><string name="wrap_mode" value="clamp"/>
                    <boolean name="raw" value="true"/></texture></bsdf></bsdf></shape>"#,
    );
    let sphere = &s.materials[s.spheres[0].material as usize];
    assert_eq!(
        sphere.bsdf,
        Bsdf::Diffuse {
            albedo: Vec3::splat(0.8)
        }
    );
    assert_eq!(sphere.textures.opacity_value, 0.25);
    assert_eq!(
        sphere.textures.alpha_cutoff, None,
        "stochastic, as Mitsuba's mask"
    );
    let quad = &s.materials[s.meshes[0].material as usize].textures;
    let opacity = quad.opacity.as_ref().expect("a textured opacity");
    assert!(opacity.srgb && opacity.channel == Channel::Luminance);
    assert_eq!(quad.alpha_cutoff, None);
    let albedo = quad.albedo.as_ref().expect("a textured reflectance");
    assert!(!albedo.srgb, "raw: linear");
    assert_eq!(
        (albedo.filter, albedo.wrap),
        (TextureFilter::Nearest, Wrap::Clamp)
    );
    // A textured mask on a sphere (no uvs), a mask in a mask, an unknown wrap mode: refused.
    for (body, needle, want) in [
        (
            r#"<shape type="sphere"><bsdf type="mask"><texture name="opacity" type="bitmap"><string name="filename" value="leaf.png"/></texture><bsdf type="diffuse"/></bsdf></shape>"#,
            "<shape",
            "textures meshes",
        ),
        (
            r#"<shape type="sphere"><bsdf type="mask"><bsdf type="mask"><bsdf type="diffuse"/></bsdf></bsdf></shape>"#,
            "<bsdf type=\"mask\"><bsdf",
            "a mask inside a mask",
        ),
        (
            r#"<shape type="obj"><string name="filename" value="quad.obj"/><bsdf type="diffuse"><texture name="reflectance" type="bitmap"><string name="filename" value="leaf.png"/><string name="wrap_mode" value="zero"/></texture></bsdf></shape>"#,
            "<shape",
            "wrap_mode \"zero\"",
        ),
    ] {
        let e = error_in(dir.path(), body);
        assert!(
            e.contains(want) && e.contains(&format!("line {}", line_of(body, needle))),
            "{e}"
        );
    }
}

/// Mitsuba's `checkerboard` texture becomes vkpath's (its two colours exact, as f32) with the texture's
/// `to_uv` as the reference's scale, rotation and offset (Mitsuba applies the 4x4's x-y block and
/// translation: scale(4, 3), then rotate 20 degrees, then translate (0.1, 0.2) is uv' = R S uv + t); a
/// rectangle and a cube carry Mitsuba's uvs (the rectangle's (x + 1, y + 1) / 2, the cube's own mesh);
/// a scalar parameter (a mask's opacity) reads each colour's channel mean with the colours swapped, as
/// Mitsuba 3.9.1's `eval_1` does; a sphere (no uvs), a bump map of a checkerboard and a shearing to_uv
/// are refused at their elements.
#[test]
fn checkerboards_and_to_uv_become_texture_references_on_rectangles_and_cubes() {
    let dir = tempfile::tempdir().unwrap();
    let s = load_in(
        dir.path(),
        r#"
        <shape type="rectangle"><transform name="to_world"><scale value="2"/></transform>
            <bsdf type="diffuse"><texture type="checkerboard" name="reflectance">
                <rgb name="color0" value="0.9, 0.5, 0.1"/><rgb name="color1" value="0.1, 0.2, 0.7"/>
                <transform name="to_uv"><scale x="4" y="3"/><rotate z="1" angle="20"/><translate x="0.1" y="0.2"/></transform>
            </texture></bsdf></shape>
        <shape type="cube"><bsdf type="mask"><texture type="checkerboard" name="opacity">
            <rgb name="color0" value="0.9, 0.6, 0.3"/><float name="color1" value="0.25"/></texture>
            <bsdf type="diffuse"/></bsdf></shape>"#,
    );
    assert_eq!(
        s.meshes.len(),
        2 + 12,
        "a textured rectangle and cube: a mesh per triangle"
    );
    let rect = &s.meshes[0];
    for (p, uv) in rect.positions.iter().zip(&rect.uvs) {
        assert_eq!(
            *uv,
            [(p.x / 2.0 + 1.0) / 2.0, (p.y / 2.0 + 1.0) / 2.0],
            "{p}"
        );
    }
    let albedo = s.materials[rect.material as usize]
        .textures
        .albedo
        .as_ref()
        .expect("textured");
    assert!(albedo.image.checkerboard && !albedo.srgb);
    let bits = |c: [f32; 6]| c.map(f32::to_bits).to_vec();
    assert_eq!(albedo.image.texels, bits([0.9, 0.5, 0.1, 0.1, 0.2, 0.7]));
    assert_eq!(albedo.scale, [4.0, 3.0]);
    assert!(
        (albedo.rotation_deg - 20.0).abs() < 1e-4,
        "{}",
        albedo.rotation_deg
    );
    assert!((albedo.offset[0] - 0.1).abs() < 1e-6 && (albedo.offset[1] - 0.2).abs() < 1e-6);
    // Each cube face's uvs span [0, 1]^2 and every triangle faces outwards.
    for m in &s.meshes[2..] {
        let p = &m.positions;
        let n = (p[1] - p[0]).cross(p[2] - p[0]);
        assert!(n.dot(p[0] + p[1] + p[2]) > 0.0, "outward");
        assert!(
            m.uvs.iter().flatten().all(|&t| t == 0.0 || t == 1.0),
            "{:?}",
            m.uvs
        );
    }
    let opacity = s.materials[s.meshes[2].material as usize]
        .textures
        .opacity
        .as_ref()
        .expect("textured");
    assert_eq!(
        opacity.image.texels,
        bits([0.25, 0.25, 0.25, 0.6, 0.6, 0.6]),
        "swapped means"
    );
    assert_eq!(opacity.channel, Channel::R);
    for (body, needle, want) in [
        (
            r#"<shape type="sphere"><bsdf type="diffuse"><texture type="checkerboard" name="reflectance"/></bsdf></shape>"#,
            "<shape",
            "textures meshes",
        ),
        (
            r#"<shape type="rectangle"><bsdf type="bumpmap"><texture type="checkerboard"/><bsdf type="diffuse"/></bsdf></shape>"#,
            "<texture",
            "of a checkerboard",
        ),
        (
            r#"<shape type="rectangle"><bsdf type="diffuse"><texture type="checkerboard" name="reflectance">
                <transform name="to_uv"><matrix value="1 0.5 0 0  0 1 0 0  0 0 1 0  0 0 0 1"/></transform></texture></bsdf></shape>"#,
            "name=\"to_uv\"",
            "shears",
        ),
    ] {
        let e = error_in(dir.path(), body);
        assert!(
            e.contains(want) && e.contains(&format!("line {}", line_of(body, needle))),
            "{e}"
        );
    }
}

/// Mitsuba's film draws samples on the image only (hdrfilm's `sample_border`, default false): an edge
/// pixel's filter is cut off at the edge. An emitter whose edge crosses the last column of an 8-pixel
/// orthographic view at 0.4 of the pixel: with the default tent (radius 1 px, centred 0.5 px from the
/// edge) the column sees the tent's mass over [-0.1, 0.5] of its cut-off mass over [-1, 0.5],
/// (F(0.5) - F(-0.1)) / F(0.5) = 0.470 / 0.875 = 0.5371 (F the tent's CDF); with sample_border true the
/// whole tent's mass over [-0.1, 1], 0.595. Within 5 standard errors of the column's mean.
#[test]
fn the_film_keeps_samples_on_the_image_unless_sample_border() {
    let dir = tempfile::tempdir().unwrap();
    let tent_cdf = |x: f64| {
        if x < 0.0 {
            0.5 * (1.0 + x) * (1.0 + x)
        } else {
            1.0 - 0.5 * (1.0 - x) * (1.0 - x)
        }
    };
    for (border, want) in [
        ("", (tent_cdf(0.5) - tent_cdf(-0.1)) / tent_cdf(0.5)),
        (
            r#"<boolean name="sample_border" value="true"/>"#,
            1.0 - tent_cdf(-0.1),
        ),
    ] {
        let body = format!(
            r#"
            <integrator type="path"><integer name="max_depth" value="1"/></integrator>
            <sensor type="orthographic">
                <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
                <sampler type="independent"><integer name="sample_count" value="16384"/></sampler>
                <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/>
                    <rfilter type="tent"/>{border}</film>
            </sensor>
            <shape type="rectangle"><transform name="to_world"><scale x="1" y="3"/><translate x="1.85"/></transform>
                <emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>"#
        );
        let s = load_in(dir.path(), &body);
        assert_eq!(s.render.sample_border, !border.is_empty());
        let film = common::render(&s);
        let column: Vec<f64> = (0..8).map(|y| f64::from(film.pixel(7, y)[0])).collect();
        let mean = column.iter().sum::<f64>() / 8.0;
        // Each sample is 0 or 1: a pixel's variance of its mean is p (1 - p) / n.
        let se = (want * (1.0 - want) / (8.0 * 16384.0)).sqrt();
        assert!(
            (mean - want).abs() < 5.0 * se,
            "{border}: {mean} vs {want} (se {se})"
        );
    }
}

/// Mitsuba's `principled` becomes vkpath's (its parameters as given, `specular` through Mitsuba's
/// eta = 2 / (1 - sqrt(0.08 specular)) - 1, Mitsuba's defaults otherwise, one-sided without twosided);
/// `eta` is read instead of specular; spec_trans and anisotropy are refused at their elements. (Its
/// render against Mitsuba 3: docs/scene-format.md.)
#[test]
fn principled_becomes_the_principled_material() {
    let s = load(
        r#"
        <shape type="sphere"><bsdf type="principled">
            <rgb name="base_color" value="0.8, 0.2, 0.1"/><float name="metallic" value="0.3"/>
            <float name="roughness" value="0.4"/><float name="specular" value="0.6"/>
            <float name="spec_tint" value="0.2"/><float name="sheen" value="0.5"/><float name="sheen_tint" value="0.1"/>
            <float name="clearcoat" value="0.7"/><float name="clearcoat_gloss" value="0.8"/><float name="flatness" value="0.25"/>
            <float name="main_specular_sampling_rate" value="2"/>
        </bsdf></shape>
        <shape type="sphere"><point name="center" value="2, 0, 0"/><bsdf type="twosided"><bsdf type="principled"><float name="eta" value="1.33"/></bsdf></bsdf></shape>"#,
    );
    let m = &s.materials[s.spheres[0].material as usize];
    let eta = (2.0 / (1.0 - (0.08f64 * 0.6).sqrt()) - 1.0) as f32;
    assert_eq!(
        m.bsdf,
        Bsdf::Principled {
            base_color: Vec3::new(0.8, 0.2, 0.1),
            roughness: 0.4,
            anisotropic: 0.0,
            metallic: 0.3,
            eta,
            spec_tint: 0.2,
            sheen: 0.5,
            sheen_tint: 0.1,
            clearcoat: 0.7,
            clearcoat_gloss: 0.8,
            flatness: 0.25,
        }
    );
    assert!(m.textures.one_sided);
    let m2 = &s.materials[s.spheres[1].material as usize];
    assert!(!m2.textures.one_sided);
    match m2.bsdf {
        Bsdf::Principled {
            base_color,
            roughness,
            metallic,
            eta,
            ..
        } => {
            assert_eq!(
                (base_color, roughness, metallic, eta),
                (Vec3::splat(0.5), 0.5, 0.0, 1.33)
            )
        }
        ref b => panic!("{b:?}"),
    }
    let dir = tempfile::tempdir().unwrap();
    for (body, needle, want) in [
        (
            r#"<shape type="sphere"><bsdf type="principled"><float name="spec_trans" value="0.5"/></bsdf></shape>"#,
            "spec_trans",
            "specular transmission",
        ),
        (
            r#"<shape type="sphere"><bsdf type="principled"><float name="anisotropic" value="0.5"/></bsdf></shape>"#,
            "anisotropic",
            "tangent frame",
        ),
        (
            r#"<shape type="sphere"><bsdf type="principled"><float name="specular" value="0.5"/><float name="eta" value="1.5"/></bsdf></shape>"#,
            "name=\"eta\"",
            "both specular and eta",
        ),
    ] {
        let e = error_in(dir.path(), body);
        assert!(
            e.contains(want) && e.contains(&format!("line {}", line_of(body, needle))),
            "{e}"
        );
    }
}

/// Mitsuba's reflecting BSDFs scatter on their front face only unless wrapped in twosided (a mask
/// around a twosided too); its dielectrics on both; a shape without a BSDF gets Mitsuba's one-sided
/// default diffuse. vkpath's one_sided says the same.
#[test]
fn bsdfs_without_twosided_are_one_sided() {
    let s = load(
        r#"<shape type="sphere"><bsdf type="diffuse"/></shape>
           <shape type="sphere"><bsdf type="twosided"><bsdf type="diffuse"/></bsdf></shape>
           <shape type="sphere"><bsdf type="dielectric"/></shape>
           <shape type="sphere"><bsdf type="thindielectric"/></shape>
           <shape type="sphere"><bsdf type="mask"><bsdf type="twosided"><bsdf type="roughplastic"/></bsdf></bsdf></shape>
           <shape type="sphere"><bsdf type="mask"><bsdf type="conductor"/></bsdf></shape>
           <shape type="sphere"/>"#,
    );
    let one_sided: Vec<bool> = s
        .spheres
        .iter()
        .map(|sp| s.materials[sp.material as usize].textures.one_sided)
        .collect();
    assert_eq!(one_sided, [true, false, false, false, false, true, true]);
    // twosided with two BSDFs: the first is the material, the second its back (a material of its own).
    let s = load(
        r#"<shape type="sphere"><bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.1, 0.1"/></bsdf>
               <bsdf type="conductor"/></bsdf></shape>"#,
    );
    let front = &s.materials[s.spheres[0].material as usize];
    assert!(!front.textures.one_sided);
    assert_eq!(
        front.bsdf,
        Bsdf::Diffuse {
            albedo: Vec3::new(0.8, 0.1, 0.1)
        }
    );
    let back = &s.materials[front.textures.back.expect("a back material") as usize];
    // (Mitsuba's default conductor, material "none", reflects everything: vkpath's white mirror.)
    assert_eq!(back.bsdf, Bsdf::Mirror { tint: Vec3::ONE });
    let body = r#"<shape type="sphere"><bsdf type="twosided"><bsdf type="diffuse"/><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf></shape>"#;
    assert!(error_in(&std::env::temp_dir(), body).contains("one or two nested BSDFs"));
    // blendbsdf: the first BSDF's material blends with a material of the second's at the weight; a
    // blend of two one-sided BSDFs is one-sided, of two two-sided ones two-sided.
    let s = load(
        r#"<shape type="sphere"><bsdf type="blendbsdf"><float name="weight" value="0.3"/>
               <bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.1, 0.1"/></bsdf><bsdf type="conductor"/></bsdf></shape>
           <shape type="sphere"><bsdf type="blendbsdf"><bsdf type="dielectric"/><bsdf type="twosided"><bsdf type="diffuse"/></bsdf></bsdf></shape>"#,
    );
    let first = &s.materials[s.spheres[0].material as usize];
    assert_eq!(first.textures.blend_weight, 0.3);
    assert!(first.textures.one_sided);
    let second = &s.materials[first.textures.blend.expect("a blend") as usize];
    assert_eq!(second.bsdf, Bsdf::Mirror { tint: Vec3::ONE });
    let glassy = &s.materials[s.spheres[1].material as usize];
    assert!(!glassy.textures.one_sided && glassy.textures.blend_weight == 0.5);
    for (body, want) in [
        (
            r#"<shape type="sphere"><bsdf type="blendbsdf"><bsdf type="diffuse"/><bsdf type="dielectric"/></bsdf></shape>"#,
            "a two-sided and a one-sided BSDF",
        ),
        (
            r#"<shape type="sphere"><bsdf type="blendbsdf"><bsdf type="diffuse"/></bsdf></shape>"#,
            "two nested BSDFs",
        ),
        (
            r#"<shape type="sphere"><bsdf type="blendbsdf"><float name="weight" value="1.5"/><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf></shape>"#,
            "in [0, 1]",
        ),
    ] {
        let e = error_in(&std::env::temp_dir(), body);
        assert!(e.contains(want) && e.contains("line"), "{e}");
    }
}

#[test]
fn approximations_are_refused_unless_lenient_and_model_differences_are_warnings() {
    let dir = tempfile::tempdir().unwrap();
    // Mitsuba's default, full Oren-Nayar roughdiffuse: refused, or read with a warning.
    {
        let body = r#"<shape type="sphere"><bsdf type="roughdiffuse"/></shape>"#;
        let e = error_in(dir.path(), body);
        assert!(e.contains("--xml-lenient"), "{e}");
        let p = write(dir.path(), "scene.xml", &scene_xml(body));
        let s = Scene::load_with_options(&p, None, true).unwrap();
        assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    }
    // Mitsuba's default Beckmann distribution and linear plastic are read as such.
    let s = load(
        r#"<shape type="sphere"><bsdf type="roughconductor"><string name="material" value="Al"/></bsdf></shape>
           <shape type="sphere"><bsdf type="roughdielectric"><string name="distribution" value="ggx"/></bsdf></shape>"#,
    );
    let roughness = |i: usize| match s.materials[s.spheres[i].material as usize].bsdf {
        Bsdf::Conductor { roughness, .. } | Bsdf::Dielectric { roughness, .. } => roughness,
        ref other => panic!("{other:?}"),
    };
    assert!(roughness(0).beckmann && !roughness(1).beckmann);
    assert!(
        (roughness(0).u - 0.1f32.sqrt()).abs() < 1e-6,
        "Mitsuba's default alpha 0.1"
    );
    let s = load(r#"<shape type="sphere"><bsdf type="plastic"/></shape>"#);
    assert!(matches!(
        s.materials[s.spheres[0].material as usize].bsdf,
        Bsdf::Plastic {
            nonlinear: false,
            ..
        }
    ));
    let s = load(
        r#"<shape type="sphere"><bsdf type="roughplastic"><string name="distribution" value="ggx"/>
             <boolean name="nonlinear" value="true"/><float name="alpha" value="0.25"/></bsdf></shape>"#,
    );
    // Mitsuba's rough-coat model is vkpath's: no warning.
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    // Lenient: unknown elements, plugins and parameters are skipped, each with a warning naming it.
    let p = write(
        dir.path(),
        "lenient.xml",
        &scene_xml(
            r#"<medium type="homogeneous"/>
               <shape type="cylinder"/>
               <shape type="sphere"><float name="wobble" value="1"/></shape>
               <shape type="sphere"><bsdf type="measured"/></shape>
               <fancy/>"#,
        ),
    );
    let s = Scene::load_with_options(&p, None, true).unwrap();
    assert_eq!(s.spheres.len(), 2);
    assert_eq!(s.warnings.len(), 5, "{:#?}", s.warnings);
    for (w, what) in s
        .warnings
        .iter()
        .zip(["fancy", "medium", "cylinder", "wobble", "measured"])
    {
        assert!(w.contains(what) && w.contains("lenient.xml, line"), "{w}");
    }
}

#[test]
fn defaults_includes_and_references() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("parts")).unwrap();
    write(
        dir.path(),
        "parts/materials.xml",
        r#"<scene version="3.0.0">
             <bsdf type="diffuse" id="red"><rgb name="reflectance" value="$red, 0, 0"/></bsdf>
             <include filename="more.xml"/>
           </scene>"#,
    );
    // Relative to the including file (parts/); a root that is not a <scene> is one element.
    write(
        dir.path(),
        "parts/more.xml",
        r#"<bsdf type="diffuse" id="blue"><rgb name="reflectance" value="0 0 0.5"/></bsdf>"#,
    );
    let s = load_in(
        dir.path(),
        r#"<default name="red" value="0.7"/>
           <default name="red" value="0.1"/>
           <default name="r" value="2"/>
           <shape type="sphere"><ref name="bsdf" id="blue"/><float name="radius" value="$r"/></shape>
           <include filename="parts/materials.xml"/>
           <shape type="sphere"><ref id="red"/></shape>"#,
    );
    // A reference to an object defined later (in an include) is resolved; the first <default> wins;
    // $r is substituted, $red is not taken for $r (longest names first).
    assert_eq!(s.spheres[0].radius, 2.0);
    let albedo = |i: usize| match s.materials[s.spheres[i].material as usize].bsdf {
        Bsdf::Diffuse { albedo } => albedo,
        b => panic!("{b:?}"),
    };
    assert_eq!(albedo(0), Vec3::new(0.0, 0.0, 0.5));
    assert_eq!(albedo(1), Vec3::new(0.7, 0.0, 0.0));
}

/// `-D name=value` (ImportOptions::defines) sets `<default>` parameters as Mitsuba's command line does:
/// over the file's `<default>`, the first of a repeated name winning; a name the file never mentions is a
/// warning; one the file uses without a `<default>` is defined by it. On the command line: render takes
/// it, and refuses it for a TOML scene (exit 2, naming the flag) or without the `=`.
#[test]
fn command_line_defines_set_xml_default_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let body = r#"<default name="integrator" value="my_guiding_integrator"/>
           <default name="depth" value="8"/>
           <integrator type="$integrator"><integer name="max_depth" value="$depth"/></integrator>
           <shape type="sphere"><float name="radius" value="$r"/></shape>"#;
    let p = write(dir.path(), "scene.xml", &scene_xml(body));
    let with = |defines: &[(&str, &str)]| {
        let options = ImportOptions {
            defines: defines
                .iter()
                .map(|(n, v)| (n.to_string(), v.to_string()))
                .collect(),
            ..ImportOptions::default()
        };
        Scene::load_with(&p, &options)
    };
    // As written: the custom integrator is refused, and $r has no <default>.
    let e = with(&[]).expect_err("refused").to_string();
    assert!(
        e.contains("$r") || e.contains("my_guiding_integrator"),
        "{e}"
    );
    let e = with(&[("r", "2")]).expect_err("refused").to_string();
    assert!(e.contains("my_guiding_integrator"), "{e}");
    // -D over <default>; the first -D of a name wins; max_depth 8 is 7 bounces, 4 is 3.
    let s = with(&[("integrator", "path"), ("r", "2"), ("r", "5")]).unwrap();
    assert_eq!(s.spheres[0].radius, 2.0);
    assert_eq!(s.render.max_bounces, 7);
    assert!(
        s.warnings.iter().all(|w| !w.contains("-D")),
        "{:?}",
        s.warnings
    );
    let s = with(&[("integrator", "path"), ("r", "2"), ("depth", "4")]).unwrap();
    assert_eq!(s.render.max_bounces, 3);
    // A -D the file neither declares nor uses (a misspelling) is refused naming it and the names the
    // file has (cli.md; Mitsuba 3: "Found unused parameters").
    let e = with(&[
        ("integrator", "path"),
        ("r", "2"),
        ("depth", "4"),
        ("nmae", "x"),
    ])
    .expect_err("an unused -D")
    .to_string();
    assert!(
        e.contains("-D nmae=") && e.contains("scene.xml") && e.contains("depth"),
        "{e}"
    );

    let out = dir.path().join("out.exr");
    let ok = run(
        dir.path(),
        &[
            "render",
            p.to_str().unwrap(),
            "-D",
            "integrator=path",
            "-D",
            "r=1",
            "--spp",
            "1",
            "--width",
            "8",
            "--height",
            "4",
            "--quiet",
            "-o",
            out.to_str().unwrap(),
        ],
    );
    assert_eq!(
        ok.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    let toml = write(
        dir.path(),
        "scene.toml",
        "[camera]\nposition = [0.0, 0.0, 5.0]\n",
    );
    for (args, needle) in [
        (vec!["render", toml.to_str().unwrap(), "-D", "r=1"], "-D r="),
        (vec!["render", p.to_str().unwrap(), "-D", "r"], "NAME=VALUE"),
        (
            vec![
                "render",
                p.to_str().unwrap(),
                "-D",
                "integrator=path",
                "-D",
                "r=1",
                "-D",
                "bogus=1",
            ],
            "-D bogus=",
        ),
    ] {
        let o = run(dir.path(), &args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains(needle), "{err}");
    }
}

/// An area emitter declared at the top level with an id and referenced from a shape (as Mitsuba's own
/// cbox-rgb.xml does) emits through that shape; without an id it is still refused (it belongs to no shape).
#[test]
fn a_top_level_area_emitter_with_an_id_emits_through_the_shapes_that_refer_to_it() {
    let s = load(
        r#"<shape type="sphere"><ref id="glow"/></shape>
           <shape type="sphere"><point name="center" x="3" y="0" z="0"/></shape>
           <emitter type="area" id="glow"><rgb name="radiance" value="3, 2, 1"/></emitter>"#,
    );
    let lamp = &s.materials[s.spheres[0].material as usize];
    let e = lamp.emission.expect("the referring sphere emits");
    assert_eq!(e.radiance, Vec3::new(3.0, 2.0, 1.0));
    assert!(
        s.materials[s.spheres[1].material as usize]
            .emission
            .is_none()
    );
    let dir = tempfile::tempdir().unwrap();
    let body = r#"<shape type="sphere"/>
           <emitter type="area"><rgb name="radiance" value="3, 2, 1"/></emitter>"#;
    let e = error_in(dir.path(), body);
    assert!(e.contains("area emitter directly in the scene"), "{e}");
    assert!(
        e.contains(&format!("line {}", line_of(body, "<emitter"))),
        "{e}"
    );
}

/// Spectra given by wavelengths (Mitsuba's cbox.xml) become the RGB colours Mitsuba's RGB variants load:
/// a reflectance weighted by D65 and clamped to [0, 1] (a flat one is grey), an emitter's radiance
/// unweighted and unclamped above (a flat one keeps its luminance, sRGB's Y row).
#[test]
fn spectra_given_by_wavelengths_become_mitsubas_rgb() {
    let s = load(
        r#"<shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" value="360:0.5, 830:0.5"/></bsdf></shape>
           <shape type="sphere"><point name="center" x="3" y="0" z="0"/>
               <bsdf type="diffuse"><spectrum name="reflectance" value="400:3, 700:3"/></bsdf>
               <emitter type="area"><spectrum name="radiance" value="360:4, 830:4"/></emitter></shape>"#,
    );
    let albedo = |i: usize| match s.materials[s.spheres[i].material as usize].bsdf {
        Bsdf::Diffuse { albedo } => albedo,
        ref other => panic!("{other:?}"),
    };
    let grey = albedo(0);
    assert!(
        (grey.max_element() - grey.min_element()) < 2e-3 && (grey.x - 0.5).abs() < 2e-3,
        "{grey}"
    );
    assert_eq!(albedo(1), Vec3::ONE, "a reflectance of 3 clamps to 1");
    let e = s.materials[s.spheres[1].material as usize]
        .emission
        .expect("emits")
        .radiance;
    let y = 0.212671 * e.x + 0.715160 * e.y + 0.072169 * e.z;
    assert!((y - 4.0).abs() < 1e-4, "{e}: luminance {y}");
    let dir = tempfile::tempdir().unwrap();
    for bad in ["400:0.5", "500:0.5, 400:0.6", "400:0.5, 500:x"] {
        let body = format!(
            r#"<shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" value="{bad}"/></bsdf></shape>"#
        );
        let e = error_in(dir.path(), &body);
        assert!(
            e.contains("wavelength:value pairs")
                && e.contains(&format!("line {}", line_of(&body, "<spectrum"))),
            "{e}"
        );
    }
}

/// `<spectrum filename="...">` (Mitsuba's spectral data files: a `wavelength value` pair a line, `#`
/// comments) gives the colour of the same pairs written inline, bit for bit, as a reflectance and as a
/// radiance; a file that is not one, or is missing, is refused naming the file (and its line) and the
/// element's line in the scene.
#[test]
fn spectra_from_files_are_the_inline_spectra() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(
        d,
        "refl.spd",
        "# a measured reflectance\n400 0.12\n\n500 0.55\n600   0.31\n700 0.8\n",
    );
    write(d, "light.spd", "360 2\n830 5\n");
    let from_file = load_in(
        d,
        r#"<shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" filename="refl.spd"/></bsdf>
               <emitter type="area"><spectrum name="radiance" filename="light.spd"/></emitter></shape>"#,
    );
    let inline = load(
        r#"<shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" value="400:0.12, 500:0.55, 600:0.31, 700:0.8"/></bsdf>
               <emitter type="area"><spectrum name="radiance" value="360:2, 830:5"/></emitter></shape>"#,
    );
    assert_eq!(from_file.materials, inline.materials);
    let albedo = match from_file.materials[0].bsdf {
        Bsdf::Diffuse { albedo } => albedo,
        ref other => panic!("{other:?}"),
    };
    assert!(
        albedo.min_element() > 0.05 && albedo.max_element() < 0.9,
        "{albedo}"
    );
    for (file, text, words) in [
        (
            "three.spd",
            "400 0.5 1\n500 0.6\n",
            vec!["three.spd, line 1", "one wavelength and one value"],
        ),
        (
            "down.spd",
            "500 0.5\n# note\n400 0.6\n",
            vec!["down.spd, line 3", "does not increase"],
        ),
        ("one.spd", "400 0.5\n", vec!["one.spd", "fewer than two"]),
        (
            "word.spd",
            "400 x\n500 0.6\n",
            vec!["word.spd, line 1", "not two numbers"],
        ),
    ] {
        write(d, file, text);
        let body = format!(
            r#"<shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" filename="{file}"/></bsdf></shape>"#
        );
        let e = error_in(d, &body);
        assert!(
            words.iter().all(|w| e.contains(w))
                && e.contains(&format!("line {}", line_of(&body, "<spectrum"))),
            "{e}"
        );
    }
    let body = r#"<shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" filename="gone.spd"/></bsdf></shape>"#;
    let e = error_in(d, body);
    assert!(e.contains("gone.spd") && e.contains("not found"), "{e}");
}

/// Every refusal: the file, the line, the element and what vkpath reads instead.
#[test]
fn errors_name_the_file_the_line_and_the_element() {
    let dir = tempfile::tempdir().unwrap();
    let check = |body: &str, needle: &str, element: &str, words: &[&str]| {
        let e = error_in(dir.path(), body);
        let line = line_of(body, needle);
        assert!(e.contains("scene.xml"), "{e}");
        assert!(
            e.contains(&format!("line {line}")),
            "line {line} expected: {e}"
        );
        assert!(e.contains(element), "{element} expected: {e}");
        for w in words {
            assert!(e.contains(w), "{w:?} expected: {e}");
        }
        assert!(!e.contains('\n'), "one paragraph: {e}");
    };
    check(
        "<shape type=\"sphere\">\n<bsdf type=\"measured\"/></shape>",
        "measured",
        "<bsdf type=\"measured\">",
        &["diffuse, conductor"],
    );
    check(
        "<shape type=\"cylinder\"/>",
        "cylinder",
        "<shape type=\"cylinder\">",
        &["sphere, rectangle"],
    );
    check(
        "<shape type=\"sphere\">\n<float name=\"wobble\" value=\"1\"/></shape>",
        "wobble",
        "<float name=\"wobble\">",
        &["\"wobble\"", "\"center\""],
    );
    check(
        "<shape type=\"sphere\">\n<float name=\"radius\" value=\"big\"/></shape>",
        "big",
        "<float name=\"radius\">",
        &["not a number"],
    );
    check(
        "<shape type=\"sphere\">\n<rgb name=\"radius\" value=\"1 2\"/></shape>",
        "rgb",
        "<rgb name=\"radius\">",
        &["one or three"],
    );
    check(
        "<shape type=\"sphere\">\n<ref id=\"nowhere\"/></shape>",
        "nowhere",
        "<ref id=\"nowhere\">",
        &["no object"],
    );
    check(
        "<include filename=\"missing.xml\"/>",
        "missing",
        "<include>",
        &["missing.xml", "not found"],
    );
    check("<fancy/>", "fancy", "<fancy>", &["--xml-lenient"]);
    check(
        "<shape type=\"sphere\" colour=\"red\"/>",
        "colour",
        "<shape type=\"sphere\">",
        &["\"colour\""],
    );
    check(
        "<shape type=\"sphere\">\n<float name=\"radius\" value=\"$size\"/></shape>",
        "size",
        "<float name=\"radius\">",
        &["<default"],
    );
    // An error of the TOML reader is reported at the XML element it came from.
    check(
        "<shape type=\"sphere\">\n<bsdf type=\"diffuse\">\n<rgb name=\"reflectance\" value=\"2\"/></bsdf></shape>",
        "<bsdf type=\"diffuse\">",
        "<bsdf type=\"diffuse\">",
        &["albedo"],
    );
    check(
        "<shape type=\"sphere\">\n<float name=\"radius\" value=\"-1\"/></shape>",
        "-1",
        "<float name=\"radius\">",
        &["radius"],
    );
    check(
        "<shape type=\"sphere\">\n<emitter type=\"area\">\n<rgb name=\"radiance\" value=\"-1\"/></emitter></shape>",
        "<rgb name=\"radiance\"",
        "<rgb name=\"radiance\">",
        &["negative"],
    );
    check(
        "<shape type=\"obj\">\n<string name=\"filename\" value=\"absent.obj\"/></shape>",
        "absent.obj",
        "<string name=\"filename\">",
        &["absent.obj"],
    );
    // Malformed XML: the line of the syntax error.
    let p = write(
        dir.path(),
        "bad.xml",
        "<scene version=\"3.0.0\">\n<shape type=\"sphere\">\n</scene>\n",
    );
    let e = Scene::load(&p).unwrap_err().to_string();
    assert!(
        e.contains("bad.xml, line 3") && e.contains("well-formed"),
        "{e}"
    );
    // A cyclic include names both files and the include's line.
    write(
        dir.path(),
        "a.xml",
        "<scene version=\"3.0.0\">\n\n<include filename=\"b.xml\"/>\n</scene>\n",
    );
    write(
        dir.path(),
        "b.xml",
        "<scene version=\"3.0.0\">\n<include filename=\"a.xml\"/>\n</scene>\n",
    );
    let p = write(
        dir.path(),
        "main.xml",
        &scene_xml("<include filename=\"a.xml\"/>"),
    );
    let e = Scene::load(&p).unwrap_err().to_string();
    assert!(
        e.contains("b.xml, line 2") && e.contains("a.xml") && e.contains("cycle"),
        "{e}"
    );
    // No sensor; a root that is not a scene; no version.
    let p = write(
        dir.path(),
        "nosensor.xml",
        "<scene version=\"3.0.0\">\n</scene>\n",
    );
    let e = Scene::load(&p).unwrap_err().to_string();
    assert!(
        e.contains("nosensor.xml, line 1") && e.contains("no <sensor>"),
        "{e}"
    );
    let p = write(dir.path(), "noversion.xml", "<scene>\n</scene>\n");
    let e = Scene::load(&p).unwrap_err().to_string();
    assert!(e.contains("\"version\""), "{e}");
}

/// The XML that Mitsuba's `mitsuba.xml.dict_to_xml` writes for the dicts of
/// benches/peers/mitsuba_scene.py: `$spp` defaults, ids on top-level objects, `<ref name="bsdf">`, points
/// as x/y/z attributes, the sensor's transform decomposed into rotations and a translation, other
/// transforms as matrices, `%f` numbers, output format strings.
#[test]
fn the_xml_mitsuba_writes_from_a_dict_is_read() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "triangles-0.obj",
        "v -1 0 -1\nv 1 0 -1\nv 0 0 1\nf 1 2 3\n",
    );
    let xml = r#"<scene version="2.1.0">

<!-- Defaults, these can be set via the command line: -Darg=value -->


	<default name="spp" value="64"/>
	<default name="resx" value="48"/>
	<default name="resy" value="32"/>

<!-- Camera and Rendering Parameters -->

	<integrator type="path" id="integrator">
		<integer name="max_depth" value="6"/>
		<integer name="rr_depth" value="3"/>
		<boolean name="hide_emitters" value="false"/>
	</integrator>
	<sensor type="perspective" id="sensor">
		<float name="fov" value="39.597752"/>
		<string name="fov_axis" value="x"/>
		<transform name="to_world">
			<rotate y="1" angle="180.00000500895632"/>
			<translate value="0.000000 1.000000 6.800000"/>
		</transform>
		<float name="near_clip" value="0.001000"/>
		<float name="far_clip" value="1000000.000000"/>
		<sampler type="independent">
			<integer name="sample_count" value="$spp"/>
		</sampler>
		<film type="hdrfilm">
			<integer name="width" value="$resx"/>
			<integer name="height" value="$resy"/>
			<rfilter type="box"/>
			<string name="pixel_format" value="rgb"/>
			<string name="component_format" value="float32"/>
		</film>
	</sensor>

<!-- Materials -->

	<bsdf type="twosided" id="bsdf-white">
		<bsdf type="diffuse">
			<rgb value="0.800000 0.800000 0.800000" name="reflectance"/>
		</bsdf>
	</bsdf>
	<bsdf type="diffuse" id="bsdf-lamp">
		<rgb value="0.000000 0.000000 0.000000" name="reflectance"/>
	</bsdf>
	<bsdf type="twosided" id="bsdf-gold">
		<bsdf type="roughconductor">
			<string name="distribution" value="ggx"/>
			<float name="alpha" value="0.040000"/>
			<boolean name="sample_visible" value="true"/>
			<texture type="srgb" name="eta">
				<point name="color" x="0.2" y="0.9" z="1.1"/>
				<boolean name="unbounded" value="true"/>
			</texture>
			<texture type="srgb" name="k">
				<point name="color" x="3.9" y="2.4" z="2.1"/>
				<boolean name="unbounded" value="true"/>
			</texture>
		</bsdf>
	</bsdf>

<!-- Emitters -->

	<emitter type="point" id="light-0">
		<point name="position" x="-1.0" y="4.0" z="2.0"/>
		<rgb value="2.000000 2.000000 2.000000" name="intensity"/>
	</emitter>
	<emitter type="directional" id="light-1">
		<point name="direction" x="0.0" y="-1.0" z="0.0"/>
		<rgb value="3.000000 3.000000 3.000000" name="irradiance"/>
	</emitter>
	<shape type="sphere" id="light-2">
		<point name="center" x="0.0" y="3.0" z="0.0"/>
		<float name="radius" value="0.250000"/>
		<bsdf type="diffuse">
			<rgb value="0.000000 0.000000 0.000000" name="reflectance"/>
		</bsdf>
		<emitter type="area">
			<rgb value="12.000000 12.000000 12.000000" name="radiance"/>
		</emitter>
	</shape>
	<emitter type="constant" id="environment">
		<rgb value="0.100000 0.100000 0.100000" name="radiance"/>
	</emitter>

<!-- Shapes -->

	<shape type="sphere" id="sphere-000">
		<point name="center" x="0.0" y="0.5" z="0.0"/>
		<float name="radius" value="0.500000"/>
		<ref id="bsdf-gold" name="bsdf"/>
	</shape>
	<shape type="obj" id="triangles-0">
		<string name="filename" value="triangles-0.obj"/>
		<boolean name="face_normals" value="true"/>
		<ref id="bsdf-white" name="bsdf"/>
	</shape>
</scene>
"#;
    let p = write(dir.path(), "from_dict.xml", xml);
    let s = Scene::load(&p).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        (s.image.width, s.image.height, s.render.samples),
        (48, 32, 64)
    );
    assert_eq!(s.render.max_bounces, 5);
    assert_close(s.camera.position, Vec3::new(0.0, 1.0, 6.8));
    assert_close(s.camera.look_at, Vec3::new(0.0, 1.0, 5.8));
    assert_close(s.camera.up, Vec3::Y);
    assert!((f64::from(s.camera.fov_deg) - 39.597752).abs() < 1e-5);
    assert_eq!(s.spheres.len(), 2);
    assert_eq!(s.meshes.len(), 1);
    assert_eq!(s.lights.len(), 2);
    assert_eq!(s.environment.radiance, Vec3::splat(0.1));
    let gold = s.materials[s.spheres[1].material as usize].bsdf;
    assert_eq!(
        gold,
        Bsdf::Conductor {
            fresnel: ConductorFresnel::Complex {
                eta: Vec3::new(0.2, 0.9, 1.1),
                k: Vec3::new(3.9, 2.4, 2.1)
            },
            roughness: Roughness::isotropic(0.2),
            tint: Vec3::ONE,
        }
    );
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

/// The same scene as Mitsuba XML and as hand-written vkpath TOML: the same scene, the same bits.
#[test]
fn an_xml_scene_renders_the_bits_of_its_hand_written_toml() {
    let dir = tempfile::tempdir().unwrap();
    let xml = scene_xml(
        r#"
        <sensor type="perspective">
            <float name="fov" value="50"/>
            <transform name="to_world"><lookat origin="0, 1, 4" target="0, 0.5, 0" up="0, 1, 0"/></transform>
            <sampler type="independent"><integer name="sample_count" value="16"/><integer name="seed" value="7"/></sampler>
            <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="24"/><rfilter type="box"/></film>
        </sensor>
        <integrator type="path"><integer name="max_depth" value="4"/></integrator>
        <bsdf type="twosided" id="white"><bsdf type="diffuse"><rgb name="reflectance" value="0.8"/></bsdf></bsdf>
        <shape type="rectangle">
            <transform name="to_world"><matrix value="2 0 0 0  0 0 2 0  0 -2 0 0  0 0 0 1"/></transform>
            <ref id="white"/>
        </shape>
        <shape type="sphere"><point name="center" value="0, 0.5, 0"/><float name="radius" value="0.5"/>
            <bsdf type="roughconductor"><string name="material" value="Au"/><string name="distribution" value="ggx"/><float name="alpha" value="0.25"/></bsdf>
        </shape>
        <shape type="sphere"><point name="center" value="1, 2, 1"/><float name="radius" value="0.25"/>
            <bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf>
            <emitter type="area"><rgb name="radiance" value="10"/></emitter>
        </shape>
        <emitter type="point"><point name="position" value="-1, 2, 1"/><rgb name="intensity" value="2"/></emitter>
        <emitter type="constant"><rgb name="radiance" value="0.2"/></emitter>"#,
    );
    let power = (8.0 * std::f64::consts::PI) as f32;
    let toml = format!(
        r#"[camera]
position = [0, 1, 4]
look_at = [0, 0.5, 0]
up = [0, 1, 0]
fov = 50
[image]
width = 32
height = 24
gamma = "srgb"
[render]
samples = 16
max_bounces = 3
seed = 7
sampler = "independent"
filter = "box"
sample_border = false
[environment]
radiance = [0.2, 0.2, 0.2]
[materials]
white = {{ type = "diffuse", albedo = [0.8, 0.8, 0.8] }}
shape1-sphere = {{ type = "conductor", preset = "gold", roughness = 0.5, one_sided = true }}
shape2-sphere = {{ type = "diffuse", albedo = [0, 0, 0], emission = [10, 10, 10], one_sided = true }}
[[triangle]]
vertices = [[-2, 0, 2], [2, 0, 2], [2, 0, -2]]
material = "white"
[[triangle]]
vertices = [[-2, 0, 2], [2, 0, -2], [-2, 0, -2]]
material = "white"
[[sphere]]
center = [0, 0.5, 0]
radius = 0.5
material = "shape1-sphere"
[[sphere]]
center = [1, 2, 1]
radius = 0.25
material = "shape2-sphere"
[[light]]
type = "point"
position = [-1, 2, 1]
power = {power:?}
color = [1, 1, 1]
"#
    );
    let from_xml =
        Scene::load(&write(dir.path(), "scene.xml", &xml)).unwrap_or_else(|e| panic!("{e}"));
    let by_hand =
        Scene::load(&write(dir.path(), "scene.toml", &toml)).unwrap_or_else(|e| panic!("{e}"));
    let strip = |s: &Scene| Scene {
        path: None,
        ..s.clone()
    };
    assert_eq!(strip(&from_xml), strip(&by_hand));
    let (a, b) = (common::render(&from_xml), common::render(&by_hand));
    assert!(a.mean.iter().any(|p| p[1] > 0.0), "the image is not black");
    let bits = |f: &vkpath::Film| {
        f.mean
            .iter()
            .flat_map(|p| p.map(f32::to_bits))
            .collect::<Vec<_>>()
    };
    assert!(bits(&a) == bits(&b), "the renders differ");
}

/// The round trip (issue 15): every course scene and the Cornell box, written as Mitsuba 3 XML by Mitsuba's own
/// `dict_to_xml` from the translation benches/peers uses (scenes/mitsuba/make_xml.py, which also has
/// Mitsuba load each file), read back by vkpath, renders the same bits as the TOML scene it came from
/// with the box filter (the filter the translation needs). Rendered at 48x32, 4 spp: the bits, not the
/// convergence, are what is checked.
#[test]
fn the_course_scenes_round_trip_through_mitsuba_xml_to_the_same_bits() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let small = |mut s: Scene| {
        s.image.width = 48;
        s.image.height = 32;
        s.render.samples = 4;
        s
    };
    let bits = |f: &vkpath::Film| {
        f.mean
            .iter()
            .flat_map(|p| p.map(f32::to_bits))
            .collect::<Vec<_>>()
    };
    let names = [
        "01-sphere",
        "02-lambert",
        "03-shadows",
        "04-gamma",
        "05-mirror",
        "06-glass",
        "07-indirect",
        "08-samples",
        "09-antialiasing",
        "10-soft-shadows",
        "11-depth-of-field",
        "12-triangle",
        "course",
        "cornell-box",
    ];
    for name in names {
        let mut toml = Scene::load(&root.join(format!("scenes/{name}.toml"))).unwrap();
        toml.render.filter = Filter::Box;
        // The XMLs were written with Mitsuba's independent sampler, which reads as vkpath's independent
        // sampler (vkpath's own default is Sobol').
        toml.render.sampler = Sampler::Independent;
        let xml_path = root.join(format!("scenes/mitsuba/{name}.xml"));
        let xml = Scene::load(&xml_path).unwrap_or_else(|e| panic!("{name}.xml: {e}"));
        assert!(xml.warnings.is_empty(), "{name}.xml: {:?}", xml.warnings);
        assert_eq!(xml.render.sampler, Sampler::Independent, "{name}");
        assert_eq!(
            (xml.render.max_bounces, xml.render.samples),
            (toml.render.max_bounces, toml.render.samples),
            "{name}: depth or samples"
        );
        let (a, b) = (common::render(&small(xml)), common::render(&small(toml)));
        assert!(a.average() > 0.0, "{name}: black image");
        assert!(
            bits(&a) == bits(&b),
            "{name}: the XML renders other bits than the TOML"
        );
    }
}

/// `vkpath convert scene.xml -o out.toml` writes the TOML with paths relative to the output, and that
/// TOML loads as the same scene.
#[test]
fn convert_writes_the_toml_of_an_xml_scene() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "tri.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    );
    let xml = write(
        dir.path(),
        "scene.xml",
        &scene_xml(
            r#"<shape type="obj"><string name="filename" value="tri.obj"/></shape><shape type="cube"/>"#,
        ),
    );
    std::fs::create_dir(dir.path().join("out")).unwrap();
    let out = dir.path().join("out/scene.toml");
    let status = run(
        dir.path(),
        &[
            "convert",
            xml.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ],
    );
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.contains("obj       = \"../tri.obj\""), "{text}");
    let converted = Scene::load(&out).unwrap();
    let direct = Scene::load(&xml).unwrap();
    assert_eq!(converted.triangles, direct.triangles);
    assert_eq!(converted.meshes.len(), direct.meshes.len());
    assert_eq!(converted.camera, direct.camera);
    // A bad scene: exit status 2 and no output.
    let bad = write(
        dir.path(),
        "bad.xml",
        &scene_xml("<shape type=\"cylinder\"/>"),
    );
    let out2 = dir.path().join("out/bad.toml");
    let r = run(
        dir.path(),
        &[
            "convert",
            bad.to_str().unwrap(),
            "-o",
            out2.to_str().unwrap(),
        ],
    );
    assert_eq!(r.status.code(), Some(2));
    assert!(!out2.exists());
    let r = run(
        dir.path(),
        &[
            "convert",
            bad.to_str().unwrap(),
            "--xml-lenient",
            "-o",
            out2.to_str().unwrap(),
        ],
    );
    assert!(r.status.success());
    assert!(String::from_utf8_lossy(&r.stderr).contains("cylinder"));
}

/// A valid scene to mutate: most elements the reader knows.
const FUZZ_SEED: &str = r#"<?xml version="1.0"?>
<scene version="3.0.0">
  <default name="spp" value="4"/>
  <integrator type="path"><integer name="max_depth" value="3"/></integrator>
  <sensor type="thinlens">
    <float name="fov" value="45"/><string name="fov_axis" value="diagonal"/>
    <float name="aperture_radius" value="0.1"/><float name="focus_distance" value="3"/>
    <transform name="to_world"><lookat origin="0 0 3" target="0 0 0" up="0 1 0"/><rotate z="1" angle="5"/></transform>
    <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/>
      <rfilter type="gaussian"><float name="stddev" value="0.4"/></rfilter></film>
  </sensor>
  <bsdf type="twosided" id="w"><bsdf type="diffuse"><rgb name="reflectance" value="0.5, 0.5, 0.5"/></bsdf></bsdf>
  <shape type="rectangle"><transform name="to_world"><matrix value="1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1"/></transform><ref id="w"/></shape>
  <shape type="sphere"><point name="center" x="0" y="1" z="0"/><float name="radius" value="0.5"/>
    <bsdf type="roughdielectric"><string name="distribution" value="ggx"/><float name="alpha" value="0.1"/></bsdf></shape>
  <shape type="disk"><emitter type="area"><spectrum name="radiance" value="2"/></emitter></shape>
  <emitter type="point"><point name="position" value="1 1 1"/></emitter>
  <emitter type="constant"/>
  <bsdf type="mask" id="m"><float name="opacity" value="0.5"/><ref id="w"/></bsdf>
  <shape type="obj"><string name="filename" value="quad.obj"/>
    <bsdf type="bumpmap"><texture name="map" type="bitmap"><string name="filename" value="h.png"/></texture>
      <float name="scale" value="0.5"/><ref id="m"/></bsdf></shape>
  <shape type="sphere"><float name="radius" value="0.2"/><bsdf type="thindielectric"/></shape>
  <emitter type="spot"><transform name="to_world"><lookat origin="0, 2, 0" target="0, 0, 0" up="1, 0, 0"/></transform>
    <float name="cutoff_angle" value="30"/><rgb name="intensity" value="2, 1, 1"/></emitter>
  <shape type="cube"><bsdf type="diffuse"><texture name="reflectance" type="checkerboard">
    <rgb name="color0" value="0.9, 0.5, 0.1"/><transform name="to_uv"><scale x="4" y="2"/></transform></texture></bsdf></shape>
</scene>
"#;

/// The fuzzer's seed is a scene that loads (so that mutations start from the reader's every path).
#[test]
fn the_fuzz_seed_loads() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "quad.obj",
        "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nf 1/1 2/2 3/3\n",
    );
    image::RgbImage::from_pixel(2, 2, image::Rgb([9, 99, 199]))
        .save(dir.path().join("h.png"))
        .unwrap();
    let p = write(dir.path(), "fuzz.xml", FUZZ_SEED);
    let s = Scene::load(&p).unwrap_or_else(|e| panic!("{e}"));
    assert!(s.meshes[0].material < s.materials.len() as u32);
    assert!(s.materials.iter().any(|m| m.textures.bump.is_some()));
}

/// Fragments of Mitsuba XML for the fuzzer to insert: elements and attributes the reader knows, the
/// constructs that once recursed, expanded or hung it (references, defaults, includes, nesting).
const XML_TOKENS: &[&str] = &[
    "<",
    ">",
    "/>",
    "</bsdf>",
    "\"",
    "$spp",
    "$spp$spp",
    "<default name=\"spp\" value=\"$spp$spp\"/>",
    "<ref id=\"w\"/>",
    "<ref id=\"m\"/>",
    "<bsdf type=\"twosided\" id=\"w\">",
    "<bsdf type=\"twosided\">",
    "<include filename=\"fuzz.xml\"/>",
    "<include filename=\"absent.xml\"/>",
    "<transform name=\"to_world\">",
    "<scale x=\"-1\"/>",
    "<matrix value=\"0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0\"/>",
    "<rgb name=\"radiance\" value=\"-1\"/>",
    "<spectrum name=\"reflectance\" value=\"400:0.5, 700:nan\"/>",
    "<texture type=\"bitmap\"><string name=\"filename\" value=\"h.png\"/></texture>",
    "<float name=\"scale\" value=\"1e30\"/>",
    "id=\"w\"",
    "name=\"\"",
];

proptest! {
    #![proptest_config(common::fuzz::config(6000))]

    /// Mutated XML (characters XML is made of replaced, deleted or inserted; elements and references
    /// inserted, lines duplicated, numbers set to boundary values) never panics or hangs: it loads, or
    /// gives a one-paragraph error, under a watchdog, strict and lenient.
    #[test]
    fn mutated_xml_never_panics(
        edits in prop::collection::vec(
            (0usize..8192, 0u8..3, prop::sample::select(b"<>/=\" $-.019aexyz\n".to_vec())),
            0..6,
        ),
        mutations in prop::collection::vec(common::fuzz::mutation(), 0..4),
    ) {
        let mut bytes = FUZZ_SEED.as_bytes().to_vec();
        for (at, op, c) in edits {
            let i = at % (bytes.len() + 1);
            match op {
                0 if i < bytes.len() => bytes[i] = c,
                1 if i < bytes.len() => { bytes.remove(i); }
                _ => bytes.insert(i, c),
            }
        }
        for m in &mutations {
            common::fuzz::apply(&mut bytes, m, XML_TOKENS, common::fuzz::EXTREMES);
        }
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), "quad.obj", "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nf 1/1 2/2 3/3\n");
        image::RgbImage::from_pixel(2, 2, image::Rgb([9, 99, 199]))
            .save(dir.path().join("h.png"))
            .unwrap();
        let p = dir.path().join("fuzz.xml");
        std::fs::write(&p, &bytes).unwrap();
        for lenient in [false, true] {
            let q = p.clone();
            let answer = common::fuzz::within_watchdog("an XML scene", move || {
                Scene::load_with_options(&q, None, lenient).map(drop).map_err(|e| e.to_string())
            });
            if let Err(text) = answer {
                prop_assert!(!text.contains('\n'), "{}", text);
            }
        }
    }
}

/// `specular_reflectance` on a conductor is vkpath's conductor tint (Bitterli's veach-mis and staircase
/// give their rough conductors one), and a rough conductor of material "none" (reflectance 1) is a
/// conductor whose Schlick f0 is 1, exactly reflectance 1.
#[test]
fn conductor_specular_reflectance_is_the_tint() {
    let s = load(
        r#"
        <shape type="sphere"><bsdf type="roughconductor"><string name="material" value="Au"/>
            <string name="distribution" value="ggx"/><float name="alpha" value="0.04"/><rgb name="specular_reflectance" value="0.3, 0.3, 0.3"/></bsdf></shape>
        <shape type="sphere"><bsdf type="roughconductor"><string name="distribution" value="ggx"/>
            <float name="alpha" value="0.09"/><rgb name="specular_reflectance" value="0.5, 0.6, 0.7"/></bsdf></shape>
        "#,
    );
    let bsdf = |i: usize| s.materials[s.spheres[i].material as usize].bsdf;
    let Bsdf::Conductor {
        fresnel: ConductorFresnel::Complex { eta, .. },
        roughness,
        tint,
    } = bsdf(0)
    else {
        panic!("{:?}", bsdf(0))
    };
    assert!((eta.x - 0.143_036).abs() < 1e-6, "the gold preset");
    assert!((roughness.u - 0.2).abs() < 1e-6);
    assert_eq!(tint, Vec3::splat(0.3));
    assert_eq!(
        bsdf(1),
        Bsdf::Conductor {
            fresnel: ConductorFresnel::Schlick { f0: Vec3::ONE },
            roughness: Roughness::isotropic(0.3),
            tint: Vec3::new(0.5, 0.6, 0.7),
        }
    );
}

/// Mitsuba's `roughdiffuse` with `use_fast_approx` (Oren and Nayar's qualitative model) is vkpath's
/// `rough_diffuse`, with roughness sqrt(alpha); without it (Mitsuba's default, the full model) it is an
/// approximation, refused unless lenient.
#[test]
fn roughdiffuse_is_the_rough_diffuse_material() {
    let s = load(
        r#"<shape type="sphere"><bsdf type="roughdiffuse"><rgb name="reflectance" value="0.6, 0.5, 0.4"/>
             <float name="alpha" value="0.36"/><boolean name="use_fast_approx" value="true"/></bsdf></shape>"#,
    );
    let Bsdf::Plugin { kind, block } = s.materials[s.spheres[0].material as usize].bsdf else {
        panic!("{:?}", s.materials[0].bsdf)
    };
    let (number, plugin) = vkpath::scene::bsdfs::by_toml_type("rough_diffuse").unwrap();
    assert_eq!(kind, number);
    let [Value::Color(albedo), Value::Float(roughness)] = plugin.unpack(&block)[..] else {
        panic!("{block:?}")
    };
    assert_close(Vec3::from(albedo), Vec3::new(0.6, 0.5, 0.4));
    assert!((roughness - 0.6).abs() < 1e-6, "{roughness}");

    let dir = tempfile::tempdir().unwrap();
    let body = r#"<shape type="sphere"><bsdf type="roughdiffuse"/></shape>"#;
    let e = error_in(dir.path(), body);
    assert!(
        e.contains("use_fast_approx") && e.contains("--xml-lenient"),
        "{e}"
    );
    let p = write(dir.path(), "scene.xml", &scene_xml(body));
    let s = Scene::load_with_options(&p, None, true).unwrap();
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    let Bsdf::Plugin { block, .. } = s.materials[s.spheres[0].material as usize].bsdf else {
        panic!("{:?}", s.materials[0].bsdf)
    };
    // Mitsuba's default alpha, 0.2.
    assert_eq!(plugin.unpack(&block)[1], Value::Float(0.2f32.sqrt()));
}

/// Issue 31's recursion defects: deep nesting (written out, or through includes) and BSDFs that hold
/// themselves through `<ref>` are refused with the file and line (exit 2 from the binary) instead of
/// overflowing the stack; before, each of these aborted the process.
#[test]
fn deep_nesting_and_reference_cycles_are_refused_not_overflowed() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        // 20 000 nested unknown elements (roxmltree's own tokenizer recurses per level).
        (
            format!("{}{}", "<foo>".repeat(20_000), "</foo>".repeat(20_000)),
            "nested more than 100 deep",
        ),
        // 5 000 nested twosided BSDFs.
        (
            format!(
                "<shape type=\"sphere\">{}<bsdf type=\"diffuse\"/>{}</shape>",
                "<bsdf type=\"twosided\">".repeat(5_000),
                "</bsdf>".repeat(5_000)
            ),
            "nested more than 100 deep",
        ),
        // A BSDF that refers to itself, and two that refer to each other.
        (
            r#"<bsdf type="twosided" id="a"><ref id="a"/></bsdf><shape type="sphere"><ref id="a"/></shape>"#
                .to_string(),
            "reference cycle",
        ),
        (
            r#"<bsdf type="twosided" id="a"><ref id="b"/></bsdf>
               <bsdf type="twosided" id="b"><ref id="a"/></bsdf><shape type="sphere"><ref id="a"/></shape>"#
                .to_string(),
            "reference cycle",
        ),
        // A chain of 150 BSDFs, each a twosided around the next by reference: flat text, deep walk.
        (
            (0..150)
                .map(|i| format!("<bsdf type=\"twosided\" id=\"b{i}\"><ref id=\"b{}\"/></bsdf>\n", i + 1))
                .collect::<String>()
                + "<bsdf type=\"diffuse\" id=\"b150\"/><shape type=\"sphere\"><ref id=\"b0\"/></shape>",
            "nested more than 100 deep through <ref>s",
        ),
    ];
    for (body, want) in &cases {
        let e = error_in(dir.path(), body);
        assert!(e.contains(want) && e.contains("scene.xml, line"), "{e}");
    }
    // Deep only together: main.xml includes a.xml, which includes b.xml, whose 100 levels (a shape, 97
    // nested twosided BSDFs and a diffuse one, under its <scene>) pass the text check; the walk counts
    // the two include elements too.
    let b = format!(
        "<scene version=\"3.0.0\"><shape type=\"sphere\">{}<bsdf type=\"diffuse\"/>{}</shape></scene>",
        "<bsdf type=\"twosided\">".repeat(97),
        "</bsdf>".repeat(97)
    );
    write(dir.path(), "b.xml", &b);
    write(
        dir.path(),
        "a.xml",
        "<scene version=\"3.0.0\"><include filename=\"b.xml\"/></scene>",
    );
    let e = error_in(dir.path(), r#"<include filename="a.xml"/>"#);
    assert!(
        e.contains("nested more than 100 deep") && e.contains("b.xml, line 1"),
        "{e}"
    );
    // The binary: exit 2 and one paragraph, for render and convert alike.
    let p = write(dir.path(), "deep.xml", &scene_xml(&cases[0].0));
    for args in [
        vec!["render", p.to_str().unwrap(), "-o", "deep.png"],
        vec!["convert", p.to_str().unwrap(), "-o", "deep.toml"],
    ] {
        let out = run(dir.path(), &args);
        assert_eq!(
            out.status.code(),
            Some(2),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(!dir.path().join("deep.png").exists() && !dir.path().join("deep.toml").exists());
    }
}

/// Issue 31: expansions bounded by a multiple of the input. A `<default>` doubling the one before it 40
/// times (a 1.5 kB file asking for a terabyte) and an include fan-out (12 files of 8 includes each:
/// 8^11 reads) used to abort on allocation and to run for ever; each is now refused at the line where
/// the bound is crossed. A parameter used many times over stays well inside the bound.
#[test]
fn expansion_bombs_and_include_fan_outs_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut bomb = String::from("<default name=\"a0\" value=\"xxxxxxxxxxxxxxxx\"/>\n");
    for i in 1..=40 {
        bomb += &format!(
            "<default name=\"a{i}\" value=\"$a{}$a{}\"/>\n",
            i - 1,
            i - 1
        );
    }
    bomb += "<shape type=\"sphere\"><string name=\"label\" value=\"$a40\"/></shape>";
    let e = error_in(dir.path(), &bomb);
    // The first default whose two uses of the one before (16 x 2^(i-1) bytes each, replacing the
    // `$a{i-1}` written) take the total past 16 x the file plus 1 MiB: a16.
    let budget = 16 * scene_xml(&bomb).len() + (1 << 20);
    let mut added = 0;
    let first = (1..=40)
        .find(|i| {
            added += 2 * (16 << (i - 1)) - 2 * format!("$a{}", i - 1).len();
            added > budget
        })
        .unwrap();
    assert_eq!(first, 16);
    assert!(
        e.contains("expands itself")
            && e.contains(&format!(
                "line {}",
                line_of(&bomb, &format!("<default name=\"a{first}\""))
            )),
        "{e}"
    );
    for level in 0..12 {
        let body = if level < 11 {
            format!("<include filename=\"inc{}.xml\"/>", level + 1).repeat(8)
        } else {
            "<shape type=\"sphere\"/>".into()
        };
        write(
            dir.path(),
            &format!("inc{level}.xml"),
            &format!("<scene version=\"3.0.0\">{body}</scene>"),
        );
    }
    let started = std::time::Instant::now();
    let e = error_in(dir.path(), r#"<include filename="inc0.xml"/>"#);
    assert!(e.contains("more than 10000 <include>s"), "{e}");
    assert!(started.elapsed().as_secs() < 60, "bounded, not merely slow");
    // A 200-character parameter used 300 times (60 kB from a 12 kB file): read.
    let body = format!(
        "<default name=\"label\" value=\"{}\"/>\n{}<shape type=\"sphere\"/>",
        "y".repeat(200),
        (0..300)
            .map(|i| format!("<default name=\"u{i}\" value=\"$label\"/>\n"))
            .collect::<String>()
    );
    assert_eq!(load(&body).spheres.len(), 1);
}

/// Issue 31: what no shape uses is still read, as Mitsuba instantiates every object of a scene: an
/// unknown plugin, a parameter nothing reads, an unknown texture, each refused at its line even where
/// nothing refers to it (a warning with --xml-lenient). A light of negative intensity or radiance is
/// refused instead of becoming a black light.
#[test]
fn unused_definitions_are_read_and_negative_lights_refused() {
    let dir = tempfile::tempdir().unwrap();
    let light = r#"<shape type="sphere"/><emitter type="point"><point name="position" x="0" y="0" z="3"/></emitter>"#;
    for (def, needle, want) in [
        (
            r#"<bsdf type="frobnicate" id="x"><float name="bogus" value="1"/></bsdf>"#,
            "frobnicate",
            "bsdf plugin \"frobnicate\"",
        ),
        (
            r#"<bsdf type="diffuse" id="d"><float name="bogosity" value="3"/></bsdf>"#,
            "bogosity",
            "bogosity",
        ),
        (r#"<texture type="nosuch" id="t"/>"#, "nosuch", "\"nosuch\""),
        (
            r#"<emitter type="point"><point name="position" x="0" y="0" z="3"/><rgb name="intensity" value="-3000"/></emitter>"#,
            "-3000",
            "negative",
        ),
        (
            r#"<shape type="rectangle"><emitter type="area"><rgb name="radiance" value="1, -1, 1"/></emitter></shape>"#,
            "radiance",
            "negative",
        ),
        (
            r#"<emitter type="directional"><vector name="direction" x="0" y="0" z="-1"/><float name="irradiance" value="-2"/></emitter>"#,
            "irradiance",
            "negative",
        ),
    ] {
        let body = format!("{light}\n{def}");
        let e = error_in(dir.path(), &body);
        assert!(
            e.contains(want) && e.contains(&format!("line {}", line_of(&body, needle))),
            "{def}: {e}"
        );
    }
    let p = write(
        dir.path(),
        "lenient.xml",
        &scene_xml(&format!(
            "{light}\n<bsdf type=\"frobnicate\" id=\"x\"/>\n<bsdf type=\"diffuse\" id=\"d\"><float name=\"bogosity\" value=\"3\"/></bsdf>"
        )),
    );
    let s = Scene::load_with_options(&p, None, true).unwrap();
    assert_eq!(s.warnings.len(), 2, "{:#?}", s.warnings);
    assert!(s.warnings[0].contains("frobnicate") && s.warnings[1].contains("bogosity"));
    // Used or not, a definition vkpath reads costs nothing: the same scene as without it.
    let with = load(&format!(
        "{light}\n<bsdf type=\"roughconductor\" id=\"spare\"/>"
    ));
    assert_eq!(with.materials.len(), load(light).materials.len());
}

/// Mitsuba's bumpmap and normalmap become the bump and normal_map modifiers of the BSDF they hold: the
/// bump texture read as Mitsuba's eval_1 (luminance of the sRGB-decoded texels) with its scale, the
/// normal map as given (raw: linear), and the two-sidedness of what they hold. Bitterli's staircase
/// defines a bumpmap at the top level that no shape uses (its inner BSDF is used by id): that reads.
#[test]
fn bumpmaps_and_normalmaps_become_bump_and_normal_map_modifiers() {
    let dir = tempfile::tempdir().unwrap();
    image::RgbImage::from_pixel(2, 2, image::Rgb([200, 100, 50]))
        .save(dir.path().join("h.png"))
        .unwrap();
    write(
        dir.path(),
        "quad.obj",
        "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n",
    );
    let quad = |bsdf: &str| {
        format!(r#"<shape type="obj"><string name="filename" value="quad.obj"/>{bsdf}</shape>"#)
    };
    let s = load_in(
        dir.path(),
        &[
            quad(
                r#"<bsdf type="bumpmap"><texture name="map" type="bitmap"><string name="filename" value="h.png"/></texture>
                   <float name="scale" value="0.25"/>
                   <bsdf type="twosided"><bsdf type="roughconductor"/></bsdf></bsdf>"#,
            ),
            quad(
                r#"<bsdf type="normalmap"><texture name="normalmap" type="bitmap"><boolean name="raw" value="true"/>
                   <string name="filename" value="h.png"/></texture><bsdf type="diffuse"/></bsdf>"#,
            ),
            // The staircase's pattern: the bumpmap is defined, unused; its twosided is used by id.
            r#"<bsdf type="bumpmap"><texture name="map" type="bitmap"><string name="filename" value="h.png"/></texture>
                   <bsdf type="twosided" id="inner"><bsdf type="diffuse"/></bsdf></bsdf>"#
                .to_string(),
            quad(r#"<ref id="inner"/>"#),
        ]
        .join("\n"),
    );
    let m: Vec<_> = s
        .meshes
        .iter()
        .map(|m| &s.materials[m.material as usize])
        .collect();
    let (bump, scale) = m[0].textures.bump.as_ref().expect("a bump map");
    assert_eq!(*scale, 0.25);
    assert!(bump.srgb && bump.channel == Channel::Luminance);
    assert!(!m[0].textures.one_sided, "a bumpmap around a twosided");
    let (normal, nscale) = m[1].textures.normal_map.as_ref().expect("a normal map");
    assert_eq!(*nscale, 1.0);
    assert!(!normal.srgb && normal.channel == Channel::Rgb);
    assert!(m[1].textures.one_sided, "a normalmap around a diffuse");
    assert!(m[2].textures.bump.is_none() && !m[2].textures.one_sided);
    // Without one texture and one BSDF: refused at the element.
    let body = quad(r#"<bsdf type="bumpmap"><bsdf type="diffuse"/></bsdf>"#);
    let e = error_in(dir.path(), &body);
    assert!(
        e.contains("one texture") && e.contains(&format!("line {}", line_of(&body, "bumpmap"))),
        "{e}"
    );
}

/// Mitsuba's shapegroup and instance: each instance draws the group's shapes placed by its to_world
/// after their own (a shapegroup alone draws nothing), the same geometry, bit for bit, as the shapes
/// written out with the composed transforms (the group's mesh shared by the instances after the first:
/// its placements put its vertices where the written-out meshes have theirs) (exact in binary here: translations, scales by 2, a
/// quarter turn as an integer matrix). A group with an emitter, a group in a group and an instance of a plain
/// shape are refused, as Mitsuba refuses them.
#[test]
fn instances_of_a_shapegroup_are_its_shapes_placed_again() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "quad.obj",
        "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3\nf 1 3 4\n",
    );
    let quad = |ops: &str| {
        format!(
            r#"<shape type="obj"><string name="filename" value="quad.obj"/><ref id="grey"/>
               <transform name="to_world"><translate x="1"/>{ops}</transform></shape>"#
        )
    };
    let ball = |ops: &str| {
        format!(
            r#"<shape type="sphere"><float name="radius" value="0.5"/><ref id="grey"/>
               <transform name="to_world"><translate y="2"/>{ops}</transform></shape>"#
        )
    };
    let square = |ops: &str| {
        format!(
            r#"<shape type="rectangle"><ref id="grey"/>
               <transform name="to_world"><scale value="0.5"/>{ops}</transform></shape>"#
        )
    };
    let placements = [
        r#"<translate x="3" z="-2"/>"#,
        r#"<scale value="2"/><translate y="-1"/>"#,
        r#"<matrix value="0 -1 0 -4  1 0 0 0  0 0 1 0.5  0 0 0 1"/>"#,
    ];
    let grey = r#"<bsdf type="diffuse" id="grey"/>"#;
    let instanced = format!(
        "{grey}\n<shape type=\"shapegroup\" id=\"g\">{}{}{}</shape>\n{}",
        quad(""),
        ball(""),
        square(""),
        placements
            .iter()
            .map(|p| format!(
                "<shape type=\"instance\"><ref id=\"g\"/><transform name=\"to_world\">{p}</transform></shape>"
            ))
            .collect::<String>()
    );
    let written_out = format!(
        "{grey}\n{}",
        placements
            .iter()
            .map(|p| format!("{}{}{}", quad(p), ball(p), square(p)))
            .collect::<String>()
    );
    let a = load_in(dir.path(), &instanced);
    let b = load_in(dir.path(), &written_out);
    assert_eq!(a.spheres.len(), 3);
    assert_eq!(a.triangles.len(), 6);
    assert_eq!(a.spheres, b.spheres);
    assert_eq!(a.triangles, b.triangles);
    // The group's mesh: written out at the first instance, one shared copy (in the file's own space)
    // placed by the others.
    assert_eq!(a.meshes.len(), 1);
    let (ma, mb) = (&a.meshes[0], &b.meshes[0]);
    assert_eq!(
        (&ma.positions, &ma.normals, &ma.triangles, ma.material),
        (&mb.positions, &mb.normals, &mb.triangles, mb.material)
    );
    assert_eq!(a.instanced.len(), 1);
    let shared = &a.instanced[0];
    assert_eq!((shared.parts.len(), shared.placements.len()), (1, 2));
    let part = &shared.parts[0];
    for (placement, mb) in shared.placements.iter().zip(&b.meshes[1..]) {
        let placed: Vec<Vec3> = part
            .positions
            .iter()
            .map(|p| placement.to_world.transform_point3(p.as_dvec3()).as_vec3())
            .collect();
        assert_eq!(
            (&placed, &part.triangles, part.material),
            (&mb.positions, &mb.triangles, mb.material)
        );
    }
    // The second instance doubles the sphere: radius 1, centre (0, 2 x 2 - 1, 0).
    assert_eq!(a.spheres[1].radius, 1.0);
    assert_eq!(a.spheres[1].center, Vec3::new(0.0, 3.0, 0.0));
    // A group alone draws nothing.
    let lone = load_in(
        dir.path(),
        &format!(
            "{grey}<shape type=\"shapegroup\" id=\"g\">{}</shape><shape type=\"sphere\"/>",
            ball("")
        ),
    );
    assert_eq!(lone.spheres.len(), 1);
    for (body, needle, want) in [
        (
            r#"<shape type="shapegroup" id="g"><shape type="sphere"><emitter type="area"/></shape></shape>"#,
            "<shape type=\"sphere\">",
            "does not instance emitters",
        ),
        (
            r#"<shape type="shapegroup" id="g"><shape type="shapegroup"/></shape>"#,
            "<shape type=\"shapegroup\"/>",
            "a shapegroup inside a shapegroup",
        ),
        (
            r#"<shape type="sphere" id="s"/><shape type="instance"><ref id="s"/></shape>"#,
            "<shape type=\"sphere\" id",
            "an instance of a sphere shape",
        ),
    ] {
        let e = error_in(dir.path(), body);
        assert!(
            e.contains(want) && e.contains(&format!("line {}", line_of(body, needle))),
            "{e}"
        );
    }
}

/// A Mitsuba `.serialized` file of the meshes given, built as Mitsuba's format description says (each
/// mesh: u16 0x041C, u16 `version`, a zlib stream of flags, name (version 4), counts and arrays; then the
/// meshes' offsets and their count): `(flags, name, positions, normals, uvs, colours, triangles)` with
/// every array as f64 values, written in double precision when flag 0x2000 is set, else single.
#[allow(clippy::type_complexity)]
fn serialized_file(
    version: u16,
    meshes: &[(u32, &str, Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>, Vec<u32>)],
) -> Vec<u8> {
    use std::io::Write;
    let mut out = Vec::new();
    let mut offsets = Vec::new();
    for (flags, name, p, n, uv, c, t) in meshes {
        offsets.push(out.len() as u64);
        out.extend(0x041Cu16.to_le_bytes());
        out.extend(version.to_le_bytes());
        let mut data = Vec::new();
        data.extend(flags.to_le_bytes());
        if version == 4 {
            data.extend(name.as_bytes());
            data.push(0);
        }
        data.extend(((p.len() / 3) as u64).to_le_bytes());
        data.extend(((t.len() / 3) as u64).to_le_bytes());
        for array in [p, n, uv, c] {
            for &x in array {
                if flags & 0x2000 != 0 {
                    data.extend(x.to_le_bytes());
                } else {
                    data.extend((x as f32).to_le_bytes());
                }
            }
        }
        for &i in t {
            data.extend(i.to_le_bytes());
        }
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        z.write_all(&data).unwrap();
        out.extend(z.finish().unwrap());
    }
    for o in &offsets {
        if version == 4 {
            out.extend(o.to_le_bytes());
        } else {
            out.extend((*o as u32).to_le_bytes());
        }
    }
    out.extend((offsets.len() as u32).to_le_bytes());
    out
}

/// Mitsuba's `serialized` shape: mesh `shape_index` of a .serialized file, read as Mitsuba reads it
/// (single or double precision, normals, texture coordinates with v turned to vkpath's bottom-up
/// convention since Mitsuba does not flip them, colours read past, the face-normals flag), versions 3
/// and 4, is the same mesh, bit for bit, as the OBJ that writes the same numbers; errors name the mesh.
#[test]
fn serialized_meshes_are_the_same_meshes_as_obj() {
    let dir = tempfile::tempdir().unwrap();
    let tri = (
        0x0001 | 0x0002 | 0x1000,
        "tri",
        vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        vec![0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0],
        vec![0.0, 0.25, 1.0, 0.25, 0.0, 1.0],
        vec![],
        vec![0, 1, 2],
    );
    let quad = (
        0x0008 | 0x2000,
        "quad",
        vec![
            -1.0, -1.0, 0.5, 1.0, -1.0, 0.5, 1.0, 1.0, 0.5, -1.0, 1.0, 0.5,
        ],
        vec![],
        vec![],
        vec![0.25; 12],
        vec![0, 1, 2, 0, 2, 3],
    );
    write(
        dir.path(),
        "tri.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvt 0 0.75\nvt 1 0.75\nvt 0 0\nf 1/1/1 2/2/1 3/3/1\n",
    );
    write(
        dir.path(),
        "quad.obj",
        "v -1 -1 0.5\nv 1 -1 0.5\nv 1 1 0.5\nv -1 1 0.5\nf 1 2 3\nf 1 3 4\n",
    );
    for version in [3u16, 4] {
        std::fs::write(
            dir.path().join("m.serialized"),
            serialized_file(version, &[tri.clone(), quad.clone()]),
        )
        .unwrap();
        let s = load_in(
            dir.path(),
            r#"<shape type="serialized"><string name="filename" value="m.serialized"/></shape>
               <shape type="serialized"><string name="filename" value="m.serialized"/><integer name="shape_index" value="1"/>
                 <transform name="to_world"><translate x="2"/></transform></shape>
               <shape type="obj"><string name="filename" value="tri.obj"/></shape>
               <shape type="obj"><string name="filename" value="quad.obj"/>
                 <transform name="to_world"><translate x="2"/></transform></shape>"#,
        );
        assert_eq!(s.meshes.len(), 4);
        for (a, b) in [(0, 2), (1, 3)] {
            let (ma, mb) = (&s.meshes[a], &s.meshes[b]);
            assert_eq!(
                (&ma.positions, &ma.normals, &ma.uvs, &ma.triangles),
                (&mb.positions, &mb.normals, &mb.uvs, &mb.triangles),
                "version {version}, mesh {a}"
            );
        }
        assert_eq!(s.meshes[0].uvs[2], [0.0, 0.0], "v = 1 at the image's top");
    }
    // The face-normals flag shades flat: no vertex normals, whatever the file holds.
    let flat = (
        0x0001 | 0x0010,
        "flat",
        tri.2.clone(),
        tri.3.clone(),
        vec![],
        vec![],
        vec![0, 1, 2],
    );
    std::fs::write(dir.path().join("f.serialized"), serialized_file(4, &[flat])).unwrap();
    let s = load_in(
        dir.path(),
        r#"<shape type="serialized"><string name="filename" value="f.serialized"/></shape>"#,
    );
    assert!(s.meshes[0].normals.is_empty(), "{:?}", s.meshes[0].normals);
    // Errors: an index past the file's meshes, a truncated file, another format.
    let good = serialized_file(4, &[tri.clone(), quad.clone()]);
    std::fs::write(dir.path().join("cut.serialized"), &good[..good.len() / 3]).unwrap();
    std::fs::write(
        dir.path().join("not.serialized"),
        b"ply\nformat ascii 1.0\n",
    )
    .unwrap();
    for (file, index, want) in [
        (
            "m.serialized",
            2,
            "shape_index 2 asks for mesh 2, and the file has 2 (0 to 1)",
        ),
        ("cut.serialized", 0, "mesh 0 ends inside its"),
        ("not.serialized", 0, "the header 0x041C is missing"),
    ] {
        let body = format!(
            r#"<shape type="serialized"><string name="filename" value="{file}"/><integer name="shape_index" value="{index}"/></shape>"#
        );
        let e = error_in(dir.path(), &body);
        assert!(e.contains(want) && e.contains(file), "{want}: {e}");
    }
    let body = r#"<shape type="obj"><string name="filename" value="tri.obj"/><integer name="shape_index" value="1"/></shape>"#;
    assert!(error_in(dir.path(), body).contains("shape_index"));
    // In TOML: shape_index on a mesh that is not a .serialized file is refused at the key.
    let toml = write(
        dir.path(),
        "s.toml",
        "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nfov = 40\n[image]\nwidth = 8\nheight = 8\n\
         [materials]\nw = { type = \"diffuse\", albedo = [0.5, 0.5, 0.5] }\n\
         [[mesh]]\nobj = \"tri.obj\"\nmaterial = \"w\"\nshape_index = 1\n",
    );
    let e = Scene::load(&toml).unwrap_err();
    assert_eq!(e.key(), Some("mesh[0].shape_index"), "{e}");
}

proptest! {
    #![proptest_config(common::fuzz::config(3000))]

    /// The .serialized reader on files whose decompressed content is arbitrary (any flags, counts that
    /// claim anything up to 2^64, any payload) and whose container is then mutated: a consistent mesh or
    /// a one-paragraph refusal, never a panic, a hang or an allocation the counts alone ask for.
    #[test]
    fn serialized_reader_survives_arbitrary_content(
        version in 3u16..=4,
        flags in any::<u32>(),
        vertices in prop_oneof![0u64..12, Just(u64::MAX), Just(1u64 << 40)],
        triangles in prop_oneof![0u64..6, Just(u64::MAX), Just(1u64 << 33)],
        payload in prop::collection::vec(any::<u8>(), 0..400),
        index in 0u32..3,
        mutations in prop::collection::vec(common::fuzz::mutation(), 0..3),
    ) {
        use std::io::Write;
        let mut data = flags.to_le_bytes().to_vec();
        if version == 4 {
            data.extend(b"fuzz\0");
        }
        data.extend(vertices.to_le_bytes());
        data.extend(triangles.to_le_bytes());
        data.extend(&payload);
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
        z.write_all(&data).unwrap();
        let mut bytes = [&0x041Cu16.to_le_bytes()[..], &version.to_le_bytes()].concat();
        bytes.extend(z.finish().unwrap());
        bytes.extend(if version == 4 { vec![0u8; 8] } else { vec![0u8; 4] });
        bytes.extend(1u32.to_le_bytes());
        for m in &mutations {
            common::fuzz::apply(&mut bytes, m, &["\u{1c}\u{4}", "\u{0}\u{0}"], common::fuzz::EXTREMES);
        }
        let answer = common::fuzz::within_watchdog("a .serialized file", move || {
            vkpath::scene::serialized::parse_serialized(&bytes, index)
        });
        match answer {
            Ok(m) => {
                let n = m.positions.len() as u32;
                prop_assert!(m.triangles.iter().flatten().all(|&i| i < n));
                prop_assert!(m.normals.as_ref().is_none_or(|v| v.len() == n as usize));
                prop_assert!(m.uvs.as_ref().is_none_or(|v| v.len() == n as usize));
            }
            Err(e) => prop_assert!(!e.contains('\n'), "{}", e),
        }
    }
}

/// Issue 53's messages: a `<matrix>` of sixteen (or nine) entries with one that is not a finite number
/// names that entry, not its count; an emitter vkpath does not read lists every type it reads, `spot`
/// included.
#[test]
fn matrix_and_emitter_messages_say_what_is_wrong() {
    let dir = tempfile::tempdir().unwrap();
    for (value, needle) in [
        (
            "1 0 0 0 1 0 0 0 inf",
            "\"inf\" is not a finite number (of its 9 entries)",
        ),
        (
            "1 0 0 0 0 1 0 0 0 0 1 nan 0 0 0 1",
            "\"nan\" is not a finite number (of its 16 entries)",
        ),
        (
            "1 0 0 0 1 0 0 0",
            "must be 16 numbers (or 9), row by row; it has 8 entries",
        ),
    ] {
        let body = format!(
            r#"<shape type="sphere"><transform name="to_world"><matrix value="{value}"/></transform></shape>"#
        );
        let e = error_in(dir.path(), &body);
        assert!(e.contains(needle), "{value}: {e}");
    }
    let e = error_in(dir.path(), r#"<emitter type="projector"/>"#);
    assert!(
        e.contains("projector") && e.contains("point, spot, directional"),
        "{e}"
    );
}

/// Issue 53: Mitsuba's other algorithms for the same image (bdpt, pssmlt, sppm, photonmapper, ...) are
/// read as the path tracer with their max_depth and a note naming what was read past; a custom
/// integrator picked by a `<default>` is refused with the `-D` that overrides it.
#[test]
fn other_integrators_read_as_the_path_tracer_with_a_note() {
    for (kind, extra) in [
        (
            "bdpt",
            r#"<integer name="max_depth" value="5"/><boolean name="lightImage" value="true"/>"#,
        ),
        (
            "pssmlt",
            r#"<integer name="maxDepth" value="5"/><float name="pLarge" value="0.3"/>"#,
        ),
        (
            "sppm",
            r#"<integer name="max_depth" value="5"/><integer name="photonCount" value="250000"/>"#,
        ),
        ("photonmapper", r#"<integer name="max_depth" value="5"/>"#),
    ] {
        let version = if extra.contains("maxDepth")
            || extra.contains("photonCount")
            || extra.contains("lightImage")
        {
            "0.6.0"
        } else {
            "3.0.0"
        };
        let body =
            format!(r#"<integrator type="{kind}">{extra}</integrator><shape type="sphere"/>"#);
        let text = scene_xml(&body).replace("version=\"3.0.0\"", &format!("version=\"{version}\""));
        let dir = tempfile::tempdir().unwrap();
        let p = write(dir.path(), "scene.xml", &text);
        let s = Scene::load(&p).unwrap_or_else(|e| panic!("{kind}: {e}"));
        assert_eq!(s.render.max_bounces, 4, "{kind}: max_depth 5");
        let notes: Vec<_> = s.warnings.iter().filter(|w| w.contains(kind)).collect();
        assert_eq!(notes.len(), 1, "{kind}: {:?}", s.warnings);
        assert!(
            notes[0].starts_with(vkpath::scene::NOTE)
                && notes[0].contains("only the noise differs"),
            "{}",
            notes[0]
        );
        if extra.contains("pLarge") {
            assert!(notes[0].contains("p_large read past"), "{}", notes[0]);
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let e = error_in(
        dir.path(),
        r#"<default name="algo" value="guided"/><integrator type="$algo"/><shape type="sphere"/>"#,
    );
    assert!(e.contains("-D algo=path"), "{e}");
}

/// Issue 53: --xml-lenient never hides an empty result: a scene whose every light was skipped loads with
/// a warning that the image will be black; one that keeps a light has no such warning.
#[test]
fn lenient_reading_says_when_no_light_is_left() {
    let dir = tempfile::tempdir().unwrap();
    let load_lenient = |body: &str| {
        let p = write(dir.path(), "scene.xml", &scene_xml(body));
        Scene::load_with_options(&p, None, true).unwrap()
    };
    let black = load_lenient(r#"<emitter type="projector"/><shape type="sphere"/>"#);
    let said: Vec<_> = black
        .warnings
        .iter()
        .filter(|w| w.contains("no light is left"))
        .collect();
    assert_eq!(said.len(), 1, "{:?}", black.warnings);
    assert!(said[0].contains("black"), "{}", said[0]);
    let lit = load_lenient(
        r#"<emitter type="projector"/><emitter type="constant"/><shape type="sphere"/>"#,
    );
    assert!(
        lit.warnings.iter().all(|w| !w.contains("no light is left")),
        "{:?}",
        lit.warnings
    );
}
