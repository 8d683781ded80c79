// The neural BTF FeaturePass: the materials' parameters, their models (loaded once per file
// and uploaded once), and the frame's draw list.
module;
#include <chrono>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>
#include <glm/glm.hpp>
#include <nlohmann/json.hpp>
#include <weft/try.h>
module weft.pass.neural_btf;

namespace weft::passes {
namespace {

class NeuralBtfFeature final : public FeaturePass {
 public:
  // The factory the descriptor names: the graph pass first, then the feature around it.
  static Result<std::unique_ptr<FeaturePass>> create(gpu::Device& device) {
    WEFT_TRY(auto pass, NeuralBTFMaterial::create(device));
    return std::make_unique<NeuralBtfFeature>(device, std::move(pass));
  }

  NeuralBtfFeature(gpu::Device& device, NeuralBTFMaterial pass) : device_(&device), pass_(std::move(pass)) {}

  [[nodiscard]] std::string_view name() const override { return "neural_btf"; }

  Result<void> prepare(const FeatureFrame& frame) override {
    warnings_.clear();
    draws_.clear();
    frame_materials_.clear();
    WEFT_TRY_VOID(resolve_materials(
        frame, frame_materials_,
        [&](const scene::Material& material) { return material_for(material, frame.quality); },
        [&](std::uint32_t object_index, std::uint32_t slot) {
          const scene::Object& object = frame.scene.objects.at(object_index);
          const scene::Mesh& mesh = frame.scene.meshes.at(object.mesh);
          if (!mesh.has_uvs())
            warnings_.push_back(weft::format("neural_btf object '{}': mesh '{}' has no UVs, so it shows one texel",
                                             object.name, mesh.name));
          draws_.push_back({frame.meshes[object.mesh], object.transform, slot});
        }));
    if (frame.uniforms.light_color == vec4(0.0f))
      warnings_.push_back("neural_btf materials without a directional (key) light show only their ambient term");
    return {};
  }

  Result<void> add_passes(RenderGraph& graph, const FeatureFrame& frame) override {
    return pass_.add(graph, draws_, frame_materials_, frame.width, frame.height, frame.uniforms.view_projection);
  }

  [[nodiscard]] std::vector<std::string> warnings() const override { return warnings_; }

 private:
  Result<std::shared_ptr<NeuralBtfGpuMaterial>> material_for(const scene::Material& material, Quality quality) {
    WEFT_TRY(auto parsed, btf::parse_neural_btf_material(material, quality));
    if (parsed.mode == btf::BtfMode::Reference) {
      auto reference = reference_for(parsed);
      if (!reference)
        return with_context(weft::format("neural_btf material '{}' ({}.btf)", material.name, material.json_path),
                            reference.error());
      Hasher h;
      h.str(material.name).str(material.params.dump()).str(material.base_dir.string()).str(material.json_path);
      h.value(std::uint8_t(quality)).value(*reference);
      const std::uint64_t key = h.digest();
      if (auto it = materials_.find(key); it != materials_.end()) return it->second;
      WEFT_TRY(auto gpu_material, pass_.create_material(*device_, parsed, **reference));
      materials_.emplace(key, gpu_material);
      return gpu_material;
    }
    auto model = model_for(parsed.model);
    if (!model) return with_context(weft::format("neural_btf material '{}' ({}.model)", material.name, material.json_path),
                                    model.error());
    Hasher h;
    h.str(material.name).str(material.params.dump()).str(material.base_dir.string()).str(material.json_path);
    h.value(std::uint8_t(quality)).value(*model);
    const std::uint64_t key = h.digest();
    if (auto it = materials_.find(key); it != materials_.end()) return it->second;
    WEFT_TRY(auto gpu_material, pass_.create_material(*device_, parsed, **model));
    materials_.emplace(key, gpu_material);
    return gpu_material;
  }

  // The model of a .wbtf file on the GPU, loaded again only when the file changes.
  Result<const GpuBtfModel*> model_for(const std::filesystem::path& path) {
    std::error_code ec;
    const auto stamp = std::filesystem::last_write_time(path, ec);
    const auto size = std::filesystem::file_size(path, ec);
    Hasher h;
    h.str(path.string()).value(stamp.time_since_epoch().count()).value(ec ? 0 : size);
    const std::uint64_t key = h.digest();
    if (auto it = models_.find(key); it != models_.end()) return it->second.get();
    WEFT_TRY(auto model, btf::load_wbtf(path));
    log::info(weft::format("neural BTF '{}': {} x {} texels, {} latents{}, decoder {} parameters", path.filename().string(),
                           model.width, model.height, model.latent_count(), model.clustered() ? " (clustered)" : "",
                           model.decoder.parameter_count()));
    auto buffer = upload_model(*device_, model, "neural_btf_" + path.filename().string());
    if (!buffer) return with_context(path.string(), buffer.error());
    return models_.emplace(key, std::make_unique<GpuBtfModel>(std::move(*buffer))).first->second.get();
  }

  // The raw BTF of a reference-mode material on the GPU: a .btfraw / database folder (again
  // when the file changes) or the synthetic fabric the material names (made once).
  Result<const GpuBtfReference*> reference_for(const btf::NeuralBtfParams& params) {
    Hasher h;
    if (params.btf_synthetic) {
      const auto& s = *params.btf_synthetic;
      h.str("synthetic").str(s.weave).value(s.width).value(s.height).value(s.seed);
    } else {
      std::error_code ec;
      const auto stamp = std::filesystem::last_write_time(params.btf, ec);
      h.str(params.btf.string()).value(stamp.time_since_epoch().count());
    }
    const std::uint64_t key = h.digest();
    if (auto it = references_.find(key); it != references_.end()) return it->second.get();
    std::string source;
    Result<btf::Btf> data = std::unexpected(Error{ErrorKind::InvalidArgument, "no BTF"});
    if (params.btf_synthetic) {
      const auto& s = *params.btf_synthetic;
      btf::SyntheticOptions so;
      WEFT_TRY(so.weave, btf::parse_weave(s.weave));
      so.width = s.width, so.height = s.height, so.seed = s.seed;
      source = weft::format("synthetic {} {}x{} seed {}", s.weave, s.width, s.height, s.seed);
      log::info(weft::format("neural BTF reference: making the {}", source));
      data = btf::synthetic_btf(so);
    } else {
      source = params.btf.string();
      log::info(weft::format("neural BTF reference: loading {}", source));
      data = btf::load_btf(params.btf);
    }
    if (!data) return std::unexpected(data.error());
    auto uploaded = upload_reference(*device_, *data, "neural_btf_raw");
    if (!uploaded) return with_context(source, uploaded.error());
    if (uploaded->cropped)
      warnings_.push_back(weft::format("neural_btf reference {}: {} x {} texels do not fit one storage buffer; the "
                                       "reference tiles its top-left {} x {}",
                                       source, data->width, data->height, uploaded->crop.width, uploaded->crop.height));
    return references_.emplace(key, std::make_unique<GpuBtfReference>(std::move(*uploaded))).first->second.get();
  }

  gpu::Device* device_;
  NeuralBTFMaterial pass_;
  std::map<std::uint64_t, std::unique_ptr<GpuBtfReference>> references_;
  std::map<std::uint64_t, std::unique_ptr<GpuBtfModel>> models_;  // by path, time and size
  std::map<std::uint64_t, std::shared_ptr<NeuralBtfGpuMaterial>> materials_;
  // This frame's inputs, alive until the graph has executed.
  std::vector<NeuralBtfDraw> draws_;
  std::vector<std::shared_ptr<NeuralBtfGpuMaterial>> frame_materials_;
  std::vector<std::string> warnings_;
};

}  // namespace

// The model's own knobs (clusters, latent size, fp16) are bake-time (weft bake btf) and
// measured against the raw BTF by weft-bench-btf-train; here the shading knobs: decodes per
// pixel. Quality: low = nearest, no ambient; medium = nearest + ambient; high and reference =
// bilinear + ambient (docs/neural-btf.md).
const FeatureDescriptor& neural_btf_feature() {
  static const FeatureDescriptor feature{
      .name = "neural_btf", .aliases = {"btf"}, .doc = "docs/neural-btf.md",
      .summary = "measured fabrics: a neural BTF decoded per visible pixel as batched matrix products",
      .check_material = check_by_parsing<&btf::parse_neural_btf_material>, .create = &NeuralBtfFeature::create,
      // The default (batched) path's passes; a "decoder": "fragment" material draws in
      // neural_btf_fragment instead, which the trade-off study's pass times then leave out.
      .passes = {"neural_btf", "neural_btf_list_clear", "neural_btf_list", "neural_btf_decode", "neural_btf_composite"},
      .knobs = {
          choice_knob("filter", {"nearest", "bilinear"}, "texels decoded per light: 1, or 4 blended"),
          boolean_knob("ambient", "one more decode (ω_i = n) times the environment's SH irradiance"),
          boolean_knob("shadow", "the key light's shadow map (3x3 PCF)"),
      },
      .preset_values = [](Quality q) -> nlohmann::json {
        const auto p = btf::neural_btf_quality_preset(q);
        return {{"filter", std::string(btf::to_string(p.filter))}, {"ambient", p.ambient}};
      },
      // The raw BTF the model compresses (the material's "btf"), sampled by the same fragment
      // stage with every tap the material can make: the error is the model's and the knobs'.
      .reference = {{"mode", "reference"}, {"filter", "bilinear"}, {"ambient", true}, {"shadow", true}},
      .reference_why = "the raw BTF (the material's \"btf\") sampled as sample_reference samples it, bilinear texels, "
                        "ambient and shadow: the same pass with the data in place of the decoder",
      .cost = CostAxis::Frame,
      .grids = {{"filter", "ambient"}},
      .bakes = {{.name = "btf", .summary = "Train a neural BTF (encoder + decoder, optionally clustered): a .wbtf file", .add = &detail::add_btf_bake}},
  };
  return feature;
}

}  // namespace weft::passes
