# Camera, projection (Projector) and the CPU depth rasteriser shared by lines/
# and hatching/.
target_sources(fabrica_core PRIVATE ${CMAKE_CURRENT_LIST_DIR}/src/camera.cpp
                                    ${CMAKE_CURRENT_LIST_DIR}/src/depth_raster.cpp)
target_link_libraries(fabrica_core PUBLIC nlohmann_json::nlohmann_json)
# The depth raster's AVX2 row kernel (core/src/depth_raster_avx2.cpp): this
# file alone is compiled with -mavx2 (no FMA, -ffp-contract=off; the portable
# file too, so both evaluate the same IEEE operations), and called only when
# the CPU has AVX2 (detail::depth_raster_avx2_enabled()).
set_source_files_properties(${CMAKE_CURRENT_LIST_DIR}/src/depth_raster.cpp
  PROPERTIES COMPILE_OPTIONS -ffp-contract=off)
if(CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang" AND CMAKE_SYSTEM_PROCESSOR MATCHES "x86_64|AMD64"
   AND NOT FABRICA_NO_MULTIVERSION)
  target_sources(fabrica_core PRIVATE ${CMAKE_CURRENT_LIST_DIR}/src/depth_raster_avx2.cpp)
  set_source_files_properties(${CMAKE_CURRENT_LIST_DIR}/src/depth_raster_avx2.cpp
    PROPERTIES COMPILE_OPTIONS "-mavx2;-ffp-contract=off")
  target_compile_definitions(fabrica_core PRIVATE FABRICA_DEPTH_RASTER_AVX2=1)
endif()
