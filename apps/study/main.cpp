// fabrica-study: runs line-drawing user studies (docs/study.md).
//   plan STUDY.json --participant ID -o PLAN.json
//   stimuli STUDY.json -o DIR                   (draw every stimulus, PNGs by id)
//   run STUDY.json --participant ID --out DIR [--auto RESPONSES.jsonl] [--resume]
//       [--stimuli DIR] [--screenshots DIR]
//   analyze DIR -o REPORT_DIR                   (python3 analysis script)
//   export-web STUDY.json -o DIR [--participants N|ID,ID,...]  (static HTML/JS)
// Exit codes as `fabrica` (docs/cli.md): 0 ok, 1 internal, 2 bad input,
// 3 output not writable, 4 facility unavailable (no display, no python3).
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <functional>

#include "cli_main.hpp"
#include "fabrica/core/atomic_file.hpp"
#include "fabrica/core/error.hpp"
#include "plan.hpp"
#include "run.hpp"
#include "stimuli.hpp"
#include "study.hpp"
#include "web.hpp"

#ifndef FABRICA_STUDY_ANALYZE_SCRIPT
#define FABRICA_STUDY_ANALYZE_SCRIPT ""
#endif

namespace {

using fabrica::Error;
using fabrica::ErrorKind;
using fabrica::InputError;

std::string analysis_script() {
  if (const char* env = std::getenv("FABRICA_STUDY_ANALYZE"); env && *env) return env;
  std::error_code ec;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", ec);
  const auto installed =
      self.parent_path() / ".." / "share" / "fabrica" / "fabrica_study_analyze.py";
  if (!ec && std::filesystem::exists(installed)) return installed.string();
  return FABRICA_STUDY_ANALYZE_SCRIPT;
}

int analyze(const std::string& dir, const std::string& report) {
  const std::string script = analysis_script();
  if (script.empty() || !std::filesystem::exists(script))
    throw Error(ErrorKind::unavailable,
                "the analysis script is missing; set FABRICA_STUDY_ANALYZE");
  // Debian's python3 (numpy, scipy, pandas, statsmodels, matplotlib from scripts/setup).
  const std::string python =
      std::filesystem::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
  std::vector<std::string> argv = {python, script, dir, "-o", report};
  std::vector<char*> args;
  for (auto& a : argv) args.push_back(a.data());
  args.push_back(nullptr);
  std::fflush(nullptr);
  execvp(args[0], args.data());
  throw Error(ErrorKind::unavailable, "cannot run " + python + " (install python3: scripts/setup)");
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"fabrica-study: line-drawing user studies (docs/study.md)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "fabrica-study 0.1.0");
  std::function<int()> action;

  std::string study, participant, output;
  auto* plan = app.add_subcommand("plan", "Write a participant's trial sequence as JSON");
  plan->add_option("study", study, "Study definition (JSON)")->required();
  plan->add_option("--participant", participant, "Participant id ([A-Za-z0-9_-]{1,64})")
      ->required();
  plan->add_option("-o,--output", output, "Output PLAN.json")->required();
  plan->callback([&] {
    action = [&] {
      const auto s = fabrica::study::read_study(study);
      const auto p = fabrica::study::make_plan(s, participant);
      fabrica::write_file_atomically(output, [&](std::ostream& o) { o << p.dump(2) << "\n"; });
      return 0;
    };
  });

  bool quiet = false;
  auto* stim =
      app.add_subcommand("stimuli", "Draw every stimulus of a study (PNG per stimulus id)");
  stim->add_option("study", study, "Study definition (JSON)")->required();
  stim->add_option("-o,--output", output, "Output folder (stimuli/ and cameras/ inside)")
      ->required();
  stim->add_flag("-q,--quiet", quiet, "No progress messages");
  stim->callback([&] {
    action = [&] {
      const auto s = fabrica::study::read_study(study);
      fabrica::study::prepare_stimuli(s, fabrica::study::all_stimuli(s), output, {}, quiet);
      return 0;
    };
  });

  fabrica::study::RunOptions ro;
  std::string auto_file, stimuli_dir, shots;
  auto* run = app.add_subcommand("run", "Run (or --resume) a participant's session in a window");
  run->add_option("study", study, "Study definition (JSON)")->required();
  run->add_option("--participant", ro.participant, "Participant id ([A-Za-z0-9_-]{1,64})")
      ->required();
  run->add_option("--out", output, "Results folder (participants/ID/responses.csv, stimuli/)")
      ->required();
  run->add_option("--auto", auto_file, "Scripted participant: answers as JSON lines by trial");
  run->add_flag("--resume", ro.resume,
                "Continue the participant's session at the next unanswered trial");
  run->add_option("--stimuli", stimuli_dir,
                  "Read stimuli from this folder (STIMULUS_ID.png) instead of drawing");
  run->add_option("--screenshots", shots, "Save one PNG of each kind of screen into this folder");
  run->add_flag("-q,--quiet", ro.quiet, "No messages except errors");
  run->callback([&] {
    action = [&] {
      ro.study = study;
      ro.out = output;
      ro.auto_responses = auto_file;
      ro.stimuli = stimuli_dir;
      ro.screenshots = shots;
      return fabrica::study::run_session(ro);
    };
  });

  std::string dir;
  auto* an =
      app.add_subcommand("analyze", "Analyse every participant's responses: report.json and plots");
  an->add_option("dir", dir, "Results folder of `run --out`")->required();
  an->add_option("-o,--output", output, "Report folder")->required();
  an->callback([&] { action = [&] { return analyze(dir, output); }; });

  std::string participants = "24";
  auto* web = app.add_subcommand("export-web", "Write a static HTML/JS version of the study");
  web->add_option("study", study, "Study definition (JSON)")->required();
  web->add_option("-o,--output", output, "Output folder (index.html, study.js, plans.js, stimuli/)")
      ->required();
  web->add_option("--participants", participants,
                  "Number of participants (P01..PN, default 24) or a comma-separated list of ids");
  web->add_flag("-q,--quiet", quiet, "No progress messages");
  web->callback([&] {
    action = [&] {
      fabrica::study::export_web(study, output, fabrica::study::participant_list(participants),
                                 quiet);
      return 0;
    };
  });

  return fabrica::cli::parse_and_run(app, argc, argv, "fabrica-study",
                                     [&] { return action ? action() : 0; });
}
