// The viewer's panels (Dear ImGui): scene objects and materials with their feature knobs,
// the quality preset, per-pass times, transient memory, the compiled graph and messages.
module;
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>
#include <imgui.h>
#include <nlohmann/json.hpp>
module weft.viewer;
import weft.core;
import weft.graph;
import weft.scene;
import weft.renderer;

namespace weft::viewer::detail {

namespace {

// The value of `field` ("lut.size" descends) in a material's params, or null.
const nlohmann::json* knob_value(const nlohmann::json& params, const std::string& field) {
  const nlohmann::json* at = &params;
  std::size_t start = 0;
  while (true) {
    const auto dot = field.find('.', start);
    const std::string part = field.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    if (!at->is_object() || !at->contains(part)) return nullptr;
    at = &(*at)[part];
    if (dot == std::string::npos) return at;
    start = dot + 1;
  }
}

void knob_widgets(Session& s, std::size_t material_index) {
  const auto& material = s.scene.materials[material_index];
  const auto knobs = knobs_for(material, s.quality);
  if (knobs.empty()) {
    ImGui::TextDisabled("no knobs");
    return;
  }
  for (const auto& knob : knobs) {
    const nlohmann::json* set = knob_value(material.params, knob.name);
    const nlohmann::json* current = set ? set : &knob.preset;
    const std::string id = knob.name + "##" + material.name;
    switch (knob.kind) {
      case KnobKind::Integer: {
        int v = current && current->is_number() ? current->get<int>() : int(knob.min);
        if (ImGui::SliderInt(id.c_str(), &v, int(knob.min), int(knob.max), "%d", ImGuiSliderFlags_AlwaysClamp))
          s.set_knob(material_index, knob.name, v);
        break;
      }
      case KnobKind::Number: {
        float v = current && current->is_number() ? current->get<float>() : float(knob.min);
        if (ImGui::SliderFloat(id.c_str(), &v, float(knob.min), float(knob.max), "%.3f", ImGuiSliderFlags_AlwaysClamp))
          s.set_knob(material_index, knob.name, v);
        break;
      }
      case KnobKind::Boolean: {
        bool v = current && current->is_boolean() ? current->get<bool>() : false;
        if (ImGui::Checkbox(id.c_str(), &v)) s.set_knob(material_index, knob.name, v);
        break;
      }
      case KnobKind::Choice: {
        const std::string v = current && current->is_string() ? current->get<std::string>()
                                                              : (knob.choices.empty() ? "" : knob.choices.front());
        if (ImGui::BeginCombo(id.c_str(), v.c_str())) {
          for (const auto& choice : knob.choices)
            if (ImGui::Selectable(choice.c_str(), choice == v)) s.set_knob(material_index, knob.name, choice);
          ImGui::EndCombo();
        }
        break;
      }
    }
    if (ImGui::IsItemHovered() && !knob.meaning.empty()) ImGui::SetTooltip("%s", knob.meaning.c_str());
  }
  if (!reference_values(material).is_null()) {
    if (ImGui::SmallButton(("compare with reference##" + material.name).c_str())) s.request_comparison(material_index);
    if (s.comparison && s.comparison->material == material_index) {
      if (s.comparison->metrics)
        ImGui::Text("RMSE %.5f  PSNR %.2f dB", s.comparison->metrics->rmse, s.comparison->metrics->psnr);
      else
        ImGui::TextDisabled("rendering the reference at this camera...");
      ImGui::Checkbox(("difference overlay##" + material.name).c_str(), &s.comparison->overlay);
      if (ImGui::IsItemHovered())
        ImGui::SetTooltip("largest channel difference: black 0, blue, red, yellow, white >= 0.1");
      ImGui::TextWrapped("reference: %s", s.comparison->why.c_str());
    }
  }
  if (!material.params.empty() && ImGui::SmallButton(("preset values##" + material.name).c_str())) {
    s.scene.materials[material_index].params = nlohmann::json::object();  // the preset decides every knob
    s.scene_changed();
  }
}

void scene_panel(Session& s) {
  if (!ImGui::CollapsingHeader("Scene", ImGuiTreeNodeFlags_DefaultOpen)) return;
  ImGui::Text("%s", s.options.scene.string().c_str());
  static const char* presets[] = {"low", "medium", "high", "reference"};
  int q = int(s.quality);
  if (ImGui::Combo("quality", &q, presets, 4)) {
    s.quality = Quality(q);
    s.scene_changed();
  }
  if (ImGui::TreeNode("objects", "objects (%zu)", s.scene.objects.size())) {
    for (const auto& object : s.scene.objects)
      ImGui::BulletText("%s: %s", object.name.c_str(), s.scene.materials.at(object.material).name.c_str());
    ImGui::TreePop();
  }
  for (std::size_t i = 0; i < s.scene.materials.size(); ++i) {
    auto& material = s.scene.materials[i];
    const std::string label = material.name + " (" + material_type_name(material) + ")";
    if (!ImGui::TreeNode(label.c_str())) continue;
    if (is_standard(material)) {
      auto& m = material.standard;
      bool changed = ImGui::ColorEdit3(("base colour##" + material.name).c_str(), &m.base_color.x);
      changed |= ImGui::SliderFloat(("metallic##" + material.name).c_str(), &m.metallic, 0.0f, 1.0f);
      changed |= ImGui::SliderFloat(("roughness##" + material.name).c_str(), &m.roughness, 0.0f, 1.0f);
      if (changed) s.scene_changed();
    } else {
      knob_widgets(s, i);
    }
    ImGui::TreePop();
  }
}

void timing_panel(Session& s) {
  if (!ImGui::CollapsingHeader("Timings", ImGuiTreeNodeFlags_DefaultOpen)) return;
  ImGui::Text("UI %.1f fps | scene frame %.0f ms at %ux%u%s", s.ui_fps, s.last_render_ms, s.rendered_w, s.rendered_h,
              s.refined ? " (refined)" : " (moving: lower resolution)");
  if (s.scene_busy_s > 0.5)  // a bake or a slow frame: the window keeps answering meanwhile
    ImGui::TextColored(ImVec4(1, 0.8f, 0.3f, 1), "rendering the scene (bakes included): %.1f s", s.scene_busy_s);
  if (s.last_refine_ms >= 0) ImGui::Text("time to refined image after the camera stopped: %.0f ms", s.last_refine_ms);
  if (!s.frame_ms_history.empty())
    ImGui::PlotLines("scene ms", s.frame_ms_history.data(), int(s.frame_ms_history.size()), 0, nullptr, 0.0f,
                     FLT_MAX, ImVec2(0, 40));
  if (!s.ui_ms_history.empty())
    ImGui::PlotLines("UI ms", s.ui_ms_history.data(), int(s.ui_ms_history.size()), 0, nullptr, 0.0f, FLT_MAX,
                     ImVec2(0, 40));
  if (ImGui::BeginTable("passes", 3, ImGuiTableFlags_RowBg | ImGuiTableFlags_SizingStretchProp)) {
    ImGui::TableSetupColumn("pass");
    ImGui::TableSetupColumn("GPU ms");
    ImGui::TableSetupColumn("CPU us");
    ImGui::TableHeadersRow();
    for (const auto& p : s.stats.passes) {
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(p.name.c_str());
      ImGui::TableNextColumn();
      if (p.gpu_ms >= 0) ImGui::Text("%.2f", p.gpu_ms); else ImGui::TextDisabled("-");
      ImGui::TableNextColumn();
      ImGui::Text("%.0f", p.cpu_record_us);
    }
    ImGui::EndTable();
  }
  ImGui::Text("GPU total %.2f ms, CPU frame %.2f ms", s.stats.gpu_total_ms, s.stats.cpu_frame_ms);
  ImGui::Text("transient memory: %.1f MiB aliased, %.1f MiB without aliasing",
              double(s.stats.transient_bytes) / (1 << 20), double(s.stats.transient_bytes_unaliased) / (1 << 20));
}

// The frame-time budget: the governor measures each feature at its low, medium and high presets
// at this camera and picks the least error that fits (docs/viewer.md#the-frame-time-budget).
void budget_panel(Session& s) {
  if (!ImGui::CollapsingHeader("Frame-time budget")) return;
  ImGui::InputDouble("target ms", &s.budget_ms, 10.0, 100.0, "%.0f");
  s.budget_ms = std::clamp(s.budget_ms, 1.0, 1e6);
  if (s.budget_running) {
    ImGui::TextColored(ImVec4(1, 0.8f, 0.3f, 1), "%s", s.scene_renderer->progress().c_str());
  } else if (ImGui::Button("fit the features to the budget")) {
    s.request_budget();
  }
  if (!s.budget_summary.empty()) ImGui::TextWrapped("%s", s.budget_summary.c_str());
}

void graph_panel(Session& s) {
  if (!ImGui::CollapsingHeader("Graph")) return;
  if (!s.graph) {
    ImGui::TextDisabled("compiled when the camera stops");
    return;
  }
  // Any resource of the compiled frame in the window: a pass slot or a texture, by name.
  if (ImGui::BeginCombo("show", s.show.empty() ? "frame (the pipeline's image)" : s.show.c_str())) {
    const auto item = [&](const std::string& name, const std::string& label) {
      if (ImGui::Selectable(label.c_str(), s.show == name)) {
        s.show = name;
        s.posted.reset();
      }
    };
    item("", "frame (the pipeline's image)");
    for (const auto& slot : s.graph->slots) item(slot, slot);
    for (const auto& r : s.graph->resources)
      if (!r.starts_with("readback:") && r != "hdr_readback") item(r, r + " (texture)");
    ImGui::EndCombo();
  }
  ImGui::Text("passes in order:");
  for (std::size_t i = 0; i < s.graph->passes.size(); ++i) ImGui::BulletText("%zu %s", i, s.graph->passes[i].c_str());
  ImGui::Text("culled: %s", s.graph->culled_passes.empty() ? "(none)" : "");
  for (const auto& p : s.graph->culled_passes) ImGui::BulletText("%s", p.c_str());
  if (ImGui::TreeNode("resources, lifetimes, memory, barriers")) {
    ImGui::TextUnformatted(s.graph->dump.c_str());
    ImGui::TreePop();
  }
}

// The pipeline's passes and their options, read from each pass type's options table (the
// table the pipeline reader, the docs and `weft tradeoff --pass` read); an edit re-renders.
void pipeline_panel(Session& s) {
  if (!ImGui::CollapsingHeader("Pipeline")) return;
  const auto held = s.current_pipeline();  // kept: an edit replaces the session's copy mid-loop
  if (!held) {
    ImGui::TextDisabled("the pipeline does not load (see Messages)");
    return;
  }
  ImGui::TextWrapped("%s%s", held->source.c_str(), s.edited_pipeline ? " (options edited here)" : "");
  const auto set = [&](const std::string& pass, const std::string& option, const nlohmann::json& value) {
    if (auto ok = s.set_pass_option(pass, option, value); !ok) s.error = ok.error().what();
  };
  for (const auto& pass : held->passes) {
    if (!ImGui::TreeNode((pass.name + " (" + pass.type->name + ")").c_str())) continue;
    if (pass.type->options.empty()) ImGui::TextDisabled("no options");
    for (const auto& o : pass.type->options) {
      const nlohmann::json& v = pass.options.json().at(o.name);
      const std::string id = o.name + "##" + pass.name;
      switch (o.kind) {
        case weft::KnobKind::Integer: {
          int x = v.is_number() ? v.get<int>() : int(o.min);
          if (ImGui::SliderInt(id.c_str(), &x, int(o.min), int(o.max), "%d", ImGuiSliderFlags_AlwaysClamp))
            set(pass.name, o.name, x);
          break;
        }
        case weft::KnobKind::Number: {
          float x = v.is_number() ? v.get<float>() : float(o.min);
          // Wide ranges (an exposure from 1e-6 to 1e6) need a logarithmic slider to be usable.
          const ImGuiSliderFlags flags = ImGuiSliderFlags_AlwaysClamp |
                                         (o.min >= 0.0 && o.max - o.min > 1000.0 ? ImGuiSliderFlags_Logarithmic : 0);
          if (ImGui::SliderFloat(id.c_str(), &x, float(o.min), float(o.max), "%.4g", flags)) set(pass.name, o.name, x);
          break;
        }
        case weft::KnobKind::Boolean: {
          bool x = v.is_boolean() && v.get<bool>();
          if (ImGui::Checkbox(id.c_str(), &x)) set(pass.name, o.name, x);
          break;
        }
        case weft::KnobKind::Choice: {
          const std::string x = v.is_string() ? v.get<std::string>() : std::string();
          if (ImGui::BeginCombo(id.c_str(), x.c_str())) {
            for (const auto& choice : o.choices)
              if (ImGui::Selectable(choice.c_str(), choice == x)) set(pass.name, o.name, choice);
            ImGui::EndCombo();
          }
          break;
        }
      }
      if (ImGui::IsItemHovered() && !o.meaning.empty()) ImGui::SetTooltip("%s", o.meaning.c_str());
    }
    ImGui::TreePop();
  }
  if (s.edited_pipeline && ImGui::SmallButton("the file's options again")) s.drop_pipeline_edits();
}

void messages_panel(Session& s) {
  const std::size_t validation = s.instance->validation_enabled() ? s.instance->validation_message_count() : 0;
  const bool open = !s.error.empty() || !s.warnings.empty() || validation > 0;
  if (!ImGui::CollapsingHeader("Messages", open ? ImGuiTreeNodeFlags_DefaultOpen : 0)) return;
  if (!s.error.empty()) ImGui::TextColored(ImVec4(1, 0.4f, 0.4f, 1), "%s", s.error.c_str());
  for (const auto& w : s.warnings) ImGui::TextWrapped("warning: %s", w.c_str());
  for (const auto& w : s.scene.warnings) ImGui::TextWrapped("scene: %s", w.c_str());
  if (s.instance->validation_enabled()) ImGui::Text("validation messages: %zu", validation);
  if (s.error.empty() && s.warnings.empty() && s.scene.warnings.empty()) ImGui::TextDisabled("none");
}

}  // namespace

void Session::draw_ui() {
  if (!show_ui) return;
  ImGui::SetNextWindowPos(ImVec2(8, 8), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(380, 0), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowBgAlpha(0.85f);
  ImGui::Begin("weft view");
  if (!error.empty()) ImGui::TextColored(ImVec4(1, 0.4f, 0.4f, 1), "%s", error.c_str());
  ImGui::TextDisabled("drag: orbit | right drag: pan | wheel: zoom | WASDQE: fly | R reset | H UI | P screenshot");
  scene_panel(*this);
  timing_panel(*this);
  budget_panel(*this);
  pipeline_panel(*this);
  graph_panel(*this);
  messages_panel(*this);
  ImGui::End();
}

}  // namespace weft::viewer::detail
