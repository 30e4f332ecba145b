// trace.wgsl: the path-tracing kernel. One invocation traces one path: sample `sample_index` of one
// pixel, added to the pixel's running sums. A pass of k samples is k dispatches in one command buffer, each
// preceded by an update of `pass_constants.sample_index`, so the sums see the samples in index order
// whatever the split into passes: N passes of k samples give the same bits as one pass of N k.
// (A push constant would do as well; a 16-byte vkCmdUpdateBuffer costs the same and keeps every input of
// the kernel a buffer binding.)
//
// How many samples one invocation may trace: Mesa's lavapipe (llvmpipe) ends every loop of an invocation
// once the invocation has run 65535 loop iterations in total (a guard in its code generator against
// runaway shaders), so a loop over samples, each looping over bounces and primitives, could be cut
// silently. The host bounds each invocation's samples by the worst case of its loops
// (render::samples_per_invocation, see main below).
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
// The pixel filter: read from `params` by the generic kernel; a constant when specialised (the switch
// on a constant then folds to one case).
override FILTER_FROM_PARAMS: bool = true;
override FILTER_KIND: u32 = 0u;

// What a sample is (params.aov): radiance, or a layer of `--aov` (trace_aov). Read from `params` by the
// generic kernel; a constant when specialised, so that a render's kernel has no AOV code at all.
const AOV_NONE: u32 = 0u;
const AOV_ALBEDO: u32 = 1u;
const AOV_NORMAL: u32 = 2u;
const AOV_DEPTH: u32 = 3u;
override AOV_FROM_PARAMS: bool = true;
override AOV_KIND: u32 = 0u;

// One sample of an `--aov` layer of the pixel, through the camera ray (o, d) that the same sample of the
// render traces (same film position and lens point), so that each layer is filtered like the image:
// - AOV_DEPTH: (t, 1, 0) with t the distance from the ray's origin to the first surface, or (0, 0, 0)
//   for a ray that leaves the scene; the host divides the means (mean distance of the hits, +inf where
//   none hit).
// - AOV_ALBEDO: bsdf_albedo of the first non-delta surface, times the weights of the delta bounces
//   (mirrors, smooth glass and metals, sampled as the render samples them) on the way there; 0 for a ray
//   that leaves the scene (the environment is light, not a surface).
// - AOV_NORMAL: that surface's shading normal n, as the surface defines it (outward on spheres, the
//   interpolated vertex normal on smooth meshes), not flipped towards the viewer; 0 for none. Stored as
//   n / 2 + 1/2, in [0, 1], because the exact accumulator sums non-negative samples only; the host
//   undoes it on the mean (2 m - 1), which the affine map commutes with.
// After max_bounces delta bounces, the surface reached counts as the first non-delta one.
fn trace_aov(kind: u32, o0: vec3<f32>, d0: vec3<f32>, rng: ptr<function, Rng>) -> vec3<f32> {
    var o = o0;
    var d = d0;
    var tint = vec3<f32>(1.0);
    for (var bounce = 0u; bounce <= params.max_bounces; bounce++) {
        let hit = scene_intersect(o, d, T_MISS);
        if hit.prim_kind == PRIM_NONE {
            break;
        }
        let sp = surface_at(o, d, hit);
        if kind == AOV_DEPTH {
            return vec3<f32>(distance(o0, sp.p), 1.0, 0.0);
        }
        let mat = textured_material(materials[hit_material(hit)], sp);
        if !bsdf_is_delta(mat) || bounce == params.max_bounces {
            if kind == AOV_NORMAL {
                return 0.5 * sp.ns + vec3<f32>(0.5);
            }
            return tint * bsdf_albedo(mat);
        }
        let f = facing(sp, d, hit);
        let bs = bsdf_sample(mat, -d, f.sh, rng);
        if bs.flags == 0u {
            break;
        }
        tint *= bs.weight;
        o = offset_ray_origin(sp.p, sp.err, f.n, bs.wi);
        d = bs.wi;
    }
    // Nothing met: albedo 0, normal 0 (stored as 1/2), depth (0, 0, 0).
    return select(vec3<f32>(0.0), vec3<f32>(0.5), kind == AOV_NORMAL);
}

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

fn camera_sample(px: vec2<u32>, sample: u32) -> CameraSample {
    if HAS_OPACITY {
        // The sample's part of the opacity test's hash (opacity.wgsl): rays of different samples with
        // the same origin and direction (a pinhole camera without a pixel filter) decide independently.
        opacity_seed = pcg4d(vec4<u32>(px.x, px.y, sample, params.seed)).x;
    }
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

fn path_begin(px: vec2<u32>, sample: u32) -> Path {
    let cam = camera_sample(px, sample);
    return Path(cam.rng, cam.o, cam.d, vec3<f32>(1.0), vec3<f32>(0.0), vec3<f32>(0.0), 0.0, NO_LIGHT,
                true, 0u);
}

// One ray cast of the path and what follows it: the emission the ray finds, then (unless the path ends
// there) next-event estimation and a BSDF-sampled continuation. Returns whether the path goes on.
// (One exit per outcome, `return` in place of the `break`s of a loop.)
fn path_step(path: ptr<function, Path>) -> bool {
    let o = (*path).o;
    let d = (*path).d;
    let beta = (*path).beta;
    let strategy = light_sampling_strategy();
    let mis = lights_mis(strategy);
    let hit = scene_intersect(o, d, T_MISS);
    if hit.prim_kind == PRIM_NONE {
        if HAS_ENVIRONMENT {
            if params.environment_light != NO_LIGHT {
                let env = lights[params.environment_light];
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
    var mat = materials[hit_material(hit)];
    if HAS_EMISSION {
        if any(mat.emission > vec3<f32>(0.0)) {
            // Front or back: against the geometric normal (outward on spheres). A mesh's emissive
            // texture multiplies the emission.
            let s = surface_at(o, d, hit);
            var le = material_emission(mat, dot(d, s.n) < 0.0);
            if HAS_EMISSIVE_TEXTURES {
                le *= surface_emission_scale(s);
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
        if mat.kind == MAT_EMITTER {
            return false;
        }
    }
    if (*path).bounces >= params.max_bounces {
        return false;
    }
    (*path).bounces += 1u;
    let sp = surface_at(o, d, hit);
    let on_sphere = select(NO_LIGHT, hit.prim_index, hit.prim_kind == PRIM_SPHERE);
    let f = facing(sp, d, hit);
    let n = f.n;
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

// One sample of an `--aov` layer (trace_aov) through the sample's camera ray; radiance is traced by
// path_begin and path_step.
fn aov_sample(kind: u32, px: vec2<u32>, sample: u32) -> vec3<f32> {
    var cam = camera_sample(px, sample);
    var rng = cam.rng;
    return trace_aov(kind, cam.o, cam.d, &rng);
}

// The sample as the accumulator takes it. The firefly clamp (render.clamp, off by default): biased by
// design, so a scene opts in. The sample is scaled, not clipped per channel, so that a clamped sample
// keeps its hue. (A NaN passes through to the accumulator, which counts it.)
fn add_sample(acc: ptr<function, Accum>, sample_radiance: vec3<f32>) {
    var radiance = sample_radiance;
    let peak = max(radiance.x, max(radiance.y, radiance.z));
    if params.sample_clamp > 0.0 && peak > params.sample_clamp {
        radiance *= params.sample_clamp / peak;
    }
    let fault = accumulate_into(acc, radiance, params.guard_one);
    if fault != 0u {
        count_sample_fault(fault);
    }
}

// One invocation: samples sample_index .. sample_index + sample_count - 1 of one pixel, added to the
// pixel's sums in index order. The pixel's accumulator entry is read once, updated in registers and
// written once.
//
// Path regeneration: the invocation traces its samples in one loop whose every iteration is one ray cast
// (path_step); when a path ends, the iteration adds it and starts the next sample. On a SIMD machine (a
// GPU's warp, lavapipe's 8-wide AVX2 lanes) an invocation whose path ended early then goes on working
// instead of idling until the longest path of its group ends, and the group runs about max over lanes
// of (sum of path lengths) iterations instead of sum over samples of (max of path lengths). The host
// sizes sample_count so that the invocation's loop iterations stay within lavapipe's budget
// (render::samples_per_invocation). The bits do not depend on sample_count: each sample is the same
// function of (pixel, sample index, seed) and is added in the same order, so any split of a pass into
// dispatches, tiles, passes or ranges gives the same image.
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
    let end = pc.sample_index + pc.sample_count;
    var acc = accum[slot];
    // An `--aov` layer instead of radiance: written with bare constant conditions, so that a specialised
    // render kernel has no AOV code (features.wgsl explains the pruning).
    if AOV_FROM_PARAMS {
        if params.aov != AOV_NONE {
            add_aov_samples(&acc, params.aov, px, pc.sample_index, end);
            accum[slot] = acc;
            return;
        }
    } else {
        if AOV_KIND != AOV_NONE {
            add_aov_samples(&acc, AOV_KIND, px, pc.sample_index, end);
            accum[slot] = acc;
            return;
        }
    }
    var sample = pc.sample_index;
    var path = path_begin(px, sample);
    loop {
        if !path_step(&path) {
            add_sample(&acc, path.radiance);
            sample += 1u;
            if sample >= end {
                break;
            }
            path = path_begin(px, sample);
        }
    }
    accum[slot] = acc;
}

fn add_aov_samples(acc: ptr<function, Accum>, kind: u32, px: vec2<u32>, first: u32, end: u32) {
    for (var sample = first; sample < end; sample++) {
        add_sample(acc, aov_sample(kind, px, sample));
    }
}
