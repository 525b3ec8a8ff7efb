// hom's scene through wgpu: one draw per object, the object's id as the
// instance index (its record in `objects`), flat shading as hom's software
// renderer shades (colour × (0.25 + 0.75 |n · v|)), and the object id for
// the item target. hom's clip space is wgpu's: z / w in [0, 1], y up.

struct Frame {
    view_proj: mat4x4<f32>,
    eye: vec4<f32>,
    // x: 1 when the false-colour overlay is on.
    flags: vec4<u32>,
};

struct Object {
    model: mat4x4<f32>,
    colour: vec4<f32>,
};

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var<storage, read> objects: array<Object>;
// Per object this frame: 0 drawn, 1 drawn as an occluder.
@group(0) @binding(2) var<storage, read> roles: array<u32>;

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) @interpolate(flat) id: u32,
    // The object's colour, false colour applied: read once a vertex, not
    // once a fragment (lavapipe's fragments pay for every storage read).
    @location(2) @interpolate(flat) colour: vec3<f32>,
};

@vertex
fn vs(@location(0) position: vec3<f32>, @builtin(instance_index) id: u32) -> VsOut {
    let world = objects[id].model * vec4<f32>(position, 1.0);
    var out: VsOut;
    out.clip = frame.view_proj * world;
    out.world = world.xyz;
    out.id = id;
    out.colour = objects[id].colour.rgb;
    if frame.flags.x == 1u && roles[id] == 1u {
        // Occluders blue, as `hom render --false-colour` draws them.
        out.colour = mix(out.colour, vec3<f32>(0.2, 0.4, 1.0), 0.75);
    }
    return out;
}

// Two-sided headlight Lambert on the face normal, from the world position's
// screen derivatives (constant over a triangle, as the software renderer's).
// |n · v| as |c · d| / (|c| |d|), one inverse square root.
fn headlight(world: vec3<f32>) -> f32 {
    let c = cross(dpdx(world), dpdy(world));
    let d = frame.eye.xyz - world;
    return 0.25 + 0.75 * min(abs(dot(c, d)) * inverseSqrt(max(dot(c, c) * dot(d, d), 1e-30)), 1.0);
}

@fragment
fn fs_colour(in: VsOut) -> @location(0) vec4<f32> {
    return vec4<f32>(in.colour * headlight(in.world), 1.0);
}

// Culled objects drawn through what hides them: no depth test, blended.
@fragment
fn fs_ghost(in: VsOut) -> @location(0) vec4<f32> {
    return vec4<f32>(vec3<f32>(1.0, 0.25, 0.2) * headlight(in.world), 0.35);
}

@fragment
fn fs_item(in: VsOut) -> @location(0) u32 {
    return in.id;
}
