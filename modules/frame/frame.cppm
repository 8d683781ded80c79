// weft.frame — what every pass of a frame shares without knowing the scene file: meshes on
// the GPU in weft's one vertex layout, the per-frame uniforms (camera, key light, shadow
// matrix, environment), draw items tagged with the feature that shades them, and the
// pipeline and shadow sampler that the features drawing lit meshes all create alike.
module;
#include <array>
#include <cstdint>
#include <expected>
#include <span>
#include <string>
#include <vector>
export module weft.frame;
import weft.core;
import weft.gpu;

export namespace weft::frame {

// One interleaved vertex for every pass (64 bytes; matches shaders/frame.glsl).
struct Vertex {
  vec3 position;
  float curvature = 0.0f;  // |Δn|/|Δp| per vertex, 1/mm-free units of the mesh (skin uses it)
  vec3 normal;
  float pad0 = 0.0f;
  vec4 tangent{1, 0, 0, 1};  // xyz tangent, w handedness
  vec2 uv{0, 0};
  vec2 pad1{0, 0};
};
static_assert(sizeof(Vertex) == 64);

// The vertex buffer layout of frame::Vertex, locations 0..4.
gpu::VertexBufferLayout vertex_layout();

// The pipeline the passes that shade meshes into the scene's colour and depth share
// (forward, skin, fur, SSDF, neural BTF): one vertex buffer (frame::Vertex unless told
// otherwise), triangles, both faces drawn, one colour target, depth tested (less) and written.
Result<gpu::RenderPipeline> create_lit_mesh_pipeline(gpu::Device& device, std::string label,
                                                     const gpu::PipelineLayout& layout, const gpu::ShaderModule& vertex,
                                                     const gpu::ShaderModule& fragment, gpu::Format color_format,
                                                     gpu::Format depth_format,
                                                     gpu::VertexBufferLayout vertices = vertex_layout());

// The sampler a lit pass reads the shadow map through (sampler2DShadow): a less-or-equal
// depth comparison, linearly filtered, level 0 only.
Result<gpu::Sampler> create_shadow_compare_sampler(gpu::Device& device, std::string label);

struct GpuMesh {
  std::string name;
  gpu::Buffer vertices;
  gpu::Buffer indices;
  std::uint32_t index_count = 0;
  std::uint32_t vertex_count = 0;
  vec3 bounds_min{0}, bounds_max{0};
};

struct MeshData {
  std::string name;
  std::vector<Vertex> vertices;
  std::vector<std::uint32_t> indices;
};
Result<GpuMesh> upload_mesh(gpu::Device& device, const MeshData& mesh);

// Which pass shades a draw item; a pass draws only the items of its own feature.
enum class Feature : std::uint8_t { Standard, Fur, Skin, NeuralBtf, SsdfLit };
std::string_view to_string(Feature feature);

struct StandardMaterial {
  vec3 base_color{0.8f};
  float metallic = 0.0f;
  float roughness = 0.5f;
  vec3 emissive{0.0f};
};

struct DrawItem {
  const GpuMesh* mesh = nullptr;
  mat4 model{1.0f};
  Feature feature = Feature::Standard;
  StandardMaterial material;    // used by the standard passes; features keep their own
  const gpu::TextureView* base_color_texture = nullptr;  // sRGB, multiplies base_color; null = white
  std::uint32_t feature_index = 0;  // index into the feature's own material list
};

// std140 per-frame uniforms, bound as set 0 binding 0 by the passes that need them.
struct FrameUniforms {
  mat4 view{1.0f};
  mat4 projection{1.0f};
  mat4 view_projection{1.0f};
  mat4 inverse_view_projection{1.0f};
  mat4 light_view_projection{1.0f};
  vec4 camera_position{0, 0, 0, 1};
  vec4 light_direction{0, 1, 0, 0};  // xyz: unit vector towards the key light
  vec4 light_color{1, 1, 1, 0};      // rgb * intensity (radiance at normal incidence)
  vec4 environment{1, 0, 0, 0};      // x intensity, y rotation (radians), z has map (0/1)
  vec4 viewport{1, 1, 1, 1};         // width, height, 1/width, 1/height
  std::array<vec4, 9> irradiance_sh{};  // order-2 SH of the environment's irradiance (rgb)
};
static_assert(sizeof(FrameUniforms) % 16 == 0);

// Order-2 spherical harmonics of the cosine-convolved radiance of an equirectangular map
// (Ramamoorthi & Hanrahan 2001): E(n) = sum c_i Y_i(n). `rgb` is width*height*3 floats.
std::array<vec4, 9> irradiance_sh(std::span<const float> rgb, std::uint32_t width, std::uint32_t height,
                                  float rotation_radians = 0.0f);
vec3 evaluate_sh(const std::array<vec4, 9>& sh, vec3 normal);
// Exact SH of a constant sky of radiance c: E(n) = π c everywhere.
std::array<vec4, 9> constant_irradiance_sh(vec3 radiance);

// SPIR-V of shaders/fullscreen.vert: one triangle over the screen at the far plane, `uv` out.
std::span<const std::uint32_t> fullscreen_vertex_spirv();

// A camera for Vulkan's clip space (y down, depth 0..1, right-handed view).
mat4 perspective_vk(float vertical_fov_radians, float aspect, float near_plane, float far_plane);

}  // namespace weft::frame
