// trace.wgsl: the path-tracing kernel. One invocation traces the samples of one pixel for a bounded
// number of ray casts, added to the pixel's running sums; a path still going then is saved and continued
// by a later dispatch (main, at the end). A pass of k samples is one dispatch per tile that begins them,
// then dispatches over the queue of unfinished paths until none is left; each is preceded by an update of
// `pass_constants` (a push constant would do as well; a 16-byte vkCmdUpdateBuffer costs the same and
// keeps every input of the kernel a buffer binding). Sums are exact, so N passes of k samples give the
// same bits as one pass of N k.
//
// The integrator knows no material and no light: it asks bsdf.wgsl (generated from the material registry)
// for f, its pdf and a sampled
// direction, and lights.wgsl for a light sample, and applies f cos / pdf itself (next-event estimation
// with every light, plus BSDF sampling for the path's continuation).
//
// requires: features.wgsl, scene.wgsl, camera.wgsl, accumulate.wgsl

const FILTER_NONE: u32 = 0u;
const FILTER_BOX: u32 = 1u;
const FILTER_GAUSSIAN: u32 = 2u;
const FILTER_TENT: u32 = 3u;
// The pixel filter: read from `params` by the generic kernel; a constant when specialised (the switch
// on a constant then folds to one case).
override FILTER_FROM_PARAMS: bool = true;
override FILTER_KIND: u32 = 0u;
// Whether the filter is cut off at the image's edges (params.filter_in_image, film_position): likewise.
override FILTER_IN_IMAGE_FROM_PARAMS: bool = true;
override FILTER_IN_IMAGE: bool = false;
// Whether the radiance samples are splatted (params.splat, render.splat): likewise.
override SPLAT_FROM_PARAMS: bool = true;
override SPLAT: bool = false;

fn splatting() -> bool {
    return select(SPLAT, params.splat != 0u, SPLAT_FROM_PARAMS);
}

// What a sample is (params.aov): radiance, or a layer of `--aov` (aov_step). Read from `params` by the
// generic kernel; a constant when specialised, so that a render's kernel has no AOV code at all.
const AOV_NONE: u32 = 0u;
const AOV_ALBEDO: u32 = 1u;
const AOV_NORMAL: u32 = 2u;
const AOV_DEPTH: u32 = 3u;
override AOV_FROM_PARAMS: bool = true;
override AOV_KIND: u32 = 0u;

// One ray cast of a sample of an `--aov` layer of the pixel, the path's role in `main` when the kernel
// traces a layer instead of radiance. The path starts as the render's does (path_begin: same film position
// and lens point), so that each layer is filtered like the image, and follows delta bounces only:
// - AOV_DEPTH: (t, 1, 0) with t the distance from the camera ray's origin (prev_p, path_begin) to the
//   first surface, or (0, 0, 0) for a ray that leaves the scene; the host divides the means (mean distance
//   of the hits, +inf where none hit).
// - AOV_ALBEDO: bsdf_albedo of the first non-delta surface, times the weights of the delta bounces
//   (mirrors, smooth glass and metals, sampled as the render samples them) on the way there (beta); 0 for
//   a ray that leaves the scene (the environment is light, not a surface).
// - AOV_NORMAL: that surface's shading normal n, as the surface defines it (outward on spheres, the
//   interpolated vertex normal on smooth meshes), not flipped towards the viewer; 0 for none. Stored as
//   n / 2 + 1/2, in [0, 1], because the exact accumulator sums non-negative samples only; the host
//   undoes it on the mean (2 m - 1), which the affine map commutes with.
// After max_bounces delta bounces, the surface reached counts as the first non-delta one. The layer's
// value ends in `radiance` when the step returns false.
fn aov_step(kind: u32, path: ptr<function, Path>) -> bool {
    let o = (*path).o;
    let d = (*path).d;
    // Nothing met: albedo 0, normal 0 (stored as 1/2), depth (0, 0, 0).
    (*path).radiance = select(vec3<f32>(0.0), vec3<f32>(0.5), kind == AOV_NORMAL);
    let hit = scene_intersect(o, d, T_MISS);
    if hit.prim_kind == PRIM_NONE {
        return false;
    }
    let sp = surface_at(o, d, hit);
    if kind == AOV_DEPTH {
        (*path).radiance = vec3<f32>(distance((*path).prev_p, sp.p), 1.0, 0.0);
        return false;
    }
    let mat = textured_material(material_at(hit_material(hit)), sp);
    if !bsdf_is_delta(mat) || (*path).bounces >= params.max_bounces {
        if kind == AOV_NORMAL {
            (*path).radiance = 0.5 * sp.ns + vec3<f32>(0.5);
        } else {
            (*path).radiance = (*path).beta * bsdf_albedo(mat);
        }
        return false;
    }
    let f = facing(sp, d, hit);
    var rng = (*path).rng;
    let bs = bsdf_sample(mat, -d, f.sh, &rng);
    (*path).rng = rng;
    if bs.flags == 0u {
        return false;
    }
    (*path).beta *= bs.weight;
    (*path).o = offset_ray_origin(sp.p, sp.err, f.n, bs.wi);
    (*path).d = bs.wi;
    (*path).bounces += 1u;
    return true;
}

// Position on the film of one sample of pixel `px`, importance-sampled from the pixel filter: the
// filter's weight is then 1 for every sample, and the pixel value is the plain mean of its samples.
//
// With params.filter_in_image (render.sample_border = false, Mitsuba 3's default) the filter is cut off
// at the image's edges and renormalised, so that an edge pixel averages what lies on the image only:
// Mitsuba's film, which splats samples drawn on the image only with the filter's weights and divides by
// their sum, converges to that. Mitsuba's filters are separable (its film weighs a sample by f(dx) f(dy)),
// so each axis is sampled from its cut-off 1-D filter: the tent's, and the Gaussian's over Mitsuba's radius
// 4 sigma (Mitsuba's Gaussian also subtracts its value there, exp(-8) = 3.4e-4 of the peak, which is not
// modelled: it moves 0.1 % of each axis's mass towards the radius).
//
// A splatted render (splatting()) draws every sample uniformly over its pixel instead, as Mitsuba's
// film does: the filter is applied when the sample is splatted (splat.wgsl), as a weight.
fn film_position(px: vec2<u32>, rng: ptr<function, Rng>) -> vec2<f32> {
    let center = vec2<f32>(px) + vec2<f32>(0.5);
    let u = rng_next2(rng);
    let w = params.filter_width;
    let in_image = select(FILTER_IN_IMAGE, params.filter_in_image != 0u, FILTER_IN_IMAGE_FROM_PARAMS);
    // The offsets that keep the sample on the image.
    let lo = -center;
    let hi = vec2<f32>(f32(params.width), f32(params.height)) - center;
    var x = center;
    let kind = select(FILTER_KIND, params.filter_kind, FILTER_FROM_PARAMS);
    switch select(kind, FILTER_BOX, splatting()) {
        case FILTER_BOX: {
            x = vec2<f32>(px) + u;
        }
        case FILTER_GAUSSIAN: {
            if in_image {
                let r = 4.0 * w;
                x = center + vec2<f32>(sample_gaussian_within(u.x, w, max(-r, lo.x), min(r, hi.x)),
                                       sample_gaussian_within(u.y, w, max(-r, lo.y), min(r, hi.y)));
            } else {
                x = center + sample_gaussian2(u, w);
            }
        }
        case FILTER_TENT: {
            if in_image {
                x = center + vec2<f32>(sample_tent_within(u.x, w, max(-w, lo.x), min(w, hi.x)),
                                       sample_tent_within(u.y, w, max(-w, lo.y), min(w, hi.y)));
            } else {
                x = center + sample_tent2(u, w);
            }
        }
        default: {}
    }
    return x;
}

// A hit seen along d: the geometric normal turned to the side d came from (both faces scatter) and the
// frame its material is shaded in (Shading, bsdfs/common.wgsl). Smooth, normal- and bump-mapped
// surfaces scatter about their shading normal ns (on the same side as n); everything else about n. A
// direction chosen about ns can still point below the geometric surface near a silhouette; such a path
// ends there (absorbed: path_step), rather than leaking through the mesh. That loses a little energy at
// grazing angles, the usual price of shading normals (pbrt-v4 §10.1). The tangent is the direction
// anisotropic roughness runs along (zero, and not computed, without anisotropy).
struct Facing {
    n: vec3<f32>,
    sh: Shading,
}

fn facing(sp: Surface, d: vec3<f32>, hit: Hit) -> Facing {
    let entering = dot(d, sp.n) < 0.0;
    let n = select(-sp.n, sp.n, entering);
    var sh = Shading(n, vec3<f32>(0.0), entering, false);
    if HAS_SMOOTH_NORMALS || HAS_NORMAL_MAPS || HAS_BUMP_MAPS {
        sh.ns = select(-sp.ns, sp.ns, entering);
        sh.perturbed = sp.shading_normal;
    }
    if HAS_ANISOTROPY {
        sh.tangent = surface_tangent(hit, sp.n);
    }
    return Facing(n, sh);
}

// The cosine factor of direct light arriving along wi: dot(n, wi), or with a shading normal dot(ns, wi)
// provided the light is above the geometric surface too (a shadow ray towards a light below it would
// start on the far side).
fn light_cosine(sp: Surface, n: vec3<f32>, ns: vec3<f32>, wi: vec3<f32>) -> f32 {
    var cos_theta = dot(n, wi);
    if HAS_SMOOTH_NORMALS || HAS_NORMAL_MAPS || HAS_BUMP_MAPS {
        if sp.shading_normal && cos_theta > 0.0 {
            cos_theta = dot(ns, wi);
        }
    }
    return cos_theta;
}

// Next-event estimation at a surface point with material `mat`, seen from direction wo: for each
// selected light, one light sample (L, wi, pdf) and the estimate f(wo, wi) L |cos(theta)| / (pdf pmf) if
// the sampled point on the light is visible. n is the facing geometric normal, sh the shading frame
// (facing): its ns is the same vector except on smooth, normal- and bump-mapped surfaces. Lights
// behind the surface count only for a material that transmits (rough glass); the shadow ray then
// leaves from the far side. `on_sphere` is the sphere the point lies on (or
// NO_LIGHT): a sphere light is not sampled from its own surface, whose rounding puts the point a hair
// inside or outside it (outside, its cone would be nearly a hemisphere of directions that the sphere
// itself blocks); its light reaches the point by BSDF-sampled rays instead, which then count in full
// (emitter_light_pdf is 0 for them too).
//
// With multiple importance sampling (`mis`), a sample of a non-delta light is weighted by the power
// heuristic against the density bsdf_pdf would have given its direction; trace_path weighs the BSDF's
// own samples that hit the light the other way round (emission_weight), so the two estimates of that
// light's contribution add up to one unbiased estimate (Veach 1997, ch. 9), each strategy dominating
// where it is good.
fn direct_light(mat: Material, sp: Surface, n: vec3<f32>, sh: Shading, wo: vec3<f32>, mis: bool,
                on_sphere: u32, rng: ptr<function, Rng>) -> vec3<f32> {
    let ns = sh.ns;
    var l = vec3<f32>(0.0);
    let strategy = light_sampling_strategy();
    let transmits = bsdf_transmits(mat);
    for (var k = 0u; k < light_selection_count(); k++) {
        let chosen = light_select(k);
        var ls = light_sample_li(chosen.light, sp.p, strategy, rng);
        if HAS_TRIANGLE_LIGHTS {
            if HAS_EMISSIVE_TEXTURES {
                if ls.triangle != NO_LIGHT && ls.pdf > 0.0 {
                    ls.L *= emission_texture(ls.triangle, ls.p_light);
                }
            }
        }
        if HAS_SPHERE_LIGHTS {
            if chosen.light.kind == LIGHT_SPHERE && chosen.light.index == on_sphere {
                ls.pdf = 0.0;
            }
        }
        var cos_theta = light_cosine(sp, n, ns, ls.wi);
        if transmits && dot(n, ls.wi) < 0.0 {
            cos_theta = light_cosine(sp, -n, -ns, ls.wi);
        }
        // (Nested tests rather than `continue`: one exit per iteration, as in the dispatchers.)
        if ls.pdf > 0.0 && cos_theta > 0.0 {
            var shadow = spawn_ray_to(sp.p, sp.err, n, ls.p_light);
            if HAS_DIRECTIONAL_LIGHTS || HAS_ENVIRONMENT {
                if ls.dist >= T_MISS {
                    shadow = spawn_ray_towards(sp.p, sp.err, n, ls.wi);
                }
            }
            if !scene_occluded(shadow.o, shadow.d, shadow.t_max) {
                let f = bsdf_eval(mat, wo, ls.wi, sh);
                let pdf = ls.pdf * chosen.pmf;
                // Suns are not weighed: a BSDF-sampled ray counts them only after delta bounces.
                var w = 1.0;
                if mis && !ls.delta && chosen.light.kind != LIGHT_DIRECTIONAL {
                    w = power_heuristic(pdf, bsdf_pdf(mat, wo, ls.wi, sh));
                }
                l += f * ls.L * (w * cos_theta / pdf);
            }
        }
    }
    return l;
}

// Whether a ray can find emission: some surface emits, or light comes from infinity (the environment,
// a sun of nonzero size seen through a mirror or glass). Bare constant conditions: the specialised
// kernel folds it to a constant.
fn rays_find_emission() -> bool {
    if HAS_EMISSION {
        return true;
    }
    if HAS_ENVIRONMENT {
        return true;
    }
    if HAS_DIRECTIONAL_LIGHTS {
        return true;
    }
    return false;
}

// The radiance of the suns whose cones contain direction d.
fn suns_seen(d: vec3<f32>) -> vec3<f32> {
    var l = vec3<f32>(0.0);
    for (var k = 0u; k < light_selection_count(); k++) {
        let light = light_select(k).light;
        if light.kind == LIGHT_DIRECTIONAL {
            l += light_radiance(light, d);
        }
    }
    return l;
}

// The camera ray of sample `sample` of pixel px, and the sample's random numbers, positioned after the
// film and lens dimensions (0 and 1).
struct CameraSample {
    o: vec3<f32>,
    d: vec3<f32>,
    rng: Rng,
}

// The sample's part of the opacity test's hash (opacity.wgsl): rays of different samples with the same
// origin and direction (a pinhole camera without a pixel filter) decide independently. Set when a sample
// begins and when its path is taken up again in a later dispatch.
fn set_opacity_seed(px: vec2<u32>, sample: u32) {
    if HAS_OPACITY || HAS_BLEND_MATERIALS {
        opacity_seed = pcg4d(vec4<u32>(px.x, px.y, sample, params.seed)).x;
    }
}

fn camera_sample(px: vec2<u32>, sample: u32) -> CameraSample {
    set_opacity_seed(px, sample);
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
    var cam = camera_ray(params.cam_position, params.cam_right, params.cam_up, params.cam_forward,
                         params.view_half_width, params.width, params.height, film,
                         lens_radius, params.focus_distance, lens);
    if HAS_ORTHOGRAPHIC {
        if params.camera_kind == CAMERA_ORTHOGRAPHIC {
            cam = orthographic_ray(params.cam_position, params.cam_right, params.cam_up,
                                   params.cam_forward, params.view_half_width, params.width,
                                   params.height, film);
        }
    }
    return CameraSample(cam.o, cam.d, rng);
}

// A path in flight: everything trace_path carries from one ray cast to the next. The kernel keeps one per
// invocation and, when its path ends, starts the invocation's next sample in the same state (path
// regeneration, main below).
//
// The path's estimate: L = sum over vertices of beta * (emission seen by a specular chain, or direct
// light by next-event estimation at non-delta vertices), with beta the product of f cos / pdf along the
// path. Emission found by a ray (a surface's, the environment's) counts in full on camera rays and after
// delta bounces (mirror, glass), where no light sample competed; after a non-delta bounce, with
// emission_weight against the light's sampling of the same direction from the previous vertex (prev_p,
// where the BSDF sampled it with density prev_pdf).
struct Path {
    rng: Rng,
    o: vec3<f32>,
    d: vec3<f32>,
    beta: vec3<f32>,
    radiance: vec3<f32>,
    prev_p: vec3<f32>,
    prev_pdf: f32,
    prev_sphere: u32, // the sphere prev_p lies on, if any
    // Whether the ray was spawned by a delta bounce (or is the camera ray): then no light sample at its
    // origin could have found what it finds.
    last_delta: bool,
    bounces: u32,
}

// The camera ray of the sample. prev_p starts at the camera (an AOV path's depth is measured from it;
// a radiance path reads prev_p only after a non-delta bounce has set it).
fn path_begin(px: vec2<u32>, sample: u32) -> Path {
    let cam = camera_sample(px, sample);
    return Path(cam.rng, cam.o, cam.d, vec3<f32>(1.0), vec3<f32>(0.0), cam.o, 0.0, NO_LIGHT, true, 0u);
}

// Paths ended by the bounce limit are counted when the limit is BOUNCE_CAP (abi.rs: the scene asked for
// no limit, or for more bounces than the cap): such a path would have gone on, so its sample is short of
// light, and the host reports how many there were.
fn count_bounce_cap() {
    if params.max_bounces >= BOUNCE_CAP {
        atomicAdd(&sample_faults[FAULT_BOUNCE_CAP], 1u);
    }
}

// One ray cast of the path and what follows it: the emission the ray finds, then (unless the path ends
// there) next-event estimation and a BSDF-sampled continuation. Returns whether the path goes on.
// (One exit per outcome, `return` in place of the `break`s of a loop.)
fn path_step(path: ptr<function, Path>) -> bool {
    let o = (*path).o;
    let d = (*path).d;
    var beta = (*path).beta;
    let strategy = light_sampling_strategy();
    let mis = lights_mis(strategy);
    let hit = scene_intersect(o, d, T_MISS);
    if hit.prim_kind == PRIM_NONE {
        if HAS_ENVIRONMENT {
            if params.environment_light != NO_LIGHT {
                let env = light_at(params.environment_light);
                var w = 1.0;
                if !(*path).last_delta {
                    w = emission_weight((*path).prev_pdf, light_pdf_li(env, (*path).prev_p, d, strategy),
                                        strategy);
                }
                (*path).radiance += beta * environment_radiance(env, d) * w;
            }
        }
        // A sun of nonzero size seen directly, or through a mirror or glass (its caustics included):
        // after a non-delta bounce it was light-sampled instead (suns are not weighed by mis).
        if HAS_DIRECTIONAL_LIGHTS {
            if (*path).last_delta {
                (*path).radiance += beta * suns_seen(d);
            }
        }
        return false;
    }
    let hit_mat = hit_material(hit);
    var mat = material_at(hit_mat);
    // What the hit needs its surface (normal, uv, shading frame: surface_at) for: a glTF volume's
    // boundary, emission, a path that goes on. A path that ends here with none of them (at the bounce
    // limit, or on a black emitter) needs none; otherwise one surface_at serves all three (inlined once:
    // the compiler inlines every call site, and the generic kernel's surface_at is large).
    var volume = false;
    if HAS_GLTF_PBR {
        volume = mat.kind == MAT_GLTF_PBR && (mat.flags & MATERIAL_VOLUME) != 0u;
    }
    var emits = false;
    if HAS_EMISSION {
        emits = any(mat.emission > vec3<f32>(0.0));
    }
    var on_emitter = false;
    if HAS_EMITTERS {
        on_emitter = mat.kind == MAT_EMITTER;
    }
    let at_limit = (*path).bounces >= params.max_bounces;
    if (at_limit || on_emitter) && !volume && !emits {
        if !on_emitter {
            count_bounce_cap();
        }
        return false;
    }
    let sp = surface_at(o, d, hit);
    // A path inside a glTF volume (KHR_materials_volume) meets its boundary from behind (the side its
    // geometric normal points away from, as `facing` decides below): the segment it travelled lay inside,
    // where the medium absorbs exp(-sigma_a t) (Beer-Lambert; d is a unit vector, so t is the distance).
    // Everything this path gathers from here on passes through that factor, the emission found at this
    // boundary first (light that crossed the medium too).
    if HAS_GLTF_PBR {
        if volume && dot(d, sp.n) >= 0.0 {
            beta *= exp(-vec3<f32>(material_coat(mat, 4), material_coat(mat, 5), material_coat(mat, 6)) * hit.t);
        }
    }
    if HAS_EMISSION {
        if emits {
            // Front or back: against the geometric normal (outward on spheres). A mesh's emissive
            // texture multiplies the emission.
            var le = material_emission(mat, dot(d, sp.n) < 0.0);
            if HAS_EMISSIVE_TEXTURES {
                le *= surface_emission_scale(sp);
            }
            var w = 1.0;
            if !(*path).last_delta {
                w = emission_weight((*path).prev_pdf,
                                    emitter_light_pdf(hit, (*path).prev_p, (*path).prev_sphere, d, strategy),
                                    strategy);
            }
            (*path).radiance += beta * le * w;
        }
    }
    if HAS_EMITTERS {
        if on_emitter {
            return false;
        }
    }
    if at_limit {
        count_bounce_cap();
        return false;
    }
    (*path).bounces += 1u;
    let on_sphere = select(NO_LIGHT, hit.prim_index, hit.prim_kind == PRIM_SPHERE);
    let f = facing(sp, d, hit);
    let n = f.n;
    // A one-sided material (Mitsuba's BSDFs without `twosided`) is black from behind: the path ends on
    // its back face, after the emission found there counted (above), unless the material has a back
    // material, which scatters there as on its own front. surface_at chose the material the hit shows
    // (a back material, a blend's): shaded with it from here on.
    let back_face = !f.sh.entering;
    if back_face && (mat.flags & MATERIAL_ONE_SIDED) != 0u && !(HAS_BACK_MATERIALS && mat.back != 0u) {
        return false;
    }
    if (HAS_BACK_MATERIALS || HAS_BLEND_MATERIALS) && sp.material != hit_mat {
        mat = material_at(sp.material);
    }
    // The material's textured parameters at the hit (textured_material, scene.wgsl).
    mat = textured_material(mat, sp);
    let wo = -d;
    var rng = (*path).rng;
    if !bsdf_is_delta(mat) {
        (*path).radiance += beta * direct_light(mat, sp, n, f.sh, wo, mis, on_sphere, &rng);
    }
    // After the last scattering event the continuation ray can only add the emission it finds (an
    // emitting surface, the environment, a sun seen through glass). In a scene where nothing a ray can
    // hit emits (lights that are points or delta suns only: a constant of the specialised kernel), that
    // is exactly nothing, so the path ends here without sampling the BSDF or casting the ray: the same
    // bits, one ray cast fewer per path (half the rays of a one-bounce scene).
    if (*path).bounces >= params.max_bounces && !rays_find_emission() {
        count_bounce_cap();
        return false;
    }
    let bs = bsdf_sample(mat, wo, f.sh, &rng);
    (*path).rng = rng;
    if bs.flags == 0u {
        return false; // absorbed
    }
    var beta_next = beta * bs.weight;
    let delta = (bs.flags & BSDF_DELTA) != 0u;
    (*path).prev_pdf = select(bs.pdf, 0.0, delta);
    (*path).prev_p = sp.p;
    (*path).prev_sphere = on_sphere;
    (*path).last_delta = delta;
    if HAS_SMOOTH_NORMALS || HAS_NORMAL_MAPS || HAS_BUMP_MAPS {
        // wi must leave on the side the ray came from (reflection) or cross (transmission).
        let reflected = (bs.flags & BSDF_REFLECTION) != 0u;
        if sp.shading_normal && (dot(bs.wi, n) > 0.0) != reflected {
            return false;
        }
    }
    (*path).o = offset_ray_origin(sp.p, sp.err, n, bs.wi);
    (*path).d = bs.wi;
    // Russian roulette (unbiased): past roulette_depth, continue with probability q and divide by q.
    if HAS_ROULETTE {
        if (*path).bounces >= params.roulette_depth {
            let q = clamp(max(beta_next.x, max(beta_next.y, beta_next.z)), 0.05, 0.95);
            if rng_next(&rng) >= q {
                (*path).rng = rng;
                return false;
            }
            (*path).rng = rng;
            beta_next /= q;
        }
    }
    (*path).beta = beta_next;
    return true;
}

// The sample as the accumulator takes it. The firefly clamp (render.clamp, off by default): biased by
// design, so a scene opts in. The sample is scaled, not clipped per channel, so that a clamped sample
// keeps its hue. (A NaN passes through to the accumulator, which counts it.)
fn clamped_sample(sample_radiance: vec3<f32>) -> vec3<f32> {
    var radiance = sample_radiance;
    let peak = max(radiance.x, max(radiance.y, radiance.z));
    if params.sample_clamp > 0.0 && peak > params.sample_clamp {
        radiance *= params.sample_clamp / peak;
    }
    return radiance;
}

fn add_sample(acc: ptr<function, Accum>, sample_radiance: vec3<f32>) {
    let fault = accumulate_into(acc, clamped_sample(sample_radiance), params.guard_one);
    if fault != 0u {
        count_sample_fault(fault);
    }
}

// A splatted render's samples of the current pass, for the film-side gather that follows the pass
// (splat.wgsl): record (s - pass_start) * pixels + pixel holds sample s of the pixel, its radiance as the
// accumulator takes it (clamped by render.clamp; a non-finite or negative channel as 0, which the
// accumulator has counted) and, in w, its position in the pixel as two 16-bit fixed-point fractions
// (pack2x16unorm: within 2^-17 of a pixel of where the ray went; the gather weighs the sample by that
// rounded position, the same for every split of the render).
@group(0) @binding(48) var<storage, read_write> splat_samples: array<vec4<f32>>;

fn splat_record(px: vec2<u32>, sample: u32, sample_radiance: vec3<f32>) {
    var l = max(clamped_sample(sample_radiance), vec3<f32>(0.0));
    if !is_finite_vec3(l) {
        l = vec3<f32>(0.0);
    }
    // The film position's numbers again (film_position: the first pair of the sample's sequence, a pure
    // function of pixel, sample and seed), so that the path need not carry them.
    var rng = rng_new_sampler(px.y * params.width + px.x, sample, params.seed, params.sampler);
    let u = rng_next2(&rng);
    let pixels = params.width * params.height;
    let i = (sample - pass_constants.pass_start) * pixels + px.y * params.width + px.x;
    splat_samples[i] = vec4<f32>(l, bitcast<f32>(pack2x16unorm(u)));
}

// A path between two dispatches: Path packed into 16-byte rows (the booleans and counters bitcast into
// the fourth lanes), with its pixel and the samples the pixel still has to trace in this pass. Exact: a
// path taken up again continues with the same bits it would have had without the break.
struct PathState {
    o_pdf: vec4<f32>, // o, prev_pdf
    d_sphere: vec4<f32>, // d, prev_sphere
    beta_bounces: vec4<f32>, // beta, bounces
    radiance_delta: vec4<f32>, // radiance, last_delta
    prev_p_dim: vec4<f32>, // prev_p, the rng's next dimension
    pixel: vec4<u32>, // px.x, px.y, the sample being traced, the end of the pixel's samples
}

@group(0) @binding(18) var<storage, read_write> path_state: array<PathState>;
@group(0) @binding(19) var<storage, read_write> path_queue: array<u32>;
@group(0) @binding(20) var<storage, read_write> path_count: atomic<u32>;

fn path_save(p: Path, px: vec2<u32>, sample: u32, end: u32) -> PathState {
    return PathState(vec4<f32>(p.o, p.prev_pdf), vec4<f32>(p.d, bitcast<f32>(p.prev_sphere)),
                     vec4<f32>(p.beta, bitcast<f32>(p.bounces)),
                     vec4<f32>(p.radiance, bitcast<f32>(select(0u, 1u, p.last_delta))),
                     vec4<f32>(p.prev_p, bitcast<f32>(p.rng.dim)), vec4<u32>(px, sample, end));
}

fn path_load(s: PathState) -> Path {
    let px = s.pixel.xy;
    let sample = s.pixel.z;
    set_opacity_seed(px, sample);
    var rng = rng_new_sampler(px.y * params.width + px.x, sample, params.seed, params.sampler);
    rng.dim = bitcast<u32>(s.prev_p_dim.w);
    return Path(rng, s.o_pdf.xyz, s.d_sphere.xyz, s.beta_bounces.xyz, s.radiance_delta.xyz,
                s.prev_p_dim.xyz, s.o_pdf.w, bitcast<u32>(s.d_sphere.w),
                bitcast<u32>(s.radiance_delta.w) != 0u, bitcast<u32>(s.beta_bounces.w));
}

// One ray cast of the path: radiance (path_step) or, when the kernel traces an `--aov` layer, aov_step.
// Written with bare constant conditions, so that a render's kernel has no AOV code and a layer's no
// radiance code (features.wgsl explains the pruning). Every kernel the host builds, the generic one
// included, fixes AOV_KIND (src/kernel/features.rs, FeatureSet::generic); reading it from the
// parameters is what a kernel with the knob left open would do.
fn step(path: ptr<function, Path>) -> bool {
    if AOV_FROM_PARAMS {
        if params.aov != AOV_NONE {
            return aov_step(params.aov, path);
        }
    } else {
        if AOV_KIND != AOV_NONE {
            return aov_step(AOV_KIND, path);
        }
    }
    return path_step(path);
}

// One invocation traces the samples of one pixel, in index order, added to the pixel's exact sums
// (accumulate.wgsl), for at most `casts` ray casts; a path still going then is saved and continued by
// the next dispatch. That is a wavefront in its simplest form (Laine, Karras & Aila, "Megakernels
// considered harmful", HPG 2013): the path's state lives in a device buffer between dispatches, and the
// queue of live paths is compacted between them. It is what makes paths of any length and scenes of any
// size possible: Mesa's lavapipe (llvmpipe) ends every loop of an invocation once the invocation has run
// 65535 loop iterations in total (a guard in its code generator against runaway shaders), and one
// invocation's loops now run at most `casts` ray casts whatever the path length; the host sizes
// `casts` from one cast's worst case (render::casts_per_dispatch) and bounds the dispatch's duration by
// its tile.
//
// A dispatch with `queued` = 0 begins the tile's pixels: samples sample_index .. + sample_count - 1,
// invocation (x, y) the pixel (tile_x0 + x, tile_y0 + y), whose state slot is y * tile width + x. A
// dispatch with `queued` > 0 continues the paths listed at path_queue[queue_in ..], one invocation each
// (invocation (x, y) the entry y * tile width + x). The host dispatches until no path is left.
//
// Path regeneration: when a path ends, the invocation adds it and starts the pixel's next sample in the
// same iteration. On a SIMD machine (a GPU's warp, lavapipe's 8-wide AVX2 lanes) an invocation whose
// path ended early then goes on working instead of idling until the longest path of its group ends.
//
// The bits do not depend on `casts`, the tiling or the order of the queue: each sample is the same
// function of (pixel, sample index, seed), a saved path resumes exactly, and the pixel's samples are
// added in index order to an exact sum, so that any split of a render gives the same image.
// Adaptive sampling's list of the pixels still sampling (PassConstants.list_start, list_len), as
// row-major pixel indices y * width + x, ascending.
@group(0) @binding(49) var<storage, read> active_pixels: array<u32>;

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let pc = pass_constants;
    let tile_w = pc.tile_x1 - pc.tile_x0;
    var slot = gid.y * tile_w + gid.x;
    var px = gid.xy + vec2<u32>(pc.tile_x0, pc.tile_y0);
    var sample = pc.sample_index;
    var end = pc.sample_index + pc.sample_count;
    var path: Path;
    // Whether `path` is to begin (sample `sample` of pixel px) at the top of the loop: one call site of
    // path_begin for the first sample and every regenerated one, so that the driver, which inlines
    // every call, compiles the camera's sampling once (docs/performance.md, compile time).
    var begin = pc.queued == 0u;
    if pc.queued == 0u && pc.list_len != 0u {
        // Adaptive sampling: the pixels still sampling, listed by the host (row-major indices).
        if gid.x >= tile_w || slot >= pc.list_len {
            return;
        }
        let p = active_pixels[pc.list_start + slot];
        px = vec2<u32>(p % params.width, p / params.width);
    } else if pc.queued == 0u {
        if px.x >= pc.tile_x1 || px.y >= pc.tile_y1 || px.x >= params.width || px.y >= params.height {
            return;
        }
    } else {
        if gid.x >= tile_w || slot >= pc.queued {
            return;
        }
        slot = path_queue[pc.queue_in + slot];
        let saved = path_state[slot];
        px = saved.pixel.xy;
        sample = saved.pixel.z;
        end = saved.pixel.w;
        path = path_load(saved);
    }
    let accum_slot = px.y * params.width + px.x - pc.accum_base;
    var acc = accum[accum_slot];
    var added = false;
    var casts = 0u;
    loop {
        if begin {
            path = path_begin(px, sample);
            begin = false;
        }
        if casts >= pc.casts {
            path_state[slot] = path_save(path, px, sample, end);
            path_queue[pc.queue_out + atomicAdd(&path_count, 1u)] = slot;
            break;
        }
        casts += 1u;
        if !step(&path) {
            add_sample(&acc, path.radiance);
            if splatting() {
                splat_record(px, sample, path.radiance);
            }
            added = true;
            sample += 1u;
            if sample >= end {
                break;
            }
            begin = true;
        }
    }
    if added {
        accum[accum_slot] = acc;
    }
}
