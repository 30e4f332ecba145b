//! A [`Scene`] flattened into the Pod arrays the shader reads.
//!
//! Sphere lights are both lights (sampled by next-event estimation) and visible spheres: each gets an
//! emitter material and a sphere, and the light records that sphere's index so a shadow ray can tell
//! "hit the light" from "hit something in front of it".

use super::types::*;
use crate::scene::{Filter, Light, Material, Scene};
use std::f32::consts::PI;

/// The scene as GPU arrays (host side; uploaded by the renderer).
#[derive(Clone, Debug, Default)]
pub struct GpuScene {
    pub spheres: Vec<GpuSphere>,
    pub triangles: Vec<GpuTriangle>,
    pub materials: Vec<GpuMaterial>,
    pub lights: Vec<GpuLight>,
}

impl GpuScene {
    pub fn build(scene: &Scene) -> GpuScene {
        let mut g = GpuScene::default();
        for m in &scene.materials {
            g.materials.push(match *m {
                Material::Diffuse { albedo } => GpuMaterial {
                    albedo: albedo.into(),
                    kind: MAT_DIFFUSE,
                    ..Default::default()
                },
                Material::Mirror { tint } => GpuMaterial {
                    albedo: tint.into(),
                    kind: MAT_MIRROR,
                    ..Default::default()
                },
                Material::Dielectric { ior } => GpuMaterial {
                    kind: MAT_DIELECTRIC,
                    ior,
                    ..Default::default()
                },
            });
        }
        for s in &scene.spheres {
            g.spheres.push(GpuSphere {
                center: s.center.into(),
                radius: s.radius,
                material: s.material,
                _pad: [0; 3],
            });
        }
        for t in &scene.triangles {
            g.triangles.push(GpuTriangle {
                v0: t.vertices[0].into(),
                v1: t.vertices[1].into(),
                v2: t.vertices[2].into(),
                material: t.material,
                ..Default::default()
            });
        }
        for l in &scene.lights {
            match *l {
                Light::Point {
                    position,
                    power,
                    color,
                } => g.lights.push(GpuLight {
                    position: position.into(),
                    // Radiant intensity of an isotropic point source: I = P / (4 pi) W/sr.
                    intensity: (color * (power / (4.0 * PI))).into(),
                    kind: LIGHT_POINT,
                    ..Default::default()
                }),
                Light::Sphere {
                    center,
                    radius,
                    power,
                    color,
                } => {
                    // A sphere of radius r with uniform radiance Le emits P = Le * pi * 4 pi r^2
                    // (pi from the cosine-weighted hemisphere, 4 pi r^2 the area): Le = P / (4 pi^2 r^2).
                    let le = color * (power / (4.0 * PI * PI * radius * radius));
                    let material = g.materials.len() as u32;
                    g.materials.push(GpuMaterial {
                        kind: MAT_EMITTER,
                        emission: le.into(),
                        ..Default::default()
                    });
                    let sphere_index = g.spheres.len() as u32;
                    g.spheres.push(GpuSphere {
                        center: center.into(),
                        radius,
                        material,
                        _pad: [0; 3],
                    });
                    g.lights.push(GpuLight {
                        position: center.into(),
                        radius,
                        intensity: le.into(),
                        kind: LIGHT_SPHERE,
                        sphere_index,
                        ..Default::default()
                    });
                }
            }
        }
        g
    }
}

/// The uniform parameters for a render of `scene` (the primitive counts are filled in by the renderer).
pub fn params_for(scene: &Scene, roulette_depth: u32) -> GpuParams {
    let cam = &scene.camera;
    // Camera frame: forward towards look_at, right = forward x up, up re-orthogonalised.
    let forward = (cam.look_at - cam.position).normalize();
    let right = forward.cross(cam.up).normalize();
    let up = right.cross(forward);
    GpuParams {
        cam_position: cam.position.into(),
        lens_radius: cam.aperture,
        cam_right: right.into(),
        tan_half_fov: (cam.fov_deg.to_radians() * 0.5).tan(),
        cam_up: up.into(),
        focus_distance: cam.focus_distance,
        cam_forward: forward.into(),
        filter_sigma: scene.render.filter_sigma,
        background: scene.render.background.into(),
        filter_kind: match scene.render.filter {
            Filter::None => 0,
            Filter::Box => 1,
            Filter::Gaussian => 2,
        },
        width: scene.image.width,
        height: scene.image.height,
        max_bounces: scene.render.max_bounces,
        seed: scene.render.seed,
        _pad1: 0,
        _pad2: 0,
        num_spheres: 0,
        num_triangles: 0,
        num_lights: 0,
        roulette_depth,
        guard_one: 1.0,
        _pad0: 0,
    }
}
