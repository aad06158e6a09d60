"""GLSL 410 sources of the renderer's programs (shadow, sky, lit colour, labels + depth).

The mesh programs draw one batch of instances (:mod:`usdworld.render.batches`): each
vertex is a corner of the mesh in its own frame (``in_pos``, double precision) and each
instance brings the top three rows of its world_from_local transform (``in_r0..2``,
double precision). The corner is placed in double precision and then rounded to float,
which gives the same float32 world position as placing it on the CPU in float64 (as
:func:`~usdworld.render.usd_mesh.place_mesh` does), so the instanced draw rasterises the
same triangles as drawing the placed ones.
"""

from __future__ import annotations

#: Placing one corner (shared by every mesh program, so that all compute the same position).
_PLACE = """
in dvec3 in_pos;
in dvec4 in_r0;
in dvec4 in_r1;
in dvec4 in_r2;
vec3 world_position() {
    dmat4 m = transpose(dmat4(in_r0, in_r1, in_r2, dvec4(0.0, 0.0, 0.0, 1.0)));
    return vec3((m * dvec4(in_pos, 1.0)).xyz);
}
"""

SHADOW_VS = (
    """
#version 410
uniform mat4 u_sun_vp;
"""
    + _PLACE
    + """
void main() { gl_Position = u_sun_vp * vec4(world_position(), 1.0); }
"""
)

SHADOW_FS = """
#version 410
void main() {}
"""

# Full-screen triangle; each pixel's viewing ray gives its elevation -> sky gradient.
SKY_VS = """
#version 410
out vec2 v_ndc;
void main() {
    vec2 p = vec2((gl_VertexID == 1) ? 3.0 : -1.0, (gl_VertexID == 2) ? 3.0 : -1.0);
    v_ndc = p;
    gl_Position = vec4(p, 1.0, 1.0);
}
"""

SKY_FS = """
#version 410
uniform mat3 u_world_from_px;   // R_world_from_cam * inverse(K), applied to (u, v, 1)
uniform vec2 u_size;            // image width, height
uniform vec3 u_zenith;
uniform vec3 u_horizon;
out vec4 f_color;
void main() {
    // gl_FragCoord is at pixel centres (i + 0.5) with y up; OpenCV centres are at integers, v down.
    vec2 px = vec2(gl_FragCoord.x - 0.5, u_size.y - gl_FragCoord.y - 0.5);
    vec3 ray = normalize(u_world_from_px * vec3(px, 1.0));
    float t = clamp(ray.z, 0.0, 1.0);
    f_color = vec4(mix(u_horizon, u_zenith, pow(t, 0.6)), 1.0);
}
"""

# Depth only, for the colour pass's depth pre-pass: ``invariant`` here, in LIT_VS and in
# LABEL_VS (whose depth serves as the pre-pass in ``Renderer.render``) makes the programs
# compute the same gl_Position, so the lit pass's "<=" test passes exactly the
# surface that is seen and shades each pixel once.
DEPTH_VS = (
    """
#version 410
invariant gl_Position;
uniform mat4 u_view_proj;
"""
    + _PLACE
    + """
void main() { gl_Position = u_view_proj * vec4(world_position(), 1.0); }
"""
)

DEPTH_FS = SHADOW_FS

# The normal is the mesh's (authored, or the face's) times the cofactor matrix of the
# instance's linear part (``in_n0..2``, its columns; det times the inverse transpose): the
# placed triangle's normal up to length and sign (the fragment shader normalises it and turns
# it to the eye), also for a scale that flattens the mesh.
LIT_VS = (
    """
#version 410
invariant gl_Position;
uniform mat4 u_view_proj;
in vec3 in_normal;
in vec3 in_n0;
in vec3 in_n1;
in vec3 in_n2;
in vec3 in_color;
out vec3 v_pos;
out vec3 v_normal;
out vec3 v_color;
"""
    + _PLACE
    + """
void main() {
    vec3 p = world_position();
    v_pos = p;
    v_normal = mat3(in_n0, in_n1, in_n2) * in_normal;
    v_color = in_color;
    gl_Position = u_view_proj * vec4(p, 1.0);
}
"""
)

_LIT_HEAD = """
#version 410
#ifndef SUNLIT
#define SUNLIT 1
#endif
uniform sampler2DShadow u_shadow_map;
uniform mat4 u_sun_vp;
uniform vec3 u_sun_dir;
uniform vec3 u_sun_color;
uniform vec3 u_sky_ambient;
uniform vec3 u_ground_ambient;
uniform vec3 u_eye;
uniform float u_specular;
uniform float u_shininess;
uniform float u_inv_gamma;
uniform float u_normal_offset;   // metres (about 1.5 shadow texels)
uniform float u_map_size;        // shadow map size, texels
in vec3 v_pos;
in vec3 v_normal;
in vec3 v_color;
out vec4 f_color;

"""

#: The still's shadow filter: a 3x3 PCF in four bilinear depth comparisons.
_SUN_VISIBILITY_PCF3 = """float sun_visibility(vec3 n) {
    vec4 p = u_sun_vp * vec4(v_pos + n * u_normal_offset, 1.0);
    vec3 s = p.xyz / p.w * 0.5 + 0.5;
    if (s.x < 0.0 || s.x > 1.0 || s.y < 0.0 || s.y > 1.0) return 1.0;
    float ref = s.z - 5e-4;
    // A 3x3 PCF: nine bilinear depth comparisons at whole-texel offsets -1, 0, 1 weigh the 4x4
    // texels around s by (1 - f, 1, 1, f) per axis (f: s's fraction between texel centres).
    // Two bilinear taps per axis give the same weights: one between the first two texels
    // (weights 1 - f and 1: total 2 - f), one between the last two (1 and f: total 1 + f).
    vec2 t = s.xy * u_map_size - 0.5;   // texel centres at whole numbers
    vec2 i = floor(t);
    vec2 f = t - i;
    vec2 w0 = 2.0 - f;
    vec2 w1 = 1.0 + f;
    vec2 c0 = (i - 0.5 + 1.0 / w0) / u_map_size;
    vec2 c1 = (i + 1.5 + f / w1) / u_map_size;
    float sum = w0.x * w0.y * texture(u_shadow_map, vec3(c0.x, c0.y, ref))
              + w1.x * w0.y * texture(u_shadow_map, vec3(c1.x, c0.y, ref))
              + w0.x * w1.y * texture(u_shadow_map, vec3(c0.x, c1.y, ref))
              + w1.x * w1.y * texture(u_shadow_map, vec3(c1.x, c1.y, ref));
    return sum / 9.0;
}

"""

#: The fly-through's shadow filter (``video.shadow_taps`` = 1): one bilinear depth comparison,
#: the 2x2 texels around the point weighed by their distance (a 2x2 PCF; its penumbra is one
#: texel wide instead of two, so shadow edges are a little harder).
_SUN_VISIBILITY_BILINEAR = """float sun_visibility(vec3 n) {
    vec4 p = u_sun_vp * vec4(v_pos + n * u_normal_offset, 1.0);
    vec3 s = p.xyz / p.w * 0.5 + 0.5;
    if (s.x < 0.0 || s.x > 1.0 || s.y < 0.0 || s.y > 1.0) return 1.0;
    return texture(u_shadow_map, vec3(s.xy, s.z - 5e-4));
}

"""

_LIT_MAIN = """void main() {
    vec3 n = normalize(v_normal);
    vec3 v = normalize(u_eye - v_pos);
    if (dot(n, v) < 0.0) n = -n;   // two-sided
    vec3 ambient = mix(u_ground_ambient, u_sky_ambient, 0.5 + 0.5 * n.z);
#if SUNLIT
    float ndl = dot(n, u_sun_dir);
    float lit = ndl > 0.0 ? sun_visibility(n) : 0.0;
    vec3 h = normalize(u_sun_dir + v);
    float spec = ndl > 0.0 ? u_specular * pow(max(dot(n, h), 0.0), u_shininess) : 0.0;
    vec3 linear = v_color * (ambient + u_sun_color * max(ndl, 0.0) * lit) + u_sun_color * spec * lit;
#else
    vec3 linear = v_color * ambient;   // the above with u_sun_color = 0, exactly
#endif
    f_color = vec4(pow(clamp(linear, 0.0, 1.0), vec3(u_inv_gamma)), 1.0);
}
"""

LIT_FS = _LIT_HEAD + _SUN_VISIBILITY_PCF3 + _LIT_MAIN

#: The lit pass with the one-tap shadow filter (the fly-through's: ``VideoParams.shadow_taps``).
LIT_BILINEAR_FS = _LIT_HEAD + _SUN_VISIBILITY_BILINEAR + _LIT_MAIN

LABEL_VS = (
    """
#version 410
invariant gl_Position;
uniform mat4 u_view_proj;
uniform mat4 u_view;
in ivec3 in_ids;          // class, instance, object (per instance)
flat out ivec3 v_ids;
out float v_depth;
"""
    + _PLACE
    + """
void main() {
    vec3 p = world_position();
    v_ids = in_ids;
    v_depth = -(u_view * vec4(p, 1.0)).z;   // OpenCV camera z, metres
    gl_Position = u_view_proj * vec4(p, 1.0);
}
"""
)

LABEL_FS = """
#version 410
flat in ivec3 v_ids;
in float v_depth;
layout(location = 0) out int f_class;
layout(location = 1) out int f_instance;
layout(location = 2) out int f_object;
layout(location = 3) out float f_depth;
void main() {
    f_class = v_ids.x;
    f_instance = v_ids.y;
    f_object = v_ids.z;
    f_depth = v_depth;
}
"""

#: The lit pass under a sun of no light (an overcast world): ambient only, no shadow lookup;
#: the same pixels as LIT_FS with ``u_sun_color`` = 0, where every sun term is exactly 0.
LIT_AMBIENT_FS = LIT_FS.replace("#version 410\n", "#version 410\n#define SUNLIT 0\n", 1)
