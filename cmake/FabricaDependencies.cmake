# Order matters (see docs/DEVELOPING.md): CONFIG packages first, then GL,
# pkg-config, VTK with explicit components, CGAL last.
#
# Required by the libraries: Eigen, TBB and nlohmann_json (core, lines,
# hatching), zlib and pugixml (io: gzip data, GIfTI, NIfTI label tables).
# Everything else is optional, one FABRICA_WITH_<X> option per part
# (docs/library.md): AUTO (the default) turns the part on when its
# dependency is found and else off with one configure message; ON makes a
# missing dependency a configure error; OFF leaves the part out. The result
# is FABRICA_HAVE_<X> (ON/OFF), which the CMakeLists use.

# fabrica_optional(X "what it gives"): declares FABRICA_WITH_X.
macro(fabrica_optional name what)
  set(FABRICA_WITH_${name} AUTO CACHE STRING "${what}: AUTO (on when found), ON or OFF")
  set_property(CACHE FABRICA_WITH_${name} PROPERTY STRINGS AUTO ON OFF)
  set(_fabrica_what_${name} "${what}")
  string(TOUPPER "${FABRICA_WITH_${name}}" _fabrica_with)
  if(NOT _fabrica_with MATCHES "^(AUTO|ON|OFF|TRUE|FALSE|YES|NO|1|0)$")
    message(FATAL_ERROR "FABRICA_WITH_${name}=${FABRICA_WITH_${name}}: use AUTO, ON or OFF")
  endif()
  set(FABRICA_WANT_${name} ON)
  if(_fabrica_with MATCHES "^(OFF|FALSE|NO|0)$")
    set(FABRICA_WANT_${name} OFF)
  endif()
endmacro()

# fabrica_resolve(X FOUND "package hint"): sets FABRICA_HAVE_X from whether
# the dependency was found, with a message when the part is off.
macro(fabrica_resolve name found hint)
  if(NOT FABRICA_WANT_${name})
    set(FABRICA_HAVE_${name} OFF)
    message(STATUS "fabrica: building without ${_fabrica_what_${name}} (FABRICA_WITH_${name}=OFF)")
  elseif(${found})
    set(FABRICA_HAVE_${name} ON)
  elseif(FABRICA_WITH_${name} STREQUAL "AUTO")
    set(FABRICA_HAVE_${name} OFF)
    message(NOTICE "fabrica: ${hint} not found: building without ${_fabrica_what_${name}} "
                   "(install it and reconfigure to have it; -DFABRICA_WITH_${name}=OFF silences this)")
  else()
    message(FATAL_ERROR "fabrica: FABRICA_WITH_${name}=${FABRICA_WITH_${name}} but ${hint} was not found "
                        "(install it, or configure with -DFABRICA_WITH_${name}=OFF to build without "
                        "${_fabrica_what_${name}})")
  endif()
endmacro()

fabrica_optional(RENDER "the GL renderer fabrica::render (PNG output, fabrica render/hatch)")
fabrica_optional(CAIRO "PDF output")
fabrica_optional(VTK ".vtp reading and label-volume extraction (fabrica extract)")
fabrica_optional(CGAL "the self-intersection check (fabrica info --self-intersections)")

find_package(Eigen3 3.3 REQUIRED CONFIG)
find_package(TBB REQUIRED CONFIG)
find_package(nlohmann_json REQUIRED CONFIG)
find_package(pugixml REQUIRED CONFIG)
if(FABRICA_BUILD_APPS)
  find_package(CLI11 REQUIRED CONFIG)
  find_package(fmt QUIET CONFIG)
  find_package(spdlog QUIET CONFIG)
endif()
if(FABRICA_BUILD_TESTS)
  find_package(GTest REQUIRED CONFIG)
  # An independent reader in the mesh I/O tests only.
  find_package(OpenMesh QUIET)
endif()
if(FABRICA_BUILD_BENCH)
  find_package(benchmark REQUIRED CONFIG)
endif()
# Not used by the libraries; found when present for the window/viewer code.
if(FABRICA_WANT_RENDER)
  find_package(glfw3 QUIET CONFIG)
  find_package(glm QUIET CONFIG)
endif()

find_package(PkgConfig QUIET)
if(FABRICA_WANT_RENDER)
  set(OpenGL_GL_PREFERENCE GLVND)
  find_package(OpenGL QUIET COMPONENTS OpenGL EGL GLX)
  set(_fabrica_render_found OFF)
  if(PkgConfig_FOUND AND OpenGL_EGL_FOUND)
    pkg_check_modules(STB QUIET IMPORTED_TARGET stb)
    pkg_check_modules(OSMESA QUIET IMPORTED_TARGET osmesa)
    pkg_check_modules(IMGUI QUIET IMPORTED_TARGET imgui)
    if(STB_FOUND AND OSMESA_FOUND)
      set(_fabrica_render_found ON)
    endif()
  endif()
endif()
fabrica_resolve(RENDER _fabrica_render_found "EGL, OSMesa or stb (libegl-dev libosmesa6-dev libstb-dev)")

if(FABRICA_WANT_CAIRO AND PkgConfig_FOUND)
  pkg_check_modules(CAIRO QUIET IMPORTED_TARGET cairo)
endif()
fabrica_resolve(CAIRO CAIRO_FOUND "cairo (libcairo2-dev)")

find_package(ZLIB REQUIRED)

if(FABRICA_WANT_VTK)
  find_package(VTK QUIET COMPONENTS
    CommonCore CommonDataModel CommonExecutionModel CommonTransforms
    IOGeometry IOPLY IOXML IOLegacy IOImage
    FiltersCore FiltersGeneral FiltersModeling)
endif()
fabrica_resolve(VTK VTK_FOUND "VTK 9 (libvtk9-dev)")

if(FABRICA_WANT_CGAL)
  find_package(CGAL QUIET)
  if(CGAL_FOUND)
    include(CGAL_Eigen3_support)
  endif()
endif()
fabrica_resolve(CGAL CGAL_FOUND "CGAL (libcgal-dev)")
