#version 460
// One step down the bloom chain (Jimenez, "Next Generation Post Processing in Call of Duty:
// Advanced Warfare", 2014): 13 bilinear taps of the level above, weighted so that they sum to
// one -- a constant image stays constant, which is what makes the chain conserve energy.
layout(set = 0, binding = 0) uniform sampler2D source;
layout(push_constant) uniform Step { vec2 source_texel; } step_;
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 out_color;

vec3 tap(float x, float y) { return texture(source, uv + step_.source_texel * vec2(x, y)).rgb; }

void main() {
  vec3 inner = tap(-1, -1) + tap(1, -1) + tap(-1, 1) + tap(1, 1);
  vec3 corners = tap(-2, -2) + tap(2, -2) + tap(-2, 2) + tap(2, 2);
  vec3 edges = tap(0, -2) + tap(-2, 0) + tap(2, 0) + tap(0, 2);
  vec3 center = tap(0, 0);
  // Five 2x2 boxes: the inner one weighted 0.5, the four outer ones 0.125 each.
  vec3 c = inner * 0.125 + corners * 0.03125 + edges * 0.0625 + center * 0.125;
  out_color = vec4(c, 1.0);
}
