// A picture on top of the frame: a rectangle (NDC left, top, right, bottom)
// textured with it, drawn as a four-vertex strip.

@group(0) @binding(0) var<uniform> rect: vec4<f32>;
@group(0) @binding(1) var picture: texture_2d<f32>;
@group(0) @binding(2) var picture_sampler: sampler;

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) uv: vec2<f32>,
};

@vertex
fn vs(@builtin(vertex_index) i: u32) -> VsOut {
    let u = f32(i & 1u);
    let v = f32(i >> 1u);
    var out: VsOut;
    out.clip = vec4<f32>(mix(rect.x, rect.z, u), mix(rect.y, rect.w, v), 0.0, 1.0);
    out.uv = vec2<f32>(u, v);
    return out;
}

@fragment
fn fs(in: VsOut) -> @location(0) vec4<f32> {
    return textureSample(picture, picture_sampler, in.uv);
}
