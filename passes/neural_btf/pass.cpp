// The model buffer (pack_model), the decode kernel (compute) and NeuralBTFMaterial (the graph
// pass: pipeline, bind groups, draws).
module;
#include <algorithm>
#include <bit>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <expected>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>
#include <glm/glm.hpp>
#include "weft_pass_neural_btf_shaders.h"
module weft.pass.neural_btf;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.frame;
import weft.btf.model;

namespace weft::passes {

namespace {
constexpr gpu::Format color_format = frame::scene_color_format;
constexpr gpu::Format depth_format = frame::scene_depth_format;
constexpr std::uint32_t kNone = 0xffffffffu;
constexpr std::size_t kHeaderWords = 4 + 4 + 4 + 4 * kBtfMaxLayers;  // shape, offsets, scales, layers

// Matches `Draw` in neural_btf_common.glsl.
struct NeuralBtfConstants {
  mat4 model;
  vec4 uv_scale;  // xy tiling, z flags, w exposure
  vec4 tint;
  vec4 debug;
};
static_assert(sizeof(NeuralBtfConstants) == 112);

enum : int { flag_ambient = 1, flag_bilinear = 2, flag_shadow = 4 };
}  // namespace

Result<std::vector<std::uint32_t>> pack_model(const btf::NeuralBtf& model) {
  if (auto ok = btf::validate(model); !ok) return std::unexpected(ok.error());
  const auto& layers = model.decoder.layers;
  if (layers.size() > kBtfMaxLayers)
    return fail(ErrorKind::Unsupported, "neural BTF: the decoder has {} layers; the shader evaluates at most {}",
                layers.size(), kBtfMaxLayers);
  if (model.latent_size + 4 > kBtfMaxWidth)
    return fail(ErrorKind::Unsupported, "neural BTF: latent size {} + 4 directions exceeds the shader's {} inputs",
                model.latent_size, kBtfMaxWidth);
  for (std::size_t i = 0; i < layers.size(); ++i)
    if (layers[i].outputs > kBtfMaxWidth)
      return fail(ErrorKind::Unsupported, "neural BTF: decoder layer {} has {} outputs; the shader's limit is {}", i,
                  layers[i].outputs, kBtfMaxWidth);
  if (model.texels() >= (1u << 24) || model.latent_count() >= (1u << 24))
    return fail(ErrorKind::Unsupported, "neural BTF: {} texels / {} latents; the shader indexes fewer than 2^24",
                model.texels(), model.latent_count());
  // Everything after the header is in vec4s: offsets count vec4s, and each block starts on one.
  std::vector<std::uint32_t> words(kHeaderWords, 0);
  auto push_float = [&](float v) { words.push_back(std::bit_cast<std::uint32_t>(v)); };
  auto align4 = [&] {
    while ((words.size() - kHeaderWords) % 4) push_float(0.0f);
  };
  auto offset4 = [&] { return std::uint32_t((words.size() - kHeaderWords) / 4); };
  auto up4 = [](std::uint32_t n) { return (n + 3) / 4; };
  for (std::size_t i = 0; i < layers.size(); ++i) {
    const btf::DenseLayer& l = layers[i];
    const std::uint32_t in4 = up4(l.inputs), out4 = up4(l.outputs);
    const std::size_t at = 12 + 4 * i;
    words[at + 0] = in4;
    words[at + 1] = out4;
    words[at + 2] = offset4();
    // Rows padded to in4 vec4s, and padded rows up to out4 * 4: zeros, so padded outputs are 0
    // and padded inputs contribute nothing.
    for (std::uint32_t o = 0; o < out4 * 4; ++o)
      for (std::uint32_t k = 0; k < in4 * 4; ++k)
        push_float(o < l.outputs && k < l.inputs ? l.weights[std::size_t(o) * l.inputs + k] : 0.0f);
    words[at + 3] = offset4();
    for (std::uint32_t o = 0; o < out4 * 4; ++o) push_float(o < l.outputs ? l.bias[o] : 0.0f);
  }
  words[0] = std::uint32_t(layers.size());
  words[1] = model.latent_size;
  words[2] = model.width;
  words[3] = model.height;
  words[4] = offset4();
  for (std::size_t c = 0; c < model.latent_count(); ++c) {
    for (std::uint32_t k = 0; k < model.latent_size; ++k) push_float(model.latents[c * model.latent_size + k]);
    align4();
  }
  words[5] = kNone;
  if (model.clustered()) {
    words[5] = offset4();
    for (std::uint32_t id : model.cluster_ids) push_float(float(id));  // exact below 2^24
    align4();
  }
  words[6] = kNone;
  if (!model.texel_scales.empty()) {
    words[6] = offset4();
    for (float s : model.texel_scales) push_float(s);
    align4();
  }
  words[8] = std::bit_cast<std::uint32_t>(model.output_scale);
  return words;
}

bool is_paper_shape(const btf::NeuralBtf& model) {
  const auto& l = model.decoder.layers;
  return model.latent_size == 8 && l.size() == 4 && l[0].inputs == 12 && l[0].outputs == 106 && l[1].outputs == 106 &&
         l[2].outputs == 106 && l[3].outputs == 3;
}

Result<GpuBtfModel> upload_model(gpu::Device& device, const btf::NeuralBtf& model, std::string_view label,
                                 bool allow_unrolled) {
  auto words = pack_model(model);
  if (!words) return std::unexpected(words.error());
  auto buffer = device.create_buffer_with_data({.label = std::string(label), .size = words->size() * 4,
                                                .usage = gpu::BufferUsage::Storage | gpu::BufferUsage::CopyDst},
                                               std::as_bytes(std::span(*words)));
  if (!buffer) return std::unexpected(buffer.error());
  return GpuBtfModel{std::move(*buffer), allow_unrolled && is_paper_shape(model)};
}

// ---- the decode kernel ----------------------------------------------------------------------

struct BtfDecodeKernel::State {
  gpu::BindGroupLayout layout;
  gpu::PipelineLayout pipeline_layout;
  gpu::ComputePipeline pipeline;        // any shape
  gpu::ComputePipeline paper_pipeline;  // the paper's shape, unrolled
};

Result<BtfDecodeKernel> BtfDecodeKernel::create(gpu::Device& device) {
  using gpu::BindingType;
  using gpu::ShaderStage;
  auto cs = device.create_shader_module(
      {.label = "btf_decode.comp", .stage = ShaderStage::Compute, .spirv = shaders::btf_decode_comp()});
  if (!cs) return std::unexpected(cs.error());
  auto paper_cs = device.create_shader_module(
      {.label = "btf_decode_paper.comp", .stage = ShaderStage::Compute, .spirv = shaders::btf_decode_paper_comp()});
  if (!paper_cs) return std::unexpected(paper_cs.error());
  auto layout = device.create_bind_group_layout({.label = "btf-decode",
                                                 .entries = {{0, BindingType::ReadOnlyStorageBuffer, ShaderStage::Compute},
                                                             {1, BindingType::ReadOnlyStorageBuffer, ShaderStage::Compute},
                                                             {2, BindingType::StorageBuffer, ShaderStage::Compute}}});
  if (!layout) return std::unexpected(layout.error());
  auto pipeline_layout =
      device.create_pipeline_layout({.label = "btf-decode", .bind_group_layouts = {&*layout}, .push_constant_size = 4});
  if (!pipeline_layout) return std::unexpected(pipeline_layout.error());
  auto pipeline = device.create_compute_pipeline({.label = "btf-decode", .layout = &*pipeline_layout, .module = &*cs});
  if (!pipeline) return std::unexpected(pipeline.error());
  auto paper_pipeline =
      device.create_compute_pipeline({.label = "btf-decode-paper", .layout = &*pipeline_layout, .module = &*paper_cs});
  if (!paper_pipeline) return std::unexpected(paper_pipeline.error());
  BtfDecodeKernel k;
  k.state_ = std::make_shared<State>(
      State{std::move(*layout), std::move(*pipeline_layout), std::move(*pipeline), std::move(*paper_pipeline)});
  return k;
}

Result<double> BtfDecodeKernel::run(gpu::Device& device, const GpuBtfModel& model, const gpu::Buffer& queries,
                                    const gpu::Buffer& results, std::uint32_t count) const {
  if (queries.size() < std::uint64_t(count) * sizeof(DecodeQuery) || results.size() < std::uint64_t(count) * sizeof(vec4))
    return fail(ErrorKind::InvalidArgument, "btf decode: {} queries need {} and {} bytes; the buffers have {} and {}", count,
                std::uint64_t(count) * sizeof(DecodeQuery), std::uint64_t(count) * sizeof(vec4), queries.size(),
                results.size());
  auto group = device.create_bind_group(
      {.label = "btf-decode", .layout = &state_->layout,
       .entries = {gpu::bind(0, model.buffer), gpu::bind(1, queries), gpu::bind(2, results)}});
  if (!group) return std::unexpected(group.error());
  auto enc = device.create_command_encoder("btf-decode");
  if (!enc) return std::unexpected(enc.error());
  {
    auto pass = enc->begin_compute_pass("btf-decode");
    pass.set_pipeline(model.paper_shape ? state_->paper_pipeline : state_->pipeline);
    pass.set_bind_group(0, *group);
    pass.push(count);
    pass.dispatch((count + 63) / 64);
    pass.end();
  }
  auto cmd = enc->finish();
  if (!cmd) return std::unexpected(cmd.error());
  const auto start = std::chrono::steady_clock::now();
  if (auto ok = device.queue().submit(std::move(*cmd)); !ok) return std::unexpected(ok.error());
  if (auto ok = device.queue().wait_idle(); !ok) return std::unexpected(ok.error());
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

Result<std::vector<vec4>> BtfDecodeKernel::decode(gpu::Device& device, const GpuBtfModel& model,
                                                  std::span<const DecodeQuery> queries) const {
  if (queries.empty()) return std::vector<vec4>{};
  auto in = device.create_buffer_with_data(
      {.label = "btf-queries", .size = queries.size_bytes(), .usage = gpu::BufferUsage::Storage | gpu::BufferUsage::CopyDst},
      std::as_bytes(queries));
  if (!in) return std::unexpected(in.error());
  auto out = device.create_buffer({.label = "btf-results", .size = queries.size() * sizeof(vec4),
                                   .usage = gpu::BufferUsage::Storage | gpu::BufferUsage::CopySrc});
  if (!out) return std::unexpected(out.error());
  if (auto ok = run(device, model, *in, *out, std::uint32_t(queries.size())); !ok) return std::unexpected(ok.error());
  auto bytes = device.queue().read_buffer(*out);
  if (!bytes) return std::unexpected(bytes.error());
  std::vector<vec4> results(queries.size());
  std::memcpy(results.data(), bytes->data(), results.size() * sizeof(vec4));
  return results;
}

// ---- the graph pass ----------------------------------------------------------------------------

struct NeuralBtfGpuMaterial {
  btf::NeuralBtfParams params;
  const gpu::Buffer* model = nullptr;  // the packed model, or the raw BTF (reference)
  gpu::BindGroup group;
  bool reference = false;
};

struct NeuralBTFMaterial::State {
  gpu::BindGroupLayout frame_layout;
  gpu::BindGroupLayout material_layout;
  gpu::PipelineLayout layout;
  // The generic decoder for any shape: the unrolled paper-shape variant measured slower in
  // the fragment shader on lavapipe (docs/neural-btf.md), so only the decode kernel has it.
  gpu::RenderPipeline pipeline;
  gpu::RenderPipeline reference_pipeline;  // the raw BTF sampled instead (btf_reference.glsl)
  gpu::Sampler shadow_compare;
};

Result<NeuralBTFMaterial> NeuralBTFMaterial::create(gpu::Device& device) {
  using gpu::BindingType;
  using gpu::ShaderStage;
  auto vs = device.create_shader_module(
      {.label = "neural_btf.vert", .stage = ShaderStage::Vertex, .spirv = shaders::neural_btf_vert()});
  if (!vs) return std::unexpected(vs.error());
  auto fs = device.create_shader_module(
      {.label = "neural_btf.frag", .stage = ShaderStage::Fragment, .spirv = shaders::neural_btf_frag()});
  if (!fs) return std::unexpected(fs.error());
  auto reference_fs = device.create_shader_module({.label = "neural_btf_reference.frag",
                                                   .stage = ShaderStage::Fragment,
                                                   .spirv = shaders::neural_btf_reference_frag()});
  if (!reference_fs) return std::unexpected(reference_fs.error());
  auto frame_layout = device.create_bind_group_layout(
      {.label = "neural-btf-frame",
       .entries = {{0, BindingType::UniformBuffer, ShaderStage::Vertex | ShaderStage::Fragment},
                   {1, BindingType::TextureSampler, ShaderStage::Fragment}}});
  if (!frame_layout) return std::unexpected(frame_layout.error());
  auto material_layout = device.create_bind_group_layout(
      {.label = "neural-btf-model", .entries = {{0, BindingType::ReadOnlyStorageBuffer, ShaderStage::Fragment}}});
  if (!material_layout) return std::unexpected(material_layout.error());
  auto layout = device.create_pipeline_layout({.label = "neural-btf",
                                               .bind_group_layouts = {&*frame_layout, &*material_layout},
                                               .push_constant_size = sizeof(NeuralBtfConstants)});
  if (!layout) return std::unexpected(layout.error());
  auto pipeline = frame::create_lit_mesh_pipeline(device, "neural-btf", *layout, *vs, *fs, color_format, depth_format);
  if (!pipeline) return std::unexpected(pipeline.error());
  auto reference_pipeline = frame::create_lit_mesh_pipeline(device, "neural-btf-reference", *layout, *vs, *reference_fs,
                                                            color_format, depth_format);
  if (!reference_pipeline) return std::unexpected(reference_pipeline.error());
  auto shadow_compare = frame::create_shadow_compare_sampler(device, "neural-btf-shadow");
  if (!shadow_compare) return std::unexpected(shadow_compare.error());
  NeuralBTFMaterial pass;
  pass.state_ = std::make_shared<State>(State{std::move(*frame_layout), std::move(*material_layout), std::move(*layout),
                                              std::move(*pipeline), std::move(*reference_pipeline),
                                              std::move(*shadow_compare)});
  return pass;
}

Result<std::shared_ptr<NeuralBtfGpuMaterial>> NeuralBTFMaterial::create_material(gpu::Device& device,
                                                                             const btf::NeuralBtfParams& params,
                                                                             const GpuBtfModel& model) const {
  auto group = device.create_bind_group(
      {.label = "neural-btf-model", .layout = &state_->material_layout, .entries = {gpu::bind(0, model.buffer)}});
  if (!group) return std::unexpected(group.error());
  return std::make_shared<NeuralBtfGpuMaterial>(NeuralBtfGpuMaterial{params, &model.buffer, std::move(*group), false});
}

Result<std::shared_ptr<NeuralBtfGpuMaterial>> NeuralBTFMaterial::create_material(gpu::Device& device,
                                                                             const btf::NeuralBtfParams& params,
                                                                             const GpuBtfReference& reference) const {
  auto group = device.create_bind_group({.label = "neural-btf-reference",
                                         .layout = &state_->material_layout,
                                         .entries = {gpu::bind(0, reference.buffer)}});
  if (!group) return std::unexpected(group.error());
  return std::make_shared<NeuralBtfGpuMaterial>(NeuralBtfGpuMaterial{params, &reference.buffer, std::move(*group), true});
}

Result<void> NeuralBTFMaterial::add(RenderGraph& graph, std::span<const NeuralBtfDraw> draws,
                                std::span<const std::shared_ptr<NeuralBtfGpuMaterial>> materials) const {
  for (const auto& d : draws)
    if (!d.mesh || d.material >= materials.size() || !materials[d.material])
      return fail(ErrorKind::InvalidArgument, "neural BTF pass: a draw names material {} of {} (or has no mesh)",
                  d.material, materials.size());
  // Each distinct model buffer once: the graph sees the pass read it.
  std::vector<const gpu::Buffer*> models;
  for (const auto& m : materials)
    if (std::find(models.begin(), models.end(), m->model) == models.end()) models.push_back(m->model);
  frame::ScenePassDesc desc{.name = "neural_btf"};
  for (std::size_t i = 0; i < models.size(); ++i)
    desc.buffers.push_back(
        {models.size() == 1 ? std::string("neural_btf_model") : weft::format("neural_btf_model_{}", i), models[i]});
  auto state = state_;
  return frame::add_scene_color_pass(graph, std::move(desc), [state, draws, materials](frame::ScenePassDraw& scene) {
    PassContext& ctx = scene.context;
    auto group = ctx.device().create_bind_group(
        {.label = "neural-btf-frame",
         .layout = &state->frame_layout,
         .entries = {gpu::bind(0, scene.uniforms), gpu::bind(1, scene.shadow_map, &state->shadow_compare)}});
    if (!group) return ctx.encoder().report_error(group.error());
    const auto& frame_group = ctx.keep(std::move(*group));
    gpu::RenderPassEncoder& pass = scene.pass;
    const gpu::RenderPipeline* bound = nullptr;
    for (const NeuralBtfDraw& draw : draws) {
      const NeuralBtfGpuMaterial& mat = *materials[draw.material];
      const gpu::RenderPipeline* pipeline = mat.reference ? &state->reference_pipeline : &state->pipeline;
      if (pipeline != bound) {
        pass.set_pipeline(*pipeline);
        pass.set_bind_group(0, frame_group);
        bound = pipeline;
      }
      const btf::NeuralBtfParams& m = mat.params;
      const int flags = (m.ambient ? flag_ambient : 0) | (m.filter == btf::TexelFilter::Bilinear ? flag_bilinear : 0) |
                        (m.shadow ? flag_shadow : 0);
      NeuralBtfConstants c{};
      c.model = draw.model;
      c.uv_scale = vec4(m.uv_scale, float(flags), m.exposure);
      c.tint = vec4(m.tint, 1.0f);
      c.debug = vec4(float(int(m.debug_view)), 0.0f, 0.0f, 0.0f);
      pass.set_bind_group(1, mat.group);
      pass.push(c);
      pass.set_vertex_buffer(0, draw.mesh->vertices);
      pass.set_index_buffer(draw.mesh->indices);
      pass.draw_indexed(draw.mesh->index_count);
    }
  });
}

}  // namespace weft::passes
