# Order matters (see docs/DEVELOPING.md): CONFIG packages first, then GL,
# pkg-config, VTK with explicit components, CGAL last.
find_package(Eigen3 3.3 REQUIRED CONFIG)
find_package(TBB REQUIRED CONFIG)
find_package(OpenMesh REQUIRED)
find_package(glfw3 REQUIRED CONFIG)
find_package(glm REQUIRED CONFIG)
find_package(CLI11 REQUIRED CONFIG)
find_package(nlohmann_json REQUIRED CONFIG)
find_package(fmt REQUIRED CONFIG)
find_package(spdlog REQUIRED CONFIG)
find_package(pugixml REQUIRED CONFIG)
if(FABRICA_BUILD_TESTS)
  find_package(GTest REQUIRED CONFIG)
endif()
if(FABRICA_BUILD_BENCH)
  find_package(benchmark REQUIRED CONFIG)
endif()

set(OpenGL_GL_PREFERENCE GLVND)
find_package(OpenGL REQUIRED COMPONENTS OpenGL EGL GLX)

find_package(PkgConfig REQUIRED)
pkg_check_modules(IMGUI REQUIRED IMPORTED_TARGET imgui)
pkg_check_modules(STB REQUIRED IMPORTED_TARGET stb)
pkg_check_modules(OSMESA REQUIRED IMPORTED_TARGET osmesa)
pkg_check_modules(CAIRO IMPORTED_TARGET cairo)

find_package(VTK REQUIRED COMPONENTS
  CommonCore CommonDataModel CommonExecutionModel CommonTransforms
  IOGeometry IOPLY IOXML IOLegacy IOImage
  FiltersCore FiltersGeneral FiltersModeling)

find_package(CGAL REQUIRED)
include(CGAL_Eigen3_support)
