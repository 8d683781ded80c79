// Shader modules, bind group layouts and bind groups, pipeline layouts, pipelines.
module;
#include <expected>
#include <optional>
#include <span>
#include <utility>
#include <cstdint>
#include <string_view>
#include <algorithm>
#include <bit>
#include <memory>
#include <string>
#include <vector>
#include <vulkan/vulkan.h>
module weft.gpu;
import weft.core;

namespace weft::gpu {
using namespace detail;

// ---- shader modules -------------------------------------------------------------------

Result<ShaderModule> Device::create_shader_module(const ShaderModuleDescriptor& desc) {
  std::vector<std::uint32_t> compiled;
  std::span<const std::uint32_t> code = desc.spirv;
  if (code.empty()) {
    auto spirv = compile_glsl(desc);
    if (!spirv) return std::unexpected(spirv.error());
    compiled = std::move(*spirv);
    code = compiled;
  }
  if (code.empty() || code[0] != 0x07230203u)
    return fail(ErrorKind::Shader, "shader '{}': not SPIR-V (bad magic number)", desc.label);
  VkShaderModuleCreateInfo info{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  info.codeSize = code.size_bytes();
  info.pCode = code.data();
  ShaderModule module;
  module.device_ = shared_;
  module.stage_ = desc.stage;
  module.label_ = desc.label;
  if (shared_->declaring()) return module;
  if (VkResult r = vkCreateShaderModule(shared_->device, &info, nullptr, &module.module_); r != VK_SUCCESS)
    return std::unexpected(vk_error(r, weft::format("creating shader module '{}'", desc.label)));
  shared_->set_name(VK_OBJECT_TYPE_SHADER_MODULE, std::uint64_t(module.module_), desc.label);
  return module;
}

ShaderModule::ShaderModule(ShaderModule&&) noexcept = default;
ShaderModule& ShaderModule::operator=(ShaderModule&& o) noexcept {
  std::swap(device_, o.device_);
  std::swap(module_, o.module_);
  std::swap(stage_, o.stage_);
  std::swap(label_, o.label_);
  return *this;
}
ShaderModule::~ShaderModule() {
  if (device_ && module_) vkDestroyShaderModule(device_->device, module_, nullptr);
}

// ---- bind group layouts ---------------------------------------------------------------

Result<BindGroupLayout> Device::create_bind_group_layout(const BindGroupLayoutDescriptor& desc) {
  std::vector<VkDescriptorSetLayoutBinding> bindings;
  for (std::size_t i = 0; i < desc.entries.size(); ++i) {
    const auto& e = desc.entries[i];
    for (std::size_t j = 0; j < i; ++j)
      if (desc.entries[j].binding == e.binding)
        return fail(ErrorKind::InvalidArgument, "bind group layout '{}': binding {} is declared twice", desc.label,
                    e.binding);
    if (!any(e.visibility))
      return fail(ErrorKind::InvalidArgument, "bind group layout '{}': binding {} is visible to no stage", desc.label,
                  e.binding);
    if (e.type == BindingType::StorageTexture && !format_info(e.storage_format).storage)
      return fail(ErrorKind::InvalidArgument, "bind group layout '{}': binding {} storage texture format {} is not a storage format",
                  desc.label, e.binding, to_string(e.storage_format));
    bindings.push_back({e.binding, to_vk(e.type), 1, to_vk(e.visibility), nullptr});
  }
  VkDescriptorSetLayoutCreateInfo info{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  info.bindingCount = std::uint32_t(bindings.size());
  info.pBindings = bindings.data();
  BindGroupLayout layout;
  layout.device_ = shared_;
  layout.desc_ = desc;
  if (shared_->declaring()) return layout;
  if (VkResult r = vkCreateDescriptorSetLayout(shared_->device, &info, nullptr, &layout.layout_); r != VK_SUCCESS)
    return std::unexpected(vk_error(r, weft::format("creating bind group layout '{}'", desc.label)));
  shared_->set_name(VK_OBJECT_TYPE_DESCRIPTOR_SET_LAYOUT, std::uint64_t(layout.layout_), desc.label);
  return layout;
}

BindGroupLayout::BindGroupLayout(BindGroupLayout&&) noexcept = default;
BindGroupLayout& BindGroupLayout::operator=(BindGroupLayout&& o) noexcept {
  std::swap(device_, o.device_);
  std::swap(layout_, o.layout_);
  std::swap(desc_, o.desc_);
  return *this;
}
BindGroupLayout::~BindGroupLayout() {
  if (device_ && layout_) vkDestroyDescriptorSetLayout(device_->device, layout_, nullptr);
}

// ---- bind groups ----------------------------------------------------------------------

BindGroupEntry bind(std::uint32_t binding, const Buffer& buffer, std::uint64_t offset, std::uint64_t size) {
  return {.binding = binding, .buffer = &buffer, .offset = offset, .size = size};
}
BindGroupEntry bind(std::uint32_t binding, const TextureView& view, const Sampler* sampler) {
  return {.binding = binding, .texture = &view, .sampler = sampler};
}
BindGroupEntry bind(std::uint32_t binding, const Sampler& sampler) { return {.binding = binding, .sampler = &sampler}; }

namespace {
// Checks one entry against its layout slot; the message names group, binding and object.
Result<void> check_entry(const BindGroupDescriptor& desc, const BindGroupLayoutEntry& slot, const BindGroupEntry& e) {
  const auto where = weft::format("bind group '{}' (layout '{}') binding {}", desc.label, desc.layout->label(), slot.binding);
  auto need_buffer = [&](BufferUsage usage) -> Result<void> {
    if (!e.buffer) return fail(ErrorKind::InvalidArgument, "{}: expects a {}, got no buffer", where, to_string(slot.type));
    if (!has(e.buffer->usage(), usage))
      return fail(ErrorKind::InvalidArgument, "{}: buffer '{}' is bound as a {} but its usage ({}) lacks {}", where,
                  e.buffer->label(), to_string(slot.type), to_string(e.buffer->usage()), to_string(usage));
    const std::uint64_t size = e.size ? e.size : e.buffer->size() - std::min(e.offset, e.buffer->size());
    if (e.offset >= e.buffer->size() || e.offset + size > e.buffer->size())
      return fail(ErrorKind::InvalidArgument, "{}: range [{}, {}) is outside buffer '{}' of {} bytes", where, e.offset,
                  e.offset + size, e.buffer->label(), e.buffer->size());
    return {};
  };
  auto need_texture = [&](TextureUsage usage) -> Result<void> {
    if (!e.texture) return fail(ErrorKind::InvalidArgument, "{}: expects a {}, got no texture", where, to_string(slot.type));
    const Texture& t = e.texture->texture();
    if (!has(t.usage(), usage))
      return fail(ErrorKind::InvalidArgument, "{}: texture '{}' is bound as a {} but its usage ({}) lacks {}", where,
                  t.label(), to_string(slot.type), to_string(t.usage()), to_string(usage));
    return {};
  };
  switch (slot.type) {
    case BindingType::UniformBuffer: return need_buffer(BufferUsage::Uniform);
    case BindingType::StorageBuffer:
    case BindingType::ReadOnlyStorageBuffer: return need_buffer(BufferUsage::Storage);
    case BindingType::SampledTexture: return need_texture(TextureUsage::Sampled);
    case BindingType::StorageTexture: {
      if (auto ok = need_texture(TextureUsage::Storage); !ok) return ok;
      if (e.texture->texture().format() != slot.storage_format)
        return fail(ErrorKind::InvalidArgument, "{}: texture '{}' has format {} but the layout expects {}", where,
                    e.texture->texture().label(), to_string(e.texture->texture().format()),
                    to_string(slot.storage_format));
      if (e.texture->mip_count() != 1)
        return fail(ErrorKind::InvalidArgument, "{}: a storage texture view must select exactly one mip", where);
      return {};
    }
    case BindingType::TextureSampler:
      if (!e.sampler) return fail(ErrorKind::InvalidArgument, "{}: expects a texture+sampler, got no sampler", where);
      return need_texture(TextureUsage::Sampled);
    case BindingType::Sampler:
      if (!e.sampler) return fail(ErrorKind::InvalidArgument, "{}: expects a sampler, got none", where);
      return {};
  }
  return {};
}
}  // namespace

Result<BindGroup> Device::create_bind_group(const BindGroupDescriptor& desc) {
  if (!desc.layout) return fail(ErrorKind::InvalidArgument, "bind group '{}': no layout", desc.label);
  const auto& slots = desc.layout->descriptor().entries;
  for (const auto& e : desc.entries)
    if (std::none_of(slots.begin(), slots.end(), [&](auto& s) { return s.binding == e.binding; }))
      return fail(ErrorKind::InvalidArgument, "bind group '{}': binding {} is not in layout '{}'", desc.label,
                  e.binding, desc.layout->label());
  std::vector<VkDescriptorPoolSize> sizes;
  for (const auto& slot : slots) {
    auto it = std::find_if(desc.entries.begin(), desc.entries.end(), [&](auto& e) { return e.binding == slot.binding; });
    if (it == desc.entries.end())
      return fail(ErrorKind::InvalidArgument, "bind group '{}': binding {} ({}) of layout '{}' is missing", desc.label,
                  slot.binding, to_string(slot.type), desc.layout->label());
    if (auto ok = check_entry(desc, slot, *it); !ok) return std::unexpected(ok.error());
    sizes.push_back({to_vk(slot.type), 1});
  }

  BindGroup group;
  group.device_ = shared_;
  group.label_ = desc.label;
  group.layout_ = desc.layout->layout_;
  if (shared_->declaring()) return group;
  VkDescriptorPoolCreateInfo pool{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  pool.maxSets = 1;
  pool.poolSizeCount = std::uint32_t(sizes.size());
  pool.pPoolSizes = sizes.data();
  if (sizes.empty()) {  // Vulkan wants at least one pool size even for an empty set
    static const VkDescriptorPoolSize dummy{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1};
    pool.poolSizeCount = 1;
    pool.pPoolSizes = &dummy;
  }
  if (VkResult r = vkCreateDescriptorPool(shared_->device, &pool, nullptr, &group.pool_); r != VK_SUCCESS)
    return std::unexpected(vk_error(r, weft::format("creating bind group '{}'", desc.label)));
  VkDescriptorSetAllocateInfo alloc{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  alloc.descriptorPool = group.pool_;
  alloc.descriptorSetCount = 1;
  alloc.pSetLayouts = &group.layout_;
  if (VkResult r = vkAllocateDescriptorSets(shared_->device, &alloc, &group.set_); r != VK_SUCCESS)
    return std::unexpected(vk_error(r, weft::format("allocating bind group '{}'", desc.label)));
  shared_->set_name(VK_OBJECT_TYPE_DESCRIPTOR_SET, std::uint64_t(group.set_), desc.label);

  std::vector<VkDescriptorBufferInfo> buffers(desc.entries.size());
  std::vector<VkDescriptorImageInfo> images(desc.entries.size());
  std::vector<VkWriteDescriptorSet> writes;
  for (std::size_t i = 0; i < desc.entries.size(); ++i) {
    const auto& e = desc.entries[i];
    const auto& slot = *std::find_if(slots.begin(), slots.end(), [&](auto& s) { return s.binding == e.binding; });
    VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    w.dstSet = group.set_;
    w.dstBinding = e.binding;
    w.descriptorCount = 1;
    w.descriptorType = to_vk(slot.type);
    if (e.buffer) {
      buffers[i] = {e.buffer->buffer_, e.offset, e.size ? e.size : VK_WHOLE_SIZE};
      w.pBufferInfo = &buffers[i];
    } else {
      images[i].sampler = e.sampler ? e.sampler->sampler_ : VK_NULL_HANDLE;
      if (e.texture) {
        images[i].imageView = e.texture->view_;
        const bool depth = format_info(e.texture->texture().format()).depth;
        images[i].imageLayout = slot.type == BindingType::StorageTexture ? VK_IMAGE_LAYOUT_GENERAL
                                : depth ? VK_IMAGE_LAYOUT_DEPTH_STENCIL_READ_ONLY_OPTIMAL
                                        : VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
      }
      w.pImageInfo = &images[i];
    }
    writes.push_back(w);
  }
  vkUpdateDescriptorSets(shared_->device, std::uint32_t(writes.size()), writes.data(), 0, nullptr);
  return group;
}

BindGroup::BindGroup(BindGroup&&) noexcept = default;
BindGroup& BindGroup::operator=(BindGroup&& o) noexcept {
  std::swap(device_, o.device_);
  std::swap(pool_, o.pool_);
  std::swap(set_, o.set_);
  std::swap(layout_, o.layout_);
  std::swap(label_, o.label_);
  return *this;
}
BindGroup::~BindGroup() {
  if (device_ && pool_) vkDestroyDescriptorPool(device_->device, pool_, nullptr);
}

// ---- pipeline layouts -----------------------------------------------------------------

Result<PipelineLayout> Device::create_pipeline_layout(const PipelineLayoutDescriptor& desc) {
  if (desc.push_constant_size > shared_->info.limits.max_push_constant_size || desc.push_constant_size % 4 != 0)
    return fail(ErrorKind::InvalidArgument,
                "pipeline layout '{}': push constant size {} must be a multiple of 4 and at most {}", desc.label,
                desc.push_constant_size, shared_->info.limits.max_push_constant_size);
  if (desc.bind_group_layouts.size() > 8)
    return fail(ErrorKind::InvalidArgument, "pipeline layout '{}': {} bind groups, at most 8", desc.label,
                desc.bind_group_layouts.size());
  PipelineLayout layout;
  layout.device_ = shared_;
  layout.label_ = desc.label;
  layout.push_constant_size_ = desc.push_constant_size;
  for (std::size_t i = 0; i < desc.bind_group_layouts.size(); ++i) {
    if (!desc.bind_group_layouts[i])
      return fail(ErrorKind::InvalidArgument, "pipeline layout '{}': bind group layout {} is null", desc.label, i);
    layout.set_layouts_.push_back(desc.bind_group_layouts[i]->layout_);
  }
  VkPushConstantRange range{VK_SHADER_STAGE_ALL, 0, desc.push_constant_size};
  VkPipelineLayoutCreateInfo info{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  info.setLayoutCount = std::uint32_t(layout.set_layouts_.size());
  info.pSetLayouts = layout.set_layouts_.data();
  info.pushConstantRangeCount = desc.push_constant_size ? 1 : 0;
  info.pPushConstantRanges = &range;
  if (shared_->declaring()) return layout;
  if (VkResult r = vkCreatePipelineLayout(shared_->device, &info, nullptr, &layout.layout_); r != VK_SUCCESS)
    return std::unexpected(vk_error(r, weft::format("creating pipeline layout '{}'", desc.label)));
  shared_->set_name(VK_OBJECT_TYPE_PIPELINE_LAYOUT, std::uint64_t(layout.layout_), desc.label);
  return layout;
}

PipelineLayout::PipelineLayout(PipelineLayout&&) noexcept = default;
PipelineLayout& PipelineLayout::operator=(PipelineLayout&& o) noexcept {
  std::swap(device_, o.device_);
  std::swap(layout_, o.layout_);
  std::swap(set_layouts_, o.set_layouts_);
  std::swap(push_constant_size_, o.push_constant_size_);
  std::swap(label_, o.label_);
  return *this;
}
PipelineLayout::~PipelineLayout() {
  if (device_ && layout_) vkDestroyPipelineLayout(device_->device, layout_, nullptr);
}

// ---- pipelines ------------------------------------------------------------------------

Result<RenderPipeline> Device::create_render_pipeline(const RenderPipelineDescriptor& desc) {
  if (!desc.layout) return fail(ErrorKind::InvalidArgument, "render pipeline '{}': no layout", desc.label);
  if (!desc.vertex) return fail(ErrorKind::InvalidArgument, "render pipeline '{}': no vertex shader", desc.label);
  if (desc.vertex->stage() != ShaderStage::Vertex)
    return fail(ErrorKind::InvalidArgument, "render pipeline '{}': shader '{}' is not a vertex shader", desc.label,
                desc.vertex->label());
  if (desc.fragment && desc.fragment->stage() != ShaderStage::Fragment)
    return fail(ErrorKind::InvalidArgument, "render pipeline '{}': shader '{}' is not a fragment shader", desc.label,
                desc.fragment->label());
  if (desc.color_targets.empty() && !desc.depth_stencil)
    return fail(ErrorKind::InvalidArgument, "render pipeline '{}': no color target and no depth", desc.label);
  for (const auto& t : desc.color_targets)
    if (format_info(t.format).depth || t.format == Format::Undefined)
      return fail(ErrorKind::InvalidArgument, "render pipeline '{}': {} is not a color format", desc.label,
                  to_string(t.format));
  if (desc.depth_stencil && !format_info(desc.depth_stencil->format).depth)
    return fail(ErrorKind::InvalidArgument, "render pipeline '{}': {} is not a depth format", desc.label,
                to_string(desc.depth_stencil->format));
  const MultisampleState& ms = desc.multisample;
  {
    const Limits& l = shared_->info.limits;
    std::uint32_t counts = desc.color_targets.empty() ? ~0u : l.color_sample_counts;
    if (desc.depth_stencil) counts &= l.depth_sample_counts;
    if (std::popcount(ms.count) != 1 || !(counts & ms.count))
      return fail(ErrorKind::InvalidArgument, "render pipeline '{}': {} samples; adapter '{}' renders {} with {}",
                  desc.label, ms.count, shared_->info.name,
                  desc.depth_stencil && !desc.color_targets.empty() ? "colour and depth"
                  : desc.depth_stencil                               ? "depth"
                                                                     : "colour",
                  sample_counts_text(counts));
    if (ms.alpha_to_coverage && ms.count == 1)
      return fail(ErrorKind::InvalidArgument,
                  "render pipeline '{}': alpha-to-coverage needs a multisampled target (count is 1); "
                  "discard by alpha instead, or render with MSAA",
                  desc.label);
    if (ms.alpha_to_coverage && desc.color_targets.empty())
      return fail(ErrorKind::InvalidArgument, "render pipeline '{}': alpha-to-coverage needs a colour target (its alpha)",
                  desc.label);
  }

  std::vector<VkPipelineShaderStageCreateInfo> stages;
  stages.push_back({VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_VERTEX_BIT,
                    desc.vertex->module_, "main", nullptr});
  if (desc.fragment)
    stages.push_back({VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_FRAGMENT_BIT,
                      desc.fragment->module_, "main", nullptr});

  std::vector<VkVertexInputBindingDescription> vb;
  std::vector<VkVertexInputAttributeDescription> va;
  for (std::uint32_t i = 0; i < desc.vertex_buffers.size(); ++i) {
    const auto& b = desc.vertex_buffers[i];
    vb.push_back({i, b.stride, b.step_mode == VertexStepMode::Instance ? VK_VERTEX_INPUT_RATE_INSTANCE
                                                                       : VK_VERTEX_INPUT_RATE_VERTEX});
    for (const auto& a : b.attributes) va.push_back({a.location, i, to_vk(a.format), a.offset});
  }
  VkPipelineVertexInputStateCreateInfo vertex_input{VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
  vertex_input.vertexBindingDescriptionCount = std::uint32_t(vb.size());
  vertex_input.pVertexBindingDescriptions = vb.data();
  vertex_input.vertexAttributeDescriptionCount = std::uint32_t(va.size());
  vertex_input.pVertexAttributeDescriptions = va.data();

  VkPipelineInputAssemblyStateCreateInfo assembly{VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO};
  switch (desc.topology) {
    case PrimitiveTopology::TriangleList: assembly.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST; break;
    case PrimitiveTopology::TriangleStrip: assembly.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_STRIP; break;
    case PrimitiveTopology::LineList: assembly.topology = VK_PRIMITIVE_TOPOLOGY_LINE_LIST; break;
    case PrimitiveTopology::PointList: assembly.topology = VK_PRIMITIVE_TOPOLOGY_POINT_LIST; break;
  }
  VkPipelineViewportStateCreateInfo viewport{VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO};
  viewport.viewportCount = 1;
  viewport.scissorCount = 1;
  VkPipelineRasterizationStateCreateInfo raster{VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO};
  raster.polygonMode = VK_POLYGON_MODE_FILL;
  raster.cullMode = desc.cull_mode == CullMode::Back    ? VK_CULL_MODE_BACK_BIT
                    : desc.cull_mode == CullMode::Front ? VK_CULL_MODE_FRONT_BIT
                                                        : VK_CULL_MODE_NONE;
  raster.frontFace = desc.front_face_clockwise ? VK_FRONT_FACE_CLOCKWISE : VK_FRONT_FACE_COUNTER_CLOCKWISE;
  raster.lineWidth = 1.0f;
  if (desc.depth_stencil && (desc.depth_stencil->depth_bias_constant != 0 || desc.depth_stencil->depth_bias_slope != 0)) {
    raster.depthBiasEnable = VK_TRUE;
    raster.depthBiasConstantFactor = desc.depth_stencil->depth_bias_constant;
    raster.depthBiasSlopeFactor = desc.depth_stencil->depth_bias_slope;
  }
  VkPipelineMultisampleStateCreateInfo multisample{VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO};
  multisample.rasterizationSamples = VkSampleCountFlagBits(ms.count);
  const VkSampleMask sample_mask = ms.mask;
  multisample.pSampleMask = &sample_mask;
  multisample.alphaToCoverageEnable = ms.alpha_to_coverage ? VK_TRUE : VK_FALSE;
  VkPipelineDepthStencilStateCreateInfo depth{VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO};
  if (desc.depth_stencil) {
    depth.depthTestEnable = VK_TRUE;
    depth.depthWriteEnable = desc.depth_stencil->depth_write;
    depth.depthCompareOp = to_vk(desc.depth_stencil->compare);
  }
  std::vector<VkPipelineColorBlendAttachmentState> blends;
  std::vector<VkFormat> color_formats;
  for (const auto& t : desc.color_targets) {
    VkPipelineColorBlendAttachmentState b{};
    b.colorWriteMask = VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT | VK_COLOR_COMPONENT_B_BIT |
                       VK_COLOR_COMPONENT_A_BIT;
    b.colorBlendOp = b.alphaBlendOp = VK_BLEND_OP_ADD;
    switch (t.blend) {
      case BlendMode::Replace: break;
      case BlendMode::Alpha:
        b.blendEnable = VK_TRUE;
        b.srcColorBlendFactor = VK_BLEND_FACTOR_SRC_ALPHA;
        b.dstColorBlendFactor = VK_BLEND_FACTOR_ONE_MINUS_SRC_ALPHA;
        b.srcAlphaBlendFactor = VK_BLEND_FACTOR_ONE;
        b.dstAlphaBlendFactor = VK_BLEND_FACTOR_ONE_MINUS_SRC_ALPHA;
        break;
      case BlendMode::PremultipliedAlpha:
        b.blendEnable = VK_TRUE;
        b.srcColorBlendFactor = b.srcAlphaBlendFactor = VK_BLEND_FACTOR_ONE;
        b.dstColorBlendFactor = b.dstAlphaBlendFactor = VK_BLEND_FACTOR_ONE_MINUS_SRC_ALPHA;
        break;
      case BlendMode::Additive:
        b.blendEnable = VK_TRUE;
        b.srcColorBlendFactor = b.dstColorBlendFactor = VK_BLEND_FACTOR_ONE;
        b.srcAlphaBlendFactor = b.dstAlphaBlendFactor = VK_BLEND_FACTOR_ONE;
        break;
    }
    blends.push_back(b);
    color_formats.push_back(to_vk(t.format));
  }
  VkPipelineColorBlendStateCreateInfo blend{VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO};
  blend.attachmentCount = std::uint32_t(blends.size());
  blend.pAttachments = blends.data();
  const VkDynamicState dynamic_states[] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
  VkPipelineDynamicStateCreateInfo dynamic{VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO};
  dynamic.dynamicStateCount = 2;
  dynamic.pDynamicStates = dynamic_states;

  VkPipelineRenderingCreateInfo rendering{VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO};
  rendering.colorAttachmentCount = std::uint32_t(color_formats.size());
  rendering.pColorAttachmentFormats = color_formats.data();
  rendering.depthAttachmentFormat = desc.depth_stencil ? to_vk(desc.depth_stencil->format) : VK_FORMAT_UNDEFINED;
  if (desc.depth_stencil && desc.depth_stencil->format == Format::Depth24PlusStencil8)
    rendering.stencilAttachmentFormat = rendering.depthAttachmentFormat;

  VkGraphicsPipelineCreateInfo info{VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO, &rendering};
  info.stageCount = std::uint32_t(stages.size());
  info.pStages = stages.data();
  info.pVertexInputState = &vertex_input;
  info.pInputAssemblyState = &assembly;
  info.pViewportState = &viewport;
  info.pRasterizationState = &raster;
  info.pMultisampleState = &multisample;
  info.pDepthStencilState = &depth;
  info.pColorBlendState = &blend;
  info.pDynamicState = &dynamic;
  info.layout = desc.layout->layout_;

  RenderPipeline pipeline;
  pipeline.device_ = shared_;
  pipeline.layout_ = desc.layout->layout_;
  pipeline.push_constant_size_ = desc.layout->push_constant_size();
  pipeline.label_ = desc.label;
  for (const auto& t : desc.color_targets) pipeline.color_formats_.push_back(t.format);
  pipeline.depth_format_ = desc.depth_stencil ? desc.depth_stencil->format : Format::Undefined;
  pipeline.sample_count_ = ms.count;
  if (shared_->declaring()) return pipeline;
  if (VkResult r = vkCreateGraphicsPipelines(shared_->device, VK_NULL_HANDLE, 1, &info, nullptr, &pipeline.pipeline_);
      r != VK_SUCCESS)
    return std::unexpected(vk_error(r, weft::format("creating render pipeline '{}'", desc.label)));
  shared_->set_name(VK_OBJECT_TYPE_PIPELINE, std::uint64_t(pipeline.pipeline_), desc.label);
  return pipeline;
}

RenderPipeline::RenderPipeline(RenderPipeline&&) noexcept = default;
RenderPipeline& RenderPipeline::operator=(RenderPipeline&& o) noexcept {
  std::swap(device_, o.device_);
  std::swap(pipeline_, o.pipeline_);
  std::swap(layout_, o.layout_);
  std::swap(push_constant_size_, o.push_constant_size_);
  std::swap(color_formats_, o.color_formats_);
  std::swap(depth_format_, o.depth_format_);
  std::swap(sample_count_, o.sample_count_);
  std::swap(label_, o.label_);
  return *this;
}
RenderPipeline::~RenderPipeline() {
  if (device_ && pipeline_) vkDestroyPipeline(device_->device, pipeline_, nullptr);
}

Result<ComputePipeline> Device::create_compute_pipeline(const ComputePipelineDescriptor& desc) {
  if (!desc.layout) return fail(ErrorKind::InvalidArgument, "compute pipeline '{}': no layout", desc.label);
  if (!desc.module) return fail(ErrorKind::InvalidArgument, "compute pipeline '{}': no shader", desc.label);
  if (desc.module->stage() != ShaderStage::Compute)
    return fail(ErrorKind::InvalidArgument, "compute pipeline '{}': shader '{}' is not a compute shader", desc.label,
                desc.module->label());
  VkComputePipelineCreateInfo info{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
  info.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_COMPUTE_BIT,
                desc.module->module_, "main", nullptr};
  info.layout = desc.layout->layout_;
  ComputePipeline pipeline;
  pipeline.device_ = shared_;
  pipeline.layout_ = desc.layout->layout_;
  pipeline.push_constant_size_ = desc.layout->push_constant_size();
  pipeline.label_ = desc.label;
  if (shared_->declaring()) return pipeline;
  if (VkResult r = vkCreateComputePipelines(shared_->device, VK_NULL_HANDLE, 1, &info, nullptr, &pipeline.pipeline_);
      r != VK_SUCCESS)
    return std::unexpected(vk_error(r, weft::format("creating compute pipeline '{}'", desc.label)));
  shared_->set_name(VK_OBJECT_TYPE_PIPELINE, std::uint64_t(pipeline.pipeline_), desc.label);
  return pipeline;
}

ComputePipeline::ComputePipeline(ComputePipeline&&) noexcept = default;
ComputePipeline& ComputePipeline::operator=(ComputePipeline&& o) noexcept {
  std::swap(device_, o.device_);
  std::swap(pipeline_, o.pipeline_);
  std::swap(layout_, o.layout_);
  std::swap(push_constant_size_, o.push_constant_size_);
  std::swap(label_, o.label_);
  return *this;
}
ComputePipeline::~ComputePipeline() {
  if (device_ && pipeline_) vkDestroyPipeline(device_->device, pipeline_, nullptr);
}

}  // namespace weft::gpu
