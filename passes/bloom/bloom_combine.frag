#version 460
// The bloom's last step: the chain's sum (every level once, divided by the level count, so it
// carries the image's energy) tent-filtered up to full size and mixed with the scene colour.
// mix() with weights summing to one keeps the frame's total energy: threshold-free bloom.
layout(set = 0, binding = 0) uniform sampler2D scene_color;
layout(set = 0, binding = 1) uniform sampler2D chain;
layout(push_constant) uniform Step { vec2 chain_texel; float radius; float intensity; float inverse_levels; } step_;
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
  vec4 scene = texelFetch(scene_color, ivec2(gl_FragCoord.xy), 0);
  vec3 bloom = tent(chain, uv, step_.chain_texel * step_.radius) * step_.inverse_levels;
  out_color = vec4(mix(scene.rgb, bloom, step_.intensity), scene.a);
}
