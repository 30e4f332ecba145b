//! glTF 2.0 scenes, read as vkpath scenes (`vkpath render model.gltf`).
//!
//! A glTF 2.0 file becomes the TOML scene that says what vkpath understood of it: the file as one
//! `[[mesh]]` (its geometry and materials, super::gltf), a `[camera]` from the scene's first camera (or the
//! one `--camera N` names, N counting the camera nodes in the order a depth-first walk of the scene
//! meets them; with none, or with `--camera auto`, the view viewers give an asset: its bounding sphere
//! framed from +z), and a `[[light]]` per KHR_lights_punctual point or directional light (with none, a
//! uniform white `[environment]`, as viewers light an asset with an environment). The TOML is then read
//! like any scene file, so every check and default is the TOML reader's, and `vkpath convert` writes the
//! same text out.
//!
//! Units. glTF point lights give a luminous intensity in candela and directional lights an illuminance in
//! lux; vkpath is radiometric and uncoloured by a luminous efficacy, so one candela is read as one watt per
//! steradian (a point light's power P = 4 pi I) and one lux as one watt per square metre, times the
//! light's colour; spot lights likewise (candela as W/sr on the axis), with their cone angles and the
//! extension's smooth falloff (`falloff = "smooth"`). Cameras: glTF's vertical field of view and aspect
//! ratio give vkpath's horizontal field of view, fov_x = 2 atan(aspect tan(yfov / 2)), and the image
//! 640 pixels wide (height = 640 / aspect); an orthographic camera's xmag is half the view's width.

use super::NOTE;
use super::SceneError;
use super::toml_text::{absolute, num, relative_to, toml_string};
use super::translated::{ImportOptions, Origin, Translated};
use glam::Vec3;
use std::fmt::Write as _;
use std::path::Path;

/// `[x, y, z]` of a glam vector.
fn vec3(v: Vec3) -> String {
    super::toml_text::vec3(v.to_array())
}

/// The image width an imported camera gets (its aspect ratio gives the height).
pub const IMPORTED_IMAGE_WIDTH: u32 = 640;

fn error(path: &Path, problem: impl Into<String>, hint: &str) -> SceneError {
    SceneError::import(path, None, problem, hint)
}

/// The TOML scene for the glTF file at `path` (see the module comment); `options.camera` picks a camera
/// node. The mesh refers to the file by its path relative to `toml_dir` (absolute; the path itself when it
/// has none), or by its name when `None`: the TOML is then read as if it sat beside the file. glTF's entry
/// in super::import.
pub fn to_toml(
    path: &Path,
    options: &ImportOptions,
    toml_dir: Option<&Path>,
) -> Result<Translated, SceneError> {
    let mesh_ref = match toml_dir {
        None => path
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
        Some(dir) => {
            let input = absolute(path);
            let mesh_ref = relative_to(&input, dir).unwrap_or(input);
            mesh_ref.to_string_lossy().into_owned()
        }
    };
    if options.auto_camera && options.camera.is_some() {
        return Err(SceneError::import(
            path,
            Some("--camera".into()),
            "--camera is given twice: auto and a camera index",
            "Give --camera auto or --camera N.",
        ));
    }
    let camera = if options.auto_camera {
        Pick::Auto
    } else {
        Pick::Node(options.camera)
    };
    scene_toml(path, camera, &mesh_ref, options.environment_given)
}

/// The camera asked for: a camera node (`None`: the first, or the framed view when there is none), or
/// the framed view (`--camera auto`).
#[derive(Clone, Copy)]
enum Pick {
    Node(Option<usize>),
    Auto,
}

/// The framed view's vertical field of view (degrees) and image: 45 degrees and 640 x 480, a common
/// viewer default; the camera looks along -z from the +z side of the scene's bounding sphere, y up, at
/// the distance where the sphere fits the smaller (vertical) field.
pub const AUTO_YFOV_DEG: f32 = 45.0;
pub const AUTO_IMAGE: [u32; 2] = [640, 480];

/// The world-space bounding box of the scene's triangle geometry: every primitive's POSITION accessor
/// bounds (`min`/`max`, which glTF requires of POSITION) carried through its node's world matrix (the
/// eight corners: a box that holds the transformed box). `None` when there is no geometry, or an accessor
/// has no usable bounds.
fn scene_bounds(nodes: &[(gltf::Node, glam::Mat4)]) -> Option<(Vec3, Vec3)> {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    let read = |v: &Option<gltf::json::Value>| -> Option<Vec3> {
        let a = v.as_ref()?.as_array()?;
        let f = |i: usize| a.get(i)?.as_f64().map(|x| x as f32);
        Some(Vec3::new(f(0)?, f(1)?, f(2)?))
    };
    for (node, world) in nodes {
        let Some(mesh) = node.mesh() else { continue };
        for prim in mesh.primitives() {
            let Some(acc) = prim.get(&gltf::Semantic::Positions) else {
                continue;
            };
            let (a, b) = (read(&acc.min())?, read(&acc.max())?);
            for i in 0..8 {
                let corner = Vec3::new(
                    if i & 1 == 0 { a.x } else { b.x },
                    if i & 2 == 0 { a.y } else { b.y },
                    if i & 4 == 0 { a.z } else { b.z },
                );
                let p = world.transform_point3(corner);
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
    }
    (lo.is_finite() && hi.is_finite()).then_some((lo, hi))
}

/// [`to_toml`], with the mesh's `obj` written as `mesh_ref`.
fn scene_toml(
    path: &Path,
    camera: Pick,
    mesh_ref: &str,
    environment_given: bool,
) -> Result<Translated, SceneError> {
    let hint = "vkpath reads glTF 2.0 (.gltf with its buffers, or .glb); see docs/scene-format.md, \"glTF scenes\".";
    let bytes = crate::memory::read_file(path).map_err(|e| {
        error(
            path,
            format!("cannot read the glTF file: {e}"),
            "Check that the path is right and that the file is readable.",
        )
    })?;
    let gltf = super::gltf::read_gltf(&bytes).map_err(|m| error(path, m, hint))?;
    let doc = &gltf.document;
    let scene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or_else(|| error(path, "the glTF file has no scene", hint))?;
    let mut warnings = Vec::new();
    let mut cameras = Vec::new();
    let mut lights = String::new();
    let nodes = super::gltf::scene_nodes(doc, &scene, false).map_err(|m| error(path, m, hint))?;
    let bounds = scene_bounds(&nodes);
    for (node, world) in nodes {
        if let Some(c) = node.camera() {
            cameras.push((c, world));
        }
        if let Some(light) = node.light() {
            let position = world.transform_point3(Vec3::ZERO);
            // A light shines along its node's -z.
            let direction = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
            let color = light.color();
            let intensity = light.intensity();
            match light.kind() {
                gltf::khr_lights_punctual::Kind::Point => {
                    let _ = write!(
                        lights,
                        "\n[[light]]                       # glTF point light {}\ntype     = \"point\"\n\
                         position = {}\npower    = {}           # 4 pi x {intensity} cd\ncolor    = {}\n",
                        light.index(),
                        vec3(position),
                        num(4.0 * std::f32::consts::PI * intensity),
                        vec3(Vec3::from_array(color))
                    );
                }
                gltf::khr_lights_punctual::Kind::Directional => {
                    let _ = write!(
                        lights,
                        "\n[[light]]                       # glTF directional light {}\ntype       = \"directional\"\n\
                         direction  = {}\nirradiance = {}         # {intensity} lx\ncolor      = {}\n",
                        light.index(),
                        vec3(direction),
                        num(intensity),
                        vec3(Vec3::from_array(color))
                    );
                }
                gltf::khr_lights_punctual::Kind::Spot {
                    inner_cone_angle,
                    outer_cone_angle,
                } => {
                    // The extension's cone angles (radians, 0 <= inner < outer <= pi / 2) as the spot's
                    // beam and cutoff, with its smooth falloff; the intensity in candela as W/sr on the axis.
                    let (beam, cutoff) = (
                        inner_cone_angle.max(0.0).to_degrees(),
                        outer_cone_angle.to_degrees(),
                    );
                    let _ = write!(
                        lights,
                        "\n[[light]]                       # glTF spot light {}\ntype         = \"spot\"\n\
                         position     = {}\nlook_at      = {}\nintensity    = {}        # {intensity} cd\n\
                         cutoff_angle = {}\nbeam_width   = {}\nfalloff      = \"smooth\"\ncolor        = {}\n",
                        light.index(),
                        vec3(position),
                        vec3(position + direction),
                        num(intensity),
                        num(cutoff),
                        num(beam.min(cutoff)),
                        vec3(Vec3::from_array(color))
                    );
                }
            }
        }
    }
    let chosen = match camera {
        Pick::Auto => None,
        Pick::Node(Some(n)) if n >= cameras.len() => {
            return Err(SceneError::import(
                path,
                Some("--camera".into()),
                format!(
                    "--camera {n} asks for camera node {n}, but the scene has {} (0 to {})",
                    cameras.len(),
                    cameras.len().saturating_sub(1)
                ),
                "Give a camera index the file has, or leave --camera out for the first.",
            ));
        }
        Pick::Node(Some(n)) => Some(&cameras[n]),
        Pick::Node(None) => cameras.first(),
    };
    let name = path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    let (mut toml, width, height, camera_element) = match chosen {
        Some((cam, world)) => {
            let (text, aspect) = node_camera(path, cam, world, hint)?;
            let height = ((IMPORTED_IMAGE_WIDTH as f32 / aspect).round() as u32).clamp(1, 65536);
            (
                format!(
                    "# Read from {name} by vkpath: the file as one mesh, its camera and its lights.\n\n{text}"
                ),
                IMPORTED_IMAGE_WIDTH,
                height,
                format!("cameras[{}]", cam.index()),
            )
        }
        None => {
            let Some((lo, hi)) = bounds else {
                return Err(error(
                    path,
                    "the glTF scene has no camera, and no geometry with bounds to frame one on",
                    "Add a camera to the glTF file, or give its POSITION accessors their min and max.",
                ));
            };
            if cameras.is_empty() {
                warnings.push(format!(
                    "{NOTE}the glTF scene has no camera: framed from its bounds (--camera auto: from +z, y up, {AUTO_YFOV_DEG} degrees vertically)"
                ));
            }
            (
                format!(
                    "# Read from {name} by vkpath: the file as one mesh, framed from its bounds, and its lights.\n\n{}",
                    framed_camera(lo, hi)
                ),
                AUTO_IMAGE[0],
                AUTO_IMAGE[1],
                "meshes".to_string(),
            )
        }
    };
    let _ = write!(
        toml,
        "\n[image]\nwidth  = {width}\nheight = {height}\n\n[[mesh]]\nobj = {}\n",
        toml_string(mesh_ref)
    );
    toml += &lights;
    // Viewers (the Khronos sample viewer, Blender, model-viewer) light an asset that has no lights with
    // an environment: vkpath with a uniform white one (its emissive materials glow on top of it).
    if lights.is_empty() && !environment_given {
        toml += "\n[environment]                   # the file has no lights: a uniform white sky, as viewers light it\nradiance = [1.0, 1.0, 1.0]\n";
        warnings.push(format!(
            "{NOTE}the glTF scene has no point or directional lights: lit by a uniform white environment (radiance 1), as viewers light such assets"
        ));
    }
    let origins = origins(path, &toml, &camera_element);
    Ok(Translated::new(toml, warnings, origins))
}

/// The `[camera]` of a glTF camera node at `world`, and its aspect ratio.
fn node_camera(
    path: &Path,
    cam: &gltf::Camera,
    world: &glam::Mat4,
    hint: &str,
) -> Result<(String, f32), SceneError> {
    let position = world.transform_point3(Vec3::ZERO);
    let forward = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
    let up = world.transform_vector3(Vec3::Y).normalize_or_zero();
    let mut toml = format!(
        "[camera]\nposition = {}\nlook_at  = {}\nup       = {}\n",
        vec3(position),
        vec3(position + forward),
        vec3(up)
    );
    let aspect = match cam.projection() {
        gltf::camera::Projection::Perspective(p) => {
            let aspect = p.aspect_ratio().unwrap_or(1.5);
            let fov_x = 2.0 * (aspect * (p.yfov() / 2.0).tan()).atan();
            let _ = writeln!(
                toml,
                "fov      = {}         # from yfov {} rad",
                num(fov_x.to_degrees()),
                p.yfov()
            );
            aspect
        }
        gltf::camera::Projection::Orthographic(o) => {
            let aspect = if o.ymag() != 0.0 {
                o.xmag() / o.ymag()
            } else {
                1.0
            };
            let _ = writeln!(
                toml,
                "type     = \"orthographic\"\nextent   = {}",
                num(2.0 * o.xmag())
            );
            aspect
        }
    };
    if !(aspect.is_finite() && aspect > 0.0) {
        return Err(error(
            path,
            format!("the camera's aspect ratio {aspect} is not a positive number"),
            hint,
        ));
    }
    Ok((toml, aspect))
}

/// The `[camera]` that frames the box `lo`..`hi` (see [`AUTO_YFOV_DEG`]): its bounding sphere, centre c
/// and radius r (half the diagonal), seen from c + (0, 0, d), d = r / sin(yfov / 2), so that the sphere
/// fills the vertical field (the horizontal one, wider, has room); vkpath's horizontal field of view is
/// fov_x = 2 atan(aspect tan(yfov / 2)).
fn framed_camera(lo: Vec3, hi: Vec3) -> String {
    let c = (lo + hi) / 2.0;
    let r = ((hi - lo).length() / 2.0).max(1e-3);
    let half = (AUTO_YFOV_DEG / 2.0).to_radians();
    let d = r / half.sin();
    let aspect = AUTO_IMAGE[0] as f32 / AUTO_IMAGE[1] as f32;
    let fov_x = 2.0 * (aspect * half.tan()).atan();
    format!(
        "[camera]                        # framing the bounding sphere: centre {}, radius {}\nposition = {}\nlook_at  = {}\nup       = [0.0, 1.0, 0.0]\nfov      = {}         # {AUTO_YFOV_DEG} degrees vertically\n",
        vec3(c),
        num(r),
        vec3(c + Vec3::new(0.0, 0.0, d)),
        vec3(c),
        num(fov_x.to_degrees())
    )
}

/// Where each line of the TOML [`scene_toml`] writes came from, so that an error the TOML reader finds is
/// reported at the glTF element (a camera, a light, the meshes) rather than at a line of TOML the user
/// never saw. glTF is JSON, often on one line: elements are named by their JSON path, without a line.
fn origins(path: &Path, toml: &str, camera: &str) -> Vec<Option<Origin>> {
    let file = std::rc::Rc::new(path.to_path_buf());
    let mut element: Option<String> = None;
    toml.lines()
        .map(|line| {
            if line.starts_with("[camera]") || line.starts_with("[image]") {
                element = Some(camera.to_string());
            } else if line.starts_with("[[mesh]]") {
                element = Some("meshes".into());
            } else if line.starts_with("[[light]]") {
                // "[[light]]   # glTF point light 3": KHR_lights_punctual's light 3.
                let index = line.rsplit(' ').next().unwrap_or("?");
                element = Some(format!("extensions.KHR_lights_punctual.lights[{index}]"));
            }
            element.as_ref().map(|e| Origin {
                file: file.clone(),
                line: None,
                element: e.clone(),
            })
        })
        .collect()
}
