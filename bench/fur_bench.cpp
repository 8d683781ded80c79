// weft-bench-fur: shell fur from one photo (docs/fur.md), measured.
//
//   weft-bench-fur [--accuracy] [--speed] [--unfurred] [--frames K] [--size WxH] [--photo PATH]
//                  [--scene PATH] [--object NAME]
//
// Accuracy: the photo on a quad seen straight from above under the photo's lighting (light
// from the camera, Lambert, no sky), one pixel per texel, RMSE of the render's luminance
// against the grey photo for N = 1..64, band and strand; from an orthographic camera (does
// the partition lose anything?) and a perspective one (parallax of the lifted texels); and,
// for the trade-off, an oblique view against the same view with 256 layers.
// Speed: frame time of a frame that clears and draws fur (FurFrame), against vertex count
// and N, for the single-photo method and the naive method with N+1 shell textures, with the
// texture memory each needs, side by side. The machine is printed with the tables.
// Unfurred: the fur against the unfurred mesh, whole frames through the renderer (shadow
// map, background, tone map, readback) of one scene (default examples/fur/scenes/fur_spot.json,
// Spot at 960x720), the fur object in its fur material and in a plain standard material,
// alternating frame by frame; then the same frames with every pass submitted and timed alone
// (on lavapipe the GPU timestamps leave out vertex work, so they cannot say where time goes).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <expected>
#include <filesystem>
#include <fstream>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <tuple>
#include <vector>
#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <weft/args.h>
import weft.core;
import weft.feature;
import weft.renderer;
import weft.builtin_features;
import weft.gpu;
import weft.frame;
import weft.graph;
import weft.image;
import weft.scene;
import weft.pass.shell_fur;
import weft.example.fur_frame;
import weft.example.fur_resample;

using namespace weft;
using namespace weft::passes;
using namespace weft::fur;
namespace fs = std::filesystem;

namespace {

fs::path shared_data() {
  if (const char* env = std::getenv("WEFT_SHARED_DATA")) return env;
  return fs::path(WEFT_SOURCE_DIR) / ".." / "shared" / "data";
}

std::string cpu_name() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  return "unknown CPU";
}

frame::MeshData mesh_data(const scene::Mesh& mesh) {
  frame::MeshData out{mesh.name, std::vector<frame::Vertex>(mesh.positions.size()), mesh.indices};
  for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
    out.vertices[i].position = mesh.positions[i];
    out.vertices[i].normal = mesh.normals[i];
    out.vertices[i].tangent = mesh.tangents[i];
    if (mesh.has_uvs()) out.vertices[i].uv = mesh.uvs[i];
  }
  return out;
}

template <class T>
T must(Result<T> r, const char* what) {
  if (!r) {
    std::fprintf(stderr, "%s: %s\n", what, r.error().what().c_str());
    std::exit(1);
  }
  return std::move(*r);
}
void must(Result<void> r, const char* what) {
  if (!r) {
    std::fprintf(stderr, "%s: %s\n", what, r.error().what().c_str());
    std::exit(1);
  }
}

struct Gpu {
  gpu::Instance instance;
  gpu::Adapter adapter;
  gpu::Device device;
};

image::Image luminance_of(const image::Image& rgba) {
  image::Image out = image::Image::filled(rgba.width, rgba.height, 1);
  for (std::size_t i = 0; i < out.pixels.size(); ++i)
    out.pixels[i] = 0.2126f * rgba.pixels[i * 4] + 0.7152f * rgba.pixels[i * 4 + 1] + 0.0722f * rgba.pixels[i * 4 + 2];
  return out;
}

// ---- accuracy ---------------------------------------------------------------------------

void accuracy(Gpu& g, const ShellFurPass& pass, const image::Image8& photo_image, const std::string& photo_name) {
  const FurPhoto photo = must(analyze_fur_photo(photo_image), "analysing the photo");
  const FurPhotoTexture texture = must(upload_fur_photo(g.device, photo, "photo"), "uploading the photo");
  const std::uint32_t w = photo.width, h = photo.height;
  const float aspect = float(w) / float(h);
  // The unit quad stretched to the photo's aspect: one texel per pixel.
  auto quad = must(scene::make_plane(1.0f, 1), "quad");
  const frame::GpuMesh mesh = must(frame::upload_mesh(g.device, mesh_data(quad)), "uploading the quad");
  const mat4 model = glm::scale(mat4(1.0f), vec3(aspect, 1.0f, 1.0f));
  const float thickness = 0.05f;  // h_b: 5% of the quad's height

  image::Image grey = image::Image::filled(w, h, 1);
  for (std::size_t i = 0; i < grey.pixels.size(); ++i) {
    const auto* p = &photo.rgba[i * 4];
    grey.pixels[i] = 0.2126f * image::srgb_to_linear(p[0] / 255.0f) + 0.7152f * image::srgb_to_linear(p[1] / 255.0f) +
                     0.0722f * image::srgb_to_linear(p[2] / 255.0f);
  }

  auto top_settings = [&](bool orthographic) {
    FurFrameSettings s{.width = w, .height = h};
    if (orthographic) {
      s.view = glm::lookAtRH(vec3(0, 2, 0), vec3(0), vec3(0, 0, -1));
      s.projection = glm::orthoRH_ZO(-0.5f * aspect, 0.5f * aspect, -0.5f, 0.5f, 0.1f, 10.0f);
      s.projection[1][1] *= -1.0f;
      s.camera_position = vec3(0, 2, 0);
    } else {
      // 40 degrees vertical field of view, the skin exactly filling the frame.
      const float fov = glm::radians(40.0f), distance = 0.5f / std::tan(0.5f * fov);
      s.view = glm::lookAtRH(vec3(0, distance, 0), vec3(0), vec3(0, 0, -1));
      s.projection = frame::perspective_vk(fov, aspect, 0.05f, 10.0f);
      s.camera_position = vec3(0, distance, 0);
    }
    s.towards_light = s.camera_position;  // the photo's lighting: from the camera
    return s;
  };
  FurFrameSettings oblique{.width = w, .height = h};
  oblique.view = glm::lookAtRH(vec3(0, 0.9f, 1.1f), vec3(0, 0, 0.05f), vec3(0, 1, 0));
  oblique.projection = frame::perspective_vk(glm::radians(40.0f), aspect, 0.05f, 10.0f);
  oblique.camera_position = vec3(0, 0.9f, 1.1f);
  oblique.towards_light = vec3(0.3f, 1.0f, 0.6f);
  oblique.sky_radiance = vec3(0.2f);

  auto render = [&](const FurFrameSettings& settings, std::uint32_t layers, FurLayout layout) {
    const FurLayerTable table = must(
        upload_band_table(g.device, must(make_band_table(photo.i_max, photo.i_min, layers, layout), "band table"), "bands"),
        "uploading the band table");
    const ShellFurDraw draw{.mesh = &mesh, .model = model, .photo = &texture, .layers = &table,
                            .shading = {.thickness = thickness, .lighting = FurLighting::Lambert}};
    FurFrame f = must(FurFrame::create(g.device, settings), "fur frame");
    must(f.set_draws(pass, std::span(&draw, 1)), "building the frame");
    must(f.execute(), "executing the frame");
    return luminance_of(must(f.read_color(), "reading back"));
  };

  const FurFrameSettings ortho = top_settings(true), persp = top_settings(false);
  std::printf("\n### Accuracy: %s (%ux%u), h_b = %.2f of the quad, Lambert under the photo's lighting\n\n", photo_name.c_str(),
              w, h, thickness);
  std::printf("RMSE of the render's linear luminance (0..1). Top: against the grey photo, one pixel per texel. "
              "Oblique: against the same view with 256 layers.\n\n");
  std::printf("| N | band, top ortho | strand, top ortho | band, top persp. 40° | strand, top persp. 40° | band, oblique "
              "vs 256 | strand, oblique vs 256 |\n|---:|---:|---:|---:|---:|---:|---:|\n");
  const image::Image reference_band = render(oblique, 256, FurLayout::Band);
  const image::Image reference_strand = render(oblique, 256, FurLayout::Strand);
  for (std::uint32_t layers : {1u, 2u, 4u, 8u, 15u, 32u, 64u}) {
    double e[6];
    e[0] = must(image::rmse(render(ortho, layers, FurLayout::Band), grey), "rmse");
    e[1] = must(image::rmse(render(ortho, layers, FurLayout::Strand), grey), "rmse");
    e[2] = must(image::rmse(render(persp, layers, FurLayout::Band), grey), "rmse");
    e[3] = must(image::rmse(render(persp, layers, FurLayout::Strand), grey), "rmse");
    e[4] = must(image::rmse(render(oblique, layers, FurLayout::Band), reference_band), "rmse");
    e[5] = must(image::rmse(render(oblique, layers, FurLayout::Strand), reference_strand), "rmse");
    std::printf("| %u | %.4f | %.4f | %.4f | %.4f | %.4f | %.4f |\n", layers, e[0], e[1], e[2], e[3], e[4], e[5]);
  }
  // The photo's luminance quantised to N bands (each texel at its band's top luminance): what
  // a method that drew each layer in one colour would show from above.
  std::printf("\nFor scale: RMSE of the grey photo against itself quantised to N bands (each texel at its band's "
              "top luminance, layer 0 at I_max): ");
  for (std::uint32_t layers : {1u, 2u, 4u, 8u, 15u, 32u, 64u}) {
    const FurBandTable t = must(make_band_table(photo.i_max, photo.i_min, layers, FurLayout::Band), "band table");
    image::Image q = grey;
    for (std::size_t i = 0; i < q.pixels.size(); ++i) {
      const std::uint32_t d = t.depth_layer(photo.code(i));
      q.pixels[i] = float(d == 0 ? t.i_max : t.boundaries[d - 1]);
    }
    std::printf("N=%u %.4f%s", layers, must(image::rmse(q, grey), "rmse"), layers == 64 ? "\n" : ", ");
  }
}

// ---- speed ------------------------------------------------------------------------------

struct Timing {
  double median_ms = 0.0;
  double min_ms = 0.0;
  double record_us = 0.0;  // the fur pass's command recording (median)
};

Timing time_frames(FurFrame& f, int frames) {
  for (int i = 0; i < 2; ++i) must(f.execute(), "warm-up frame");
  std::vector<double> ms, record;
  for (int i = 0; i < frames; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    const FrameStats stats = must(f.execute(), "frame");
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    for (const auto& p : stats.passes)
      if (p.name == "shell_fur") record.push_back(p.cpu_record_us);
  }
  std::sort(ms.begin(), ms.end());
  std::sort(record.begin(), record.end());
  return {ms[ms.size() / 2], ms.front(), record.empty() ? 0.0 : record[record.size() / 2]};
}

struct SpeedRow {
  std::string mesh;
  std::size_t vertices;
  std::uint32_t layers;
  bool fins;
  Timing single, naive;
  std::uint64_t single_bytes, naive_bytes;              // texture memory the method needs
  std::uint64_t single_allocated, naive_allocated;      // device memory allocated for it (measured)
};

void speed(Gpu& g, const ShellFurPass& pass, const image::Image8& photo_image, const std::string& photo_name,
           std::uint32_t width, std::uint32_t height, int frames) {
  const FurPhoto photo = must(analyze_fur_photo(photo_image), "analysing the photo");
  std::uint64_t before = g.device.allocated_bytes();
  const FurPhotoTexture texture = must(upload_fur_photo(g.device, photo, "photo"), "uploading the photo");
  const std::uint64_t photo_allocated = g.device.allocated_bytes() - before;

  // Meshes at the paper's sizes (teapot 2,082, bunny 34,832) and a sphere sweep.
  struct Source {
    std::string name;
    scene::Mesh mesh;
  };
  std::vector<Source> meshes;
  const fs::path teapot = shared_data() / "meshes" / "teapot" / "teapot.obj";
  const fs::path spot_assets = fs::path(WEFT_SOURCE_DIR) / "assets" / "meshes" / "spot" / "spot_triangulated.obj";
  const fs::path spot = fs::exists(spot_assets) ? spot_assets : shared_data() / "meshes" / "spot" / "spot_triangulated.obj";
  auto base_teapot = fs::exists(teapot) ? scene::load_mesh(teapot, {.normalize_to_unit_box = true}) : scene::make_sphere(0.5f, 64);
  auto base_spot = fs::exists(spot) ? scene::load_mesh(spot, {.normalize_to_unit_box = true}) : scene::make_sphere(0.5f, 64);
  meshes.push_back({fs::exists(teapot) ? "teapot" : "sphere", must(examples::resample(must(std::move(base_teapot), "teapot"), 2082), "resampling")});
  meshes.push_back({fs::exists(spot) ? "spot (cow)" : "sphere", must(examples::resample(must(std::move(base_spot), "spot"), 34832), "resampling")});
  for (std::uint32_t segments : {32u, 128u, 256u, 512u}) {
    auto s = must(scene::make_sphere(0.5f, segments), "sphere");
    meshes.push_back({"sphere", std::move(s)});
  }

  FurFrameSettings settings{.width = width, .height = height};
  const vec3 eye{0.9f, 0.6f, 1.6f};
  settings.view = glm::lookAtRH(eye, vec3(0), vec3(0, 1, 0));
  settings.projection = frame::perspective_vk(glm::radians(40.0f), float(width) / float(height), 0.05f, 20.0f);
  settings.camera_position = eye;
  settings.towards_light = vec3(0.4f, 1.0f, 0.5f);
  settings.sky_radiance = vec3(0.2f);

  // The frame without fur (clear only) for reference.
  {
    FurFrame empty = must(FurFrame::create(g.device, settings), "fur frame");
    must(empty.set_draws(pass, {}), "building the frame");
    const Timing t = time_frames(empty, frames);
    std::printf("\n### Speed: %s, %ux%u, Lambert (the paper's shading), strand layout, h_b = 0.04\n\n", photo_name.c_str(), width, height);
    std::printf("A frame is: clear, draw the fur, submit, wait (FurFrame::execute, wall clock; median and minimum of "
                "%d after 2 warm-ups; fps from the minimum, the least disturbed by other work on the machine). The "
                "frame with no fur takes %.2f ms. Record µs: the CPU time of the fur pass's execute callback (bind "
                "groups, draws). Texture memory: what the method samples "
                "(single photo: RGBA8 photo + RG8 orientation + the band table; naive: N+1 RGBA8 layers + the band "
                "table); allocated: the device memory measured for it.\n\n",
                frames, t.median_ms);
  }
  std::printf("| mesh | vertices | N | fins | single photo: ms median / min (fps) | record µs | naive N+1 textures: ms "
              "median / min (fps) | record µs | single photo memory | naive memory |\n"
              "|---|---:|---:|---|---:|---:|---:|---:|---:|---:|\n");
  auto run = [&](const Source& source, std::uint32_t layers, bool fins) {
    const frame::GpuMesh mesh = must(frame::upload_mesh(g.device, mesh_data(source.mesh)), "uploading the mesh");
    std::optional<FurFins> fin_buffer;
    if (fins)
      fin_buffer.emplace(must(upload_fins(g.device,
                                          make_fin_edges(source.mesh.positions, source.mesh.normals, source.mesh.uvs,
                                                         source.mesh.indices),
                                          "fins"),
                              "fins"));
    const FurBandTable bands = must(make_band_table(photo.i_max, photo.i_min, layers, FurLayout::Strand), "band table");
    std::uint64_t b0 = g.device.allocated_bytes();
    const FurLayerTable single = must(upload_band_table(g.device, bands, "single"), "band table");
    const std::uint64_t single_allocated = g.device.allocated_bytes() - b0 + photo_allocated;
    b0 = g.device.allocated_bytes();
    const FurLayerTable naive = must(upload_band_table(g.device, bands, "naive", &photo), "shell textures");
    const std::uint64_t naive_allocated = g.device.allocated_bytes() - b0;
    const ShellFurDraw base{.mesh = &mesh, .photo = &texture, .fins = fin_buffer ? &*fin_buffer : nullptr,
                            .shading = {.thickness = 0.04f, .lighting = FurLighting::Lambert, .uv_scale = vec2(2.0f)}};
    ShellFurDraw a = base, b = base;
    a.layers = &single;
    b.layers = &naive;
    b.method = FurMethod::PerLayerTextures;
    FurFrame fa = must(FurFrame::create(g.device, settings), "fur frame");
    must(fa.set_draws(pass, std::span(&a, 1)), "building the frame");
    FurFrame fb = must(FurFrame::create(g.device, settings), "fur frame");
    must(fb.set_draws(pass, std::span(&b, 1)), "building the frame");
    SpeedRow row{source.name, source.mesh.vertex_count(), layers, fins, time_frames(fa, frames), time_frames(fb, frames),
                 texture.bytes() + single.bytes(), naive.bytes(), single_allocated, naive_allocated};
    auto mib = [](std::uint64_t bytes) { return double(bytes) / (1024.0 * 1024.0); };
    std::printf("| %s | %zu | %u | %s | %.1f / %.1f (%.1f) | %.0f | %.1f / %.1f (%.1f) | %.0f | %.2f MiB (alloc. %.2f) | "
                "%.2f MiB (alloc. %.2f) |\n",
                row.mesh.c_str(), row.vertices, row.layers, row.fins ? "on" : "off", row.single.median_ms,
                row.single.min_ms, 1000.0 / row.single.min_ms, row.single.record_us, row.naive.median_ms,
                row.naive.min_ms, 1000.0 / row.naive.min_ms, row.naive.record_us, mib(row.single_bytes),
                mib(row.single_allocated), mib(row.naive_bytes), mib(row.naive_allocated));
    std::fflush(stdout);
  };
  // The paper's table 1 (15 layers), then N at both sizes, then vertex count at N = 15.
  for (std::size_t m = 0; m < 2; ++m)
    for (std::uint32_t layers : {1u, 8u, 15u, 32u, 64u}) run(meshes[m], layers, false);
  for (std::size_t m = 0; m < 2; ++m) run(meshes[m], 15, true);
  for (std::size_t m = 2; m < meshes.size(); ++m) run(meshes[m], 15, false);
}

// ---- against the unfurred mesh ----------------------------------------------------------

std::string load_average() {
  std::ifstream in("/proc/loadavg");
  std::string one, five, fifteen;
  in >> one >> five >> fifteen;
  return one + " " + five + " " + fifteen;
}

double median_of(std::vector<double> v) {
  if (v.empty()) return -1.0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

void unfurred(Gpu& g, const fs::path& scene_path, const std::string& object_name, std::uint32_t width,
              std::uint32_t height, int frames) {
  const scene::Scene furred = must(scene::load_scene(scene_path), "loading the scene");
  std::size_t object = furred.objects.size();
  for (std::size_t i = 0; i < furred.objects.size(); ++i) {
    const auto& o = furred.objects[i];
    if (object_name.empty() ? furred.materials.at(o.material).type == "shell_fur" : o.name == object_name) {
      object = i;
      break;
    }
  }
  if (object == furred.objects.size()) {
    std::fprintf(stderr, "weft-bench-fur: %s has no %s\n", scene_path.string().c_str(),
                 object_name.empty() ? "object in a fur material" : ("object '" + object_name + "'").c_str());
    std::exit(2);
  }
  // The same scene with the object in a plain standard material of the fur's tint.
  scene::Scene plain = furred;
  scene::Material material;
  material.name = "plain (bench)";
  const auto& params = furred.materials.at(furred.objects[object].material).params;
  if (params.contains("tint") && params["tint"].is_array() && params["tint"].size() == 3)
    material.standard.base_color = vec3(params["tint"][0].get<float>(), params["tint"][1].get<float>(), params["tint"][2].get<float>());
  material.standard.roughness = 0.8f;
  plain.materials.push_back(material);
  plain.objects[object].material = std::uint32_t(plain.materials.size() - 1);

  renderer::Renderer fur_renderer = must(renderer::Renderer::create(g.device), "renderer");
  renderer::Renderer plain_renderer = must(renderer::Renderer::create(g.device), "renderer");
  renderer::RenderOptions options{.width = width, .height = height};
  struct Run {
    std::vector<double> ms;
    std::vector<FrameStats> stats;
  };
  auto frame = [&](renderer::Renderer& r, const scene::Scene& s, Run& run, bool serial) {
    options.serial_passes = serial;
    const auto t0 = std::chrono::steady_clock::now();
    auto f = must(r.render(s, options), "rendering");
    run.ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    run.stats.push_back(std::move(f.stats));
  };
  const std::string load_before = load_average();
  // Warm-up: the first frames compile shaders and upload everything.
  Run warm;
  for (int i = 0; i < 2; ++i) {
    frame(fur_renderer, furred, warm, false);
    frame(plain_renderer, plain, warm, false);
  }
  Run fur, flat, fur_serial, flat_serial;
  for (int i = 0; i < frames; ++i) {
    frame(fur_renderer, furred, fur, false);
    frame(plain_renderer, plain, flat, false);
  }
  for (int i = 0; i < frames; ++i) {
    frame(fur_renderer, furred, fur_serial, true);
    frame(plain_renderer, plain, flat_serial, true);
  }
  const std::string load_after = load_average();
  std::vector<double> ratios;
  for (int i = 0; i < frames; ++i) ratios.push_back(fur.ms[i] / flat.ms[i]);

  std::printf("\n### Fur against the unfurred mesh: %s, object '%s', %ux%u, medium quality\n\n",
              scene_path.filename().string().c_str(), furred.objects[object].name.c_str(), width ? width : furred.output.width,
              height ? height : furred.output.height);
  std::printf("Whole frames through the renderer (Renderer::render: prepare, graph, execute with the shadow map, "
              "background and tone map, readback), the object in its fur material and in a plain standard material "
              "(the fur's tint, roughness 0.8), alternating, %d of each after 2 warm-ups. Load average %s before, %s "
              "after.\n\n",
              frames, load_before.c_str(), load_after.c_str());
  auto sorted = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v;
  };
  const auto a = sorted(fur.ms), b = sorted(flat.ms);
  std::printf("| frame | median ms | min ms | max ms |\n|:--|--:|--:|--:|\n");
  std::printf("| unfurred (plain material) | %.1f | %.1f | %.1f |\n", median_of(b), b.front(), b.back());
  std::printf("| fur | %.1f | %.1f | %.1f |\n", median_of(a), a.front(), a.back());
  std::printf("| **fur / unfurred** | **%.2f×** (median of per-pair ratios %.2f×) | %.2f× | |\n\n", median_of(a) / median_of(b),
              median_of(ratios), a.front() / b.front());

  // Where the time goes: each pass alone (serial), and its GPU timestamps.
  std::printf("Per pass, medians: GPU timestamps from the normal frames; wall = the pass submitted and waited for "
              "alone (serial frames: %.1f ms fur, %.1f ms unfurred).\n\n",
              median_of(fur_serial.ms), median_of(flat_serial.ms));
  std::printf("| pass | fur: GPU ms | fur: wall ms alone | unfurred: GPU ms | unfurred: wall ms alone |\n|:--|--:|--:|--:|--:|\n");
  std::vector<std::string> names;
  for (const auto* run : {&fur.stats, &flat.stats})
    for (const auto& p : run->front().passes)
      if (std::find(names.begin(), names.end(), p.name) == names.end()) names.push_back(p.name);
  auto pass_median = [](const std::vector<FrameStats>& stats, const std::string& name, bool wall) {
    std::vector<double> v;
    for (const auto& f : stats)
      for (const auto& p : f.passes)
        if (p.name == name) v.push_back(wall ? p.wall_ms : p.gpu_ms);
    return median_of(v);
  };
  auto cell = [](double v) { return v < 0 ? std::string("—") : weft::format("{:.1f}", v); };
  for (const auto& name : names)
    std::printf("| %s | %s | %s | %s | %s |\n", name.c_str(), cell(pass_median(fur.stats, name, false)).c_str(),
                cell(pass_median(fur_serial.stats, name, true)).c_str(), cell(pass_median(flat.stats, name, false)).c_str(),
                cell(pass_median(flat_serial.stats, name, true)).c_str());
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  bool do_accuracy = false, do_speed = false, do_unfurred = false, size_given = false;
  int frames = 10;
  std::uint32_t width = 640, height = 480;
  fs::path photo_path, scene_path = fs::path(WEFT_SOURCE_DIR) / "examples" / "fur" / "scenes" / "fur_spot.json";
  std::string object_name;
  const char* usage =
      "usage: weft-bench-fur [--accuracy] [--speed] [--unfurred] [--frames K] [--size WxH] [--photo PATH]\n"
      "                      [--scene PATH] [--object NAME]\n"
      "  --accuracy  RMSE against the photo for N = 1..64 layers, band and strand\n"
      "  --speed     frame time against vertices and N, single photo against N+1 textures (640x480)\n"
      "  --unfurred  whole frames of --scene (default examples/fur/scenes/fur_spot.json) with the fur object\n"
      "              (--object, default the first in a fur material) in its fur and in a plain material,\n"
      "              alternating, and each pass timed alone (size: the scene's unless --size)\n"
      "  no section named: all three\n";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if ((a == "--photo" || a == "--scene" || a == "--object") && i + 1 < argc && argv[i + 1][0] == '\0') {
      std::fprintf(stderr, "weft-bench-fur: %s was given an empty value\n", a.c_str());
      return 2;
    }
    if (a == "--accuracy") {
      do_accuracy = true;
    } else if (a == "--speed") {
      do_speed = true;
    } else if (a == "--unfurred") {
      do_unfurred = true;
    } else if (a == "--scene" && i + 1 < argc) {
      scene_path = argv[++i];
    } else if (a == "--object" && i + 1 < argc) {
      object_name = argv[++i];
    } else if (a == "--help" || a == "-h") {
      std::printf("%s", usage);
      return 0;
    } else if (a == "--frames" && i + 1 < argc) {
      // Digits only (issue 33: atoi read "abc" as 0 and ran with 1 frame).
      const auto n = weft::args::whole(argv[++i], 1, 100000);
      if (!n) {
        std::fprintf(stderr, "weft-bench-fur: --frames expects a whole number 1..100000, got '%s'\n", argv[i]);
        return 2;
      }
      frames = int(*n);
    } else if (a == "--size" && i + 1 < argc) {
      const auto size = weft::args::size(argv[++i], 8192);
      if (!size) {
        std::fprintf(stderr, "weft-bench-fur: --size expects WxH with sides 1..8192, got '%s'\n", argv[i]);
        return 2;
      }
      std::tie(width, height) = *size;
      size_given = true;
    } else if (a == "--photo" && i + 1 < argc) {
      photo_path = argv[++i];
    } else if (i + 1 == argc && (a == "--frames" || a == "--size" || a == "--photo" || a == "--scene" || a == "--object")) {
      std::fprintf(stderr, "weft-bench-fur: %s needs a value\n%s", a.c_str(), usage);
      return 2;
    } else {
      std::fprintf(stderr, "weft-bench-fur: unknown argument '%s'\n%s", a.c_str(), usage);
      return 2;
    }
  }
  if (!do_accuracy && !do_speed && !do_unfurred) do_accuracy = do_speed = do_unfurred = true;
  if (photo_path.empty() && fs::exists(shared_data() / "fur" / "cream_long.jpg")) photo_path = shared_data() / "fur" / "cream_long.jpg";
  image::Image8 photo = photo_path.empty() ? synthesize_fur_photo({.width = 512, .height = 512})
                                           : must(image::load_ldr(photo_path), "loading the photo");
  const std::string photo_name = photo_path.empty() ? "synthetic 512x512 fur photo" : photo_path.filename().string();

  auto instance = must(gpu::Instance::create({.application_name = "weft-bench-fur"}), "Vulkan instance");
  auto adapter = must(instance.request_adapter(), "adapter");
  auto device = must(adapter.request_device(), "device");
  Gpu g{std::move(instance), std::move(adapter), std::move(device)};
  std::printf("## weft-bench-fur\n\nMachine: %s, %u hardware threads; adapter %s (%s %s, %s)\n",
              cpu_name().c_str(), std::thread::hardware_concurrency(), g.adapter.info().name.c_str(),
              g.adapter.info().driver.c_str(), g.adapter.info().driver_info.c_str(),
              std::string(gpu::to_string(g.adapter.info().type)).c_str());
  // This program links the fur feature and registers it, as any application does.
  must(weft::register_builtin_pass_types(), "registering the frame's pass types");
  must(register_feature(shell_fur_feature()), "registering the fur feature");
  const ShellFurPass pass = must(ShellFurPass::create(g.device), "creating the pass");
  if (do_accuracy) accuracy(g, pass, photo, photo_name);
  if (do_speed) speed(g, pass, photo, photo_name, width, height, frames);
  if (do_unfurred) unfurred(g, scene_path, object_name, size_given ? width : 0, size_given ? height : 0, frames);
  return 0;
}
