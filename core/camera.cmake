# Camera, projection (Projector) and the CPU depth rasteriser shared by lines/
# and hatching/.
target_sources(fabrica_core PRIVATE ${CMAKE_CURRENT_LIST_DIR}/src/camera.cpp
                                    ${CMAKE_CURRENT_LIST_DIR}/src/depth_raster.cpp)
target_link_libraries(fabrica_core PUBLIC nlohmann_json::nlohmann_json)
# The depth raster's AVX2 projection and row kernel
# (core/src/depth_raster_avx2.cpp, called only when
# detail::depth_raster_avx2_enabled()); the portable file is compiled without
# contraction too, so both evaluate the same IEEE operations.
set_source_files_properties(${CMAKE_CURRENT_LIST_DIR}/src/depth_raster.cpp
  PROPERTIES COMPILE_OPTIONS -ffp-contract=off)
fabrica_avx2_source(${CMAKE_CURRENT_LIST_DIR}/src/depth_raster_avx2.cpp FABRICA_DEPTH_RASTER_AVX2)
