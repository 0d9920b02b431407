// The GL renderer's shaders and their compilation.
#include "gl_shaders.h"

#include <string>

#include "tetrascope/renderer/render.h"

namespace tetrascope::renderer {

// Per tet, precomputed once per mesh: its four outward face planes and its linear field
// (gradient, offset) in attribute units: five vec4 a tet. Drawn indexed: the 12 face corners
// of a tet index its 4 vertices, so a vertex cache runs 4 vertex shaders a tet, not 12.
const char* const kTetVertex = R"(#version 450 core
layout(std430, binding = 0) readonly buffer Vertices { vec4 vertices[]; };
layout(std430, binding = 1) readonly buffer Tets { uvec4 tets[]; };
layout(std430, binding = 2) readonly buffer Order { uint order[]; };
layout(std430, binding = 3) readonly buffer Cells { vec4 cells[]; };
uniform mat4 mvp;
uniform uint first_slot;
out vec3 world;
flat out vec4 plane0, plane1, plane2, plane3, field;
void main() {
  uint slot = first_slot + uint(gl_VertexID) / 4u;
  uint tet = order[slot];
  uint corner = uint(gl_VertexID) % 4u;
  world = vertices[tets[tet][corner]].xyz;
  plane0 = cells[5u * tet];
  plane1 = cells[5u * tet + 1u];
  plane2 = cells[5u * tet + 2u];
  plane3 = cells[5u * tet + 3u];
  field = cells[5u * tet + 4u];
  gl_Position = mvp * vec4(world, 1.0);
}
)";

// The colour of one ray segment through a tet (values over the transfer function's range,
// length in world units): one read of the table texture, or with isosurfaces in the volume, the parts
// between the isovalues it crosses composed front to back with the lit surfaces between.
// `isos` ascending, distinct. A crossing counts where (value < iso) changes, so a ray through
// a vertex on the isosurface meets it once.
const std::string kSegmentShading = R"(
uniform sampler3D table;
uniform float table_n, table_lengths;
uniform float length_scale, inv_log_length_range;  // the table's length axis (PreintegrationTable)
uniform int iso_count;
uniform float isos[8];
uniform float iso_opacity;
uniform sampler1D colormap;
uniform float fine_slices, inv_unit;  // the fine transfer function's slices after the table's lengths; 1 / unit distance
// One read of the table texture. A segment whose value spans a bin or more reads the table at
// (front, back, length). One whose value changes by less reads the transfer function on its
// fine grid (FineTransfer: 65,024 intervals in rows of n texels, a row's last the next row's
// first, n rows a slice, in `fine_slices` slices after the lengths) at its middle value: the
// extinction there (times the unit distance) and the colour give its optical depth and colour,
// however long it is, where the table interpolated between bins would veil thin opacity.
vec4 lookup(float sf, float sb, float t) {
  float depth_texels = table_lengths + fine_slices;
  bool near_constant = abs(sb - sf) * (table_n - 1.0) < 1.0;
  vec3 uvw;
  if (near_constant) {
    float rows = table_n * fine_slices;
    float x = clamp(0.5 * (sf + sb), 0.0, 1.0) * (table_n - 1.0) * rows;
    float row = min(floor(x / (table_n - 1.0)), rows - 1.0);
    uvw = vec3((x - row * (table_n - 1.0) + 0.5) / table_n, (mod(row, table_n) + 0.5) / table_n, (table_lengths + floor(row / table_n) + 0.5) / depth_texels);
  } else {
    uvw = vec3((clamp(sf, 0.0, 1.0) * (table_n - 1.0) + 0.5) / table_n, (clamp(sb, 0.0, 1.0) * (table_n - 1.0) + 0.5) / table_n,
               (clamp(log(1.0 + t / length_scale) * inv_log_length_range, 0.0, 1.0) * (table_lengths - 1.0) + 0.5) / depth_texels);
  }
  vec4 c = texture(table, uvw);
  if (!near_constant) return c;
  float depth = c.x * inv_unit * t;
  float alpha = depth < 1e-3 ? depth * (1.0 - 0.5 * depth) : 1.0 - exp(-depth);
  return vec4(c.yzw * alpha, alpha);
}
float iso_light(vec3 gradient, vec3 d) {
  float g = length(gradient);
  return 0.25 + 0.75 * (g > 0.0 ? abs(dot(gradient / g, d)) : 1.0);
}
vec4 shade(float sf, float sb, float t, float light) {
  if (iso_count == 0) return lookup(sf, sb, t);
  vec4 acc = vec4(0.0);
  float s0 = sf, t0 = 0.0;
  bool rising = sb > sf;
  for (int k = 0; k < iso_count; ++k) {
    float iv = isos[rising ? k : iso_count - 1 - k];
    if ((s0 < iv) != (sb < iv)) {
      float ti = t * (iv - sf) / (sb - sf);
      acc += (1.0 - acc.a) * lookup(s0, iv, ti - t0);
      vec3 base = texture(colormap, clamp(iv, 0.0, 1.0)).rgb;
      acc += (1.0 - acc.a) * vec4(base * light * iso_opacity, iso_opacity);
      s0 = iv;
      t0 = ti;
    }
  }
  return acc + (1.0 - acc.a) * lookup(s0, sb, t - t0);
}
)";

const std::string kTetFragmentSource = R"(#version 450 core
in vec3 world;
flat in vec4 plane0, plane1, plane2, plane3, field;
uniform vec3 eye, forward;
uniform bool ortho;
uniform float lo, inv_span;
uniform bool clip_depth;
uniform sampler2D depth_limit;   // distance along the ray to the nearest opaque surface
uniform vec2 viewport;
uniform bool near_pass;          // back faces of a tet that reaches the near plane: the segment ends here
uniform float near_depth;        // the near plane's distance from the eye along `forward`
out vec4 color;
)" + kSegmentShading + R"(
void exit_of(vec4 pl, vec3 d, inout float t) {
  float dn = dot(pl.xyz, d);
  if (dn > 1e-20) t = min(t, -(dot(pl.xyz, world) + pl.w) / dn);
}
void entry_of(vec4 pl, vec3 d, inout float s) {
  float dn = dot(pl.xyz, d);
  if (dn < -1e-20) s = max(s, -(dot(pl.xyz, world) + pl.w) / dn);
}
void main() {
  vec3 d = ortho ? forward : normalize(world - eye);
  vec3 front = world;
  float t;
  if (near_pass) {  // the segment starts at max(near plane, entry into the tet)
    float s = -3.4e38;
    entry_of(plane0, d, s);
    entry_of(plane1, d, s);
    entry_of(plane2, d, s);
    entry_of(plane3, d, s);
    s = min(max(s, (near_depth - dot(world - eye, forward)) / dot(d, forward)), 0.0);
    front = world + s * d;
    t = -s;
  } else {
    t = 3.4e38;
    exit_of(plane0, d, t);
    exit_of(plane1, d, t);
    exit_of(plane2, d, t);
    exit_of(plane3, d, t);
    t = max(t, 0.0);
  }
  if (clip_depth) {
    float limit = texture(depth_limit, gl_FragCoord.xy / viewport).r;
    float here = ortho ? dot(front - eye, forward) : length(front - eye);
    t = min(t, max(limit - here, 0.0));
  }
  float sf = (dot(field.xyz, front) + field.w - lo) * inv_span;
  float sb = sf + dot(field.xyz, d) * t * inv_span;
  color = shade(sf, sb, t, iso_count > 0 ? iso_light(field.xyz, d) : 1.0);
}
)";
const char* const kTetFragment = kTetFragmentSource.c_str();

// Projected tetrahedra (projected_tets.h): the CPU wrote every vertex of every fan.
const char* const kProjectedVertex = R"(#version 450 core
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 segment_in;  // front value, back value, length
layout(location = 2) in float light_in;
uniform mat4 mvp;
out vec3 world;
out vec3 segment;
flat out float light;  // from the thick vertex, the provoking one
void main() {
  world = position;
  segment = segment_in;
  light = light_in;
  gl_Position = mvp * vec4(position, 1.0);
}
)";

const std::string kProjectedFragmentSource = R"(#version 450 core
in vec3 world;
in vec3 segment;
flat in float light;
uniform vec3 eye, forward;
uniform bool ortho;
uniform bool clip_depth;
uniform sampler2D depth_limit;
uniform vec2 viewport;
out vec4 color;
)" + kSegmentShading + R"(
void main() {
  vec3 d = ortho ? forward : normalize(world - eye);
  float sf = segment.x, sb = segment.y, t = max(segment.z, 0.0);
  if (clip_depth) {
    float limit = texture(depth_limit, gl_FragCoord.xy / viewport).r;
    float here = ortho ? dot(world - eye, forward) : length(world - eye);
    float cut = min(t, max(limit - here, 0.0));
    sb = sf + (sb - sf) * (t > 0.0 ? cut / t : 0.0);
    t = cut;
  }
  color = shade(sf, sb, t, light);
}
)";
const char* const kProjectedFragment = kProjectedFragmentSource.c_str();

const char* const kSurfaceVertex = R"(#version 450 core
layout(location = 0) in vec3 position;
layout(location = 1) in float value;
uniform mat4 mvp;
out vec3 world;
out float v;
void main() {
  world = position;
  v = value;
  gl_Position = mvp * vec4(position, 1.0);
}
)";

const char* const kSurfaceFragment = R"(#version 450 core
in vec3 world;
in float v;
uniform vec3 eye, forward;
uniform bool ortho;
uniform sampler1D colormap;
uniform float lo, inv_span;
uniform vec4 solid;   // a >= 0: this colour instead of the colormap
uniform float opacity = 1.0;  // premultiplied output
uniform float depth_out; // 1: write the distance along the ray into the colour's alpha target 1
uniform bool lit;         // false: flat, the colour unshaded (slices)
layout(location = 0) out vec4 color;
layout(location = 1) out float distance_out;
void main() {
  vec3 n = normalize(cross(dFdx(world), dFdy(world)));
  vec3 d = ortho ? forward : normalize(world - eye);
  float light = lit ? 0.25 + 0.75 * abs(dot(n, d)) : 1.0;
  // texel i holds the colour at i / 255: s maps to texel coordinate 255 s, its centre + 0.5
  float s = clamp((v - lo) * inv_span, 0.0, 1.0);
  vec3 base = solid.a >= 0.0 ? solid.rgb : texture(colormap, (s * 255.0 + 0.5) / 256.0).rgb;
  color = vec4(base * light * opacity, opacity);
  distance_out = ortho ? dot(world - eye, forward) : length(world - eye);
}
)";

const char* const kLineFragment = R"(#version 450 core
uniform vec4 solid;
layout(location = 0) out vec4 color;
layout(location = 1) out float distance_out;
void main() { color = solid; distance_out = 3.4e38; }
)";

namespace {
GLuint compile(GLenum type, const char* source) {
  GLuint shader = glCreateShader(type);
  glShaderSource(shader, 1, &source, nullptr);
  glCompileShader(shader);
  GLint ok = 0;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[4096];
    glGetShaderInfoLog(shader, sizeof log, nullptr, log);
    throw RenderError(std::string("shader does not compile: ") + log);
  }
  return shader;
}
}  // namespace

GLuint link_program(const char* vs, const char* fs) {
  GLuint p = glCreateProgram();
  GLuint a = compile(GL_VERTEX_SHADER, vs), b = compile(GL_FRAGMENT_SHADER, fs);
  glAttachShader(p, a);
  glAttachShader(p, b);
  glLinkProgram(p);
  glDeleteShader(a);
  glDeleteShader(b);
  GLint ok = 0;
  glGetProgramiv(p, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[4096];
    glGetProgramInfoLog(p, sizeof log, nullptr, log);
    throw RenderError(std::string("shaders do not link: ") + log);
  }
  return p;
}

}  // namespace tetrascope::renderer
