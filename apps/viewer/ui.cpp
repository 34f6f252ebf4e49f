#include "ui.hpp"

#define GLFW_INCLUDE_NONE  // GL types come from glcorearb.h (gl_functions.hpp)
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <imgui_stdlib.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <optional>
#include <string>

#include "fabrica/core/error.hpp"
#include "fabrica/lines/extract.hpp"
#include "viewer.hpp"

namespace fabrica::viewer {

namespace {

enum class Dialog { none, open, save_scene, save_camera, load_camera, screenshot, export_svg };

struct UiState {
  Dialog dialog = Dialog::none;
  std::filesystem::path folder = std::filesystem::current_path();
  std::string path;
  bool show_structures = true, show_hud = true;
  int shot_w = 2048, shot_h = 1280;
  bool shot_transparent = false;
};

std::map<std::string, bool>& pending_open() {
  static std::map<std::string, bool> pending;
  return pending;
}

UiState& ui() {
  static UiState state;
  return state;
}

const AnatomicalView kViews[] = {AnatomicalView::anterior, AnatomicalView::posterior,
                                 AnatomicalView::left,     AnatomicalView::right,
                                 AnatomicalView::superior, AnatomicalView::inferior};

/// Runs an action of the session; an error goes to the error panel.
template <class F>
void guarded(Viewer& v, F&& f) {
  try {
    f();
  } catch (const std::exception& e) {
    v.report_error(e.what());
  }
}

void open_dialog(Dialog d, const std::string& default_name) {
  ui().dialog = d;
  ui().path = (ui().folder / default_name).string();
}

void menu(Viewer& v) {
  if (!ImGui::BeginMainMenuBar()) return;
  if (ImGui::BeginMenu("File")) {
    if (ImGui::MenuItem("Open...", "Ctrl+O")) open_dialog(Dialog::open, "");
    if (ImGui::BeginMenu("Recent", !v.recent_files().empty())) {
      for (const auto& p : std::vector<std::filesystem::path>(v.recent_files()))
        if (ImGui::MenuItem(p.string().c_str())) v.open(p);
      ImGui::EndMenu();
    }
    ImGui::Separator();
    if (ImGui::MenuItem("Save scene...", "Ctrl+S")) open_dialog(Dialog::save_scene, "scene.json");
    if (ImGui::MenuItem("Save camera...")) open_dialog(Dialog::save_camera, "camera.json");
    if (ImGui::MenuItem("Load camera...")) open_dialog(Dialog::load_camera, "camera.json");
    if (ImGui::MenuItem("Screenshot...", "Ctrl+P")) open_dialog(Dialog::screenshot, "view.png");
    if (ImGui::MenuItem("Export SVG/PDF...")) open_dialog(Dialog::export_svg, "lines.svg");
    ImGui::Separator();
    if (ImGui::MenuItem("Quit", "Ctrl+Q")) v.request_close();
    ImGui::EndMenu();
  }
  if (ImGui::BeginMenu("View")) {
    int key = 1;
    for (AnatomicalView view : kViews) {
      const std::string shortcut = std::to_string(key++);
      if (ImGui::MenuItem(to_string(view), shortcut.c_str()))
        guarded(v, [&] { v.view(view, true); });
    }
    if (ImGui::MenuItem("Fit to selection", "F")) guarded(v, [&] { v.fit_to_selection(true); });
    ImGui::Separator();
    ImGui::MenuItem("Structures panel", "S", &ui().show_structures);
    ImGui::MenuItem("HUD", "H", &ui().show_hud);
    ImGui::SliderFloat("Resolution while moving", &v.moving_scale(), 0.25f, 1.0f, "%.2f");
    if (ImGui::Checkbox("Simplified while moving", &v.simplify_while_moving())) v.style_changed();
    if (ImGui::Checkbox("Coarse focus lines while moving", &v.coarse_lines_while_moving()))
      v.style_changed();
    if (ImGui::ColorEdit3("Background", &v.background().r, ImGuiColorEditFlags_NoInputs))
      v.style_changed();
    if (ImGui::Checkbox("Transparent export", &v.transparent())) v.style_changed();
    ImGui::EndMenu();
  }
  if (ImGui::BeginMenu("Tools")) {
    if (ImGui::MenuItem("Measure distance", "M", &v.measure_mode())) v.measure_points().clear();
    if (ImGui::BeginMenu("Clipping plane")) {
      // The context loses what lies beyond a plane through the focus
      // (script: clip off|view|SIDE [OFFSET_MM]).
      ClipSettings c = v.clip();
      bool on = c.mode != ClipSettings::Mode::off, changed = false;
      if (ImGui::Checkbox("clip the context", &on)) {
        c.mode = on ? ClipSettings::Mode::view : ClipSettings::Mode::off;
        changed = true;
      }
      const char* orientations[] = {"facing the eye", "anterior", "posterior", "left",
                                    "right",          "superior", "inferior"};
      int o = c.mode == ClipSettings::Mode::side ? 1 + static_cast<int>(c.side) : 0;
      if (c.mode == ClipSettings::Mode::fixed) {
        ImGui::TextUnformatted("plane from the scene file");
      } else if (on && ImGui::Combo("orientation", &o, orientations, 7)) {
        c.mode = o == 0 ? ClipSettings::Mode::view : ClipSettings::Mode::side;
        if (o > 0) c.side = static_cast<AnatomicalView>(o - 1);
        changed = true;
      }
      float offset = static_cast<float>(c.offset);
      if (on && c.mode != ClipSettings::Mode::fixed &&
          ImGui::SliderFloat("offset (mm)", &offset, -200.0f, 200.0f, "%.1f")) {
        c.offset = offset;
        changed = true;
      }
      if (changed) v.set_clip(c.mode, c.side, c.offset);
      ImGui::EndMenu();
    }
    if (ImGui::BeginMenu("Hybrid apparent ridges")) {
      auto& h = v.hybrid();
      float lambda = static_cast<float>(h.lambda), threshold = static_cast<float>(h.threshold);
      bool changed = false;
      if (ImGui::SliderFloat("lambda", &lambda, 0.0f, 4.0f)) h.lambda = lambda, changed = true;
      if (ImGui::SliderFloat("threshold", &threshold, 0.0f, 1.0f))
        h.threshold = threshold, changed = true;
      float tau = static_cast<float>(h.tau.value_or(0.0));
      bool custom = h.tau.has_value();
      if (ImGui::Checkbox("custom tau", &custom)) {
        h.tau = custom ? std::optional<double>(tau) : std::nullopt;
        changed = true;
      }
      if (custom && ImGui::SliderFloat("tau", &tau, -10.0f, 10.0f)) h.tau = tau, changed = true;
      changed |= ImGui::Checkbox("fade", &h.fade);
      if (changed) v.style_changed();
      ImGui::EndMenu();
    }
    ImGui::EndMenu();
  }
  ImGui::EndMainMenuBar();
}

bool combo(const char* label, int& current, const char* const* items, int count) {
  return ImGui::Combo(label, &current, items, count);
}

// Focus and context: the cutaway (script: cutaway on|off [MARGIN_PX
// [FADE_PX]], cutaway KEY=VALUE...; docs/viewer.md).
void cutaway_section(Viewer& v) {
  if (v.structures().empty() || !ImGui::CollapsingHeader("Cutaway")) return;
  render::Cutaway c = v.cutaway();
  bool changed = ImGui::Checkbox("cut away the context in front of the focus", &c.enabled);
  if (c.enabled) {
    const float top = static_cast<float>(render::kCutawayMaxPx) / 4.0f;
    float margin = static_cast<float>(c.margin_px), fade = static_cast<float>(c.fade_px);
    if (ImGui::SliderFloat("margin (px)", &margin, 0.0f, top, "%.1f")) {
      c.margin_px = margin;
      changed = true;
    }
    if (ImGui::SliderFloat("fade (px)", &fade, 0.0f, top, "%.1f")) {
      c.fade_px = fade;
      changed = true;
    }
    changed |= ImGui::Checkbox("rim", &c.rim);
    if (c.rim)
      changed |= ImGui::ColorEdit3("rim colour", &c.rim_color.r, ImGuiColorEditFlags_NoInputs);
  }
  if (changed) guarded(v, [&] { v.set_cutaway(c); });
}

void structure_panel(Viewer& v) {
  if (!ui().show_structures) return;
  ImGui::SetNextWindowPos(ImVec2(8, 28), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(330, 520), ImGuiCond_FirstUseEver);
  if (!ImGui::Begin("Structures", &ui().show_structures)) {
    ImGui::End();
    return;
  }
  auto& list = v.structures();
  if (list.empty()) ImGui::TextWrapped("Nothing open: File > Open, or drop files on the window.");
  for (std::size_t i = 0; i < list.size(); ++i) {
    ViewerStructure& s = list[i];
    ImGui::PushID(s.id);
    bool changed = ImGui::Checkbox("##visible", &s.visible);
    ImGui::SameLine();
    ImGui::ColorButton("##swatch", ImVec4(s.style.color.r, s.style.color.g, s.style.color.b, 1.0f),
                       ImGuiColorEditFlags_NoTooltip, ImVec2(12, 12));
    ImGui::SameLine();
    const std::string title =
        s.name + (s.role == render::Role::focus ? "  [focus]" : "") + "###node";
    // `panel NAME open|closed` (script): the row and its Lines section.
    std::optional<bool> set_open;
    if (const auto p = pending_open().find(s.name); p != pending_open().end()) {
      set_open = p->second;
      pending_open().erase(p);
      ImGui::SetNextItemOpen(*set_open);
    }
    if (ImGui::TreeNode(title.c_str())) {
      int role = s.role == render::Role::focus ? 0 : 1;
      const char* roles[] = {"focus", "context"};
      if (combo("role", role, roles, 2)) {
        if (role == 0)
          v.focus(i);
        else
          v.set_role(i, render::Role::context);
      }
      auto& st = s.style;
      changed |= ImGui::ColorEdit3("colour", &st.color.r, ImGuiColorEditFlags_NoInputs);
      float opacity = static_cast<float>(st.opacity);
      if (ImGui::SliderFloat("opacity", &opacity, 0.0f, 1.0f)) {
        st.opacity = opacity;
        changed = true;
      }
      int shading = static_cast<int>(st.shading);
      const char* shadings[] = {"none", "flat", "lambert", "toon"};
      if (combo("shading", shading, shadings, 4)) {
        st.shading = static_cast<render::Shading>(shading);
        changed = true;
      }
      if (set_open) ImGui::SetNextItemOpen(*set_open);
      if (ImGui::TreeNode("Lines")) {
        for (LineFamily f : all_families()) {
          bool on = std::find(st.families.begin(), st.families.end(), f) != st.families.end();
          if (ImGui::Checkbox(family_name(f), &on)) {
            if (on)
              st.families.push_back(f);
            else
              st.families.erase(std::remove(st.families.begin(), st.families.end(), f),
                                st.families.end());
            changed = true;
          }
        }
        auto slider = [&](const char* label, double& value, float hi) {
          float x = static_cast<float>(value);
          if (ImGui::SliderFloat(label, &x, 0.0f, hi, "%.3f")) {
            value = x;
            changed = true;
          }
        };
        slider("suggestive threshold", s.thresholds.suggestive.threshold, 0.2f);
        slider("apparent threshold", s.thresholds.apparent.threshold, 1.0f);
        slider("ridge/valley threshold", s.thresholds.ridge.threshold, 1.0f);
        s.thresholds.valley.threshold = s.thresholds.ridge.threshold;
        slider("feature size (mm, 0 auto)", s.thresholds.feature_size, 20.0f);
        slider("line width", st.lines.width, 10.0f);
        changed |=
            ImGui::ColorEdit4("line colour", &st.lines.color.r, ImGuiColorEditFlags_NoInputs);
        int hidden = static_cast<int>(st.lines.hidden);
        const char* hiddens[] = {"omit", "dashed", "show"};
        if (combo("hidden lines", hidden, hiddens, 3)) {
          st.lines.hidden = static_cast<render::HiddenLines>(hidden);
          changed = true;
        }
        changed |= ImGui::Checkbox("hybrid GPU apparent ridges", &st.hybrid_apparent_ridges);
        ImGui::TreePop();
      }
      if (ImGui::TreeNode("Hatching")) {
        changed |= ImGui::Checkbox("shading strokes", &s.hatching);
        float width = static_cast<float>(s.hatching_width);
        if (ImGui::SliderFloat("stroke width", &width, 0.5f, 4.0f)) {
          s.hatching_width = width;
          changed = true;
        }
        ImGui::TreePop();
      }
      if (ImGui::Button("Reset to defaults")) {
        const render::Color c = st.color;
        st = render::default_style(s.role);
        st.color = c;
        s.thresholds = LineOptions{};
        s.hatching = false;
        s.hatching_width = 1.0;
        changed = true;
      }
      ImGui::TreePop();
    }
    if (changed) v.style_changed();
    ImGui::PopID();
  }
  cutaway_section(v);
  ImGui::End();
}

void hud(Viewer& v) {
  const auto& io = ImGui::GetIO();
  auto& loader = v.loader();
  if (loader.busy()) {
    ImGui::SetNextWindowPos(ImVec2(io.DisplaySize.x * 0.5f, 40), ImGuiCond_Always, ImVec2(0.5f, 0));
    ImGui::Begin("Loading", nullptr,
                 ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_AlwaysAutoResize);
    const auto [name, fraction] = loader.progress();
    ImGui::Text("Loading %s", name.c_str());
    ImGui::ProgressBar(static_cast<float>(fraction), ImVec2(260, 0));
    if (ImGui::Button("Cancel")) loader.cancel();
    ImGui::End();
  }
  if (ui().show_hud) {
    ImGui::SetNextWindowPos(ImVec2(8, io.DisplaySize.y - 8), ImGuiCond_Always, ImVec2(0, 1));
    ImGui::SetNextWindowBgAlpha(0.6f);
    ImGui::Begin("HUD", nullptr,
                 ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_AlwaysAutoResize |
                     ImGuiWindowFlags_NoFocusOnAppearing | ImGuiWindowFlags_NoNav);
    const FrameStats& f = v.last_frame();
    ImGui::Text("frame %.1f ms (draw %.1f ms)   lines %.1f ms, age %llu frame%s", f.ms_frame,
                f.ms_gpu_submit, f.ms_lines, static_cast<unsigned long long>(f.lines_age),
                f.lines_age == 1 ? "" : "s");
    if (v.hover() && v.hover()->structure >= 0 &&
        v.hover()->structure < static_cast<int>(v.structures().size())) {
      const SurfacePick& h = *v.hover();
      ImGui::Text("%s   k1 %.4f  k2 %.4f  H %.4f /mm",
                  v.structures()[static_cast<std::size_t>(h.structure)].name.c_str(), h.k1, h.k2,
                  0.5 * (h.k1 + h.k2));
    }
    if (v.measure_mode()) {
      const auto& m = v.measure_points();
      if (m.size() == 2)
        ImGui::Text("distance %.2f mm", (m[0].point - m[1].point).norm());
      else
        ImGui::Text("measure: click %s point", m.empty() ? "the first" : "the second");
    }
    ImGui::End();
  }
}

void errors(Viewer& v) {
  if (v.errors().empty()) return;
  const auto& io = ImGui::GetIO();
  ImGui::SetNextWindowPos(ImVec2(io.DisplaySize.x - 8, 28), ImGuiCond_Always, ImVec2(1, 0));
  ImGui::SetNextWindowSize(ImVec2(std::min(560.0f, io.DisplaySize.x * 0.6f), 0), ImGuiCond_Always);
  ImGui::Begin("Errors", nullptr, ImGuiWindowFlags_NoCollapse);
  for (const auto& e : v.errors()) {
    ImGui::PushStyleColor(ImGuiCol_Text, ImVec4(0.75f, 0.1f, 0.1f, 1.0f));
    ImGui::TextWrapped("%s", e.c_str());
    ImGui::PopStyleColor();
  }
  if (ImGui::Button("Clear")) v.clear_errors();
  ImGui::End();
}

void file_dialog(Viewer& v) {
  UiState& s = ui();
  if (s.dialog == Dialog::none) return;
  const char* titles[] = {"",           "Open",      "Save scene", "Save camera", "Load camera",
                          "Screenshot", "Export SVG"};
  const auto& io = ImGui::GetIO();
  ImGui::SetNextWindowPos(ImVec2(io.DisplaySize.x * 0.5f, io.DisplaySize.y * 0.5f),
                          ImGuiCond_Appearing, ImVec2(0.5f, 0.5f));
  ImGui::SetNextWindowSize(ImVec2(520, 420), ImGuiCond_Appearing);
  bool open = true;
  ImGui::Begin(titles[static_cast<int>(s.dialog)], &open);
  ImGui::TextUnformatted(s.folder.string().c_str());
  ImGui::BeginChild("files", ImVec2(0, -ImGui::GetFrameHeightWithSpacing() * 3));
  if (ImGui::Selectable("..")) s.folder = s.folder.parent_path();
  std::error_code ec;
  std::vector<std::filesystem::directory_entry> entries;
  for (const auto& e : std::filesystem::directory_iterator(s.folder, ec)) entries.push_back(e);
  std::sort(entries.begin(), entries.end(), [](const auto& a, const auto& b) {
    if (a.is_directory() != b.is_directory()) return a.is_directory();
    return a.path().filename() < b.path().filename();
  });
  for (const auto& e : entries) {
    const std::string label = e.path().filename().string() + (e.is_directory() ? "/" : "");
    if (ImGui::Selectable(label.c_str(), false, ImGuiSelectableFlags_AllowDoubleClick)) {
      if (e.is_directory()) {
        s.folder = e.path();
      } else {
        s.path = e.path().string();
        if (ImGui::IsMouseDoubleClicked(0) && s.dialog == Dialog::open) {
          v.open(e.path());
          open = false;
        }
      }
    }
  }
  ImGui::EndChild();
  ImGui::InputText("path", &s.path);
  if (s.dialog == Dialog::screenshot) {
    ImGui::InputInt("width", &s.shot_w);
    ImGui::SameLine();
    ImGui::InputInt("height", &s.shot_h);
    ImGui::Checkbox("transparent", &s.shot_transparent);
  }
  if (ImGui::Button("OK")) {
    const std::filesystem::path p = s.path;
    guarded(v, [&] {
      switch (s.dialog) {
        case Dialog::open:
          v.open(p);
          break;
        case Dialog::save_scene:
          v.save_scene(p);
          break;
        case Dialog::save_camera:
          write_camera(v.camera(), p);
          break;
        case Dialog::load_camera:
          v.set_camera(read_camera(p));
          break;
        case Dialog::screenshot:
          render::write_png(v.screenshot(std::clamp(s.shot_w, 1, 16384),
                                         std::clamp(s.shot_h, 1, 16384), s.shot_transparent),
                            p);
          break;
        case Dialog::export_svg:
          v.export_svg(p);
          break;
        case Dialog::none:
          break;
      }
    });
    open = false;
  }
  ImGui::SameLine();
  if (ImGui::Button("Cancel")) open = false;
  ImGui::End();
  if (!open) s.dialog = Dialog::none;
}

void shortcuts(Viewer& v) {
  const auto& io = ImGui::GetIO();
  if (io.WantCaptureKeyboard) return;
  const bool ctrl = io.KeyCtrl;
  if (ctrl && ImGui::IsKeyPressed(GLFW_KEY_O)) open_dialog(Dialog::open, "");
  if (ctrl && ImGui::IsKeyPressed(GLFW_KEY_S)) open_dialog(Dialog::save_scene, "scene.json");
  if (ctrl && ImGui::IsKeyPressed(GLFW_KEY_P)) open_dialog(Dialog::screenshot, "view.png");
  if (ctrl && ImGui::IsKeyPressed(GLFW_KEY_Q)) v.request_close();
  if (ctrl) return;
  for (int k = 0; k < 6; ++k)
    if (ImGui::IsKeyPressed(GLFW_KEY_1 + k)) guarded(v, [&] { v.view(kViews[k], true); });
  if (ImGui::IsKeyPressed(GLFW_KEY_F)) guarded(v, [&] { v.fit_to_selection(true); });
  if (ImGui::IsKeyPressed(GLFW_KEY_H)) ui().show_hud = !ui().show_hud;
  if (ImGui::IsKeyPressed(GLFW_KEY_S)) ui().show_structures = !ui().show_structures;
  if (ImGui::IsKeyPressed(GLFW_KEY_M)) {
    v.measure_mode() = !v.measure_mode();
    v.measure_points().clear();
  }
  if (ImGui::IsKeyPressed(GLFW_KEY_ESCAPE)) ui().dialog = Dialog::none;
}

}  // namespace

void set_panel_open(const std::string& structure, bool open) {
  pending_open()[structure] = open;
}

void draw_ui(Viewer& v) {
  shortcuts(v);
  menu(v);
  structure_panel(v);
  hud(v);
  errors(v);
  file_dialog(v);
}

}  // namespace fabrica::viewer
