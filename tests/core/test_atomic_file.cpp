#include <gtest/gtest.h>

#include <fstream>

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
