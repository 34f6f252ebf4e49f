// fabrica-study export-web: a static HTML/JS version of a study (the same
// plans, stimuli and CSV columns as `run`; docs/study.md "On the web").
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace fabrica::study {

/// "N" -> P01..PN (zero-padded to N's width, at least 2), else a
/// comma-separated list of ids (each validated).
std::vector<std::string> participant_list(const std::string& spec);

/// Writes DIR/index.html, study.js, plans.js (one plan per participant)
/// and stimuli/ID.png.
void export_web(const std::filesystem::path& study, const std::filesystem::path& out,
                const std::vector<std::string>& participants, bool quiet);

}  // namespace fabrica::study
