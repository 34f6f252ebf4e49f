# Mesh file reading and writing (OBJ, PLY, STL, OFF, legacy VTK, GIfTI, MNI
# .obj, FreeSurfer parsed here; VTP read through VTK, in the module
# libfabrica_io_vtk.so (vtk_module.cmake), when FABRICA_HAVE_VTK). GIfTI
# needs pugixml and zlib.
target_sources(fabrica_io PRIVATE
  ${CMAKE_CURRENT_SOURCE_DIR}/src/mesh_io.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/mesh_io_obj.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/mesh_io_off.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/mesh_io_ply.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/mesh_io_stl.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/mesh_io_vtk_legacy.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/mesh_io_gifti.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/inflate.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/mesh_io_mni.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/mesh_io_freesurfer.cpp
)
target_link_libraries(fabrica_io PRIVATE ZLIB::ZLIB pugixml::pugixml)
