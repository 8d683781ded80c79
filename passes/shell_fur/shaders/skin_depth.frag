#version 460
// The skin's depth pre-pass (ShellFurPass): depth only. The pipeline adds this zero to the
// scene colour (additive blending), so the colour is left exactly as it was.
layout(location = 0) out vec4 out_color;
void main() { out_color = vec4(0.0); }
