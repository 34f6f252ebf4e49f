// One libFuzzer target per reader (fuzz/CMakeLists.txt compiles this file
// once per target with FUZZ_FILE, the file name the input is saved as, and
// FUZZ_READ, the reader called on it). The readers take paths, so every
// input is written to a file in a private folder (under /dev/shm when there
// is one). Bad input must end in fabrica::InputError; any other exception,
// a crash, a leak, undefined behaviour, a hang or an allocation beyond
// libFuzzer's limits is a finding (docs/reliability.md).
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "fabrica/core/error.hpp"

#if FUZZ_KIND_MESH
#include "fabrica/io/mesh_io.hpp"
#define FUZZ_READ(path) (void)fabrica::io::read_mesh(path)
#elif FUZZ_KIND_VOLUME
#include "fabrica/io/label_volume.hpp"
#define FUZZ_READ(path) (void)fabrica::io::read_label_volume(path)
#elif FUZZ_KIND_CAMERA
#include "fabrica/core/camera.hpp"
#define FUZZ_READ(path) (void)fabrica::read_camera(path)
#elif FUZZ_KIND_SCENE
#include "fabrica/render/scene.hpp"
#define FUZZ_READ(path) (void)fabrica::render::read_scene_spec(path)
#endif

namespace {

std::filesystem::path scratch_file() {
  const std::filesystem::path shm = "/dev/shm";
  const auto root =
      std::filesystem::is_directory(shm) ? shm : std::filesystem::temp_directory_path();
  const auto dir = root / ("fabrica-fuzz-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir / FUZZ_FILE;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::filesystem::path file = scratch_file();
  {
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  try {
    FUZZ_READ(file);
  } catch (const fabrica::Error& e) {
    if (e.kind() != fabrica::ErrorKind::input) std::abort();  // only bad input is expected
  }
  return 0;
}
