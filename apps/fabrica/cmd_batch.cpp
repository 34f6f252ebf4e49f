// `fabrica batch MANIFEST.json [-o DIR] [--jobs N] [--resume] [--dry-run]
//  [--shard I/N|auto [--shard-count N]] [--quiet]` and `fabrica batch merge
// DIR...`: many illustrations from one manifest of inputs x views x styles,
// in parallel worker processes, resumable, shardable over a cluster
// (docs/batch.md). The work is in batch/.
#include <CLI/CLI.hpp>
#include <memory>
#include <string>
#include <vector>

#include "batch/batch.hpp"
#include "commands.hpp"
#include "fabrica/core/error.hpp"

namespace fabrica::cli {

void add_batch_command(CLI::App& app, Action& action) {
  auto o = std::make_shared<batch::Options>();
  auto manifest = std::make_shared<std::string>();
  auto dir = std::make_shared<std::string>();
  CLI::App* cmd = app.add_subcommand(
      "batch",
      "Many illustrations from a JSON manifest (inputs x views x styles), in parallel, "
      "resumable, shardable over Slurm / Kubernetes (docs/batch.md)");
  cmd->add_option("manifest", *manifest, "Manifest JSON (paths in it are relative to it)");
  cmd->add_option("-o,--output", *dir, "Output folder (default: the manifest's folder / out)");
  cmd->add_option("-j,--jobs", o->jobs, "Worker processes (default: every usable core)")
      ->check(CLI::Range(1, 4096));
  cmd->add_flag("--resume", o->resume,
                "Skip items whose outputs exist with the same recorded parameters and input hash");
  cmd->add_flag("--dry-run", o->dry_run, "List the items (as command lines) and do nothing");
  cmd->add_option("--shard", o->shard,
                  "Only items with index = I (mod N): I/N, or auto (SLURM_ARRAY_TASK_ID, "
                  "JOB_COMPLETION_INDEX)");
  cmd->add_option("--shard-count", o->shard_count,
                  "With --shard auto on Kubernetes: the Indexed Job's completions")
      ->check(CLI::Range(1, 1000000));
  cmd->add_flag("-q,--quiet", o->quiet, "No progress or summary (failed items are still reported)");
  cmd->add_option("--worker", o->worker)->group("");  // internal: a worker process W/J

  auto dirs = std::make_shared<std::vector<std::string>>();
  auto merged = std::make_shared<std::string>();
  auto merge_quiet = std::make_shared<bool>(false);
  CLI::App* merge =
      cmd->add_subcommand("merge", "Join the reports of shards (batch-report*.json) into one");
  merge->add_option("dirs", *dirs, "Output folders of the shards")->required();
  merge->add_option("-o,--output", *merged,
                    "Merged report file (default: FIRST_DIR/batch-report.json)");
  merge->add_flag("-q,--quiet", *merge_quiet, "No summary line");
  merge->callback([&action, dirs, merged, merge_quiet] {
    action = [dirs, merged, merge_quiet] {
      return batch::merge_reports({dirs->begin(), dirs->end()}, *merged, *merge_quiet);
    };
  });

  cmd->callback([&action, merge, o, manifest, dir] {
    if (merge->parsed()) return;
    action = [o, manifest, dir] {
      if (manifest->empty())
        throw InputError(
            "batch: give a manifest (fabrica batch MANIFEST.json -o DIR; docs/batch.md)");
      o->manifest = *manifest;
      o->dir = dir->empty() ? o->manifest.parent_path() / "out" : std::filesystem::path(*dir);
      return batch::run_batch(*o);
    };
  });
}

}  // namespace fabrica::cli
