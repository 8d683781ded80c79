module;
#include <cstdint>
#include <cstdio>
#include <expected>
#include <span>
#include <string>
#include <string_view>
#include <vector>
module weft.feature;
import weft.core;
import weft.frame;
import weft.scene;

namespace weft {

std::string_view to_string(Quality q) {
  switch (q) {
    case Quality::Low: return "low";
    case Quality::Medium: return "medium";
    case Quality::High: return "high";
    case Quality::Reference: return "reference";
  }
  return "?";
}

Result<Quality> quality_from_string(std::string_view name) {
  for (Quality q : {Quality::Low, Quality::Medium, Quality::High, Quality::Reference})
    if (to_string(q) == name) return q;
  return fail(ErrorKind::InvalidArgument, "unknown quality '{}' (low, medium, high, reference)", name);
}

int bake_failed(std::string_view bake, const Error& error) {
  std::fprintf(stderr, "weft bake %.*s: %s\n", int(bake.size()), bake.data(), error.what().c_str());
  return 1;
}

std::uint64_t mesh_content_hash(const scene::Mesh& mesh) {
  Hasher h;
  h.bytes(mesh.positions.data(), mesh.positions.size() * sizeof(vec3));
  h.bytes(mesh.normals.data(), mesh.normals.size() * sizeof(vec3));
  h.bytes(mesh.uvs.data(), mesh.uvs.size() * sizeof(vec2));
  h.bytes(mesh.uvs1.data(), mesh.uvs1.size() * sizeof(vec2));
  h.bytes(mesh.indices.data(), mesh.indices.size() * sizeof(std::uint32_t));
  return h.digest();
}

frame::MeshData to_mesh_data(const scene::Mesh& mesh) {
  frame::MeshData out{mesh.name, std::vector<frame::Vertex>(mesh.positions.size()), mesh.indices};
  for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
    frame::Vertex& v = out.vertices[i];
    v.position = mesh.positions[i];
    if (i < mesh.normals.size()) v.normal = mesh.normals[i];
    if (i < mesh.tangents.size()) v.tangent = mesh.tangents[i];
    if (i < mesh.uvs.size()) v.uv = mesh.uvs[i];
    v.uv1 = i < mesh.uvs1.size() ? mesh.uvs1[i] : v.uv;
    if (i < mesh.curvature.size()) v.curvature = mesh.curvature[i];
  }
  return out;
}

Result<void> join_problems(std::span<const std::string> problems) {
  if (problems.empty()) return {};
  std::string message = problems.front();
  for (std::size_t i = 1; i < problems.size(); ++i)
    if (message.find(problems[i]) == std::string::npos) message += "\n" + problems[i];
  return std::unexpected(Error{ErrorKind::Parse, std::move(message)});
}

}  // namespace weft
