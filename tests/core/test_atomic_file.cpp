#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <string>
#include <vector>

#include "fabrica/core/atomic_file.hpp"
#include "fabrica/core/error.hpp"
#include "test_support.hpp"

using namespace fabrica;

TEST(AtomicFile, FailedWriteLeavesNoFileAndKeepsTheOldOne) {
  const auto dir = test::temp_dir("atomic");
  const auto path = dir / "out.txt";
  write_file_atomically(path, [](std::ostream& o) { o << "first"; });
  EXPECT_THROW(write_file_atomically(path,
                                     [](std::ostream& o) {
                                       o << "partial";
                                       throw std::runtime_error("boom");
                                     }),
               OutputError);
  std::ifstream in(path);
  std::string s;
  in >> s;
  EXPECT_EQ(s, "first");
  std::size_t files = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir)) ++files;
  EXPECT_EQ(files, 1u);  // no temporary left behind
}

TEST(AtomicFile, MissingFolderIsAClearOutputError) {
  try {
    write_file_atomically("/nonexistent-folder-xyz/out.txt", [](std::ostream& o) { o << "x"; });
    FAIL();
  } catch (const OutputError& e) {
    EXPECT_NE(std::string(e.what()).find("does not exist"), std::string::npos);
  }
}

namespace {
std::vector<std::string> names_in(const std::filesystem::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}
}  // namespace

TEST(StagedOutputs, NothingIsRenamedUntilCommitThenEverything) {
  const auto dir = test::temp_dir("staged-commit");
  {
    StagedOutputs staged;
    write_file_atomically(dir / "a.txt", [](std::ostream& o) { o << "a"; });
    write_file_atomically(dir / "b.txt", [](std::ostream& o) { o << "b"; });
    for (const auto& n : names_in(dir)) EXPECT_NE(n.find(".tmp-"), std::string::npos) << n;
    staged.commit();
  }
  EXPECT_EQ(names_in(dir), (std::vector<std::string>{"a.txt", "b.txt"}));
  // After commit, writes go straight to their target again.
  write_file_atomically(dir / "c.txt", [](std::ostream& o) { o << "c"; });
  EXPECT_TRUE(std::filesystem::exists(dir / "c.txt"));
}

TEST(StagedOutputs, AFailedOutputLeavesEveryTargetAsItWas) {
  const auto dir = test::temp_dir("staged-fail");
  write_file_atomically(dir / "a.txt", [](std::ostream& o) { o << "old"; });
  try {
    StagedOutputs staged;
    write_file_atomically(dir / "a.txt", [](std::ostream& o) { o << "new"; });
    write_file_atomically(dir / "missing" / "b.txt", [](std::ostream& o) { o << "b"; });
    staged.commit();
    FAIL() << "the second output should fail";
  } catch (const OutputError&) {
  }
  EXPECT_EQ(names_in(dir), (std::vector<std::string>{"a.txt"}));
  std::ifstream in(dir / "a.txt");
  std::string s;
  in >> s;
  EXPECT_EQ(s, "old");
}

TEST(StagedOutputs, StaleTemporariesOfEndedProcessesAreRemovedOnTheNextWrite) {
  const auto dir = test::temp_dir("stale");
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  ::waitpid(child, nullptr, 0);
  const std::string dead = "out.txt.tmp-" + std::to_string(child) + "-3";
  const std::string mine = "out.txt.tmp-" + std::to_string(::getpid()) + "-99";
  for (const std::string& n :
       {dead, mine, std::string("out.txt.tmp-x-1"), std::string("other.txt.tmp-1-0")})
    std::ofstream(dir / n) << "left over";
  write_file_atomically(dir / "out.txt", [](std::ostream& o) { o << "x"; });
  std::vector<std::string> kept{"other.txt.tmp-1-0", "out.txt", "out.txt.tmp-x-1", mine};
  std::sort(kept.begin(), kept.end());
  EXPECT_EQ(names_in(dir), kept);
}
