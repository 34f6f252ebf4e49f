# Label volumes (NRRD / seg.nrrd, MetaImage, NIfTI) -> surfaces.
# Headers are parsed here (zlib for gzip/zlib data, pugixml for NIfTI label
# tables); VTK supplies the contouring, smoothing and decimation filters
# (label_volume_extract.cpp, in the module libfabrica_io_vtk.so,
# vtk_module.cmake, only when FABRICA_HAVE_VTK).
target_sources(fabrica_io PRIVATE
  ${CMAKE_CURRENT_SOURCE_DIR}/src/label_volume_read.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/label_volume_nrrd.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/label_volume_metaimage.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/label_volume_nifti.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/label_volume_stats.cpp)
target_link_libraries(fabrica_io PRIVATE ZLIB::ZLIB pugixml::pugixml TBB::tbb)
