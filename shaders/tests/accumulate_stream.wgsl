// Test kernel: feeds a stream of samples through accumulate_into, exactly as trace.wgsl adds the samples
// of a pixel, continuing from the Accum state it is given (the host chains runs: lavapipe ends an
// invocation's loops after 65535 iterations in total, so a stream of millions is cut into chunks).
//
// Sample i of a stream (i counted from the start of the whole stream) is `first` for i = 0, then `value`;
// every `nan_every`-th sample (if > 0) is NaN and every `inf_every`-th (if > 0) is +Inf. The three
// channels get x, -x (negative: counted as 0) and x / 2. `guard` is 1.0, read from the buffer so that the
// compiler cannot know it (see accumulate.wgsl).
//
// requires: accumulate.wgsl

struct Stream {
    state: Accum,
    first: f32,
    value: f32,
    start: u32, // index of the first sample of this chunk
    count: u32, // samples in this chunk
    guard: f32,
    nan_every: u32,
    inf_every: u32,
    _pad0: u32,
}

@group(0) @binding(0) var<storage, read> input: array<Stream>;
// Named `accum`, as in the render kernel.
@group(0) @binding(1) var<storage, read_write> accum: array<Accum>;

// Adds one sample to accum[slot] in place, through the render kernel's accumulate_into.
fn accumulate_sample(slot: u32, radiance: vec3<f32>, guard: f32) {
    var acc = accum[slot];
    accumulate_into(&acc, radiance, guard);
    accum[slot] = acc;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= arrayLength(&accum) {
        return;
    }
    let s = input[id.x];
    accum[id.x] = s.state;
    // NaN and Inf built from bits: WGSL constant expressions may not overflow.
    let nan = bitcast<f32>(0x7fc00000u);
    let inf = bitcast<f32>(0x7f800000u);
    for (var i = s.start; i < s.start + s.count; i++) {
        var x = select(s.value, s.first, i == 0u);
        if s.nan_every > 0u && i % s.nan_every == s.nan_every - 1u {
            x = nan;
        }
        if s.inf_every > 0u && i % s.inf_every == s.inf_every - 1u {
            x = inf;
        }
        accumulate_sample(id.x, vec3<f32>(x, -x, 0.5 * x), s.guard);
    }
}
