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
#include <weft/try.h>
#include "weft_pass_neural_btf_shaders.h"
module weft.pass.neural_btf;

namespace weft::passes {

namespace {
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
  WEFT_TRY_VOID(btf::validate(model));
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
  WEFT_TRY(auto words, pack_model(model));
  WEFT_TRY(auto buffer, device.create_buffer_with_data({.label = std::string(label), .size = words.size() * 4,
                                                  .usage = gpu::BufferUsage::Storage | gpu::BufferUsage::CopyDst},
                                                 std::as_bytes(std::span(words))));
  return GpuBtfModel{std::move(buffer), allow_unrolled && is_paper_shape(model), is_paper_shape(model)};
}

// ---- the decode kernel ----------------------------------------------------------------------

struct BtfDecodeKernel::State {
  gpu::BindGroupLayout layout;
  gpu::PipelineLayout pipeline_layout;
  gpu::ComputePipeline pipeline;        // any shape
  gpu::ComputePipeline paper_pipeline;  // the paper's shape, unrolled
  gpu::ComputePipeline tiled_pipeline;  // the paper's shape, batched (the material's batched path)
};

std::string_view to_string(DecodeVariant v) {
  switch (v) {
    case DecodeVariant::Auto: return "auto";
    case DecodeVariant::Generic: return "generic";
    case DecodeVariant::Unrolled: return "unrolled";
    case DecodeVariant::Tiled: return "tiled";
  }
  return "?";
}

Result<BtfDecodeKernel> BtfDecodeKernel::create(gpu::Device& device) {
  using gpu::BindingType;
  using gpu::ShaderStage;
  WEFT_TRY(auto cs, device.create_shader_module(
        {.label = "btf_decode.comp", .stage = ShaderStage::Compute, .spirv = shaders::btf_decode_comp()}));
  WEFT_TRY(auto paper_cs, device.create_shader_module(
        {.label = "btf_decode_paper.comp", .stage = ShaderStage::Compute, .spirv = shaders::btf_decode_paper_comp()}));
  WEFT_TRY(auto tiled_cs, device.create_shader_module(
        {.label = "btf_decode_tiled.comp", .stage = ShaderStage::Compute, .spirv = shaders::btf_decode_tiled_comp()}));
  WEFT_TRY(auto layout, device.create_bind_group_layout({.label = "btf-decode",
                                                   .entries = {{0, BindingType::ReadOnlyStorageBuffer, ShaderStage::Compute},
                                                               {1, BindingType::ReadOnlyStorageBuffer, ShaderStage::Compute},
                                                               {2, BindingType::StorageBuffer, ShaderStage::Compute}}}));
  auto pipeline_layout =
      device.create_pipeline_layout({.label = "btf-decode", .bind_group_layouts = {&layout}, .push_constant_size = 4});
  if (!pipeline_layout) return std::unexpected(pipeline_layout.error());
  WEFT_TRY(auto pipeline, device.create_compute_pipeline({.label = "btf-decode", .layout = &*pipeline_layout, .module = &cs}));
  auto paper_pipeline =
      device.create_compute_pipeline({.label = "btf-decode-paper", .layout = &*pipeline_layout, .module = &paper_cs});
  if (!paper_pipeline) return std::unexpected(paper_pipeline.error());
  auto tiled_pipeline =
      device.create_compute_pipeline({.label = "btf-decode-tiled", .layout = &*pipeline_layout, .module = &tiled_cs});
  if (!tiled_pipeline) return std::unexpected(tiled_pipeline.error());
  BtfDecodeKernel k;
  k.state_ = std::make_shared<State>(State{std::move(layout), std::move(*pipeline_layout), std::move(pipeline),
                                           std::move(*paper_pipeline), std::move(*tiled_pipeline)});
  return k;
}

Result<double> BtfDecodeKernel::run(gpu::Device& device, const GpuBtfModel& model, const gpu::Buffer& queries,
                                    const gpu::Buffer& results, std::uint32_t count, DecodeVariant variant) const {
  if (variant == DecodeVariant::Auto) variant = model.paper_shape ? DecodeVariant::Unrolled : DecodeVariant::Generic;
  if ((variant == DecodeVariant::Unrolled || variant == DecodeVariant::Tiled) && !model.tiled)
    return fail(ErrorKind::Unsupported, "btf decode: the {} shader decodes the paper's shape only (8 + 4 -> 106 x 3 -> 3)",
                to_string(variant));
  if (count == 0) return 0.0;
  if (queries.size() < std::uint64_t(count) * sizeof(DecodeQuery) || results.size() < std::uint64_t(count) * sizeof(vec4))
    return fail(ErrorKind::InvalidArgument, "btf decode: {} queries need {} and {} bytes; the buffers have {} and {}", count,
                std::uint64_t(count) * sizeof(DecodeQuery), std::uint64_t(count) * sizeof(vec4), queries.size(),
                results.size());
  WEFT_TRY(auto group, device.create_bind_group(
        {.label = "btf-decode", .layout = &state_->layout,
         .entries = {gpu::bind(0, model.buffer), gpu::bind(1, queries), gpu::bind(2, results)}}));
  WEFT_TRY(auto enc, device.create_command_encoder("btf-decode"));
  {
    auto pass = enc.begin_compute_pass("btf-decode");
    pass.set_pipeline(variant == DecodeVariant::Unrolled ? state_->paper_pipeline
                      : variant == DecodeVariant::Tiled  ? state_->tiled_pipeline
                                                         : state_->pipeline);
    pass.set_bind_group(0, group);
    pass.push(count);
    // The tiled kernel decodes 256 queries a workgroup (32 invocations x 8 rows), the others 64.
    const std::uint32_t per_group = variant == DecodeVariant::Tiled ? 256 : 64;
    pass.dispatch((count + per_group - 1) / per_group);
    pass.end();
  }
  WEFT_TRY(auto cmd, enc.finish());
  const auto start = std::chrono::steady_clock::now();
  WEFT_TRY_VOID(device.queue().submit(std::move(cmd)));
  WEFT_TRY_VOID(device.queue().wait_idle());
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

Result<std::vector<vec4>> BtfDecodeKernel::decode(gpu::Device& device, const GpuBtfModel& model,
                                                  std::span<const DecodeQuery> queries, DecodeVariant variant) const {
  if (queries.empty()) return std::vector<vec4>{};
  WEFT_TRY(auto in, device.create_buffer_with_data(
        {.label = "btf-queries", .size = queries.size_bytes(), .usage = gpu::BufferUsage::Storage | gpu::BufferUsage::CopyDst},
        std::as_bytes(queries)));
  WEFT_TRY(auto out, device.create_buffer({.label = "btf-results", .size = queries.size() * sizeof(vec4),
                                     .usage = gpu::BufferUsage::Storage | gpu::BufferUsage::CopySrc}));
  if (auto ok = run(device, model, in, out, std::uint32_t(queries.size()), variant); !ok)
    return std::unexpected(ok.error());
  WEFT_TRY(auto bytes, device.queue().read_buffer(out));
  std::vector<vec4> results(queries.size());
  std::memcpy(results.data(), bytes.data(), results.size() * sizeof(vec4));
  return results;
}

// ---- the graph pass ----------------------------------------------------------------------------

struct NeuralBtfGpuMaterial {
  btf::NeuralBtfParams params;
  const gpu::Buffer* model = nullptr;  // the packed model, or the raw BTF (reference)
  bool tiled = false;                  // the model has the paper's shape (GpuBtfModel::tiled)
  gpu::BindGroup group;
  bool reference = false;              // the raw BTF: drawn through the fragment path
};

struct NeuralBTFMaterial::State {
  gpu::BindGroupLayout frame_layout;
  gpu::BindGroupLayout material_layout;
  std::shared_ptr<const gpu::PipelineLayout> layout;
  // The generic decoder for any shape: the unrolled paper-shape variant measured slower in
  // the fragment shader on lavapipe (docs/neural-btf.md), so only the decode kernel has it.
  frame::PipelineSamples pipeline;
  frame::PipelineSamples reference_pipeline;  // the raw BTF sampled instead (btf_reference.glsl)
  gpu::Sampler shadow_compare;
  // The batched path: geometry into the G-buffer (same layouts as the fragment path), the
  // tiled decode (paper shape; any other shape per row), the resolve into the scene colour.
  gpu::RenderPipeline gbuffer_pipeline;
  gpu::BindGroupLayout list_layout;
  gpu::PipelineLayout list_pipeline_layout;
  gpu::ComputePipeline list_pipeline;
  gpu::BindGroupLayout decode_layout;
  gpu::PipelineLayout decode_pipeline_layout;
  gpu::ComputePipeline decode_tiled;
  gpu::ComputePipeline decode_generic;
  gpu::BindGroupLayout resolve_layout;  // the composite's decoded inputs: marker, radiance
  gpu::Sampler nearest;
  // The last step: the objects drawn again into the scene colour and depth (multisampled or
  // not), depth-tested there, each pixel taking its decode (neural_btf_composite.frag).
  std::shared_ptr<const gpu::PipelineLayout> composite_layout;
  frame::PipelineSamples composite_pipeline;
};

namespace {
// The G-buffer of the batched path (neural_btf_gbuffer.frag): the twelve numbers a decode
// reads as fp32, so the decode sees the fragment path's numbers exactly, packed without gaps
// into three RGBA32F targets, and the marker in a half (exact for its small integers): 50
// bytes a pixel where four RGBA32F targets with a marker in one were 64. (Halves for the
// weights and 16-bit directions were tried: 3.8e-4 RMSE against the fragment path.)
constexpr gpu::Format gbuffer_formats[4] = {gpu::Format::RGBA32Float, gpu::Format::RGBA32Float,
                                            gpu::Format::RGBA32Float, gpu::Format::R16Float};
constexpr const char* gbuffer_names[4] = {"neural_btf_coords", "neural_btf_light", "neural_btf_weights",
                                          "neural_btf_marker"};
constexpr int gbuffer_marker = 3;  // the target every pass that only asks "is this a BTF pixel" reads
constexpr std::uint32_t list_tile = 16;    // btf_list_taps.comp's TILE
constexpr std::uint32_t tap_classes = 4;   // btf_pixel_taps.glsl's BTF_CLASSES: pixels of 1, 2, 4, 8 decodes
struct DecodePush {
  std::uint32_t width, height, model, tap_class;
};
}  // namespace

Result<NeuralBTFMaterial> NeuralBTFMaterial::create(gpu::Device& device) {
  using gpu::BindingType;
  using gpu::ShaderStage;
  WEFT_TRY(auto vs, device.create_shader_module(
        {.label = "neural_btf.vert", .stage = ShaderStage::Vertex, .spirv = shaders::neural_btf_vert()}));
  WEFT_TRY(auto fs, device.create_shader_module(
        {.label = "neural_btf.frag", .stage = ShaderStage::Fragment, .spirv = shaders::neural_btf_frag()}));
  WEFT_TRY(auto reference_fs, device.create_shader_module({.label = "neural_btf_reference.frag",
                                                     .stage = ShaderStage::Fragment,
                                                     .spirv = shaders::neural_btf_reference_frag()}));
  WEFT_TRY(auto gbuffer_fs, device.create_shader_module(
        {.label = "neural_btf_gbuffer.frag", .stage = ShaderStage::Fragment, .spirv = shaders::neural_btf_gbuffer_frag()}));
  WEFT_TRY(auto list_cs, device.create_shader_module(
        {.label = "btf_list_taps.comp", .stage = ShaderStage::Compute, .spirv = shaders::btf_list_taps_comp()}));
  WEFT_TRY(auto tiled_cs, device.create_shader_module(
        {.label = "btf_decode_taps.comp", .stage = ShaderStage::Compute, .spirv = shaders::btf_decode_taps_comp()}));
  WEFT_TRY(auto generic_cs, device.create_shader_module({.label = "btf_decode_taps_generic.comp",
                                                   .stage = ShaderStage::Compute,
                                                   .spirv = shaders::btf_decode_taps_generic_comp()}));

  WEFT_TRY(auto frame_layout, device.create_bind_group_layout(
        {.label = "neural-btf-frame",
         .entries = {{0, BindingType::UniformBuffer, ShaderStage::Vertex | ShaderStage::Fragment},
                     {1, BindingType::TextureSampler, ShaderStage::Fragment}}}));
  WEFT_TRY(auto material_layout, device.create_bind_group_layout(
        {.label = "neural-btf-model", .entries = {{0, BindingType::ReadOnlyStorageBuffer, ShaderStage::Fragment}}}));
  WEFT_TRY(auto made_layout, device.create_pipeline_layout({.label = "neural-btf",
                                                 .bind_group_layouts = {&frame_layout, &material_layout},
                                                 .push_constant_size = sizeof(NeuralBtfConstants)}));
  // Shared with the pipelines of other sample counts, made when a frame first asks.
  const auto layout = std::make_shared<const gpu::PipelineLayout>(std::move(made_layout));
  WEFT_TRY(auto shadow_compare, frame::create_shadow_compare_sampler(device, "neural-btf-shadow"));

  WEFT_TRY(auto gbuffer_pipeline, device.create_render_pipeline(
        {.label = "neural-btf-gbuffer",
         .layout = layout.get(),
         .vertex = &vs,
         .fragment = &gbuffer_fs,
         .vertex_buffers = {frame::vertex_layout()},
         .cull_mode = gpu::CullMode::None,
         .color_targets = {{gbuffer_formats[0]}, {gbuffer_formats[1]}, {gbuffer_formats[2]}, {gbuffer_formats[3]}},
         .depth_stencil = gpu::DepthStencilState{.format = frame::scene_depth_format}}));
  // The fragment path in every sample count (it is what an MSAA frame draws): each kept set
  // owns its shaders, so the reference gets its own copy of the vertex shader.
  WEFT_TRY(auto reference_vs, device.create_shader_module(
        {.label = "neural_btf.vert", .stage = ShaderStage::Vertex, .spirv = shaders::neural_btf_vert()}));
  WEFT_TRY(auto pipeline, frame::create_lit_mesh_pipelines(device, "neural-btf", layout, std::move(vs), std::move(fs)));
  WEFT_TRY(auto reference_pipeline, frame::create_lit_mesh_pipelines(device, "neural-btf-reference", layout,
                                                                     std::move(reference_vs), std::move(reference_fs)));
  WEFT_TRY(auto list_layout, device.create_bind_group_layout({.label = "neural-btf-list",
                                                        .entries = {{0, BindingType::TextureSampler, ShaderStage::Compute},
                                                                    {1, BindingType::TextureSampler, ShaderStage::Compute},
                                                                    {2, BindingType::TextureSampler, ShaderStage::Compute},
                                                                    {3, BindingType::StorageBuffer, ShaderStage::Compute},
                                                                    {4, BindingType::StorageBuffer, ShaderStage::Compute},
                                                                    {5, BindingType::StorageBuffer, ShaderStage::Compute},
                                                                    {6, BindingType::StorageBuffer, ShaderStage::Compute}}}));
  WEFT_TRY(auto list_pipeline_layout, device.create_pipeline_layout(
        {.label = "neural-btf-list", .bind_group_layouts = {&list_layout}, .push_constant_size = sizeof(DecodePush)}));
  WEFT_TRY(auto list_pipeline, device.create_compute_pipeline(
        {.label = "neural-btf-list", .layout = &list_pipeline_layout, .module = &list_cs}));
  WEFT_TRY(auto decode_layout, device.create_bind_group_layout({.label = "neural-btf-decode",
                                                          .entries = {{0, BindingType::ReadOnlyStorageBuffer, ShaderStage::Compute},
                                                                      {1, BindingType::TextureSampler, ShaderStage::Compute},
                                                                      {2, BindingType::TextureSampler, ShaderStage::Compute},
                                                                      {3, BindingType::TextureSampler, ShaderStage::Compute},
                                                                      {4, BindingType::TextureSampler, ShaderStage::Compute},
                                                                      {5, BindingType::ReadOnlyStorageBuffer, ShaderStage::Compute},
                                                                      {6, BindingType::ReadOnlyStorageBuffer, ShaderStage::Compute},
                                                                      {7, BindingType::StorageBuffer, ShaderStage::Compute}}}));
  WEFT_TRY(auto decode_pipeline_layout, device.create_pipeline_layout(
        {.label = "neural-btf-decode", .bind_group_layouts = {&decode_layout}, .push_constant_size = sizeof(DecodePush)}));
  WEFT_TRY(auto decode_tiled, device.create_compute_pipeline(
        {.label = "neural-btf-decode-tiled", .layout = &decode_pipeline_layout, .module = &tiled_cs}));
  WEFT_TRY(auto decode_generic, device.create_compute_pipeline(
        {.label = "neural-btf-decode-generic", .layout = &decode_pipeline_layout, .module = &generic_cs}));
  WEFT_TRY(auto resolve_layout, device.create_bind_group_layout(
        {.label = "neural-btf-resolve",
         .entries = {{0, BindingType::TextureSampler, ShaderStage::Fragment},
                     {1, BindingType::ReadOnlyStorageBuffer, ShaderStage::Fragment}}}));
  WEFT_TRY(auto nearest, device.create_sampler(
        {.label = "neural-btf-gbuffer", .mag_filter = gpu::FilterMode::Nearest, .min_filter = gpu::FilterMode::Nearest}));
  WEFT_TRY(auto made_composite_layout,
           device.create_pipeline_layout({.label = "neural-btf-composite",
                                          .bind_group_layouts = {&frame_layout, &resolve_layout},
                                          .push_constant_size = sizeof(NeuralBtfConstants)}));
  const auto composite_layout = std::make_shared<const gpu::PipelineLayout>(std::move(made_composite_layout));
  WEFT_TRY(auto composite_vs, device.create_shader_module(
        {.label = "neural_btf.vert", .stage = ShaderStage::Vertex, .spirv = shaders::neural_btf_vert()}));
  WEFT_TRY(auto composite_fs, device.create_shader_module({.label = "neural_btf_composite.frag",
                                                          .stage = ShaderStage::Fragment,
                                                          .spirv = shaders::neural_btf_composite_frag()}));
  WEFT_TRY(auto composite_pipeline, frame::create_lit_mesh_pipelines(device, "neural-btf-composite", composite_layout,
                                                                     std::move(composite_vs), std::move(composite_fs)));

  NeuralBTFMaterial pass;
  pass.state_ = std::make_shared<State>(State{std::move(frame_layout), std::move(material_layout), layout,
                                              std::move(pipeline), std::move(reference_pipeline),
                                              std::move(shadow_compare), std::move(gbuffer_pipeline), std::move(list_layout),
                                              std::move(list_pipeline_layout), std::move(list_pipeline), std::move(decode_layout),
                                              std::move(decode_pipeline_layout), std::move(decode_tiled),
                                              std::move(decode_generic), std::move(resolve_layout),
                                              std::move(nearest), composite_layout, std::move(composite_pipeline)});
  return pass;
}

Result<std::shared_ptr<NeuralBtfGpuMaterial>> NeuralBTFMaterial::create_material(gpu::Device& device,
                                                                             const btf::NeuralBtfParams& params,
                                                                             const GpuBtfModel& model) const {
  WEFT_TRY(auto group, device.create_bind_group(
        {.label = "neural-btf-model", .layout = &state_->material_layout, .entries = {gpu::bind(0, model.buffer)}}));
  return std::make_shared<NeuralBtfGpuMaterial>(
      NeuralBtfGpuMaterial{params, &model.buffer, model.tiled, std::move(group), false});
}

Result<std::shared_ptr<NeuralBtfGpuMaterial>> NeuralBTFMaterial::create_material(gpu::Device& device,
                                                                             const btf::NeuralBtfParams& params,
                                                                             const GpuBtfReference& reference) const {
  WEFT_TRY(auto group, device.create_bind_group({.label = "neural-btf-reference",
                                           .layout = &state_->material_layout,
                                           .entries = {gpu::bind(0, reference.buffer)}}));
  return std::make_shared<NeuralBtfGpuMaterial>(
      NeuralBtfGpuMaterial{params, &reference.buffer, false, std::move(group), true});
}

namespace {

// The raw-BTF reference and the debug views draw through the fragment path.
bool batched(const NeuralBtfGpuMaterial& mat) {
  const btf::NeuralBtfParams& m = mat.params;
  return !mat.reference && m.decoder == btf::BtfDecoder::Batched && m.debug_view == btf::BtfDebugView::None;
}

NeuralBtfConstants draw_constants(const NeuralBtfDraw& draw, const btf::NeuralBtfParams& m, float marker,
                                  vec2 gbuffer_origin = vec2(0.0f)) {
  const int flags = (m.ambient ? flag_ambient : 0) | (m.filter == btf::TexelFilter::Bilinear ? flag_bilinear : 0) |
                    (m.shadow ? flag_shadow : 0);
  NeuralBtfConstants c{};
  c.model = draw.model;
  c.uv_scale = vec4(m.uv_scale, float(flags), m.exposure);
  c.tint = vec4(m.tint, 1.0f);
  c.debug = vec4(float(int(m.debug_view)), marker, gbuffer_origin);
  return c;
}

// The pixels the draws can cover in a width x height frame: their bounds' corners projected,
// two pixels of margin (rasterisation rules, a jittered projection). The whole frame when a
// corner is not in front of the camera (its projection is not bounded), at least one pixel.
struct PixelRect {
  std::uint32_t x = 0, y = 0, width = 1, height = 1;
};
PixelRect covered_pixels(std::span<const NeuralBtfDraw> draws, const mat4& view_projection, std::uint32_t width,
                         std::uint32_t height) {
  const PixelRect frame{0, 0, width, height};
  float x0 = std::numeric_limits<float>::max(), y0 = x0, x1 = -x0, y1 = -x0;
  for (const NeuralBtfDraw& d : draws) {
    const mat4 to_clip = view_projection * d.model;
    for (int corner = 0; corner < 8; ++corner) {
      const vec3 p((corner & 1) ? d.mesh->bounds_max.x : d.mesh->bounds_min.x,
                   (corner & 2) ? d.mesh->bounds_max.y : d.mesh->bounds_min.y,
                   (corner & 4) ? d.mesh->bounds_max.z : d.mesh->bounds_min.z);
      const vec4 clip = to_clip * vec4(p, 1.0f);
      if (!(clip.w > 1e-6f) || !std::isfinite(clip.x) || !std::isfinite(clip.y)) return frame;
      // Vulkan's viewport: NDC -1..1 to pixels 0..size, y down the image.
      const float px = (clip.x / clip.w * 0.5f + 0.5f) * float(width), py = (clip.y / clip.w * 0.5f + 0.5f) * float(height);
      x0 = std::min(x0, px), x1 = std::max(x1, px), y0 = std::min(y0, py), y1 = std::max(y1, py);
    }
  }
  const auto clamp_to = [](float v, std::uint32_t size) {
    return std::uint32_t(std::clamp(v, 0.0f, float(size)));
  };
  const std::uint32_t left = clamp_to(std::floor(x0) - 2.0f, width), right = clamp_to(std::ceil(x1) + 2.0f, width);
  const std::uint32_t top = clamp_to(std::floor(y0) - 2.0f, height), bottom = clamp_to(std::ceil(y1) + 2.0f, height);
  if (right <= left || bottom <= top) return {std::min(left, width - 1), std::min(top, height - 1), 1, 1};
  return {left, top, right - left, bottom - top};
}

}  // namespace

Result<void> NeuralBTFMaterial::add(RenderGraph& graph, std::span<const NeuralBtfDraw> draws,
                                    std::span<const std::shared_ptr<NeuralBtfGpuMaterial>> materials, std::uint32_t width,
                                    std::uint32_t height, const mat4& view_projection) const {
  for (const auto& d : draws)
    if (!d.mesh || d.material >= materials.size() || !materials[d.material])
      return fail(ErrorKind::InvalidArgument, "neural BTF pass: a draw names material {} of {} (or has no mesh)",
                  d.material, materials.size());
  // An MSAA frame keeps the batched path: one decode per pixel (as MSAA shades once per pixel),
  // then the objects drawn again into the multisampled targets, covered per sample, each
  // pixel taking its decode (add_batched; docs/anti-aliasing.md#msaa). Through the fragment
  // path instead -- the MLP in the fragment shader -- an MSAA showcase frame spent 26 times
  // as long on the cloth on lavapipe.
  std::vector<NeuralBtfDraw> batched_draws, fragment_draws;
  for (const auto& d : draws) (batched(*materials[d.material]) ? batched_draws : fragment_draws).push_back(d);
  if (!batched_draws.empty())
    if (auto ok = add_batched(graph, std::move(batched_draws), materials, width, height, view_projection); !ok)
      return ok;
  if (fragment_draws.empty()) return {};

  // The fragment path: each distinct model buffer once, so the graph sees the pass read it.
  std::vector<const gpu::Buffer*> models;
  for (const auto& d : fragment_draws)
    if (std::find(models.begin(), models.end(), materials[d.material]->model) == models.end())
      models.push_back(materials[d.material]->model);
  frame::ScenePassDesc desc{.name = "neural_btf_fragment"};
  for (std::size_t i = 0; i < models.size(); ++i)
    desc.buffers.push_back({models.size() == 1 ? std::string("neural_btf_model") : weft::format("neural_btf_model_{}", i),
                            models[i]});
  auto state = state_;
  return frame::add_scene_color_pass(
      graph, std::move(desc), [state, draws = std::move(fragment_draws), materials](frame::ScenePassDraw& scene) {
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
          auto chosen = (mat.reference ? state->reference_pipeline : state->pipeline).at(ctx.device(), scene.samples);
          if (!chosen) return ctx.encoder().report_error(chosen.error());
          const gpu::RenderPipeline* pipeline = *chosen;
          if (pipeline != bound) {
            pass.set_pipeline(*pipeline);
            pass.set_bind_group(0, frame_group);
            bound = pipeline;
          }
          pass.set_bind_group(1, mat.group);
          pass.push(draw_constants(draw, mat.params, 0.0f));
          pass.set_vertex_buffer(0, draw.mesh->vertices);
          pass.set_index_buffer(draw.mesh->indices);
          pass.draw_indexed(draw.mesh->index_count);
        }
      });
}

// The batched path (docs/neural-btf.md, "The batched decode"): neural_btf draws the objects
// into a G-buffer of decode inputs with a depth of its own; per model (so the graph orders
// their writes), neural_btf_list collects the model's pixels into lists by how many decodes
// each needs, and neural_btf_decode decodes the lists in full batches of 256 rows (indirect
// dispatches); neural_btf_composite draws the objects again into the scene colour and depth,
// depth-tested there, each pixel taking its decode. The G-buffer, its depth, the lists and
// the radiance cover only the pixels the objects' bounds project to (covered_pixels), so they
// take memory by the objects' size on screen, not the frame's.
Result<void> NeuralBTFMaterial::add_batched(RenderGraph& graph, std::vector<NeuralBtfDraw> draws,
                                            std::span<const std::shared_ptr<NeuralBtfGpuMaterial>> materials,
                                            std::uint32_t width, std::uint32_t height, const mat4& view_projection) const {
  if (width == 0 || height == 0)
    return fail(ErrorKind::InvalidArgument, "neural BTF pass: the frame is {} x {} pixels", width, height);
  WEFT_TRY(frame::SceneTargets shared, frame::scene_targets(graph.blackboard(), {.environment = false}));
  // The G-buffer (one sample per pixel, over the objects' rectangle) has a depth of its own --
  // the objects' nearest surface in each pixel -- and the composite at the end depth-tests them
  // against the scene's depth (all of its samples in an MSAA frame).
  const std::uint32_t samples = frame::scene_sample_count(graph);
  const PixelRect rect = covered_pixels(draws, view_projection, width, height);
  const gpu::Extent3D rect_size{rect.width, rect.height, 1};
  const vec2 rect_origin(float(rect.x), float(rect.y));
  // The distinct models, in the order the G-buffer's marker numbers them.
  struct Model {
    const gpu::Buffer* buffer;
    bool tiled;
    BufferHandle handle;
  };
  std::vector<Model> models;
  std::vector<float> marker_of_draw;
  for (const auto& d : draws) {
    const NeuralBtfGpuMaterial& mat = *materials[d.material];
    std::size_t m = 0;
    while (m < models.size() && models[m].buffer != mat.model) ++m;
    if (m == models.size()) {
      const std::string name = weft::format("neural_btf_model{}", m == 0 ? std::string() : weft::format("_{}", m));
      models.push_back({mat.model, mat.tiled, graph.import_buffer(name, mat.model, gpu::Access::StorageRead)});
    }
    marker_of_draw.push_back(float(2 * m + (mat.params.filter == btf::TexelFilter::Bilinear ? 1 : 0) + 1));
  }

  struct GeometryData {
    BufferHandle uniforms;
    TextureHandle shadow_map;
    TextureHandle gbuffer[4];
    TextureHandle depth;
  };
  auto state = state_;
  auto& geometry = graph.add_pass<GeometryData>(
      "neural_btf",
      [&](PassBuilder& b, GeometryData& d) {
        d.uniforms = b.read(shared.uniforms, BufferUse::Uniform);
        d.shadow_map = b.read(shared.shadow_map, TextureUse::Sampled);
        for (const Model& m : models) b.read(m.handle, BufferUse::StorageRead);
        for (int i = 0; i < 4; ++i)
          d.gbuffer[i] = b.write(b.create_texture(gbuffer_names[i], {.size = rect_size, .format = gbuffer_formats[i]}),
                                 TextureUse::ColorAttachment);
        d.depth = b.write(b.create_texture("neural_btf_depth", {.size = rect_size, .format = frame::scene_depth_format}),
                          TextureUse::DepthAttachment);
      },
      [state, draws, materials, marker_of_draw, rect, width, height](const PassResources& res, const GeometryData& d,
                                                                     PassContext& ctx) {
        auto group = ctx.device().create_bind_group(
            {.label = "neural-btf-frame",
             .layout = &state->frame_layout,
             .entries = {gpu::bind(0, res.buffer(d.uniforms)), gpu::bind(1, res.view(d.shadow_map), &state->shadow_compare)}});
        if (!group) return ctx.encoder().report_error(group.error());
        const auto& frame_group = ctx.keep(std::move(*group));
        gpu::RenderPassDescriptor rp{.label = "neural_btf"};
        for (int i = 0; i < 4; ++i)
          rp.color_attachments.push_back({.view = &res.view(d.gbuffer[i]), .load = gpu::LoadOp::Clear,
                                          .clear_color = vec4(0.0f)});
        rp.depth_attachment = gpu::DepthAttachment{.view = &res.view(d.depth), .load = gpu::LoadOp::Clear};
        auto pass = ctx.encoder().begin_render_pass(rp);
        pass.set_pipeline(state->gbuffer_pipeline);
        // The frame's viewport, moved so that the rectangle's corner is the targets' origin.
        pass.set_viewport(-float(rect.x), -float(rect.y), float(width), float(height));
        pass.set_scissor_rect(0, 0, rect.width, rect.height);
        pass.set_bind_group(0, frame_group);
        for (std::size_t i = 0; i < draws.size(); ++i) {
          const NeuralBtfDraw& draw = draws[i];
          const NeuralBtfGpuMaterial& mat = *materials[draw.material];
          pass.set_bind_group(1, mat.group);
          pass.push(draw_constants(draw, mat.params, marker_of_draw[i]));
          pass.set_vertex_buffer(0, draw.mesh->vertices);
          pass.set_index_buffer(draw.mesh->indices);
          pass.draw_indexed(draw.mesh->index_count);
        }
        pass.end();
      });
  const GeometryData g = geometry;

  // The lists' lengths and the decodes' indirect group counts, zeroed each frame: per model and
  // class (btf_pixel_taps.glsl), a count, and a VkDispatchIndirectCommand behind a pad word.
  const std::uint64_t pixels = std::uint64_t(rect.width) * rect.height;
  if (2 * pixels >= (std::uint64_t(1) << 32))
    return fail(ErrorKind::InvalidArgument,
                "neural BTF pass: its objects cover {} x {} pixels, more than the decode list indexes (2^31)", rect.width,
                rect.height);
  const std::uint64_t counters = models.size() * tap_classes;
  struct ClearData {
    BufferHandle counts, groups;
  };
  auto& clear = graph.add_pass<ClearData>(
      "neural_btf_list_clear",
      [&](PassBuilder& b, ClearData& d) {
        d.counts = b.write(b.create_buffer("neural_btf_list_counts", {.size = counters * 4}), BufferUse::CopyDst);
        d.groups = b.write(b.create_buffer("neural_btf_decode_groups", {.size = counters * 16}), BufferUse::CopyDst);
        b.kind(PassKind::Transfer);
      },
      [](const PassResources& res, const ClearData& d, PassContext& ctx) {
        ctx.encoder().fill_buffer(res.buffer(d.counts), 0);
        ctx.encoder().fill_buffer(res.buffer(d.groups), 0);
      });
  BufferHandle counts = clear.counts, groups = clear.groups, list, radiance;

  struct ListData {
    TextureHandle gbuffer[3];  // light, weights, marker
    BufferHandle counts, groups, list, radiance;
  };
  struct DecodeData {
    TextureHandle gbuffer[4];
    BufferHandle model, counts, groups, list, radiance;
  };
  for (std::size_t m = 0; m < models.size(); ++m) {
    const bool first = m == 0;
    const std::string suffix = first ? std::string() : weft::format("_{}", m);
    auto& listed = graph.add_pass<ListData>(
        "neural_btf_list" + suffix,
        [&](PassBuilder& b, ListData& d) {
          for (int i = 0; i < 3; ++i) d.gbuffer[i] = b.read(g.gbuffer[i + 1], TextureUse::Sampled);
          d.counts = b.write(counts, BufferUse::StorageWrite);
          d.groups = b.write(groups, BufferUse::StorageWrite);
          // Two halves of one entry per pixel (btf_pixel_taps.glsl's list_index); rgb fp32 per pixel.
          d.list = b.write(first ? b.create_buffer("neural_btf_list", {.size = 2 * pixels * 4}) : list,
                           BufferUse::StorageWrite);
          d.radiance = b.write(first ? b.create_buffer("neural_btf_radiance", {.size = pixels * 12}) : radiance,
                               BufferUse::StorageWrite);
          b.kind(PassKind::Compute);
        },
        // The list and the decode see the G-buffer's rectangle as their frame.
        [state, width = rect.width, height = rect.height, index = std::uint32_t(m)](const PassResources& res,
                                                                                    const ListData& d, PassContext& ctx) {
          auto group = ctx.device().create_bind_group(
              {.label = "neural-btf-list",
               .layout = &state->list_layout,
               .entries = {gpu::bind(0, res.view(d.gbuffer[0]), &state->nearest),
                           gpu::bind(1, res.view(d.gbuffer[1]), &state->nearest),
                           gpu::bind(2, res.view(d.gbuffer[2]), &state->nearest), gpu::bind(3, res.buffer(d.counts)),
                           gpu::bind(4, res.buffer(d.groups)), gpu::bind(5, res.buffer(d.list)),
                           gpu::bind(6, res.buffer(d.radiance))}});
          if (!group) return ctx.encoder().report_error(group.error());
          const auto& list_group = ctx.keep(std::move(*group));
          auto pass = ctx.encoder().begin_compute_pass("neural_btf_list");
          pass.set_pipeline(state->list_pipeline);
          pass.set_bind_group(0, list_group);
          pass.push(DecodePush{width, height, index, 0});
          pass.dispatch((width + list_tile - 1) / list_tile, (height + list_tile - 1) / list_tile);
          pass.end();
        });
    counts = listed.counts;
    groups = listed.groups;
    list = listed.list;
    radiance = listed.radiance;
    auto& decode = graph.add_pass<DecodeData>(
        "neural_btf_decode" + suffix,
        [&](PassBuilder& b, DecodeData& d) {
          for (int i = 0; i < 4; ++i) d.gbuffer[i] = b.read(g.gbuffer[i], TextureUse::Sampled);
          d.model = b.read(models[m].handle, BufferUse::StorageRead);
          d.counts = b.read(counts, BufferUse::StorageRead);
          d.groups = b.read(groups, BufferUse::Indirect);
          d.list = b.read(list, BufferUse::StorageRead);
          d.radiance = b.write(radiance, BufferUse::StorageWrite);
          b.kind(PassKind::Compute);
        },
        [state, width = rect.width, height = rect.height, index = std::uint32_t(m), tiled = models[m].tiled](const PassResources& res,
                                                                                   const DecodeData& d, PassContext& ctx) {
          auto group = ctx.device().create_bind_group(
              {.label = "neural-btf-decode",
               .layout = &state->decode_layout,
               .entries = {gpu::bind(0, res.buffer(d.model)), gpu::bind(1, res.view(d.gbuffer[0]), &state->nearest),
                           gpu::bind(2, res.view(d.gbuffer[1]), &state->nearest),
                           gpu::bind(3, res.view(d.gbuffer[2]), &state->nearest),
                           gpu::bind(4, res.view(d.gbuffer[3]), &state->nearest), gpu::bind(5, res.buffer(d.counts)),
                           gpu::bind(6, res.buffer(d.list)), gpu::bind(7, res.buffer(d.radiance))}});
          if (!group) return ctx.encoder().report_error(group.error());
          const auto& decode_group = ctx.keep(std::move(*group));
          auto pass = ctx.encoder().begin_compute_pass("neural_btf_decode");
          pass.set_pipeline(tiled ? state->decode_tiled : state->decode_generic);
          pass.set_bind_group(0, decode_group);
          // One dispatch per class; the list pass wrote each one's group count (0 when empty).
          for (std::uint32_t c = 0; c < tap_classes; ++c) {
            pass.push(DecodePush{width, height, index, c});
            pass.dispatch_indirect(res.buffer(d.groups), (std::uint64_t(index) * tap_classes + c) * 16 + 4);
          }
          pass.end();
        });
    radiance = decode.radiance;
  }

  {
    struct CompositeData {
      BufferHandle uniforms;
      TextureHandle shadow_map, light;
      BufferHandle radiance;
      TextureHandle color, depth;
    };
    auto& composite = graph.add_pass<CompositeData>(
        "neural_btf_composite",
        [&](PassBuilder& b, CompositeData& d) {
          d.uniforms = b.read(shared.uniforms, BufferUse::Uniform);
          d.shadow_map = b.read(shared.shadow_map, TextureUse::Sampled);
          d.light = b.read(g.gbuffer[gbuffer_marker], TextureUse::Sampled);
          d.radiance = b.read(radiance, BufferUse::StorageRead);
          d.color = b.write(shared.color, TextureUse::ColorAttachment);
          d.depth = b.write(shared.depth, TextureUse::DepthAttachment);
        },
        [state, draws, materials, marker_of_draw, samples, rect_origin](const PassResources& res,
                                                                        const CompositeData& d, PassContext& ctx) {
          auto pipeline = state->composite_pipeline.at(ctx.device(), samples);
          if (!pipeline) return ctx.encoder().report_error(pipeline.error());
          auto frame_group = ctx.device().create_bind_group(
              {.label = "neural-btf-frame",
               .layout = &state->frame_layout,
               .entries = {gpu::bind(0, res.buffer(d.uniforms)), gpu::bind(1, res.view(d.shadow_map), &state->shadow_compare)}});
          if (!frame_group) return ctx.encoder().report_error(frame_group.error());
          auto decoded = ctx.device().create_bind_group(
              {.label = "neural-btf-composite",
               .layout = &state->resolve_layout,
               .entries = {gpu::bind(0, res.view(d.light), &state->nearest), gpu::bind(1, res.buffer(d.radiance))}});
          if (!decoded) return ctx.encoder().report_error(decoded.error());
          const auto& frame_kept = ctx.keep(std::move(*frame_group));
          const auto& decoded_kept = ctx.keep(std::move(*decoded));
          auto pass = ctx.encoder().begin_render_pass(
              {.label = "neural_btf_composite",
               .color_attachments = {{.view = &res.view(d.color), .load = gpu::LoadOp::Load}},
               .depth_attachment = gpu::DepthAttachment{.view = &res.view(d.depth), .load = gpu::LoadOp::Load}});
          pass.set_pipeline(**pipeline);
          pass.set_bind_group(0, frame_kept);
          pass.set_bind_group(1, decoded_kept);
          for (std::size_t i = 0; i < draws.size(); ++i) {
            const NeuralBtfDraw& draw = draws[i];
            pass.push(draw_constants(draw, materials[draw.material]->params, marker_of_draw[i], rect_origin));
            pass.set_vertex_buffer(0, draw.mesh->vertices);
            pass.set_index_buffer(draw.mesh->indices);
            pass.draw_indexed(draw.mesh->index_count);
          }
          pass.end();
        });
    frame::put_scene_targets(graph.blackboard(), {.color = composite.color, .depth = composite.depth});
    return {};
  }

}


}  // namespace weft::passes
