// trace.wgsl: the path-tracing kernel. One invocation traces one path: sample `sample_index` of one
// pixel, added to the pixel's running sums. A pass of k samples is k dispatches in one command buffer, each
// preceded by an update of `pass_constants.sample_index`, so the sums see the samples in index order
// whatever the split into passes: N passes of k samples give the same bits as one pass of N k.
// (A push constant would do as well; a 16-byte vkCmdUpdateBuffer costs the same and keeps every input of
// the kernel a buffer binding.)
//
// Why not loop over the pass's samples inside one invocation? Mesa's lavapipe (llvmpipe) ends every loop
// of an invocation once the invocation has run 65535 loop iterations in total (a guard in its code
// generator against runaway shaders): a loop over samples, each looping over bounces and primitives, would
// be cut silently. One path per invocation keeps each invocation's loops small and bounded.

const FILTER_NONE: u32 = 0u;
const FILTER_BOX: u32 = 1u;
const FILTER_GAUSSIAN: u32 = 2u;
// The pixel filter: read from `params` by the generic kernel; a constant when specialised (the switch
// on a constant then folds to one case).
override FILTER_FROM_PARAMS: bool = true;
override FILTER_KIND: u32 = 0u;

// Position on the film of one sample of pixel `px`, importance-sampled from the pixel filter: the
// filter's weight is then 1 for every sample, and the pixel value is the plain mean of its samples.
fn film_position(px: vec2<u32>, rng: ptr<function, Rng>) -> vec2<f32> {
    let center = vec2<f32>(px) + vec2<f32>(0.5);
    let u = rng_next2(rng);
    switch select(FILTER_KIND, params.filter_kind, FILTER_FROM_PARAMS) {
        case FILTER_BOX: {
            return vec2<f32>(px) + u;
        }
        case FILTER_GAUSSIAN: {
            return center + sample_gaussian2(u, params.filter_sigma);
        }
        default: {
            return center;
        }
    }
}

// One path: the Monte Carlo estimate of the radiance arriving at the camera through this sample.
// L = sum over vertices of beta * (emission seen by a specular chain, or direct light by next-event
// estimation at diffuse vertices), with beta the product of f cos / pdf along the path.
fn trace_path(px: vec2<u32>, sample: u32) -> vec3<f32> {
    var rng = rng_new_sampler(px.y * params.width + px.x, sample, params.seed, params.sampler);
    let film = film_position(px, &rng);
    // The lens sample is dimension 1 whether or not there is a lens, so that a pinhole-specialised kernel
    // draws every later number at the same dimension as the generic one.
    var lens = vec2<f32>(0.0);
    var lens_radius = 0.0;
    if HAS_LENS {
        lens = sample_uniform_disk(rng_next2(&rng));
        lens_radius = params.lens_radius;
    } else {
        rng.dim += 1u;
    }
    let cam = camera_ray(params.cam_position, params.cam_right, params.cam_up, params.cam_forward,
                         params.tan_half_fov, params.width, params.height, film,
                         lens_radius, params.focus_distance, lens);
    var o = cam.o;
    var d = cam.d;
    var beta = vec3<f32>(1.0);
    var radiance = vec3<f32>(0.0);
    // Emission found by a ray counts only when no next-event estimate already accounted for it: on camera
    // rays and after specular bounces (mirror, glass). After a diffuse bounce, the light was sampled,
    // unless sphere lights are not sampled (light_sampling = "none"): then their emission always counts.
    let nee_spheres = sphere_lights_sampled();
    var count_emission = true;
    var bounces = 0u;
    loop {
        let hit = scene_intersect(o, d, T_MISS);
        if hit.prim_kind == PRIM_NONE {
            if HAS_BACKGROUND {
                radiance += beta * params.background;
            }
            break;
        }
        let mat = materials[hit_material(hit)];
        if HAS_EMITTERS {
            if mat.kind == MAT_EMITTER {
                if count_emission {
                    radiance += beta * mat.emission;
                }
                break;
            }
        }
        if bounces >= params.max_bounces {
            break;
        }
        bounces += 1u;
        let sp = surface_at(o, d, hit);
        // Both faces scatter: shade with the normal on the side the ray came from.
        let entering = dot(d, sp.n) < 0.0;
        let n = select(-sp.n, sp.n, entering);
        // Smooth meshes scatter about their interpolated normal ns (on the same side as n); everything
        // else about n. A direction chosen about ns can still point below the geometric surface near a
        // silhouette; such a path ends there (absorbed), rather than leaking through the mesh. That
        // loses a little energy at grazing angles, the usual price of shading normals (pbrt-v4 §10.1).
        var ns = n;
        if HAS_SMOOTH_NORMALS {
            ns = select(-sp.ns, sp.ns, entering);
        }
        // A texture replaces the material's albedo (diffuse) or tint (mirror).
        var albedo = mat.albedo;
        if HAS_TEXTURES {
            if sp.textured {
                albedo = sp.albedo;
            }
        }
        var wi = vec3<f32>(0.0);
        // Whether wi must leave on the side the ray came from (reflection) rather than cross (refraction).
        var reflected = true;
        if HAS_DIFFUSE {
            if SINGLE_MATERIAL_KIND || mat.kind == MAT_DIFFUSE {
                // Next-event estimation: f = albedo / pi times sum of Le cos / pdf.
                radiance += beta * albedo * INV_PI * direct_light(sp, n, ns, &rng);
                // Continue with a cosine-weighted direction: f cos / pdf = (albedo/pi) cos / (cos/pi) = albedo.
                wi = sample_cosine_hemisphere(ns, rng_next2(&rng));
                beta *= albedo;
                count_emission = !nee_spheres;
            }
        }
        if HAS_MIRROR {
            if SINGLE_MATERIAL_KIND || mat.kind == MAT_MIRROR {
                wi = reflect_dir(d, ns);
                beta *= albedo;
                count_emission = true;
            }
        }
        if HAS_DIELECTRIC {
            if SINGLE_MATERIAL_KIND || mat.kind == MAT_DIELECTRIC {
                // eta = n_t / n_i: entering goes from the outside (index 1) into the material.
                let eta = select(1.0 / mat.ior, mat.ior, entering);
                let f = fresnel_dielectric(-dot(d, ns), eta);
                // Choose reflection with probability F, refraction with 1 - F: the weights F/F and
                // (1-F)/(1-F) cancel, so beta is unchanged (radiance scaling by eta^2 is not applied:
                // it cancels along any path that enters and leaves the same medium).
                if rng_next(&rng) < f {
                    wi = reflect_dir(d, ns);
                } else {
                    wi = refract_dir(d, ns, eta);
                    reflected = false;
                }
                count_emission = true;
            }
        }
        if HAS_SMOOTH_NORMALS {
            if sp.shading_normal && (dot(wi, n) > 0.0) != reflected {
                break;
            }
        }
        o = offset_ray_origin(sp.p, sp.err, n, wi);
        d = wi;
        // Russian roulette (unbiased): past roulette_depth, continue with probability q and divide by q.
        if HAS_ROULETTE {
            if bounces >= params.roulette_depth {
                let q = clamp(max(beta.x, max(beta.y, beta.z)), 0.05, 0.95);
                if rng_next(&rng) >= q {
                    break;
                }
                beta /= q;
            }
        }
    }
    return radiance;
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    // The dispatch covers one tile (see PassConstants); the pixel, and so its random numbers, do not
    // depend on the tiling.
    let pc = pass_constants;
    let px = gid.xy + vec2<u32>(pc.tile_x0, pc.tile_y0);
    if px.x >= pc.tile_x1 || px.y >= pc.tile_y1 || px.x >= params.width || px.y >= params.height {
        return;
    }
    let slot = px.y * params.width + px.x - pc.accum_base;
    let radiance = trace_path(px, pass_constants.sample_index);
    accumulate_sample(slot, radiance, params.guard_one);
}
