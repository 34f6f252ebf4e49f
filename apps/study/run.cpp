#include "run.hpp"

#define GLFW_INCLUDE_NONE
#include <GL/gl.h>
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <imgui_impl_glfw.h>
#include <imgui_impl_opengl3.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <map>
#include <optional>

#include "fabrica/core/atomic_file.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/core/types.hpp"
#include "fabrica/render/image.hpp"
#include "log.hpp"
#include "plan.hpp"
#include "stimuli.hpp"

// From fabrica/render/context.hpp, whose GL loader header cannot share a
// translation unit with <GL/gl.h> (used here by ImGui's backend).
namespace fabrica::render {
void keep_gl_driver_loaded();
}

namespace fabrica::study {
namespace {

using Clock = std::chrono::steady_clock;

/// One answer, from a widget or from the --auto file (same fields).
struct Answer {
  std::optional<Vec3> normal;
  std::optional<int> choice, rating;
  std::optional<std::vector<int>> order;  ///< indices into the trial's stimuli, best first
};

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6f", v);
  return buf;
}

std::string wall_time() {
  const auto now = std::chrono::system_clock::now();
  const std::time_t t = std::chrono::system_clock::to_time_t(now);
  const auto ms =
      std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()) % 1000;
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[40];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &tm);
  char out[48];
  std::snprintf(out, sizeof out, "%s.%03dZ", buf, static_cast<int>(ms.count()));
  return out;
}

/// --auto RESPONSES.jsonl: one {"trial": N, <one answer>} a line, checked
/// against the plan (trial exists, answer fits its task).
std::map<int, Answer> read_auto(const std::filesystem::path& path, const nlohmann::json& plan) {
  std::ifstream in(path);
  if (!in) throw InputError(path.string() + ": cannot read the --auto responses");
  std::map<int, const nlohmann::json*> trials;
  for (const auto& t : plan["trials"]) trials[t["trial"].get<int>()] = &t;
  std::map<int, Answer> out;
  std::string line;
  for (int ln = 1; std::getline(in, line); ++ln) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const std::string where = path.string() + " line " + std::to_string(ln) + ": ";
    nlohmann::json j;
    try {
      j = nlohmann::json::parse(line);
    } catch (const nlohmann::json::exception&) {
      throw InputError(where + "not a JSON object");
    }
    if (!j.is_object() || !j.contains("trial") || !j["trial"].is_number_integer() ||
        j["trial"].get<long long>() < 0 || j["trial"].get<long long>() > 1000000000)
      throw InputError(where + "expected {\"trial\": N, ...}");
    const int n = static_cast<int>(j["trial"].get<long long>());
    if (!trials.count(n))
      throw InputError(where + "trial " + std::to_string(n) + " is not in the plan");
    const std::string task = (*trials[n])["task"].get<std::string>();
    const std::size_t k = trials[n]->contains("stimuli") ? (*trials[n])["stimuli"].size() : 1;
    Answer a;
    for (const auto& [key, v] : j.items()) {
      if (key == "trial") continue;
      if (key == "normal" && task == "gauge" && v.is_array() && v.size() == 3 && v[0].is_number() &&
          v[1].is_number() && v[2].is_number()) {
        const Vec3 nv(v[0].get<double>(), v[1].get<double>(), v[2].get<double>());
        if (!(nv.norm() > 0.0) || !nv.allFinite())
          throw InputError(where + "normal must be non-zero");
        a.normal = nv.normalized();
      } else if (key == "choice" && task == "2afc" && v.is_number_integer() &&
                 (v.get<long long>() == 0 || v.get<long long>() == 1)) {
        a.choice = v.get<int>();
      } else if (key == "rating" && task == "likert" && v.is_number_integer() &&
                 v.get<long long>() >= 1 &&
                 v.get<long long>() <= (*trials[n])["scale"].get<long long>()) {
        a.rating = v.get<int>();
      } else if (key == "order" && task == "ranking" && v.is_array() && v.size() == k) {
        std::vector<int> order;
        std::vector<bool> seen(k, false);
        for (const auto& e : v) {
          int idx = -1;
          if (e.is_number_integer() && e.get<long long>() >= 0 &&
              e.get<long long>() < static_cast<long long>(k))
            idx = static_cast<int>(e.get<long long>());
          for (std::size_t i = 0; e.is_string() && i < k; ++i)
            if ((*trials[n])["techniques"][i] == e || (*trials[n])["stimuli"][i] == e)
              idx = static_cast<int>(i);
          if (idx < 0 || idx >= static_cast<int>(k) || seen[idx])
            throw InputError(where + "order must list each of the trial's " + std::to_string(k) +
                             " stimuli once (indices, technique names or stimulus ids)");
          seen[idx] = true;
          order.push_back(idx);
        }
        a.order = order;
      } else {
        throw InputError(where + "\"" + key + "\" is not a valid answer for trial " +
                         std::to_string(n) + " (a " + task +
                         " trial: normal [x,y,z] | choice 0/1 | rating 1..scale | order [...])");
      }
    }
    if (!a.normal && !a.choice && !a.rating && !a.order)
      throw InputError(where + "no answer given");
    out[n] = a;
  }
  return out;
}

struct Step {
  std::string screen;  ///< empty for a trial
  std::string text;
  const nlohmann::json* trial = nullptr;
};

class Session {
 public:
  Session(const RunOptions& o, const nlohmann::json& plan, ResponseLog& log,
          std::map<std::string, std::filesystem::path> stimuli, std::map<int, Answer> answers)
      : opt_(o), plan_(plan), log_(log), stimuli_(std::move(stimuli)), auto_(std::move(answers)) {
    const bool resumed = !log_.answered().empty();
    bool first = true;
    for (const auto& t : plan_["trials"]) {
      if (log_.answered().count(t["trial"].get<int>())) continue;
      if (first && resumed)
        steps_.push_back({"resume",
                          "Welcome back. You continue at trial " +
                              std::to_string(t["trial"].get<int>()) + " of " +
                              std::to_string(plan_["trials"].size()) + ".",
                          nullptr});
      first = false;
      if (t.contains("before"))
        for (const auto& s : t["before"])
          steps_.push_back({s["screen"].get<std::string>(), s["text"].get<std::string>(), nullptr});
      steps_.push_back({"", "", &t});
    }
    steps_.push_back({"goodbye", plan_["goodbye"].get<std::string>(), nullptr});
  }

  bool done() const { return step_ >= steps_.size(); }
  int answered_now() const { return answered_now_; }

  /// Draws the current step; returns the kind of screen drawn.
  std::string frame(float width, float height) {
    ImGui::SetNextWindowPos(ImVec2(0, 0));
    ImGui::SetNextWindowSize(ImVec2(width, height));
    ImGui::Begin("study", nullptr,
                 ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_NoMove |
                     ImGuiWindowFlags_NoSavedSettings | ImGuiWindowFlags_NoBringToFrontOnFocus);
    const Step& s = steps_[step_];
    const std::string kind = s.trial ? (*s.trial)["task"].get<std::string>() : s.screen;
    if (frames_in_step_ == 0) {
      shown_at_ = Clock::now();
      state_ = Answer{};
      if (s.trial && s.trial->contains("initial_normal")) {
        const auto& n = (*s.trial)["initial_normal"];
        state_.normal = Vec3(n[0].get<double>(), n[1].get<double>(), n[2].get<double>());
      }
      if (s.trial && s.trial->contains("stimuli") && kind == "ranking") {
        std::vector<int> order;
        for (std::size_t i = 0; i < (*s.trial)["stimuli"].size(); ++i)
          order.push_back(static_cast<int>(i));
        state_.order = order;
      }
    }
    // Scripted participant: from the second frame on, the answer is put
    // into the widget state and submitted exactly as a click would.
    bool submit = false;
    if (!opt_.auto_responses.empty() && frames_in_step_ >= 1) {
      if (!s.trial) {
        submit = true;
      } else if (auto it = auto_.find((*s.trial)["trial"].get<int>()); it != auto_.end()) {
        const Answer& a = it->second;
        if (a.normal) state_.normal = a.normal;
        if (a.choice) state_.choice = a.choice;
        if (a.rating) state_.rating = a.rating;
        if (a.order) state_.order = a.order;
        submit = true;
      }
    }
    ++frames_in_step_;
    if (s.trial)
      draw_trial(*s.trial, submit, width);
    else
      draw_screen(s, submit);
    ImGui::End();
    return kind;
  }

 private:
  unsigned texture(const std::string& id) {
    auto it = textures_.find(id);
    if (it != textures_.end()) return it->second;
    const render::Image img = render::read_png(stimuli_.at(id));
    GLuint tex = 0;
    glGenTextures(1, &tex);
    glBindTexture(GL_TEXTURE_2D, tex);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA, img.width, img.height, 0, GL_RGBA, GL_UNSIGNED_BYTE,
                 img.rgba.data());
    return textures_[id] = tex;
  }

  void advance() {
    ++step_;
    frames_in_step_ = 0;
  }

  void draw_screen(const Step& s, bool submit) {
    ImGui::Dummy(ImVec2(0, 30));
    ImGui::PushTextWrapPos(ImGui::GetWindowWidth() - 40);
    ImGui::TextWrapped("%s", s.text.c_str());
    ImGui::PopTextWrapPos();
    ImGui::Dummy(ImVec2(0, 20));
    const char* label = s.screen == "goodbye" ? "Finish" : "Continue";
    if (ImGui::Button(label, ImVec2(160, 40)) || submit) advance();
  }

  /// Logs the answer (fsync'ed) and moves on: the only way a trial ends.
  void commit(const nlohmann::json& t) {
    const double rt = std::chrono::duration<double, std::milli>(Clock::now() - shown_at_).count();
    std::map<std::string, std::string> row;
    auto str = [&](const char* key) {
      return t.contains(key) ? (t[key].is_string() ? t[key].get<std::string>() : t[key].dump())
                             : "";
    };
    auto joined = [&](const nlohmann::json& list) {
      return join(list.get<std::vector<std::string>>(), "|");
    };
    row["participant"] = opt_.participant;
    row["session"] = std::to_string(log_.session());
    for (const char* key :
         {"trial", "block", "task", "model", "view", "technique", "stimulus", "question"})
      row[key] = str(key);
    row["practice"] = t["practice"].get<bool>() ? "1" : "0";
    row["attention"] = t["attention"].get<bool>() ? "1" : "0";
    if (t.contains("expected"))
      row["expected"] = t["expected"].is_array() ? number(t["expected"][0].get<double>()) + " " +
                                                       number(t["expected"][1].get<double>()) +
                                                       " " + number(t["expected"][2].get<double>())
                                                 : t["expected"].dump();
    if (t.contains("stimuli")) {
      row["techniques"] = joined(t["techniques"]);
      row["stimuli"] = joined(t["stimuli"]);
      if (t["stimuli"].size() == 2) {
        row["technique_a"] = t["techniques"][0].get<std::string>();
        row["technique_b"] = t["techniques"][1].get<std::string>();
        row["stimulus_a"] = t["stimuli"][0].get<std::string>();
        row["stimulus_b"] = t["stimuli"][1].get<std::string>();
      }
    }
    const std::string task = t["task"].get<std::string>();
    if (task == "gauge") {
      row["pixel_x"] = number(t["pixel"][0].get<double>());
      row["pixel_y"] = number(t["pixel"][1].get<double>());
      row["true_nx"] = number(t["true_normal"][0].get<double>());
      row["true_ny"] = number(t["true_normal"][1].get<double>());
      row["true_nz"] = number(t["true_normal"][2].get<double>());
      const Vec3 n = state_.normal->normalized();
      row["normal_x"] = number(n.x());
      row["normal_y"] = number(n.y());
      row["normal_z"] = number(n.z());
      row["response"] = row["normal_x"] + " " + row["normal_y"] + " " + row["normal_z"];
    } else if (task == "2afc") {
      row["choice"] = std::to_string(*state_.choice);
      row["chosen_technique"] = t["techniques"][*state_.choice].get<std::string>();
      row["response"] = row["choice"];
    } else if (task == "likert") {
      row["rating"] = std::to_string(*state_.rating);
      row["response"] = row["rating"];
    } else {
      std::vector<std::string> order;
      for (int i : *state_.order) order.push_back(t["techniques"][i].get<std::string>());
      row["order"] = row["response"] = join(order, "|");
    }
    row["rt_ms"] = std::to_string(static_cast<long long>(std::llround(rt)));
    row["wall_time"] = wall_time();
    std::vector<std::string> values;
    for (const auto& c : log_columns()) values.push_back(row[c]);
    log_.append(values);
    ++answered_now_;
    advance();
  }

  void header(const nlohmann::json& t) {
    const bool practice = t["practice"].get<bool>();
    ImGui::Text("Trial %d of %zu%s", t["trial"].get<int>(), plan_["trials"].size(),
                practice ? "  (practice)" : "");
    ImGui::PushTextWrapPos(ImGui::GetWindowWidth() - 20);
    ImGui::TextWrapped("%s", t["question"].get<std::string>().c_str());
    ImGui::PopTextWrapPos();
  }

  void draw_trial(const nlohmann::json& t, bool submit, float width) {
    header(t);
    const std::string task = t["task"].get<std::string>();
    const int n = t.contains("stimuli") ? static_cast<int>(t["stimuli"].size()) : 1;
    const float w = plan_["size"][0].get<float>(), h = plan_["size"][1].get<float>();
    const float gap = 16.0f;
    const float scale = std::min(1.0f, (width - 32.0f - gap * (n - 1)) / (n * w));
    const ImVec2 size(w * scale, h * scale);
    if (task == "gauge") {
      const ImVec2 origin = ImGui::GetCursorScreenPos();
      ImGui::Image(
          reinterpret_cast<ImTextureID>(static_cast<std::uintptr_t>(texture(t["stimulus"]))), size);
      const ImVec2 c(origin.x + t["pixel"][0].get<float>() * scale,
                     origin.y + t["pixel"][1].get<float>() * scale);
      const float trackball = 60.0f;
      if (ImGui::IsItemHovered() && ImGui::IsMouseDown(ImGuiMouseButton_Left)) {
        const ImVec2 m = ImGui::GetMousePos();
        Vec3 d((m.x - c.x) / trackball, -(m.y - c.y) / trackball, 0.0);
        const double r = d.norm();
        d = r < 1.0 ? Vec3(d.x(), d.y(), std::sqrt(1.0 - r * r)) : Vec3(d / r);
        state_.normal = d;
      }
      draw_gauge(c, state_.normal->normalized(), 18.0f);
      if (ImGui::Button("Next", ImVec2(160, 40)) || submit) commit(t);
    } else if (task == "2afc") {
      for (int i = 0; i < 2; ++i) {
        if (i) ImGui::SameLine(0.0f, gap);
        ImGui::PushID(i);
        const auto tex = texture(t["stimuli"][i]);
        if (ImGui::ImageButton(reinterpret_cast<ImTextureID>(static_cast<std::uintptr_t>(tex)),
                               size, ImVec2(0, 0), ImVec2(1, 1), 2))
          state_.choice = i, submit = true;
        ImGui::PopID();
      }
      ImGui::TextUnformatted("Click a picture to choose it.");
      if (submit && state_.choice) commit(t);
    } else if (task == "likert") {
      ImGui::Image(
          reinterpret_cast<ImTextureID>(static_cast<std::uintptr_t>(texture(t["stimulus"]))), size);
      const int scale_n = t["scale"].get<int>();
      for (int k = 1; k <= scale_n; ++k) {
        if (k > 1) ImGui::SameLine();
        if (ImGui::RadioButton(std::to_string(k).c_str(), state_.rating && *state_.rating == k))
          state_.rating = k;
      }
      ImGui::BeginDisabled(!state_.rating);
      if (ImGui::Button("Next", ImVec2(160, 40)) || (submit && state_.rating)) commit(t);
      ImGui::EndDisabled();
    } else {
      auto& order = *state_.order;
      for (int i = 0; i < n; ++i) {
        if (i) ImGui::SameLine(0.0f, gap);
        ImGui::BeginGroup();
        ImGui::Image(reinterpret_cast<ImTextureID>(
                         static_cast<std::uintptr_t>(texture(t["stimuli"][order[i]]))),
                     size);
        ImGui::PushID(i);
        ImGui::Text("%d.", i + 1);
        ImGui::SameLine();
        if (ImGui::ArrowButton("left", ImGuiDir_Left) && i > 0) std::swap(order[i], order[i - 1]);
        ImGui::SameLine();
        if (ImGui::ArrowButton("right", ImGuiDir_Right) && i + 1 < n)
          std::swap(order[i], order[i + 1]);
        ImGui::PopID();
        ImGui::EndGroup();
      }
      if (ImGui::Button("Next", ImVec2(160, 40)) || submit) commit(t);
    }
  }

  /// The gauge: a disc of radius r perpendicular to the normal (an ellipse
  /// on screen) and a stick along the normal (Koenderink's gauge figure).
  static void draw_gauge(const ImVec2& c, const Vec3& n, float r) {
    ImDrawList* dl = ImGui::GetWindowDrawList();
    const Vec3 a = (std::abs(n.z()) < 0.9 ? Vec3(0, 0, 1) : Vec3(1, 0, 0)).cross(n).normalized();
    const Vec3 b = n.cross(a);
    ImVec2 pts[48];
    for (int i = 0; i < 48; ++i) {
      const double th = 2.0 * 3.14159265358979 * i / 48;
      const Vec3 p = r * (std::cos(th) * a + std::sin(th) * b);
      pts[i] = ImVec2(c.x + static_cast<float>(p.x()), c.y - static_cast<float>(p.y()));
    }
    const ImU32 color = IM_COL32(0, 160, 60, 255);
    dl->AddPolyline(pts, 48, color, ImDrawFlags_Closed, 2.0f);
    dl->AddLine(c,
                ImVec2(c.x + r * 1.2f * static_cast<float>(n.x()),
                       c.y - r * 1.2f * static_cast<float>(n.y())),
                color, 2.5f);
    dl->AddCircleFilled(c, 2.5f, color);
  }

  const RunOptions& opt_;
  const nlohmann::json& plan_;
  ResponseLog& log_;
  std::map<std::string, std::filesystem::path> stimuli_;
  std::map<int, Answer> auto_;
  std::map<std::string, unsigned> textures_;
  std::vector<Step> steps_;
  std::size_t step_ = 0;
  int frames_in_step_ = 0;
  int answered_now_ = 0;
  Clock::time_point shown_at_;
  Answer state_;
};

/// The GLFW window with its GL 3.0 context and Dear ImGui, torn down in
/// reverse order however the session ends (glfwInit done by the caller).
class Window {
 public:
  Window(int w, int h, const std::string& title, bool vsync) {
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 0);
    glfwWindowHint(GLFW_RESIZABLE, GLFW_FALSE);
    window_ = glfwCreateWindow(w, h, title.c_str(), nullptr, nullptr);
    if (!window_) {
      glfwTerminate();
      throw Error(ErrorKind::unavailable,
                  "cannot create an OpenGL 3.0 window (no display or GL driver)");
    }
    glfwMakeContextCurrent(window_);
    render::keep_gl_driver_loaded();
    glfwSwapInterval(vsync ? 1 : 0);
    ImGui::CreateContext();
    ImGui::GetIO().IniFilename = nullptr;
    ImGui::StyleColorsLight();
    ImGui::GetIO().FontGlobalScale = 1.3f;
    ImGui_ImplGlfw_InitForOpenGL(window_, true);
    ImGui_ImplOpenGL3_Init("#version 130");
  }
  ~Window() {
    ImGui_ImplOpenGL3_Shutdown();
    ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
    glfwDestroyWindow(window_);
    glfwTerminate();
  }
  Window(const Window&) = delete;
  Window& operator=(const Window&) = delete;
  GLFWwindow* get() const { return window_; }

 private:
  GLFWwindow* window_ = nullptr;
};

void screenshot(const std::filesystem::path& path, int w, int h) {
  render::Image img(w, h);
  std::vector<std::uint8_t> raw(static_cast<std::size_t>(w) * h * 4);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, raw.data());
  for (int y = 0; y < h; ++y)
    std::copy_n(raw.data() + static_cast<std::size_t>(h - 1 - y) * w * 4, w * 4, img.pixel(0, y));
  for (int i = 0; i < w * h; ++i) img.rgba[static_cast<std::size_t>(i) * 4 + 3] = 255;
  render::write_png(img, path);
}

}  // namespace

int run_session(const RunOptions& o) {
  if (!valid_name(o.participant))
    throw InputError("--participant \"" + o.participant +
                     "\": use 1 to 64 of A-Z a-z 0-9 _ - (e.g. P01)");
  const Study study = read_study(o.study);
  const nlohmann::json plan = make_plan(study, o.participant);
  const auto folder = o.out / "participants" / o.participant;
  std::error_code ec;
  std::filesystem::create_directories(folder, ec);
  if (ec) throw OutputError(folder.string() + ": cannot create the folder: " + ec.message());
  const auto log_path = folder / "responses.csv", plan_path = folder / "plan.json";
  const std::string plan_text = plan.dump(2) + "\n";
  if (std::filesystem::exists(log_path) && !o.resume)
    throw InputError(log_path.string() +
                     ": this participant already has a response log; it is never overwritten. "
                     "Continue the session with --resume, or use another --participant");
  if (std::filesystem::exists(plan_path)) {
    std::ifstream in(plan_path);
    const std::string old((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (old != plan_text)
      throw InputError(plan_path.string() +
                       ": the study's plan for this participant changed since the session began "
                       "(study file edited?); restore the study file or use a new --out folder");
  } else {
    write_file_atomically(plan_path, [&](std::ostream& out) { out << plan_text; });
  }
  std::map<int, Answer> answers;
  if (!o.auto_responses.empty()) answers = read_auto(o.auto_responses, plan);
  std::set<std::string> needed;
  for (const auto& t : plan["trials"]) {
    if (t.contains("stimulus")) needed.insert(t["stimulus"].get<std::string>());
    if (t.contains("stimuli"))
      for (const auto& s : t["stimuli"]) needed.insert(s.get<std::string>());
  }
  // The display first: without one, nothing is drawn and no log is started.
  if (!glfwInit())
    throw Error(ErrorKind::unavailable,
                "cannot open a window (no display?): run on a desktop or under xvfb-run -a");
  auto stimuli = prepare_stimuli(study, needed, o.out, o.stimuli, o.quiet);
  std::size_t most = 1;
  for (const auto& t : plan["trials"])
    if (t.contains("stimuli")) most = std::max(most, t["stimuli"].size());
  const int win_w = std::clamp(static_cast<int>(most) * (study.width + 16) + 48, 720, 1800);
  const int win_h = std::clamp(study.height + 230, 480, 1200);
  Window window(win_w, win_h, "fabrica-study: " + study.name, o.auto_responses.empty());

  ResponseLog log(log_path, o.resume);
  if (log.answered().size() >= plan["trials"].size()) {
    std::fprintf(stderr, "fabrica-study: %s has answered all %zu trials; nothing to do\n",
                 o.participant.c_str(), plan["trials"].size());
    return 0;
  }
  Session session(o, plan, log, std::move(stimuli), std::move(answers));
  std::set<std::string> captured;
  int shot = 0;
  while (!session.done() && !glfwWindowShouldClose(window.get())) {
    if (o.auto_responses.empty())
      glfwWaitEventsTimeout(0.1);
    else
      glfwPollEvents();
    ImGui_ImplOpenGL3_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    int fw = 0, fh = 0;
    glfwGetFramebufferSize(window.get(), &fw, &fh);
    const std::string kind = session.frame(static_cast<float>(fw), static_cast<float>(fh));
    ImGui::Render();
    glViewport(0, 0, fw, fh);
    glClearColor(1, 1, 1, 1);
    glClear(GL_COLOR_BUFFER_BIT);
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    if (!o.screenshots.empty() && captured.insert(kind).second) {
      std::filesystem::create_directories(o.screenshots, ec);
      char name[64];
      std::snprintf(name, sizeof name, "%02d-%s.png", ++shot, kind.c_str());
      screenshot(o.screenshots / name, fw, fh);
    }
    glfwSwapBuffers(window.get());
  }
  if (!o.quiet)
    std::fprintf(
        stderr,
        "fabrica-study: %s: %d trial(s) answered in session %d, %zu of %zu in all -> %s%s\n",
        o.participant.c_str(), session.answered_now(), log.session(), log.answered().size(),
        plan["trials"].size(), log_path.string().c_str(),
        session.done() ? "" : " (window closed: continue with --resume)");
  return 0;
}

}  // namespace fabrica::study
