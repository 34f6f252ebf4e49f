// Small helpers shared by the mesh_io tests.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "fabrica/core/error.hpp"
#include "fabrica/io/mesh_io.hpp"

namespace fabrica::test {

inline void write_bytes(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

inline std::string read_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// Reads `path` expecting an InputError whose message names the file and
/// contains `fragment`; returns the message.
inline std::string expect_input_error(const std::filesystem::path& path,
                                      const std::string& fragment = {}) {
  try {
    (void)io::read_mesh(path);
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find(path.filename().string()), std::string::npos) << message;
    EXPECT_NE(message.find(fragment), std::string::npos)
        << "message '" << message << "' lacks '" << fragment << "'";
    EXPECT_EQ(message.find('\n'), std::string::npos) << "not one line: " << message;
    EXPECT_EQ(e.exit_code(), 2);
    return message;
  } catch (const std::exception& e) {
    ADD_FAILURE() << path << ": expected InputError, got " << e.what();
    return {};
  }
  ADD_FAILURE() << path << ": expected InputError, but the file was read";
  return {};
}

}  // namespace fabrica::test
