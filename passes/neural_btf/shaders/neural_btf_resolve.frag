#version 460
// The batched path's resolve: the decoded radiance of every pixel the geometry pass marked goes
// into the scene colour; the others are left as they were (discard).
layout(set = 0, binding = 0) uniform sampler2D g_light;  // z: marker, 0 where no neural BTF pixel
layout(std430, set = 0, binding = 1) readonly buffer Radiance { float radiance[]; };  // rgb per pixel
layout(push_constant) uniform Push { uint width; } push;
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 out_color;
void main() {
  ivec2 px = ivec2(gl_FragCoord.xy);
  if (texelFetch(g_light, px, 0).z == 0.0) discard;
  uint i = 3u * (uint(px.y) * push.width + uint(px.x));
  out_color = vec4(radiance[i], radiance[i + 1u], radiance[i + 2u], 1.0);
}
