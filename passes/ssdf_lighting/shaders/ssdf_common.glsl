// Shared by ssdf.vert and ssdf.frag: the bindings, the per-draw constants (weft::passes
// SsdfPush, 112 bytes) and the shading maths of weft.ssdf's shading.cpp (same formulas,
// same table, same bilinear lookup).
#ifndef WEFT_SSDF_COMMON_GLSL
#define WEFT_SSDF_COMMON_GLSL
struct Lobe {
  vec4 axis_sharpness;  // xyz unit axis, w sharpness λ
  vec4 energy;          // rgb ∫ G dω
  uvec4 cells;          // the four bilinear taps of the axis in the direction grid
  vec4 weights;
};
layout(set = 0, binding = 0) uniform Frame { FrameData frame; };
layout(set = 0, binding = 1) uniform sampler2DShadow shadow_map;
layout(std430, set = 0, binding = 2) readonly buffer Table { float irradiance_table[]; };  // 64 x 128
layout(std430, set = 0, binding = 3) readonly buffer Lobes { Lobe lobes[]; };
layout(std430, set = 0, binding = 4) readonly buffer Vertices { uvec2 vertex_slot[]; };  // cluster, slot
layout(std430, set = 0, binding = 5) readonly buffer Clusters { uvec4 cluster_info[]; };  // m, coef, basis, mean
layout(std430, set = 0, binding = 6) readonly buffer Data { float ssdf_data[]; };

layout(push_constant) uniform Draw {
  mat4 model;
  vec4 albedo_mode;  // rgb albedo, w 1: per-pixel shading
  uvec4 info;        // x base vertex, y lobe count, z directions
  vec4 params;       // x half the grid spacing (radians)
} draw;

const uint TABLE_ROWS = 64u, TABLE_COLUMNS = 128u;
const float TABLE_MIDPOINT = 8.0;
const uint NO_MEAN = 0xffffffffu;

// ssdf::IrradianceTable::lookup: T(λ, t), rows u = λ / (λ + 8), columns t in [-1, 1].
float table_lookup(float sharpness, float cosine) {
  float s = max(sharpness, 0.0);
  float x = clamp(s / (s + TABLE_MIDPOINT), 0.0, 1.0) * float(TABLE_ROWS - 1u);
  float y = (clamp(cosine, -1.0, 1.0) * 0.5 + 0.5) * float(TABLE_COLUMNS - 1u);
  uint x0 = min(uint(x), TABLE_ROWS - 2u), y0 = min(uint(y), TABLE_COLUMNS - 2u);
  float tx = x - float(x0), ty = y - float(y0);
  uint i = x0 * TABLE_COLUMNS + y0;
  float top = mix(irradiance_table[i], irradiance_table[i + 1u], ty);
  float bottom = mix(irradiance_table[i + TABLE_COLUMNS], irradiance_table[i + TABLE_COLUMNS + 1u], ty);
  return mix(top, bottom, tx);
}

// ssdf::boundary_distance and ssdf::lobe_visibility.
float boundary_distance(float d, float half_spacing) {
  float a = abs(d);
  return sign(d) * max(a - half_spacing, 0.5 * a);
}
float lobe_visibility(float distance, float sharpness) {
  float w = sharpness > 0.0 ? min(1.88 / sqrt(sharpness), 0.5 * PI) : 0.5 * PI;
  return smoothstep(-w, w, distance);
}

// One lobe's irradiance on normal n with the SSDF d at its centre.
vec3 lobe_light(uint j, vec3 n, float d) {
  Lobe lobe = lobes[j];
  float t = dot(lobe.axis_sharpness.xyz, n);
  return lobe.energy.rgb * table_lookup(lobe.axis_sharpness.w, t) *
         lobe_visibility(boundary_distance(d, draw.params.x), lobe.axis_sharpness.w);
}

// The reconstructed SSDF of row (cluster, slot) at lobe j's axis: the mean plus m
// coefficients times the basis, each read at the lobe's four taps. Cost: 4 (m + 1) reads,
// independent of the number of directions.
float ssdf_at_lobe(uvec4 cluster, uint slot, uint j) {
  Lobe lobe = lobes[j];
  uint directions = draw.info.z;
  float d = 0.0;
  for (int t = 0; t < 4; ++t) {
    float w = lobe.weights[t];
    uint cell = lobe.cells[t];
    float s = cluster.w != NO_MEAN ? ssdf_data[cluster.w + cell] : 0.0;
    uint basis = cluster.z + cell;
    uint coefficients = cluster.y + slot * cluster.x;
    for (uint k = 0u; k < cluster.x; ++k) s += ssdf_data[coefficients + k] * ssdf_data[basis + k * directions];
    d += w * s;
  }
  return d;
}
#endif
