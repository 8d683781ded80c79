#version 460
// One step up the bloom chain: this level's downsampled colour plus a 3x3 tent of the coarser
// level's result (weights 1-2-1, summing to one).
layout(set = 0, binding = 0) uniform sampler2D level;
layout(set = 0, binding = 1) uniform sampler2D coarser;
layout(push_constant) uniform Step { vec2 coarser_texel; float radius; } step_;
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 out_color;

vec3 tent(sampler2D s, vec2 at, vec2 d) {
  vec3 c = texture(s, at).rgb * 4.0;
  c += (texture(s, at + vec2(-d.x, 0)).rgb + texture(s, at + vec2(d.x, 0)).rgb +
        texture(s, at + vec2(0, -d.y)).rgb + texture(s, at + vec2(0, d.y)).rgb) * 2.0;
  c += texture(s, at - d).rgb + texture(s, at + d).rgb + texture(s, at + vec2(d.x, -d.y)).rgb +
       texture(s, at + vec2(-d.x, d.y)).rgb;
  return c / 16.0;
}

void main() {
  out_color = vec4(texture(level, uv).rgb + tent(coarser, uv, step_.coarser_texel * step_.radius), 1.0);
}
