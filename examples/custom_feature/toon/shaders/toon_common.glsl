// The toon pass's bindings and push constants (ToonPush in pass.cpp).
layout(set = 0, binding = 0) uniform Frame { FrameData frame; };
layout(set = 0, binding = 1) uniform sampler2DShadow shadow_map;
layout(push_constant) uniform Draw {
  mat4 model;
  vec4 base_color_bands;     // rgb base colour, w bands
  vec4 outline_color_width;  // rgb outline colour, w width in object units
  vec4 options;              // x: 1 = the key light's shadow map is used
} draw;
