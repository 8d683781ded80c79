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
  gpu::RenderPipelineDescriptor desc =
      lit_mesh_pipeline_descriptor(std::move(label), layout, color_format, depth_format, std::move(vertices));
  desc.vertex = &vertex;
  desc.fragment = &fragment;
  return device.create_render_pipeline(desc);
}

Result<gpu::Sampler> create_shadow_compare_sampler(gpu::Device& device, std::string label) {
  return device.create_sampler({.label = std::move(label), .mipmap_filter = gpu::FilterMode::Nearest,
                                .compare = gpu::CompareFunction::LessEqual, .max_lod = 0.0f});
}

}  // namespace weft::frame
