#include "web.hpp"

#include <algorithm>
#include <cstdio>
#include <set>
#include <sstream>

#include "fabrica/core/atomic_file.hpp"
#include "fabrica/core/error.hpp"
#include "plan.hpp"
#include "stimuli.hpp"

namespace fabrica::study {

extern const char* const kWebIndex;
extern const char* const kWebScript;

std::vector<std::string> participant_list(const std::string& spec) {
  std::vector<std::string> ids;
  if (!spec.empty() && std::all_of(spec.begin(), spec.end(), ::isdigit)) {
    const int n = spec.size() > 5 ? 0 : std::stoi(spec);
    if (n < 1 || n > 10000)
      throw InputError("--participants: give a count from 1 to 10000 or a list of ids");
    const int width = std::max<int>(2, static_cast<int>(std::to_string(n).size()));
    for (int i = 1; i <= n; ++i) {
      std::string id = std::to_string(i);
      id.insert(0, static_cast<std::size_t>(width) - std::min<std::size_t>(id.size(), width), '0');
      ids.push_back('P' + id);
    }
    return ids;
  }
  std::stringstream in(spec);
  std::string id;
  std::set<std::string> seen;
  while (std::getline(in, id, ',')) {
    if (!valid_name(id))
      throw InputError("--participants: \"" + id + "\" is not an id of 1 to 64 of A-Z a-z 0-9 _ -");
    if (seen.insert(id).second) ids.push_back(id);
  }
  if (ids.empty()) throw InputError("--participants: no participant given");
  return ids;
}

void export_web(const std::filesystem::path& study_path, const std::filesystem::path& out,
                const std::vector<std::string>& participants, bool quiet) {
  const Study study = read_study(study_path);
  nlohmann::json plans = nlohmann::json::object();
  std::set<std::string> needed;
  for (const auto& id : participants) {
    plans[id] = make_plan(study, id);
    for (const auto& t : plans[id]["trials"]) {
      if (t.contains("stimulus")) needed.insert(t["stimulus"].get<std::string>());
      if (t.contains("stimuli"))
        for (const auto& s : t["stimuli"]) needed.insert(s.get<std::string>());
    }
  }
  prepare_stimuli(study, needed, out, {}, quiet);
  auto text = [&](const char* name, const std::string& content) {
    write_file_atomically(out / name, [&](std::ostream& o) { o << content; });
  };
  text("index.html", kWebIndex);
  text("study.js", kWebScript);
  text("plans.js", "window.FABRICA_PLANS = " + plans.dump(1) + ";\n");
  if (!quiet)
    std::fprintf(stderr, "fabrica-study: web version for %zu participant(s) -> %s/index.html\n",
                 participants.size(), out.string().c_str());
}

}  // namespace fabrica::study
