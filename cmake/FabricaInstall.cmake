# Installs the libraries as the CMake package `fabrica` (docs/library.md):
#   find_package(fabrica REQUIRED COMPONENTS lines)
#   target_link_libraries(app PRIVATE fabrica::lines)
# Included by the top-level CMakeLists.txt after every library exists.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(FABRICA_INSTALL_CMAKEDIR "${CMAKE_INSTALL_LIBDIR}/cmake/fabrica"
    CACHE STRING "Where fabricaConfig.cmake is installed, relative to the prefix")

# component -> target; the component list is the libraries this build has.
set(FABRICA_COMPONENTS "")
foreach(component core io lines hatching render)
  if(NOT TARGET fabrica_${component})
    continue()
  endif()
  set(target fabrica_${component})
  list(APPEND FABRICA_COMPONENTS ${component})
  # fabrica::<component> in the installed tree as in the build tree; PIC so
  # the static libraries can go into shared modules (the Python module).
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${component} POSITION_INDEPENDENT_CODE ON)
  target_compile_features(${target} PUBLIC cxx_std_20)
  # Include folders under the source or build tree are build-time only; the
  # installed headers are under <prefix>/include. (Wrapping them here keeps the
  # targets' own CMakeLists plain.)
  get_target_property(includes ${target} INTERFACE_INCLUDE_DIRECTORIES)
  if(NOT includes)
    set(includes "")
  endif()
  set(wrapped "")
  foreach(dir IN LISTS includes)
    string(FIND "${dir}" "${PROJECT_SOURCE_DIR}/" in_source)
    string(FIND "${dir}" "${PROJECT_BINARY_DIR}/" in_build)
    if(dir MATCHES "^\\$<" OR NOT (in_source EQUAL 0 OR in_build EQUAL 0))
      list(APPEND wrapped "${dir}")
    else()
      list(APPEND wrapped "$<BUILD_INTERFACE:${dir}>")
    endif()
  endforeach()
  list(APPEND wrapped "$<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>")
  set_target_properties(${target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${wrapped}")
  if(NOT FABRICA_INSTALL)
    continue()
  endif()
  install(TARGETS ${target} EXPORT fabricaTargets
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT fabrica_development
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT fabrica_development
    RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT fabrica_runtime)
  # Every header under the target's include/ folder (new ones too).
  get_target_property(source_dir ${target} SOURCE_DIR)
  install(DIRECTORY ${source_dir}/include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
    COMPONENT fabrica_development FILES_MATCHING PATTERN "*.hpp" PATTERN "*.h")
endforeach()

if(NOT FABRICA_INSTALL)
  return()
endif()

# fabrica_io's VTK parts (core/io/vtk_module.cmake), loaded at run time from
# <libdir>/fabrica by the program and by applications linking fabrica::io:
# in both components.
if(TARGET fabrica_io_vtk)
  foreach(component fabrica_runtime fabrica_development)
    install(TARGETS fabrica_io_vtk LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}/fabrica
      COMPONENT ${component})
  endforeach()
endif()

# The static libraries link fabrica::warnings privately (it carries compile
# options only, which never reach users): it is exported so the link
# interface resolves.
install(TARGETS fabrica_warnings EXPORT fabricaTargets)
set_target_properties(fabrica_warnings PROPERTIES EXPORT_NAME warnings)

install(EXPORT fabricaTargets NAMESPACE fabrica:: DESTINATION ${FABRICA_INSTALL_CMAKEDIR}
  COMPONENT fabrica_development)
# Inside a parent project (add_subdirectory / FetchContent), the build tree
# can be found too.
export(EXPORT fabricaTargets NAMESPACE fabrica:: FILE ${PROJECT_BINARY_DIR}/fabricaTargets.cmake)

configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/fabricaConfig.cmake.in
  ${PROJECT_BINARY_DIR}/fabricaConfig.cmake
  INSTALL_DESTINATION ${FABRICA_INSTALL_CMAKEDIR})
# 0.x: a minor version may change the interface.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/fabricaConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/fabricaConfig.cmake ${PROJECT_BINARY_DIR}/fabricaConfigVersion.cmake
  DESTINATION ${FABRICA_INSTALL_CMAKEDIR} COMPONENT fabrica_development)
