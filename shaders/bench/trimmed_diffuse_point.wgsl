// trimmed_diffuse_point.wgsl: a kernel written by hand for one kind of scene only: diffuse spheres lit by
// point lights, pinhole camera, every sample through the pixel centre, black background, Russian roulette.
// It is the bound that the specialised kernel is measured against (`vkpath bench specialisation`): a
// specialised kernel should be as fast as this, since both contain only these features. It follows
// trace.wgsl step for step, so on such a scene it renders the same bits (tests/specialise.rs).
//
// requires: scene.wgsl, camera.wgsl

fn trimmed_closest_sphere(o: vec3<f32>, d: vec3<f32>) -> Hit {
    var hit = Hit(T_MISS, PRIM_NONE, 0u, vec3<f32>(0.0), NO_INSTANCE);
    for (var i = 0u; i < params.num_spheres; i++) {
        let s = spheres[i];
        let t = intersect_sphere(o, d, s.center, s.radius, 0.0, hit.t);
        if t < hit.t {
            hit = Hit(t, PRIM_SPHERE, i, vec3<f32>(0.0), NO_INSTANCE);
        }
    }
    return hit;
}

fn trimmed_occluded(o: vec3<f32>, d: vec3<f32>, t_max: f32) -> bool {
    for (var i = 0u; i < params.num_spheres; i++) {
        let s = spheres[i];
        if intersect_sphere(o, d, s.center, s.radius, 0.0, t_max) < t_max {
            return true;
        }
    }
    return false;
}

fn trimmed_path(px: vec2<u32>, sample: u32) -> vec3<f32> {
    var rng = rng_new(px.y * params.width + px.x, sample, params.seed);
    rng.dim += 2u; // the filter and lens dimensions, unused here
    let cam = camera_ray(params.cam_position, params.cam_right, params.cam_up, params.cam_forward,
                         params.view_half_width, params.width, params.height, vec2<f32>(px) + vec2<f32>(0.5),
                         0.0, params.focus_distance, vec2<f32>(0.0));
    var o = cam.o;
    var d = cam.d;
    var beta = vec3<f32>(1.0);
    var radiance = vec3<f32>(0.0);
    var bounces = 0u;
    loop {
        let hit = trimmed_closest_sphere(o, d);
        if hit.prim_kind == PRIM_NONE || bounces >= params.max_bounces {
            break;
        }
        bounces += 1u;
        let s = spheres[hit.prim_index];
        let sp3 = sphere_surface_point(o, d, hit.t, s.center, s.radius);
        let sn = normalize(sp3.p - s.center);
        let sp = Surface(sp3.p, sp3.err, sn, s.material, sn, false, vec2<f32>(0.0));
        let mat = materials[sp.material];
        let n = select(-sp.n, sp.n, dot(d, sp.n) < 0.0);
        // Next-event estimation as trace.wgsl's direct_light computes it for a point light.
        var l = vec3<f32>(0.0);
        for (var i = 0u; i < params.num_lights; i++) {
            let ls = point_light_sample(lights[i], sp.p);
            if ls.pdf == 0.0 {
                continue;
            }
            let cos_theta = dot(n, ls.wi);
            if cos_theta <= 0.0 {
                continue;
            }
            let shadow = spawn_ray_to(sp.p, sp.err, n, ls.p_light);
            if !trimmed_occluded(shadow.o, shadow.d, shadow.t_max) {
                l += mat.albedo * INV_PI * ls.L * (cos_theta / (ls.pdf * 1.0));
            }
        }
        radiance += beta * l;
        let wi = sample_cosine_hemisphere(n, rng_next2(&rng));
        beta *= mat.albedo;
        o = offset_ray_origin(sp.p, sp.err, n, wi);
        d = wi;
        if bounces >= params.roulette_depth {
            let q = clamp(max(beta.x, max(beta.y, beta.z)), 0.05, 0.95);
            if rng_next(&rng) >= q {
                break;
            }
            beta /= q;
        }
    }
    return radiance;
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    // Tiles as in trace.wgsl.
    let pc = pass_constants;
    let px = gid.xy + vec2<u32>(pc.tile_x0, pc.tile_y0);
    if px.x >= pc.tile_x1 || px.y >= pc.tile_y1 || px.x >= params.width || px.y >= params.height {
        return;
    }
    let slot = px.y * params.width + px.x - pc.accum_base;
    let radiance = trimmed_path(px, pass_constants.sample_index);
    var acc = accum[slot];
    accumulate_into(&acc, radiance, params.guard_one);
    accum[slot] = acc;
}
