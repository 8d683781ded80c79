// The shell_fur feature: its descriptor (registration), and what the renderer creates for
// scenes with "shell_fur" (or "fur") materials. It parses each
// material, loads and analyses its photo, builds band tables, generated UVs and fins, caching
// each by content so a second frame uploads nothing, and adds one ShellFurPass.
module;
#include <algorithm>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>
#include <glm/glm.hpp>
#include <nlohmann/json.hpp>
#include <weft/try.h>
module weft.pass.shell_fur;

namespace weft::passes {

using namespace fur;

namespace {

class ShellFurFeature final : public FeaturePass {
 public:
  // The factory the descriptor names: the graph pass first, then the feature around it.
  static Result<std::unique_ptr<FeaturePass>> create(gpu::Device& device) {
    WEFT_TRY(auto pass, ShellFurPass::create(device));
    return std::unique_ptr<FeaturePass>(std::make_unique<ShellFurFeature>(device, std::move(pass)));
  }

  explicit ShellFurFeature(gpu::Device& device, ShellFurPass pass) : device_(&device), pass_(std::move(pass)) {}

  [[nodiscard]] std::string_view name() const override { return "shell_fur"; }

  Result<void> prepare(const FeatureFrame& frame) override {
    draws_.clear();
    warnings_.clear();
    for (const std::uint32_t index : frame.objects) {
      const scene::Object& object = frame.scene.objects.at(index);
      const scene::Material& material = frame.scene.materials.at(object.material);
      auto ok = add_object(frame, object, material);
      if (!ok) return with_context(weft::format("fur object '{}'", object.name), ok.error());
    }
    std::sort(warnings_.begin(), warnings_.end());
    warnings_.erase(std::unique(warnings_.begin(), warnings_.end()), warnings_.end());
    return {};
  }

  Result<void> add_passes(RenderGraph& graph, const FeatureFrame&) override { return pass_.add(graph, draws_); }

  [[nodiscard]] std::vector<std::string> warnings() const override { return warnings_; }

 private:
  struct PhotoAsset {
    FurPhoto photo;
    FurPhotoTexture texture;
  };
  struct MeshAsset {
    std::unique_ptr<frame::GpuMesh> generated;  // the mesh with generated UVs, when it had none
    std::unique_ptr<FurFins> fins;
    bool fins_built = false;
  };

  Result<const PhotoAsset*> photo_for(const FurMaterial& m, const std::string& material_name) {
    std::error_code ec;
    const auto size = std::filesystem::file_size(m.photo, ec);
    const auto time = std::filesystem::last_write_time(m.photo, ec).time_since_epoch().count();
    const std::uint64_t key = Hasher{}
                                  .str(m.photo.string())
                                  .value(size)
                                  .value(time)
                                  .value(m.thresholds.low_percentile)
                                  .value(m.thresholds.high_percentile)
                                  .digest();
    if (auto it = photos_.find(key); it != photos_.end()) return it->second.get();
    auto image = image::load_ldr(m.photo);
    if (!image) return with_context(weft::format("material '{}': photo", material_name), image.error());
    auto photo = analyze_fur_photo(*image, m.thresholds);
    if (!photo) return with_context(weft::format("material '{}'", material_name), photo.error());
    WEFT_TRY(auto texture, upload_fur_photo(*device_, *photo, m.photo.filename().string()));
    auto asset = std::make_unique<PhotoAsset>(PhotoAsset{std::move(*photo), std::move(texture)});
    return photos_.emplace(key, std::move(asset)).first->second.get();
  }

  Result<const FurLayerTable*> table_for(const PhotoAsset& photo, const FurMaterial& m) {
    const std::uint64_t key =
        Hasher{}.value(&photo).value(photo.photo.i_max).value(photo.photo.i_min).value(m.layers).value(m.layout).digest();
    if (auto it = tables_.find(key); it != tables_.end()) return it->second.get();
    WEFT_TRY(auto table, make_band_table(photo.photo.i_max, photo.photo.i_min, m.layers, m.layout));
    WEFT_TRY(auto uploaded, upload_band_table(*device_, std::move(table), photo.texture.photo.label()));
    return tables_.emplace(key, std::make_unique<FurLayerTable>(std::move(uploaded))).first->second.get();
  }

  Result<void> add_object(const FeatureFrame& frame, const scene::Object& object, const scene::Material& material) {
    WEFT_TRY(auto m, parse_fur_material(material, frame.quality));
    WEFT_TRY(auto photo, photo_for(m, material.name));
    for (const auto& note : photo->photo.notes)
      warnings_.push_back(weft::format("fur material '{}': {}", material.name, note));
    if (photo->photo.bimodality > 0.85)
      warnings_.push_back(weft::format(
          "fur material '{}': the photo's luminance has two separate populations (separability {:.2f}); "
          "two-coloured fur is the method's weak case: dark patches will sit deep in the fur (docs/fur.md)",
          material.name, photo->photo.bimodality));
    WEFT_TRY(auto table, table_for(*photo, m));

    const scene::Mesh& mesh = frame.scene.meshes.at(object.mesh);
    const frame::GpuMesh* gpu_mesh = frame.meshes[object.mesh];
    MeshAsset& asset = meshes_[Hasher{}.value(mesh_content_hash(mesh)).value(m.uv_mapping).digest()];
    const bool generate = !mesh.has_uvs() || m.uv_mapping == FurUvMapping::Planar ||
                          m.uv_mapping == FurUvMapping::Spherical;
    scene::Mesh uv_mesh;
    if (generate) {
      if (!asset.generated) {
        uv_mesh = mesh;
        if (auto ok = generate_fur_uvs(uv_mesh, m.uv_mapping); !ok)
          return with_context(weft::format("material '{}'", material.name), ok.error());
        WEFT_TRY(auto uploaded, frame::upload_mesh(*device_, to_mesh_data(uv_mesh)));
        asset.generated = std::make_unique<frame::GpuMesh>(std::move(uploaded));
      }
      gpu_mesh = asset.generated.get();
      if (!mesh.has_uvs())
        warnings_.push_back(weft::format("fur material '{}': mesh '{}' has no UVs; the photo is mapped with generated "
                                         "{} UVs (set \"uv_mapping\" to choose)",
                                         material.name, mesh.name,
                                         m.uv_mapping == FurUvMapping::Auto ? "planar or spherical"
                                                                             : to_string(m.uv_mapping)));
    }
    if (m.fins && !asset.fins_built) {
      const scene::Mesh& source = generate && !uv_mesh.positions.empty() ? uv_mesh : mesh;
      const auto edges = make_fin_edges(source.positions, source.normals, source.uvs, source.indices);
      if (!edges.empty()) {
        WEFT_TRY(auto fins, upload_fins(*device_, edges, mesh.name));
        asset.fins = std::make_unique<FurFins>(std::move(fins));
      }
      asset.fins_built = true;
    }
    const float diagonal = glm::length(mesh.bounds.empty() ? scene::compute_bounds(mesh.positions).size() : mesh.bounds.size());
    ShellFurDraw draw{.mesh = gpu_mesh, .model = object.transform, .photo = &photo->texture, .layers = table,
                      .fins = m.fins ? asset.fins.get() : nullptr, .per_sample_hair = m.per_sample_hair};
    draw.shading = {.thickness = m.thickness_for(diagonal), .tint = m.tint, .lighting = m.lighting,
                    .uv_scale = m.uv_scale, .wrap = m.wrap, .comb = m.comb, .lift_degrees = m.lift_degrees,
                    .specular = m.specular, .shininess = m.shininess, .fin_threshold = m.fin_threshold};
    draws_.push_back(draw);
    return {};
  }

  gpu::Device* device_;
  ShellFurPass pass_;
  std::map<std::uint64_t, std::unique_ptr<PhotoAsset>> photos_;
  std::map<std::uint64_t, std::unique_ptr<FurLayerTable>> tables_;
  std::map<std::uint64_t, MeshAsset> meshes_;
  std::vector<ShellFurDraw> draws_;
  std::vector<std::string> warnings_;
};

}  // namespace

// Quality picks `layers` (8 / 15 / 32 / 64); docs/fur.md and docs/tradeoffs.md say more.
const FeatureDescriptor& shell_fur_feature() {
  static const FeatureDescriptor feature{
      .name = "shell_fur", .aliases = {"fur"}, .doc = "docs/fur.md",
      .summary = "fur grown as shells and fins from one photograph of fur",
      .check_material = check_by_parsing<&fur::parse_fur_material>, .create = &ShellFurFeature::create,
      .passes = {"shell_fur"},
      .knobs = {
          integer_knob("layers", 1, max_fur_layers, {1, 2, 4, 8, 15, 32, 64, 128},
                       "shells N: the height field's depth resolution"),
          boolean_knob("fins", "silhouette fins (Lengyel): one quad per edge near the silhouette"),
          number_knob("fin_threshold", 0, 1, {0.1, 0.35, 0.7}, "|N.V| below which an edge grows a fin"),
          choice_knob("msaa_hair", {"coverage", "per_sample"},
                      "under MSAA: alpha to coverage, or each sample tests its own texel (the hair supersampled, "
                      "shaded per sample; where the adapter can)"),
      },
      .preset_values = [](Quality q) -> nlohmann::json {
        return {{"layers", fur_layers_for(q)}, {"msaa_hair", q >= Quality::High ? "per_sample" : "coverage"}};
      },
      // As N grows the strand shells converge to the continuous height field the photo
      // describes (the gap between shells, h_b / N, falls below a pixel); fins patch the gaps
      // of few shells at grazing angles, so the limit has none.
      .reference = {{"layers", max_fur_layers}, {"fins", false}},
      .reference_why = "256 shells (the most the material takes), no fins: the limit the shells converge to",
      .cost = CostAxis::Frame,
      .grids = {{"layers", "fins"}},
  };
  return feature;
}

}  // namespace weft::passes
