// Small helpers shared by the graph suites (plain header: included before any import).
#pragma once
#include <algorithm>
#include <string>
#include <vector>

namespace graph_test {

// A triangle covering the viewport (gl_VertexIndex 0..2), for full-screen passes in GPU tests.
inline constexpr const char* fullscreen_vs = R"(#version 460
void main() {
  vec2 p = vec2((gl_VertexIndex << 1) & 2, gl_VertexIndex & 2);
  gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
})";

inline bool contains(const std::string& haystack, const std::string& needle) {
  return haystack.find(needle) != std::string::npos;
}

inline bool has(const std::vector<std::string>& list, const std::string& item) {
  return std::find(list.begin(), list.end(), item) != list.end();
}

}  // namespace graph_test
