// Frames declared and compiled with no adapter: gpu::Device::create_declaring and
// renderer::describe. ctest runs this suite with no Vulkan driver to be found
// (VK_ICD_FILENAMES / VK_DRIVER_FILES point at nothing), so anything here that needed one
// would fail; the first case checks that the driver really is out of reach.
#include <doctest/doctest.h>
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <vector>
#include <unistd.h>
import weft.core;
import weft.gpu;
import weft.graph;
import weft.image;
import weft.scene;
import weft.renderer;
import weft.graph_testing;

using namespace weft;

namespace {
bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

std::filesystem::path source_dir() {
  const char* dir = std::getenv("WEFT_SOURCE_DIR");
  REQUIRE_MESSAGE(dir, "WEFT_SOURCE_DIR is not set (ctest sets it)");
  return dir;
}

scene::Scene load_file(const std::filesystem::path& path) {
  auto s = scene::load_scene(path);
  REQUIRE_MESSAGE(s, (s ? "" : s.error().what()));
  return std::move(*s);
}

scene::Scene load_text(const std::string& json) {
  auto desc = scene::parse_scene(json, std::filesystem::temp_directory_path());
  REQUIRE_MESSAGE(desc, (desc ? "" : desc.error().message));
  auto s = scene::load_scene(*desc);
  REQUIRE_MESSAGE(s, (s ? "" : s.error().message));
  return std::move(*s);
}

std::filesystem::path temp_dir(const std::string& name) {
  auto dir = std::filesystem::temp_directory_path() / ("weft-describe-" + name + "-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

bool has(const std::vector<std::string>& list, const std::string& item) {
  return std::find(list.begin(), list.end(), item) != list.end();
}

const char* skin_scene = R"({
  "version": 1,
  "output": {"width": 64, "height": 48},
  "camera": {"position": [0, 0, 4], "target": [0, 0, 0], "fov": 40},
  "lights": [{"type": "directional", "direction": [0, -1, -1], "intensity": 2}],
  "meshes": {"ball": {"primitive": "sphere", "radius": 1.0}},
  "materials": {"skin": {"type": "skin_sss", "lut": {"size": 2048, "samples": 1000}}},
  "objects": [{"name": "head", "mesh": "ball", "material": "skin"}]
})";
}  // namespace

TEST_CASE("this suite runs with no Vulkan driver to be found (so nothing below can have used one)") {
  auto instance = gpu::Instance::create();
  if (!instance) return;  // no loader or no driver at all: what the suite wants
  auto adapter = instance->request_adapter();
  CHECK_MESSAGE(!adapter, "an adapter was found: the suite's environment does not hide the drivers");
}

TEST_CASE("a declaring device keeps descriptors, checks them as always, drops writes and refuses to record or read") {
  gpu::Device device = gpu::Device::create_declaring("decl");
  CHECK(device.declaring());
  CHECK(contains(device.adapter_info().name, "decl"));
  CHECK(device.adapter_info().limits.max_texture_dimension_2d >= 4096);

  auto buffer = device.create_buffer({.label = "b", .size = 256, .usage = gpu::BufferUsage::Storage | gpu::BufferUsage::CopyDst});
  REQUIRE(buffer);
  CHECK(buffer->size() == 256);
  CHECK(buffer->label() == "b");
  const std::vector<std::byte> bytes(256, std::byte{7});
  CHECK(device.queue().write_buffer(*buffer, 0, bytes));  // dropped
  // A write past the end is still the caller's mistake.
  CHECK(!device.queue().write_buffer(*buffer, 128, bytes));
  auto with_data = device.create_buffer_with_data({.label = "d", .usage = gpu::BufferUsage::Storage}, bytes);
  REQUIRE(with_data);
  CHECK(with_data->size() == 256);

  auto texture = device.create_texture({.label = "t", .size = {32, 16, 1}, .format = gpu::Format::RGBA16Float,
                                        .usage = gpu::TextureUsage::Sampled | gpu::TextureUsage::CopyDst});
  REQUIRE(texture);
  CHECK(texture->size().width == 32);
  CHECK(&texture->view().texture() == &*texture);
  CHECK(device.queue().write_texture(*texture, std::vector<std::byte>(32 * 16 * 8)));
  CHECK(!device.queue().write_texture(*texture, std::vector<std::byte>(3)));  // wrong size: still an error

  // Descriptors are checked as on an adapter.
  auto empty = device.create_buffer({.label = "empty", .size = 0, .usage = gpu::BufferUsage::Storage});
  REQUIRE(!empty);
  CHECK(contains(empty.error().message, "'empty'"));
  auto huge = device.create_texture({.label = "huge", .size = {1u << 20, 4, 1}, .usage = gpu::TextureUsage::Sampled});
  CHECK(!huge);
  auto bad_shader = device.create_shader_module({.label = "bad.comp", .stage = gpu::ShaderStage::Compute,
                                                 .glsl = "#version 460\nvoid main() { nope(); }\n"});
  REQUIRE(!bad_shader);
  CHECK(bad_shader.error().kind == ErrorKind::Shader);

  // Pipelines are made (nothing to run them on) and their descriptors checked.
  auto shader = device.create_shader_module({.label = "ok.comp", .stage = gpu::ShaderStage::Compute,
                                             .glsl = "#version 460\nlayout(local_size_x = 1) in;\nvoid main() {}\n"});
  REQUIRE(shader);
  auto layout = device.create_pipeline_layout({.label = "layout"});
  REQUIRE(layout);
  CHECK(device.create_compute_pipeline({.label = "c", .layout = &*layout, .module = &*shader}));
  CHECK(!device.create_compute_pipeline({.label = "no-shader", .layout = &*layout}));
  auto bgl = device.create_bind_group_layout({.label = "bgl", .entries = {{0, gpu::BindingType::UniformBuffer}}});
  REQUIRE(bgl);
  auto wrong = device.create_bind_group({.label = "wrong", .layout = &*bgl, .entries = {gpu::bind(0, *buffer)}});
  REQUIRE(!wrong);  // a storage buffer in a uniform slot
  CHECK(contains(wrong.error().message, "'wrong'"));

  auto encoder = device.create_command_encoder("frame");
  REQUIRE(!encoder);
  CHECK(encoder.error().kind == ErrorKind::Unsupported);
  CHECK(contains(encoder.error().message, "'frame'"));
  auto read = device.queue().read_buffer(*buffer);
  REQUIRE(!read);
  CHECK(read.error().kind == ErrorKind::Unsupported);
  CHECK(!device.create_memory_block("heap", 1 << 20));
}

TEST_CASE("a graph compiled with a declaring device is sized by estimate and cannot execute") {
  gpu::Device device = gpu::Device::create_declaring();
  RenderGraph graph("g");
  struct Data {
    TextureHandle color;
  };
  auto& pass = graph.add_pass<Data>(
      "draw", [](PassBuilder& b, Data& d) {
        d.color = b.write(b.create_texture("color", {.size = RelativeSize{1.0f}, .format = gpu::Format::RGBA8Unorm}),
                          TextureUse::ColorAttachment);
      },
      [](const PassResources&, const Data&, PassContext&) {});
  graph.mark_output(pass.color);
  auto compiled = graph.compile({.output_extent = {64, 32, 1}, .device = &device});
  REQUIRE_MESSAGE(compiled, (compiled ? "" : compiled.error().to_error().message));
  CHECK(!testing::expect_transient_bytes_at_most(*compiled, 1u << 20));
  CHECK(testing::expect_transient_bytes_at_most(*compiled, 64u * 32u * 4u - 1));  // the texture's 8 KiB is counted
  auto run = compiled->execute(device);
  REQUIRE(!run);
  CHECK_MESSAGE(contains(run.error().what(), "declar"), run.error().what());
}

TEST_CASE("every shipped scene's frame declares and compiles with no driver, with the passes its materials need") {
  const auto scenes = source_dir() / "examples" / "scenes";
  struct Expect {
    const char* scene;
    std::vector<std::string> passes;
  };
  const std::vector<Expect> expected = {
      {"default.json", {"forward", "background", "tonemap"}},
      {"showcase.json", {"shadow_map", "forward", "shell_fur", "skin_sss", "ssdf_lighting", "neural_btf", "background", "tonemap"}},
      {"ssdf.json", {"forward", "ssdf_lighting", "tonemap"}},
      {"neural_btf.json", {"forward", "neural_btf", "tonemap"}},
  };
  for (const auto& e : expected) {
    CAPTURE(e.scene);
    const auto s = load_file(scenes / e.scene);
    auto report = renderer::describe(s);
    REQUIRE_MESSAGE(report, (report ? "" : report.error().what()));
    for (const auto& pass : e.passes) CHECK_MESSAGE(has(report->passes, pass), pass);
    CHECK(report->dot.find("digraph") != std::string::npos);
    CHECK(!report->resources.empty());
  }
}

TEST_CASE("a declared frame runs no bake: a 2048-texel, 1,000-sample skin LUT (half a minute) is declared, not baked") {
  const auto cache = temp_dir("lut-cache");
  ::setenv("WEFT_SKIN_LUT_CACHE", cache.c_str(), 1);
  auto report = renderer::describe(load_text(skin_scene));
  ::unsetenv("WEFT_SKIN_LUT_CACHE");
  REQUIRE_MESSAGE(report, (report ? "" : report.error().what()));
  CHECK(has(report->passes, "skin_sss"));
  CHECK(has(report->resources, "skin_lut"));
  CHECK(contains(report->dump, "2048"));  // the LUT at its size
  CHECK(std::filesystem::is_empty(cache));  // a bake would have written its cache file here
  std::filesystem::remove_all(cache);
}

TEST_CASE("a declaring renderer renders nothing, and says why") {
  gpu::Device device = gpu::Device::create_declaring("decl");
  auto r = renderer::Renderer::create(device);
  REQUIRE(r);
  auto frame = r->render(load_text(skin_scene));
  REQUIRE(!frame);
  CHECK(frame.error().kind == ErrorKind::Unsupported);
  CHECK(contains(frame.error().message, "describe"));
}

TEST_CASE("the test kit checks a scene's whole frame without a device, and a false expectation fails") {
  const auto s = load_file(source_dir() / "examples" / "scenes" / "showcase.json");
  CHECK(!testing::expect_scene_frame(s, {.width = 320, .height = 180}, [](const CompiledGraph& g) {
    return testing::expect_order(g, {"shadow_map", "forward", "shell_fur", "background", "tonemap"});
  }));
  CHECK(testing::expect_scene_frame(s, {.width = 320, .height = 180}, [](const CompiledGraph& g) {
    return testing::expect_order(g, {"tonemap", "forward"});
  }));
  CHECK(!testing::expect_scene_frame(s, {.width = 320, .height = 180}, [](const CompiledGraph& g) {
    return testing::expect_barrier(g, "tonemap", "scene_color", gpu::Access::ColorAttachment, gpu::Access::ShaderRead);
  }));
  // A frame that cannot compile: its error, and a check on it.
  const auto broken = source_dir() / "tests" / "pipeline" / "broken";
  std::optional<std::filesystem::path> cycle;
  for (const auto& entry : std::filesystem::directory_iterator(broken))
    if (contains(entry.path().filename().string(), "cycle") && entry.path().extension() == ".json") cycle = entry.path();
  REQUIRE(cycle);
  renderer::RenderOptions options{.width = 64, .height = 48};
  options.pipeline_file = *cycle;
  CHECK(testing::expect_scene_frame(s, options, {}));
  CHECK(!testing::expect_scene_frame_error(s, options, "cycle"));
  CHECK(testing::expect_scene_frame_error(s, options, "no such words in the message"));
}
