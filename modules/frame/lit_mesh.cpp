// The lit-mesh pipeline and the shadow comparison sampler: one definition for every feature
// that draws into the scene's colour and depth and reads the key light's shadow map.
module;
#include <expected>
#include <string>
#include <utility>
module weft.frame;
import weft.core;
import weft.gpu;

namespace weft::frame {

Result<gpu::RenderPipeline> create_lit_mesh_pipeline(gpu::Device& device, std::string label,
                                                     const gpu::PipelineLayout& layout, const gpu::ShaderModule& vertex,
                                                     const gpu::ShaderModule& fragment, gpu::Format color_format,
                                                     gpu::Format depth_format, gpu::VertexBufferLayout vertices) {
  return device.create_render_pipeline({.label = std::move(label),
                                        .layout = &layout,
                                        .vertex = &vertex,
                                        .fragment = &fragment,
                                        .vertex_buffers = {std::move(vertices)},
                                        .cull_mode = gpu::CullMode::None,
                                        .color_targets = {{color_format}},
                                        .depth_stencil = gpu::DepthStencilState{.format = depth_format}});
}

Result<gpu::Sampler> create_shadow_compare_sampler(gpu::Device& device, std::string label) {
  return device.create_sampler({.label = std::move(label), .mipmap_filter = gpu::FilterMode::Nearest,
                                .compare = gpu::CompareFunction::LessEqual, .max_lod = 0.0f});
}

}  // namespace weft::frame
